//! Frames of peeltrim's own embedding hosts — the viewer's swapchain frames
//! (`present`) and the bench's off-screen frames ([`OffscreenHost`]): the host's
//! colour and depth attachments cleared and left in the layouts
//! [`Embedder::record`] expects, then peeltrim's CSG recorded into them, exactly
//! as an engine would (docs/embedding.md).

use std::sync::Arc;
use std::time::Instant;

use ash::vk;

use super::cpu_clock;
use super::embed::{Embedder, HostTargets};
use super::error::VkError;
use super::exec::ExecStats;
use super::image::{Image, ImageDesc};
use super::instance::{Context, Shared};
use super::submit::{self, Submitter};
use super::sync::{image_barrier, Access};

/// The colour attachment's state inside a host frame.
pub(crate) const COLOR_ATTACHMENT: Access = Access {
    stage: vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
    access: vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
    layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
};

const TESTS: vk::PipelineStageFlags = vk::PipelineStageFlags::from_raw(
    vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS.as_raw()
        | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS.as_raw(),
);

const DEPTH_ATTACHMENT: Access = Access {
    stage: TESTS,
    access: vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
    layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
};

/// The host's attachments of one frame.
pub(crate) struct HostAttachments<'a> {
    /// Colour image, its view and format.
    pub color: (vk::Image, vk::ImageView, vk::Format),
    /// The depth buffer (a combined depth-stencil format of `vk::image`).
    pub depth: &'a Image,
    pub extent: vk::Extent2D,
}

/// Records the host's part of a frame into `cmd`: both attachments from
/// `UNDEFINED` (after earlier frames' attachment writes) to attachment layouts,
/// cleared to `background` and `far_depth` by the host's own pass (an engine
/// draws its scene there). The attachments are left in the layouts
/// [`Embedder::record`] expects.
///
/// # Safety
///
/// `cmd` records outside rendering and is submitted to the context's queue;
/// the attachments are live, not used by pending work other than earlier frames
/// on that queue.
pub(crate) unsafe fn record_host_pass(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    att: &HostAttachments<'_>,
    background: [u8; 3],
    far_depth: f32,
) {
    let stages = COLOR_ATTACHMENT.stage | TESTS;
    let undefined = |access| Access {
        stage: stages,
        access,
        layout: vk::ImageLayout::UNDEFINED,
    };
    let barriers = [
        image_barrier(
            undefined(vk::AccessFlags::COLOR_ATTACHMENT_WRITE),
            COLOR_ATTACHMENT,
            att.color.0,
            vk::ImageAspectFlags::COLOR,
        ),
        image_barrier(
            undefined(vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE),
            DEPTH_ATTACHMENT,
            att.depth.raw,
            att.depth.desc.aspect(),
        ),
    ];
    submit::image_barriers(device, cmd, stages, stages, &barriers);
    let bg = background.map(|c| c as f32 / 255.0);
    let colors = [vk::RenderingAttachmentInfo::default()
        .image_view(att.color.1)
        .image_layout(COLOR_ATTACHMENT.layout)
        .load_op(vk::AttachmentLoadOp::CLEAR)
        .store_op(vk::AttachmentStoreOp::STORE)
        .clear_value(vk::ClearValue {
            color: vk::ClearColorValue {
                float32: [bg[0], bg[1], bg[2], 1.0],
            },
        })];
    let depth = vk::RenderingAttachmentInfo::default()
        .image_view(att.depth.view)
        .image_layout(DEPTH_ATTACHMENT.layout)
        .load_op(vk::AttachmentLoadOp::CLEAR)
        .store_op(vk::AttachmentStoreOp::STORE)
        .clear_value(vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth: far_depth,
                stencil: 0,
            },
        });
    let ri = vk::RenderingInfo::default()
        .render_area(att.extent.into())
        .layer_count(1)
        .color_attachments(&colors)
        .depth_attachment(&depth);
    // SAFETY: outside rendering (the caller's contract); both views are
    // attachments in the layouts the barrier above set.
    unsafe { device.cmd_begin_rendering(cmd, &ri) };
    // SAFETY: closes the block just begun.
    unsafe { device.cmd_end_rendering(cmd) };
}

/// [`record_host_pass`], then `embedder`'s CSG ([`Embedder::record`]) — skipped
/// (`None`) when the attachments are not the embedder's size. The colour image
/// is left in [`COLOR_ATTACHMENT`].
///
/// # Safety
///
/// As [`record_host_pass`]; `embedder`'s frames-in-flight contract holds for `cmd`.
#[cfg(feature = "present")]
pub(crate) unsafe fn record_host_frame(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    att: &HostAttachments<'_>,
    background: [u8; 3],
    far_depth: f32,
    embedder: &mut Embedder,
) -> Result<Option<ExecStats>, VkError> {
    // SAFETY: the caller's contract.
    unsafe { record_host_pass(device, cmd, att, background, far_depth) };
    let targets = att.targets();
    let d = embedder.desc();
    if targets.extent != [d.width, d.height] {
        return Ok(None);
    }
    // SAFETY: the caller's contract is `record`'s; the attachments are in the
    // layouts it names (the host pass above).
    Ok(Some(unsafe { embedder.record(cmd, &targets) }?))
}

