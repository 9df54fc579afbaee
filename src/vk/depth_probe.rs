//! Measuring whether the rasterizer interpolates depth from the unsnapped
//! vertex positions ([`super::DeviceProfile::unsnapped_depth`]): one small
//! draw per physical device and process, never a guess from the device's type
//! or name.
//!
//! The tie rule (Hable & Rossignac, "Blister", §4; Stewart, Leach & John §3 on
//! the depth test as the only comparison of two faces) holds that two faces at
//! the same depth agree within the depth the rasterizer computes. A rasterizer
//! that snaps vertices to its subpixel grid before setting up the depth plane
//! (every hardware GPU; SwiftShader, though it is a CPU device) is off the
//! exact plane by up to the snap times the depth slope; one that interpolates
//! from the f32 positions (lavapipe) is as exact at a pixel centre as the plane
//! depth the shaders compute. Only the latter may run the depth-`EQUAL` final
//! shade (`plan::tie_free`).
//!
//! The probe draws one triangle whose vertices sit off the subpixel grid into
//! a 16×16 D32 target (depth test `ALWAYS`, no fragment shader), reads the
//! depth back and compares each covered pixel centre with the plane through
//! the f32 vertices and with the plane through the same vertices snapped to
//! `subPixelPrecisionBits`. The depth slope is steep (about 0.07 per pixel)
//! and the offsets are 0.27 to 0.43 of a grid step, so snapping at 8 bits moves
//! the depth by about 10⁻⁴, far above f32 interpolation's error (about 10⁻⁷).

use std::sync::{Arc, Mutex};

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::error::{Check, VkError};
use super::image::{Image, ImageDesc};
use super::instance::Shared;
use super::memory::Buffer;
use super::pipeline::{graphics_pipeline, shader_module, Graphics};
use super::submit::{image_barriers, transfer_to_host_barrier, Submitter};
use super::sync::{image_barrier, Access};

const PROBE_VERT: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/depth_probe.vert.spv"));

/// The probe target's side in pixels.
pub(crate) const SIDE: u32 = 16;

/// Below this largest difference from the unsnapped plane (depth units) the
/// rasterizer interpolates from unsnapped vertices: a few f32 roundings of
/// the interpolation, 50× below what 8-bit snapping moves on the probe.
pub const UNSNAPPED_TOLERANCE: f64 = 2e-6;

/// What the probe measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthProbe {
    /// The largest difference between the raster depth and the plane through
    /// the f32 vertices, over the covered pixel centres.
    pub unsnapped_error: f64,
    /// The same against the plane through the vertices snapped (rounded to
    /// nearest) to the device's `subPixelPrecisionBits`.
    pub snapped_error: f64,
    /// Pixel centres compared.
    pub pixels: u32,
    /// The device's `subPixelPrecisionBits` the vertices were placed off.
    pub subpixel_bits: u32,
}

impl DepthProbe {
    /// Whether depth is interpolated from unsnapped positions: within
    /// [`UNSNAPPED_TOLERANCE`] of the unsnapped plane, and nearer it than the
    /// snapped one.
    pub fn unsnapped(&self) -> bool {
        self.pixels > 0
            && self.unsnapped_error <= UNSNAPPED_TOLERANCE
            && self.unsnapped_error < self.snapped_error
    }
}

/// The probe's triangle in framebuffer pixels (x, y) and depth, before the
/// off-grid offsets.
const CORNERS: [[f64; 3]; 3] = [[1.0, 1.0, 0.10], [14.0, 3.0, 0.90], [4.0, 14.0, 0.45]];
/// Each corner's offset from the grid, in grid steps (x, y).
const OFFSETS: [[f64; 2]; 3] = [[0.41, -0.37], [-0.29, 0.43], [0.36, 0.27]];

/// The probe's vertices for `bits` subpixel bits: clip-space f32 positions
/// (w = 1) and the framebuffer positions they stand for, exactly.
pub fn vertices(bits: u32) -> ([[f32; 4]; 3], [[f64; 3]; 3]) {
    let step = (-(bits as f64)).exp2();
    let mut clip = [[0f32; 4]; 3];
    let mut fb = [[0f64; 3]; 3];
    for i in 0..3 {
        let [x, y, z] = CORNERS[i];
        let px = x + OFFSETS[i][0] * step;
        let py = y + OFFSETS[i][1] * step;
        let to_ndc = |p: f64| (p * 2.0 / SIDE as f64 - 1.0) as f32;
        clip[i] = [to_ndc(px), to_ndc(py), z as f32, 1.0];
        // The viewport maps ndc to (ndc + 1)·side/2.
        let back = |n: f32| (n as f64 + 1.0) * SIDE as f64 / 2.0;
        fb[i] = [back(clip[i][0]), back(clip[i][1]), clip[i][2] as f64];
    }
    (clip, fb)
}

