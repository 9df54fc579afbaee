//! The plan executor: runs a [`Plan`]'s steps on one device at one image size and
//! leaves the frame's images on the GPU; [`Executor::read_back`] copies them to
//! the CPU when someone needs the pixels.
//!
//! A frame is one command buffer and one submission. Its data-dependent loops
//! (`Step::Loop`, peeling until an occlusion query counts no sample) are unrolled
//! to the layer counts the previous frame of the same plan needed, and checked on
//! the GPU's query results after the frame: every head but the last must have
//! passed samples, the last none (or the loop hit its bound). A plan seen for the
//! first time, or a check that fails (the view changed the depth complexity), runs
//! loop by loop instead — one submission per head and tail with a CPU wait, which
//! learns the counts — so images never depend on a guess. The unrolled recording
//! is kept and replayed as long as the plan and the layer counts stay the same
//! (`record_ms` is then 0). The camera is a uniform buffer (`camera`), so a moved
//! camera replays too, unless a mesh's screen rectangle left the one its scissors
//! were recorded with (`Scissors`; see docs/executor.md).
//!
//! Modules: `gpu_scene` (vertex buffer, camera state), `camera` (its uniform
//! buffer), `targets` (images and descriptor sets), `record` (steps to commands,
//! barriers from `plan::usage` through `vk::sync`), `state` (dynamic state
//! recorded only where it changes), `stats` (typed statistics), `normals` (the
//! optional normal buffer and the edge pass on it, Kirsch, Nienhaus & Döllner §5),
//! `transparency` (the accumulate pass compositing peeled layers on the GPU,
//! Hable & Rossignac §6), `sequence` (several plans, accumulate passes and layer
//! copies in one submission: layered frames), `shadow` (what the shadow pass,
//! `vk::shadow`, reads of an executor), `switches` (the `set_*` settings), `ties`
//! (the tie-free decisions, kept per plan and camera), `scissors` (the per-mesh
//! rectangles of a recording's scissors), `recording` (the kept recording and
//! its timing), `kept` (what the outputs hold, what clears and copies reach),
//! `unrolled` (frames with unrolled loops, checked after the fact),
//! `stepwise` (the loop-by-loop frame), `read_back` (images to the CPU),
//! `batch` and `embed` (frames others submit).

mod batch;
mod camera;
mod corners;
mod embed;
mod gpu_scene;
mod kept;
mod normals;
mod read_back;
mod record;
mod recording;
mod scissors;
mod sequence;
mod shadow;
mod state;
mod stats;
mod stepwise;
mod switches;
mod targets;
mod ties;
mod transparency;
mod unrolled;

use std::sync::Arc;
use std::time::Instant;

use ash::vk;

pub use super::conv::DepthFormat;
pub(crate) use embed::{Output, Unrolled};
pub(crate) use normals::copy_to_host;
pub use sequence::{PlanCounts, SeqFrame, SeqItem};
pub(crate) use shadow::color_format;
pub use stats::{Counts, ExecStats, PassStats, Recorded};

use super::error::VkError;
use super::instance::{Context, Shared};
use super::memory::Buffer;
use super::pipeline::Pipelines;
use super::profile::DeviceProfile;
use super::submit::{self, Queries, Submitter};
use super::sync::{self, REST};
use crate::images::Images;
use crate::plan::cut_away::CutAway;
use crate::plan::formats::needs_stencil;
use crate::plan::memo::{Memo, PlanIds};
use crate::plan::reach::KeptImages;
use crate::plan::tie_free::TieFree;
use crate::plan::validate::validate;
use crate::plan::{Plan, Step};
use crate::scene::{Camera, Scene};
use camera::CameraBuffer;
use gpu_scene::{CameraState, GpuScene};
use kept::{ReachKey, Reached};
use read_back::whole_image_region;
pub(crate) use record::{copy_counts, final_shade, host_barriers, peel_depth, HostShade};
use record::{Bindings, Group, Recorder};
pub use record::{ClearMode, FrameTimestamps};
use recording::Recording;
use scissors::{OpeningRects, Scissors};
use targets::Targets;
use ties::TieKey;
use unrolled::{add_gpu_times, layers_fit, unroll};

