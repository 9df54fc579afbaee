//! Convex hulls and Minkowski sums of convex sets, as closed CCW-outward meshes.
//!
//! - The hull is `chull`'s quickhull (Barber, Dobkin and Huhdanpaa, "The
//!   Quickhull Algorithm for Convex Hulls", ACM TOMS 22(4), 1996) run on
//!   `BigInt` coordinates (its `ConvexHullWrapper`): every `f64` is scaled by
//!   2⁵² and truncated, so the orientation tests are exact for any coordinate
//!   above 2⁻⁵² and coplanar, collinear or repeated points cannot make it
//!   inconsistent. Large point sets (Minkowski sums, fine cylinders) first go
//!   through `chull`'s floating-point quickhull (points within 10⁻¹² of the
//!   extent inside a facet may be dropped); its hull stands when it is closed
//!   and outward, and otherwise its vertices go to the exact pass. Points with no volume between them (fewer than four, all
//!   collinear or coplanar) have no 3D hull: `None`, which OpenSCAD also turns
//!   into an empty object.
//! - The Minkowski sum of two convex polytopes is the hull of all pairwise sums
//!   of their vertices (de Berg et al., "Computational Geometry", 3rd ed.,
//!   §13.3); a union of convex parts sums part by part, which is how OpenSCAD
//!   2021.01 sums decomposed solids (`applyMinkowski`: the hull of every pair
//!   of convex parts, then their union).

use glam::DVec3;

use super::super::Mesh;
use crate::scene::validate::{check_closed, signed_volume};

/// Points above this many are refused before the hull runs. Where every
/// point is a vertex of the hull (two fine cylinders), the floating-point pass
/// takes about 80 µs a point: 1.3 s for this many. A cube ⊕ a sphere of
/// `$fn = 60` is 14 400 points.
pub const MAX_HULL_POINTS: usize = 16_000;

/// Above this many points, a floating-point quickhull first keeps the
/// candidates for the exact one (about 20 µs a point).
const PREFILTER: usize = 2_000;

/// The convex hull of `points` (finite), or `None` when they enclose no volume.
pub fn convex_hull(points: &[DVec3]) -> Option<Mesh> {
    let mut pts: Vec<[u64; 3]> = points
        .iter()
        .filter(|p| p.is_finite())
        .map(|p| p.to_array().map(f64::to_bits))
        .collect();
    // Repeated points cost the exact arithmetic time and add nothing.
    pts.sort_unstable();
    pts.dedup();
    if pts.len() < 4 {
        return None;
    }
    // `chull`'s integers are the coordinates times 2⁵²: above 2⁹⁰⁰ they would
    // overflow `f64` first, so such sets are scaled by a power of two (exact)
    // and scaled back.
    let max = pts
        .iter()
        .flatten()
        .fold(0.0f64, |m, &b| m.max(f64::from_bits(b).abs()));
    let shift = if max > 2f64.powi(900) {
        max.log2().ceil() as i32 - 900
    } else {
        0
    };
    let down = 2f64.powi(-shift);
    let mut input: Vec<Vec<f64>> = pts
        .iter()
        .map(|p| p.map(|b| f64::from_bits(b) * down).to_vec())
        .collect();
    let up = 2f64.powi(shift);
    if input.len() > PREFILTER {
        // Points within 1e-12 of the extent from a facet are dropped here;
        // they move the hull by no more than that. Where this hull is closed
        // and outward it is the answer (the exact pass on thousands of
        // vertices takes seconds); otherwise its vertices, or all the points
        // if it failed, go to the exact hull.
        let extent = input.iter().flatten().fold(0.0f64, |m, &c| m.max(c.abs()));
        if let Ok(h) = chull::ConvexHull::<f64>::try_new(&input, extent * 1e-12, None) {
            let (v, idx) = h.vertices_indices();
            if let Some(mesh) = outward_mesh(&v, &idx, up) {
                return Some(mesh);
            }
            if v.len() >= 4 {
                input = v;
            }
        }
    }
    let hull = chull::ConvexHullWrapper::try_new(&input, None).ok()?;
    let (verts, idx) = hull.vertices_indices();
    outward_mesh(&verts, &idx, up)
}

/// A hull's vertices (scaled by `up`) and triangles as a closed outward mesh;
/// `None` when they are not one (a check keeps a library surprise from
/// reaching the renderer as a wrong picture).
fn outward_mesh(verts: &[Vec<f64>], idx: &[usize], up: f64) -> Option<Mesh> {
    if verts.len() < 4 {
        return None;
    }
    let positions: Vec<DVec3> = verts
        .iter()
        .map(|v| DVec3::new(v[0], v[1], v[2]) * up)
        .collect();
    let centre = positions.iter().copied().sum::<DVec3>() / positions.len() as f64;
    let triangles: Vec<[u32; 3]> = idx
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [t[0] as u32, t[1] as u32, t[2] as u32];
            let [pa, pb, pc] = [a, b, c].map(|i| positions[i as usize]);
            if (pb - pa).cross(pc - pa).dot(pa - centre) >= 0.0 {
                [a, b, c]
            } else {
                [a, c, b]
            }
        })
        .collect();
    let mesh = Mesh {
        positions,
        triangles,
    };
    (check_closed(&mesh).is_ok() && signed_volume(&mesh) > 0.0).then_some(mesh)
}

