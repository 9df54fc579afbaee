//! Exact tessellation of the built-in shapes (docs/scene-format.md) and the primitive
//! transform `M = T * Rz * Ry * Rx * S`.
//!
//! Vertices are shared by index so every shape is a closed, consistently oriented
//! (manifold) mesh, and every triangle is wound counter-clockwise seen from outside.
//! Angles follow docs/scene-format.md: `φ = 2π i / n` runs from +X towards −Z
//! (counter- clockwise seen from +Y), `θ = π j / m` from the north pole (+Y) down.

use glam::{DMat4, DVec3};
use std::f64::consts::PI;

use super::Mesh;

/// Default `segments` of curved shapes.
pub const DEFAULT_SEGMENTS: u32 = 48;

/// Default `rings` for a given `segments`: floor(segments / 2), at least `min`
/// (2 for a sphere, 3 for a torus).
pub fn default_rings(segments: u32, min: u32) -> u32 {
    (segments / 2).max(min)
}

/// `M = T * Rz * Ry * Rx * S` (degrees, right-hand rule), applied to column vectors.
pub fn transform(scale: DVec3, rotate_deg: DVec3, translate: DVec3) -> DMat4 {
    DMat4::from_translation(translate)
        * DMat4::from_rotation_z(rotate_deg.z.to_radians())
        * DMat4::from_rotation_y(rotate_deg.y.to_radians())
        * DMat4::from_rotation_x(rotate_deg.x.to_radians())
        * DMat4::from_scale(scale)
}

/// Applies `m` to every vertex; when `det(m) < 0` (a mirroring scale) the winding
/// of every triangle is reversed so normals stay outward.
pub fn apply_transform(mesh: &Mesh, m: &DMat4) -> Mesh {
    let positions = mesh
        .positions
        .iter()
        .map(|&p| m.transform_point3(p))
        .collect();
    let flip = m.determinant() < 0.0;
    let triangles = mesh
        .triangles
        .iter()
        .map(|&[a, b, c]| if flip { [a, c, b] } else { [a, b, c] })
        .collect();
    Mesh {
        positions,
        triangles,
    }
}

fn phi(i: u32, n: u32) -> f64 {
    2.0 * PI * (i % n) as f64 / n as f64
}

/// Box of full extents `size`, centred at the origin: 8 corners, 12 triangles.
pub fn make_box(size: DVec3) -> Mesh {
    let h = size * 0.5;
    // Corner k has x = +h.x when bit 0 is set, y when bit 1, z when bit 2.
    let positions = (0..8)
        .map(|k| {
            DVec3::new(
                if k & 1 != 0 { h.x } else { -h.x },
                if k & 2 != 0 { h.y } else { -h.y },
                if k & 4 != 0 { h.z } else { -h.z },
            )
        })
        .collect();
    // Each face as a CCW quad seen from outside.
    let quads: [[u32; 4]; 6] = [
        [1, 3, 7, 5], // +X
        [0, 4, 6, 2], // −X
        [2, 6, 7, 3], // +Y
        [0, 1, 5, 4], // −Y
        [4, 5, 7, 6], // +Z
        [0, 2, 3, 1], // −Z
    ];
    let triangles = quads
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    Mesh {
        positions,
        triangles,
    }
}

/// UV sphere: rings `j = 1..m-1` of `n` vertices, plus the poles, fans at the poles.
pub fn make_sphere(r: f64, n: u32, m: u32) -> Mesh {
    let mut positions = Vec::with_capacity((n * (m - 1) + 2) as usize);
    for j in 1..m {
        let th = PI * j as f64 / m as f64;
        for i in 0..n {
            let ph = phi(i, n);
            positions.push(r * DVec3::new(th.sin() * ph.cos(), th.cos(), -th.sin() * ph.sin()));
        }
    }
    let north = positions.len() as u32;
    positions.push(DVec3::new(0.0, r, 0.0));
    let south = north + 1;
    positions.push(DVec3::new(0.0, -r, 0.0));
    let v = |i: u32, j: u32| (j - 1) * n + (i % n);
    let mut triangles = Vec::with_capacity((2 * n * (m - 1)) as usize);
    for i in 0..n {
        triangles.push([north, v(i, 1), v(i + 1, 1)]);
    }
    for j in 1..m - 1 {
        for i in 0..n {
            let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
            triangles.push([a, d, c]);
            triangles.push([a, c, b]);
        }
    }
    for i in 0..n {
        triangles.push([south, v(i + 1, m - 1), v(i, m - 1)]);
    }
    Mesh {
        positions,
        triangles,
    }
}

