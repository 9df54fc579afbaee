//! Convexity of a closed mesh, tolerant of the f32 rounding of its input.
//!
//! CST (Hable & Rossignac §4, convex leaves) and layered Goldfeather stop peeling a
//! primitive known to be convex after one or two layers, so a false "convex" is
//! a wrong image while a false "not convex" only costs layers. Meshes of scene
//! files are tessellated in f64, but an embedding host hands its meshes over as
//! f32 ([`crate::embed::MeshInput`]), so vertices of an exactly convex solid lie
//! up to half an f32 ulp per coordinate off it, and the faces' planes tilt by the
//! same amount over the face's size. The test below accepts exactly what that
//! rounding can explain (a first-order bound, see [`face_tolerance`]) and no
//! more.

use glam::DVec3;

use crate::geom::bounds;
use crate::scene::Mesh;

/// Unit roundoff of f32: a coordinate `c` given as f32 is within `U32 · |c|` of
/// its exact value.
pub const U32: f64 = f32::EPSILON as f64 * 0.5;

/// Floor of every tolerance, relative to the mesh's diagonal: what f64
/// tessellation and the plane arithmetic below round to.
const F64_REL: f64 = 1e-9;

/// Whether a closed, outward-oriented mesh bounds a convex set: every vertex lies
/// on or behind the plane of every (non-degenerate) face, up to the tolerance of
/// `face_tolerance` (f32 rounding of the input coordinates, and at least 1e-9 of
/// the mesh's diagonal). Meshes with more than 4·10⁶ vertex-face pairs are
/// reported as not convex rather than tested (the test is quadratic).
pub fn is_convex(mesh: &Mesh) -> bool {
    let (p, t) = (&mesh.positions, &mesh.triangles);
    if t.len() < 4 || p.len().saturating_mul(t.len()) > 4_000_000 {
        return false;
    }
    let b = bounds(p);
    let size = (b.max - b.min).length();
    let delta = vertex_rounding(p);
    let mut planes: Vec<(DVec3, f64, f64)> = Vec::with_capacity(t.len());
    for &[a, bb, c] in t {
        let (a, bb, c) = (p[a as usize], p[bb as usize], p[c as usize]);
        let n = (bb - a).cross(c - a);
        let len = n.length();
        if len <= 1e-12 * size * size {
            continue;
        }
        let tol = face_tolerance([a, bb, c], len, delta, size);
        let n = n / len;
        let d = n.dot(a);
        // Coplanar faces (same plane within the tighter tolerance) test once.
        if planes
            .iter()
            .any(|&(m, e, t)| m.dot(n) > 1.0 - 1e-12 && (e - d).abs() <= tol.min(t))
        {
            continue;
        }
        planes.push((n, d, tol));
    }
    !planes.is_empty()
        && planes
            .iter()
            .all(|&(n, d, tol)| p.iter().all(|&v| n.dot(v) - d <= tol))
}

/// The most a vertex of `p` can be off its exact position when its coordinates
/// were rounded to f32: `√3 · U32 · max |coordinate|`.
pub fn vertex_rounding(p: &[DVec3]) -> f64 {
    let m = p.iter().map(|v| v.abs().max_element()).fold(0.0, f64::max);
    3f64.sqrt() * U32 * m
}

