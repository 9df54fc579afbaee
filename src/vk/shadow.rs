//! The shadow pass of a `[light]` (Rossignac & Wu's shadow buffer; docs/shadows.md):
//! after the eye's frame and the light's depth map have run on two executors of
//! one device, one full-screen draw (`shaders/shadow.frag`), scissored to the
//! eye's projected bounds, samples the eye's depth, ids and normal buffer and the
//! map's depth and ids as textures, darkens the shadowed pixels of the eye's
//! colour image in place (by blending, so the pass never reads the image it
//! writes) and marks them in a mask image of its own. Both frames' images stay
//! on the GPU: nothing is read back between them. The pass goes in one
//! submission with the frames it reads when they replay (`submit_after`).

/// Fraction of a shadowed pixel's colour kept; the lit shading is the
/// reference's ([`crate::images::shade`]).
pub const SHADOW_KEEP: f64 = 0.5;

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::error::{Check, VkError};
use super::exec::{copy_to_host, Executor};
use super::image::{Image, ImageDesc};
use super::instance::{Context, Shared};
use super::memory::Buffer;
use super::pipeline::{graphics_pipeline, Graphics};
use super::scissor::Rect;
use super::submit::{self, Queries, Submitter};
use super::sync::{self, REST};
use crate::plan::usage::Usage;

const FRAG: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/shadow.frag.spv"));

/// The mask image's format: 1 where the pass found a shadow, 0 elsewhere.
const MASK_FORMAT: vk::Format = vk::Format::R8_UNORM;

/// The pass's uniform block (`Shadow` in `shaders/shadow.frag`, std140: every
/// member a mat4 or vec4), in world units relative to one origin.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShadowParams {
    /// An eye pixel's `(nx·d, ny·d, d, 1)` (perspective) or `(nx, ny, d, 1)`
    /// (orthographic), NDC `(nx, ny)` and view depth `d`, to world (column-major).
    pub eye_unproject: [f32; 16],
    /// World to the light's clip space, standard depth (column-major).
    pub light_clip: [f32; 16],
    /// The eye camera: near, far, 1 when orthographic, 1 when reversed depth.
    pub eye_cam: [f32; 4],
    /// The light's map camera, laid out as `eye_cam`.
    pub map_cam: [f32; 4],
    /// The eye position (xyz); w 1 for perspective.
    pub eye_pos: [f32; 4],
    /// The eye's unit view direction (xyz).
    pub eye_fwd: [f32; 4],
    /// The light's eye position (xyz); w 1 for a point light.
    pub light_pos: [f32; 4],
    /// The light's unit view direction (xyz); w a map texel's world size
    /// (orthographic) or that size per unit of light view depth (perspective).
    pub light_fwd: [f32; 4],
    /// The eye image's width and height, then the map's.
    pub sizes: [f32; 4],
    /// 1 for float depth (D32) else 0; `2^-(subpixel bits + 1)`; the number
    /// of closed primitives (higher ids are open surfaces); unused.
    pub prec: [f32; 4],
}

impl ShadowParams {
    /// The block's bytes in declaration order.
    fn bytes(&self) -> Vec<u8> {
        [
            &self.eye_unproject[..],
            &self.light_clip,
            &self.eye_cam,
            &self.map_cam,
            &self.eye_pos,
            &self.eye_fwd,
            &self.light_pos,
            &self.light_fwd,
            &self.sizes,
            &self.prec,
        ]
        .concat()
        .iter()
        .flat_map(|v| v.to_ne_bytes())
        .collect()
    }
}

/// What one shadow pass cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShadowRun {
    /// GPU time of the draw (0 without timestamps).
    pub gpu_ms: f64,
    /// Pixels the scissored full-screen draw covered.
    pub pixels: u64,
}

/// The pass's Vulkan objects for one eye image size.
pub struct ShadowPass {
    shared: Arc<Shared>,
    extent: [u32; 2],
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    pipeline: vk::Pipeline,
    sampler: vk::Sampler,
    uniform: Buffer,
    mask: Image,
    submit: Submitter,
    timestamps: Queries,
    /// The views the set points at (eye depth, ids, normals, map depth, ids).
    views: Option<[vk::ImageView; 5]>,
    /// Whether the mask holds a pass's result.
    ran: bool,
}

/// Sampled-image bindings 0–4 of the set, then the sampler (5) and the uniform (6).
const IMAGES: u32 = 5;

