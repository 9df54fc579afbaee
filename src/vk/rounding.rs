//! Rounding emulation: makes this rasterizer round like a coarser one, so that a
//! test on lavapipe fails when a result depends on lavapipe's exact rounding.
//!
//! A conformant device snaps each vertex's framebuffer position to a grid of
//! 2^-`subPixelPrecisionBits` pixel (at least 4 bits, Vulkan "Limits") and may
//! interpolate depth from the snapped positions, as an NVIDIA H200
//! does; lavapipe interpolates depth from
//! the unsnapped floats. The vertex shader (`shaders/mesh.vert`, push constant
//! `snap`) snaps positions to a grid of 2^-`subpixel_bits` pixel before the
//! rasterizer sees them, so depths and coverage move exactly as on such a device.
//! Every pass snaps the same vertex the same way, so depth-equal passes stay exact
//! (`invariant gl_Position`).

/// Vertex snapping to `2^-subpixel_bits` pixel (4: the coarsest a conformant
/// device may use).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RoundingEmulation {
    /// The sub-pixel precision emulated: vertices snap to `2^-subpixel_bits` pixel.
    pub subpixel_bits: u32,
}

impl RoundingEmulation {
    /// The emulation of the coarsest conformant device.
    pub const SPEC_MINIMUM: RoundingEmulation = RoundingEmulation { subpixel_bits: 4 };
    /// 8 bits, snapped before depth interpolation: the NVIDIA H200 of the log.
    pub const EIGHT_BITS: RoundingEmulation = RoundingEmulation { subpixel_bits: 8 };

    /// The grid step in normalized device coordinates for a `width`×`height`
    /// viewport (NDC spans 2 over the viewport).
    pub fn ndc_step(self, width: u32, height: u32) -> [f32; 2] {
        let cell = 0.5f32.powi(self.subpixel_bits as i32);
        [
            2.0 / width.max(1) as f32 * cell,
            2.0 / height.max(1) as f32 * cell,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_is_a_sixteenth_pixel_at_the_spec_minimum() {
        let [x, y] = RoundingEmulation::SPEC_MINIMUM.ndc_step(128, 64);
        // 128 px span 2 NDC units: one pixel is 1/64, a sixteenth of it 1/1024.
        assert_eq!(x, 1.0 / 1024.0);
        assert_eq!(y, 1.0 / 512.0);
    }
}
