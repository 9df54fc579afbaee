//! Recording plan steps into a command buffer (seed papers' passes become draws
//! with their depth, stencil and cull state baked into pipeline variants,
//! `state.rs`).
//!
//! Synchronization comes from the steps' declared usages (`plan::usage`) through
//! the pure table in `vk/sync.rs`: the recorder tracks each image's last usage and
//! emits one pipeline barrier, with exactly the stages, accesses and layout
//! changes needed, only where a step's usage conflicts with the last one.
//! Consecutive draws into the same attachments share one dynamic-rendering block
//! (rasterization order orders them). Clears are deferred to the image's next
//! use: a clear nobody reads is dropped; one followed by rendering into the image
//! becomes that block's load op ([`ClearMode::LoadOp`]) or a clear command just
//! before it ([`ClearMode::Command`]); one read otherwise is a clear command. Draws whose scissor is empty on
//! screen are not recorded. Meshes of one draw that lie contiguously in the
//! vertex buffer and need no per-mesh push constants are drawn with one call.
//!
//! Re-recording a plan costs ≤ 1 µs of CPU per draw (issue 9 §3): a pipeline
//! bind, the scissor and the push constants are recorded only where they
//! change (`state.rs`, `record/push.rs`), and nothing is allocated per draw.

use std::collections::{BTreeMap, VecDeque};

use ash::vk;

use super::gpu_scene::GpuScene;
use super::state;
use super::stats::ExecStats;
use super::targets::{self, Targets};
use super::ExecDesc;
use ahead::Ahead;
use clears::PendingClear;
use lower::RecordedDraw;

mod ahead;
mod clears;
mod host;
mod lower;
mod push;
mod shade;
use crate::plan::direct_shade::DirectShades;
use crate::plan::reach::ClearNeed;
use crate::plan::tie_free::{ShadeCopy, TieFree};
use crate::plan::usage::{self, Resource, Usage, Uses};
use crate::plan::{Draw, Fragment, Geometry, Scissor, Step};
use crate::vk::conv;
use crate::vk::error::VkError;
use crate::vk::pipeline::{
    FragmentKind, PipelineDesc, Pipelines, PushConstants, RasterState, Reads, QUAD_INSTANCE,
};
use crate::vk::scissor::{Rect, RectUnions};
use crate::vk::submit;
use crate::vk::sync::{self, REST};
pub(crate) use host::{copy_counts, final_shade, host_barriers, peel_depth, HostShade};
use push::PushTracker;

/// Attachments of a rendering block: plain data (no allocation per draw).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct BlockKey {
    /// The first `n_colors` are the colour attachments, in order.
    colors: [Resource; MAX_COLORS],
    n_colors: u8,
    ds: Option<u8>,
}

/// Most colour targets of a fragment program (`Peel { shade: true }`: colour,
/// ids, depth texture; and the normal buffer when it is on).
const MAX_COLORS: usize = 4;

impl BlockKey {
    fn new(colors: &[Resource], ds: Option<u8>) -> BlockKey {
        assert!(
            colors.len() <= MAX_COLORS,
            "a fragment program writes at most {MAX_COLORS} colour targets"
        );
        let mut c = [Resource::Color; MAX_COLORS];
        c[..colors.len()].copy_from_slice(colors);
        BlockKey {
            colors: c,
            n_colors: colors.len() as u8,
            ds,
        }
    }

    /// The block of a draw with usages `uses` (which list its colour targets
    /// in attachment order) into depth-stencil `ds`.
    fn of_draw(uses: &[(Resource, Usage)], ds: u8) -> BlockKey {
        let mut key = BlockKey::new(&[], Some(ds));
        for &(r, _) in uses.iter().filter(|u| u.1 == Usage::ColorTarget) {
            assert!(
                (key.n_colors as usize) < MAX_COLORS,
                "a fragment program writes at most {MAX_COLORS} colour targets"
            );
            key.colors[key.n_colors as usize] = r;
            key.n_colors += 1;
        }
        key
    }

    fn colors(&self) -> &[Resource] {
        &self.colors[..self.n_colors as usize]
    }
}

/// A pipeline of a recording: what selects it, and whether its depth,
/// stencil and cull state is baked in (`fixed`) or set dynamically.
#[derive(Clone, Copy, Debug)]
struct Pipe {
    block: BlockKey,
    kind: FragmentKind,
    state: RasterState,
    pipeline: vk::Pipeline,
    fixed: bool,
}

/// Each image's last usage in the recording: a flat table by [`ImageStates::slot`]
/// (the recorder looks up every used image at every draw).
#[derive(Default)]
struct ImageStates(Vec<Option<Usage>>);

impl ImageStates {
    fn slot(r: Resource) -> usize {
        match r {
            Resource::Color => 0,
            Resource::Prim => 1,
            Resource::Normal => 2,
            Resource::Edges => 3,
            Resource::Accum => 4,
            Resource::AlphaTable => 5,
            Resource::DepthStencil(d) => 6 + 2 * d as usize,
            Resource::Texture(t) => 7 + 2 * t as usize,
        }
    }

    fn get(&self, r: Resource) -> Usage {
        self.0
            .get(Self::slot(r))
            .copied()
            .flatten()
            .unwrap_or_else(|| panic!("{r:?} is not an image of the executor's targets"))
    }

    fn set(&mut self, r: Resource, u: Usage) {
        let i = Self::slot(r);
        if self.0.len() <= i {
            self.0.resize(i + 1, None);
        }
        self.0[i] = Some(u);
    }
}

