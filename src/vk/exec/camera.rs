//! The camera as data on the GPU: a uniform buffer the shaders read the
//! view-projection matrix and the eye from (`shaders/camera.glsl`), so a
//! recording does not depend on the camera and a camera move replays it.
//!
//! The standalone executor writes the buffer from the host before it submits (it
//! waits for every frame, so no frame is reading it then). An embedded frame is
//! recorded into a host's command buffer while earlier frames may still be in
//! flight, so it writes the buffer in the command stream instead
//! ([`CameraBuffer::record_update`], ordered after those frames' reads).

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::gpu_scene::CameraState;
use crate::vk::error::{Check, VkError};
use crate::vk::instance::Shared;
use crate::vk::memory::Buffer;
use crate::vk::submit;

/// Bytes of the uniform block: `mat4 mvp; vec4 view;`.
pub(super) const CAMERA_SIZE: usize = 80;

/// The block's bytes for `cam` (std140: column-major matrix, then the vector).
pub(super) fn camera_bytes(cam: &CameraState) -> [u8; CAMERA_SIZE] {
    let mut out = [0u8; CAMERA_SIZE];
    for (i, f) in cam.mvp.iter().chain(&cam.view_vec).enumerate() {
        out[i * 4..i * 4 + 4].copy_from_slice(&f.to_ne_bytes());
    }
    out
}

/// The camera's uniform buffer and its descriptor set (set 1 of every pipeline).
pub(super) struct CameraBuffer {
    shared: Arc<Shared>,
    buffer: Buffer,
    pool: vk::DescriptorPool,
    pub set: vk::DescriptorSet,
}

impl CameraBuffer {
    pub fn new(shared: &Arc<Shared>, layout: vk::DescriptorSetLayout) -> Result<Self, VkError> {
        let buffer = Buffer::new(
            shared,
            "camera",
            CAMERA_SIZE as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::CpuToGpu,
        )?;
        let sizes = [vk::DescriptorPoolSize {
            ty: vk::DescriptorType::UNIFORM_BUFFER,
            descriptor_count: 1,
        }];
        let pci = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: valid create info on a live device.
        let pool = unsafe { shared.device.create_descriptor_pool(&pci, None) }
            .check("vkCreateDescriptorPool")?;
        let mut cb = CameraBuffer {
            shared: shared.clone(),
            buffer,
            pool,
            set: vk::DescriptorSet::null(),
        };
        let layouts = [layout];
        let ai = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(pool)
            .set_layouts(&layouts);
        // SAFETY: the pool has room for exactly this set.
        cb.set = unsafe { shared.device.allocate_descriptor_sets(&ai) }
            .check("vkAllocateDescriptorSets")?[0];
        let info = [vk::DescriptorBufferInfo {
            buffer: cb.buffer.raw,
            offset: 0,
            range: CAMERA_SIZE as u64,
        }];
        let write = vk::WriteDescriptorSet::default()
            .dst_set(cb.set)
            .dst_binding(0)
            .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
            .buffer_info(&info);
        // SAFETY: set and buffer are live; the set is not in use yet.
        unsafe { shared.device.update_descriptor_sets(&[write], &[]) };
        Ok(cb)
    }

    /// Writes `cam` from the host. The caller guarantees that no submitted frame
    /// still reads the buffer (the standalone executor waits for each frame).
    pub fn write(&mut self, cam: &CameraState) -> Result<(), VkError> {
        self.buffer
            .mapped_mut()?
            .copy_from_slice(&camera_bytes(cam));
        Ok(())
    }

    /// Records a write of `cam` into `cmd` (outside rendering), ordered after the
    /// shader reads of every earlier command on the queue and before those of
    /// later ones.
    pub fn record_update(&self, cmd: vk::CommandBuffer, cam: &CameraState) {
        let device = &self.shared.device;
        let shaders =
            vk::PipelineStageFlags::VERTEX_SHADER | vk::PipelineStageFlags::FRAGMENT_SHADER;
        // Earlier frames' reads finish before the write (write-after-read: an
        // execution dependency suffices).
        submit::memory_barrier(
            device,
            cmd,
            (shaders, vk::AccessFlags::empty()),
            (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::empty()),
        );
        // SAFETY: outside rendering; the buffer allows transfer dst and holds
        // `CAMERA_SIZE` bytes (a multiple of 4, under 65536).
        unsafe { device.cmd_update_buffer(cmd, self.buffer.raw, 0, &camera_bytes(cam)) };
        submit::memory_barrier(
            device,
            cmd,
            (
                vk::PipelineStageFlags::TRANSFER,
                vk::AccessFlags::TRANSFER_WRITE,
            ),
            (shaders, vk::AccessFlags::UNIFORM_READ),
        );
    }
}

impl Drop for CameraBuffer {
    fn drop(&mut self) {
        let _layer = self.shared.layer_use();
        // SAFETY: the executor waited for the GPU; destroying the pool frees its set.
        unsafe { self.shared.device.destroy_descriptor_pool(self.pool, None) };
    }
}