impl ShadowPass {
    /// The pass for eye images of `width × height` on `ctx`'s device.
    pub fn new(ctx: &Context, width: u32, height: u32) -> Result<ShadowPass, VkError> {
        let shared = ctx.shared.clone();
        let _layer = shared.layer_use();
        let device = &shared.device;
        let uniform = Buffer::new(
            &shared,
            "shadow uniform",
            ShadowParams::default().bytes().len() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        let mask = Image::new(
            &shared,
            "shadow mask",
            ImageDesc::new_2d(MASK_FORMAT, [width, height])
                .usage(vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC),
        )?;
        let mut timestamps = Queries::new(&shared, vk::QueryType::TIMESTAMP);
        timestamps.ensure(2)?;
        let mut p = ShadowPass {
            submit: Submitter::new(&shared)?,
            shared: shared.clone(),
            extent: [width, height],
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            pipeline: vk::Pipeline::null(),
            sampler: vk::Sampler::null(),
            uniform,
            mask,
            timestamps,
            views: None,
            ran: false,
        };
        let binding = super::pipeline::fragment_binding;
        let mut bindings: Vec<_> = (0..IMAGES)
            .map(|b| binding(b, vk::DescriptorType::SAMPLED_IMAGE))
            .collect();
        bindings.push(binding(IMAGES, vk::DescriptorType::SAMPLER));
        bindings.push(binding(IMAGES + 1, vk::DescriptorType::UNIFORM_BUFFER));
        let dci = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid create info on a live device (objects made here are
        // destroyed by `Drop` even when a later step fails; null is ignored).
        p.set_layout = unsafe { device.create_descriptor_set_layout(&dci, None) }
            .check("vkCreateDescriptorSetLayout")?;
        let set_layouts = [p.set_layout];
        let lci = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        // SAFETY: valid create info; the set layout is live.
        p.layout =
            unsafe { device.create_pipeline_layout(&lci, None) }.check("vkCreatePipelineLayout")?;
        let sizes = [
            (vk::DescriptorType::SAMPLED_IMAGE, IMAGES),
            (vk::DescriptorType::SAMPLER, 1),
            (vk::DescriptorType::UNIFORM_BUFFER, 1),
        ]
        .map(|(ty, descriptor_count)| vk::DescriptorPoolSize {
            ty,
            descriptor_count,
        });
        let pci = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: valid create info.
        p.pool =
            unsafe { device.create_descriptor_pool(&pci, None) }.check("vkCreateDescriptorPool")?;
        let ai = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(p.pool)
            .set_layouts(&set_layouts);
        // SAFETY: the pool has room for this one set.
        p.set =
            unsafe { device.allocate_descriptor_sets(&ai) }.check("vkAllocateDescriptorSets")?[0];
        let sci = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST);
        // SAFETY: valid create info on a live device.
        p.sampler = unsafe { device.create_sampler(&sci, None) }.check("vkCreateSampler")?;
        p.pipeline = p.make_pipeline()?;
        p.write_fixed();
        Ok(p)
    }

    fn make_pipeline(&self) -> Result<vk::Pipeline, VkError> {
        // Shadowed fragments write 0 to the colour and 1 to the mask: with
        // `ONE · src + keep · dst` the colour becomes `keep · colour` and the
        // (cleared) mask 1. One state for both attachments (no independent blend).
        let one = vk::PipelineColorBlendAttachmentState::default()
            .blend_enable(true)
            .src_color_blend_factor(vk::BlendFactor::ONE)
            .dst_color_blend_factor(vk::BlendFactor::CONSTANT_COLOR)
            .color_blend_op(vk::BlendOp::ADD)
            .src_alpha_blend_factor(vk::BlendFactor::ZERO)
            .dst_alpha_blend_factor(vk::BlendFactor::ONE)
            .alpha_blend_op(vk::BlendOp::ADD)
            .color_write_mask(
                vk::ColorComponentFlags::R
                    | vk::ColorComponentFlags::G
                    | vk::ColorComponentFlags::B,
            );
        // `keep` a little over SHADOW_KEEP: an odd channel value's half is a
        // tie, which the UNORM conversion may round either way; 2^-10 more
        // rounds it up, as the CPU's `round` does, and leaves even values'
        // halves exact (255 · 2^-10 < 0.25).
        let keep = (SHADOW_KEEP + 1.0 / 1024.0) as f32;
        super::stages::fullscreen_pipeline(&self.shared, FRAG, |stages| {
            graphics_pipeline(
                &self.shared.device,
                &Graphics {
                    stages,
                    vertex_input: &vk::PipelineVertexInputStateCreateInfo::default(),
                    cull: vk::CullModeFlags::NONE,
                    depth_stencil: &vk::PipelineDepthStencilStateCreateInfo::default(),
                    dynamic_states: &[vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR],
                    color_formats: &[super::exec::color_format(), MASK_FORMAT],
                    depth_format: vk::Format::UNDEFINED,
                    stencil_format: vk::Format::UNDEFINED,
                    layout: self.layout,
                    samples: 1,
                    sample_shading: false,
                    blend: Some((one, [keep; 4])),
                },
            )
        })
    }

    /// The eye image size the pass was made for.
    pub fn extent(&self) -> [u32; 2] {
        self.extent
    }

    /// Points the set at the sampler and the uniform buffer (once).
    fn write_fixed(&self) {
        let si = [vk::DescriptorImageInfo {
            sampler: self.sampler,
            image_view: vk::ImageView::null(),
            image_layout: vk::ImageLayout::UNDEFINED,
        }];
        let bi = [vk::DescriptorBufferInfo {
            buffer: self.uniform.raw,
            offset: 0,
            range: vk::WHOLE_SIZE,
        }];
        let writes = [
            vk::WriteDescriptorSet::default()
                .dst_set(self.set)
                .dst_binding(IMAGES)
                .descriptor_type(vk::DescriptorType::SAMPLER)
                .image_info(&si),
            vk::WriteDescriptorSet::default()
                .dst_set(self.set)
                .dst_binding(IMAGES + 1)
                .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
                .buffer_info(&bi),
        ];
        // SAFETY: set, sampler and buffer are live; no command buffer uses the set yet.
        unsafe { self.shared.device.update_descriptor_sets(&writes, &[]) };
    }

    /// Points the set at `views` unless it already does (no pass is pending:
    /// every run waits for its submission).
    fn write_views(&mut self, views: [vk::ImageView; 5]) {
        if self.views == Some(views) {
            return;
        }
        let sampled = sync::access(Usage::Sampled).layout;
        let infos = views.map(|image_view| {
            [vk::DescriptorImageInfo {
                sampler: vk::Sampler::null(),
                image_view,
                image_layout: sampled,
            }]
        });
        let writes: Vec<_> = infos
            .iter()
            .enumerate()
            .map(|(b, i)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(self.set)
                    .dst_binding(b as u32)
                    .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
                    .image_info(i)
            })
            .collect();
        // SAFETY: the views are live; the set is not used by a pending command buffer.
        unsafe { self.shared.device.update_descriptor_sets(&writes, &[]) };
        self.views = Some(views);
    }