/// Whether the closed outward mesh is convex: its volume equals its hull's
/// (relative 1e-9).
pub fn is_convex(mesh: &Mesh) -> bool {
    let Some(h) = convex_hull(&mesh.positions) else {
        return false;
    };
    let (vh, vm) = (signed_volume(&h), signed_volume(mesh));
    (vh - vm).abs() <= 1e-9 * vh.abs()
}

/// The hull of all sums `a + b`: the Minkowski sum of the convex hulls of
/// `a` and `b`.
pub fn minkowski_convex(a: &[DVec3], b: &[DVec3]) -> Option<Mesh> {
    let sums: Vec<DVec3> = a
        .iter()
        .flat_map(|&p| b.iter().map(move |&q| p + q))
        .collect();
    convex_hull(&sums)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube_points(lo: f64, hi: f64) -> Vec<DVec3> {
        let mut v = Vec::new();
        for x in [lo, hi] {
            for y in [lo, hi] {
                for z in [lo, hi] {
                    v.push(DVec3::new(x, y, z));
                }
            }
        }
        v
    }

    fn volume(m: &Mesh) -> f64 {
        check_closed(m).unwrap();
        signed_volume(m)
    }

    #[test]
    fn cube_with_interior_coplanar_and_repeated_points() {
        let mut pts = cube_points(0.0, 1.0);
        // A grid on every face and inside, each point twice.
        for i in 0..=10 {
            for j in 0..=10 {
                for k in 0..=10 {
                    let p = DVec3::new(i as f64, j as f64, k as f64) * 0.1;
                    pts.push(p);
                    pts.push(p);
                }
            }
        }
        let h = convex_hull(&pts).unwrap();
        assert_eq!(h.positions.len(), 8);
        assert!((volume(&h) - 1.0).abs() < 1e-12);
        assert!(is_convex(&h));
    }

    #[test]
    fn degenerate_point_sets_have_no_hull() {
        assert!(convex_hull(&[]).is_none());
        assert!(convex_hull(&cube_points(0.0, 1.0)[..3]).is_none());
        let line: Vec<DVec3> = (0..20).map(|i| DVec3::splat(i as f64)).collect();
        assert!(convex_hull(&line).is_none());
        let plane: Vec<DVec3> = (0..20)
            .map(|i| DVec3::new(i as f64, ((i * i) % 7) as f64, 0.0))
            .collect();
        assert!(convex_hull(&plane).is_none());
        let same = vec![DVec3::ONE; 9];
        assert!(convex_hull(&same).is_none());
        let nan = [DVec3::NAN, DVec3::ZERO, DVec3::X, DVec3::Y];
        assert!(convex_hull(&nan).is_none());
    }

    #[test]
    fn nearly_coplanar_points_stay_consistent() {
        // A square with points displaced by one ulp above and below its plane.
        let mut pts = cube_points(0.0, 1.0);
        for i in 0..50 {
            let t = i as f64 / 50.0;
            let z = if i % 2 == 0 {
                1.0 + f64::EPSILON
            } else {
                1.0 - f64::EPSILON / 2.0
            };
            pts.push(DVec3::new(t, 1.0 - t, z));
        }
        let h = convex_hull(&pts).unwrap();
        assert!((volume(&h) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn minkowski_of_cubes_adds_sizes() {
        let m = minkowski_convex(&cube_points(0.0, 1.0), &cube_points(-0.5, 0.5)).unwrap();
        assert!((volume(&m) - 8.0).abs() < 1e-12);
        let aabb = m.aabb().unwrap();
        assert_eq!(aabb.min, DVec3::splat(-0.5));
        assert_eq!(aabb.max, DVec3::splat(1.5));
    }

    #[test]
    fn a_concave_mesh_is_not_convex() {
        // An L of two boxes, as one closed mesh: hull volume is larger.
        let m = crate::scene::fixtures::box_mesh(DVec3::ZERO, DVec3::new(2.0, 1.0, 1.0));
        assert!(is_convex(&m));
        let l = crate::scene::fixtures::joined(
            crate::scene::fixtures::box_mesh(DVec3::ZERO, DVec3::new(2.0, 1.0, 1.0)),
            crate::scene::fixtures::box_mesh(DVec3::new(0.0, 1.0, 0.0), DVec3::new(1.0, 2.0, 1.0)),
        );
        assert!(!is_convex(&l));
    }
}
