//! Presenting finished frames to a window (feature `viewer`): a `VK_KHR_surface`
//! made with `ash-window`, a `VK_KHR_swapchain` on the executor's device and queue,
//! and a host-visible staging buffer copied into the acquired swapchain image.
//!
//! The executor hands back CPU images ([`crate::output::Images`]), so a frame is
//! uploaded once more to present it; the CPU reference goes the same way.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;
use raw_window_handle::{RawDisplayHandle, RawWindowHandle};

use super::error::{Check, VkError};
use super::instance::{Context, ContextDesc, PresentHooks, Shared};
use super::memory::Buffer;
use crate::output::Images;

/// What [`Presenter::present`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Presented {
    /// The image is on screen.
    Shown,
    /// The swapchain was out of date or the window has no area; nothing shown.
    /// Present again (after the window's next resize event).
    Skipped,
}

/// A window's surface and swapchain on a [`Context`]'s device.
pub struct Presenter {
    shared: Arc<Shared>,
    surface_fn: ash::khr::surface::Instance,
    swapchain_fn: ash::khr::swapchain::Device,
    surface: vk::SurfaceKHR,
    command_pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    acquired: vk::Semaphore,
    swapchain: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    /// One per swapchain image: signalled by the copy, waited on by the present.
    copied: Vec<vk::Semaphore>,
    format: vk::Format,
    extent: vk::Extent2D,
    staging: Option<Buffer>,
    /// The swapchain must be rebuilt before the next present.
    stale: bool,
}

