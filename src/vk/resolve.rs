//! The read-back of a multisampled frame: one full-screen pass
//! (`shaders/resolve.frag`) from the executor's multisampled colour, id and
//! output depth images into single-sample ones, which `read_back` copies.
//! Colour is the mean of the pixel's samples; primitive id and depth are
//! sample 0's — the sample `prim.png` and `depth.npy` report, at the position
//! Vulkan's standard sample locations give it (the reference casts its rays
//! there). A shader rather than `vkCmdResolveImage`: that leaves integer
//! formats implementation-defined and takes no depth.

use std::sync::Arc;

use ash::vk;

use super::composite::{bind_fullscreen, output_set, write_output_set};
use super::error::{Check, VkError};
use super::image::{Image, ImageDesc};
use super::instance::Shared;
use super::pipeline::{fragment_binding, graphics_pipeline, Graphics};
use super::submit;
use super::sync::{self, REST};
use crate::plan::usage::Usage;

const FRAG: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/resolve.frag.spv"));

/// The resolve pass's objects and its single-sample images, for one size
/// and depth format.
pub(crate) struct Resolve {
    shared: Arc<Shared>,
    /// The depth format and extent they were made for.
    pub key: (vk::Format, [u32; 2]),
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    pipeline: vk::Pipeline,
    /// Single-sample colour, ids and depth, resting in `REST` (copy source).
    pub color: Image,
    pub prim: Image,
    pub depth: Image,
}

/// The multisampled images a resolve reads: colour, ids, and the output
/// depth-stencil (sampled through its depth view).
pub(crate) struct Sources<'a> {
    pub color: &'a Image,
    pub prim: &'a Image,
    pub depth: &'a Image,
    pub samples: u32,
}

impl Resolve {
    pub(crate) fn new(
        shared: &Arc<Shared>,
        depth_format: vk::Format,
        extent: [u32; 2],
    ) -> Result<Resolve, VkError> {
        let device = &shared.device;
        let attach = |usage| usage | vk::ImageUsageFlags::TRANSFER_SRC;
        let color = Image::new(
            shared,
            "resolved color",
            ImageDesc::new_2d(super::exec::color_format(), extent)
                .usage(attach(vk::ImageUsageFlags::COLOR_ATTACHMENT)),
        )?;
        let prim = Image::new(
            shared,
            "resolved prim",
            ImageDesc::new_2d(vk::Format::R32_UINT, extent)
                .usage(attach(vk::ImageUsageFlags::COLOR_ATTACHMENT)),
        )?;
        let depth = Image::new(
            shared,
            "resolved depth",
            ImageDesc::new_2d(depth_format, extent)
                .usage(attach(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT)),
        )?;
        let mut r = Resolve {
            shared: shared.clone(),
            key: (depth_format, extent),
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            pipeline: vk::Pipeline::null(),
            color,
            prim,
            depth,
        };
        let bindings = [
            fragment_binding(0, vk::DescriptorType::SAMPLED_IMAGE),
            fragment_binding(1, vk::DescriptorType::SAMPLED_IMAGE),
            fragment_binding(2, vk::DescriptorType::SAMPLED_IMAGE),
            fragment_binding(3, vk::DescriptorType::SAMPLER),
        ];
        let dci = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid create info on a live device (each object made here is
        // destroyed by `Drop`, null or not).
        r.set_layout = unsafe { device.create_descriptor_set_layout(&dci, None) }
            .check("vkCreateDescriptorSetLayout")?;
        let set_layouts = [r.set_layout];
        let ranges = [vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::FRAGMENT,
            offset: 0,
            size: 4,
        }];
        let lci = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(&ranges);
        // SAFETY: valid create info; the set layout is live.
        r.layout =
            unsafe { device.create_pipeline_layout(&lci, None) }.check("vkCreatePipelineLayout")?;
        (r.pool, r.set) = output_set(device, r.set_layout)?;
        let depth_stencil = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(vk::CompareOp::ALWAYS);
        let stencil_format = if super::conv::has_stencil(depth_format) {
            depth_format
        } else {
            vk::Format::UNDEFINED
        };
        let color_formats = [super::exec::color_format(), vk::Format::R32_UINT];
        r.pipeline = super::stages::fullscreen_pipeline(shared, FRAG, |stages| {
            graphics_pipeline(
                device,
                &Graphics {
                    stages,
                    vertex_input: &vk::PipelineVertexInputStateCreateInfo::default(),
                    cull: vk::CullModeFlags::NONE,
                    depth_stencil: &depth_stencil,
                    dynamic_states: &[vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR],
                    color_formats: &color_formats,
                    depth_format,
                    stencil_format,
                    layout: r.layout,
                    samples: 1,
                    sample_shading: false,
                    blend: None,
                },
            )
        })?;
        Ok(r)
    }