/// The depth of the plane through `v` at (x, y), and whether (x, y) is at
/// least `margin` pixels inside the triangle.
pub(crate) fn plane(v: &[[f64; 3]; 3], x: f64, y: f64, margin: f64) -> (f64, bool) {
    let e = |a: [f64; 3], b: [f64; 3], x: f64, y: f64| {
        (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])
    };
    let area = e(v[0], v[1], v[2][0], v[2][1]);
    let w0 = e(v[1], v[2], x, y) / area;
    let w1 = e(v[2], v[0], x, y) / area;
    let w2 = e(v[0], v[1], x, y) / area;
    let inside = [(w0, 1, 2), (w1, 2, 0), (w2, 0, 1)]
        .iter()
        .all(|&(w, a, b)| {
            let len = (v[b][0] - v[a][0]).hypot(v[b][1] - v[a][1]);
            // Distance to the opposite edge: w · 2·area / |edge|.
            w * area.abs() / len >= margin
        });
    (w0 * v[0][2] + w1 * v[1][2] + w2 * v[2][2], inside)
}

/// Compares the read-back depths (`SIDE`² f32, row-major) with both planes.
pub fn compare(depths: &[f32], bits: u32) -> DepthProbe {
    let (_, fb) = vertices(bits);
    let scale = (bits as f64).exp2();
    let snapped = fb.map(|[x, y, z]| [(x * scale).round() / scale, (y * scale).round() / scale, z]);
    let mut probe = DepthProbe {
        unsnapped_error: 0.0,
        snapped_error: 0.0,
        pixels: 0,
        subpixel_bits: bits,
    };
    for j in 0..SIDE {
        for i in 0..SIDE {
            let (x, y) = (i as f64 + 0.5, j as f64 + 0.5);
            let (exact, inside) = plane(&fb, x, y, 0.75);
            if !inside {
                continue;
            }
            let (snap, _) = plane(&snapped, x, y, 0.0);
            let d = depths[(j * SIDE + i) as usize] as f64;
            probe.unsnapped_error = probe.unsnapped_error.max((d - exact).abs());
            probe.snapped_error = probe.snapped_error.max((d - snap).abs());
            probe.pixels += 1;
        }
    }
    probe
}

/// A physical device: vendor, device, driver and pipeline-cache UUID (what a
/// probe's measurement is kept under for the process).
pub(crate) type Key = (u32, u32, u32, [u8; vk::UUID_SIZE]);

/// The [`Key`] of `shared`'s physical device.
pub(crate) fn device_key(shared: &Shared) -> Key {
    // SAFETY: the physical device belongs to the instance; a plain query.
    let props = unsafe {
        shared
            .instance
            .get_physical_device_properties(shared.physical)
    };
    (
        props.vendor_id,
        props.device_id,
        props.driver_version,
        props.pipeline_cache_uuid,
    )
}

/// The probe target's whole area.
pub(crate) fn area() -> vk::Rect2D {
    vk::Rect2D {
        offset: vk::Offset2D::default(),
        extent: vk::Extent2D {
            width: SIDE,
            height: SIDE,
        },
    }
}

/// Records the probe's viewport and scissor (the whole target) and pushes
/// its triangle for `bits` subpixel bits (`layout`: 48 bytes of vertex push
/// constants).
pub(crate) fn set_triangle(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    layout: vk::PipelineLayout,
    bits: u32,
) {
    let (clip, _) = vertices(bits);
    let bytes: Vec<u8> = clip
        .iter()
        .flatten()
        .flat_map(|f| f.to_ne_bytes())
        .collect();
    let viewport = vk::Viewport {
        x: 0.0,
        y: 0.0,
        width: SIDE as f32,
        height: SIDE as f32,
        min_depth: 0.0,
        max_depth: 1.0,
    };
    // SAFETY: recording; viewport and scissor are dynamic in the probes'
    // pipelines, and `layout` declares the 48 bytes pushed.
    unsafe {
        d.cmd_set_viewport(cmd, 0, &[viewport]);
        d.cmd_set_scissor(cmd, 0, &[area()]);
        d.cmd_push_constants(cmd, layout, vk::ShaderStageFlags::VERTEX, 0, &bytes);
    }
}