impl Presenter {
    /// Creates a context whose device can present to the window, and the window's
    /// surface and swapchain (`size`: the window's inner size in pixels).
    pub fn new(
        desc: &ContextDesc,
        display: RawDisplayHandle,
        window: RawWindowHandle,
        size: [u32; 2],
    ) -> Result<(Context, Presenter), VkError> {
        let instance_extensions = ash_window::enumerate_required_extensions(display)
            .check("ash_window::enumerate_required_extensions")?;
        let create_surface = |entry: &ash::Entry, instance: &ash::Instance| {
            // SAFETY: the handles come from a live window that the caller keeps alive
            // as long as the returned presenter (the viewer owns both and drops the
            // presenter first).
            unsafe { ash_window::create_surface(entry, instance, display, window, None) }
                .check("vkCreateSurfaceKHR")
        };
        let hooks = PresentHooks {
            instance_extensions,
            create_surface: &create_surface,
        };
        let (ctx, surface) = Context::new_inner(desc, Some(&hooks))?;
        let shared = ctx.shared.clone();
        let surface_fn = ash::khr::surface::Instance::new(&shared.entry, &shared.instance);
        let swapchain_fn = ash::khr::swapchain::Device::new(&shared.instance, &shared.device);
        // Build the presenter field by field so its Drop cleans up a partial one.
        let mut p = Presenter {
            shared: shared.clone(),
            surface_fn,
            swapchain_fn,
            surface,
            command_pool: vk::CommandPool::null(),
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            acquired: vk::Semaphore::null(),
            swapchain: vk::SwapchainKHR::null(),
            images: Vec::new(),
            copied: Vec::new(),
            format: vk::Format::UNDEFINED,
            extent: vk::Extent2D::default(),
            staging: None,
            stale: true,
        };
        let device = &shared.device;
        let pool_ci = vk::CommandPoolCreateInfo::default()
            .queue_family_index(shared.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid create info on a live device.
        p.command_pool =
            unsafe { device.create_command_pool(&pool_ci, None) }.check("vkCreateCommandPool")?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(p.command_pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool was just created on this device.
        let cmds =
            unsafe { device.allocate_command_buffers(&alloc) }.check("vkAllocateCommandBuffers")?;
        p.cmd = cmds
            .first()
            .copied()
            .ok_or_else(|| VkError::Plan("no command buffer allocated".into()))?;
        // SAFETY: valid create info.
        p.fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
            .check("vkCreateFence")?;
        // SAFETY: valid create info.
        p.acquired = unsafe { device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
            .check("vkCreateSemaphore")?;
        p.rebuild(size)?;
        Ok((ctx, p))
    }

    /// The swapchain's size (may lag the window's until the next present).
    pub fn extent(&self) -> [u32; 2] {
        [self.extent.width, self.extent.height]
    }

    /// Marks the swapchain for rebuilding (the window was resized).
    pub fn resized(&mut self) {
        self.stale = true;
    }

    fn destroy_swapchain(&mut self) {
        let device = &self.shared.device;
        for s in self.copied.drain(..) {
            // SAFETY: `present` waits on its fence before returning, and the present
            // that waited on this semaphore was queued before that; the device is
            // idle below before the swapchain goes.
            unsafe { device.destroy_semaphore(s, None) };
        }
        self.images.clear();
        if self.swapchain != vk::SwapchainKHR::null() {
            // SAFETY: the device is idle (callers wait), no image is acquired.
            unsafe { self.swapchain_fn.destroy_swapchain(self.swapchain, None) };
            self.swapchain = vk::SwapchainKHR::null();
        }
    }

    /// (Re)creates the swapchain for a window of `size` pixels.
    fn rebuild(&mut self, size: [u32; 2]) -> Result<(), VkError> {
        let shared = self.shared.clone();
        let device = &shared.device;
        // SAFETY: waiting for idle has no preconditions on a live device.
        unsafe { device.device_wait_idle() }.check("vkDeviceWaitIdle")?;
        // SAFETY: the surface belongs to this instance, `physical` too.
        let caps = unsafe {
            self.surface_fn
                .get_physical_device_surface_capabilities(shared.physical, self.surface)
        }
        .check("vkGetPhysicalDeviceSurfaceCapabilitiesKHR")?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: size[0].clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: size[1].clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        self.destroy_swapchain();
        self.extent = extent;
        if extent.width == 0 || extent.height == 0 {
            // Minimized: no swapchain until the window has an area again.
            self.stale = true;
            return Ok(());
        }
        if !caps
            .supported_usage_flags
            .contains(vk::ImageUsageFlags::TRANSFER_DST)
        {
            return Err(VkError::Unsupported(
                "swapchain images as transfer destinations".into(),
            ));
        }
        // SAFETY: as above.
        let formats = unsafe {
            self.surface_fn
                .get_physical_device_surface_formats(shared.physical, self.surface)
        }
        .check("vkGetPhysicalDeviceSurfaceFormatsKHR")?;
        let format = pick_format(&formats).ok_or_else(|| {
            VkError::Unsupported(format!(
                "an 8-bit RGBA/BGRA UNORM swapchain format (the surface offers {:?})",
                formats.iter().map(|f| f.format).collect::<Vec<_>>()
            ))
        })?;
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let alpha = [
            vk::CompositeAlphaFlagsKHR::OPAQUE,
            vk::CompositeAlphaFlagsKHR::INHERIT,
            vk::CompositeAlphaFlagsKHR::PRE_MULTIPLIED,
            vk::CompositeAlphaFlagsKHR::POST_MULTIPLIED,
        ]
        .into_iter()
        .find(|a| caps.supported_composite_alpha.contains(*a))
        .unwrap_or(vk::CompositeAlphaFlagsKHR::OPAQUE);
        let ci = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::TRANSFER_DST)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(alpha)
            // FIFO is the one mode every implementation supports.
            .present_mode(vk::PresentModeKHR::FIFO)
            .clipped(true);
        // SAFETY: valid create info; the surface has no other swapchain (destroyed above).
        self.swapchain = unsafe { self.swapchain_fn.create_swapchain(&ci, None) }
            .check("vkCreateSwapchainKHR")?;
        // SAFETY: the swapchain was just created.
        self.images = unsafe { self.swapchain_fn.get_swapchain_images(self.swapchain) }
            .check("vkGetSwapchainImagesKHR")?;
        for _ in 0..self.images.len() {
            // SAFETY: valid create info.
            let s = unsafe { device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
                .check("vkCreateSemaphore")?;
            self.copied.push(s);
        }
        self.format = format.format;
        self.stale = false;
        Ok(())
    }

    /// Shows `img` in the window (top-left aligned; the rest cleared to `background`).
    /// `size` is the window's current inner size, used when the swapchain is rebuilt.
    pub fn present(
        &mut self,
        img: &Images,
        background: [u8; 3],
        size: [u32; 2],
    ) -> Result<Presented, VkError> {
        if self.stale {
            self.rebuild(size)?;
            if self.stale {
                return Ok(Presented::Skipped);
            }
        }
        let shared = self.shared.clone();
        let device = &shared.device;
        // SAFETY: live swapchain; the semaphore is unsignaled (its last wait finished
        // before the previous present's fence).
        let acquired = unsafe {
            self.swapchain_fn.acquire_next_image(
                self.swapchain,
                u64::MAX,
                self.acquired,
                vk::Fence::null(),
            )
        };
        let index = match acquired {
            Ok((i, suboptimal)) => {
                if suboptimal {
                    self.stale = true;
                }
                i
            }
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.stale = true;
                return Ok(Presented::Skipped);
            }
            Err(e) => {
                return Err(VkError::Call {
                    call: "vkAcquireNextImageKHR",
                    result: e,
                })
            }
        };
        let image = *self
            .images
            .get(index as usize)
            .ok_or_else(|| VkError::Plan("swapchain image index out of range".into()))?;
        let copied = self.copied[index as usize];

        // Staging: the frame's pixels in the swapchain's byte order.
        let bytes = img.width as u64 * img.height as u64 * 4;
        if self.staging.as_ref().map_or(true, |b| b.size != bytes) {
            self.staging = None;
            self.staging = Some(Buffer::new(
                &shared,
                "present staging",
                bytes,
                vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::CpuToGpu,
            )?);
        }
        let staging = self
            .staging
            .as_mut()
            .ok_or_else(|| VkError::Plan("no staging buffer".into()))?;
        let bgra = self.format == vk::Format::B8G8R8A8_UNORM;
        let dst = staging.mapped_mut()?;
        for (d, s) in dst.chunks_exact_mut(4).zip(&img.color) {
            if bgra {
                d.copy_from_slice(&[s[2], s[1], s[0], 255]);
            } else {
                d.copy_from_slice(&[s[0], s[1], s[2], 255]);
            }
        }
        let staging_raw = staging.raw;

        let cmd = self.cmd;
        let range = vk::ImageSubresourceRange::default()
            .aspect_mask(vk::ImageAspectFlags::COLOR)
            .level_count(1)
            .layer_count(1);
        let to_dst = vk::ImageMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::empty())
            .dst_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .old_layout(vk::ImageLayout::UNDEFINED)
            .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(range);
        let between = vk::ImageMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .new_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(range);
        let to_present = vk::ImageMemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::empty())
            .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
            .new_layout(vk::ImageLayout::PRESENT_SRC_KHR)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image)
            .subresource_range(range);
        let bg = [
            background[0] as f32 / 255.0,
            background[1] as f32 / 255.0,
            background[2] as f32 / 255.0,
            1.0,
        ];
        // Clear values name components (R, G, B, A), whatever the byte order.
        let clear = vk::ClearColorValue { float32: bg };
        let region = vk::BufferImageCopy::default()
            .buffer_offset(0)
            .buffer_row_length(img.width)
            .buffer_image_height(img.height)
            .image_subresource(
                vk::ImageSubresourceLayers::default()
                    .aspect_mask(vk::ImageAspectFlags::COLOR)
                    .layer_count(1),
            )
            .image_extent(vk::Extent3D {
                width: img.width.min(self.extent.width),
                height: img.height.min(self.extent.height),
                depth: 1,
            });
        // SAFETY: not in use: the previous present waited on the fence.
        unsafe { device.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()) }
            .check("vkResetCommandBuffer")?;
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: the buffer was just reset.
        unsafe { device.begin_command_buffer(cmd, &begin) }.check("vkBeginCommandBuffer")?;
        // SAFETY: recording; `image` is a live swapchain image acquired for this frame.
        unsafe {
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[to_dst],
            )
        };
        // SAFETY: recording; the image is in TRANSFER_DST_OPTIMAL after the barrier.
        unsafe {
            device.cmd_clear_color_image(
                cmd,
                image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &clear,
                &[range],
            )
        };
        // SAFETY: recording; orders the clear before the copy.
        unsafe {
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[between],
            )
        };
        if region.image_extent.width > 0 && region.image_extent.height > 0 {
            // SAFETY: recording; the staging buffer holds `width * height` texels and
            // the region stays inside both buffer and image.
            unsafe {
                device.cmd_copy_buffer_to_image(
                    cmd,
                    staging_raw,
                    image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &[region],
                )
            };
        }
        // SAFETY: recording; hands the image to the presentation engine.
        unsafe {
            device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[to_present],
            )
        };
        // SAFETY: recording, no open render pass.
        unsafe { device.end_command_buffer(cmd) }.check("vkEndCommandBuffer")?;
        let cmds = [cmd];
        let waits = [self.acquired];
        let stages = [vk::PipelineStageFlags::TRANSFER];
        let signals = [copied];
        let si = [vk::SubmitInfo::default()
            .wait_semaphores(&waits)
            .wait_dst_stage_mask(&stages)
            .command_buffers(&cmds)
            .signal_semaphores(&signals)];
        let swapchains = [self.swapchain];
        let indices = [index];
        let pi = vk::PresentInfoKHR::default()
            .wait_semaphores(&signals)
            .swapchains(&swapchains)
            .image_indices(&indices);
        let presented = {
            let _queue = shared.queue_lock.lock();
            // SAFETY: the command buffer is executable, the fence unsignaled, the
            // semaphores as described above; the lock serializes queue access.
            unsafe { device.queue_submit(shared.queue, &si, self.fence) }.check("vkQueueSubmit")?;
            // SAFETY: `index` was acquired from this swapchain; its copy signals `copied`.
            unsafe { self.swapchain_fn.queue_present(shared.queue, &pi) }
        };
        // SAFETY: the fence was just submitted.
        unsafe { device.wait_for_fences(&[self.fence], true, u64::MAX) }
            .check("vkWaitForFences")?;
        // SAFETY: the fence is signaled and no longer in use.
        unsafe { device.reset_fences(&[self.fence]) }.check("vkResetFences")?;
        match presented {
            Ok(false) => Ok(Presented::Shown),
            Ok(true) => {
                self.stale = true;
                Ok(Presented::Shown)
            }
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.stale = true;
                Ok(Presented::Skipped)
            }
            Err(e) => Err(VkError::Call {
                call: "vkQueuePresentKHR",
                result: e,
            }),
        }
    }
}