/// Tags the occlusion queries of one loop-head execution: `(loop, iteration)`.
pub(super) type Group = Option<(usize, u32)>;

/// What a recorder records against: the executor's device objects.
pub(super) struct Bindings<'a> {
    pub device: &'a ash::Device,
    pub desc: ExecDesc,
    pub pipelines: &'a mut Pipelines,
    pub targets: &'a Targets,
    pub scene: &'a GpuScene,
    pub occlusion: vk::QueryPool,
    /// `None` when the queue has no timestamps.
    pub timestamps: Option<vk::QueryPool>,
    pub clears: ClearMode,
    pub join: BlockJoin,
    /// A timestamp at every `Step::Pass` (per-pass GPU times); otherwise only
    /// around the command buffer.
    pub pass_timestamps: bool,
    /// Push-constant flags (reversed Z, subpixel precision).
    pub flags: u32,
    /// Emulated vertex snapping step of mesh draws (zero: off).
    pub snap: [f32; 2],
    /// Write the normal buffer wherever colour is written (seed 001 §5.2).
    pub normals: bool,
    /// The camera's uniform buffer (set 1 of every pipeline).
    pub camera_set: vk::DescriptorSet,
    /// Which tolerant parity and peel draws run as plain depth tests under the
    /// recorded camera (`plan::tie_free`).
    pub ties: &'a TieFree,
    /// Screen rectangle of each mesh's bounds (a `BoundsOf` scissor is their
    /// union, exactly as `bounds_rect` of all the boxes), as a table of unions;
    /// the executor may pass larger ones (see `Executor::execute`).
    pub mesh_rects: RectUnions,
}

/// How a plan's clears of attachments are recorded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClearMode {
    /// As the load op of the next rendering block into the image (tile-based and
    /// other hardware GPUs clear on load for free).
    LoadOp,
    /// As clear commands of the region later steps read (`clears.rs`).
    /// Lavapipe clears on load far more slowly (README, "Executor"), so CPU
    /// devices use this.
    Command,
}

/// Which blocks a draw whose program writes no colour may record in
/// (`record/ahead.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BlockJoin {
    /// Any open block on its depth-stencil image, the block's colour writes
    /// masked, and a block it opens takes the attachments of the colour draws
    /// that follow (the look-ahead): fewer blocks and barriers (the default).
    Masked,
    /// Only blocks without colour attachments. On lavapipe a masked draw
    /// over many pixels can cost more than the block end it saves (llvmpipe
    /// of Mesa 22.3 seems to blend into every bound colour buffer, writes
    /// masked or not; README, "One block for the depth-only draws and the
    /// shade").
    DepthOnly,
}

/// Records steps into command buffers; its image states persist from one
/// command buffer to the next of the same frame.
pub(super) struct Recorder<'a> {
    b: Bindings<'a>,
    cmd: vk::CommandBuffer,
    block: Option<BlockKey>,
    /// What the current command buffer has bound and set, so that only changes
    /// are recorded (command-buffer state outlives pipeline binds and blocks).
    bound: Option<vk::Pipeline>,
    bound_set: Option<vk::DescriptorSet>,
    scissor: Option<Rect>,
    /// The dynamic depth, stencil and cull state; `None` also after a bind of a
    /// pipeline with that state baked in (which leaves it undefined).
    dyn_state: Option<RasterState>,
    push: PushTracker,
    /// Pipelines of this recording (a plan uses a few dozen; looked up without
    /// building a `PipelineDesc` per draw).
    pipes: Vec<Pipe>,
    /// Indices in `pipes` of the two last found by a search, newest first.
    recent: [usize; 2],
    state: ImageStates,
    pending_clear: BTreeMap<Resource, PendingClear>,
    /// Regions of the clears recorded next, in order (`plan::reach`).
    clear_regions: VecDeque<ClearNeed>,
    /// What the depth copies recorded next cover, in order (`shade.rs`).
    shade_copies: VecDeque<ShadeCopy>,
    /// The direct draws that shade, and the final shade draws they replace
    /// (`plan::direct_shade`, `shade.rs`).
    direct: DirectShades,
    /// Regions of the copies recorded next, in order (`plan::reach`).
    copy_regions: VecDeque<Rect>,
    /// Whether the texture writes of the draws recorded next are read, in
    /// order (`plan::reach::FrameReach::texture_writes`).
    texture_writes: VecDeque<bool>,
    /// The frame's outputs (`use_reach`).
    outputs: Vec<Resource>,
    /// What each step recorded next does to the open block (`ahead.rs`), and
    /// the index in it of the step after the one being recorded.
    ahead: Vec<Ahead>,
    next: usize,
    /// The open block's render area.
    render_area: Rect,
    /// Group of each occlusion query of the current command buffer.
    pub queries: Vec<Group>,
    /// Group of the counted draws recorded next.
    pub group: Group,
    /// Pass name at each timestamp of the current command buffer.
    pub marks: Vec<String>,
    /// Index in `stats.per_pass` of the current pass; `None` before the first.
    pass: Option<usize>,
    pub stats: ExecStats,
}