/// What an [`Executor`] renders into: its images' size and depth format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExecDesc {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The format of the plans' depth-stencil images.
    pub depth_format: DepthFormat,
    /// Reversed depth (near 1, far 0); meant for `D32S8`.
    pub reversed_z: bool,
    /// Samples per pixel of every plan image (1, 2, 4 or 8; the device's
    /// [`Context::supported_samples`]). Above 1 the read-back resolves:
    /// colour averaged, depth and primitive ids of sample 0
    /// (`vk::resolve`).
    pub samples: u32,
}

/// A frame's images (read back) and statistics.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// The colour, primitive-id and depth images read back.
    pub images: Images,
    /// What the frame drew and how long it took.
    pub stats: ExecStats,
}

/// How many results each decision cache keeps, and plan ids the executor
/// remembers: a frame, the bench's moved camera and a layered frame's few
/// plans fit.
const MEMO_CAP: usize = 4;
const PLAN_IDS: usize = 16;

/// Time bookkeeping of one `execute`.
#[derive(Default)]
struct Clock {
    /// Wall clock: when the frame's first submission went out.
    first_submit: Option<Instant>,
    /// The process's CPU time at the first submission (`vk::cpu_clock`).
    first_submit_cpu: u64,
    /// The calling thread's CPU time recording, pipeline creation included.
    record_ms: f64,
}

/// A frame between [`Executor::begin_frame`] and [`Executor::end_frame`].
struct FrameStart {
    start: Instant,
    clock: Clock,
    /// The loop counts the last frame of the plan needed (`None`: a new plan).
    known: Option<Vec<u32>>,
    /// Each mesh's exact screen rectangle under the frame's camera.
    exact: Scissors,
    /// The camera is the last frame's.
    still: bool,
    /// Pipelines created, and their CPU ms, before the frame.
    pipelines_before: (u32, f64),
}

impl Clock {
    /// Notes the first submission of the frame (later ones change nothing).
    fn submitting(&mut self) {
        if self.first_submit.is_none() {
            self.first_submit_cpu = crate::vk::cpu_clock::process_ns();
            self.first_submit = Some(Instant::now());
        }
    }
}

/// Runs plans on one device at one image size.
pub struct Executor {
    shared: Arc<Shared>,
    desc: ExecDesc,
    pipelines: Pipelines,
    submit: Submitter,
    /// The replayable frame recording's command buffer.
    frame_cmd: vk::CommandBuffer,
    occlusion: Queries,
    timestamps: Queries,
    targets: Option<Targets>,
    scene: Option<GpuScene>,
    readback: Option<Buffer>,
    camera: CameraBuffer,
    /// The camera of the last frame (a camera that stays gets exact scissors).
    last_cam: Option<CameraState>,
    /// The per-mesh rectangles the next recording's scissors are made from.
    rects: Scissors,
    recording: Option<Recording>,
    /// Loop layer counts the last frame of this plan needed.
    layers: Option<(Plan, Vec<u32>)>,
    /// Bumped whenever an object a recording refers to is replaced.
    epoch: u64,
    /// Output depth-stencil of the last executed plan (what `read_back` copies).
    last_output: Option<u8>,
    /// Timestamps at every pass (per-pass GPU times) or only around the frame.
    pass_timestamps: bool,
    /// The cutter sets of the uploaded scene under its camera
    /// (`set_cut_away`): where the SCS subtractions' scissors
    /// (`plan::Scissor::Openings`) are cut to. Dropped with a new upload.
    cut_away: CutAway,
    /// Where `cut_away` shows each mesh's inside, for its camera.
    opening_rects: OpeningRects,
    /// Write the normal buffer with the colour ([`Executor::set_normals`]).
    normals: bool,
    /// What the device is and the workarounds it needs (the context's).
    profile: DeviceProfile,
    /// Stencil-free plans get depth-only images: the device can use the
    /// set-up's depth-only twin (half the bytes to clear and test where
    /// D32S8 becomes D32, the same depths).
    depth_only: bool,
    /// The tie-free decisions for the current plan and camera.
    ties: TieFree,
    /// Keep the accumulate pass's images ([`Executor::set_transparency`]).
    transparency: bool,
    /// Sequence frames' recording and buffers ([`Executor::execute_sequence`]).
    seq: sequence::SeqState,
    /// What the outputs hold now, outside the pixels frames dirtied
    /// (`plan::reach`): their next clears reach only those pixels.
    kept: KeptImages,
    /// An embedding recorded a frame someone else submits: what the outputs
    /// hold is no longer known here, and their clears reach whole images.
    kept_unknown: bool,
    /// Ids of the plans seen lately, for the decision caches' keys.
    plan_ids: PlanIds,
    /// `plan::tie_free` decisions, by plan, camera and settings.
    tie_memo: Memo<TieKey, TieFree>,
    /// `plan::reach` regions of recordings, by steps, scissors and what the
    /// outputs hold.
    reach_memo: Memo<ReachKey, Arc<Reached>>,
    /// The read-back's resolve pass and images, with samples above 1.
    resolve: Option<crate::vk::resolve::Resolve>,
    /// The last read-back's coverage, with samples above 1 ([`Executor::coverage`]).
    coverage: Option<Vec<u8>>,
}

