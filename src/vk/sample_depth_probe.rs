//! Measuring whether a fragment program run once per sample reads the
//! sample's own depth in `gl_FragCoord.z` ([`super::DeviceProfile::sample_depth`]):
//! one small multisampled draw per physical device and process, never a
//! guess from the device's name.
//!
//! Multisampled frames run every program that compares its depth with a depth
//! texture once per sample (Vulkan specification, "Sample Shading"), and the
//! comparison is exact only if `gl_FragCoord.z` is the depth the rasterizer
//! computed for that sample — the value the same draw writes into the
//! sample's depth. The specification says that `FragCoord`'s x and y are the
//! sample's location under sample shading, and of z only that it is "the
//! interpolated depth value of the primitive" (where it is interpolated is an
//! open question in the Vulkan-Docs tracker, "Sample Shading and FragCoord
//! interpolation not fully specified for Z and W"). lavapipe interpolates
//! it at the sample; SwiftShader gives every sample's invocation the depth of
//! sample 0 (its `PixelProgram::setBuiltins` sets `fragCoord[2] = z[0]`), and
//! MoltenVK on Apple GPUs the depth at the pixel centre. On such a device the
//! samples other than the defined one fail their own depth tests: peeltrim
//! refuses multisampled frames there ([`super::Context::check_samples`]).
//!
//! The probe draws the depth probe's triangle (`vk::depth_probe`, depth slope
//! about 0.07 per pixel, so samples of one pixel differ in depth by about
//! 0.03) twice into a multisampled target: first without a fragment program,
//! writing the raster depth; then, once per sample, a program that replaces
//! the depth with `gl_FragCoord.z` and writes white where a depth-`EQUAL`
//! test passes. The colour is resolved (averaged) and read back: pixels well
//! inside the triangle are white only if every sample passed.

use std::sync::{Arc, Mutex};

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::depth_probe::{
    area, cleared_depth, device_key, plane, read_region, set_triangle, vertices, Key, SIDE,
};
use super::error::{Check, VkError};
use super::image::{Image, ImageDesc};
use super::instance::Shared;
use super::memory::Buffer;
use super::pipeline::{graphics_pipeline, shader_module, Graphics};
use super::submit::{image_barriers, transfer_to_host_barrier, Submitter};
use super::sync::{access, image_barrier, Access};
use crate::plan::usage::Usage;

const PROBE_VERT: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/depth_probe.vert.spv"));
const PROBE_FRAG: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/sample_depth_probe.frag.spv"));

/// The resolved colour's format.
const COLOR: vk::Format = vk::Format::R8G8B8A8_UNORM;

/// What the probe measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleDepthProbe {
    /// Samples per pixel of the probe's target.
    pub samples: u32,
    /// Pixels at least 0.75 pixel inside the triangle.
    pub pixels: u32,
    /// Those of them where every sample passed its depth-`EQUAL` test.
    pub passed: u32,
}

impl SampleDepthProbe {
    /// Whether `gl_FragCoord.z` is each sample's own depth: every inner
    /// pixel passed on all its samples.
    pub fn per_sample(&self) -> bool {
        self.pixels > 0 && self.passed == self.pixels
    }
}

/// Measured once per physical device and process.
static MEASURED: Mutex<Vec<(Key, SampleDepthProbe)>> = Mutex::new(Vec::new());

/// The probe of `shared`'s device at `samples` per pixel into a D32 `format`
/// (`bits`: its `subPixelPrecisionBits`), measured on the first call for
/// that device.
pub(crate) fn measure(
    shared: &Arc<Shared>,
    bits: u32,
    format: vk::Format,
    samples: u32,
) -> Result<SampleDepthProbe, VkError> {
    let key = device_key(shared);
    let mut measured = MEASURED.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, p)) = measured.iter().find(|(k, _)| *k == key) {
        return Ok(*p);
    }
    let resolved = draw(shared, bits, format, samples)?;
    let (_, fb) = vertices(bits);
    let mut probe = SampleDepthProbe {
        samples,
        pixels: 0,
        passed: 0,
    };
    for j in 0..SIDE {
        for i in 0..SIDE {
            if !plane(&fb, i as f64 + 0.5, j as f64 + 0.5, 0.75).1 {
                continue;
            }
            probe.pixels += 1;
            // The red channel of the resolved RGBA8 texel.
            let red = resolved[((j * SIDE + i) * 4) as usize];
            probe.passed += u32::from(red == 255);
        }
    }
    measured.push((key, probe));
    Ok(probe)
}

