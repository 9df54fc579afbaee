//! Geometry shared by the plan builders and the exact reference: bounds, the
//! BVH with its watertight line–triangle test ([`bvh`]), and point-in-mesh parity.
//! `plan/` uses this module, never `reference/`'s internals; the reference's ray
//! caster is built on the same queries.
#![deny(unsafe_code)]

pub mod bvh;
pub(crate) mod clip;
pub(crate) mod ties;

use glam::DVec3;

pub use crate::scene::Aabb;
use crate::scene::Mesh;
use bvh::{Line, MeshBvh};

/// The bounds of `points` (an empty box, min > max, for none).
pub fn bounds(points: &[DVec3]) -> Aabb {
    let mut b = Aabb {
        min: DVec3::splat(f64::INFINITY),
        max: DVec3::splat(f64::NEG_INFINITY),
    };
    for &p in points {
        b.min = b.min.min(p);
        b.max = b.max.max(p);
    }
    b
}

/// Whether `point` lies inside the closed `mesh`: the parity of the crossings of
/// a watertight ray cast from it (in a direction unlikely to graze an edge of a
/// tessellated shape; the tie-break of [`bvh`] counts edge hits consistently).
pub fn contains(mesh: &Mesh, point: DVec3) -> bool {
    let b = bounds(&mesh.positions);
    if point.cmplt(b.min).any() || point.cmpgt(b.max).any() {
        return false;
    }
    let line = Line::new(point, DVec3::new(0.5773, 0.5967, 0.5571).normalize());
    let mut hits = Vec::new();
    MeshBvh::new(mesh).cast_local(&line, &mut hits);
    hits.iter().filter(|c| c.t > 0.0).count() % 2 == 1
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::fixtures;

    #[test]
    fn box_contains_its_centre_not_a_point_outside() {
        let m = fixtures::box_mesh(DVec3::ZERO, DVec3::ONE);
        assert!(contains(&m, DVec3::splat(0.5)));
        assert!(contains(&m, DVec3::new(0.99, 0.01, 0.5)));
        assert!(!contains(&m, DVec3::new(1.5, 0.5, 0.5)));
        assert!(!contains(&m, DVec3::new(0.5, 0.5, -0.01)));
        let b = bounds(&m.positions);
        assert_eq!((b.min, b.max), (DVec3::ZERO, DVec3::ONE));
    }
}