/// A depth attachment of `view` cleared to 1 on load.
pub(crate) fn cleared_depth(
    view: vk::ImageView,
    store: vk::AttachmentStoreOp,
) -> vk::RenderingAttachmentInfo<'static> {
    vk::RenderingAttachmentInfo::default()
        .image_view(view)
        .image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
        .load_op(vk::AttachmentLoadOp::CLEAR)
        .store_op(store)
        .clear_value(vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth: 1.0,
                stencil: 0,
            },
        })
}

/// The copy of a whole probe image's `aspect` into a buffer.
pub(crate) fn read_region(aspect: vk::ImageAspectFlags) -> vk::BufferImageCopy {
    vk::BufferImageCopy::default()
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: aspect,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        })
        .image_extent(vk::Extent3D {
            width: SIDE,
            height: SIDE,
            depth: 1,
        })
}

/// Measured once per physical device (vendor, device, driver, pipeline-cache
/// UUID) and process.
static MEASURED: Mutex<Vec<(Key, DepthProbe)>> = Mutex::new(Vec::new());

/// The probe of `shared`'s device (`bits`: its `subPixelPrecisionBits`),
/// measured on the first call for that device; `None` where the device has
/// no usable D32 format (then depth counts as snapped).
pub(crate) fn measure(
    shared: &Arc<Shared>,
    bits: u32,
    format: Option<vk::Format>,
) -> Result<Option<DepthProbe>, VkError> {
    let Some(format) = format else {
        return Ok(None);
    };
    let key = device_key(shared);
    let mut measured = MEASURED.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, p)) = measured.iter().find(|(k, _)| *k == key) {
        return Ok(Some(*p));
    }
    let depths = draw(shared, bits, format)?;
    let probe = compare(&depths, bits);
    measured.push((key, probe));
    Ok(Some(probe))
}

/// The probe of `ctx`'s device (measured once per device and process; the
/// device's own rasterizer, whatever the profile emulates); `None` where it
/// has no usable D32 format.
pub fn of(ctx: &super::Context) -> Result<Option<DepthProbe>, VkError> {
    let formats = ctx.profile().depth_formats;
    let format = [
        (formats.d32, vk::Format::D32_SFLOAT),
        (formats.d32s8, vk::Format::D32_SFLOAT_S8_UINT),
    ]
    .into_iter()
    .find_map(|(ok, f)| ok.then_some(f));
    let bits = ctx.shared.limits.sub_pixel_precision_bits;
    measure(&ctx.shared, bits, format)
}

/// Draws the probe triangle into a `format` target and reads its depth back.
fn draw(shared: &Arc<Shared>, bits: u32, format: vk::Format) -> Result<Vec<f32>, VkError> {
    let _layer = shared.layer_use();
    let d = &shared.device;
    let image = Image::new(
        shared,
        "depth probe",
        ImageDesc::new_2d(format, [SIDE, SIDE]).usage(
            vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
        ),
    )?;
    let aspect = image.desc.aspect();
    let buffer = Buffer::new(
        shared,
        "depth probe read-back",
        (SIDE * SIDE * 4) as u64,
        vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuToCpu,
    )?;
    let ranges = [vk::PushConstantRange::default()
        .stage_flags(vk::ShaderStageFlags::VERTEX)
        .offset(0)
        .size(48)];
    // SAFETY: valid create info on a live device.
    let layout = unsafe {
        d.create_pipeline_layout(
            &vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&ranges),
            None,
        )
    }
    .check("vkCreatePipelineLayout")?;
    let pipeline = shader_module(shared, PROBE_VERT).and_then(|vert| {
        let stages = [vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::VERTEX)
            .module(vert)
            .name(c"main")];
        let depth_stencil = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(vk::CompareOp::ALWAYS);
        let stencil_format = match aspect.contains(vk::ImageAspectFlags::STENCIL) {
            true => format,
            false => vk::Format::UNDEFINED,
        };
        let made = graphics_pipeline(
            d,
            &Graphics {
                stages: &stages,
                vertex_input: &vk::PipelineVertexInputStateCreateInfo::default(),
                cull: vk::CullModeFlags::NONE,
                depth_stencil: &depth_stencil,
                dynamic_states: &[vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR],
                color_formats: &[],
                depth_format: format,
                stencil_format,
                layout,
                samples: 1,
                sample_shading: false,
                blend: None,
            },
        );
        // SAFETY: modules are only needed while creating the pipeline.
        unsafe { d.destroy_shader_module(vert, None) };
        made
    });
    let result = pipeline.and_then(|pipeline| {
        let r = record_and_read(shared, &image, &buffer, pipeline, layout, bits);
        // SAFETY: `record_and_read` waited for its submission.
        unsafe { d.destroy_pipeline(pipeline, None) };
        r
    });
    // SAFETY: no pipeline uses the layout any more.
    unsafe { d.destroy_pipeline_layout(layout, None) };
    result
}

