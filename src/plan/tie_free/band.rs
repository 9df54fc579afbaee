//! The tie band under one camera (docs/precision.md): how far
//! apart, in world units, two faces must be for the tie rule's tolerance never
//! to span both at any pixel, from the depth format's quantum, f32 rounding
//! and the device's vertex snapping ([`super`]'s decisions compare each mesh's
//! smallest gap with it).

use super::super::tie::REVERSED_SCALE;
use crate::scene::{Aabb, Camera, Projection};

/// Depth quantum of a 24-bit buffer (and the largest ulp of standard-Z floats
/// below 1).
const QUANTUM_STANDARD: f64 = 1.0 / (1u64 << 24) as f64;
/// Relative ulp bound of a reversed-Z float depth.
const QUANTUM_REVERSED: f64 = 1.0 / (1u64 << 23) as f64;
/// Relative f32 rounding of vertices and transforms allowed for (2⁻¹⁸ of the
/// distance from the eye: four times the 2⁻²⁰ of docs/precision.md).
const ROUNDING: f64 = 1.0 / (1u64 << 18) as f64;
/// Every bound below is doubled (the depth slope is taken as constant over the
/// band; the band is a tiny fraction of the view depth).
const SAFETY: f64 = 2.0;

/// The tie band as a world distance between two faces, under one camera: two
/// faces farther apart than [`TieBand::world`] are never within the tie rule's
/// tolerance of each other at any pixel.
///
/// Along a view ray at angle β to the view axis, faces a distance `h` apart
/// differ in view depth by at least `h cos β`. The rule's tolerance in
/// normalized depth, `eps' + 2^-bits · fwidth(z)`, is in view depth `eps' /
/// |dz/dw| + 2^-bits (|∂w/∂x| + |∂w/∂y|)`; for parallel planes the second term
/// is at most `2^(2-bits)` pixel footprints in perspective (`2^(1-bits)`
/// orthographic) whatever their angle to the ray, because the separation along
/// the ray grows with the same `1/cos` as the slope. With the depth-format
/// quantum, f32 rounding and a factor of two for safety, the band in world units
/// is `SAFETY · (per_eps · |eps| + fixed) + rounding`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TieBand {
    /// World units per unit of the draw's `|eps|`.
    per_eps: f64,
    /// The part independent of `eps`: quantum and vertex snapping, before
    /// [`SAFETY`].
    fixed: f64,
    /// f32 rounding of positions, world units.
    rounding: f64,
}

impl TieBand {
    /// The band for `camera` on a `width × height` image of a device that snaps
    /// vertices to `2^-subpixel_bits` pixel, with reversed or standard Z, for
    /// faces inside `bounds`.
    pub fn new(
        camera: &Camera,
        width: u32,
        height: u32,
        subpixel_bits: u32,
        reversed_z: bool,
        bounds: &Aabb,
    ) -> TieBand {
        let (n, f) = (camera.near, camera.far);
        let mut w_max = n;
        let mut t_max: f64 = 0.0;
        for k in 0..8 {
            let p = glam::DVec3::new(
                if k & 1 == 0 {
                    bounds.min.x
                } else {
                    bounds.max.x
                },
                if k & 2 == 0 {
                    bounds.min.y
                } else {
                    bounds.max.y
                },
                if k & 4 == 0 {
                    bounds.min.z
                } else {
                    bounds.max.z
                },
            );
            w_max = w_max.max(camera.view_depth(p));
            t_max = t_max.max((p - camera.eye).length());
        }
        // Nothing beyond the far plane is drawn (and an empty box gives -inf).
        let w_max = if w_max.is_finite() { w_max.min(f) } else { f };
        let t_max = if t_max.is_finite() { t_max } else { f };
        let snap = 0.5f64.powi(subpixel_bits.min(30) as i32);
        let (depth_per_z, slope, cos_beta) = match camera.projection {
            Projection::Perspective { fov_y_deg } => {
                let tan_half = (fov_y_deg.to_radians() * 0.5).tan();
                let aspect = width as f64 / height as f64;
                let cos_beta = 1.0 / (1.0 + tan_half * tan_half * (1.0 + aspect * aspect)).sqrt();
                // World size of a pixel at distance t: at most t · ρ.
                let rho = 2.0 * tan_half / height as f64;
                // View depth per unit of (reversed: relative) normalized depth.
                let per_z = if reversed_z {
                    w_max
                } else {
                    (f - n) * w_max * w_max / (f * n)
                };
                (per_z, 4.0 * snap * t_max * rho, cos_beta)
            }
            Projection::Orthographic { height: view_h } => {
                (f - n, 2.0 * snap * view_h / height as f64, 1.0)
            }
        };
        let (per_eps, quantum) = if reversed_z {
            (
                REVERSED_SCALE as f64 * depth_per_z,
                QUANTUM_REVERSED * depth_per_z,
            )
        } else {
            (depth_per_z, QUANTUM_STANDARD * depth_per_z)
        };
        TieBand {
            per_eps: per_eps / cos_beta,
            fixed: (quantum + slope) / cos_beta,
            rounding: ROUNDING * t_max,
        }
    }

    /// The band of a draw with tolerance `eps` (normalized depth), world units.
    pub fn world(&self, eps: f32) -> f64 {
        SAFETY * (self.per_eps * eps.abs() as f64 + self.fixed) + self.rounding
    }
}

#[cfg(test)]
mod tests {
    use super::super::super::testing::{band, camera, unit};
    use super::super::super::SHADE_EPS;
    use super::*;
    use glam::DVec3;

    #[test]
    fn the_band_scales_with_the_pixel_and_the_snapping() {
        // The snapping part is proportional to the pixel's size: 8× at 1/8 the size.
        let (fine, coarse) = (band(800, 8, true), band(100, 8, true));
        assert!((coarse.fixed - 8.0 * fine.fixed).abs() < 1e-2 * coarse.fixed);
        // 4 bits (the coarsest conformant device) snap 16× coarser than 8.
        assert!(band(800, 4, true).world(0.0) > 10.0 * band(800, 8, true).world(0.0));
        // At 800 px a pixel is ~6e-3 wide at the far corner (6 units away);
        // 2^-6 of it (snapping 2^-8, two faces, perspective, safety) over cos β,
        // plus rounding: ~2.6e-4. A 1e-3 thin wall is outside the band.
        let w = fine.world(SHADE_EPS);
        assert!(w > 1e-4 && w < 5e-4, "{w}");
    }

    #[test]
    fn reversed_z_tolerances_are_narrower_than_standard_ones() {
        // Standard Z: (f - n) w² / (f n) = 6.9 view units per unit of eps at the
        // far corner; reversed Z: REVERSED_SCALE · w = 0.75.
        let (std, rev) = (band(800, 8, false), band(800, 8, true));
        assert!((std.per_eps / rev.per_eps - 6.0 * 6.0 * 4.0 / 21.0 / 0.75).abs() < 1e-9);
        let ortho = camera(
            DVec3::new(0.0, 0.0, 5.0),
            Projection::Orthographic { height: 3.0 },
        );
        let o = TieBand::new(&ortho, 800, 800, 8, false, &unit());
        // Orthographic standard Z: (f - n) per unit of eps; snapping 2^-7 of 3/800.
        assert!((o.per_eps - 4.0).abs() < 1e-12);
        assert!((o.fixed - (4.0 / (1u64 << 24) as f64 + 2.0 / 256.0 * 3.0 / 800.0)).abs() < 1e-12);
    }
}
