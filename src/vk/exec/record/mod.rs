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
//! Re-recording a plan costs ≤ 1 µs of CPU per draw: a pipeline
//! bind, the scissor and the push constants are recorded only where they
//! change (`state.rs`, `record/push.rs`), and nothing is allocated per draw.
//!
//! Files: this one holds the recorder and its frame ends; `step` (a step
//! recorded: copies and draws), `blocks` (image states, barriers, rendering
//! blocks), `bind` (pipelines, sets, scissors, dynamic state, push constants
//! recorded where they change), `fullscreen` (the quad, the edge and
//! accumulate passes), `clears` (deferred clears), `ahead` (the look-ahead
//! joining blocks), `lower` (a draw lowered once), `shade` (the final shade's
//! depth copies and tie zones), `push` (push constants held), `host` (the
//! final shade into an embedding host's attachments).

use std::collections::{BTreeMap, VecDeque};

use ash::vk;

use super::gpu_scene::GpuScene;
use super::state;
use super::stats::ExecStats;
use super::targets::{self, Targets};
use super::ExecDesc;
use ahead::Ahead;
use clears::PendingClear;

mod ahead;
mod bind;
mod blocks;
mod clears;
mod fullscreen;
mod host;
mod push;
mod shade;
mod step;
use crate::plan::direct_shade::DirectShades;
use crate::plan::reach::ClearNeed;
use crate::plan::tie_free::{ShadeCopy, TieFree};
use crate::plan::usage::{Resource, Usage};
use crate::vk::pipeline::{Pipelines, RasterState};
use crate::vk::scissor::{Rect, RectUnions};
use crate::vk::sync::REST;
use bind::Pipe;
use blocks::ImageStates;
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

/// Where a command buffer's closing timestamp (per-pass timestamps off) goes.
///
/// On lavapipe a timestamp bins its query into every tile of the scene being
/// binned (a new one when none is), and each rasterizer thread keeps the time
/// of the last tile it ran the query in; `BOTTOM_OF_PIPE` first flushes the
/// scene. Written after the last block, the closing timestamp is a scene of its
/// own: one more round of waking the rasterizer threads and waiting for them.
/// shadow_block SCS at 800×800: 25–27 context switches a frame with it outside,
/// 20–20.6 with it binned (9.5 with no timestamps at all; docs/executor.md). The
/// opening one keeps its scene: inside the first block each thread would keep the
/// time of its last tile, the frame's end.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameTimestamps {
    /// `BOTTOM_OF_PIPE` after every command of the buffer: what a hardware
    /// GPU's timestamp means.
    Outside,
    /// The CPU devices' (lavapipe's): `TOP_OF_PIPE` inside the last block (no
    /// flush), so its query lands in every tile after the tile's draws and the
    /// latest thread's time is when they were done. The clears and barriers
    /// after the last block fall outside the frame's GPU time.
    Binned,
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
    /// A timestamp at every `Step::Pass` (per-pass GPU times); otherwise only
    /// around the command buffer.
    pub pass_timestamps: bool,
    /// Where the frame's closing timestamp goes ([`FrameTimestamps`]).
    pub frame_ts: FrameTimestamps,
    /// Push-constant flags (reversed Z, subpixel precision).
    pub flags: u32,
    /// Emulated vertex snapping step of mesh draws (zero: off).
    pub snap: [f32; 2],
    /// Write the normal buffer wherever colour is written (Kirsch, Nienhaus & Döllner
    /// §5.2).
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
    /// Lavapipe clears on load far more slowly (docs/executor.md), so CPU
    /// devices use this.
    Command,
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
    /// The command buffer's closing timestamp is written (inside its last block).
    closed: bool,
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
            closed: false,
            pass: None,
            stats: ExecStats::default(),
        }
    }

    pub fn begin(&mut self, cmd: vk::CommandBuffer, occlusion_cap: u32, timestamp_cap: u32) {
        self.queries.clear();
        self.marks.clear();
        self.closed = false;
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
        self.timestamp(pass, vk::PipelineStageFlags::BOTTOM_OF_PIPE);
    }

    /// Whether the closing timestamp goes where [`FrameTimestamps::Binned`] says.
    fn binned_timestamps(&self) -> bool {
        self.b.frame_ts == FrameTimestamps::Binned
            && !self.b.pass_timestamps
            && self.b.timestamps.is_some()
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
        let vertices = &self.b.scene.vertices;
        // SAFETY: the vertex and index buffers are live while the recording may
        // be replayed.
        unsafe {
            let d = self.b.device;
            d.cmd_bind_vertex_buffers(cmd, 0, &[vertices.raw], &[0]);
            d.cmd_bind_index_buffer(cmd, self.b.scene.indices.raw, 0, vk::IndexType::UINT32);
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
        self.stats.counts.state_commands += 5;
    }

    fn pass_name(&self) -> String {
        self.pass
            .map(|i| self.stats.per_pass[i].name.clone())
            .unwrap_or_default()
    }

    /// Ends the current command buffer's work (it stays to be ended by the caller).
    pub fn end(&mut self) {
        self.end_block();
        if !self.closed {
            self.timestamp(String::new(), vk::PipelineStageFlags::BOTTOM_OF_PIPE);
        }
    }

    /// Writes the closing timestamp into the open block where
    /// [`FrameTimestamps::Binned`] asks for it (per-pass timestamps end every
    /// pass's block anyway): the frame's time then ends with its last block's
    /// draws, and [`Self::end`] writes none.
    /// `open`: a block is open (the recorder's, or the host's).
    pub(super) fn close_in_block(&mut self, open: bool) {
        if self.binned_timestamps() && open {
            self.timestamp(String::new(), vk::PipelineStageFlags::TOP_OF_PIPE);
            self.closed = true;
            self.stats.counts.timestamps_in_block += 1;
        }
    }

    /// Leaves the images the way the next frame expects them: read-back targets
    /// with their pending clears done, every image in `REST`.
    pub fn finish_frame(&mut self, output_ds: u8) {
        self.close_in_block(self.block.is_some());
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

    fn timestamp(&mut self, pass: String, stage: vk::PipelineStageFlags) {
        let Some(ts) = self.b.timestamps else { return };
        let idx = self.marks.len() as u32;
        // SAFETY: recording, inside or outside rendering (no multiview); the
        // query was reset in this buffer and is written once.
        unsafe { self.b.device.cmd_write_timestamp(self.cmd, stage, ts, idx) };
        self.marks.push(pass);
        self.stats.counts.timestamps += 1;
    }
}