    /// Darkens the shadowed pixels of `eye`'s last frame by `map`'s last frame
    /// (both executors of this pass's device, idle), within `scissor`, in one
    /// submission waited for. `eye` must have written its normal buffer
    /// ([`Executor::set_normals`]).
    pub fn run(
        &mut self,
        eye: &Executor,
        map: &Executor,
        params: &ShadowParams,
        scissor: Rect,
    ) -> Result<ShadowRun, VkError> {
        self.record_own(eye, map, params, scissor)?;
        self.submit_after(&[])?;
        self.result(scissor)
    }

    /// Records the pass into its own command buffer for [`Self::submit_after`]:
    /// `eye` and `map` are idle or their frames go in that submission first
    /// (their images' views are the last frames').
    pub fn record_own(
        &mut self,
        eye: &Executor,
        map: &Executor,
        params: &ShadowParams,
        scissor: Rect,
    ) -> Result<(), VkError> {
        let _layer = self.shared.layer_use();
        let cmd = self.submit.cmd;
        self.submit.begin(cmd, true)?;
        let ts = (self.shared.timestamp_valid_bits > 0).then_some(self.timestamps.pool);
        self.record(cmd, eye, map, params, scissor, ts)?;
        self.submit.end(cmd)
    }

    /// Submits the executable `before` (frames whose images the pass reads,
    /// in order) and then the pass recorded by [`Self::record_own`], in one
    /// submission, and waits for it: a shadowed frame is one submission.
    pub fn submit_after(&self, before: &[vk::CommandBuffer]) -> Result<(), VkError> {
        let _layer = self.shared.layer_use();
        let mut cmds = before.to_vec();
        cmds.push(self.submit.cmd);
        self.submit.submit_all(&cmds, &[], &[])?;
        self.submit.wait()
    }

