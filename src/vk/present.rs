//! Presenting finished frames to a window (feature `viewer`): a `VK_KHR_surface`
//! made with `ash-window`, a `VK_KHR_swapchain` on the executor's device and queue,
//! and a host-visible staging buffer copied into the acquired swapchain image.
//!
//! The viewer is an embedding host ([`Presenter::present_recorded`]): each frame
//! clears the acquired swapchain image and the presenter's own depth buffer, lets
//! the caller record peeltrim's CSG into them (`vk::Embedder::record`), and
//! presents, with [`FRAMES_IN_FLIGHT`] frames submitted before the CPU waits for
//! the oldest. The CPU reference's images go through a staging buffer
//! ([`Presenter::present`], which waits for its copy).

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;
use raw_window_handle::{RawDisplayHandle, RawWindowHandle};

use super::embed::Embedder;
use super::error::{Check, VkError};
use super::exec::ExecStats;
use super::host_frame::{host_depth_format, record_host_frame, HostAttachments, COLOR_ATTACHMENT};
use super::image::{Image, ImageDesc};
use super::instance::{Context, ContextDesc, PresentHooks, Shared};
use super::memory::Buffer;
use super::submit::{self, Submitter};
use crate::images::Images;

/// Frames [`Presenter::present_recorded`] keeps submitted before waiting.
pub const FRAMES_IN_FLIGHT: u32 = 2;