impl Executor {
    /// An executor of plans into images of `desc` on `ctx`'s device.
    pub fn new(ctx: &Context, desc: &ExecDesc) -> Result<Executor, VkError> {
        let _layer = ctx.shared.layer_use();
        if desc.width == 0 || desc.height == 0 {
            return Err(VkError::Plan("image size must be at least 1x1".into()));
        }
        let shared = ctx.shared.clone();
        ctx.check_samples(desc.samples)?;
        if !ctx.depth_format_usable(desc.depth_format.vk()) {
            return Err(VkError::Unsupported(format!(
                "{:?} as a sampled, copyable depth-stencil attachment (try the other --depth-format)",
                desc.depth_format
            )));
        }
        let profile = *ctx.profile();
        let depth_only = ctx.depth_format_usable(desc.depth_format.vk_for(false));
        let pipelines = Pipelines::new(&shared)?;
        let camera = CameraBuffer::new(&shared, pipelines.camera_set_layout)?;
        let submit = Submitter::new(&shared)?;
        let frame_cmd = submit.allocate()?;
        let mut occlusion = Queries::new(&shared, vk::QueryType::OCCLUSION);
        let mut timestamps = Queries::new(&shared, vk::QueryType::TIMESTAMP);
        occlusion.ensure(64)?;
        timestamps.ensure(64)?;
        Ok(Executor {
            shared,
            desc: *desc,
            pipelines,
            submit,
            frame_cmd,
            occlusion,
            timestamps,
            targets: None,
            scene: None,
            readback: None,
            camera,
            last_cam: None,
            rects: Scissors {
                rects: Vec::new(),
                openings: Vec::new(),
                grown: false,
            },
            recording: None,
            layers: None,
            epoch: 0,
            last_output: None,
            pass_timestamps: true,
            cut_away: CutAway::none(),
            opening_rects: OpeningRects::default(),
            normals: false,
            profile,
            depth_only,
            ties: TieFree::none(),
            transparency: false,
            seq: Default::default(),
            kept: KeptImages::new(),
            kept_unknown: false,
            plan_ids: PlanIds::new(PLAN_IDS),
            tie_memo: Memo::new(MEMO_CAP),
            reach_memo: Memo::new(MEMO_CAP),
            resolve: None,
            coverage: None,
        })
    }

    /// The last read-back's coverage per pixel, row-major, with samples above
    /// 1: the samples a primitive covers, times 255 over the samples, rounded
    /// (`None` at one sample, where it is 255 wherever `prim` is not 0).
    pub fn coverage(&self) -> Option<&[u8]> {
        self.coverage.as_deref()
    }

    /// The size and formats it was created with.
    pub fn desc(&self) -> &ExecDesc {
        &self.desc
    }

    /// Uploads all meshes of `scene` (primitives in file order, then surfaces) and
    /// its camera.
    pub fn upload(&mut self, scene: &Scene) -> Result<(), VkError> {
        let _layer = self.shared.layer_use();
        self.scene = Some(GpuScene::new(&self.shared, scene, &self.desc)?);
        self.cut_away = CutAway::none();
        self.opening_rects.clear();
        self.epoch += 1;
        Ok(())
    }

    /// Moves the camera of the uploaded scene without uploading its meshes again
    /// (an interactive viewer orbiting).
    pub fn set_camera(&mut self, camera: &Camera) -> Result<(), VkError> {
        let desc = self.desc;
        let scene = self
            .scene
            .as_mut()
            .ok_or_else(|| VkError::Plan("set_camera before upload".into()))?;
        // Vertices stay relative to the eye at upload, so the images equal a
        // fresh upload's up to f32 rounding.
        scene.camera = *camera;
        scene.cam = gpu_scene::camera_state(camera, &desc, scene.origin);
        Ok(())
    }

