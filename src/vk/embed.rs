//! Embedding: a plan's frame recorded into a host engine's command buffer and
//! composited, depth-tested, into the host's own colour and depth attachments.
//! Nothing here submits to a queue (see README "Embedding" for the full
//! synchronization contract, repeated on [`Embedder::record`]).
//!
//! The frame itself is the executor's unrolled recording (loops unrolled to learnt
//! counts, as in the standalone replay of the performance work). Its occlusion
//! counts are copied on the GPU (`vkCmdCopyQueryPoolResults`) into a host-visible
//! ring slot per frame in flight, and checked when that slot comes round again,
//! i.e. after the host has waited for the frame: no CPU wait is ever added. A
//! failed check adjusts the counts for the next frames.
#![warn(missing_docs)]

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::error::{Check, VkError};
use super::exec::{ExecDesc, ExecStats, Executor, Unrolled};
use super::instance::{Context, Shared};
use super::memory::Buffer;
use super::submit;
use super::sync::{self, REST};
use crate::plan::usage::Usage;
use crate::plan::Plan;

const VERT: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/fullscreen.vert.spv"));
const FRAG: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/composite.frag.spv"));

/// The host's attachments for one frame. Both are views of 2D images of
/// `extent` with one mip level and one layer; see [`Embedder::record`] for the
/// layouts they must be in.
#[derive(Clone, Copy, Debug)]
pub struct HostTargets {
    /// A colour view whose format is a float or UNORM/SRGB colour-attachment
    /// format (peeltrim writes RGBA in 0..1).
    pub color_view: vk::ImageView,
    /// The format of the colour image (the composite pipeline is made for it).
    pub color_format: vk::Format,
    /// A view of the depth aspect of a depth or depth-stencil image (any depth
    /// format the device supports as an attachment); stencil is not touched.
    pub depth_view: vk::ImageView,
    /// The format of the depth image.
    pub depth_format: vk::Format,
    /// Width and height of both images: the embedder's size.
    pub extent: [u32; 2],
}

/// One frame in flight: where its occlusion counts land and what they check.
struct Slot {
    counts: Buffer,
    pending: Option<(Plan, Unrolled)>,
}

/// The composite pass's objects, made for one pair of host formats.
struct Composite {
    formats: (vk::Format, vk::Format),
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    pipeline: vk::Pipeline,
    /// Executor epoch the set's views belong to.
    epoch: Option<u64>,
}

/// Records plans into a host's command buffers (see the module doc).
pub struct Embedder {
    shared: Arc<Shared>,
    exec: Executor,
    slots: Vec<Slot>,
    frame: u64,
    /// Loop counts to unroll to (learnt standalone, then adjusted by checks).
    layers: Option<(Plan, Vec<u32>)>,
    composite: Option<Composite>,
    sampler: vk::Sampler,
    /// What `record` draws.
    plan: Option<Plan>,
}