impl<'a> Recorder<'a> {
    pub fn new(b: Bindings<'a>) -> Recorder<'a> {
        // Every image rests in `REST` between frames (see `finish_frame`).
        let mut state = ImageStates::default();
        for r in b.targets.all() {
            state.set(r, REST);
        }
        Recorder {
            b,
            cmd: vk::CommandBuffer::null(),
            block: None,
            bound: None,
            bound_set: None,
            scissor: None,
            dyn_state: None,
            push: PushTracker::default(),
            pipes: Vec::new(),
            recent: [usize::MAX; 2],
            state,
            pending_clear: BTreeMap::new(),
            clear_regions: VecDeque::new(),
            shade_copies: VecDeque::new(),
            direct: DirectShades::none(),
            copy_regions: VecDeque::new(),
            texture_writes: VecDeque::new(),
            outputs: Vec::new(),
            ahead: Vec::new(),
            next: 0,
            render_area: Rect::EMPTY,
            queries: Vec::new(),
            group: None,
            marks: Vec::new(),
            pass: None,
            stats: ExecStats::default(),
        }
    }

    pub fn begin(&mut self, cmd: vk::CommandBuffer, occlusion_cap: u32, timestamp_cap: u32) {
        self.queries.clear();
        self.marks.clear();
        // SAFETY: recording; outside rendering; ranges within the pools.
        unsafe {
            self.b
                .device
                .cmd_reset_query_pool(cmd, self.b.occlusion, 0, occlusion_cap)
        };
        if let Some(ts) = self.b.timestamps {
            // SAFETY: as above.
            unsafe {
                self.b
                    .device
                    .cmd_reset_query_pool(cmd, ts, 0, timestamp_cap)
            };
        }
        self.begin_state(cmd);
        let pass = match self.b.pass_timestamps {
            true => self.pass_name(),
            false => String::new(),
        };
        self.timestamp(pass);
    }

    /// Starts recording into the fresh command buffer `cmd`: nothing is bound
    /// or set in it yet, then the state every draw shares.
    fn begin_state(&mut self, cmd: vk::CommandBuffer) {
        self.cmd = cmd;
        self.bound = None;
        self.bound_set = None;
        self.scissor = None;
        self.dyn_state = None;
        self.push.reset();
        state::record_fixed(self.b.device, cmd, self.b.desc.width, self.b.desc.height);
        // SAFETY: the vertex buffer is live while the recording may be replayed.
        unsafe {
            self.b
                .device
                .cmd_bind_vertex_buffers(cmd, 0, &[self.b.scene.vertices.raw], &[0])
        };
        // SAFETY: outside rendering; the set matches the layout's set 1 and its
        // buffer lives as long as the executor.
        unsafe {
            self.b.device.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                self.b.pipelines.layout,
                1,
                &[self.b.camera_set],
                &[],
            )
        };
        self.stats.counts.state_commands += 4;
    }

    fn pass_name(&self) -> String {
        self.pass
            .map(|i| self.stats.per_pass[i].name.clone())
            .unwrap_or_default()
    }

    /// Ends the current command buffer's work (it stays to be ended by the caller).
    pub fn end(&mut self) {
        self.end_block();
        self.timestamp(String::new());
    }

    /// Leaves the images the way the next frame expects them: read-back targets
    /// with their pending clears done, every image in `REST`.
    pub fn finish_frame(&mut self, output_ds: u8) {
        self.end_block();
        let outputs = self.outputs(output_ds);
        self.flush_clears(&outputs);
        // Clears of other images are read by nobody.
        self.pending_clear.clear();
        self.rest_all();
    }

    /// Ends one plan of a sequence frame (`exec::sequence`) the way
    /// [`Self::finish_frame`] ends a frame, but records every pending clear:
    /// the sequence's reach (`plan::reach::sequence_reach`) gives a clear a
    /// region only where a later plan reads it.
    pub fn finish_plan(&mut self) {
        self.end_block();
        let pending: Vec<Resource> = self.pending_clear.keys().copied().collect();
        self.flush_clears(&pending);
        self.rest_all();
    }

