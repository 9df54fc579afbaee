//! What the Vulkan specification lets a conformant device's depth output differ
//! from the exact reference, per pixel — the tolerance of GPU tests that must hold
//! on any device (docs/precision.md; `plan::tie` for the tie rule).
//!
//! At a pixel of view depth `d` whose surface changes view depth by `s =
//! |∂d/∂x| + |∂d/∂y|` per pixel, the allowed error is the sum of:
//!
//! - **vertex snapping**: framebuffer x, y of vertices are snapped to
//!   2^-`subPixelPrecisionBits` pixel (Vulkan "Limits", ≥ 4) and depth may be
//!   interpolated from the snapped vertices: at most `2^-(bits+1) · s` (each
//!   vertex moves ≤ 2^-(bits+1) per axis; a convex combination of the moves moves
//!   the point no further). The output pass re-evaluates the plane at the pixel
//!   centre, so this term is an upper bound the output should stay well under;
//! - **depth representation**: `R` resolvable steps of normalized depth `r` at the
//!   value (D24: r = 2^-24; D32 float: r = one ulp of the stored value, 2^(e-23),
//!   the "minimum resolvable difference" of Vulkan's depth-bias section), mapped to
//!   view depth by the projection's `|∂d/∂z|`: perspective `d²(f−n)/(f n)` (both
//!   standard and reversed Z), orthographic `f − n`. `R` = 4 (rounding on store,
//!   interpolation, and the read-back conversion);
//! - **single-precision transforms**: vertex transform and interpolation in f32,
//!   a few ulps of the view depth: `2^-20 · d`.
//!
//! [`DepthPrecision::allowed`] is the sum; [`spec_depth_check`] measures a render
//! against it.

use peeltrim::scene::camera::DepthConvention;
use peeltrim::scene::{Camera, Projection};
use peeltrim::Images;

/// A depth set-up as the specification's bounds see it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthPrecision {
    /// `true`: D32 float; `false`: D24 unorm.
    pub float: bool,
    pub convention: DepthConvention,
    /// The device's `subPixelPrecisionBits` (4 at the specification's minimum).
    pub subpixel_bits: u32,
}

/// Resolvable depth steps allowed for rounding on store, interpolation and read-back.
const STEPS: f64 = 4.0;
/// Relative view-depth error of f32 vertex transforms and interpolation.
const TRANSFORM_REL: f64 = 1.0 / (1u64 << 20) as f64;

impl DepthPrecision {
    /// Normalized depth at view depth `d`.
    fn window_z(&self, cam: &Camera, d: f64) -> f64 {
        let (n, f) = (cam.near, cam.far);
        let z = match cam.projection {
            Projection::Perspective { .. } => f * (d - n) / (d * (f - n)),
            Projection::Orthographic { .. } => (d - n) / (f - n),
        };
        match self.convention {
            DepthConvention::Standard => z,
            DepthConvention::Reversed => 1.0 - z,
        }
    }

    /// The minimum resolvable difference of normalized depth at `z`.
    fn resolution(&self, z: f64) -> f64 {
        if self.float {
            let z = (z as f32).abs().max(f32::MIN_POSITIVE);
            // One ulp of the stored f32.
            (f32::from_bits(z.to_bits() + 1) - z) as f64
        } else {
            2f64.powi(-24)
        }
    }

    /// `|∂d/∂z|`: view depth per unit of normalized depth at view depth `d`.
    fn view_per_window(cam: &Camera, d: f64) -> f64 {
        let (n, f) = (cam.near, cam.far);
        match cam.projection {
            Projection::Perspective { .. } => d * d * (f - n) / (f * n),
            Projection::Orthographic { .. } => f - n,
        }
    }

    /// The allowed |view depth error| at a pixel of view depth `d` whose surface
    /// changes view depth by `slope` (|∂d/∂x| + |∂d/∂y|) per pixel.
    pub fn allowed(&self, cam: &Camera, d: f64, slope: f64) -> f64 {
        let snap = 0.5f64.powi(self.subpixel_bits as i32 + 1) * slope;
        let z = self.window_z(cam, d);
        let repr = STEPS * self.resolution(z) * Self::view_per_window(cam, d);
        snap + repr + TRANSFORM_REL * d.abs()
    }
}

