//! Which of two primitives every ray meets first, for SCS's subtraction order
//! (Stewart, Leach & John, "Sequenced convex subtraction": a sequence sorted
//! front to back subtracts a chain of cutters in one pass). Two solids with a
//! separating plane meet any ray in that plane's order: a ray crosses the
//! plane once, so it meets the solid on the eye's side first
//! ([`Apart::a_first`]). Pure geometry on the primitives' vertices; the plan
//! builder ([`super::order`]) turns it into a sequence.
#![deny(unsafe_code)]

use glam::DVec3;

use crate::scene::{Aabb, Camera, Mesh, Projection, Scene};

/// Most triangles of a mesh whose hull is kept: the separating-axis test is
/// quadratic in them. A larger mesh keeps no hull (and no copy of its
/// vertices), so it is never proven apart: its group keeps SCS's rounds.
const MAX_TRIANGLES: usize = 4096;

/// What the separating-axis test needs of a primitive: its vertices and the
/// normals of its faces. Any axis that separates the vertex sets separates
/// the convex hulls and so the solids, convex or not.
#[derive(Clone, Debug, Default)]
pub struct Hull {
    points: Vec<DVec3>,
    normals: Vec<DVec3>,
    /// Scale of the coordinates: the tolerance of "touching" is relative to it.
    scale: f64,
}

/// Most primitives of a scene whose hulls are kept: past it (a scene of
/// thousands of primitives, thousands of products) no group is ordered and
/// SCS keeps its rounds, so planning stays linear in the scene.
pub const MAX_PRIMITIVES: usize = 4096;

/// The hulls of `scene`'s primitives, none past [`MAX_PRIMITIVES`].
pub fn of_scene(scene: &Scene) -> Vec<Hull> {
    if scene.primitives.len() > MAX_PRIMITIVES {
        return Vec::new();
    }
    scene.primitives.iter().map(|p| Hull::of(&p.mesh)).collect()
}

impl Hull {
    pub fn of(mesh: &Mesh) -> Hull {
        let p = &mesh.positions;
        if mesh.triangles.len() > MAX_TRIANGLES {
            return Hull::default();
        }
        let mut normals: Vec<DVec3> = Vec::new();
        for &[a, b, c] in &mesh.triangles {
            let (a, b, c) = (p[a as usize], p[b as usize], p[c as usize]);
            let n = (b - a).cross(c - a).normalize_or_zero();
            // The two triangles of a quad usually come one after the other.
            if n != DVec3::ZERO && normals.last().is_none_or(|m| m.dot(n) < 1.0 - 1e-12) {
                normals.push(n);
            }
        }
        let scale = p.iter().fold(0.0f64, |s, q| s.max(q.abs().max_element()));
        Hull {
            points: p.clone(),
            normals,
            scale,
        }
    }

    /// The hull's extent along `n`.
    fn range(&self, n: DVec3) -> (f64, f64) {
        self.points
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &q| {
                let d = n.dot(q);
                (lo.min(d), hi.max(d))
            })
    }
}

/// A plane between two solids `a` and `b`: `a` lies where `normal·x ≤ a_max`,
/// `b` where `normal·x ≥ b_min`, and `a_max ≤ b_min` up to rounding (they may
/// touch: a face of one on a face of the other).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Apart {
    pub normal: DVec3,
    pub a_max: f64,
    pub b_min: f64,
}

/// Where rays come from: a perspective eye, or the direction of an
/// orthographic view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Viewpoint {
    Eye(DVec3),
    Along(DVec3),
}

impl Viewpoint {
    pub fn of(camera: &Camera) -> Viewpoint {
        match camera.projection {
            Projection::Perspective { .. } => Viewpoint::Eye(camera.eye),
            Projection::Orthographic { .. } => Viewpoint::Along(camera.target - camera.eye),
        }
    }
}

impl Viewpoint {
    /// How far along the rays the nearest point of box `b` lies (a
    /// perspective eye: distance; an orthographic view: along its direction).
    pub fn nearest(self, b: &Aabb) -> f64 {
        match self {
            Viewpoint::Eye(e) => (e.clamp(b.min, b.max) - e).length(),
            Viewpoint::Along(d) => d.dot(DVec3::select(d.cmpge(DVec3::ZERO), b.min, b.max)),
        }
    }
}