/// An 8-bit UNORM swapchain format (the rendered bytes are copied as they are).
fn pick_format(formats: &[vk::SurfaceFormatKHR]) -> Option<vk::SurfaceFormatKHR> {
    [vk::Format::B8G8R8A8_UNORM, vk::Format::R8G8B8A8_UNORM]
        .into_iter()
        .find_map(|want| formats.iter().find(|f| f.format == want).copied())
}

impl Drop for Presenter {
    fn drop(&mut self) {
        let shared = self.shared.clone();
        let device = &shared.device;
        // SAFETY: waiting for idle makes destroying everything below legal; a lost
        // device is idle too, so the result is not needed.
        let _ = unsafe { device.device_wait_idle() };
        self.staging = None;
        self.destroy_swapchain();
        // Idle device; each handle was created here (or is null, which the destroy
        // calls accept) and is destroyed once, in reverse creation order.
        // SAFETY: as above.
        unsafe { device.destroy_semaphore(self.acquired, None) };
        // SAFETY: as above.
        unsafe { device.destroy_fence(self.fence, None) };
        // SAFETY: as above; destroying the pool frees its command buffer.
        unsafe { device.destroy_command_pool(self.command_pool, None) };
        // SAFETY: as above; the swapchain on this surface was destroyed first.
        unsafe { self.surface_fn.destroy_surface(self.surface, None) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefers_bgra_unorm_then_rgba_unorm() {
        let f = |format| vk::SurfaceFormatKHR {
            format,
            color_space: vk::ColorSpaceKHR::SRGB_NONLINEAR,
        };
        let offered = [f(vk::Format::B8G8R8A8_SRGB), f(vk::Format::R8G8B8A8_UNORM)];
        assert_eq!(
            pick_format(&offered).map(|f| f.format),
            Some(vk::Format::R8G8B8A8_UNORM)
        );
        let offered = [f(vk::Format::R8G8B8A8_UNORM), f(vk::Format::B8G8R8A8_UNORM)];
        assert_eq!(
            pick_format(&offered).map(|f| f.format),
            Some(vk::Format::B8G8R8A8_UNORM)
        );
        assert_eq!(pick_format(&[f(vk::Format::B8G8R8A8_SRGB)]), None);
    }
}