fn record_and_read(
    shared: &Arc<Shared>,
    image: &Image,
    buffer: &Buffer,
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    bits: u32,
) -> Result<Vec<f32>, VkError> {
    let d = &shared.device;
    let submit = Submitter::new(shared)?;
    let cmd = submit.cmd;
    submit.begin(cmd, true)?;
    let aspect = image.desc.aspect();
    let attachment = Access {
        stage: vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
            | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS,
        access: vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
            | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
        layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
    };
    let undefined = Access {
        stage: vk::PipelineStageFlags::TOP_OF_PIPE,
        access: vk::AccessFlags::empty(),
        layout: vk::ImageLayout::UNDEFINED,
    };
    let transfer = Access {
        stage: vk::PipelineStageFlags::TRANSFER,
        access: vk::AccessFlags::TRANSFER_READ,
        layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
    };
    image_barriers(
        d,
        cmd,
        undefined.stage,
        attachment.stage,
        &[image_barrier(undefined, attachment, image.raw, aspect)],
    );
    let depth = cleared_depth(image.view, vk::AttachmentStoreOp::STORE);
    let with_stencil = aspect.contains(vk::ImageAspectFlags::STENCIL);
    let ri = vk::RenderingInfo::default()
        .render_area(area())
        .layer_count(1)
        .depth_attachment(&depth);
    let ri = match with_stencil {
        true => ri.stencil_attachment(&depth),
        false => ri,
    };
    // SAFETY: recording; the image is in the attachment layout (barrier above).
    unsafe { d.cmd_begin_rendering(cmd, &ri) };
    set_triangle(d, cmd, layout, bits);
    // SAFETY: the pipeline was made for the image's format; viewport and
    // scissor cover it.
    unsafe {
        d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
        d.cmd_draw(cmd, 3, 1, 0, 0);
        d.cmd_end_rendering(cmd);
    }
    image_barriers(
        d,
        cmd,
        attachment.stage,
        transfer.stage,
        &[image_barrier(attachment, transfer, image.raw, aspect)],
    );
    let region = read_region(vk::ImageAspectFlags::DEPTH);
    // SAFETY: the image is in TRANSFER_SRC_OPTIMAL; the buffer holds SIDE² words.
    unsafe { d.cmd_copy_image_to_buffer(cmd, image.raw, transfer.layout, buffer.raw, &[region]) };
    transfer_to_host_barrier(d, cmd);
    submit.finish(cmd)?;
    let bytes = buffer.mapped()?;
    Ok(bytes
        .chunks_exact(4)
        .map(|w| f32::from_ne_bytes([w[0], w[1], w[2], w[3]]))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Depths as a rasterizer computes them from `v` at the pixel centres.
    fn raster(v: &[[f64; 3]; 3]) -> Vec<f32> {
        (0..SIDE * SIDE)
            .map(|k| {
                let (x, y) = ((k % SIDE) as f64 + 0.5, (k / SIDE) as f64 + 0.5);
                plane(v, x, y, 0.0).0 as f32
            })
            .collect()
    }

    #[test]
    fn unsnapped_interpolation_is_told_from_snapped() {
        for bits in [4, 8, 12] {
            let (_, fb) = vertices(bits);
            let exact = compare(&raster(&fb), bits);
            assert!(exact.pixels > 30, "{exact:?}");
            assert!(exact.unsnapped(), "{bits} bits: {exact:?}");
            let s = (bits as f64).exp2();
            let snapped = fb.map(|[x, y, z]| [(x * s).round() / s, (y * s).round() / s, z]);
            let snap = compare(&raster(&snapped), bits);
            assert!(!snap.unsnapped(), "{bits} bits: {snap:?}");
            // 50× the tolerance at 8 bits (hardware's usual grid), still
            // above it at 12.
            let margin = if bits <= 8 { 10.0 } else { 1.0 };
            assert!(
                snap.unsnapped_error > margin * UNSNAPPED_TOLERANCE,
                "{bits} bits: {snap:?}"
            );
        }
    }
}
