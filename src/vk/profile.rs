//! What the device is and how peeltrim works around it, decided once per
//! physical device: the [`DeviceProfile`] a [`super::Context`] owns. Plans,
//! pipelines and recordings read it; nothing else asks what kind of device
//! runs them (in the spirit of wgpu-hal's Vulkan `Workarounds`).
//!
//! `PEELTRIM_DEVICE_PROFILE=hardware` ([`PROFILE_ENV`]) forces the hardware
//! profile on any device: on a CPU rasterizer (lavapipe) the hardware paths
//! then run — load-op clears, frame timestamps after the frame's commands, no
//! depth-equal shades — with hardware's vertex snapping emulated at 8
//! subpixel bits, so that they are tested where no GPU is. `device` (or the
//! variable unset) keeps the device's own profile.

use ash::vk;

use super::error::VkError;
use super::exec::{ClearMode, FrameTimestamps};
use super::rounding::RoundingEmulation;

/// The environment variable that chooses the profile ([`ProfileChoice`]).
pub const PROFILE_ENV: &str = "PEELTRIM_DEVICE_PROFILE";

/// What kind of rasterizer the profile describes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProfileKind {
    /// A CPU rasterizer (lavapipe's llvmpipe, SwiftShader): it bins each
    /// rendering block's draws. Whether it snaps vertices before interpolating
    /// depth is measured apart ([`DeviceProfile::unsnapped_depth`]): lavapipe
    /// does not, SwiftShader does.
    CpuRasterizer,
    /// A hardware GPU: it snaps vertices to its subpixel grid before
    /// interpolating depth (as the NVIDIA H200 of the tests' logs does).
    Hardware,
}

/// Which profile to use: [`PROFILE_ENV`]'s value.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ProfileChoice {
    /// The device's own (`device`, or the variable unset).
    #[default]
    Device,
    /// The hardware profile on any device (`hardware`).
    Hardware,
}

impl ProfileChoice {
    /// Parses [`PROFILE_ENV`]'s value (`None`: unset).
    pub fn parse(value: Option<&str>) -> Result<ProfileChoice, VkError> {
        match value {
            None | Some("device") => Ok(ProfileChoice::Device),
            Some("hardware") => Ok(ProfileChoice::Hardware),
            Some(other) => Err(VkError::Config(format!(
                "{PROFILE_ENV}='{other}': use 'device' (the device's own profile, the default) or 'hardware'"
            ))),
        }
    }

    /// The choice of this process's environment.
    pub fn from_env() -> Result<ProfileChoice, VkError> {
        match std::env::var(PROFILE_ENV) {
            Ok(v) => Self::parse(Some(&v)),
            Err(std::env::VarError::NotPresent) => Self::parse(None),
            Err(std::env::VarError::NotUnicode(v)) => Self::parse(Some(&v.to_string_lossy())),
        }
    }
}

/// Which depth-stencil formats work as sampled, copyable attachments with
/// optimal tiling (what the executor needs of a depth format).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DepthFormats {
    /// `D32_SFLOAT_S8_UINT`.
    pub d32s8: bool,
    /// `D24_UNORM_S8_UINT`.
    pub d24s8: bool,
    /// `D32_SFLOAT`: the depth-only twin of D32S8 for stencil-free plans.
    pub d32: bool,
}

impl DepthFormats {
    /// Whether `format` is usable; formats the executor never uses are not.
    pub fn usable(&self, format: vk::Format) -> bool {
        match format {
            vk::Format::D32_SFLOAT_S8_UINT => self.d32s8,
            vk::Format::D24_UNORM_S8_UINT => self.d24s8,
            vk::Format::D32_SFLOAT => self.d32,
            _ => false,
        }
    }
}

/// The facts of a physical device a profile is made from (pure, for tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceFacts {
    /// `PHYSICAL_DEVICE_TYPE_CPU`: chooses the clear and timestamp placement
    /// only (costs, not correctness).
    pub cpu: bool,
    /// Depth is interpolated from unsnapped vertex positions, as measured by
    /// the probe draw (`vk::depth_probe`); never assumed from `cpu`.
    pub unsnapped_depth: bool,
    /// `subPixelPrecisionBits`.
    pub subpixel_bits: u32,
    /// The depth-stencil formats the executor can use.
    pub depth_formats: DepthFormats,
    /// Under sample shading `gl_FragCoord.z` is the sample's own depth, as
    /// measured by the probe draw (`vk::sample_depth_probe`); `false` where
    /// the device cannot multisample at all.
    pub sample_depth: bool,
}

