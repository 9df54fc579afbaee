//! Transparency composited on the GPU (Hable & Rossignac §6): each peeled layer is
//! blended front to back into an accumulation target right after the plan
//! that peeled it (`shaders/accumulate.frag`, the recorder's
//! `accumulate_pass`), so a transparent frame reads back one image, not every
//! layer. The caller peels the layers in front-to-back order per pixel.

use ash::vk;

use super::targets::format;
use super::Executor;
use crate::plan::usage::Resource;
use crate::vk::error::VkError;

impl Executor {
    /// Whether later frames keep the accumulate pass's images (an `f32` RGBA
    /// target and the opacity table). Returns whether it is on: `false` when
    /// asked but the device cannot blend into the accumulation format (the
    /// caller then composites on the CPU).
    pub fn set_transparency(&mut self, on: bool) -> Result<bool, VkError> {
        let _layer = self.shared.layer_use();
        let fmt = format(Resource::Accum);
        // SAFETY: physical device of this instance; plain query.
        let props = unsafe {
            self.shared
                .instance
                .get_physical_device_format_properties(self.shared.physical, fmt)
        };
        let on = on
            && props
                .optimal_tiling_features
                .contains(vk::FormatFeatureFlags::COLOR_ATTACHMENT_BLEND);
        if self.transparency != on {
            self.transparency = on;
            self.recording = None;
            self.last_output = None;
        }
        Ok(on)
    }

    /// Blends the last frame's layer into the accumulation target (see
    /// `Recorder::accumulate_pass`). `alpha`: given for the first layer of a
    /// composite, which starts the target from zero; the opacity of primitive
    /// id `p` is `alpha[p]` (1 beyond its end). Needs
    /// [`Executor::set_transparency`] on before the frame.
    pub fn accumulate(&mut self, alpha: Option<&[f32]>) -> Result<(), VkError> {
        let _layer = self.shared.layer_use();
        if self.last_output.is_none() {
            return Err(VkError::Plan("accumulate before execute: no frame".into()));
        }
        assert!(
            self.transparency,
            "accumulate needs set_transparency(true) before the frame"
        );
        let staging = alpha
            .map(|a| super::sequence::alpha_staging(&self.shared, a))
            .transpose()?;
        let cmd = self.submit.cmd;
        let (mut rec, sub) = self.recorder_and_submitter();
        sub.begin(cmd, true)?;
        rec.accumulate_pass(cmd, staging.as_ref())?;
        sub.finish(cmd)?;
        Ok(())
    }

    /// The accumulation target: per pixel, row-major, the premultiplied colour
    /// `C` (0..1 per channel) and the coverage `A` of the layers blended so far.
    pub fn read_accumulation(&mut self) -> Result<Vec<[f32; 4]>, VkError> {
        let _layer = self.shared.layer_use();
        let bytes = self
            .copy_out(Resource::Accum, 16)?
            .ok_or_else(|| VkError::Plan("read_accumulation without set_transparency".into()))?;
        Ok(bytes
            .chunks_exact(16)
            .map(|p| {
                let f = |k: usize| f32::from_ne_bytes([p[k], p[k + 1], p[k + 2], p[k + 3]]);
                [f(0), f(4), f(8), f(12)]
            })
            .collect())
    }
}
