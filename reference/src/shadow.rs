//! Shadows, exactly: one `f64` shadow ray per visible point (Rossignac & Wu's
//! shadows, with rays instead of a shadow buffer). A pixel's visible point `P` is in
//! shadow when the line from the light through `P` first enters the solid (or meets a
//! kept surface) before reaching `P`, by more than the grouping tolerance. The line
//! is cast by the same regularized caster as the eye's pixels, through `P`'s exact
//! (sub-pixel) place in the light's view, so the GPU's shadow map and these rays
//! answer the same question.
#![deny(unsafe_code)]

use rayon::prelude::*;

use super::raycast::Prepared;
use peeltrim::scene::light::Light;
use peeltrim::scene::Scene;

/// Image size of the light's view for the rays. Any size gives the same lines
/// (they pass through `P` exactly); this one keeps the pixel coordinates tame.
const LIGHT_VIEW: u32 = 1024;

/// Per pixel of a `width × height` eye image: `None` on background, `Some(true)`
/// where the visible point is in `light`'s shadow, `Some(false)` where it is lit.
pub fn shadow_rays(scene: &Scene, light: &Light, width: u32, height: u32) -> Vec<Option<bool>> {
    let eye = Prepared::new(scene);
    let light_scene = Scene {
        camera: light.camera_for(scene),
        ..scene.clone()
    };
    let from_light = Prepared::new(&light_scene);
    let cam = &light_scene.camera;
    let tol = from_light.tol;
    (0..height)
        .into_par_iter()
        .flat_map_iter(|y| {
            let (eye, from_light) = (&eye, &from_light);
            (0..width).map(move |x| {
                let hit = eye.cast_pixel(x as f64 + 0.5, y as f64 + 0.5, width, height)?;
                let (lx, ly) = cam.pixel_of(hit.point, LIGHT_VIEW, LIGHT_VIEW);
                let d = cam.view_depth(hit.point);
                let first = from_light.cast_pixel(lx, ly, LIGHT_VIEW, LIGHT_VIEW);
                Some(first.is_some_and(|f| f.depth < d - tol))
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use peeltrim::scene::fixtures::*;
    use peeltrim::scene::Projection;

    /// A small box floating over a slab, lit from straight above and seen from
    /// above: the slab is shadowed exactly under the box, lit elsewhere; the
    /// box's top is lit.
    #[test]
    fn box_over_slab_casts_its_footprint() {
        let mut c = camera(DVec3::new(0.0, 5.0, 0.0), DVec3::ZERO, 40.0, 0.1, 100.0);
        c.up = DVec3::NEG_Z;
        c.projection = Projection::Orthographic { height: 4.0 };
        let mut e = ExprBuilder::default();
        let (a, b) = (e.leaf(0), e.leaf(1));
        let u = e.union(a, b);
        let sc = scene(
            c,
            vec![
                prim(
                    "slab",
                    box_mesh(DVec3::new(-2.0, -0.2, -2.0), DVec3::new(2.0, 0.0, 2.0)),
                    [200; 3],
                ),
                prim(
                    "box",
                    box_mesh(DVec3::new(-0.5, 1.0, -0.5), DVec3::new(0.5, 1.5, 0.5)),
                    [200; 3],
                ),
            ],
            e.build(u),
        );
        let light = Light::Directional {
            direction: DVec3::NEG_Y,
        };
        // 40 × 40 pixels of 0.1: the box covers x, z ∈ (-0.5, 0.5), 10 × 10 pixels.
        let m = shadow_rays(&sc, &light, 40, 40);
        assert!(m.iter().all(|v| v.is_some()));
        let shadowed = m.iter().filter(|v| **v == Some(true)).count();
        // Seen from above the box hides its own shadow: nothing shadowed shows.
        assert_eq!(shadowed, 0);
        // Light at a slant: the shadow moves off the box's footprint.
        let slant = Light::Directional {
            direction: DVec3::new(1.0, -1.0, 0.0).normalize(),
        };
        let m = shadow_rays(&sc, &slant, 40, 40);
        // The box's shadow on the slab is its footprint moved by +1 in x (height
        // 1 to 1.5 over the slab at y = 0): x ∈ (0.5, 2.0), |z| < 0.5, the part
        // x ∈ (0.5, 2.0) not hidden by the box (which covers x < 0.5).
        let at = |x: f64, z: f64| {
            let (px, py) = ((x + 2.0) / 0.1, (z + 2.0) / 0.1);
            m[py as usize * 40 + px as usize]
        };
        assert_eq!(at(1.25, 0.05), Some(true));
        assert_eq!(at(0.75, -0.35), Some(true));
        assert_eq!(at(1.25, 0.75), Some(false));
        assert_eq!(at(-1.25, 0.05), Some(false));
        assert_eq!(at(0.05, 0.05), Some(false)); // the box's top
        let shadowed = m.iter().filter(|v| **v == Some(true)).count();
        assert_eq!(shadowed, 15 * 10);
    }
}