impl Embedder {
    /// An embedder whose internal images have `desc`'s size and depth set-up;
    /// `frames_in_flight`: the most recorded frames the host has submitted and not
    /// yet waited for at any time (1 for a host that waits every frame).
    pub fn new(ctx: &Context, desc: &ExecDesc, frames_in_flight: u32) -> Result<Embedder, VkError> {
        let _layer = ctx.shared.layer_use();
        let shared = ctx.shared.clone();
        let exec = Executor::new(ctx, desc)?;
        let sci = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST);
        // SAFETY: valid create info on a live device.
        let sampler =
            unsafe { shared.device.create_sampler(&sci, None) }.check("vkCreateSampler")?;
        let slots = (0..frames_in_flight.max(1) + 1)
            .map(|i| {
                Ok(Slot {
                    counts: Buffer::new(
                        &shared,
                        &format!("embed counts {i}"),
                        16,
                        vk::BufferUsageFlags::TRANSFER_DST,
                        MemoryLocation::GpuToCpu,
                    )?,
                    pending: None,
                })
            })
            .collect::<Result<Vec<_>, VkError>>()?;
        Ok(Embedder {
            shared,
            exec,
            slots,
            frame: 0,
            layers: None,
            composite: None,
            sampler,
            plan: None,
        })
    }

    /// Size and depth set-up of the internal images.
    pub fn desc(&self) -> &ExecDesc {
        self.exec.desc()
    }

    /// The executor (upload meshes, move the camera, run standalone frames).
    pub fn executor(&mut self) -> &mut Executor {
        &mut self.exec
    }

    /// Sets the plan [`Embedder::record`] draws (kept when equal to the current one).
    /// A new plan with as many loops keeps the old loop counts as its first
    /// guess (the GPU check corrects them, see the module doc).
    pub fn set_plan(&mut self, plan: Plan) {
        if self.plan.as_ref() == Some(&plan) {
            return;
        }
        let loops = |p: &Plan| {
            p.steps
                .iter()
                .filter(|s| matches!(s, crate::plan::Step::Loop(_)))
                .count()
        };
        if let Some((old, l)) = self.layers.take() {
            if loops(&old) == loops(&plan) {
                self.layers = Some((plan.clone(), l));
            }
        }
        self.plan = Some(plan);
    }

    /// The plan [`Embedder::record`] draws.
    pub fn plan(&self) -> Option<&Plan> {
        self.plan.as_ref()
    }

    /// Runs the plan once standalone on peeltrim's queue, waiting for it, to learn
    /// its loop counts. Not part of the record path: call it when the host has no
    /// frame of this embedder pending (at load, or after a big change of view).
    pub fn prepare(&mut self) -> Result<ExecStats, VkError> {
        let _layer = self.shared.layer_use();
        let plan = self
            .plan
            .clone()
            .ok_or_else(|| VkError::Plan("prepare before set_plan".into()))?;
        let plan = &plan;
        let stats = self.exec.execute(plan)?;
        self.layers = self.exec.learnt_layers(plan).map(|l| (plan.clone(), l));
        for s in &mut self.slots {
            s.pending = None;
        }
        Ok(stats)
    }

    /// Whether the plan's loop counts are known ([`Embedder::prepare`] ran, or
    /// counts were carried over from an equal plan).
    pub fn prepared(&self) -> bool {
        self.plan.as_ref().is_some_and(|p| self.layers(p).is_some())
    }

    /// The loop counts the next [`Embedder::record`] of `plan` unrolls to.
    fn layers(&self, plan: &Plan) -> Option<&[u32]> {
        match &self.layers {
            Some((p, l)) if p == plan => Some(l),
            _ => None,
        }
    }

    /// Records the plan's frame and its composite into `cmd`. Returns the
    /// recording's counts (`submits` is 0: the host submits).
    ///
    /// # Safety
    ///
    /// - `cmd` is a primary command buffer in the recording state, outside any
    ///   render pass or dynamic rendering, allocated from a pool of the context's
    ///   queue family, and submitted (by the host) to a queue of that family.
    /// - On entry the host's colour image is in `COLOR_ATTACHMENT_OPTIMAL` and its
    ///   depth image in `DEPTH_STENCIL_ATTACHMENT_OPTIMAL`; they are left in these
    ///   layouts. Earlier attachment writes of the host are made available by the
    ///   barrier recorded here (`COLOR_ATTACHMENT_OUTPUT | LATE_FRAGMENT_TESTS` →
    ///   the composite's `COLOR_ATTACHMENT_OUTPUT | EARLY/LATE_FRAGMENT_TESTS`); the
    ///   composite's own writes are colour-attachment and depth-attachment writes
    ///   in those stages, which the host's next use must synchronize with (as after
    ///   any rendering of its own).
    /// - Peeltrim's internal images, its vertex buffer and its query pools are used
    ///   by this recording from the first command to the last (transfer, vertex,
    ///   fragment, attachment stages); the host must not touch them.
    /// - At most `frames_in_flight` (given to [`Embedder::new`]) command buffers
    ///   holding a recording of this embedder are pending at any time, all on one
    ///   queue, and their submission order is their recording order.
    /// - The views stay valid until the command buffer has completed.
    pub unsafe fn record(
        &mut self,
        cmd: vk::CommandBuffer,
        targets: &HostTargets,
    ) -> Result<ExecStats, VkError> {
        let _layer = self.shared.layer_use();
        let plan = self
            .plan
            .clone()
            .ok_or_else(|| VkError::Plan("record before set_plan".into()))?;
        let plan = &plan;
        let d = *self.exec.desc();
        // The host's depth test: nearer wins, the host's geometry on ties.
        let depth_compare = if d.reversed_z {
            vk::CompareOp::GREATER
        } else {
            vk::CompareOp::LESS
        };
        if targets.extent != [d.width, d.height] {
            return Err(VkError::Plan(format!(
                "host targets are {}x{}, the embedder's images {}x{}: resize the embedder to the host's targets",
                targets.extent[0], targets.extent[1], d.width, d.height
            )));
        }
        self.check_finished_slot(plan)?;
        let layers = self
            .layers(plan)
            .map(<[u32]>::to_vec)
            .ok_or_else(|| VkError::Plan("record before prepare: loop counts unknown".into()))?;
        let unrolled = self.exec.record_unrolled(cmd, plan, &layers)?;
        let slot = (self.frame % self.slots.len() as u64) as usize;
        self.frame += 1;
        self.copy_counts(cmd, slot, unrolled.groups.len() as u32);
        self.composite(cmd, targets, depth_compare)?;
        let stats = unrolled.stats.clone();
        self.slots[slot].pending = Some((plan.clone(), unrolled));
        Ok(stats)
    }

    /// Checks the frame that last used the slot the next frame takes: by the
    /// frames-in-flight contract it has completed.
    fn check_finished_slot(&mut self, plan: &Plan) -> Result<(), VkError> {
        let slot = (self.frame % self.slots.len() as u64) as usize;
        let Some((p, u)) = self.slots[slot].pending.take() else {
            return Ok(());
        };
        let n = u.groups.len();
        let bytes = self.slots[slot].counts.mapped()?;
        let word =
            |i: usize| u64::from_ne_bytes(bytes[i * 8..i * 8 + 8].try_into().expect("8 bytes"));
        let available = (0..n).all(|i| word(2 * i + 1) != 0);
        if p != *plan || !available {
            return Ok(());
        }
        let samples: Vec<u64> = (0..n).map(|i| word(2 * i)).collect();
        if Executor::unrolled_fits(&p, &u, &samples) {
            return Ok(());
        }
        let adjusted = adjust_layers(&u, &samples);
        if self.layers(plan) == Some(&u.layers[..]) {
            self.layers = Some((p, adjusted));
        }
        Ok(())
    }

    /// Copies the frame's occlusion counts, with availability, into `slot`.
    fn copy_counts(&mut self, cmd: vk::CommandBuffer, slot: usize, n: u32) {
        let need = (n.max(1) as u64) * 16;
        if self.slots[slot].counts.size < need {
            // Grown outside any pending use: by the frames-in-flight contract this
            // slot's last frame completed.
            match Buffer::new(
                &self.shared,
                "embed counts",
                need.next_power_of_two(),
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            ) {
                Ok(b) => self.slots[slot].counts = b,
                Err(_) => return,
            }
        }
        if n == 0 {
            return;
        }
        let device = &self.shared.device;
        // SAFETY: outside rendering; the first `n` queries were reset and written
        // by this recording; the buffer holds `n` pairs of u64.
        unsafe {
            device.cmd_copy_query_pool_results(
                cmd,
                self.exec.occlusion_pool(),
                0,
                n,
                self.slots[slot].counts.raw,
                0,
                16,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WITH_AVAILABILITY,
            )
        };
        submit::memory_barrier(
            device,
            cmd,
            (
                vk::PipelineStageFlags::TRANSFER,
                vk::AccessFlags::TRANSFER_WRITE,
            ),
            (vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ),
        );
    }

    /// Draws peeltrim's colour and depth into the host's attachments, where the
    /// CSG covers the pixel, with the host's depth test.
    fn composite(
        &mut self,
        cmd: vk::CommandBuffer,
        t: &HostTargets,
        depth_compare: vk::CompareOp,
    ) -> Result<(), VkError> {
        let formats = (t.color_format, t.depth_format);
        if self.composite.as_ref().map(|c| c.formats) != Some(formats) {
            self.composite = None;
            self.composite = Some(Composite::new(&self.shared, formats)?);
        }
        let out = self
            .exec
            .output()
            .expect("record_unrolled leaves an output");
        let epoch = self.exec.epoch();
        let c = self.composite.as_mut().expect("made above");
        if c.epoch != Some(epoch) {
            c.write_set(&self.shared, &out, self.sampler);
            c.epoch = Some(epoch);
        }
        let device = &self.shared.device;
        let images = [
            (out.color.0, vk::ImageAspectFlags::COLOR),
            (out.prim.0, vk::ImageAspectFlags::COLOR),
            (
                out.depth.0,
                vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
            ),
        ];
        let to_sampled = |from: Usage, to: Usage| {
            let (src, dst) = sync::transition(from, to, false);
            let barriers: Vec<_> = images
                .iter()
                .map(|&(img, aspect)| sync::image_barrier(src, dst, img, aspect))
                .collect();
            (src.stage, dst.stage, barriers)
        };
        let (s, d, b) = to_sampled(REST, Usage::Sampled);
        submit::image_barriers(device, cmd, s, d, &b);
        let att_stages = vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
            | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
            | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS;
        submit::memory_barrier(
            device,
            cmd,
            (
                att_stages,
                vk::AccessFlags::COLOR_ATTACHMENT_WRITE
                    | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
            ),
            (
                att_stages,
                vk::AccessFlags::COLOR_ATTACHMENT_READ
                    | vk::AccessFlags::COLOR_ATTACHMENT_WRITE
                    | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
                    | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
            ),
        );
        let extent = vk::Extent2D {
            width: t.extent[0],
            height: t.extent[1],
        };
        // Only where the CSG can be: its meshes' projected bounds.
        let rect = self.exec.output_rect();
        let scissor = crate::vk::conv::rect2d(rect);
        let color = [vk::RenderingAttachmentInfo::default()
            .image_view(t.color_view)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::LOAD)
            .store_op(vk::AttachmentStoreOp::STORE)];
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(t.depth_view)
            .image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::LOAD)
            .store_op(vk::AttachmentStoreOp::STORE);
        let ri = vk::RenderingInfo::default()
            .render_area(extent.into())
            .layer_count(1)
            .color_attachments(&color)
            .depth_attachment(&depth);
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: extent.width as f32,
            height: extent.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        // SAFETY: outside rendering (the caller's contract); the views are the
        // host's attachments in the layouts the contract names.
        unsafe { device.cmd_begin_rendering(cmd, &ri) };
        // SAFETY: inside the block above; the pipeline was made for its formats.
        unsafe { device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, c.pipeline) };
        // SAFETY: the set's images are in `SHADER_READ_ONLY_OPTIMAL` (barrier above).
        unsafe {
            device.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                c.layout,
                0,
                &[c.set],
                &[],
            )
        };
        // SAFETY: dynamic state of the bound pipeline.
        unsafe { device.cmd_set_viewport(cmd, 0, &[viewport]) };
        // SAFETY: as above; the rectangle lies within the attachments.
        unsafe { device.cmd_set_scissor(cmd, 0, &[scissor]) };
        // SAFETY: as above.
        unsafe { device.cmd_set_depth_compare_op(cmd, depth_compare) };
        // SAFETY: pipeline, set and state bound; the vertex shader needs no buffer.
        unsafe { device.cmd_draw(cmd, 3, 1, 0, 0) };
        // SAFETY: closes the block begun above.
        unsafe { device.cmd_end_rendering(cmd) };
        let (s, d, b) = to_sampled(Usage::Sampled, REST);
        submit::image_barriers(device, cmd, s, d, &b);
        Ok(())
    }
}