/// Every fact and workaround that changes a plan or a recording, set once
/// from the physical device ([`DeviceProfile::detect`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceProfile {
    /// A CPU rasterizer or a hardware GPU.
    pub kind: ProfileKind,
    /// The raster depth is interpolated from unsnapped vertex positions
    /// (measured once per device by a probe draw, `vk::depth_probe`), so it
    /// is as exact at the pixel centre as the tie rule's plane depth: the final
    /// shade may then run depth-`EQUAL` draws where no tie is possible and
    /// leave the raster depth in the depth output (`plan::tie_free`).
    pub unsnapped_depth: bool,
    /// The vertex snapping the tie rule allows for: 2^-bits pixel (the
    /// emulation's where one is on, else the device's `subPixelPrecisionBits`).
    pub subpixel_bits: u32,
    /// Hardware's vertex snapping emulated in the vertex shader
    /// (`vk::rounding`); `None`: the device's own rasterization.
    pub vertex_snapping_emulation: Option<RoundingEmulation>,
    /// How clears are recorded: load ops on hardware, where tile-based and
    /// other GPUs clear on load for free; clear commands on a CPU rasterizer,
    /// which clears on load far more slowly.
    pub clears: ClearMode,
    /// Where each frame's closing timestamp goes: after every command on
    /// hardware; inside the last block on a CPU rasterizer, which saves it a
    /// binned scene per frame.
    pub frame_timestamps: FrameTimestamps,
    /// The depth formats the device can use.
    pub depth_formats: DepthFormats,
    /// A program run once per sample reads the sample's own depth in
    /// `gl_FragCoord.z` (measured, `vk::sample_depth_probe`): what every
    /// multisampled frame needs, its per-sample peel, parity and tie tests
    /// comparing that depth with the same sample's depth textures. The
    /// Vulkan specification leaves open where z is interpolated under sample
    /// shading; SwiftShader gives every sample sample 0's depth, and
    /// peeltrim runs only single-sample frames there
    /// ([`super::Context::check_samples`]).
    pub sample_depth: bool,
}

impl DeviceProfile {
    /// The profile of a device with `facts` under `choice`.
    pub fn from_facts(facts: DeviceFacts, choice: ProfileChoice) -> DeviceProfile {
        let cpu = facts.cpu && choice == ProfileChoice::Device;
        let emulation = (facts.cpu && !cpu).then_some(RoundingEmulation::EIGHT_BITS);
        let profile = DeviceProfile {
            kind: ProfileKind::Hardware,
            unsnapped_depth: false,
            subpixel_bits: facts.subpixel_bits,
            vertex_snapping_emulation: None,
            clears: ClearMode::LoadOp,
            frame_timestamps: FrameTimestamps::Outside,
            depth_formats: facts.depth_formats,
            sample_depth: facts.sample_depth,
        };
        match (cpu, emulation) {
            (true, _) => DeviceProfile {
                kind: ProfileKind::CpuRasterizer,
                unsnapped_depth: facts.unsnapped_depth,
                clears: ClearMode::Command,
                frame_timestamps: FrameTimestamps::Binned,
                ..profile
            },
            (false, Some(e)) => profile.emulating(e),
            (false, None) => DeviceProfile {
                unsnapped_depth: facts.unsnapped_depth && choice == ProfileChoice::Device,
                ..profile
            },
        }
    }

    /// The hardware profile with `emulation`'s vertex snapping, on the same
    /// depth formats: what a test of a coarser device runs with.
    pub fn emulating(self, emulation: RoundingEmulation) -> DeviceProfile {
        DeviceProfile {
            kind: ProfileKind::Hardware,
            unsnapped_depth: false,
            subpixel_bits: emulation.subpixel_bits,
            vertex_snapping_emulation: Some(emulation),
            clears: ClearMode::LoadOp,
            frame_timestamps: FrameTimestamps::Outside,
            depth_formats: self.depth_formats,
            sample_depth: self.sample_depth,
        }
    }

