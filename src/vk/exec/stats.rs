//! The executor's statistics: typed until `output.rs` writes them as JSON.
//! Timings vary from run to run; counts are deterministic (two runs of one plan
//! on one scene and camera give equal counts).

use crate::plan::lower::Lowering;
use crate::plan::scissor::Rect;
use crate::plan::{Cull, Draw};
use serde::Serialize;

/// GPU time and draw count of all `Step::Pass` groups of one name.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PassStats {
    /// The pass group's name.
    pub name: String,
    /// Its GPU time (0 where timestamps are not read, e.g. embedded frames).
    pub gpu_ms: f64,
    /// Its draws.
    pub draws: u64,
}

/// Deterministic counts of one executed frame.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Counts {
    /// `Step::Draw`s executed (loop bodies once per iteration), skipped ones not
    /// counted.
    pub draws: u64,
    /// Draws of mesh geometry (`Mesh` or `Meshes`).
    pub mesh_draws: u64,
    /// `vkCmdDraw` calls of mesh geometry after merging meshes that lie
    /// contiguously in the vertex buffer and share all state.
    pub draw_calls: u64,
    /// Those of `draw_calls` drawn indexed, from the meshes' shared or lit
    /// corners (`GpuScene`'s doc): all of them.
    pub indexed_draw_calls: u64,
    /// Full-screen draws, including internal depth copies.
    pub fullscreen_passes: u64,
    /// Mesh triangles submitted for rasterization (full-screen quads not counted).
    pub triangles: u64,
    /// Sum of the scissor areas of full-screen draws.
    pub fullscreen_pixels: u64,
    /// Sum of the scissor areas of mesh draws: a bound on the pixels their
    /// fragments can cover (the per-fragment work of a software rasterizer).
    pub mesh_pixels: u64,
    /// Mesh draws at a constant depth (`Geometry::Footprint`): full-screen
    /// passes cut to a mesh's footprint, counted in `mesh_draws` and
    /// `mesh_pixels` too.
    pub footprint_passes: u64,
    /// Plan steps not recorded because their scissor is empty on screen.
    pub skipped_steps: u64,
    /// Tolerant parity and peel draws run as plain depth tests because no face
    /// they draw can tie under this camera (`plan::tie_free`): a depth-stencil
    /// draw without a shader, the exact peel, or SCS's exact merge.
    pub tie_free_draws: u64,
    /// Parity, clip, merge and peel draws that still run a tie-rule shader
    /// (`nearer_than`, `behind_than`, `merge_behind`, `peel_tolerant`).
    pub tie_rule_draws: u64,
    /// Parity and clip draws that may meet a tie, their rule run as the depth
    /// test (`Fragment::TieDepth`, `plan::tie_free`): no texture read.
    pub tie_depth_draws: u64,
    /// Draws recorded depth-only because nobody reads the depth texture they
    /// write (`plan::reach`): SCS's front and exit draws once every draw
    /// that sampled their texture is tie-free.
    pub dead_texture_writes: u64,
    /// Draws of the final shade (`plan::tie::shade_near_depth`) run as plain
    /// depth-`EQUAL` draws of the shading program because the mesh cannot tie
    /// under this camera (`plan::tie_free`): tested before the shader, no
    /// texture read, no depth written.
    pub shade_fixed_draws: u64,
    /// Direct draws of one-primitive products recorded with the shading
    /// program, colour and id written with their depth, each replacing its
    /// mesh's draw in the final shade (`plan::direct_shade`). In an embedded
    /// frame: those products' depth-equal final-shade draws into the host's
    /// targets, drawn without a check of the output depth (`record::host`;
    /// also counted in `shade_fixed_draws`).
    pub direct_shade_draws: u64,
    /// In an embedded frame: depth-equal final-shade draws into the host's
    /// targets that write their own depth, with no depth merge before them
    /// (`record::host`'s `writes_depth`; also counted in `shade_fixed_draws`).
    pub shade_written_draws: u64,
    /// In an embedded frame: depth-equal final-shade pieces drawn without a
    /// check of the output depth because they lie outside the screen
    /// rectangles of their mesh's cutters (`plan::cut_away`; also counted in
    /// `shade_fixed_draws`, and in `shade_written_draws` where they write
    /// their depth), and the sum of their scissor areas.
    pub shade_uncut_draws: u64,
    /// The sum of the scissor areas of those pieces (see `shade_uncut_draws`).
    pub shade_uncut_pixels: u64,
    /// In an embedded frame: the sum of the scissor areas of the pieces that
    /// write their depth and fetch the output depth on every fragment in
    /// front of the host's (`Piece::Written`): the pixels that may run the
    /// fetch.
    pub shade_written_fetch_pixels: u64,
    /// In an embedded frame: the draws (and their triangles) that splitting
    /// pieces at their mesh's cutters added (`plan::cut_away`: a piece split
    /// into `k` counts `k - 1`); the standalone frame has none of them.
    pub shade_split_draws: u64,
    /// The triangles of those added draws (see `shade_split_draws`).
    pub shade_split_triangles: u64,
    /// Draws of the final shade (depth-equal or tie-rule) that cull the side
    /// of their mesh that is never visible (`plan::VisibleSides`): about half
    /// its faces.
    pub shade_culled_draws: u64,
    /// Draws of the final shade that keep the tie rule (`shade_near_depth`):
    /// one per mesh, or one per rule rectangle of a mesh whose shade keeps the
    /// rule only in its tie zones (`plan::tie_zones`; its depth-equal pieces
    /// count as `shade_fixed_draws`).
    pub shade_rule_draws: u64,
    /// Sum of the scissor areas of the final shade's tie-rule draws: the pixels
    /// that may run `shade_near_depth`.
    pub shade_rule_pixels: u64,
    /// Pipeline barriers recorded (each may carry several image barriers). A
    /// plan's first frame, run loop by loop, records more: each of its
    /// submissions starts a new rendering block.
    pub barriers: u64,
    /// Pipeline, descriptor-set and vertex-buffer binds, push constants and
    /// dynamic-state commands recorded; one that would repeat what the command
    /// buffer already holds is not recorded (the CPU cost of recording, with
    /// `draw_calls`).
    pub state_commands: u64,
    /// Rendering blocks (`vkCmdBeginRendering`) recorded. Lavapipe starts a new
    /// binned scene for each whose attachments differ from the last one's.
    pub render_passes: u64,
    /// Clear commands (`vkCmdClear*Image`, `vkCmdClearAttachments`): on lavapipe
    /// each waits for the rasterizer and fills on the calling thread.
    pub clear_commands: u64,
    /// Attachments cleared by their block's load op.
    pub load_op_clears: u64,
    /// Pixels cleared, by clear commands (their rectangles) and load ops (whole
    /// images).
    pub cleared_pixels: u64,
    /// Bytes those clears fill (`conv::texel_bytes` of each image's format):
    /// a depth-only plan's depth images are half as wide (`plan::formats`).
    pub cleared_bytes: u64,
    /// Pixels copied between textures (`CopyTexture`).
    pub copied_pixels: u64,
    /// GPU timestamps written (per pass, or only around the frame).
    pub timestamps: u64,
    /// Of those, closing timestamps written inside the last block
    /// (`FrameTimestamps::Binned`: one fewer scene for lavapipe).
    pub timestamps_in_block: u64,
    /// Embedded final-shade pieces drawn after the solid's faces with the
    /// strict compare: the cavities' insides (`record::host::insides_last`).
    pub shade_insides_last: u64,
    /// Pixels cut from the final shade's cavity insides' scissors, where
    /// they cannot be seen through an opening: embedded
    /// (`record::host::cut_insides`) and in the executor's own targets
    /// (`record::lower::seen_inside`).
    pub shade_insides_cut_pixels: u64,
    /// Queue submissions of the frame.
    pub submits: u64,
    /// Pipelines created for this frame: the first use of a fragment program
    /// with a set of attachment formats on this executor (later frames and plans
    /// reuse them).
    pub pipelines_created: u64,
    /// Head executions of each loop, in execution order.
    pub loop_iterations: Vec<u32>,
    /// Samples passed by all `count_samples` draws.
    pub samples_counted: u64,
    /// Samples passed by the `count_samples` draws after the plan's last loop
    /// (Kirsch, Nienhaus & Döllner's layer count, §6).
    pub final_samples: u64,
}

