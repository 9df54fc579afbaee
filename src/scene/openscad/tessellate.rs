//! OpenSCAD 2021.01's tessellation of `cube`, `sphere`, `cylinder` and
//! `polyhedron` (its `primitives.cc`), as closed CCW-outward meshes (the scene
//! format's winding), so a `.csg` file gives the same facets as OpenSCAD's preview
//! and CGAL render.
//!
//! - Fragments: `get_fragments_from_r` (below), `$fa`/`$fs` clamped to 0.01.
//! - Circles: point `i` at angle `360 i / n` degrees from +X towards +Y, with
//!   OpenSCAD's `sin_degrees`/`cos_degrees` (exact at multiples of 30°/45°).
//! - Sphere: `(n + 1) / 2` rings at `phi = 180 (i + 0.5) / rings`, ring radius
//!   `r sin(phi)` at `z = r cos(phi)`; the first and last rings are closed by flat
//!   caps (no pole vertices).
//! - Cylinder: `r1` at `z1`, `r2` at `z2` (`0, h`, or `±h/2` centred), fragments
//!   from the larger radius, one apex vertex where a radius is 0.
//! - Polyhedron: OpenSCAD lists faces clockwise seen from outside; each face is
//!   triangulated in its plane (ear clipping by `earcutr`, so concave faces stay
//!   inside their outline, as OpenSCAD's own tessellator keeps them; a fan from
//!   the first point where that fails) and reversed to our CCW.
//!
//! Degenerate sizes (a radius, height or extent ≤ 0) give `None`: OpenSCAD makes
//! an empty object of them, which the converter treats as the empty set.

use glam::DVec3;

use super::super::Mesh;

/// OpenSCAD's `GRID_FINE`: radii below it get 3 fragments.
const GRID_FINE: f64 = 0.000_000_953_674_316_406_25;
/// OpenSCAD's `F_MINIMUM`: smaller `$fa`/`$fs` are clamped to it.
pub const F_MINIMUM: f64 = 0.01;

/// `$fn`, `$fa`, `$fs` of a node (OpenSCAD's defaults 0, 12, 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Resolution {
    pub fn_: f64,
    pub fa: f64,
    pub fs: f64,
}

impl Default for Resolution {
    fn default() -> Self {
        Resolution {
            fn_: 0.0,
            fa: 12.0,
            fs: 2.0,
        }
    }
}

/// `Calc::get_fragments_from_r`: `fn > 0 ? max(fn, 3) : ceil(max(min(360/fa,
/// r 2π/fs), 5))`, `fn` truncated to an integer. `fa`/`fs` must be clamped.
pub fn fragments(r: f64, res: Resolution) -> u64 {
    if r < GRID_FINE || !res.fn_.is_finite() {
        return 3;
    }
    if res.fn_ > 0.0 {
        return if res.fn_ >= 3.0 { res.fn_ as u64 } else { 3 };
    }
    (360.0 / res.fa)
        .min(r * 2.0 * std::f64::consts::PI / res.fs)
        .max(5.0)
        .ceil() as u64
}

/// OpenSCAD's `sin_degrees`: exact for multiples of 30° and 45°.
pub fn sin_degrees(x: f64) -> f64 {
    let mut x = x % 360.0;
    if x < 0.0 {
        x += 360.0;
    }
    let oppose = x >= 180.0;
    if oppose {
        x -= 180.0;
    }
    if x > 90.0 {
        x = 180.0 - x;
    }
    let s = if x == 0.0 {
        0.0
    } else if x == 30.0 {
        0.5
    } else if x == 45.0 {
        std::f64::consts::FRAC_1_SQRT_2
    } else if x == 60.0 {
        0.75f64.sqrt()
    } else if x == 90.0 {
        1.0
    } else {
        x.to_radians().sin()
    };
    if oppose {
        -s
    } else {
        s
    }
}

/// OpenSCAD's `cos_degrees`.
pub fn cos_degrees(x: f64) -> f64 {
    sin_degrees(x + 90.0)
}

/// `generate_circle`: `n` points of radius `r` at `z`, point `i` at `360 i / n`°.
fn circle(r: f64, n: u64, z: f64) -> impl Iterator<Item = DVec3> {
    (0..n).map(move |i| {
        let phi = 360.0 * i as f64 / n as f64;
        DVec3::new(r * cos_degrees(phi), r * sin_degrees(phi), z)
    })
}

/// Fan of the polygon `ring` (CCW seen from where the normal points).
fn fan(out: &mut Vec<[u32; 3]>, ring: impl Iterator<Item = u32>) {
    let ring: Vec<u32> = ring.collect();
    for k in 1..ring.len().saturating_sub(1) {
        out.push([ring[0], ring[k], ring[k + 1]]);
    }
}

/// `cube(size, center)`.
pub fn cube(size: DVec3, center: bool) -> Option<Mesh> {
    if size.min_element() <= 0.0 {
        return None;
    }
    let mut m = super::super::shapes::make_box(size);
    if !center {
        for p in &mut m.positions {
            *p += size * 0.5;
        }
    }
    Some(m)
}

