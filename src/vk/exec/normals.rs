//! The optional normal buffer (Kirsch, Nienhaus & Döllner §5.2) and the edge pass on
//! it (§5.1): turning it on, reading it back in view space, and the first layer's
//! edge map computed on the GPU (`shaders/edges.frag`; the recorder's `edge_pass`).

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::{whole_image_region, Executor};
use crate::plan::usage::Resource;
use crate::vk::error::VkError;
use crate::vk::instance::Shared;
use crate::vk::memory::Buffer;
use crate::vk::submit::{self, Submitter};
use crate::vk::sync::{self, REST};

impl Executor {
    /// Whether later frames also write the normal buffer (Kirsch, Nienhaus & Döllner
    /// §5.2): every pass that writes colour writes the seen face's normal beside it,
    /// so the final image's normals are those of its visible faces. Off by default
    /// (one more 16-byte target per pixel); [`Executor::read_normals`] reads it.
    pub fn set_normals(&mut self, on: bool) {
        if self.normals != on {
            self.normals = on;
            self.recording = None;
            self.last_output = None;
        }
    }

    /// Whether frames write the normal buffer ([`Executor::set_normals`]).
    pub fn normals(&self) -> bool {
        self.normals
    }

    /// The last frame's normal buffer, in view space (x right, y up, z towards
    /// the viewer), each the unit normal of the visible face turned towards the
    /// eye; zero where nothing was drawn. `None` unless [`Executor::set_normals`]
    /// was on for that frame.
    pub fn read_normals(&mut self) -> Result<Option<Vec<[f32; 3]>>, VkError> {
        let _layer = self.shared.layer_use();
        let Some(bytes) = self.copy_out(Resource::Normal, 16)? else {
            return Ok(None);
        };
        let view = self.scene.as_ref().expect("scene uploaded").camera.view();
        Ok(Some(crate::vk::readback::decode_normals(&bytes, &view)))
    }

    /// The edge map of the last frame's image (its first layer) by the rule of
    /// `render::edges` with thresholds `depth_rel` and `angle_deg`, computed on
    /// the GPU in one full-screen pass (`shaders/edges.frag`) and read back;
    /// `None` unless [`Executor::set_normals`] was on for that frame.
    pub fn edge_map(
        &mut self,
        depth_rel: f64,
        angle_deg: f64,
    ) -> Result<Option<Vec<bool>>, VkError> {
        let _layer = self.shared.layer_use();
        let output = self
            .last_output
            .ok_or_else(|| VkError::Plan("edge_map before execute: no frame".into()))?;
        if !self.normals {
            return Ok(None);
        }
        let cmd = self.submit.cmd;
        let rule = [depth_rel as f32, angle_deg.to_radians().cos() as f32];
        let (mut rec, sub) = self.recorder_and_submitter();
        sub.begin(cmd, true)?;
        rec.edge_pass(cmd, output, rule)?;
        sub.finish(cmd)?;
        drop(rec);
        let bytes = self
            .copy_out(Resource::Edges, 1)?
            .expect("the edge map exists with the normal buffer");
        Ok(Some(bytes.into_iter().map(|v| v >= 128).collect()))
    }

    /// Copies target `r` (`bpp` bytes a pixel, resting in `REST` after a frame)
    /// to the CPU; `None` when the targets lack it.
    pub(super) fn copy_out(&mut self, r: Resource, bpp: u64) -> Result<Option<Vec<u8>>, VkError> {
        if self.last_output.is_none() {
            return Err(VkError::Plan("read-back before execute: no frame".into()));
        }
        let Some(t) = self.targets.as_ref() else {
            return Ok(None);
        };
        if !t.all().contains(&r) {
            return Ok(None);
        }
        let img = t.image(r).raw;
        let (w, h) = (self.desc.width, self.desc.height);
        copy_to_host(&self.shared, &self.submit, img, [w, h], bpp).map(Some)
    }
}

/// Copies colour image `image` (`extent`, `bpp` bytes a pixel, resting in
/// `REST`) to the CPU with `submit`'s command buffer, waited for.
pub(crate) fn copy_to_host(
    shared: &std::sync::Arc<Shared>,
    submit: &Submitter,
    image: vk::Image,
    [w, h]: [u32; 2],
    bpp: u64,
) -> Result<Vec<u8>, VkError> {
    let buf = Buffer::new(
        shared,
        "target readback",
        w as u64 * h as u64 * bpp,
        vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuToCpu,
    )?;
    let cmd = submit.cmd;
    submit.begin(cmd, true)?;
    let region = whole_image_region(vk::ImageAspectFlags::COLOR, 0, w, h);
    let layout = sync::access(REST).layout;
    let device = &shared.device;
    // SAFETY: outside rendering; the image allows transfer src and rests in
    // `layout` (the caller's contract); the region fits the buffer.
    unsafe { device.cmd_copy_image_to_buffer(cmd, image, layout, buf.raw, &[region]) };
    submit::transfer_to_host_barrier(device, cmd);
    submit.finish(cmd)?;
    Ok(buf.mapped()?.to_vec())
}