/// The probe of `ctx`'s device at the smallest sample count above 1 its
/// framebuffers have (measured once per device and process); `None` where
/// it cannot multisample, has no `sampleRateShading` or no usable D32 format.
pub fn of(ctx: &super::Context) -> Result<Option<SampleDepthProbe>, VkError> {
    let formats = ctx.profile().depth_formats;
    let format = [
        (formats.d32, vk::Format::D32_SFLOAT),
        (formats.d32s8, vk::Format::D32_SFLOAT_S8_UINT),
    ]
    .into_iter()
    .find_map(|(ok, f)| ok.then_some(f));
    let l = &ctx.shared.limits;
    match (format, smallest_count(l), ctx.shared.sample_rate_shading) {
        (Some(format), Some(n), true) => {
            let bits = l.sub_pixel_precision_bits;
            measure(&ctx.shared, bits, format, n).map(Some)
        }
        _ => Ok(None),
    }
}

/// The smallest sample count above 1 that colour and depth framebuffers of
/// a device with `limits` have (the probe's count).
pub(crate) fn smallest_count(limits: &vk::PhysicalDeviceLimits) -> Option<u32> {
    let counts = limits.framebuffer_color_sample_counts & limits.framebuffer_depth_sample_counts;
    super::samples::SAMPLE_COUNTS
        .into_iter()
        .find(|&n| n > 1 && counts.contains(super::samples::flag(n)))
}

/// The probe's two pipelines and their layout, destroyed on drop.
struct Pipelines<'a> {
    device: &'a ash::Device,
    layout: vk::PipelineLayout,
    /// Raster depth only (no fragment program, no colour write).
    depth: vk::Pipeline,
    /// Once per sample: depth replaced by `gl_FragCoord.z`, tested `EQUAL`.
    shade: vk::Pipeline,
}

impl Drop for Pipelines<'_> {
    fn drop(&mut self) {
        // SAFETY: the probe waited for its submission (or never submitted);
        // null handles are ignored.
        unsafe {
            self.device.destroy_pipeline(self.depth, None);
            self.device.destroy_pipeline(self.shade, None);
            self.device.destroy_pipeline_layout(self.layout, None);
        }
    }
}

fn pipelines<'a>(
    shared: &'a Arc<Shared>,
    format: vk::Format,
    samples: u32,
) -> Result<Pipelines<'a>, VkError> {
    let d = &shared.device;
    let ranges = [vk::PushConstantRange::default()
        .stage_flags(vk::ShaderStageFlags::VERTEX)
        .offset(0)
        .size(48)];
    let mut p = Pipelines {
        device: d,
        layout: vk::PipelineLayout::null(),
        depth: vk::Pipeline::null(),
        shade: vk::Pipeline::null(),
    };
    // SAFETY: valid create info on a live device.
    p.layout = unsafe {
        d.create_pipeline_layout(
            &vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&ranges),
            None,
        )
    }
    .check("vkCreatePipelineLayout")?;
    let stencil_format = match super::conv::has_stencil(format) {
        true => format,
        false => vk::Format::UNDEFINED,
    };
    let vert = shader_module(shared, PROBE_VERT)?;
    let frag = shader_module(shared, PROBE_FRAG);
    let made = frag.and_then(|frag| {
        let stage = |s, m| {
            vk::PipelineShaderStageCreateInfo::default()
                .stage(s)
                .module(m)
                .name(c"main")
        };
        let both = [
            stage(vk::ShaderStageFlags::VERTEX, vert),
            stage(vk::ShaderStageFlags::FRAGMENT, frag),
        ];
        let make = |stages: &[vk::PipelineShaderStageCreateInfo<'_>], op, write, mask| {
            let depth_stencil = vk::PipelineDepthStencilStateCreateInfo::default()
                .depth_test_enable(true)
                .depth_write_enable(write)
                .depth_compare_op(op);
            let blend = vk::PipelineColorBlendAttachmentState::default().color_write_mask(mask);
            graphics_pipeline(
                d,
                &Graphics {
                    stages,
                    vertex_input: &vk::PipelineVertexInputStateCreateInfo::default(),
                    cull: vk::CullModeFlags::NONE,
                    depth_stencil: &depth_stencil,
                    dynamic_states: &[vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR],
                    color_formats: &[COLOR],
                    depth_format: format,
                    stencil_format,
                    layout: p.layout,
                    samples,
                    sample_shading: true,
                    blend: Some((blend, [0.0; 4])),
                },
            )
        };
        let made = make(
            &both[..1],
            vk::CompareOp::ALWAYS,
            true,
            vk::ColorComponentFlags::empty(),
        )
        .and_then(|depth| {
            p.depth = depth;
            make(
                &both,
                vk::CompareOp::EQUAL,
                false,
                vk::ColorComponentFlags::RGBA,
            )
        });
        // SAFETY: modules are only needed while creating the pipelines.
        unsafe { d.destroy_shader_module(frag, None) };
        made
    });
    // SAFETY: as above.
    unsafe { d.destroy_shader_module(vert, None) };
    p.shade = made?;
    Ok(p)
}