/// `|∂d/∂x| + |∂d/∂y|` per pixel of a reference depth image, from differences to
/// the neighbours of the same primitive (the larger one-sided difference per axis;
/// 0 where no neighbour shares the primitive).
pub fn slopes(img: &Images) -> Vec<f64> {
    let (w, h) = (img.width as usize, img.height as usize);
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !img.depth[i].is_finite() {
                continue;
            }
            let diff = |j: usize| {
                (img.prim[j] == img.prim[i] && img.depth[j].is_finite())
                    .then(|| (img.depth[j] as f64 - img.depth[i] as f64).abs())
                    .unwrap_or(0.0)
            };
            let sx = [x.checked_sub(1), (x + 1 < w).then_some(x + 1)]
                .into_iter()
                .flatten()
                .map(|nx| diff(y * w + nx))
                .fold(0.0, f64::max);
            let sy = [y.checked_sub(1), (y + 1 < h).then_some(y + 1)]
                .into_iter()
                .flatten()
                .map(|ny| diff(ny * w + x))
                .fold(0.0, f64::max);
            out[i] = sx + sy;
        }
    }
    out
}

/// A render's depth against the specification's bound, over the interior pixels
/// (not within one pixel of a coverage or id boundary of the reference) covered
/// in both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecDepthReport {
    /// 99th percentile of error / allowed (≤ 1: within the specification).
    pub ratio_p99: f64,
    /// 99th percentile of error / view depth.
    pub relative_p99: f64,
    /// Pixels compared.
    pub pixels: u64,
}

/// Measures `gpu`'s depth against `reference` with the bounds of `precision`.
pub fn spec_depth_check(
    reference: &Images,
    gpu: &Images,
    cam: &Camera,
    precision: &DepthPrecision,
) -> SpecDepthReport {
    let edge = super::compare::boundary_mask(reference);
    let slope = slopes(reference);
    let (mut ratio, mut rel) = (Vec::new(), Vec::new());
    for i in 0..reference.depth.len() {
        let (a, b) = (reference.depth[i] as f64, gpu.depth[i] as f64);
        if edge[i] || !a.is_finite() || !b.is_finite() {
            continue;
        }
        let e = (a - b).abs();
        ratio.push(e / precision.allowed(cam, a, slope[i]));
        rel.push(e / a.abs().max(f64::MIN_POSITIVE));
    }
    let p99 = |mut v: Vec<f64>| {
        if v.is_empty() {
            return 0.0;
        }
        v.sort_unstable_by(f64::total_cmp);
        v[((0.99 * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1]
    };
    SpecDepthReport {
        pixels: ratio.len() as u64,
        ratio_p99: p99(ratio),
        relative_p99: p99(rel),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use peeltrim::scene::fixtures;

    fn cam() -> Camera {
        fixtures::camera(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, 40.0, 1.0, 100.0)
    }

    #[test]
    fn d24_standard_allows_the_quantum_at_the_far_plane() {
        let p = DepthPrecision {
            float: false,
            convention: DepthConvention::Standard,
            subpixel_bits: 8,
        };
        let c = cam();
        // At d = f the quantum maps to 2^-24 · f²(f−n)/(f n) = 2^-24 · 9900.
        let want = 4.0 * 2f64.powi(-24) * 9900.0 + 100.0 * 2f64.powi(-20);
        assert!((p.allowed(&c, 100.0, 0.0) - want).abs() < 1e-12 * want);
        // A slope adds 2^-9 of it at 8 subpixel bits.
        assert!((p.allowed(&c, 100.0, 1.0) - want - 2f64.powi(-9)).abs() < 1e-12);
    }

    #[test]
    fn reversed_float_is_relative_and_standard_float_is_not() {
        let c = cam();
        let rev = DepthPrecision {
            float: true,
            convention: DepthConvention::Reversed,
            subpixel_bits: 8,
        };
        let std = DepthPrecision {
            convention: DepthConvention::Standard,
            ..rev
        };
        // Reversed: the allowance over d stays within a small factor from near to far.
        let (a, b) = (
            rev.allowed(&c, 2.0, 0.0) / 2.0,
            rev.allowed(&c, 90.0, 0.0) / 90.0,
        );
        assert!(a / b < 4.0 && b / a < 4.0, "{a} {b}");
        // Standard Z in float near 1.0 is far coarser at the far end.
        assert!(std.allowed(&c, 90.0, 0.0) > 10.0 * rev.allowed(&c, 90.0, 0.0));
    }

    #[test]
    fn slopes_follow_a_ramp_and_stop_at_other_primitives() {
        let mut img = Images {
            width: 4,
            height: 1,
            color: vec![[0, 0, 0, 255]; 4],
            depth: vec![1.0, 1.5, 2.0, 9.0],
            prim: vec![1, 1, 1, 2],
        };
        let s = slopes(&img);
        assert_eq!(&s[..3], &[0.5, 0.5, 0.5]);
        assert_eq!(s[3], 0.0);
        img.depth[3] = f32::INFINITY;
        img.prim[3] = 0;
        assert_eq!(slopes(&img)[3], 0.0);
    }
}