/// Loop counts corrected by a frame's samples: one past the last head that
/// passed samples (the first empty head ends the loop), or twice as many when
/// even the last head passed samples.
fn adjust_layers(u: &Unrolled, samples: &[u64]) -> Vec<u32> {
    let mut per_head: Vec<Vec<u64>> = u.layers.iter().map(|&n| vec![0; n as usize]).collect();
    for (g, s) in u.groups.iter().zip(samples) {
        if let Some((l, k)) = g {
            per_head[*l][*k as usize] += s;
        }
    }
    per_head
        .iter()
        .map(|heads| match heads.iter().position(|&s| s == 0) {
            Some(first_empty) => first_empty as u32 + 1,
            None => (heads.len() as u32 * 2).max(1),
        })
        .collect()
}

impl Composite {
    fn new(shared: &Shared, formats: (vk::Format, vk::Format)) -> Result<Composite, VkError> {
        let device = &shared.device;
        let binding = |b: u32, ty| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(b)
                .descriptor_type(ty)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::FRAGMENT)
        };
        let bindings = [
            binding(0, vk::DescriptorType::SAMPLED_IMAGE),
            binding(1, vk::DescriptorType::SAMPLED_IMAGE),
            binding(2, vk::DescriptorType::SAMPLED_IMAGE),
            binding(3, vk::DescriptorType::SAMPLER),
        ];
        let mut c = Composite {
            formats,
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            pipeline: vk::Pipeline::null(),
            epoch: None,
        };
        let dci = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid create info on a live device. (Each object made below is
        // destroyed by `Composite::destroy` even when a later step fails.)
        c.set_layout = unsafe { device.create_descriptor_set_layout(&dci, None) }
            .check("vkCreateDescriptorSetLayout")
            .inspect_err(|_| c.destroy(device))?;
        let set_layouts = [c.set_layout];
        let lci = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        // SAFETY: valid create info; the set layout is live.
        c.layout = unsafe { device.create_pipeline_layout(&lci, None) }
            .check("vkCreatePipelineLayout")
            .inspect_err(|_| c.destroy(device))?;
        let sizes = [
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::SAMPLED_IMAGE,
                descriptor_count: 3,
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::SAMPLER,
                descriptor_count: 1,
            },
        ];
        let pci = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: valid create info.
        c.pool = unsafe { device.create_descriptor_pool(&pci, None) }
            .check("vkCreateDescriptorPool")
            .inspect_err(|_| c.destroy(device))?;
        let ai = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(c.pool)
            .set_layouts(&set_layouts);
        // SAFETY: the pool has room for this one set.
        c.set = unsafe { device.allocate_descriptor_sets(&ai) }
            .check("vkAllocateDescriptorSets")
            .inspect_err(|_| c.destroy(device))?[0];
        c.pipeline = c.make_pipeline(device).inspect_err(|_| c.destroy(device))?;
        Ok(c)
    }

    fn make_pipeline(&self, device: &ash::Device) -> Result<vk::Pipeline, VkError> {
        let module = |bytes: &[u8]| -> Result<vk::ShaderModule, VkError> {
            let words = ash::util::read_spv(&mut std::io::Cursor::new(bytes))
                .map_err(|e| VkError::Plan(format!("embedded SPIR-V unreadable: {e}")))?;
            let ci = vk::ShaderModuleCreateInfo::default().code(&words);
            // SAFETY: SPIR-V produced and validated by naga in build.rs.
            unsafe { device.create_shader_module(&ci, None) }.check("vkCreateShaderModule")
        };
        let (vert, frag) = (module(VERT)?, module(FRAG)?);
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(vert)
                .name(c"main"),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(frag)
                .name(c"main"),
        ];
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default();
        let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth_stencil = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true);
        let blend_attachments = [vk::PipelineColorBlendAttachmentState::default()
            .color_write_mask(vk::ColorComponentFlags::RGBA)];
        let blend =
            vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let dynamic_states = [
            vk::DynamicState::VIEWPORT,
            vk::DynamicState::SCISSOR,
            vk::DynamicState::DEPTH_COMPARE_OP,
        ];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let color_formats = [self.formats.0];
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(&color_formats)
            .depth_attachment_format(self.formats.1);
        let ci = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth_stencil)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(self.layout)
            .push_next(&mut rendering);
        // SAFETY: the state structs live across the call; modules and layout are live.
        let made =
            unsafe { device.create_graphics_pipelines(vk::PipelineCache::null(), &[ci], None) };
        // SAFETY: modules are only needed while creating the pipeline.
        unsafe { device.destroy_shader_module(vert, None) };
        // SAFETY: as above.
        unsafe { device.destroy_shader_module(frag, None) };
        made.map(|p| p[0]).map_err(|(_, e)| VkError::Call {
            call: "vkCreateGraphicsPipelines",
            result: e,
        })
    }

    /// Points the set at the executor's current output images.
    fn write_set(&self, shared: &Shared, out: &super::exec::Output, sampler: vk::Sampler) {
        let sampled = sync::access(Usage::Sampled).layout;
        let info = |view| {
            [vk::DescriptorImageInfo {
                sampler: vk::Sampler::null(),
                image_view: view,
                image_layout: sampled,
            }]
        };
        let (ci, pi, di) = (info(out.color.1), info(out.prim.1), info(out.depth.1));
        let si = [vk::DescriptorImageInfo {
            sampler,
            image_view: vk::ImageView::null(),
            image_layout: vk::ImageLayout::UNDEFINED,
        }];
        let infos: [(vk::DescriptorType, &[vk::DescriptorImageInfo]); 4] = [
            (vk::DescriptorType::SAMPLED_IMAGE, &ci),
            (vk::DescriptorType::SAMPLED_IMAGE, &pi),
            (vk::DescriptorType::SAMPLED_IMAGE, &di),
            (vk::DescriptorType::SAMPLER, &si),
        ];
        let writes: Vec<vk::WriteDescriptorSet<'_>> = infos
            .iter()
            .enumerate()
            .map(|(b, (ty, i))| {
                vk::WriteDescriptorSet::default()
                    .dst_set(self.set)
                    .dst_binding(b as u32)
                    .descriptor_type(*ty)
                    .image_info(i)
            })
            .collect();
        // SAFETY: set, views and sampler are live; the set is not in use by a
        // pending command buffer (it changes only with the executor's images,
        // which change only when no frame is pending).
        unsafe { shared.device.update_descriptor_sets(&writes, &[]) };
    }

    fn destroy(&self, device: &ash::Device) {
        // SAFETY (each call): no pending command buffer uses these objects (the
        // embedder is dropped or remade only when the host has no frame of it
        // pending); null handles are ignored.
        unsafe { device.destroy_pipeline(self.pipeline, None) };
        // SAFETY: as above.
        unsafe { device.destroy_descriptor_pool(self.pool, None) };
        // SAFETY: as above.
        unsafe { device.destroy_pipeline_layout(self.layout, None) };
        // SAFETY: as above.
        unsafe { device.destroy_descriptor_set_layout(self.set_layout, None) };
    }
}

