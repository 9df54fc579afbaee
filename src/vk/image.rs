//! 2D images that own their memory and a view (kajiya-style plain descriptions).

use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::Allocation;
use gpu_allocator::MemoryLocation;

use super::error::{Check, VkError};
use super::instance::Shared;
use super::memory::{allocate, free};

/// Everything needed to create an image; plain data, hashable.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ImageDesc {
    pub format: vk::Format,
    pub extent: [u32; 2],
    pub usage: vk::ImageUsageFlags,
    /// Samples per pixel (1, 2, 4 or 8).
    pub samples: u32,
}

impl ImageDesc {
    pub fn new_2d(format: vk::Format, extent: [u32; 2]) -> Self {
        ImageDesc {
            format,
            extent,
            usage: vk::ImageUsageFlags::empty(),
            samples: 1,
        }
    }

    pub fn samples(mut self, samples: u32) -> Self {
        self.samples = samples;
        self
    }

    pub fn usage(mut self, usage: vk::ImageUsageFlags) -> Self {
        self.usage = usage;
        self
    }

    /// A depth attachment, with or without stencil (`conv::is_depth`).
    pub fn is_depth_stencil(&self) -> bool {
        super::conv::is_depth(self.format)
    }

    pub fn aspect(&self) -> vk::ImageAspectFlags {
        super::conv::aspects(self.format)
    }
}

/// An image with its memory, a full view, and for depth-stencil images a
/// depth-only view for sampling.
pub struct Image {
    shared: Arc<Shared>,
    pub desc: ImageDesc,
    pub(crate) raw: vk::Image,
    allocation: Option<Allocation>,
    pub(crate) view: vk::ImageView,
    pub(crate) depth_view: vk::ImageView,
}

impl Image {
    pub(crate) fn new(shared: &Arc<Shared>, name: &str, desc: ImageDesc) -> Result<Image, VkError> {
        let ci = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(desc.format)
            .extent(vk::Extent3D {
                width: desc.extent[0],
                height: desc.extent[1],
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(super::samples::flag(desc.samples))
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(desc.usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid create info on a live device.
        let raw = unsafe { shared.device.create_image(&ci, None) }.check("vkCreateImage")?;
        let mut image = Image {
            shared: shared.clone(),
            desc,
            raw,
            allocation: None,
            view: vk::ImageView::null(),
            depth_view: vk::ImageView::null(),
        };
        // SAFETY: `raw` is a live image of this device.
        let req = unsafe { shared.device.get_image_memory_requirements(raw) };
        let allocation = allocate(shared, name, req, MemoryLocation::GpuOnly, false)?;
        // SAFETY: the allocation satisfies `req`; no memory is bound yet.
        unsafe {
            shared
                .device
                .bind_image_memory(raw, allocation.memory(), allocation.offset())
        }
        .check("vkBindImageMemory")?;
        image.allocation = Some(allocation);
        image.view = image.make_view(desc.aspect())?;
        if desc.is_depth_stencil() && desc.usage.contains(vk::ImageUsageFlags::SAMPLED) {
            image.depth_view = image.make_view(vk::ImageAspectFlags::DEPTH)?;
        }
        Ok(image)
    }

    fn make_view(&self, aspect: vk::ImageAspectFlags) -> Result<vk::ImageView, VkError> {
        let ci = vk::ImageViewCreateInfo::default()
            .image(self.raw)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(self.desc.format)
            .subresource_range(range(aspect));
        // SAFETY: the image is live with memory bound.
        unsafe { self.shared.device.create_image_view(&ci, None) }.check("vkCreateImageView")
    }
}

pub(crate) fn range(aspect: vk::ImageAspectFlags) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: aspect,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        let _layer = self.shared.layer_use();
        // SAFETY: the owner waited for the GPU; views are destroyed before their image,
        // the image before its memory is freed.
        unsafe {
            if self.depth_view != vk::ImageView::null() {
                self.shared.device.destroy_image_view(self.depth_view, None);
            }
        }
        // SAFETY: as above.
        unsafe {
            if self.view != vk::ImageView::null() {
                self.shared.device.destroy_image_view(self.view, None);
            }
        }
        // SAFETY: as above.
        unsafe { self.shared.device.destroy_image(self.raw, None) };
        if let Some(a) = self.allocation.take() {
            free(&self.shared, a);
        }
    }
}