    /// The profile of `physical` under [`PROFILE_ENV`]'s choice; an error
    /// names the variable where its value is not one of the accepted ones.
    /// `PEELTRIM_EMULATE_NO_D32S8=1` emulates a device without D32S8 (the
    /// tests of the D24S8 fallback, on lavapipe, which has it);
    /// `PEELTRIM_EMULATE_NO_D24S8=1` one without D24S8 (as SwiftShader and AMD
    /// GPUs are). `unsnapped_depth` measures the device's depth interpolation
    /// (`vk::depth_probe`; given its subpixel bits and a D32 format it can
    /// draw into); it is not called under the hardware choice, which snaps.
    /// `sample_depth` measures where a program run once per sample reads its
    /// depth (`vk::sample_depth_probe`; given the subpixel bits, the D32
    /// format and the smallest sample count above 1 that the device's
    /// framebuffers have); it is called only where the device has
    /// `sampleRateShading` and such a count, whatever the choice.
    pub fn detect(
        instance: &ash::Instance,
        physical: vk::PhysicalDevice,
        unsnapped_depth: impl FnOnce(u32, Option<vk::Format>) -> Result<bool, VkError>,
        sample_depth: impl FnOnce(u32, vk::Format, u32) -> Result<bool, VkError>,
    ) -> Result<DeviceProfile, VkError> {
        let choice = ProfileChoice::from_env()?;
        // SAFETY: `physical` belongs to `instance`; plain queries.
        let props = unsafe { instance.get_physical_device_properties(physical) };
        let usable = |format: vk::Format| {
            // SAFETY: as above.
            let fp = unsafe { instance.get_physical_device_format_properties(physical, format) };
            fp.optimal_tiling_features.contains(
                vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT
                    | vk::FormatFeatureFlags::SAMPLED_IMAGE
                    | vk::FormatFeatureFlags::TRANSFER_SRC
                    | vk::FormatFeatureFlags::TRANSFER_DST,
            )
        };
        let emulate_no = |v: &str| std::env::var_os(v).is_some_and(|v| v == "1");
        let depth_formats = DepthFormats {
            d32s8: !emulate_no("PEELTRIM_EMULATE_NO_D32S8")
                && usable(vk::Format::D32_SFLOAT_S8_UINT),
            d24s8: !emulate_no("PEELTRIM_EMULATE_NO_D24S8")
                && usable(vk::Format::D24_UNORM_S8_UINT),
            d32: usable(vk::Format::D32_SFLOAT),
        };
        let subpixel_bits = props.limits.sub_pixel_precision_bits;
        let probe_format = [
            (depth_formats.d32, vk::Format::D32_SFLOAT),
            (depth_formats.d32s8, vk::Format::D32_SFLOAT_S8_UINT),
        ]
        .into_iter()
        .find_map(|(ok, f)| ok.then_some(f));
        let unsnapped_depth = match choice {
            ProfileChoice::Hardware => false,
            ProfileChoice::Device => unsnapped_depth(subpixel_bits, probe_format)?,
        };
        let multisampled = super::sample_depth_probe::smallest_count(&props.limits);
        // SAFETY: as above.
        let features = unsafe { instance.get_physical_device_features(physical) };
        let sample_depth = match (probe_format, multisampled) {
            (Some(format), Some(n)) if features.sample_rate_shading == vk::TRUE => {
                sample_depth(subpixel_bits, format, n)?
            }
            _ => false,
        };
        let facts = DeviceFacts {
            cpu: props.device_type == vk::PhysicalDeviceType::CPU,
            unsnapped_depth,
            subpixel_bits,
            depth_formats,
            sample_depth,
        };
        Ok(DeviceProfile::from_facts(facts, choice))
    }

    /// Whether final shades may run depth-`EQUAL` draws where no tie is
    /// possible, on a depth image of `format`: only with unsnapped depth and
    /// D32S8. On D24 the quantized raster depth misses the strict depth bar
    /// that the plane depth at the pixel centre meets (`vk_tests`
    /// `classic_assembly`).
    pub fn depth_equal_shades(&self, format: super::DepthFormat) -> bool {
        self.unsnapped_depth && format == super::DepthFormat::D32S8
    }

