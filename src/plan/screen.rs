//! Where each primitive projects on the scene's image: the box of its
//! vertices' projections, in continuous pixel coordinates at `scene.render`'s
//! size, unclamped (a world box's corners reach the near plane of a fitted
//! camera long before the primitive does). SCS draws products
//! whose pixels cannot meet in one block (`scs::batch`); unlike the
//! executor's scissors, which only bound work (a recording may grow them
//! after a camera move), these boxes decide correctness, so two of them count
//! as apart only with [`MARGIN_PX`] pixels between them. Re-derived with the
//! camera, as `plan::view_convex` is.
#![deny(unsafe_code)]

use glam::{DMat4, DVec2, DVec3};

use crate::scene::camera::DepthConvention;
use crate::scene::{Camera, Scene};

/// Pixels two boxes must be apart by: a fragment lies within its triangle's
/// projection up to the vertex snapping (1/16 pixel at the coarsest
/// precision Vulkan allows) and `f32` rounding, far below this.
pub const MARGIN_PX: f64 = 2.0;

/// A box on screen, in pixels (y downward), as the rectangle of its corners'
/// projections.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenBox {
    /// The corner with the smallest pixel coordinates.
    pub lo: DVec2,
    /// The corner with the largest pixel coordinates.
    pub hi: DVec2,
}

impl ScreenBox {
    /// The smallest box holding both.
    pub fn union(&self, o: &ScreenBox) -> ScreenBox {
        ScreenBox {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    /// Whether no pixel can be drawn in both: at least [`MARGIN_PX`] between
    /// them along x or y.
    pub fn apart(&self, o: &ScreenBox) -> bool {
        let gap = (o.lo - self.hi).max(self.lo - o.hi);
        gap.max_element() >= MARGIN_PX
    }
}

/// Per primitive of `scene`, the screen box of its vertices under the scene's
/// camera and image size (a box around the projections of the vertices holds
/// every triangle's); `None` where a vertex lies at or in front of the near
/// plane (its projection is unbounded there, or clipped).
pub fn of_scene(scene: &Scene) -> Vec<Option<ScreenBox>> {
    let (w, h) = (scene.render.width as f64, scene.render.height as f64);
    let m = scene.camera.proj(w / h, DepthConvention::Standard) * scene.camera.view();
    scene
        .primitives
        .iter()
        .map(|p| project(&p.mesh.positions, &scene.camera, m, (w, h)))
        .collect()
}

/// The screen box of `points` on a `w × h` image seen by `cam` (`m`: its
/// world → clip matrix).
fn project(points: &[DVec3], cam: &Camera, m: DMat4, (w, h): (f64, f64)) -> Option<ScreenBox> {
    // Far enough in front of the near plane that `w` is positive and the
    // projection finite (the f32 clipping on the GPU agrees).
    let near = cam.near * (1.0 + 1e-6) + 1e-9;
    let mut out: Option<ScreenBox> = None;
    for &c in points {
        if cam.view_depth(c) <= near {
            return None;
        }
        let q = m * c.extend(1.0);
        let p = DVec2::new((q.x / q.w + 1.0) * 0.5 * w, (q.y / q.w + 1.0) * 0.5 * h);
        if !p.is_finite() || q.w <= 0.0 {
            return None;
        }
        let one = ScreenBox { lo: p, hi: p };
        out = Some(out.map_or(one, |o| o.union(&one)));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Projection;

    fn camera() -> Camera {
        Camera {
            eye: DVec3::new(0.0, 0.0, 10.0),
            target: DVec3::ZERO,
            up: DVec3::Y,
            projection: Projection::Perspective { fov_y_deg: 60.0 },
            near: 0.1,
            far: 100.0,
        }
    }

    /// The corners of a cube of half-size `r` at `(x, 0, z)`.
    fn cube(x: f64, z: f64, r: f64) -> Vec<DVec3> {
        (0..8)
            .map(|i| {
                let s = |bit: usize| if i & bit == 0 { -r } else { r };
                DVec3::new(x + s(1), s(2), z + s(4))
            })
            .collect()
    }

    fn at(cam: &Camera, points: &[DVec3]) -> Option<ScreenBox> {
        let m = cam.proj(1.0, DepthConvention::Standard) * cam.view();
        project(points, cam, m, (200.0, 200.0))
    }

    #[test]
    fn boxes_side_by_side_are_apart_and_boxes_in_line_are_not() {
        let cam = camera();
        let at = |x, z| at(&cam, &cube(x, z, 0.5)).unwrap();
        assert!(at(-2.0, 0.0).apart(&at(2.0, 0.0)));
        // One behind the other along the view: they overlap on screen.
        assert!(!at(0.0, 0.0).apart(&at(0.0, -5.0)));
        // Touching boxes are never apart.
        assert!(!at(0.0, 0.0).apart(&at(1.0, 0.0)));
        // The projection widens toward the eye: the nearer box is larger.
        let (near, far) = (at(0.0, 5.0), at(0.0, -5.0));
        assert!(near.hi.x - near.lo.x > far.hi.x - far.lo.x);
    }

    #[test]
    fn a_box_reaching_the_near_plane_has_no_screen_box() {
        let cam = camera();
        assert_eq!(at(&cam, &cube(0.0, 9.95, 0.5)), None);
        assert!(at(&cam, &cube(0.0, 8.0, 0.5)).is_some());
    }
}
