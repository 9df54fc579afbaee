//! What the device can hold, checked before the executor allocates its images:
//! the image sides against `maxImageDimension2D`, and the images' bytes against
//! the largest device-local memory heap. A request past either is refused with
//! the device's figure and the way out, rather than failing (or, on some drivers,
//! crashing) inside `vkCreateImage` / `vkAllocateMemory`.

use ash::vk;

use super::error::VkError;
use super::instance::Context;

impl Context {
    /// `maxImageDimension2D` of the device.
    pub fn max_image_side(&self) -> u32 {
        self.shared.limits.max_image_dimension2_d
    }

    /// Size of the largest device-local memory heap, in bytes.
    pub fn device_local_bytes(&self) -> u64 {
        let s = &self.shared;
        let _layer = s.layer_use();
        // SAFETY: `physical` was enumerated from `instance`, which is alive for as
        // long as `shared` is; the call only reads properties.
        let props = unsafe { s.instance.get_physical_device_memory_properties(s.physical) };
        props
            .memory_heaps_as_slice()
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0)
    }

    /// Refuses a `width`×`height` frame whose sides exceed the device's limit or
    /// whose images (`bytes_per_pixel` in all) exceed its device-local memory.
    pub fn check_frame_size(
        &self,
        width: u32,
        height: u32,
        bytes_per_pixel: u64,
    ) -> Result<(), VkError> {
        let max = self.max_image_side();
        if width > max || height > max {
            return Err(VkError::FrameTooLarge(format!(
                "{width}x{height} exceeds this device's largest image side, {max} pixels \
                 (maxImageDimension2D of {}); use a smaller --size",
                self.device_name()
            )));
        }
        let need = width as u64 * height as u64 * bytes_per_pixel;
        let heap = self.device_local_bytes();
        if heap > 0 && need > heap {
            return Err(VkError::FrameTooLarge(format!(
                "{width}x{height} needs about {} of device memory for its images, more than {} \
                 has ({}); use a smaller --size",
                crate::budget::human(need),
                self.device_name(),
                crate::budget::human(heap)
            )));
        }
        Ok(())
    }
}
