//! Copies a frame's colour, primitive ids and output depth to the CPU
//! (`vk::readback` decodes them into [`Images`]).

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::{gpu_scene, Executor};
use crate::images::Images;
use crate::vk::error::VkError;
use crate::vk::memory::Buffer;
use crate::vk::readback::{decode, Raw};
use crate::vk::resolve::{Resolve, Sources};
use crate::vk::submit;
use crate::vk::sync::{self, REST};

impl Executor {
    /// Copies the last frame's colour, primitive ids and output depth to the CPU.
    pub fn read_back(&mut self) -> Result<Images, VkError> {
        let _layer = self.shared.layer_use();
        let output = self
            .last_output
            .ok_or_else(|| VkError::Plan("read_back before execute: no frame".into()))?;
        let (w, h) = (self.desc.width, self.desc.height);
        let plane = w as u64 * h as u64 * 4;
        if self.readback.as_ref().map(|b| b.size) != Some(plane * 3) {
            self.readback = None;
            self.readback = Some(Buffer::new(
                &self.shared,
                "readback",
                plane * 3,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?);
        }
        let device = &self.shared.device;
        let cmd = self.submit.cmd;
        let buffer = self.readback.as_ref().map(|b| b.raw).unwrap_or_default();
        let t = self.targets.as_ref().expect("a frame was executed");
        let samples = self.desc.samples;
        let key = (t.ds_format, [w, h]);
        if samples > 1 && self.resolve.as_ref().map(|r| r.key) != Some(key) {
            self.resolve = None;
            self.resolve = Some(Resolve::new(&self.shared, key.0, key.1)?);
        }
        self.submit.begin(cmd, true)?;
        let ds = &t.ds[output as usize];
        // A multisampled frame is copied from its resolve (`vk::resolve`).
        let (color, prim, depth) = match (&self.resolve, samples > 1) {
            (Some(r), true) => {
                let src = Sources {
                    color: &t.color,
                    prim: &t.prim,
                    depth: ds,
                    samples,
                };
                r.record(cmd, &src, self.pipelines.sampler);
                (&r.color, &r.prim, &r.depth)
            }
            _ => (&t.color, &t.prim, ds),
        };
        let copies = [
            (color, vk::ImageAspectFlags::COLOR, 0),
            (prim, vk::ImageAspectFlags::COLOR, plane),
            (depth, vk::ImageAspectFlags::DEPTH, plane * 2),
        ];
        // Frames leave every image in `REST`, a copy source.
        let layout = sync::access(REST).layout;
        for (img, aspect, offset) in copies {
            let region = whole_image_region(aspect, offset, w, h);
            // SAFETY: outside rendering; the image allows transfer src and rests in
            // `layout`; the region fits the buffer.
            unsafe { device.cmd_copy_image_to_buffer(cmd, img.raw, layout, buffer, &[region]) };
        }
        submit::transfer_to_host_barrier(device, cmd);
        self.submit.finish(cmd)?;
        let bytes = self
            .readback
            .as_ref()
            .map(|b| b.mapped())
            .transpose()?
            .unwrap_or(&[]);
        let scene = self.scene.as_ref().expect("scene uploaded");
        let plane = plane as usize;
        // The resolve's alpha is the coverage (`shaders/resolve.frag`).
        self.coverage = (samples > 1).then(|| bytes[3..plane].iter().step_by(4).copied().collect());
        Ok(decode(
            Raw {
                width: w,
                height: h,
                color: &bytes[..plane],
                prim: &bytes[plane..2 * plane],
                depth: &bytes[2 * plane..3 * plane],
            },
            self.desc.depth_format,
            &scene.camera,
            gpu_scene::convention(&self.desc),
            scene.background,
        ))
    }
}

/// A copy of a whole `w × h` image aspect to `offset` of a tightly packed buffer.
pub(super) fn whole_image_region(
    aspect: vk::ImageAspectFlags,
    offset: u64,
    w: u32,
    h: u32,
) -> vk::BufferImageCopy {
    vk::BufferImageCopy {
        buffer_offset: offset,
        buffer_row_length: 0,
        buffer_image_height: 0,
        image_subresource: vk::ImageSubresourceLayers {
            aspect_mask: aspect,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        },
        image_offset: vk::Offset3D::default(),
        image_extent: vk::Extent3D {
            width: w,
            height: h,
            depth: 1,
        },
    }
}