    fn ensure_targets(&mut self, plan: &Plan) -> Result<(), VkError> {
        let n_ds = plan.depth_stencils.max(1) as usize;
        let n_tex = plan.textures as usize;
        let (normals, transparency) = (self.normals, self.transparency);
        let ds_format = self.ds_format(plan);
        if self.desc.samples > 1 && (normals || transparency) {
            let what = if normals {
                "the normal buffer (edge maps, --edges, styles and shadows)"
            } else {
                "the GPU transparency composite (--transparency gpu)"
            };
            return Err(VkError::Unsupported(format!(
                "{what} with {} samples per pixel: it reads single-sample \
                 neighbourhoods and layers; use --samples 1",
                self.desc.samples
            )));
        }
        if self
            .targets
            .as_ref()
            .is_some_and(|t| t.fits(n_ds, ds_format, n_tex, normals, transparency))
        {
            return Ok(());
        }
        self.targets = None;
        let t = Targets::new(
            &self.shared,
            &self.pipelines,
            &self.desc,
            n_ds,
            ds_format,
            n_tex,
            normals,
            transparency,
        )?;
        // New images start in `REST`, where every recording expects them.
        let cmd = self.submit.cmd;
        self.submit.begin(cmd, true)?;
        let rest = sync::access(REST);
        let barriers: Vec<_> = t
            .all()
            .into_iter()
            .map(|r| {
                let img = t.image(r);
                // Nothing to keep: from UNDEFINED, no access to wait for.
                let fresh = sync::Access {
                    access: vk::AccessFlags::empty(),
                    layout: vk::ImageLayout::UNDEFINED,
                    ..rest
                };
                sync::image_barrier(fresh, rest, img.raw, img.desc.aspect())
            })
            .collect();
        submit::image_barriers(
            &self.shared.device,
            cmd,
            vk::PipelineStageFlags::TOP_OF_PIPE,
            rest.stage,
            &barriers,
        );
        self.submit.finish(cmd)?;
        self.targets = Some(t);
        // New images hold nothing known.
        self.kept.clear();
        self.epoch += 1;
        Ok(())
    }

    /// The format of `plan`'s depth images: the set-up's, or its depth-only
    /// twin where no step uses stencil (`plan::formats`) and the device can
    /// use it.
    fn ds_format(&self, plan: &Plan) -> vk::Format {
        let stencil = !self.depth_only || needs_stencil(plan);
        self.desc.depth_format.vk_for(stencil)
    }

    /// The format of the current depth images (`None` before a frame).
    pub fn depth_images_format(&self) -> Option<vk::Format> {
        self.targets.as_ref().map(|t| t.ds_format)
    }

    /// Executes `plan` on the uploaded scene; the images stay on the GPU.
    pub fn execute(&mut self, plan: &Plan) -> Result<ExecStats, VkError> {
        let _layer = self.shared.layer_use();
        let mut f = self.begin_frame(plan)?;
        let unrolled = match f.known.clone() {
            Some(layers) => {
                let kind = self.ready_unrolled(plan, &layers, &mut f)?;
                f.clock.submitting();
                self.submit.submit(self.frame_cmd, &[], &[])?;
                self.submit.wait()?;
                self.check_unrolled(plan, &layers, kind)?
            }
            None => None,
        };
        self.end_frame(plan, f, unrolled)
    }

    /// Checks `plan` against the uploaded scene, makes its images and decides
    /// its tie-free draws: what a single frame and a sequence frame (all its
    /// plans as one) both do first.
    fn prepare_plan(&mut self, plan: &Plan) -> Result<(), VkError> {
        let meshes = self
            .scene
            .as_ref()
            .ok_or_else(|| VkError::Plan("execute before upload: no scene".into()))?
            .ranges
            .len() as u32;
        validate(plan, meshes)?;
        self.ensure_targets(plan)?;
        self.ties = self.decide_ties(plan);
        Ok(())
    }

    /// What every frame does before recording: checks `plan`, makes its
    /// images, writes the camera (no frame is in flight) and looks up the loop
    /// counts the last frame of `plan` needed.
    fn begin_frame(&mut self, plan: &Plan) -> Result<FrameStart, VkError> {
        let start = Instant::now();
        self.prepare_plan(plan)?;
        let scene = self.scene.as_ref().expect("checked above");
        let cam = scene.cam;
        let openings = self.opening_rects.get(&self.cut_away, scene, &self.desc);
        let exact = Scissors::exact(scene, &self.desc, openings);
        self.camera.write(&cam)?;
        let known = match &self.layers {
            Some((p, n)) if p == plan => Some(n.clone()),
            _ => None,
        };
        let still = self.last_cam == Some(cam);
        self.last_cam = Some(cam);
        Ok(FrameStart {
            start,
            clock: Clock::default(),
            known,
            exact,
            still,
            pipelines_before: (self.pipelines.created, self.pipelines.create_ms),
        })
    }