/// How a frame's commands came to be (record once, replay).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Recorded {
    /// The kept recording, replayed as it was (same plan, loop counts and
    /// scissors).
    #[default]
    Replayed,
    /// The kept recording replayed under a moved camera: only the camera's
    /// uniform buffer changed (every mesh stayed inside its recorded scissor).
    ReplayedMovedCamera,
    /// Recorded anew because the camera moved a mesh out of its recorded scissor,
    /// or stopped after moving (scissors made exact again).
    Camera,
    /// Recorded: a new plan, new loop counts or replaced device objects.
    New,
    /// Run loop by loop, each submission recorded (a plan's first frame, or loop
    /// counts that no longer fit).
    Stepwise,
}

/// Timings and counts of one `Executor::execute`.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ExecStats {
    /// GPU time from timestamps around the frame's work.
    pub gpu_ms: f64,
    /// Wall time of `execute`: validation, recording, submission and waiting.
    pub cpu_ms: f64,
    /// Wall time from the first submission of the frame until the GPU is idle,
    /// images left on the GPU.
    pub frame_ms: f64,
    /// The process's CPU time, all threads (`vk::cpu_clock`), over the same
    /// interval as `frame_ms`: on a CPU device the frame's cost unaffected by
    /// other processes' load.
    pub frame_cpu_ms: f64,
    /// CPU time of the calling thread recording command buffers (0 when a
    /// recording is replayed), without creating pipelines (`pipeline_ms`).
    pub record_ms: f64,
    /// CPU time of the calling thread creating the pipelines this frame used
    /// first (`pipelines_created`; the driver compiles their shaders then).
    pub pipeline_ms: f64,
    /// Whether the frame replayed a recording or recorded, and why.
    pub recorded: Recorded,
    /// Per pass group, in order of first appearance.
    pub per_pass: Vec<PassStats>,
    /// Embedded frames ([`crate::vk::Embedder::record`]) only: how the final
    /// shading reached the host's attachments (directly, or by the composite
    /// fallback and why).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub host_path: Option<crate::vk::embed::HostPath>,
    /// Deterministic counts.
    #[serde(flatten)]
    pub counts: Counts,
}