/// One frame of `present_recorded`: its command buffer and fence, and the
/// semaphore its acquire signals.
struct InFlight {
    submit: Submitter,
    acquired: vk::Semaphore,
    pending: bool,
}

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
    submit: Option<Submitter>,
    acquired: vk::Semaphore,
    swapchain: vk::SwapchainKHR,
    images: Vec<vk::Image>,
    /// Colour-attachment views of `images`.
    views: Vec<vk::ImageView>,
    /// One per swapchain image: signalled by the copy, waited on by the present.
    copied: Vec<vk::Semaphore>,
    /// The host's depth buffer, at the swapchain's size and `samples`.
    depth: Option<Image>,
    /// Samples per pixel of the embedded frames ([`Presenter::set_samples`]).
    samples: u32,
    /// With `samples` above 1: the multisampled colour attachment the CSG is
    /// recorded into, resolved into the swapchain image.
    ms_color: Option<Image>,
    frames: Vec<InFlight>,
    next: usize,
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
        let _layer = shared.layer_use();
        let surface_fn = ash::khr::surface::Instance::new(&shared.entry, &shared.instance);
        let swapchain_fn = ash::khr::swapchain::Device::new(&shared.instance, &shared.device);
        // Build the presenter field by field so its Drop cleans up a partial one.
        let mut p = Presenter {
            shared: shared.clone(),
            surface_fn,
            swapchain_fn,
            surface,
            submit: None,
            acquired: vk::Semaphore::null(),
            swapchain: vk::SwapchainKHR::null(),
            images: Vec::new(),
            views: Vec::new(),
            copied: Vec::new(),
            depth: None,
            samples: 1,
            ms_color: None,
            frames: Vec::new(),
            next: 0,
            format: vk::Format::UNDEFINED,
            extent: vk::Extent2D::default(),
            staging: None,
            stale: true,
        };
        let device = &shared.device;
        p.submit = Some(Submitter::new(&shared)?);
        // SAFETY: valid create info.
        p.acquired = unsafe { device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
            .check("vkCreateSemaphore")?;
        for _ in 0..FRAMES_IN_FLIGHT {
            let submit = Submitter::new(&shared)?;
            // SAFETY: valid create info.
            let acquired =
                unsafe { device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
                    .check("vkCreateSemaphore")?;
            p.frames.push(InFlight {
                submit,
                acquired,
                pending: false,
            });
        }
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

    /// Samples per pixel of the frames [`Presenter::present_recorded`] draws
    /// (one of `Context::supported_samples`; the embedder's): above 1 the
    /// host's colour and depth are multisampled and resolved into the
    /// swapchain image. Rebuilds the images with the swapchain.
    pub fn set_samples(&mut self, samples: u32) {
        if samples != self.samples {
            self.samples = samples;
            self.stale = true;
        }
    }

    /// Samples per pixel of the recorded frames.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    fn destroy_swapchain(&mut self) {
        let device = &self.shared.device;
        for s in self.copied.drain(..) {
            // SAFETY: `present` waits on its fence before returning, and the present
            // that waited on this semaphore was queued before that; the device is
            // idle below before the swapchain goes.
            unsafe { device.destroy_semaphore(s, None) };
        }
        for v in self.views.drain(..) {
            // SAFETY: the device is idle (callers wait); no frame uses the view.
            unsafe { device.destroy_image_view(v, None) };
        }
        self.images.clear();
        self.depth = None;
        self.ms_color = None;
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
        let usage = vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::COLOR_ATTACHMENT;
        if !caps.supported_usage_flags.contains(usage) {
            return Err(VkError::Unsupported(
                "swapchain images as transfer destinations and colour attachments".into(),
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
            .image_usage(usage)
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
        for &image in &self.images {
            // SAFETY: valid create info.
            let s = unsafe { device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
                .check("vkCreateSemaphore")?;
            self.copied.push(s);
            let vci = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format.format)
                .subresource_range(color_range());
            // SAFETY: a view of a live swapchain image in its own format.
            let v = unsafe { device.create_image_view(&vci, None) }.check("vkCreateImageView")?;
            self.views.push(v);
        }
        let size = [extent.width, extent.height];
        self.depth = Some(Image::new(
            &shared,
            "view depth",
            ImageDesc::new_2d(host_depth_format(&shared), size)
                .usage(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT)
                .samples(self.samples),
        )?);
        if self.samples > 1 {
            self.ms_color = Some(Image::new(
                &shared,
                "view colour",
                ImageDesc::new_2d(format.format, size)
                    .usage(
                        vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
                    )
                    .samples(self.samples),
            )?);
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
        let _layer = self.shared.layer_use();
        if !self.ready(size)? {
            return Ok(Presented::Skipped);
        }
        // Staging: the frame's pixels in the swapchain's byte order.
        let bytes = img.width as u64 * img.height as u64 * 4;
        if self.staging.as_ref().map_or(true, |b| b.size != bytes) {
            self.staging = None;
            self.staging = Some(Buffer::new(
                &self.shared,
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
        let (w, h) = (img.width, img.height);
        self.present_with(background, |device, cmd, image, extent| {
            let region = vk::BufferImageCopy::default()
                .buffer_offset(0)
                .buffer_row_length(w)
                .buffer_image_height(h)
                .image_subresource(
                    vk::ImageSubresourceLayers::default()
                        .aspect_mask(vk::ImageAspectFlags::COLOR)
                        .layer_count(1),
                )
                .image_extent(vk::Extent3D {
                    width: w.min(extent.width),
                    height: h.min(extent.height),
                    depth: 1,
                });
            if region.image_extent.width > 0 && region.image_extent.height > 0 {
                // SAFETY: recording; the staging buffer holds `w * h` texels and the
                // region stays inside both buffer and image (in TRANSFER_DST_OPTIMAL).
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
        })
    }

    /// Waits for every frame [`Presenter::present_recorded`] submitted (before
    /// anything those frames use changes: a new plan's images, a resize).
    pub fn wait_frames(&mut self) -> Result<(), VkError> {
        let _layer = self.shared.layer_use();
        for f in &mut self.frames {
            if f.pending {
                f.submit.wait()?;
                f.pending = false;
            }
        }
        Ok(())
    }

    /// One host frame: acquires a swapchain image, clears it to `background` and
    /// the presenter's depth buffer to `far_depth`, records `embedder`'s CSG into
    /// them ([`Embedder::record`]), and presents. Waits only for the frame
    /// [`FRAMES_IN_FLIGHT`] frames back, whose command buffer it reuses, so
    /// `embedder` must have been made for that many frames in flight. When the
    /// swapchain's size is not the embedder's (a resize), the frame shows the
    /// background only and no stats are returned.
    pub fn present_recorded(
        &mut self,
        background: [u8; 3],
        far_depth: f32,
        size: [u32; 2],
        embedder: &mut Embedder,
    ) -> Result<(Presented, Option<ExecStats>), VkError> {
        let _layer = self.shared.layer_use();
        if !self.ready(size)? {
            return Ok((Presented::Skipped, None));
        }
        let shared = self.shared.clone();
        let device = &shared.device;
        let slot = self.next;
        let frame = &mut self.frames[slot];
        if frame.pending {
            frame.submit.wait()?;
            frame.pending = false;
        }
        // SAFETY: live swapchain; the frame's semaphore is unsignaled (the submit
        // that waited on it completed: its fence was waited for above).
        let acquired = unsafe {
            self.swapchain_fn.acquire_next_image(
                self.swapchain,
                u64::MAX,
                frame.acquired,
                vk::Fence::null(),
            )
        };
        let index = match acquired {
            Ok((i, suboptimal)) => {
                self.stale |= suboptimal;
                i as usize
            }
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.stale = true;
                return Ok((Presented::Skipped, None));
            }
            Err(e) => {
                return Err(VkError::Call {
                    call: "vkAcquireNextImageKHR",
                    result: e,
                })
            }
        };
        let (image, view) = (self.images[index], self.views[index]);
        let depth = self.depth.as_ref().expect("made with the swapchain");
        let cmd = frame.submit.cmd;
        frame.submit.begin(cmd, true)?;
        let extent = self.extent;
        // Multisampled: the CSG into the presenter's own colour, resolved
        // into the swapchain image below.
        let target = match &self.ms_color {
            Some(ms) => (ms.raw, ms.view),
            None => (image, view),
        };
        let att = HostAttachments {
            color: (target.0, target.1, self.format),
            depth,
            extent,
        };
        // SAFETY: `cmd` records outside rendering on the context's queue family
        // and is submitted below to its queue; the swapchain image was acquired
        // (its semaphore is waited for before the barrier's stage) and the views
        // live as long as the swapchain, which is rebuilt only after the device
        // idles; at most FRAMES_IN_FLIGHT frames are pending (the fence wait
        // above), in recording order on one queue; the caller made the embedder
        // for that many.
        let stats =
            unsafe { record_host_frame(device, cmd, &att, background, far_depth, embedder) }?;
        let present = super::sync::Access {
            stage: vk::PipelineStageFlags::BOTTOM_OF_PIPE,
            access: vk::AccessFlags::empty(),
            layout: vk::ImageLayout::PRESENT_SRC_KHR,
        };
        let written = match &self.ms_color {
            Some(ms) => {
                resolve_into(device, cmd, ms, image, extent);
                TRANSFER_DST
            }
            None => COLOR_ATTACHMENT,
        };
        // The acquire is waited for where the swapchain image is first
        // touched: the colour pass, or the resolve's barrier from that stage.
        let attach = COLOR_ATTACHMENT.stage;
        let to_present =
            super::sync::image_barrier(written, present, image, vk::ImageAspectFlags::COLOR);
        submit::image_barriers(device, cmd, written.stage, present.stage, &[to_present]);
        frame.submit.end(cmd)?;
        let copied = self.copied[index];
        frame
            .submit
            .submit(cmd, &[(frame.acquired, attach)], &[copied])?;
        frame.pending = true;
        self.next = (slot + 1) % self.frames.len();
        Ok((self.queue_present(index as u32, copied)?, stats))
    }

    /// Rebuilds a stale swapchain; false when there is nothing to present to.
    fn ready(&mut self, size: [u32; 2]) -> Result<bool, VkError> {
        if self.stale {
            self.rebuild(size)?;
        }
        Ok(!self.stale)
    }

    /// Acquires a swapchain image, clears it to `background`, lets `copy` record
    /// the frame into it (in `TRANSFER_DST_OPTIMAL`), and presents it.
    fn present_with(
        &mut self,
        background: [u8; 3],
        copy: impl FnOnce(&ash::Device, vk::CommandBuffer, vk::Image, vk::Extent2D),
    ) -> Result<Presented, VkError> {
        let _layer = self.shared.layer_use();
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
        let submit = self
            .submit
            .as_ref()
            .ok_or_else(|| VkError::Plan("presenter without a command buffer".into()))?;
        let cmd = submit.cmd;
        let range = vk::ImageSubresourceRange::default()
            .aspect_mask(vk::ImageAspectFlags::COLOR)
            .level_count(1)
            .layer_count(1);
        let barrier = |src, dst, old, new| {
            vk::ImageMemoryBarrier::default()
                .src_access_mask(src)
                .dst_access_mask(dst)
                .old_layout(old)
                .new_layout(new)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(image)
                .subresource_range(range)
        };
        let dst = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
        let write = vk::AccessFlags::TRANSFER_WRITE;
        let transfer = vk::PipelineStageFlags::TRANSFER;
        let bg = background.map(|c| c as f32 / 255.0);
        // Clear values name components (R, G, B, A), whatever the byte order.
        let clear = vk::ClearColorValue {
            float32: [bg[0], bg[1], bg[2], 1.0],
        };
        submit.begin(cmd, true)?;
        let to_dst = barrier(
            vk::AccessFlags::empty(),
            write,
            vk::ImageLayout::UNDEFINED,
            dst,
        );
        submit::image_barriers(device, cmd, transfer, transfer, &[to_dst]);
        // SAFETY: recording; the image is in TRANSFER_DST_OPTIMAL after the barrier.
        unsafe { device.cmd_clear_color_image(cmd, image, dst, &clear, &[range]) };
        // Orders the clear before the copy.
        submit::image_barriers(
            device,
            cmd,
            transfer,
            transfer,
            &[barrier(write, write, dst, dst)],
        );
        copy(device, cmd, image, self.extent);
        let to_present = barrier(
            write,
            vk::AccessFlags::empty(),
            dst,
            vk::ImageLayout::PRESENT_SRC_KHR,
        );
        submit::image_barriers(
            device,
            cmd,
            transfer,
            vk::PipelineStageFlags::BOTTOM_OF_PIPE,
            &[to_present],
        );
        submit.end(cmd)?;
        submit.submit(cmd, &[(self.acquired, transfer)], &[copied])?;
        let shown = self.queue_present(index, copied);
        // The staging buffer and `self.acquired` are reused at once.
        if let Some(s) = &self.submit {
            s.wait()?;
        }
        shown
    }

    /// Presents swapchain image `index` once `copied` is signalled.
    fn queue_present(&mut self, index: u32, copied: vk::Semaphore) -> Result<Presented, VkError> {
        let shared = self.shared.clone();
        let signals = [copied];
        let swapchains = [self.swapchain];
        let indices = [index];
        let pi = vk::PresentInfoKHR::default()
            .wait_semaphores(&signals)
            .swapchains(&swapchains)
            .image_indices(&indices);
        let presented = {
            let _queue = shared.queue_lock.lock();
            // SAFETY: `index` was acquired from this swapchain; the submission that
            // signals `copied` was queued before; the lock serializes queue access.
            unsafe { self.swapchain_fn.queue_present(shared.queue, &pi) }
        };
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

fn color_range() -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange::default()
        .aspect_mask(vk::ImageAspectFlags::COLOR)
        .level_count(1)
        .layer_count(1)
}

/// An 8-bit UNORM swapchain format (the rendered bytes are copied as they are).
fn pick_format(formats: &[vk::SurfaceFormatKHR]) -> Option<vk::SurfaceFormatKHR> {
    [vk::Format::B8G8R8A8_UNORM, vk::Format::R8G8B8A8_UNORM]
        .into_iter()
        .find_map(|want| formats.iter().find(|f| f.format == want).copied())
}

/// The swapchain image's state after a resolve wrote it.
const TRANSFER_DST: super::sync::Access = super::sync::Access {
    stage: vk::PipelineStageFlags::TRANSFER,
    access: vk::AccessFlags::TRANSFER_WRITE,
    layout: vk::ImageLayout::TRANSFER_DST_OPTIMAL,
};

/// Records the resolve (the samples averaged, `vkCmdResolveImage`) of the
/// multisampled colour `ms`, left as a colour attachment by the frame, into
/// swapchain image `image` (from `UNDEFINED`; left in `TRANSFER_DST`).
fn resolve_into(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    ms: &Image,
    image: vk::Image,
    extent: vk::Extent2D,
) {
    let color = vk::ImageAspectFlags::COLOR;
    let src = super::sync::Access {
        stage: vk::PipelineStageFlags::TRANSFER,
        access: vk::AccessFlags::TRANSFER_READ,
        layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
    };
    let undefined = super::sync::Access {
        stage: vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
        access: vk::AccessFlags::empty(),
        layout: vk::ImageLayout::UNDEFINED,
    };
    let barriers = [
        super::sync::image_barrier(COLOR_ATTACHMENT, src, ms.raw, color),
        super::sync::image_barrier(undefined, TRANSFER_DST, image, color),
    ];
    submit::image_barriers(
        device,
        cmd,
        COLOR_ATTACHMENT.stage,
        vk::PipelineStageFlags::TRANSFER,
        &barriers,
    );
    let layers = vk::ImageSubresourceLayers {
        aspect_mask: color,
        mip_level: 0,
        base_array_layer: 0,
        layer_count: 1,
    };
    let region = vk::ImageResolve::default()
        .src_subresource(layers)
        .dst_subresource(layers)
        .extent(vk::Extent3D {
            width: extent.width,
            height: extent.height,
            depth: 1,
        });
    // SAFETY: recording outside rendering; both images are live, of one
    // format and size, in the layouts the barriers above set; the swapchain
    // image has TRANSFER_DST usage (`rebuild`).
    unsafe {
        device.cmd_resolve_image(
            cmd,
            ms.raw,
            src.layout,
            image,
            TRANSFER_DST.layout,
            &[region],
        )
    };
}

impl Drop for Presenter {
    fn drop(&mut self) {
        let _layer = self.shared.layer_use();
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
        self.submit = None;
        for f in self.frames.drain(..) {
            // SAFETY: as above.
            unsafe { device.destroy_semaphore(f.acquired, None) };
        }
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
