//! What a frame holds in memory, checked against the budget ([`peeltrim::budget`])
//! before it is allocated: the executor's images, and beyond the plain output
//! images the optional normal buffer (`vk::exec::normals`, Kirsch, Nienhaus &
//! Döllner §5.2), the layers kept on the host while peeling (Hable & Rossignac
//! §6), and the light's shadow map frame held beside the eye's (Rossignac & Wu).
//! Over budget, the work is refused with the estimate and the flag that lowers it.
#![deny(unsafe_code)]

use peeltrim::budget::{current, OverBudget};

/// Device bytes per pixel of the executor's images: colour and primitive id (4 + 4),
/// two depth-stencil images (8 each with D32S8), the depth textures (4 each) and
/// the read-back copy.
pub const DEVICE_BYTES_PER_PIXEL: u64 = 48;
/// Host bytes per pixel of a GPU frame: the read-back buffer and the output
/// images, plus the device images on a software device (lavapipe), whose device
/// memory is host memory.
pub const GPU_HOST_BYTES_PER_PIXEL: u64 = 32 + DEVICE_BYTES_PER_PIXEL;
/// Host bytes per pixel of the reference: per-pixel results and the output images.
pub const REFERENCE_BYTES_PER_PIXEL: u64 = 32;
/// The normal buffer: its RGBA32F target on the device.
pub const NORMAL_DEVICE_BYTES_PER_PIXEL: u64 = 16;
/// The normal buffer on the host: the target on a software device, its
/// read-back copy and the decoded view-space normals (16 + 16 + 12).
pub const NORMAL_HOST_BYTES_PER_PIXEL: u64 = 44;
/// The GPU transparency composite's RGBA32F accumulation target
/// (`vk::exec::transparency`), on the device and, on a software device, in host
/// memory.
pub const ACCUMULATE_BYTES_PER_PIXEL: u64 = 16;
/// One layer kept on the host: its images (colour, depth, primitive: 10), its
/// normals (12), and the merged copy with the solid index (10 + 12 + 4), rounded up.
pub const LAYER_HOST_BYTES_PER_PIXEL: u64 = 48;

/// What one frame holds; `Default` is the plain opaque frame on the CPU.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameMemory {
    /// A GPU frame (else the reference's).
    pub gpu: bool,
    /// The normal buffer is on (styles, edge maps, `--layers-out` on the GPU).
    pub normals: bool,
    /// Layers held on the host at once.
    pub layers: u64,
    /// The side of a square shadow map rendered beside the frame (a GPU frame
    /// of its own).
    pub shadow_map: Option<u32>,
    /// The GPU transparency composite's float target is allocated.
    pub accumulate: bool,
}

impl FrameMemory {
    /// Host bytes of a `width`×`height` frame with these extras.
    pub fn host_bytes(&self, width: u32, height: u32) -> u64 {
        let px = |w: u32, h: u32| w as u64 * h as u64;
        let per_pixel = if self.gpu {
            GPU_HOST_BYTES_PER_PIXEL
        } else {
            REFERENCE_BYTES_PER_PIXEL
        } + if self.normals {
            NORMAL_HOST_BYTES_PER_PIXEL
        } else {
            0
        } + if self.accumulate {
            ACCUMULATE_BYTES_PER_PIXEL
        } else {
            0
        };
        let layers = self.layers.saturating_mul(LAYER_HOST_BYTES_PER_PIXEL);
        let map = self
            .shadow_map
            .map_or(0, |s| px(s, s) * GPU_HOST_BYTES_PER_PIXEL);
        px(width, height)
            .saturating_mul(per_pixel.saturating_add(layers))
            .saturating_add(map)
    }

    /// Device bytes per pixel of the executor's images with these extras.
    pub fn device_bytes_per_pixel(&self) -> u64 {
        DEVICE_BYTES_PER_PIXEL
            + if self.normals {
                NORMAL_DEVICE_BYTES_PER_PIXEL
            } else {
                0
            }
            + if self.accumulate {
                ACCUMULATE_BYTES_PER_PIXEL
            } else {
                0
            }
    }

    /// Refuses the frame when it would exceed the memory budget.
    pub fn check(&self, width: u32, height: u32) -> Result<(), OverBudget> {
        let mut what = format!("a {width}x{height} frame");
        let mut fix = vec!["use a smaller --size"];
        if self.normals {
            what.push_str(" with its normal buffer");
        }
        if self.accumulate {
            what.push_str(" with its transparency target");
        }
        if self.layers > 0 {
            what.push_str(&format!(" holding {} layers", self.layers));
            fix.push("peel fewer layers (--layers N, --layer-threshold N)");
        }
        if let Some(s) = self.shadow_map {
            what.push_str(&format!(" and a {s}x{s} shadow map"));
        }
        current().check(|| what, self.host_bytes(width, height), &fix.join(", or "))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extras_count_and_name_themselves() {
        let (w, h) = (100, 50);
        let px = 5000;
        let plain = FrameMemory {
            gpu: true,
            ..Default::default()
        };
        assert_eq!(plain.host_bytes(w, h), px * GPU_HOST_BYTES_PER_PIXEL);
        assert_eq!(
            FrameMemory::default().host_bytes(w, h),
            px * REFERENCE_BYTES_PER_PIXEL
        );
        let normals = FrameMemory {
            normals: true,
            ..plain
        };
        assert_eq!(
            normals.host_bytes(w, h) - plain.host_bytes(w, h),
            px * NORMAL_HOST_BYTES_PER_PIXEL
        );
        assert_eq!(normals.device_bytes_per_pixel(), 64);
        assert_eq!(plain.device_bytes_per_pixel(), DEVICE_BYTES_PER_PIXEL);
        let accumulate = FrameMemory {
            accumulate: true,
            ..plain
        };
        assert_eq!(
            accumulate.host_bytes(w, h) - plain.host_bytes(w, h),
            px * ACCUMULATE_BYTES_PER_PIXEL
        );
        assert_eq!(
            accumulate.device_bytes_per_pixel(),
            DEVICE_BYTES_PER_PIXEL + ACCUMULATE_BYTES_PER_PIXEL
        );
        let layers = FrameMemory { layers: 6, ..plain };
        assert_eq!(
            layers.host_bytes(w, h) - plain.host_bytes(w, h),
            6 * px * LAYER_HOST_BYTES_PER_PIXEL
        );
        let shadow = FrameMemory {
            shadow_map: Some(1024),
            ..plain
        };
        assert_eq!(
            shadow.host_bytes(w, h) - plain.host_bytes(w, h),
            1024 * 1024 * GPU_HOST_BYTES_PER_PIXEL
        );
        // Absurd counts saturate instead of wrapping round to a small number.
        let huge = FrameMemory {
            layers: u64::MAX / 2,
            ..plain
        };
        assert_eq!(huge.host_bytes(16384, 16384), u64::MAX);

        // The budget sees each extra: a frame that fits alone is refused with
        // its layers, and the message names them and the way out.
        let fits = plain.host_bytes(w, h);
        peeltrim::budget::with(fits, || {
            assert!(plain.check(w, h).is_ok());
            let e = layers.check(w, h).unwrap_err().to_string();
            assert!(
                e.contains("holding 6 layers") && e.contains("--layers N"),
                "{e}"
            );
            let e = shadow.check(w, h).unwrap_err().to_string();
            assert!(e.contains("1024x1024 shadow map"), "{e}");
            let e = normals.check(w, h).unwrap_err().to_string();
            assert!(e.contains("normal buffer"), "{e}");
        });
    }
}