    /// Seed 001 §5.1's edge map of the last frame's first layer, in one
    /// full-screen draw (`shaders/edges.frag`) into the edge target, sampling the
    /// normal buffer and depth-stencil `output_ds`; every image rests in `REST`
    /// after. `rule`: relative depth threshold and cosine of the crease angle.
    pub fn edge_pass(
        &mut self,
        cmd: vk::CommandBuffer,
        output_ds: u8,
        rule: [f32; 2],
    ) -> Result<(), VkError> {
        self.begin_state(cmd);
        let depth = Resource::DepthStencil(output_ds);
        let key = BlockKey::new(&[Resource::Edges], None);
        let uses = [
            (Resource::Edges, Usage::ColorTarget),
            (Resource::Normal, Usage::Sampled),
            (depth, Usage::Sampled),
        ];
        self.open(&key, &uses);
        let tests_off = state::raster_state(None, self.b.desc.reversed_z);
        let pipe = self.pipeline_for(&key, FragmentKind::Edges, &tests_off)?;
        self.bind_pipe(pipe, Some(self.b.targets.sampling_set(Resource::Normal)));
        let depth_set = self.b.targets.sampling_set(depth);
        // SAFETY: set 2 of the pipeline layout has the set's layout; inside a block.
        unsafe {
            self.b.device.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                self.b.pipelines.layout,
                2,
                &[depth_set],
                &[],
            )
        };
        let full = Rect::full(self.b.desc.width, self.b.desc.height);
        self.set_scissor(full);
        let cam = &self.b.scene.camera;
        let ortho = matches!(
            cam.projection,
            crate::scene::Projection::Orthographic { .. }
        );
        let pc = PushConstants {
            mvp: Self::fullscreen_matrix(0.0),
            view: [cam.near as f32, cam.far as f32, ortho as u32 as f32, 0.0],
            color: [rule[0], rule[1], 0.0, 0.0],
            flags: self.flags(),
            snap: self.b.snap,
            ..Default::default()
        };
        self.quad_pass(FragmentKind::Edges, &pc, full.area());
        self.end_block();
        self.rest_all();
        Ok(())
    }

    /// Seed 000 §6's front-to-back composite of one peeled layer, in one
    /// full-screen draw (`shaders/accumulate.frag`) blended into the
    /// accumulation target: where the layer's primitive id `p` is not 0,
    /// `C += (1 − A)·a·c` and `A += (1 − A)·a` with `a` the opacity table's
    /// entry for `p`. `table`: the first layer of a composite, which starts the
    /// target from zero and uploads the opacity table (a staging buffer of
    /// `ALPHA_TABLE_SIDE`² floats). Every image rests in `REST` after.
    pub fn accumulate_pass(
        &mut self,
        cmd: vk::CommandBuffer,
        table: Option<&crate::vk::memory::Buffer>,
    ) -> Result<(), VkError> {
        self.begin_state(cmd);
        if let Some(buf) = table {
            self.transitions(&[(Resource::AlphaTable, Usage::CopyDst)], false);
            let side = targets::ALPHA_TABLE_SIDE;
            let region = super::whole_image_region(vk::ImageAspectFlags::COLOR, 0, side, side);
            let img = self.b.targets.image(Resource::AlphaTable);
            // SAFETY: outside rendering; the buffer holds side² f32 and lives
            // until the caller's wait; the image is in the copy layout.
            unsafe {
                self.b.device.cmd_copy_buffer_to_image(
                    cmd,
                    buf.raw,
                    img.raw,
                    sync::access(Usage::CopyDst).layout,
                    &[region],
                )
            };
            // Read whole by the full-screen composite.
            self.pending_clear.insert(
                Resource::Accum,
                PendingClear {
                    value: vk::ClearValue {
                        color: vk::ClearColorValue { float32: [0.0; 4] },
                    },
                    rect: Rect::full(self.b.desc.width, self.b.desc.height),
                },
            );
        }
        let key = BlockKey::new(&[Resource::Accum], None);
        let uses = [
            (Resource::Accum, Usage::ColorTarget),
            (Resource::Color, Usage::Sampled),
            (Resource::Prim, Usage::Sampled),
            (Resource::AlphaTable, Usage::Sampled),
        ];
        self.open(&key, &uses);
        let t = self.b.targets;
        let sets = [
            t.sampling_set(Resource::Prim),
            t.sampling_set(Resource::AlphaTable),
        ];
        // SAFETY: sets 2 and 3 of the pipeline layout have the sets' layout;
        // inside a block.
        unsafe {
            self.b.device.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::GRAPHICS,
                self.b.pipelines.layout,
                2,
                &sets,
                &[],
            )
        };
        let color_set = t.sampling_set(Resource::Color);
        let full = Rect::full(self.b.desc.width, self.b.desc.height);
        self.fullscreen_internal(&key, FragmentKind::Accumulate, color_set, full)?;
        self.end_block();
        self.rest_all();
        Ok(())
    }

    /// Every image to `REST`, where frames leave them.
    fn rest_all(&mut self) {
        let rest: Vec<_> = self
            .b
            .targets
            .all()
            .into_iter()
            .map(|r| (r, REST))
            .collect();
        self.transitions(&rest, false);
    }

    fn timestamp(&mut self, pass: String) {
        let Some(ts) = self.b.timestamps else { return };
        let idx = self.marks.len() as u32;
        // SAFETY: recording, outside rendering; the query was reset in this buffer.
        unsafe {
            self.b.device.cmd_write_timestamp(
                self.cmd,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                ts,
                idx,
            )
        };
        self.marks.push(pass);
        self.stats.counts.timestamps += 1;
    }

    fn end_block(&mut self) {
        if self.block.take().is_some() {
            // SAFETY: a rendering block is open in this command buffer.
            unsafe { self.b.device.cmd_end_rendering(self.cmd) };
        }
    }

    /// Barriers that bring each `(resource, usage)` from its last usage; ends the
    /// open block when one is needed. `same_block`: the step records into the open
    /// block. `load_clear`: resources whose pending clear becomes a load op (their
    /// contents are discarded). Returns whether a barrier was recorded.
    fn transitions(&mut self, uses: &[(Resource, Usage)], same_block: bool) -> bool {
        self.transitions_with(uses, same_block, &[])
    }

    fn transitions_with(
        &mut self,
        uses: &[(Resource, Usage)],
        same_block: bool,
        load_clear: &[Resource],
    ) -> bool {
        let (stages, barriers) = self.image_transitions(uses, same_block, load_clear);
        if barriers.is_empty() {
            return false;
        }
        self.end_block();
        submit::image_barriers(self.b.device, self.cmd, stages.0, stages.1, &barriers);
        self.stats.counts.barriers += 1;
        true
    }

    /// The image barriers (and their source and destination stages) that bring
    /// each `(resource, usage)` from its last usage, now noted as its usage;
    /// the caller records them.
    fn image_transitions(
        &mut self,
        uses: &[(Resource, Usage)],
        same_block: bool,
        load_clear: &[Resource],
    ) -> (
        (vk::PipelineStageFlags, vk::PipelineStageFlags),
        Vec<vk::ImageMemoryBarrier<'static>>,
    ) {
        let mut barriers = Vec::new();
        let (mut src_stage, mut dst_stage) = (
            vk::PipelineStageFlags::empty(),
            vk::PipelineStageFlags::empty(),
        );
        for &(r, u) in uses {
            let prev = self.state.get(r);
            if !sync::needs_barrier(prev, u, same_block) {
                continue;
            }
            let discard = u.discards() || load_clear.contains(&r);
            let (src, dst) = sync::transition(prev, u, discard);
            src_stage |= src.stage;
            dst_stage |= dst.stage;
            let img = self.b.targets.image(r);
            barriers.push(sync::image_barrier(src, dst, img.raw, img.desc.aspect()));
        }
        for &(r, u) in uses {
            self.state.set(r, u);
        }
        ((src_stage, dst_stage), barriers)
    }

    pub fn step(&mut self, step: &Step) -> Result<(), VkError> {
        self.next += 1;
        match step {
            Step::Pass(name) => {
                self.stats.pass_entry(name);
                self.pass = self.stats.per_pass.iter().position(|p| &p.name == name);
                if self.b.pass_timestamps {
                    // Lavapipe ends its binned scene at a timestamp (and bins the
                    // query into every tile): only when per-pass times are asked for.
                    self.end_block();
                    self.timestamp(name.clone());
                }
            }
            Step::Clear(clear) => self.clear(clear),
            Step::CopyTexture { src, dst } => {
                let rect = self.copy_region();
                if src == dst || rect.is_empty() {
                    // Nobody reads the copy.
                    self.stats.counts.skipped_steps += u64::from(src != dst);
                    return Ok(());
                }
                let uses = step.usage();
                self.settle_clears(&uses);
                self.transitions(&uses, false);
                self.end_block();
                let (s, d) = (
                    self.b.targets.image(Resource::Texture(*src)),
                    self.b.targets.image(Resource::Texture(*dst)),
                );
                let layers = vk::ImageSubresourceLayers {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    mip_level: 0,
                    base_array_layer: 0,
                    layer_count: 1,
                };
                let offset = vk::Offset3D {
                    x: rect.x0 as i32,
                    y: rect.y0 as i32,
                    z: 0,
                };
                let region = vk::ImageCopy {
                    src_subresource: layers,
                    src_offset: offset,
                    dst_subresource: layers,
                    dst_offset: offset,
                    extent: vk::Extent3D {
                        width: rect.width(),
                        height: rect.height(),
                        depth: 1,
                    },
                };
                self.stats.counts.copied_pixels += rect.area();
                // SAFETY: outside rendering; both images allow transfer, same format,
                // in the copy layouts after the barrier above; the region lies in both.
                unsafe {
                    self.b.device.cmd_copy_image(
                        self.cmd,
                        s.raw,
                        sync::access(Usage::CopySrc).layout,
                        d.raw,
                        sync::access(Usage::CopyDst).layout,
                        &[region],
                    )
                };
            }
            Step::CopyDepthToTexture { ds, dst } => self.copy_depth(step, *ds, *dst)?,
            Step::Draw(draw) => self.draw(draw)?,
            Step::Loop(_) => {
                panic!("loops are unrolled by the executor (plan::validate forbids nesting)")
            }
        }
        Ok(())
    }

    /// Makes `key` the open block with every usage in `uses` satisfied.
    fn open(&mut self, key: &BlockKey, uses: &[(Resource, Usage)]) {
        self.settle_clears(uses);
        let mut load_clear = Uses::<Resource>::default();
        for &(r, _) in uses {
            if self.pending_clear.contains_key(&r) {
                load_clear.push(r);
            }
        }
        let same = self.block.as_ref() == Some(key) && load_clear.is_empty();
        let barrier = self.transitions_with(uses, same, &load_clear);
        if same && !barrier {
            return;
        }
        self.end_block();
        self.begin_block(key);
    }

    fn begin_block(&mut self, key: &BlockKey) {
        let color_layout = sync::access(Usage::ColorTarget).layout;
        let ds_layout = sync::access(Usage::DepthStencilTarget).layout;
        let attached = key.colors().iter().copied();
        let area = self.render_area(attached.chain(key.ds.map(Resource::DepthStencil)));
        let mut in_block = Vec::new();
        let mut attachment = |rec: &mut Self, r: Resource, index, layout| {
            let (load, clear) = rec.load_op(r, index, area, &mut in_block);
            vk::RenderingAttachmentInfo::default()
                .image_view(rec.b.targets.image(r).view)
                .image_layout(layout)
                .load_op(load)
                .clear_value(clear)
                .store_op(vk::AttachmentStoreOp::STORE)
        };
        let mut colors = [vk::RenderingAttachmentInfo::default(); MAX_COLORS];
        for (i, (a, r)) in colors.iter_mut().zip(key.colors()).enumerate() {
            *a = attachment(self, *r, Some(i as u32), color_layout);
        }
        let colors = &colors[..key.n_colors as usize];
        let ds_att = key
            .ds
            .map(|d| attachment(self, Resource::DepthStencil(d), None, ds_layout));
        let mut ri = vk::RenderingInfo::default()
            .render_area(conv::rect2d(area))
            .layer_count(1)
            .color_attachments(colors);
        if let Some(a) = ds_att.as_ref() {
            ri = ri.depth_attachment(a);
            if conv::has_stencil(self.b.targets.ds_format) {
                ri = ri.stencil_attachment(a);
            }
        }
        // SAFETY: recording outside rendering; all views are live and, after the
        // recorder's barriers, in the attachment layouts given.
        unsafe { self.b.device.cmd_begin_rendering(self.cmd, &ri) };
        self.stats.counts.render_passes += 1;
        self.block = Some(*key);
        self.render_area = area;
        self.clear_in_block(&in_block);
    }

    /// The pipeline of fragment program `kind` in block `key` with `state`
    /// baked in, or with dynamic state past the executor's budget of variants
    /// (`vk::pipeline::MAX_FIXED_PIPELINES`).
    fn pipeline_for(
        &mut self,
        key: &BlockKey,
        kind: FragmentKind,
        state: &RasterState,
    ) -> Result<Pipe, VkError> {
        let hit = |p: &Pipe| p.kind == kind && p.state == *state && p.block == *key;
        // The last two used first: consecutive draws mostly repeat or
        // alternate (a trim's mesh draw and sweep).
        for &i in &self.recent {
            if self.pipes.get(i).is_some_and(hit) {
                return Ok(self.pipes[i]);
            }
        }
        if let Some(i) = self.pipes.iter().position(hit) {
            self.recent = [i, self.recent[0]];
            return Ok(self.pipes[i]);
        }
        let desc = PipelineDesc {
            fragment: kind,
            color_formats: key.colors().iter().map(|r| targets::format(*r)).collect(),
            depth_stencil_format: key.ds.map(|_| self.b.targets.ds_format),
            // A program that writes no colour runs as is, the normal buffer
            // masked with the other attachments.
            normals: kind.writes_color() && key.colors().contains(&Resource::Normal),
        };
        let (pipeline, fixed) = match self.b.pipelines.get_fixed(&desc, state)? {
            Some(p) => (p, true),
            None => (self.b.pipelines.get(&desc)?, false),
        };
        let pipe = Pipe {
            block: *key,
            kind,
            state: *state,
            pipeline,
            fixed,
        };
        self.pipes.push(pipe);
        self.recent = [self.pipes.len() - 1, self.recent[0]];
        Ok(pipe)
    }

    /// Binds `pipe` and `set` where they differ from what is bound, and sets
    /// the pipe's state dynamically when it is not baked in.
    fn bind_pipe(&mut self, pipe: Pipe, set: Option<vk::DescriptorSet>) {
        if pipe.fixed {
            if self.bound != Some(pipe.pipeline) {
                // Its static state leaves the dynamic state undefined.
                self.dyn_state = None;
            }
            self.bind(pipe.pipeline, set);
        } else {
            self.bind(pipe.pipeline, set);
            self.set_dynamic(&pipe.state);
        }
    }

    /// Binds `pipeline` and `set` where they differ from what is bound.
    fn bind(&mut self, pipeline: vk::Pipeline, set: Option<vk::DescriptorSet>) {
        let device = self.b.device;
        if self.bound != Some(pipeline) {
            // SAFETY: recording inside a block whose formats match the pipeline.
            unsafe {
                device.cmd_bind_pipeline(self.cmd, vk::PipelineBindPoint::GRAPHICS, pipeline)
            };
            self.bound = Some(pipeline);
            self.stats.counts.state_commands += 1;
        }
        if let Some(set) = set.filter(|&s| self.bound_set != Some(s)) {
            // SAFETY: the set matches the pipeline layout's set 0.
            unsafe {
                device.cmd_bind_descriptor_sets(
                    self.cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.b.pipelines.layout,
                    0,
                    &[set],
                    &[],
                )
            };
            self.bound_set = Some(set);
            self.stats.counts.state_commands += 1;
        }
    }

    /// Sets the scissor unless it is what is set.
    fn set_scissor(&mut self, scissor: Rect) {
        if self.scissor != Some(scissor) {
            // SAFETY: recording; every pipeline declares the scissor dynamic.
            unsafe {
                self.b
                    .device
                    .cmd_set_scissor(self.cmd, 0, &[conv::rect2d(scissor)])
            };
            self.scissor = Some(scissor);
            self.stats.counts.state_commands += 1;
        }
    }

    /// Sets the scissor of a draw of `geometry` that asks for `scissor`,
    /// unless the one set cuts its meshes alike (`state::scissor_serves`).
    fn set_draw_scissor(&mut self, geometry: &Geometry, scissor: Rect) {
        if self.scissor == Some(scissor) {
            return;
        }
        let ids = match geometry {
            Geometry::FullScreen { .. } => return self.set_scissor(scissor),
            g => g.meshes(),
        };
        let kept = self.scissor.is_some_and(|c| {
            let covered = self.b.mesh_rects.of(ids);
            state::scissor_serves(c, scissor, covered, self.render_area)
        });
        if !kept {
            self.set_scissor(scissor);
        }
    }

    /// Records the fields of `next` that differ from the dynamic state set (a
    /// pipeline with dynamic depth, stencil and cull state is bound).
    fn set_dynamic(&mut self, next: &RasterState) {
        let mut n = 0;
        for f in state::changes(next, self.dyn_state.as_ref()) {
            state::record(self.b.device, self.cmd, next, f);
            n += 1;
        }
        self.stats.counts.state_commands += n;
        self.dyn_state = Some(*next);
    }

    /// Sets the scissor and the dynamic state of `draw` (`None`: tests off),
    /// under a pipeline with dynamic state ([`Pipelines::get`]).
    fn set_state(&mut self, draw: Option<&Draw>, scissor: Rect) {
        self.set_scissor(scissor);
        self.set_dynamic(&state::raster_state(draw, self.b.desc.reversed_z));
    }

    /// Records `pc` unless what the command buffer holds serves a draw that
    /// reads every field.
    fn push(&mut self, pc: &PushConstants) {
        self.push_reads(pc, Reads::ALL);
    }

    /// Records `pc` for a draw of program `kind` (`quad`: of the full-screen
    /// quad, which reads `mvp`) unless what is held serves it (`record/push.rs`).
    fn push_for(&mut self, kind: FragmentKind, quad: bool, pc: &PushConstants) {
        let reads = Reads {
            mvp: quad,
            ..kind.reads()
        };
        self.push_reads(pc, reads);
    }

    fn push_reads(&mut self, pc: &PushConstants, reads: Reads) {
        let Some(next) = self.push.next(pc, reads) else {
            return;
        };
        // SAFETY: recording; the range matches the layout's single push range.
        unsafe {
            self.b.device.cmd_push_constants(
                self.cmd,
                self.b.pipelines.layout,
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                0,
                &next.bytes(),
            )
        };
        self.stats.counts.state_commands += 1;
    }

    /// Pushes `pc` for `kind` and draws the full-screen quad (inside a block,
    /// with the pipeline bound), counted as a full-screen pass over `area`
    /// pixels (its scissor).
    fn quad_pass(&mut self, kind: FragmentKind, pc: &PushConstants, area: u64) {
        self.push_for(kind, true, pc);
        let first = self.b.scene.quad_first;
        // SAFETY: inside a block with a bound pipeline and vertex buffer; the
        // quad's six vertices lie in it.
        unsafe { self.b.device.cmd_draw(self.cmd, 6, 1, first, QUAD_INSTANCE) };
        self.stats.counts.fullscreen_passes += 1;
        self.stats.counts.fullscreen_pixels += area;
    }

    fn flags(&self) -> u32 {
        self.b.flags
    }

    fn fullscreen_matrix(depth: f32) -> [f32; 16] {
        let mut m = glam::Mat4::IDENTITY.to_cols_array();
        m[10] = 0.0;
        m[14] = depth;
        m
    }

    /// A full-screen draw that is not a plan `Draw` (depth copies), cut to
    /// `rect`.
    fn fullscreen_internal(
        &mut self,
        key: &BlockKey,
        kind: FragmentKind,
        set: vk::DescriptorSet,
        rect: Rect,
    ) -> Result<(), VkError> {
        let tests_off = state::raster_state(None, self.b.desc.reversed_z);
        let pipe = self.pipeline_for(key, kind, &tests_off)?;
        self.bind_pipe(pipe, Some(set));
        self.check_in_area(rect);
        self.set_scissor(rect);
        let pc = PushConstants {
            mvp: Self::fullscreen_matrix(0.0),
            flags: self.flags(),
            snap: self.b.snap,
            ..Default::default()
        };
        self.quad_pass(kind, &pc, rect.area());
        Ok(())
    }

    /// A draw's scissor lies in its block's render area (`render_area`).
    fn check_in_area(&self, scissor: Rect) {
        assert!(
            self.render_area.contains(&scissor),
            "a draw's scissor {scissor:?} lies outside its block's render area {:?}",
            self.render_area
        );
    }

    fn scissor(&self, s: &Scissor) -> Rect {
        let (w, h) = (self.b.desc.width, self.b.desc.height);
        self.b.mesh_rects.scissor(s, w, h)
    }

    fn draw(&mut self, draw: &Draw) -> Result<(), VkError> {
        // One lowering, shared with the look-ahead (`record/lower.rs`).
        let dead = self.dead_texture_write(draw);
        let scissor = self.scissor(&draw.scissor);
        match lower::lower(draw, dead, scissor, self.b.ties, &self.direct) {
            RecordedDraw::OffScreen => {
                self.stats.counts.skipped_steps += 1;
                Ok(())
            }
            RecordedDraw::Dropped => Ok(()),
            RecordedDraw::One(d, how) => {
                how.count(&d, scissor, &mut self.stats.counts);
                self.draw_in(&d, scissor)
            }
            RecordedDraw::Zoned {
                rule,
                culled,
                fixed,
                zones,
            } => self.zoned_shade(&rule, culled, &fixed, scissor, zones),
        }
    }

    /// Records `draw` cut to `scissor`, not empty.
    fn draw_in(&mut self, draw: &Draw, scissor: Rect) -> Result<(), VkError> {
        let kind = fragment_kind(&draw.fragment);
        let set = usage::sampled_texture(&draw.fragment)
            .map(|t| self.b.targets.sampling_set(Resource::Texture(t)));
        let mut uses = self.draw_uses(draw);
        let own = BlockKey::of_draw(&uses, draw.ds);
        let key = self.block_for(own, kind.writes_color(), scissor, &uses);
        if key != own {
            // Attached though not written (masked): a new block needs their
            // barriers too.
            for &c in key.colors() {
                uses.push((c, Usage::ColorTarget));
            }
        }
        let raster = state::raster_state(Some(draw), self.b.desc.reversed_z);
        let pipe = self.pipeline_for(&key, kind, &raster)?;
        self.open(&key, &uses);
        self.check_in_area(scissor);
        self.bind_pipe(pipe, set);
        self.set_draw_scissor(&draw.geometry, scissor);
        let flags = self.flags();
        let scene = self.b.scene;
        let rgb = |c: [u8; 3]| {
            [
                c[0] as f32 / 255.0,
                c[1] as f32 / 255.0,
                c[2] as f32 / 255.0,
                1.0,
            ]
        };
        let device = self.b.device;
        let query = if draw.count_samples {
            let q = self.queries.len() as u32;
            self.queries.push(self.group);
            // SAFETY: inside a block; the query was reset in this buffer and is not active.
            unsafe {
                device.cmd_begin_query(
                    self.cmd,
                    self.b.occlusion,
                    q,
                    vk::QueryControlFlags::empty(),
                )
            };
            Some(q)
        } else {
            None
        };
        self.stats.counts.draws += 1;
        if let Some(i) = self.pass {
            self.stats.per_pass[i].draws += 1;
        }
        match &draw.geometry {
            Geometry::FullScreen { depth } => {
                let color = match draw.fragment {
                    Fragment::Paint { rgb: c } => rgb(c),
                    _ => rgb(scene.background),
                };
                let pc = PushConstants {
                    mvp: Self::fullscreen_matrix(conv::depth_value(*depth, self.b.desc.reversed_z)),
                    color,
                    prim: 0,
                    flags,
                    // The quad stays unsnapped (`shaders/mesh.vert`).
                    snap: self.b.snap,
                    ..Default::default()
                };
                self.quad_pass(kind, &pc, scissor.area());
            }
            Geometry::Mesh(_) | Geometry::Meshes(_) | Geometry::Footprint { .. } => {
                let ids = draw.geometry.meshes();
                let (w, h) = (self.b.desc.width, self.b.desc.height);
                if let Geometry::Footprint { depth, .. } = draw.geometry {
                    // Every fragment at `depth`; clipping is the mesh's own.
                    let d = conv::depth_value(depth, self.b.desc.reversed_z);
                    state::set_viewport(device, self.cmd, w, h, d..=d);
                    self.stats.counts.state_commands += 1;
                    self.stats.counts.footprint_passes += 1;
                }
                self.stats.counts.mesh_draws += 1;
                self.stats.counts.mesh_pixels += scissor.area();
                // A program that reads the primitive id needs each mesh's own
                // constants and draw call.
                let per_mesh = kind.reads().prim;
                let mut i = 0;
                while i < ids.len() {
                    let m = ids[i];
                    let (first, mut count) = scene.ranges[m as usize];
                    // Meshes that follow in the vertex buffer join this call when
                    // nothing per mesh reaches the shaders.
                    let mut j = i + 1;
                    while !per_mesh && j < ids.len() && ids[j] == ids[j - 1] + 1 {
                        count += scene.ranges[ids[j] as usize].1;
                        j += 1;
                    }
                    // Fields the program does not read are not pushed for.
                    let (color, prim) = if per_mesh {
                        let color = match draw.fragment {
                            Fragment::Paint { rgb: c } => rgb(c),
                            Fragment::Background => rgb(scene.background),
                            // The tolerance travels in the colour's alpha.
                            Fragment::ShadeNearDepth { eps, .. } => {
                                let [r, g, b, _] = rgb(scene.colors[m as usize]);
                                [r, g, b, eps]
                            }
                            _ => rgb(scene.colors[m as usize]),
                        };
                        (color, m + 1)
                    } else {
                        let color = match draw.fragment {
                            Fragment::PeelTolerant { eps, .. } => [eps, 0.0, 0.0, 0.0],
                            Fragment::NearerThan { eps, .. }
                            | Fragment::ParityBeforeExit { eps, .. }
                            | Fragment::BehindThan { eps, .. }
                            | Fragment::MergeBehind { eps, .. } => [0.0, 0.0, 0.0, eps],
                            _ => [0.0; 4],
                        };
                        (color, 0)
                    };
                    let pc = PushConstants {
                        color,
                        prim,
                        // The matrix comes from the camera's uniform buffer.
                        flags,
                        snap: self.b.snap,
                        ..Default::default()
                    };
                    self.push_for(kind, false, &pc);
                    if count > 0 {
                        // SAFETY: inside a block; the range lies in the vertex buffer.
                        unsafe { device.cmd_draw(self.cmd, count, 1, first, 0) };
                        self.stats.counts.draw_calls += 1;
                    }
                    self.stats.counts.triangles += count as u64 / 3;
                    i = j;
                }
                if let Geometry::Footprint { .. } = draw.geometry {
                    state::set_viewport(device, self.cmd, w, h, 0.0..=1.0);
                    self.stats.counts.state_commands += 1;
                }
            }
        }
        if let Some(q) = query {
            // SAFETY: the query was begun in this block.
            unsafe { device.cmd_end_query(self.cmd, self.b.occlusion, q) };
        }
        Ok(())
    }
}