/// Ring of `n` vertices at height `y`: `(r cos φ, y, −r sin φ)`.
fn ring(positions: &mut Vec<DVec3>, r: f64, y: f64, n: u32) -> u32 {
    let start = positions.len() as u32;
    for i in 0..n {
        let ph = phi(i, n);
        positions.push(DVec3::new(r * ph.cos(), y, -r * ph.sin()));
    }
    start
}

/// Cylinder along +Y centred at the origin: two rings, side quads, cap fans around
/// the cap centres.
pub fn make_cylinder(r: f64, h: f64, n: u32) -> Mesh {
    let mut positions = Vec::with_capacity(2 * n as usize + 2);
    let b = ring(&mut positions, r, -h / 2.0, n);
    let t = ring(&mut positions, r, h / 2.0, n);
    let cb = positions.len() as u32;
    positions.push(DVec3::new(0.0, -h / 2.0, 0.0));
    let ct = cb + 1;
    positions.push(DVec3::new(0.0, h / 2.0, 0.0));
    let mut triangles = Vec::with_capacity(4 * n as usize);
    for i in 0..n {
        let i1 = (i + 1) % n;
        triangles.push([b + i, b + i1, t + i1]);
        triangles.push([b + i, t + i1, t + i]);
        triangles.push([ct, t + i, t + i1]);
        triangles.push([cb, b + i1, b + i]);
    }
    Mesh {
        positions,
        triangles,
    }
}

/// Cone along +Y: base ring at `y = −h/2`, apex `(0, h/2, 0)`, side fan to the apex,
/// base fan around `(0, −h/2, 0)`.
pub fn make_cone(r: f64, h: f64, n: u32) -> Mesh {
    let mut positions = Vec::with_capacity(n as usize + 2);
    let b = ring(&mut positions, r, -h / 2.0, n);
    let cb = positions.len() as u32;
    positions.push(DVec3::new(0.0, -h / 2.0, 0.0));
    let apex = cb + 1;
    positions.push(DVec3::new(0.0, h / 2.0, 0.0));
    let mut triangles = Vec::with_capacity(2 * n as usize);
    for i in 0..n {
        let i1 = (i + 1) % n;
        triangles.push([b + i, b + i1, apex]);
        triangles.push([cb, b + i1, b + i]);
    }
    Mesh {
        positions,
        triangles,
    }
}