impl Drop for Embedder {
    fn drop(&mut self) {
        let _layer = self.shared.layer_use();
        if let Some(c) = self.composite.take() {
            c.destroy(&self.shared.device);
        }
        // SAFETY: as in `Composite::destroy`.
        unsafe { self.shared.device.destroy_sampler(self.sampler, None) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unrolled(layers: Vec<u32>, groups: Vec<Option<(usize, u32)>>) -> Unrolled {
        Unrolled {
            layers,
            groups,
            stats: ExecStats::default(),
        }
    }

    #[test]
    fn counts_shrink_to_one_past_the_last_head_with_samples() {
        // Loop 0 unrolled to 4 heads; its third head counted nothing.
        let u = unrolled(vec![4], (0..4).map(|k| Some((0, k))).collect());
        assert_eq!(adjust_layers(&u, &[9, 3, 0, 0]), vec![3]);
    }

    #[test]
    fn counts_double_when_even_the_last_head_had_samples() {
        // Two loops; the second needs more layers than it was given.
        let groups = vec![Some((0, 0)), Some((0, 1)), None, Some((1, 0)), Some((1, 1))];
        let u = unrolled(vec![2, 2], groups);
        assert_eq!(adjust_layers(&u, &[5, 0, 77, 4, 2]), vec![2, 4]);
    }
}