fn fragment_kind(f: &Fragment) -> FragmentKind {
    match f {
        Fragment::None => FragmentKind::None,
        Fragment::Shade => FragmentKind::Shade,
        Fragment::Paint { .. } => FragmentKind::Paint,
        Fragment::Background => FragmentKind::Background,
        Fragment::Peel { shade: true, .. } => FragmentKind::PeelShade,
        Fragment::Peel { .. } => FragmentKind::Peel,
        Fragment::WriteDepth { .. } => FragmentKind::WriteDepth,
        Fragment::ShadeAtDepth { .. } => FragmentKind::ShadeAtDepth,
        Fragment::DepthFromTexture { .. } => FragmentKind::DepthFromTexture,
        Fragment::PeelTolerant { .. } => FragmentKind::PeelTolerant,
        // The texel copy is the depth-copy shader reading a depth texture.
        Fragment::CopyTexel { .. } => FragmentKind::CopyDepth,
        Fragment::NearerThan { .. } | Fragment::ParityBeforeExit { .. } => FragmentKind::NearerThan,
        Fragment::BehindThan { .. } => FragmentKind::BehindThan,
        // An exact merge needs none of the tie rule's fetches.
        Fragment::MergeBehind { eps, .. } if *eps == 0.0 => FragmentKind::MergeBehindExact,
        Fragment::MergeBehind { .. } => FragmentKind::MergeBehind,
        Fragment::ShadeNearDepth { .. } => FragmentKind::ShadeNearDepth,
        Fragment::DepthAtDepth { .. } => FragmentKind::DepthAtDepth,
    }
}