impl Apart {
    /// Whether every ray that meets both solids meets `a` first. A ray's
    /// `normal·x` is monotone: from an eye on `a`'s side of the plane it can
    /// reach `b` only after leaving `a`'s side, and from an eye between them
    /// it meets one of them at most (either answer holds).
    pub fn a_first(&self, view: Viewpoint) -> bool {
        match view {
            Viewpoint::Eye(e) => self.normal.dot(e) <= 0.5 * (self.a_max + self.b_min),
            Viewpoint::Along(d) => self.normal.dot(d) >= 0.0,
        }
    }
}

/// A plane between `a` and `b` among their face normals and the world axes,
/// if one is found (`None`: they overlap, or only an axis not tried, such as
/// an edge–edge one, separates them).
pub fn apart(a: &Hull, b: &Hull) -> Option<Apart> {
    if a.points.is_empty() || b.points.is_empty() {
        return None;
    }
    // Rounding of the coordinates (rotations, f32 inputs): faces that coincide
    // on paper may cross by this much and still only touch.
    let tol = 1e-9 * a.scale.max(b.scale).max(1.0);
    let world = [DVec3::X, DVec3::Y, DVec3::Z];
    world
        .iter()
        .chain(&a.normals)
        .chain(&b.normals)
        .find_map(|&n| {
            let (a_lo, a_hi) = a.range(n);
            let (b_lo, b_hi) = b.range(n);
            if a_hi <= b_lo + tol {
                Some(Apart {
                    normal: n,
                    a_max: a_hi,
                    b_min: b_lo,
                })
            } else if b_hi <= a_lo + tol {
                Some(Apart {
                    normal: -n,
                    a_max: -a_lo,
                    b_min: -b_hi,
                })
            } else {
                None
            }
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::fixtures;

    fn boxed(min: [f64; 3], max: [f64; 3]) -> Hull {
        Hull::of(&fixtures::box_mesh(DVec3::from(min), DVec3::from(max)))
    }

    #[test]
    fn touching_boxes_are_apart_and_ordered_by_the_eye() {
        let (a, b) = (
            boxed([-1.5, 0.0, -1.2], [-0.5, 0.6, 1.2]),
            boxed([-0.5, 0.2, -1.2], [0.3, 0.5, 1.2]),
        );
        let s = apart(&a, &b).expect("a shared face separates them");
        assert_eq!(s.normal, DVec3::X);
        assert!(!s.a_first(Viewpoint::Eye(DVec3::new(3.0, 2.5, 2.0))));
        assert!(s.a_first(Viewpoint::Eye(DVec3::new(-3.0, 0.0, 0.0))));
        assert!(s.a_first(Viewpoint::Along(DVec3::new(1.0, -1.0, 0.0))));
        assert!(!s.a_first(Viewpoint::Along(DVec3::new(-1.0, -1.0, 0.0))));
        // Swapped, the same plane seen from the other side.
        let t = apart(&b, &a).unwrap();
        assert!(t.a_first(Viewpoint::Eye(DVec3::new(3.0, 2.5, 2.0))));
    }

    #[test]
    fn overlapping_solids_are_not_apart() {
        let a = boxed([0.0; 3], [1.0; 3]);
        let b = boxed([0.5; 3], [2.0; 3]);
        assert_eq!(apart(&a, &b), None);
        // Spheres whose boxes overlap but which are apart along a face normal
        // (the diagonal): found among the sphere's own face normals.
        let s = |c: [f64; 3]| Hull::of(&fixtures::sphere_mesh(DVec3::from(c), 0.5, 24, 12));
        let (p, q) = (s([0.0; 3]), s([0.8, 0.8, 0.0]));
        let sep = apart(&p, &q).expect("apart along a diagonal face normal");
        assert!(sep.normal.x > 0.3 && sep.normal.y > 0.3, "{sep:?}");
        assert_eq!(apart(&p, &s([0.5, 0.5, 0.0])), None);
    }
}
