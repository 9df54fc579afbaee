//! Buffers with gpu-allocator memory: the vertex buffer and readback buffers.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::error::{Check, VkError};
use super::instance::Shared;

/// Allocates and binds memory for `requirements` (used by buffers and images).
pub(crate) fn allocate(
    shared: &Shared,
    name: &str,
    requirements: vk::MemoryRequirements,
    location: MemoryLocation,
    linear: bool,
) -> Result<Allocation, VkError> {
    let mut guard = shared
        .allocator
        .lock()
        .map_err(|_| VkError::Plan("allocator lock poisoned".into()))?;
    let allocator = guard
        .as_mut()
        .ok_or_else(|| VkError::Plan("allocator already dropped".into()))?;
    Ok(allocator.allocate(&AllocationCreateDesc {
        name,
        requirements,
        location,
        linear,
        allocation_scheme: AllocationScheme::GpuAllocatorManaged,
    })?)
}

pub(crate) fn free(shared: &Shared, allocation: Allocation) {
    if let Ok(mut guard) = shared.allocator.lock() {
        if let Some(a) = guard.as_mut() {
            // A failed free only leaks; the allocator reports it on shutdown.
            let _ = a.free(allocation);
        }
    }
}

/// A buffer that owns its memory.
pub struct Buffer {
    shared: Arc<Shared>,
    pub(crate) raw: vk::Buffer,
    allocation: Option<Allocation>,
    pub size: u64,
}

impl Buffer {
    pub(crate) fn new(
        shared: &Arc<Shared>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Buffer, VkError> {
        let ci = vk::BufferCreateInfo::default()
            .size(size.max(4))
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid create info on a live device.
        let raw = unsafe { shared.device.create_buffer(&ci, None) }.check("vkCreateBuffer")?;
        let mut buffer = Buffer {
            shared: shared.clone(),
            raw,
            allocation: None,
            size,
        };
        // SAFETY: `raw` is a live buffer of this device.
        let req = unsafe { shared.device.get_buffer_memory_requirements(raw) };
        let allocation = allocate(shared, name, req, location, true)?;
        // SAFETY: the allocation satisfies `req`; the buffer has no memory bound yet.
        unsafe {
            shared
                .device
                .bind_buffer_memory(raw, allocation.memory(), allocation.offset())
        }
        .check("vkBindBufferMemory")?;
        buffer.allocation = Some(allocation);
        Ok(buffer)
    }

    /// The mapped bytes of a host-visible buffer.
    pub(crate) fn mapped(&self) -> Result<&[u8], VkError> {
        self.allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .map(|s| &s[..self.size as usize])
            .ok_or_else(|| VkError::Plan("buffer is not host visible".into()))
    }

    pub(crate) fn mapped_mut(&mut self) -> Result<&mut [u8], VkError> {
        let size = self.size as usize;
        self.allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .map(|s| &mut s[..size])
            .ok_or_else(|| VkError::Plan("buffer is not host visible".into()))
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        let _layer = self.shared.layer_use();
        // SAFETY: the owner waits for the GPU to finish with the buffer before
        // dropping it (executors wait on their fence after every submission).
        unsafe { self.shared.device.destroy_buffer(self.raw, None) };
        if let Some(a) = self.allocation.take() {
            free(&self.shared, a);
        }
    }
}