/// Torus around Y: vertex `(i, j)` at `((R + r cos ψ) cos φ, r sin ψ, −(R + r cos ψ) sin φ)`.
pub fn make_torus(big_r: f64, r: f64, n: u32, m: u32) -> Mesh {
    let mut positions = Vec::with_capacity((n * m) as usize);
    for i in 0..n {
        let ph = phi(i, n);
        for j in 0..m {
            let ps = 2.0 * PI * j as f64 / m as f64;
            let w = big_r + r * ps.cos();
            positions.push(DVec3::new(w * ph.cos(), r * ps.sin(), -w * ph.sin()));
        }
    }
    let v = |i: u32, j: u32| (i % n) * m + (j % m);
    let mut triangles = Vec::with_capacity((2 * n * m) as usize);
    for i in 0..n {
        for j in 0..m {
            let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    Mesh {
        positions,
        triangles,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::validate::{check_closed, signed_volume};

    fn check_outward_convex(m: &Mesh) {
        // For a convex shape centred at the origin every face normal points away
        // from the origin.
        for t in &m.triangles {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let nrm = (b - a).cross(c - a);
            assert!(nrm.length() > 0.0, "degenerate triangle {t:?}");
            assert!(nrm.dot((a + b + c) / 3.0) > 0.0, "inward triangle {t:?}");
        }
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs()
    }

    #[test]
    fn box_is_closed_outward_exact() {
        let m = make_box(DVec3::new(2.0, 1.0, 3.0));
        assert_eq!((m.positions.len(), m.triangles.len()), (8, 12));
        check_closed(&m).unwrap();
        check_outward_convex(&m);
        assert!((signed_volume(&m) - 6.0).abs() < 1e-12);
        assert!(m.positions.contains(&DVec3::new(1.0, -0.5, 1.5)));
    }

    #[test]
    fn sphere_is_closed_outward_exact() {
        for (n, mm) in [(3, 2), (48, 24), (7, 5)] {
            let m = make_sphere(2.0, n, mm);
            assert_eq!(m.positions.len() as u32, n * (mm - 1) + 2);
            assert_eq!(m.triangles.len() as u32, 2 * n * (mm - 1));
            check_closed(&m).unwrap();
            check_outward_convex(&m);
            assert!(signed_volume(&m) > 0.0);
        }
        let m = make_sphere(2.0, 48, 24);
        assert!(rel(signed_volume(&m), 4.0 / 3.0 * PI * 8.0) < 0.02);
        // vertex (i=12, j=6): θ = π/4, φ = π/2 → r (sin θ · 0, cos θ, −sin θ)
        let p = m.positions[(5 * 48 + 12) as usize];
        let s = (PI / 4.0).sin() * 2.0;
        assert!((p - DVec3::new(0.0, s, -s)).length() < 1e-12, "{p}");
    }

    #[test]
    fn cylinder_and_cone_are_closed_outward_exact() {
        let c = make_cylinder(0.5, 2.0, 48);
        check_closed(&c).unwrap();
        check_outward_convex(&c);
        assert!(rel(signed_volume(&c), PI * 0.25 * 2.0) < 0.01);
        // vertex i = 12 of the top ring: φ = π/2 → (0, h/2, −r)
        assert!((c.positions[48 + 12] - DVec3::new(0.0, 1.0, -0.5)).length() < 1e-12);
        let k = make_cone(1.0, 3.0, 48);
        check_closed(&k).unwrap();
        check_outward_convex(&k);
        assert!(rel(signed_volume(&k), PI * 3.0 / 3.0) < 0.01);
        assert!(k.positions.contains(&DVec3::new(0.0, 1.5, 0.0)));
        let k3 = make_cone(1.0, 1.0, 3);
        check_closed(&k3).unwrap();
    }

    #[test]
    fn torus_is_closed_outward_exact() {
        let t = make_torus(2.0, 0.5, 48, 24);
        check_closed(&t).unwrap();
        assert!(rel(signed_volume(&t), 2.0 * PI * PI * 2.0 * 0.25) < 0.02);
        // (i=0, j=6): ψ = π/2 → (R, r, 0)
        assert!((t.positions[6] - DVec3::new(2.0, 0.5, 0.0)).length() < 1e-12);
        // every face normal points away from the tube's centre circle
        for tri in &t.triangles {
            let [a, b, c] = tri.map(|i| t.positions[i as usize]);
            let g = (a + b + c) / 3.0;
            let axis = DVec3::new(g.x, 0.0, g.z).normalize() * 2.0;
            assert!((b - a).cross(c - a).dot(g - axis) > 0.0);
        }
        check_closed(&make_torus(1.0, 0.3, 3, 3)).unwrap();
    }

    #[test]
    fn transform_order_and_mirror() {
        // scale, then rotate X, Y, Z, then translate.
        let m = transform(
            DVec3::new(2.0, 1.0, 1.0),
            DVec3::new(0.0, 90.0, 0.0),
            DVec3::new(0.0, 0.0, 5.0),
        );
        let p = m.transform_point3(DVec3::X);
        // (2,0,0) rotated +90° about Y → (0,0,−2), then +5 in z.
        assert!((p - DVec3::new(0.0, 0.0, 3.0)).length() < 1e-12, "{p}");
        let mirror = transform(DVec3::new(-1.0, 1.0, 1.0), DVec3::ZERO, DVec3::ZERO);
        let s = apply_transform(&make_sphere(1.0, 12, 6), &mirror);
        check_closed(&s).unwrap();
        assert!(signed_volume(&s) > 0.0);
        // Rx then Ry: order matters
        let r = transform(DVec3::ONE, DVec3::new(90.0, 90.0, 0.0), DVec3::ZERO);
        // Rx(90) maps Y → Z; Ry(90) maps Z → X.
        assert!((r.transform_point3(DVec3::Y) - DVec3::X).length() < 1e-12);
    }
}