/// `sphere(r)` with `n` fragments and `(n + 1) / 2` rings.
pub fn sphere(r: f64, n: u64) -> Option<Mesh> {
    if r <= 0.0 {
        return None;
    }
    let rings = n.div_ceil(2);
    let mut positions = Vec::with_capacity((rings * n) as usize);
    for i in 0..rings {
        let phi = 180.0 * (i as f64 + 0.5) / rings as f64;
        positions.extend(circle(r * sin_degrees(phi), n, r * cos_degrees(phi)));
    }
    let n32 = n as u32;
    let at = |ring: u64, i: u32| ring as u32 * n32 + i % n32;
    let mut triangles = Vec::with_capacity((2 * rings * n) as usize);
    // Top cap (normal +z): the first ring, CCW seen from above.
    fan(&mut triangles, (0..n32).map(|i| at(0, i)));
    for k in 0..rings - 1 {
        for i in 0..n32 {
            let (a, b) = (at(k, i), at(k, i + 1));
            let (c, d) = (at(k + 1, i + 1), at(k + 1, i));
            triangles.push([a, d, c]);
            triangles.push([a, c, b]);
        }
    }
    // Bottom cap (normal −z): the last ring reversed.
    fan(&mut triangles, (0..n32).rev().map(|i| at(rings - 1, i)));
    Some(Mesh {
        positions,
        triangles,
    })
}

/// `cylinder(h, r1, r2, center)` with `n` fragments.
pub fn cylinder(h: f64, r1: f64, r2: f64, center: bool, n: u64) -> Option<Mesh> {
    if h <= 0.0 || r1 < 0.0 || r2 < 0.0 || (r1 <= 0.0 && r2 <= 0.0) {
        return None;
    }
    let (z1, z2) = if center {
        (-h / 2.0, h / 2.0)
    } else {
        (0.0, h)
    };
    let n32 = n as u32;
    let mut positions = Vec::with_capacity(2 * n as usize);
    // Ring (or apex) at each end: `first` is its first vertex; an apex is one vertex.
    let mut ring = |r: f64, z: f64| -> (u32, bool) {
        let first = positions.len() as u32;
        if r > 0.0 {
            positions.extend(circle(r, n, z));
            (first, false)
        } else {
            positions.push(DVec3::new(0.0, 0.0, z));
            (first, true)
        }
    };
    let (b0, b_apex) = ring(r1, z1);
    let (t0, t_apex) = ring(r2, z2);
    let bottom = |i: u32| if b_apex { b0 } else { b0 + i % n32 };
    let top = |i: u32| if t_apex { t0 } else { t0 + i % n32 };
    let mut triangles = Vec::with_capacity(4 * n as usize);
    for i in 0..n32 {
        // The side quad bottom(i), bottom(i+1), top(i+1), top(i), CCW from outside.
        if !b_apex {
            triangles.push([bottom(i), bottom(i + 1), top(i + 1)]);
        }
        if !t_apex {
            triangles.push([bottom(i), top(i + 1), top(i)]);
        }
    }
    if !b_apex {
        fan(&mut triangles, (0..n32).rev().map(bottom));
    }
    if !t_apex {
        fan(&mut triangles, (0..n32).map(top));
    }
    Some(Mesh {
        positions,
        triangles,
    })
}

/// `polyhedron(points, faces)`: faces clockwise seen from outside (OpenSCAD),
/// fan-triangulated and reversed to CCW. Face indices must be in range (checked
/// by the caller). `None` without faces.
pub fn polyhedron(points: Vec<DVec3>, faces: &[Vec<u32>]) -> Option<Mesh> {
    let mut triangles = Vec::new();
    for f in faces {
        if f.len() > 3 {
            if let Some(tris) = ear_clip(&points, f) {
                triangles.extend(tris);
                continue;
            }
        }
        for k in 1..f.len().saturating_sub(1) {
            triangles.push([f[0], f[k + 1], f[k]]);
        }
    }
    if triangles.is_empty() {
        return None;
    }
    Some(Mesh {
        positions: points,
        triangles,
    })
}

/// Ear-clipped triangles of face `f` (OpenSCAD's clockwise order), projected
/// on the plane its Newell normal is most aligned with, reversed to CCW.
/// `None` for a face with no area or that earcut cannot triangulate fully.
fn ear_clip(points: &[DVec3], f: &[u32]) -> Option<Vec<[u32; 3]>> {
    let p = |i: usize| points[f[i] as usize];
    let n = (0..f.len()).fold(DVec3::ZERO, |n, i| n + p(i).cross(p((i + 1) % f.len())));
    let a = n.abs();
    let (u, v) = if a.z >= a.x && a.z >= a.y {
        (0, 1)
    } else if a.x >= a.y {
        (1, 2)
    } else {
        (2, 0)
    };
    let flat: Vec<f64> = (0..f.len()).flat_map(|i| [p(i)[u], p(i)[v]]).collect();
    let q = |i: usize| glam::DVec2::new(flat[2 * i], flat[2 * i + 1]);
    let area: f64 = (0..f.len())
        .map(|i| q(i).perp_dot(q((i + 1) % f.len())))
        .sum();
    if !(area.abs() > 0.0) {
        return None;
    }
    let tri = earcutr::earcut(&flat, &[], 2).ok()?;
    if tri.len() / 3 != f.len() - 2 {
        return None;
    }
    Some(
        tri.chunks(3)
            .map(|t| {
                let s = (q(t[1]) - q(t[0])).perp_dot(q(t[2]) - q(t[0]));
                // Same turn as the face's own order, then reversed to CCW.
                let (a, b, c) = if (s > 0.0) == (area > 0.0) {
                    (t[0], t[1], t[2])
                } else {
                    (t[0], t[2], t[1])
                };
                [f[a], f[c], f[b]]
            })
            .collect(),
    )
}