    /// What the plan passes (`plan::passes`) read of this profile, on depth
    /// images of `format`.
    pub fn pass_facts(&self, format: super::DepthFormat) -> crate::plan::passes::PassFacts {
        crate::plan::passes::PassFacts {
            subpixel_bits: self.subpixel_bits,
            depth_equal_shades: self.depth_equal_shades(format),
            tie_depth: format == super::DepthFormat::D32S8,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: DepthFormats = DepthFormats {
        d32s8: true,
        d24s8: true,
        d32: true,
    };

    fn facts(cpu: bool) -> DeviceFacts {
        DeviceFacts {
            cpu,
            unsnapped_depth: cpu,
            subpixel_bits: 8,
            depth_formats: ALL,
            sample_depth: true,
        }
    }

    #[test]
    fn env_values_parse_or_name_the_variable() {
        assert_eq!(ProfileChoice::parse(None).unwrap(), ProfileChoice::Device);
        assert_eq!(
            ProfileChoice::parse(Some("device")).unwrap(),
            ProfileChoice::Device
        );
        assert_eq!(
            ProfileChoice::parse(Some("hardware")).unwrap(),
            ProfileChoice::Hardware
        );
        let e = ProfileChoice::parse(Some("gpu")).unwrap_err().to_string();
        assert!(e.contains(PROFILE_ENV) && e.contains("'gpu'"), "{e}");
        assert!(e.contains("device") && e.contains("hardware"), "{e}");
    }

    #[test]
    fn a_cpu_rasterizer_gets_its_own_paths() {
        let p = DeviceProfile::from_facts(facts(true), ProfileChoice::Device);
        assert_eq!(p.kind, ProfileKind::CpuRasterizer);
        assert!(p.unsnapped_depth);
        assert_eq!(p.vertex_snapping_emulation, None);
        assert_eq!(p.clears, ClearMode::Command);
        assert_eq!(p.frame_timestamps, FrameTimestamps::Binned);
        assert!(p.depth_equal_shades(super::super::DepthFormat::D32S8));
        assert!(!p.depth_equal_shades(super::super::DepthFormat::D24S8));
    }

    /// A CPU device whose probe finds snapped depth (SwiftShader) keeps its
    /// CPU clears but gets no depth-equal shade; an unsnapped GPU would.
    #[test]
    fn unsnapped_depth_is_the_measurement_not_the_device_type() {
        let snapping_cpu = DeviceFacts {
            unsnapped_depth: false,
            ..facts(true)
        };
        let p = DeviceProfile::from_facts(snapping_cpu, ProfileChoice::Device);
        assert_eq!(p.kind, ProfileKind::CpuRasterizer);
        assert_eq!(p.clears, ClearMode::Command);
        assert!(!p.unsnapped_depth);
        assert!(!p.depth_equal_shades(super::super::DepthFormat::D32S8));
        let exact_gpu = DeviceFacts {
            unsnapped_depth: true,
            ..facts(false)
        };
        let p = DeviceProfile::from_facts(exact_gpu, ProfileChoice::Device);
        assert_eq!(p.kind, ProfileKind::Hardware);
        assert!(p.depth_equal_shades(super::super::DepthFormat::D32S8));
        let p = DeviceProfile::from_facts(exact_gpu, ProfileChoice::Hardware);
        assert!(!p.unsnapped_depth);
    }

    #[test]
    fn hardware_keeps_its_snapping_unemulated() {
        let facts = DeviceFacts {
            subpixel_bits: 4,
            ..facts(false)
        };
        for choice in [ProfileChoice::Device, ProfileChoice::Hardware] {
            let p = DeviceProfile::from_facts(facts, choice);
            assert_eq!(p.kind, ProfileKind::Hardware);
            assert!(!p.unsnapped_depth);
            assert_eq!(p.subpixel_bits, 4);
            assert_eq!(p.vertex_snapping_emulation, None);
            assert_eq!(p.clears, ClearMode::LoadOp);
            assert_eq!(p.frame_timestamps, FrameTimestamps::Outside);
        }
    }

    #[test]
    fn forced_hardware_on_a_cpu_rasterizer_emulates_eight_bit_snapping() {
        let own = DepthFormats {
            d32s8: false,
            ..ALL
        };
        let facts = DeviceFacts {
            depth_formats: own,
            ..facts(true)
        };
        let p = DeviceProfile::from_facts(facts, ProfileChoice::Hardware);
        assert_eq!(p.kind, ProfileKind::Hardware);
        assert!(!p.unsnapped_depth);
        assert_eq!(
            p.vertex_snapping_emulation,
            Some(RoundingEmulation::EIGHT_BITS)
        );
        assert_eq!(p.subpixel_bits, 8);
        assert_eq!(p.clears, ClearMode::LoadOp);
        assert_eq!(p.frame_timestamps, FrameTimestamps::Outside);
        assert_eq!(p.depth_formats, own);
        assert!(!p.depth_equal_shades(super::super::DepthFormat::D32S8));
    }

    #[test]
    fn depth_formats_answer_for_the_executor_formats_only() {
        let f = DepthFormats {
            d32s8: false,
            d24s8: true,
            d32: true,
        };
        assert!(!f.usable(vk::Format::D32_SFLOAT_S8_UINT));
        assert!(f.usable(vk::Format::D24_UNORM_S8_UINT));
        assert!(f.usable(vk::Format::D32_SFLOAT));
        assert!(!f.usable(vk::Format::D16_UNORM));
    }
}