impl HostAttachments<'_> {
    /// The attachments as [`Embedder::record`] takes them.
    fn targets(&self) -> HostTargets {
        HostTargets {
            color_view: self.color.1,
            color_format: self.color.2,
            depth_view: self.depth.view,
            depth_format: self.depth.desc.format,
            extent: [self.extent.width, self.extent.height],
        }
    }
}

/// The host's depth format: a combined one, so that `vk::image` makes its
/// attachment view with both aspects (D24S8 where D32S8 is not usable).
pub(crate) fn host_depth_format(shared: &Shared) -> vk::Format {
    // SAFETY: physical device of this instance; plain query.
    let fp = unsafe {
        shared
            .instance
            .get_physical_device_format_properties(shared.physical, vk::Format::D32_SFLOAT_S8_UINT)
    };
    if fp
        .optimal_tiling_features
        .contains(vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT)
    {
        vk::Format::D32_SFLOAT_S8_UINT
    } else {
        vk::Format::D24_UNORM_S8_UINT
    }
}

/// An off-screen host (the bench's `--embedded`): its own RGBA8 colour and
/// depth attachments and command buffer, one frame in flight. Its own pass (the
/// clear) is submitted apart ([`OffscreenHost::clear`]) so that a frame's timed
/// submission ([`OffscreenHost::frame`]) holds peeltrim's commands alone, as the
/// standalone path's does: the host's work is excluded from the comparison.
pub struct OffscreenHost {
    // Field order is drop order: every submission was waited for.
    submit: Submitter,
    color: Image,
    depth: Image,
    shared: Arc<Shared>,
}

impl OffscreenHost {
    /// Attachments of `extent` on `ctx`'s device.
    pub fn new(ctx: &Context, extent: [u32; 2]) -> Result<OffscreenHost, VkError> {
        let shared = ctx.shared.clone();
        let _layer = shared.layer_use();
        let color = Image::new(
            &shared,
            "host colour",
            ImageDesc::new_2d(vk::Format::R8G8B8A8_UNORM, extent)
                .usage(vk::ImageUsageFlags::COLOR_ATTACHMENT),
        )?;
        let depth = Image::new(
            &shared,
            "host depth",
            ImageDesc::new_2d(host_depth_format(&shared), extent)
                .usage(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT),
        )?;
        Ok(OffscreenHost {
            submit: Submitter::new(&shared)?,
            color,
            depth,
            shared,
        })
    }

    fn attachments(&self) -> HostAttachments<'_> {
        let d = self.color.desc.extent;
        HostAttachments {
            color: (self.color.raw, self.color.view, self.color.desc.format),
            depth: &self.depth,
            extent: vk::Extent2D {
                width: d[0],
                height: d[1],
            },
        }
    }

    /// The host's own pass of a frame (its clear), submitted and waited for.
    pub fn clear(&mut self, background: [u8; 3], far_depth: f32) -> Result<(), VkError> {
        let _layer = self.shared.layer_use();
        let cmd = self.submit.cmd;
        self.submit.begin(cmd, true)?;
        // SAFETY: `cmd` was just begun on the context's queue family and is
        // submitted and waited for here, so no other frame is pending.
        unsafe {
            record_host_pass(
                &self.shared.device,
                cmd,
                &self.attachments(),
                background,
                far_depth,
            )
        };
        self.submit.finish(cmd)
    }

    /// `embedder`'s CSG (made for one frame in flight) recorded into the
    /// attachments [`OffscreenHost::clear`] left, submitted and waited for: its
    /// recording's stats with `record_ms` (CPU time recording), `frame_ms` (wall
    /// time from submission to completion, as the standalone path measures it)
    /// and `frame_cpu_ms` (the process's CPU time over that interval).
    pub fn frame(&mut self, embedder: &mut Embedder) -> Result<ExecStats, VkError> {
        let _layer = self.shared.layer_use();
        let cmd = self.submit.cmd;
        let record_start = Instant::now();
        self.submit.begin(cmd, true)?;
        let targets = self.attachments().targets();
        // SAFETY: `cmd` was just begun on the context's queue family and is
        // submitted below and waited for, so no other frame is pending; `clear`
        // left the attachments in the layouts `record` names.
        let stats = unsafe { embedder.record(cmd, &targets) }?;
        self.submit.end(cmd)?;
        let record_ms = record_start.elapsed().as_secs_f64() * 1e3;
        let cpu = cpu_clock::process_ns();
        let t = Instant::now();
        self.submit.submit(cmd, &[], &[])?;
        self.submit.wait()?;
        let frame_ms = t.elapsed().as_secs_f64() * 1e3;
        Ok(ExecStats {
            record_ms,
            frame_ms,
            frame_cpu_ms: cpu_clock::ms_since(cpu),
            ..stats
        })
    }
}