    /// What the last submitted pass over `scissor` cost.
    pub fn result(&self, scissor: Rect) -> Result<ShadowRun, VkError> {
        let _layer = self.shared.layer_use();
        let device = &self.shared.device;
        let gpu_ms = match self.shared.timestamp_valid_bits > 0 {
            true => {
                let t = submit::query_results(device, self.timestamps.pool, 2)?;
                t[1].saturating_sub(t[0]) as f64 * self.shared.limits.timestamp_period as f64 * 1e-6
            }
            false => 0.0,
        };
        Ok(ShadowRun {
            gpu_ms,
            pixels: scissor.area(),
        })
    }

    /// Records the pass into `cmd` (recording, outside rendering), with
    /// timestamps 0 and 1 of `ts` around the draw. Every image starts and ends
    /// in `sync::REST`; the uniform block is written in the command stream, so
    /// earlier recordings may still be pending. The views of `eye`'s and `map`'s
    /// images may change only when none is (they change with a new plan).
    pub fn record(
        &mut self,
        cmd: vk::CommandBuffer,
        eye: &Executor,
        map: &Executor,
        params: &ShadowParams,
        scissor: Rect,
        ts: Option<vk::QueryPool>,
    ) -> Result<(), VkError> {
        let d = eye.desc();
        if [d.width, d.height] != self.extent {
            return Err(VkError::Plan(format!(
                "shadow pass made for {}x{}, eye frame {}x{}",
                self.extent[0], self.extent[1], d.width, d.height
            )));
        }
        let no_frame = || VkError::Plan("shadow pass before both frames ran".into());
        let (e, m) = (
            eye.output(None).ok_or_else(no_frame)?,
            map.output(None).ok_or_else(no_frame)?,
        );
        let normal = eye.normal_output().ok_or_else(|| {
            VkError::Plan("shadow pass needs the eye frame's normal buffer".into())
        })?;
        self.write_views([e.depth.1, e.prim.1, normal.1, m.depth.1, m.prim.1]);
        let device = &self.shared.device;
        if let Some(pool) = ts {
            // SAFETY: recording, outside rendering; the pool holds 2 queries.
            unsafe { device.cmd_reset_query_pool(cmd, pool, 0, 2) };
        }
        // The uniform block in the stream: after earlier passes' reads of it,
        // before this pass's.
        let frag = vk::PipelineStageFlags::FRAGMENT_SHADER;
        let transfer = vk::PipelineStageFlags::TRANSFER;
        submit::memory_barrier(
            device,
            cmd,
            (frag, vk::AccessFlags::empty()),
            (transfer, vk::AccessFlags::TRANSFER_WRITE),
        );
        // SAFETY: outside rendering; the buffer allows transfer dst and holds
        // the block (a multiple of 4 bytes, under 64 KiB).
        unsafe { device.cmd_update_buffer(cmd, self.uniform.raw, 0, &params.bytes()) };
        let ds = vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL;
        let col = vk::ImageAspectFlags::COLOR;
        let sampled = [
            (e.depth.0, ds),
            (e.prim.0, col),
            (normal.0, col),
            (m.depth.0, ds),
            (m.prim.0, col),
        ];
        // The five sampled images, the colour and the mask change layout
        // together: one barrier before the draw (with the uniform block's
        // write) and one after. The mask is cleared by its load op: its old
        // contents need not be kept.
        let transitions = |sampled_to: (Usage, Usage),
                           targets_to: (Usage, Usage),
                           uniform: &[vk::MemoryBarrier]| {
            let (s_src, s_dst) = sync::transition(sampled_to.0, sampled_to.1, false);
            let (t_src, t_dst) = sync::transition(targets_to.0, targets_to.1, false);
            let discard = targets_to.1 == Usage::ColorTarget;
            let (m_src, m_dst) = sync::transition(targets_to.0, targets_to.1, discard);
            let mut b: Vec<_> = sampled
                .iter()
                .map(|&(img, aspect)| sync::image_barrier(s_src, s_dst, img, aspect))
                .collect();
            b.push(sync::image_barrier(t_src, t_dst, e.color.0, col));
            b.push(sync::image_barrier(m_src, m_dst, self.mask.raw, col));
            let (src, dst) = match uniform.is_empty() {
                true => (s_src.stage | t_src.stage, s_dst.stage | t_dst.stage),
                false => (
                    s_src.stage | t_src.stage | transfer,
                    s_dst.stage | t_dst.stage | frag,
                ),
            };
            submit::pipeline_barrier(device, cmd, (src, dst), uniform, &b);
        };
        let uniform = [vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::UNIFORM_READ)];
        transitions((REST, Usage::Sampled), (REST, Usage::ColorTarget), &uniform);
        if let Some(pool) = ts {
            // SAFETY: recording, outside rendering; query 0 was reset above.
            unsafe {
                device.cmd_write_timestamp(cmd, vk::PipelineStageFlags::TOP_OF_PIPE, pool, 0)
            };
        }
        self.draw(cmd, e.color.1, scissor);
        if let Some(pool) = ts {
            // SAFETY: as above, query 1.
            unsafe {
                device.cmd_write_timestamp(cmd, vk::PipelineStageFlags::BOTTOM_OF_PIPE, pool, 1)
            };
        }
        transitions((Usage::Sampled, REST), (Usage::ColorTarget, REST), &[]);
        self.ran = true;
        Ok(())
    }

    /// The draw: the mask cleared over the whole image, the full-screen
    /// triangle within `scissor`.
    fn draw(&self, cmd: vk::CommandBuffer, color: vk::ImageView, scissor: Rect) {
        let device = &self.shared.device;
        let extent = vk::Extent2D {
            width: self.extent[0],
            height: self.extent[1],
        };
        let attachments = [
            vk::RenderingAttachmentInfo::default()
                .image_view(color)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::LOAD)
                .store_op(vk::AttachmentStoreOp::STORE),
            vk::RenderingAttachmentInfo::default()
                .image_view(self.mask.view)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue::default()),
        ];
        let ri = vk::RenderingInfo::default()
            .render_area(extent.into())
            .layer_count(1)
            .color_attachments(&attachments);
        // SAFETY: outside rendering; both views are colour attachments in
        // `COLOR_ATTACHMENT_OPTIMAL` (barrier in `record`).
        unsafe { device.cmd_begin_rendering(cmd, &ri) };
        // The set's images are in `SHADER_READ_ONLY_OPTIMAL` (barrier in `record`).
        super::composite::bind_fullscreen(
            device,
            cmd,
            (self.pipeline, self.layout, self.set),
            extent,
            super::conv::rect2d(scissor),
        );
        if !scissor.is_empty() {
            // SAFETY: pipeline, set and state bound; the vertex shader needs no buffer.
            unsafe { device.cmd_draw(cmd, 3, 1, 0, 0) };
        }
        // SAFETY: closes the block begun above.
        unsafe { device.cmd_end_rendering(cmd) };
    }

    /// The last pass's mask: per pixel of the eye image, whether it was shadowed.
    pub fn read_mask(&mut self) -> Result<Vec<bool>, VkError> {
        let _layer = self.shared.layer_use();
        if !self.ran {
            return Err(VkError::Plan("read_mask before a shadow pass".into()));
        }
        let [w, h] = self.extent;
        let bytes = copy_to_host(&self.shared, &self.submit, self.mask.raw, [w, h], 1)?;
        Ok(bytes.iter().map(|&v| v >= 128).collect())
    }
}

/// Shadows in an embedded frame (`vk::Embedder::set_shadow`): the light's map,
/// rendered standalone on its own executor beforehand, and the pass recorded
/// after each frame, before the composite, with `params` of the current camera.
pub struct EmbeddedShadow {
    /// The shadow test pass, recorded after each frame.
    pub pass: ShadowPass,
    /// The executor holding the light's depth map.
    pub map: Executor,
    /// The pass's uniform block for the current camera.
    pub params: ShadowParams,
}

impl Drop for ShadowPass {
    fn drop(&mut self) {
        let _layer = self.shared.layer_use();
        let device = &self.shared.device;
        // SAFETY (each call): every submission of the pass was waited on, so no
        // pending command buffer uses these objects; null handles are ignored.
        unsafe { device.destroy_pipeline(self.pipeline, None) };
        // SAFETY: as above.
        unsafe { device.destroy_sampler(self.sampler, None) };
        // SAFETY: as above; destroying the pool frees its set.
        unsafe { device.destroy_descriptor_pool(self.pool, None) };
        // SAFETY: as above.
        unsafe { device.destroy_pipeline_layout(self.layout, None) };
        // SAFETY: as above.
        unsafe { device.destroy_descriptor_set_layout(self.set_layout, None) };
    }
}