impl ExecStats {
    /// The per-pass entry of `name`; none for work before the first `Step::Pass`.
    pub(super) fn pass_entry(&mut self, name: &str) -> Option<&mut PassStats> {
        if name.is_empty() {
            return None;
        }
        let i = match self.per_pass.iter().position(|p| p.name == name) {
            Some(i) => i,
            None => {
                self.per_pass.push(PassStats {
                    name: name.to_string(),
                    ..Default::default()
                });
                self.per_pass.len() - 1
            }
        };
        Some(&mut self.per_pass[i])
    }

    /// Adds the figures of another frame run as part of the same result (e.g.
    /// the plans of the layers of one transparent image): times and counts sum,
    /// loop iterations and passes are appended (passes of one name summed).
    pub fn accumulate(&mut self, other: &ExecStats) {
        self.gpu_ms += other.gpu_ms;
        self.cpu_ms += other.cpu_ms;
        self.frame_ms += other.frame_ms;
        self.frame_cpu_ms += other.frame_cpu_ms;
        self.record_ms += other.record_ms;
        self.pipeline_ms += other.pipeline_ms;
        for p in &other.per_pass {
            if let Some(e) = self.pass_entry(&p.name) {
                e.gpu_ms += p.gpu_ms;
                e.draws += p.draws;
            }
        }
        let (c, o) = (&mut self.counts, &other.counts);
        c.draws += o.draws;
        c.mesh_draws += o.mesh_draws;
        c.draw_calls += o.draw_calls;
        c.indexed_draw_calls += o.indexed_draw_calls;
        c.fullscreen_passes += o.fullscreen_passes;
        c.triangles += o.triangles;
        c.fullscreen_pixels += o.fullscreen_pixels;
        c.footprint_passes += o.footprint_passes;
        c.skipped_steps += o.skipped_steps;
        c.tie_free_draws += o.tie_free_draws;
        c.dead_texture_writes += o.dead_texture_writes;
        c.tie_rule_draws += o.tie_rule_draws;
        c.tie_depth_draws += o.tie_depth_draws;
        c.shade_fixed_draws += o.shade_fixed_draws;
        c.direct_shade_draws += o.direct_shade_draws;
        c.shade_written_draws += o.shade_written_draws;
        c.shade_uncut_draws += o.shade_uncut_draws;
        c.shade_uncut_pixels += o.shade_uncut_pixels;
        c.shade_written_fetch_pixels += o.shade_written_fetch_pixels;
        c.shade_split_draws += o.shade_split_draws;
        c.shade_split_triangles += o.shade_split_triangles;
        c.shade_rule_draws += o.shade_rule_draws;
        c.shade_rule_pixels += o.shade_rule_pixels;
        c.barriers += o.barriers;
        c.render_passes += o.render_passes;
        c.clear_commands += o.clear_commands;
        c.load_op_clears += o.load_op_clears;
        c.cleared_pixels += o.cleared_pixels;
        c.cleared_bytes += o.cleared_bytes;
        c.copied_pixels += o.copied_pixels;
        c.timestamps += o.timestamps;
        c.timestamps_in_block += o.timestamps_in_block;
        c.shade_insides_last += o.shade_insides_last;
        c.shade_insides_cut_pixels += o.shade_insides_cut_pixels;
        c.state_commands += o.state_commands;
        c.submits += o.submits;
        c.pipelines_created += o.pipelines_created;
        c.loop_iterations.extend_from_slice(&o.loop_iterations);
        c.samples_counted += o.samples_counted;
    }
}

impl Counts {
    /// Counts one draw `d` lowered `how` (`plan::lower`), cut to `scissor`.
    pub(crate) fn count_lowering(&mut self, how: Lowering, d: &Draw, scissor: Rect) {
        match how {
            Lowering::Planned => {}
            Lowering::TieRule => self.tie_rule_draws += 1,
            Lowering::DirectShade => self.direct_shade_draws += 1,
            Lowering::FixedFunction { shade: true } => {
                self.shade_fixed_draws += 1;
                self.shade_culled_draws += (d.cull != Cull::None) as u64;
            }
            Lowering::FixedFunction { shade: false } => self.tie_free_draws += 1,
            Lowering::TieDepth => self.tie_depth_draws += 1,
            Lowering::ShadeRule { culled } => {
                self.shade_rule_draws += 1;
                self.shade_rule_pixels += scissor.area();
                self.shade_culled_draws += culled as u64;
            }
        }
    }
}