/// How far beyond the plane of face `f` (its cross product's length `len`) a
/// vertex of an exactly convex mesh may appear once every vertex moved by up to
/// `delta`, in a mesh of diagonal `size`.
///
/// The vertex and the face's base point move by `delta` each (`2·delta`). The
/// normal `n ∝ e1 × e2` tilts: each edge moves by up to `2·delta`, so the cross
/// product changes by at most `2·delta·(|e1| + |e2|)` (first order), and the unit
/// normal by at most that over `len` (radians). A vertex up to `size` from the
/// base point then moves off the plane by the tilt times `size`. The sum is
/// doubled for the second-order terms and the f64 arithmetic of the test, and
/// floored at 1e-9 of `size` (f64 input).
pub fn face_tolerance(f: [DVec3; 3], len: f64, delta: f64, size: f64) -> f64 {
    let (e1, e2) = ((f[1] - f[0]).length(), (f[2] - f[0]).length());
    let tilt = 2.0 * delta * (e1 + e2) / len;
    (2.0 * (2.0 * delta + tilt * size)).max(F64_REL * size)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::fixtures::{box_mesh, sphere_mesh};

    /// The mesh as an f32 host would hand it over.
    fn rounded(m: &Mesh) -> Mesh {
        Mesh {
            positions: m.positions.iter().map(|v| v.as_vec3().as_dvec3()).collect(),
            triangles: m.triangles.clone(),
        }
    }

    /// Vertex `i` pushed towards `center` by `depth` (a dent).
    fn dented(m: &Mesh, i: usize, center: DVec3, depth: f64) -> Mesh {
        let mut m = m.clone();
        let v = m.positions[i];
        m.positions[i] = v - (v - center).normalize() * depth;
        m
    }

    #[test]
    fn f32_rounded_spheres_and_boxes_are_convex() {
        for (center, r, seg, rings) in [
            (DVec3::new(0.6, 0.7, 0.6), 0.45, 32, 16),
            (DVec3::new(103.7, -41.3, 12.9), 0.8, 40, 20),
            (DVec3::new(-2.0, 5.0, 1e3), 3.0, 48, 24),
        ] {
            let s = sphere_mesh(center, r, seg, rings);
            assert!(is_convex(&s));
            let f = rounded(&s);
            // The f32 input is really off the exact sphere's planes by more than
            // the f64 floor alone (so this test needs the rounding bound).
            let strict = f.triangles.iter().any(|t| {
                let [a, b, c] = t.map(|i| f.positions[i as usize]);
                let n = (b - a).cross(c - a).normalize();
                f.positions
                    .iter()
                    .any(|&v| n.dot(v - a) > F64_REL * 2.0 * r)
            });
            assert!(strict, "{center} {r}: rounding stayed within 1e-9");
            assert!(is_convex(&f), "{center} r={r} {seg}x{rings}");
        }
        let b = box_mesh(DVec3::new(10.1, 20.3, -5.7), DVec3::new(10.9, 21.7, -4.1));
        assert!(is_convex(&rounded(&b)));
    }

    #[test]
    fn dents_well_above_the_rounding_bound_are_not_convex() {
        // A vertex on the equator pushed in, well past the bound: near the
        // origin (bound about 2e-5 here) by 1e-3 of the radius; 130 units away
        // (f32 steps of 8e-6, the bound about 2e-3: the faces' planes are that
        // uncertain over the sphere's diameter) by 1e-2.
        for (center, r, depth) in [
            (DVec3::new(0.6, 0.7, 0.6), 0.45, 0.45e-3),
            (DVec3::new(103.7, -41.3, 12.9), 0.8, 0.8e-2),
        ] {
            let s = sphere_mesh(center, r, 40, 20);
            assert!(is_convex(&rounded(&s)));
            let i = 1 + 9 * 40 + 7;
            assert!(
                !is_convex(&rounded(&dented(&s, i, center, depth))),
                "{center}"
            );
            assert!(!is_convex(&dented(&s, i, center, depth)), "{center}");
        }
        // And an L-shaped union of two boxes rounded to f32.
        let mut l = box_mesh(DVec3::ZERO, DVec3::ONE);
        let other = box_mesh(DVec3::new(1.0, 0.0, 0.0), DVec3::new(2.0, 3.0, 1.0));
        let off = l.positions.len() as u32;
        l.positions.extend(other.positions);
        l.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + off)));
        assert!(!is_convex(&rounded(&l)));
    }

    #[test]
    fn the_bound_grows_with_the_coordinates_and_thin_faces() {
        let f = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let near = face_tolerance(f, 1.0, vertex_rounding(&f), 2.0);
        let far_pts = f.map(|v| v + DVec3::splat(1000.0));
        let far = face_tolerance(far_pts, 1.0, vertex_rounding(&far_pts), 2.0);
        assert!(far > 100.0 * near);
        // A sliver (same edges, a hundredth of the area) tilts 100 times more.
        let d = vertex_rounding(&far_pts);
        let sliver = face_tolerance(far_pts, 0.01, d, 2.0);
        assert!(sliver > 50.0 * far);
    }
}
