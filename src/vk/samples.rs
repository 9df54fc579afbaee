//! Multisampling: which sample counts a device can run peeltrim's frames at,
//! and the refusal of the others. A multisampled frame renders every plan
//! image (colour, ids, depth-stencils, depth textures) at the same count, so a
//! count must be in every one of `framebufferColorSampleCounts`,
//! `framebufferDepthSampleCounts`, `framebufferStencilSampleCounts`,
//! `sampledImageColorSampleCounts`, `sampledImageDepthSampleCounts` and
//! `sampledImageIntegerSampleCounts` (Vulkan specification, "Limits"), and
//! the device must have `sampleRateShading` (the peel, parity and tie tests
//! run once per sample, "Sample Shading"). Sample positions are the standard
//! ones ("Standard Sample Locations", `standardSampleLocations` required),
//! which the reference uses too. And the device must interpolate
//! `gl_FragCoord.z` at the sample in a program run once per sample, as
//! measured by `vk::sample_depth_probe` (`DeviceProfile::sample_depth`).

use ash::vk;

use super::error::VkError;
use super::instance::Context;

/// The sample counts peeltrim accepts (devices may support fewer).
pub const SAMPLE_COUNTS: [u32; 4] = [1, 2, 4, 8];

/// The Vulkan flag of `samples` (one of [`SAMPLE_COUNTS`]).
pub(crate) fn flag(samples: u32) -> vk::SampleCountFlags {
    vk::SampleCountFlags::from_raw(samples)
}

impl Context {
    /// The sample counts this device can run frames at: 1 always, and those
    /// of [`SAMPLE_COUNTS`] every framebuffer and sampled-image limit allows,
    /// where it has `sampleRateShading`.
    pub fn supported_samples(&self) -> Vec<u32> {
        let l = &self.shared.limits;
        let all = l.framebuffer_color_sample_counts
            & l.framebuffer_depth_sample_counts
            & l.framebuffer_stencil_sample_counts
            & l.sampled_image_color_sample_counts
            & l.sampled_image_depth_sample_counts
            & l.sampled_image_integer_sample_counts;
        let standard = l.standard_sample_locations == vk::TRUE;
        let ms = self.shared.sample_rate_shading && standard && self.profile().sample_depth;
        SAMPLE_COUNTS
            .into_iter()
            .filter(|&n| n == 1 || (ms && all.contains(flag(n))))
            .collect()
    }

    /// Refuses a sample count that is not 1, 2, 4 or 8, or that this device
    /// cannot run (naming the counts it can).
    pub fn check_samples(&self, samples: u32) -> Result<(), VkError> {
        if !SAMPLE_COUNTS.contains(&samples) {
            return Err(VkError::Config(format!(
                "{samples} samples per pixel: use 1, 2, 4 or 8 (--samples)"
            )));
        }
        let supported = self.supported_samples();
        if supported.contains(&samples) {
            return Ok(());
        }
        let list: Vec<String> = supported.iter().map(u32::to_string).collect();
        let why = if !self.shared.sample_rate_shading {
            "it has no sampleRateShading"
        } else if !self.profile().sample_depth {
            "under sample-rate shading its gl_FragCoord.z is not the sample's own depth \
             (measured: vk::sample_depth_probe), which the per-sample depth tests need"
        } else {
            "framebufferColor/Depth/StencilSampleCounts, \
             sampledImageColor/Depth/IntegerSampleCounts and standardSampleLocations"
        };
        Err(VkError::Unsupported(format!(
            "{samples} samples per pixel ({}: {why}); use --samples {}",
            self.device_name(),
            list.join(" or ")
        )))
    }
}