    /// Finishes a frame begun by [`Self::begin_frame`]: `unrolled` is the
    /// unrolled frame's stats, `None` when it did not run or its loop counts
    /// did not fit (then the frame runs loop by loop now).
    fn end_frame(
        &mut self,
        plan: &Plan,
        mut f: FrameStart,
        unrolled: Option<ExecStats>,
    ) -> Result<ExecStats, VkError> {
        let mut stats = match unrolled {
            Some(s) => s,
            None => {
                self.rects = f.exact;
                let s = self.run_stepwise(plan, &mut f.clock)?;
                self.kept_after_stepwise(plan);
                self.layers = Some((plan.clone(), s.counts.loop_iterations.clone()));
                s
            }
        };
        let clock = f.clock;
        stats.frame_ms = clock
            .first_submit
            .map(|t| t.elapsed().as_secs_f64() * 1e3)
            .unwrap_or(0.0);
        if clock.first_submit.is_some() {
            stats.frame_cpu_ms = crate::vk::cpu_clock::ms_since(clock.first_submit_cpu);
        }
        // Pipelines first needed by this plan were created while recording; their
        // cost (the driver compiling shaders) is reported on its own.
        let (pipelines_before, pipeline_ms_before) = f.pipelines_before;
        stats.pipeline_ms = self.pipelines.create_ms - pipeline_ms_before;
        stats.counts.pipelines_created = (self.pipelines.created - pipelines_before) as u64;
        stats.record_ms = (clock.record_ms - stats.pipeline_ms).max(0.0);
        stats.cpu_ms = f.start.elapsed().as_secs_f64() * 1e3;
        self.last_output = Some(plan.output_ds);
        Ok(stats)
    }

    /// Executes `plan` and reads its images back.
    pub fn frame(&mut self, plan: &Plan) -> Result<Frame, VkError> {
        let stats = self.execute(plan)?;
        let images = self.read_back()?;
        Ok(Frame { images, stats })
    }

    fn recorder(&mut self) -> Recorder<'_> {
        let (rec, _) = self.recorder_and_submitter();
        rec
    }

    /// A recorder on the executor's objects, and the submitter beside it.
    fn recorder_and_submitter(&mut self) -> (Recorder<'_>, &Submitter) {
        let flags = self.flags();
        let snap = self
            .profile
            .vertex_snapping_emulation
            .map(|r| r.ndc_step(self.desc.width, self.desc.height))
            .unwrap_or_default();
        let b = Bindings {
            device: &self.shared.device,
            desc: self.desc,
            pipelines: &mut self.pipelines,
            targets: self.targets.as_ref().expect("targets exist during execute"),
            scene: self.scene.as_ref().expect("scene uploaded before execute"),
            occlusion: self.occlusion.pool,
            timestamps: (self.shared.timestamp_valid_bits > 0).then_some(self.timestamps.pool),
            clears: self.profile.clears,
            pass_timestamps: self.pass_timestamps,
            frame_ts: self.profile.frame_timestamps,
            flags,
            snap,
            normals: self.normals,
            camera_set: self.camera.set,
            ties: &self.ties,
            mesh_rects: self.rects.unions(),
        };
        (Recorder::new(b), &self.submit)
    }

    /// Grows the query pools to what `steps` need per command buffer.
    fn ensure_queries(&mut self, steps: &[(&Step, Group)]) -> Result<(), VkError> {
        let occ = steps
            .iter()
            .filter(|(s, _)| matches!(s, Step::Draw(d) if d.count_samples))
            .count() as u32;
        let ts = steps
            .iter()
            .filter(|(s, _)| matches!(s, Step::Pass(_)))
            .count() as u32
            + 2;
        let replaced = self.occlusion.ensure(occ)? | self.timestamps.ensure(ts)?;
        if replaced {
            self.epoch += 1;
        }
        Ok(())
    }

    /// What the host allocator of the executor's command buffers served so
    /// far (`vk::cmd_arena`).
    pub fn command_arena(&self) -> crate::vk::cmd_arena::ArenaCounts {
        self.submit.arena_counts()
    }
}
