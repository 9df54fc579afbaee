//! Camera framing (`fit = true`, docs/scene-format.md) and automatic near/far planes.
//!
//! Both work on the vertices of everything that is drawn (primitives named by an
//! expression, and surfaces), all positions of each mesh.

use glam::DVec3;

use super::{Camera, Mesh, Projection};

/// Relative margin added on both sides of the depth range of the drawn vertices.
pub const DEPTH_MARGIN: f64 = 0.01;
/// When drawn geometry reaches the eye plane or behind it, a perspective near plane
/// is placed at `far * NEAR_FALLBACK` (geometry closer than that is clipped; a
/// perspective projection cannot show points at or behind the eye).
pub const NEAR_FALLBACK: f64 = 1e-4;

/// The bounding sphere `fit = true` frames: centred on the AABB of all vertices,
/// radius the distance to the farthest vertex. `None` without vertices.
pub fn bounding_sphere<'a>(
    meshes: impl IntoIterator<Item = &'a Mesh> + Clone,
) -> Option<(DVec3, f64)> {
    let mut it = meshes
        .clone()
        .into_iter()
        .flat_map(|m| m.positions.iter().copied());
    let first = it.next()?;
    let (lo, hi) = it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p)));
    let c = (lo + hi) * 0.5;
    let r = meshes
        .into_iter()
        .flat_map(|m| m.positions.iter())
        .map(|&p| p.distance(c))
        .fold(0.0f64, f64::max);
    Some((c, r))
}

/// Moves the camera so the sphere `(center, radius)` fits a `width × height` image:
/// the target to the centre, the view direction kept, the eye back to
/// `r / sin(min(fov_y, fov_x) / 2)`. Orthographic: `ortho_height = 2 r max(1, h/w)`
/// and the eye at distance `2 r` (any distance beyond `r` gives the same picture).
pub fn fit(cam: &mut Camera, center: DVec3, radius: f64, width: u32, height: u32) {
    // A zero radius (a single point) still needs a non-degenerate view.
    let r = if radius > 0.0 { radius } else { 1.0 };
    let dir = (cam.eye - cam.target).normalize();
    let aspect = width as f64 / height as f64;
    cam.target = center;
    match &mut cam.projection {
        Projection::Perspective { fov_y_deg } => {
            let fy = fov_y_deg.to_radians();
            let fx = 2.0 * ((fy * 0.5).tan() * aspect).atan();
            let d = r / (fy.min(fx) * 0.5).sin();
            cam.eye = center + dir * d;
        }
        Projection::Orthographic { height: h } => {
            *h = 2.0 * r * (height as f64 / width as f64).max(1.0);
            cam.eye = center + dir * 2.0 * r;
        }
    }
}

/// Near and far planes from the view depths of the drawn vertices: tight, widened by
/// [`DEPTH_MARGIN`] of the depth range plus a tiny relative epsilon so no vertex
/// touches a plane. Explicit values (`Some`) are kept. Perspective near stays > 0
/// (see [`NEAR_FALLBACK`]); orthographic near is not moved behind the eye, so the
/// picture matches rays cast from the eye plane.
pub fn near_far<'a>(
    cam: &Camera,
    meshes: impl IntoIterator<Item = &'a Mesh>,
    near: Option<f64>,
    far: Option<f64>,
) -> (f64, f64) {
    let (mut dmin, mut dmax) = (f64::INFINITY, f64::NEG_INFINITY);
    for m in meshes {
        for &p in &m.positions {
            let d = cam.view_depth(p);
            dmin = dmin.min(d);
            dmax = dmax.max(d);
        }
    }
    let persp = matches!(cam.projection, Projection::Perspective { .. });
    if !dmin.is_finite() || !dmax.is_finite() {
        dmin = 0.1;
        dmax = 10.0;
    }
    let scale = dmax.abs().max(dmin.abs()).max(1e-300);
    let m = DEPTH_MARGIN * (dmax - dmin) + 1e-6 * scale;
    let mut f = far.unwrap_or(dmax + m);
    if f <= 0.0 && persp && far.is_none() {
        // Everything is behind the eye: nothing is visible, any planes will do.
        f = 1.0;
    }
    let n = near.unwrap_or_else(|| {
        if persp {
            if dmin > 0.0 {
                (dmin - m).max(dmin * 0.5)
            } else {
                f * NEAR_FALLBACK
            }
        } else {
            (dmin - m).max(0.0)
        }
    });
    let f = if far.is_none() && f <= n {
        n + m.max(1e-6)
    } else {
        f
    };
    (n, f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::shapes::make_sphere;

    fn cam(p: Projection) -> Camera {
        Camera {
            eye: DVec3::new(3.0, 2.0, 4.0),
            target: DVec3::ZERO,
            up: DVec3::Y,
            projection: p,
            near: 0.1,
            far: 100.0,
        }
    }

    #[test]
    fn fit_perspective_touches_the_narrower_side() {
        let mut s = make_sphere(1.0, 48, 24);
        for p in &mut s.positions {
            *p += DVec3::new(1.0, 2.0, 3.0);
        }
        let (c, r) = bounding_sphere([&s]).unwrap();
        assert!((c - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
        assert!((r - 1.0).abs() < 1e-12);
        for (w, h) in [(800, 800), (1600, 800), (400, 800)] {
            let mut k = cam(Projection::Perspective { fov_y_deg: 35.0 });
            let dir0 = (k.eye - k.target).normalize();
            fit(&mut k, c, r, w, h);
            assert_eq!(k.target, c);
            assert!(((k.eye - k.target).normalize() - dir0).length() < 1e-12);
            let d = k.eye.distance(c);
            let fy = 35f64.to_radians();
            let fx = 2.0 * ((fy / 2.0).tan() * w as f64 / h as f64).atan();
            // the sphere's angular radius equals half the narrower field of view
            assert!(((r / d).asin() - fy.min(fx) / 2.0).abs() < 1e-12);
        }
    }

    #[test]
    fn fit_orthographic_height() {
        let mut k = cam(Projection::Orthographic { height: 1.0 });
        fit(&mut k, DVec3::ZERO, 2.0, 400, 800);
        assert_eq!(k.projection, Projection::Orthographic { height: 8.0 });
        fit(&mut k, DVec3::ZERO, 2.0, 800, 400);
        assert_eq!(k.projection, Projection::Orthographic { height: 4.0 });
    }

    #[test]
    fn near_far_enclose_geometry() {
        let s = make_sphere(1.0, 24, 12);
        let k = cam(Projection::Perspective { fov_y_deg: 35.0 });
        let (n, f) = near_far(&k, [&s], None, None);
        let d = k.eye.length();
        assert!(n > 0.0 && n < d - 1.0 && n > d - 1.1, "{n}");
        assert!(f > d + 1.0 - 1e-9 && f < d + 1.1, "{f}");
        // explicit values are kept
        assert_eq!(near_far(&k, [&s], Some(0.5), Some(9.0)), (0.5, 9.0));
        // eye inside the geometry: near stays positive
        let inside = Camera {
            eye: DVec3::new(0.0, 0.0, 0.5),
            ..k
        };
        let (n, f) = near_far(&inside, [&s], None, None);
        assert!(n > 0.0 && n < 1e-3 && f > 1.5, "{n} {f}");
        let o = cam(Projection::Orthographic { height: 3.0 });
        let (n, f) = near_far(&o, [&s], None, None);
        assert!(n > 0.0 && n < d - 1.0 && f > d + 1.0);
    }
}