    /// Records the pass into `cmd` (outside rendering): `src`'s images from
    /// `REST` to sampled and back, this resolve's images from `REST` to
    /// attachments and back, so the caller copies them as it would the
    /// single-sample outputs.
    pub(crate) fn record(&self, cmd: vk::CommandBuffer, src: &Sources<'_>, sampler: vk::Sampler) {
        let device = &self.shared.device;
        let sampled = sync::access(Usage::Sampled);
        let rest = sync::access(REST);
        let color_target = sync::access(Usage::ColorTarget);
        let ds_target = sync::access(Usage::DepthStencilTarget);
        let views = [src.color.view, src.prim.view, src.depth.depth_view];
        // SAFETY: set, views and sampler are live; the set is not in use (the
        // executor's read-back waits for its one-shot command buffers).
        unsafe { write_output_set(device, self.set, views, sampler) };
        let aspect = |i: &Image| i.desc.aspect();
        // This pass's own images are written whole: their old contents go.
        let fresh = sync::Access {
            access: vk::AccessFlags::empty(),
            layout: vk::ImageLayout::UNDEFINED,
            ..rest
        };
        // `src`'s images between `from.0` and `to.0`, this pass's colour
        // images between `from.1` and `to.1`, its depth between `from.2` and
        // `to.2`.
        let transitions = |from: [sync::Access; 3], to: [sync::Access; 3]| -> Vec<_> {
            [src.color, src.prim, src.depth]
                .iter()
                .map(|i| sync::image_barrier(from[0], to[0], i.raw, aspect(i)))
                .chain([
                    sync::image_barrier(from[1], to[1], self.color.raw, aspect(&self.color)),
                    sync::image_barrier(from[1], to[1], self.prim.raw, aspect(&self.prim)),
                    sync::image_barrier(from[2], to[2], self.depth.raw, aspect(&self.depth)),
                ])
                .collect()
        };
        let into = transitions([rest, fresh, fresh], [sampled, color_target, ds_target]);
        submit::image_barriers(
            device,
            cmd,
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::PipelineStageFlags::ALL_COMMANDS,
            &into,
        );
        let [w, h] = self.key.1;
        let extent = vk::Extent2D {
            width: w,
            height: h,
        };
        let attach = |view| {
            vk::RenderingAttachmentInfo::default()
                .image_view(view)
                .load_op(vk::AttachmentLoadOp::DONT_CARE)
                .store_op(vk::AttachmentStoreOp::STORE)
        };
        let colors = [
            attach(self.color.view).image_layout(color_target.layout),
            attach(self.prim.view).image_layout(color_target.layout),
        ];
        let depth = attach(self.depth.view).image_layout(ds_target.layout);
        let stencil = super::conv::has_stencil(self.key.0).then_some(depth);
        let mut ri = vk::RenderingInfo::default()
            .render_area(extent.into())
            .layer_count(1)
            .color_attachments(&colors)
            .depth_attachment(&depth);
        if let Some(s) = &stencil {
            ri = ri.stencil_attachment(s);
        }
        // SAFETY: outside rendering; the views are this resolve's attachments in
        // the layouts the barrier above left them in.
        unsafe { device.cmd_begin_rendering(cmd, &ri) };
        bind_fullscreen(
            device,
            cmd,
            (self.pipeline, self.layout, self.set),
            extent,
            extent.into(),
        );
        // SAFETY: the layout declares 4 bytes of fragment push constants.
        unsafe {
            device.cmd_push_constants(
                cmd,
                self.layout,
                vk::ShaderStageFlags::FRAGMENT,
                0,
                &(src.samples as i32).to_ne_bytes(),
            )
        };
        // SAFETY: pipeline, set and state bound; the vertex shader needs no buffer.
        unsafe { device.cmd_draw(cmd, 3, 1, 0, 0) };
        // SAFETY: closes the block begun above.
        unsafe { device.cmd_end_rendering(cmd) };
        let back = transitions([sampled, color_target, ds_target], [rest; 3]);
        submit::image_barriers(
            device,
            cmd,
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::PipelineStageFlags::ALL_COMMANDS,
            &back,
        );
    }
}

impl Drop for Resolve {
    fn drop(&mut self) {
        let _layer = self.shared.layer_use();
        let d = &self.shared.device;
        // SAFETY (each call): the executor waited for the GPU; null handles are
        // ignored.
        unsafe { d.destroy_pipeline(self.pipeline, None) };
        // SAFETY: as above.
        unsafe { d.destroy_descriptor_pool(self.pool, None) };
        // SAFETY: as above.
        unsafe { d.destroy_pipeline_layout(self.layout, None) };
        // SAFETY: as above.
        unsafe { d.destroy_descriptor_set_layout(self.set_layout, None) };
    }
}