/// Draws the probe and reads back the resolved colour (`SIDE`² RGBA8 texels).
fn draw(
    shared: &Arc<Shared>,
    bits: u32,
    format: vk::Format,
    samples: u32,
) -> Result<Vec<u8>, VkError> {
    let _layer = shared.layer_use();
    let d = &shared.device;
    let extent = [SIDE, SIDE];
    let depth = Image::new(
        shared,
        "sample depth probe depth",
        ImageDesc::new_2d(format, extent)
            .usage(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT)
            .samples(samples),
    )?;
    let color = Image::new(
        shared,
        "sample depth probe colour",
        ImageDesc::new_2d(COLOR, extent)
            .usage(vk::ImageUsageFlags::COLOR_ATTACHMENT)
            .samples(samples),
    )?;
    let resolved = Image::new(
        shared,
        "sample depth probe resolve",
        ImageDesc::new_2d(COLOR, extent)
            .usage(vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC),
    )?;
    let buffer = Buffer::new(
        shared,
        "sample depth probe read-back",
        (SIDE * SIDE * 4) as u64,
        vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuToCpu,
    )?;
    let p = pipelines(shared, format, samples)?;
    let submit = Submitter::new(shared)?;
    let cmd = submit.cmd;
    submit.begin(cmd, true)?;
    let undefined = Access {
        stage: vk::PipelineStageFlags::TOP_OF_PIPE,
        access: vk::AccessFlags::empty(),
        layout: vk::ImageLayout::UNDEFINED,
    };
    let ds_target = access(Usage::DepthStencilTarget);
    let color_target = access(Usage::ColorTarget);
    let transfer = access(Usage::CopySrc);
    let color_aspect = vk::ImageAspectFlags::COLOR;
    image_barriers(
        d,
        cmd,
        undefined.stage,
        ds_target.stage | color_target.stage,
        &[
            image_barrier(undefined, ds_target, depth.raw, depth.desc.aspect()),
            image_barrier(undefined, color_target, color.raw, color_aspect),
            image_barrier(undefined, color_target, resolved.raw, color_aspect),
        ],
    );
    let colors = [vk::RenderingAttachmentInfo::default()
        .image_view(color.view)
        .image_layout(color_target.layout)
        .load_op(vk::AttachmentLoadOp::CLEAR)
        .store_op(vk::AttachmentStoreOp::DONT_CARE)
        .clear_value(vk::ClearValue::default())
        .resolve_mode(vk::ResolveModeFlags::AVERAGE)
        .resolve_image_view(resolved.view)
        .resolve_image_layout(color_target.layout)];
    let depth_attachment = cleared_depth(depth.view, vk::AttachmentStoreOp::DONT_CARE);
    let ri = vk::RenderingInfo::default()
        .render_area(area())
        .layer_count(1)
        .color_attachments(&colors)
        .depth_attachment(&depth_attachment);
    let ri = match super::conv::has_stencil(format) {
        true => ri.stencil_attachment(&depth_attachment),
        false => ri,
    };
    // SAFETY: recording; the images are in their attachment layouts (barrier
    // above).
    unsafe { d.cmd_begin_rendering(cmd, &ri) };
    set_triangle(d, cmd, p.layout, bits);
    // SAFETY: the pipelines were made for the formats and sample count;
    // viewport and scissor cover the target.
    unsafe {
        for pipeline in [p.depth, p.shade] {
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
            d.cmd_draw(cmd, 3, 1, 0, 0);
        }
        d.cmd_end_rendering(cmd);
    }
    image_barriers(
        d,
        cmd,
        color_target.stage,
        transfer.stage,
        &[image_barrier(
            color_target,
            transfer,
            resolved.raw,
            color_aspect,
        )],
    );
    let region = read_region(color_aspect);
    // SAFETY: the image is in TRANSFER_SRC_OPTIMAL; the buffer holds SIDE² texels.
    unsafe {
        d.cmd_copy_image_to_buffer(cmd, resolved.raw, transfer.layout, buffer.raw, &[region])
    };
    transfer_to_host_barrier(d, cmd);
    submit.finish(cmd)?;
    Ok(buffer.mapped()?.to_vec())
}
