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
//! were recorded with (`Scissors`; see README, "Executor").
//!
//! Modules: `gpu_scene` (vertex buffer, camera state), `camera` (its uniform
//! buffer), `targets` (images and descriptor sets), `record` (steps to commands,
//! barriers from `plan::usage` through `vk::sync`), `state` (dynamic state
//! recorded only where it changes), `stats` (typed statistics), `normals` (the
//! optional normal buffer and the edge pass on it, seed 001 §5), `transparency`
//! (the accumulate pass compositing peeled layers on the GPU, seed 000 §6),
//! `sequence` (several plans, accumulate passes and layer copies in one
//! submission: layered frames), `shadow` (what the shadow pass, `vk::shadow`, reads of an executor).

mod batch;
mod camera;
mod embed;
mod gpu_scene;
mod normals;
mod record;
mod sequence;
mod shadow;
mod state;
mod stats;
mod targets;
mod transparency;

use std::sync::Arc;
use std::time::Instant;

use ash::vk;
use gpu_allocator::MemoryLocation;

pub use super::conv::DepthFormat;
pub use batch::PreparedFrame;
pub(crate) use embed::{Output, Unrolled};
pub(crate) use normals::copy_to_host;
pub use sequence::{PlanCounts, SeqFrame, SeqItem};
pub(crate) use shadow::color_format;
pub use stats::{Counts, ExecStats, PassStats, Recorded};

use super::cpu_clock::CpuInstant;
use super::error::VkError;
use super::instance::{Context, Shared};
use super::memory::Buffer;
use super::pipeline::{pipeline_flags, Pipelines, FLAG_RASTER_DEPTH};
use super::readback::{decode, Raw};
use super::submit::{self, Queries, Submitter};
use super::sync::{self, REST};
use crate::output::Images;
use crate::plan::direct_shade::DirectShades;
use crate::plan::formats::needs_stencil;
use crate::plan::memo::{Memo, PlanIds};
use crate::plan::reach::{self, FrameReach, KeptImages};
use crate::plan::tie_free::{TieBand, TieFree};
use crate::plan::usage::Resource;
use crate::plan::validate::validate;
use crate::plan::{Plan, Scissor, Step};
use crate::scene::{Aabb, Camera, Scene};
use crate::vk::scissor::{bounds_rect, Rect, RectUnions};
use camera::CameraBuffer;
use gpu_scene::{CameraState, GpuScene};
pub(crate) use record::{copy_counts, final_shade, host_barriers, peel_depth, HostShade};
use record::{Bindings, Group, Recorder};
pub use record::{BlockJoin, ClearMode};
use targets::Targets;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExecDesc {
    pub width: u32,
    pub height: u32,
    pub depth_format: DepthFormat,
    /// Reversed depth (near 1, far 0); meant for `D32S8`.
    pub reversed_z: bool,
}

/// A frame's images (read back) and statistics.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub images: Images,
    pub stats: ExecStats,
}

/// What a kept recording was made for.
struct RecordingKey {
    plan: Plan,
    /// The screen rectangle of each mesh its scissors were made from.
    rects: Scissors,
    layers: Vec<u32>,
    epoch: u64,
    /// The tie-free decisions its draws were recorded with.
    ties: TieFree,
    /// What it assumes the outputs hold before it (`plan::reach::holds`).
    assumed: KeptImages,
}

/// Everything the tie-free decisions of a plan depend on
/// ([`Executor::decide_ties`]): the plan, the camera, the scene (`epoch`) and
/// the settings that choose them.
#[derive(Clone, Debug, PartialEq)]
struct TieKey {
    plan: u64,
    camera: Camera,
    epoch: u64,
    subpixel_bits: u32,
    size: (u32, u32),
    reversed_z: bool,
    tie_free: bool,
    fixed_shade: bool,
    zones: bool,
}

/// Everything a recording's clears and copies depend on
/// ([`Executor::recording_reach`]): its steps (a plan unrolled to `layers`),
/// the mesh rectangles of its scissors, what the outputs hold before it, and
/// the settings that shape them.
#[derive(Clone, Debug, PartialEq)]
struct ReachKey {
    plan: u64,
    layers: Vec<u32>,
    rects: Vec<Rect>,
    now: KeptImages,
    normals: bool,
    scissored: bool,
    /// The tie-free decisions its draws are lowered with: a texture only
    /// the lowered draws sampled is written for nobody.
    ties: TieFree,
}

/// A recording's reach (`plan::reach::recording_reach`) and what it assumes
/// the outputs hold before it.
type Reached = (FrameReach, KeptImages);

/// How many results each decision cache keeps, and plan ids the executor
/// remembers: a frame, the bench's moved camera and a layered frame's few
/// plans fit.
const MEMO_CAP: usize = 4;
const PLAN_IDS: usize = 16;

/// The per-mesh screen rectangles a recording's scissors come from: exact for a
/// still camera, grown by [`Scissors::MARGIN`] of the image after a camera move,
/// so that the next moves replay. Scissors only bound work (every plan is
/// correct with any scissor that contains its meshes' projections), so a
/// recording stays valid while each mesh's exact rectangle lies inside its
/// recorded one and no mesh recorded off screen has come on screen.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Scissors {
    pub rects: Vec<Rect>,
    pub grown: bool,
}

impl Scissors {
    /// Margin of grown rectangles, as a fraction of the image's width and height.
    pub const MARGIN: u32 = 8;

    /// Each mesh's exact rectangle under `cam`.
    fn exact(scene: &GpuScene, desc: &ExecDesc) -> Scissors {
        let rects = scene
            .bounds
            .iter()
            .map(|b| {
                bounds_rect(
                    scene.cam.view,
                    scene.cam.proj,
                    scene.camera.near,
                    std::slice::from_ref(b),
                    desc.width,
                    desc.height,
                )
            })
            .collect();
        Scissors {
            rects,
            grown: false,
        }
    }

    /// The pixels grown rectangles gain on each side, across and down.
    fn margins(desc: &ExecDesc) -> (u32, u32) {
        (
            (desc.width / Self::MARGIN).max(1),
            (desc.height / Self::MARGIN).max(1),
        )
    }

    /// `self` grown by 1/MARGIN of the image on every side, within the image.
    fn grown(&self, desc: &ExecDesc) -> Scissors {
        let (mx, my) = Self::margins(desc);
        let rects = self
            .rects
            .iter()
            .map(|r| r.grown(mx, my, desc.width, desc.height))
            .collect();
        Scissors { rects, grown: true }
    }

    /// Whether a recording made with `self` is valid for `exact`.
    fn covers(&self, exact: &Scissors) -> bool {
        self.rects.len() == exact.rects.len()
            && self
                .rects
                .iter()
                .zip(&exact.rects)
                .all(|(r, e)| e.is_empty() || r.contains(e))
    }
}

/// The kept frame recording and what its replays report.
struct Recording {
    key: RecordingKey,
    /// What the outputs hold after it runs.
    after: KeptImages,
    stats: ExecStats,
    queries: Vec<Group>,
    marks: Vec<String>,
}

/// A frame's recording: its stats, the loop group of each occlusion query, the
/// pass at each timestamp, and what it assumes the outputs hold before it and
/// leaves them holding.
type FrameRecording = (ExecStats, Vec<Group>, Vec<String>, (KeptImages, KeptImages));

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
    clears: ClearMode,
    join: BlockJoin,
    /// Timestamps at every pass (per-pass GPU times) or only around the frame.
    pass_timestamps: bool,
    /// Clears reach only what later steps read ([`Executor::set_scissored_clears`]).
    scissored_clears: bool,
    /// Vertex snapping of a coarser device, emulated (tests); `None`: off.
    rounding: Option<super::RoundingEmulation>,
    /// Write the normal buffer with the colour ([`Executor::set_normals`]).
    normals: bool,
    /// Plain depth tests where no tie is possible ([`Executor::set_tie_free`]).
    tie_free: bool,
    /// Depth-equal final shades where no tie is possible
    /// ([`Executor::set_fixed_shade`]).
    fixed_shade: bool,
    /// The shade's tie rule only in tie zones ([`Executor::set_tie_zones`]).
    tie_zones: bool,
    /// One-primitive products shaded in their direct draw
    /// ([`Executor::set_direct_shade`]).
    direct_shade: bool,
    /// The device interpolates depth from unsnapped vertex positions (a CPU
    /// device): only then is the raster depth as exact as the tie rule's
    /// plane depth at the pixel centre ([`Executor::set_fixed_shade`]).
    unsnapped: bool,
    /// The tie-free decisions for the current plan and camera.
    ties: TieFree,
    /// Keep the accumulate pass's images ([`Executor::set_transparency`]).
    transparency: bool,
    /// Stencil-free plans get depth-only images ([`Executor::set_depth_only`]).
    depth_only: bool,
    /// The device can use the set-up's depth-only twin.
    depth_only_usable: bool,
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
}

impl Executor {
    pub fn new(ctx: &Context, desc: &ExecDesc) -> Result<Executor, VkError> {
        let _layer = ctx.shared.layer_use();
        if desc.width == 0 || desc.height == 0 {
            return Err(VkError::Plan("image size must be at least 1x1".into()));
        }
        let shared = ctx.shared.clone();
        if !ctx.depth_format_usable(desc.depth_format.vk()) {
            return Err(VkError::Unsupported(format!(
                "{:?} as a sampled, copyable depth-stencil attachment (try the other --depth-format)",
                desc.depth_format
            )));
        }
        // SAFETY: physical device of this instance; plain query.
        let props = unsafe {
            shared
                .instance
                .get_physical_device_properties(shared.physical)
        };
        let cpu = props.device_type == vk::PhysicalDeviceType::CPU;
        let clears = if cpu {
            ClearMode::Command
        } else {
            ClearMode::LoadOp
        };
        let depth_only_usable = ctx.depth_format_usable(desc.depth_format.vk_for(false));
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
                grown: false,
            },
            recording: None,
            layers: None,
            epoch: 0,
            last_output: None,
            clears,
            join: BlockJoin::Masked,
            pass_timestamps: true,
            scissored_clears: true,
            rounding: None,
            normals: false,
            tie_free: true,
            fixed_shade: true,
            tie_zones: true,
            direct_shade: true,
            // Lavapipe interpolates depth from the unsnapped vertices; hardware
            // GPUs may not (the H200 does not).
            unsnapped: cpu,
            ties: TieFree::none(),
            transparency: false,
            depth_only: depth_only_usable,
            depth_only_usable,
            seq: Default::default(),
            kept: KeptImages::new(),
            kept_unknown: false,
            plan_ids: PlanIds::new(PLAN_IDS),
            tie_memo: Memo::new(MEMO_CAP),
            reach_memo: Memo::new(MEMO_CAP),
        })
    }

    pub fn desc(&self) -> &ExecDesc {
        &self.desc
    }

    /// Uploads all meshes of `scene` (primitives in file order, then surfaces) and
    /// its camera.
    pub fn upload(&mut self, scene: &Scene) -> Result<(), VkError> {
        let _layer = self.shared.layer_use();
        self.scene = Some(GpuScene::new(&self.shared, scene, &self.desc)?);
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

    /// Emulates a coarser device's vertex snapping in every later mesh draw.
    pub fn set_rounding_emulation(&mut self, rounding: Option<super::RoundingEmulation>) {
        self.rounding = rounding;
        self.recording = None;
    }

    /// The push constants' flags: reversed Z, and the subpixel precision the tie
    /// tolerance assumes ([`Self::subpixel_bits`]).
    fn flags(&self) -> u32 {
        let raster = match self.depth_equal_shades() {
            true => FLAG_RASTER_DEPTH,
            false => 0,
        };
        pipeline_flags(self.desc.reversed_z, self.subpixel_bits()) | raster
    }

    /// Whether final shades run depth-equal draws where no tie is possible
    /// ([`Self::set_fixed_shade`]).
    fn depth_equal_shades(&self) -> bool {
        // D24: lavapipe's raster depth, quantized, misses the strict depth
        // bar of `vk_tests` `classic_assembly` (p99 4.3e-6 against 3.8e-6 view
        // units), where the plane depth at the pixel centre meets it.
        let d32 = self.desc.depth_format == DepthFormat::D32S8;
        self.tie_free && self.fixed_shade && self.unsnapped && self.rounding.is_none() && d32
    }

    /// The vertex snapping the tie rule allows for: the device's, or the
    /// emulated device's.
    fn subpixel_bits(&self) -> u32 {
        match self.rounding {
            Some(r) => r.subpixel_bits,
            None => self.shared.limits.sub_pixel_precision_bits,
        }
    }

    /// Whether tolerant parity and peel draws whose meshes cannot tie under the
    /// current camera run as plain depth tests (`plan::tie_free`; the default).
    /// Off: every one runs its tie-rule shader (A/B measurements). Both give the
    /// same images up to crossings of faces within a depth quantum.
    pub fn set_tie_free(&mut self, on: bool) {
        self.tie_free = on;
        self.recording = None;
    }

    /// Whether the final shade's draws of meshes that cannot tie run as plain
    /// depth-`EQUAL` draws (`plan::tie_free`; the default, with
    /// [`Self::set_tie_free`] on). Off: they keep the tie rule (A/B
    /// measurements). Only on a device that does not snap vertices before
    /// interpolating depth (lavapipe; not under the rounding emulation): a
    /// depth-equal shade leaves the raster depth in the depth output, which
    /// carries the snapping error that the tie rule's plane depth removes
    /// (README "The final shade as depth-equal draws").
    pub fn set_fixed_shade(&mut self, on: bool) {
        self.fixed_shade = on;
        self.recording = None;
    }

    /// Whether a final shade's draw of a mesh that can tie runs the tie rule
    /// only inside its on-screen tie zones (`plan::tie_zones`; the default,
    /// with [`Self::set_fixed_shade`] on). Off: over its whole rectangle (A/B
    /// measurements, `examples/tie_ab.rs`).
    pub fn set_tie_zones(&mut self, on: bool) {
        self.tie_zones = on;
        self.recording = None;
    }

    /// Whether a one-primitive product whose final shade draw would run
    /// depth-`EQUAL` everywhere is shaded in its direct draw, that shade draw
    /// dropped (`plan::direct_shade`; the default). Off: drawn depth-only and
    /// shaded again (A/B measurements, `examples/tie_ab.rs`). Frames run
    /// loop by loop keep the old path; frames shaded into an embedding host's
    /// targets draw those products' final shade draws without a check of the
    /// output depth instead (`record::host`).
    pub fn set_direct_shade(&mut self, on: bool) {
        self.direct_shade = on;
        self.recording = None;
    }

    /// The tie-free decisions for `plan` under the scene's current camera:
    /// the kept ones while the plan, camera, scene and settings stay
    /// (`plan::memo`; a replayed frame decides nothing anew).
    fn decide_ties(&mut self, plan: &Plan) -> TieFree {
        let Some(scene) = self.scene.as_ref().filter(|_| self.tie_free) else {
            return TieFree::none();
        };
        let key = TieKey {
            plan: self.plan_ids.id(plan),
            camera: scene.camera,
            epoch: self.epoch,
            subpixel_bits: self.subpixel_bits(),
            size: (self.desc.width, self.desc.height),
            reversed_z: self.desc.reversed_z,
            tie_free: self.tie_free,
            fixed_shade: self.depth_equal_shades(),
            zones: self.tie_zones,
        };
        let (desc, bits) = (self.desc, key.subpixel_bits);
        let (fixed, zones) = (key.fixed_shade, key.zones);
        self.tie_memo
            .get_or_insert_with(key, || {
                tie_decisions(scene, &desc, bits, plan, fixed, zones)
            })
            .clone()
    }

    fn ensure_targets(&mut self, plan: &Plan) -> Result<(), VkError> {
        let n_ds = plan.depth_stencils.max(1) as usize;
        let n_tex = plan.textures as usize;
        let (normals, transparency) = (self.normals, self.transparency);
        let ds_format = self.ds_format(plan);
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
    /// use it ([`Executor::set_depth_only`]).
    fn ds_format(&self, plan: &Plan) -> vk::Format {
        let stencil = !self.depth_only || needs_stencil(plan);
        self.desc.depth_format.vk_for(stencil)
    }

    /// Depth images without a stencil aspect for plans that use no stencil
    /// (the default where the device supports `D32_SFLOAT`): half the bytes
    /// to clear and test on lavapipe, the same depths. Off: every plan gets
    /// the set-up's depth-stencil format (the A/B of README "Per-pixel cost").
    pub fn set_depth_only(&mut self, on: bool) {
        self.depth_only = on && self.depth_only_usable;
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
        let exact = Scissors::exact(scene, &self.desc);
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

    /// How clears are recorded (default: clear commands on CPU devices, load ops
    /// elsewhere). Both give the same images.
    pub fn set_clear_mode(&mut self, clears: ClearMode) {
        self.clears = clears;
        self.recording = None;
    }

    /// Which blocks a draw that writes no colour may share (default:
    /// [`BlockJoin::Masked`]; on lavapipe neither wins everywhere, README
    /// "One block for the depth-only draws and the shade"). Both give the
    /// same images.
    pub fn set_block_join(&mut self, join: BlockJoin) {
        self.join = join;
        self.recording = None;
    }

    /// Whether clears reach only the part of an image later steps read (the
    /// default) or the whole image. Both give the same images.
    pub fn set_scissored_clears(&mut self, on: bool) {
        self.scissored_clears = on;
        self.recording = None;
    }

    /// Per-pass GPU times (a timestamp at every `Step::Pass`; the default) or
    /// only the frame's (two timestamps, so that lavapipe's scenes are not cut
    /// at pass boundaries).
    pub fn set_pass_timestamps(&mut self, on: bool) {
        self.pass_timestamps = on;
        self.recording = None;
    }

    /// Drops the kept recording: the next frame records again (what a new plan or
    /// camera costs; the bench measures it with this).
    pub fn forget_recording(&mut self) {
        self.recording = None;
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
            .rounding
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
            clears: self.clears,
            join: self.join,
            pass_timestamps: self.pass_timestamps,
            flags,
            snap,
            normals: self.normals,
            camera_set: self.camera.set,
            ties: &self.ties,
            mesh_rects: RectUnions::new(&self.rects.rects),
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

    /// Makes the frame command buffer hold `plan` with its loops unrolled to
    /// `layers` for the current camera: the kept recording when it fits (see
    /// "Executor" in the README), otherwise a new one. Returns how it came to be.
    fn ready_unrolled(
        &mut self,
        plan: &Plan,
        layers: &[u32],
        f: &mut FrameStart,
    ) -> Result<Recorded, VkError> {
        let (exact, still) = (&f.exact, f.still);
        // A recording of this plan, objects and loop counts, made for some camera.
        let same = self
            .recording
            .as_ref()
            .filter(|r| r.key.epoch == self.epoch && r.key.layers == layers && r.key.plan == *plan);
        let kind = match same {
            // Scissors grown for a moving camera are made exact once it stops.
            Some(r)
                if r.key.rects.covers(exact)
                    && r.key.ties.serves(&self.ties)
                    && reach::holds(&self.kept, &r.key.assumed)
                    && !(still && r.key.rects.grown) =>
            {
                if r.key.rects.rects == exact.rects || still {
                    Recorded::Replayed
                } else {
                    Recorded::ReplayedMovedCamera
                }
            }
            Some(_) => Recorded::Camera,
            None => Recorded::New,
        };
        if matches!(kind, Recorded::Camera | Recorded::New) {
            self.rects = if kind == Recorded::Camera && !still {
                // The tie zones' rectangles grow with the scissors.
                let (mx, my) = Scissors::margins(&self.desc);
                self.ties = self.ties.grown(mx, my, self.desc.width, self.desc.height);
                exact.grown(&self.desc)
            } else {
                exact.clone()
            };
            self.recording = None;
            let now = self.kept.clone();
            f.clock.record_ms += self.record_kept(plan, layers, &now)?;
        }
        Ok(kind)
    }

    /// The stats of the unrolled frame just executed, from the GPU's counts:
    /// `None` when they show that `layers` no longer fit.
    fn check_unrolled(
        &mut self,
        plan: &Plan,
        layers: &[u32],
        kind: Recorded,
    ) -> Result<Option<ExecStats>, VkError> {
        let rec = self.recording.as_ref().expect("recorded before submission");
        // The frame ran: the outputs hold what it leaves, whatever its counts.
        if !self.kept_unknown {
            self.kept = rec.after.clone();
        }
        let device = &self.shared.device;
        let samples = submit::query_results(device, self.occlusion.pool, rec.queries.len())?;
        if !layers_fit(plan, layers, &rec.queries, &samples) {
            self.layers = None;
            return Ok(None);
        }
        let mut stats = rec.stats.clone();
        stats.recorded = kind;
        stats.counts.loop_iterations = layers.to_vec();
        stats.counts.samples_counted = samples.iter().sum();
        // Queries are in recording order: those after the last loop head's.
        let after = rec
            .queries
            .iter()
            .rposition(Option::is_some)
            .map_or(0, |i| i + 1);
        stats.counts.final_samples = samples[after..].iter().sum();
        let marks = rec.marks.clone();
        self.add_gpu_times(&mut stats, &marks)?;
        Ok(Some(stats))
    }

    /// Records `plan` unrolled to `layers` into the frame command buffer and keeps
    /// the recording for replays (scissors from `self.rects`): the calling
    /// thread's CPU ms, from resetting the buffer to ending it.
    fn record_kept(
        &mut self,
        plan: &Plan,
        layers: &[u32],
        now: &KeptImages,
    ) -> Result<f64, VkError> {
        let t = CpuInstant::now();
        let cmd = self.frame_cmd;
        self.submit.begin(cmd, false)?;
        let now = self.kept_now(now);
        let (mut stats, queries, marks, (assumed, after)) =
            self.record_frame_from(cmd, plan, layers, None, &now)?;
        stats.counts.submits = 1;
        self.submit.end(cmd)?;
        let ms = t.elapsed_ms();
        // The kept key when it is this one (a plan recorded anew): no clone.
        let key = match self.recording.take() {
            Some(r)
                if r.key.epoch == self.epoch
                    && r.key.layers == layers
                    && r.key.rects == self.rects
                    && r.key.ties == self.ties
                    && r.key.assumed == assumed
                    && r.key.plan == *plan =>
            {
                r.key
            }
            _ => RecordingKey {
                plan: plan.clone(),
                rects: self.rects.clone(),
                layers: layers.to_vec(),
                epoch: self.epoch,
                ties: self.ties.clone(),
                assumed,
            },
        };
        self.recording = Some(Recording {
            key,
            after,
            stats,
            queries,
            marks,
        });
        Ok(ms)
    }

    /// What the host allocator of the executor's command buffers served so
    /// far (`vk::cmd_arena`).
    pub fn command_arena(&self) -> crate::vk::cmd_arena::ArenaCounts {
        self.submit.arena_counts()
    }

    /// Records the kept frame of `plan` anew `reps` times without submitting it:
    /// what recording this plan costs the CPU (a new plan of its size, issue 9
    /// §3), in the calling thread's CPU ms per recording, free of the GPU's
    /// work and of waiting for a core. The recording stays kept (the same
    /// commands). Each recording works out what its clears and copies reach
    /// anew (the cache of those regions is dropped first, as for a new plan).
    /// `None` when no recording of `plan` is kept: execute it until a frame
    /// replays first.
    pub fn time_recording(&mut self, plan: &Plan, reps: u32) -> Result<Option<Vec<f64>>, VkError> {
        self.time_recordings(plan, reps, true)
    }

    /// [`Self::time_recording`] with the regions of its clears and copies
    /// taken from the cache (`plan::memo`): what recording the plan again
    /// costs when only device objects changed (an interference frame's
    /// uploads, a replaced image).
    pub fn time_recording_cached(
        &mut self,
        plan: &Plan,
        reps: u32,
    ) -> Result<Option<Vec<f64>>, VkError> {
        self.time_recordings(plan, reps, false)
    }

    /// `reps` timed recordings of the kept frame of `plan`, each working out
    /// its reach anew when `fresh`.
    fn time_recordings(
        &mut self,
        plan: &Plan,
        reps: u32,
        fresh: bool,
    ) -> Result<Option<Vec<f64>>, VkError> {
        let _layer = self.shared.layer_use();
        let layers = match &self.recording {
            Some(r) if r.key.epoch == self.epoch && r.key.plan == *plan => r.key.layers.clone(),
            _ => return Ok(None),
        };
        // The scissors and tie decisions it was made with, so that the
        // recording stays what it was.
        let key = &self.recording.as_ref().expect("matched above").key;
        (self.rects, self.ties) = (key.rects.clone(), key.ties.clone());
        // Made for what it assumed, a recording assumes the same.
        let assumed = key.assumed.clone();
        (0..reps)
            .map(|_| {
                if fresh {
                    self.reach_memo.clear();
                }
                self.record_kept(plan, &layers, &assumed)
            })
            .collect::<Result<Vec<f64>, VkError>>()
            .map(Some)
    }

    /// Records `plan` with its loops unrolled to `layers` into `cmd` (begun by the
    /// caller): the stats, the loop group of each occlusion query, the pass at
    /// each timestamp. Every image starts and ends in `REST`. With `host`, the
    /// plan's last `host.1` steps (its final shade, `record::final_shade`) are
    /// drawn into an embedding host's attachments instead (`record::host`).
    /// Someone else submits it: from now on what the outputs hold is unknown
    /// here, and their clears reach whole images.
    fn record_frame(
        &mut self,
        cmd: vk::CommandBuffer,
        plan: &Plan,
        layers: &[u32],
        host: Option<(&HostShade, usize)>,
    ) -> Result<(ExecStats, Vec<Group>, Vec<String>), VkError> {
        self.kept_unknown = true;
        self.kept.clear();
        let (stats, groups, marks, _) =
            self.record_frame_from(cmd, plan, layers, host, &KeptImages::new())?;
        Ok((stats, groups, marks))
    }

    /// [`Self::record_frame`] for outputs that hold `now` before it: also
    /// what the recording assumes they hold and what they hold after it
    /// (`Executor::recording_reach`).
    fn record_frame_from(
        &mut self,
        cmd: vk::CommandBuffer,
        plan: &Plan,
        layers: &[u32],
        host: Option<(&HostShade, usize)>,
        now: &KeptImages,
    ) -> Result<FrameRecording, VkError> {
        let flat = unroll(plan, layers);
        self.ensure_queries(&flat)?;
        let steps: Vec<&Step> = flat.iter().map(|(s, _)| *s).collect();
        // The host's shade reads the body's last depth copy: its draws count.
        let reached = self.recording_reach(plan, layers, &steps, now);
        let (occ_cap, ts_cap) = (self.occlusion.cap, self.timestamps.cap);
        let direct_shade = self.direct_shade;
        let mut rec = self.recorder();
        let body = steps.len() - host.map_or(0, |h| h.1);
        rec.use_reach(&reached.0, plan.output_ds);
        // The host's shade draws decide what the last copy covers, as the
        // standalone shade's do.
        rec.plan_shades(&steps);
        if direct_shade && host.is_none() {
            rec.plan_direct_shades(&steps, plan.output_ds);
        }
        rec.plan_blocks(&steps[..body]);
        let shade = &steps[body..];
        rec.begin(cmd, occ_cap, ts_cap);
        for (s, g) in flat.iter().take(body) {
            rec.group = *g;
            rec.step(s)?;
        }
        match host {
            Some((h, _)) => {
                // The same products as the standalone frame's direct shades.
                let direct = match direct_shade {
                    true => rec.direct_shades(&steps, plan.output_ds),
                    false => DirectShades::none(),
                };
                rec.host_shade(h, shade, &direct)?
            }
            None => rec.finish_frame(plan.output_ds),
        }
        rec.end();
        let kept = (reached.1.clone(), reached.0.kept.clone());
        Ok((rec.stats, rec.queries, rec.marks, kept))
    }

    /// What the clears and copies of a recording of `steps` (`plan` unrolled
    /// to `layers`) reach with the current scissors, for outputs that hold
    /// `now` before it, and what it assumes they hold: the kept result while
    /// its inputs stay (`plan::memo`). Without scissored clears, clears and
    /// copies reach whole images.
    fn recording_reach(
        &mut self,
        plan: &Plan,
        layers: &[u32],
        steps: &[&Step],
        now: &KeptImages,
    ) -> Arc<Reached> {
        let key = ReachKey {
            plan: self.plan_ids.id(plan),
            layers: layers.to_vec(),
            rects: self.rects.rects.clone(),
            now: now.clone(),
            normals: self.normals,
            scissored: self.scissored_clears,
            ties: self.ties.clone(),
        };
        let (w, h) = (self.desc.width, self.desc.height);
        let outputs = reach::outputs(plan.output_ds, self.normals);
        let images = self.reach_images(&outputs);
        let (rects, scissored, ties) = (&self.rects.rects, self.scissored_clears, &self.ties);
        let reached = self.reach_memo.get_or_insert_with(key, || {
            let unions = RectUnions::new(rects);
            let scissor = |s: &Scissor| unions.scissor(s, w, h);
            Arc::new(match scissored {
                true => {
                    // What the draws read as recorded: a texture only tie-free
                    // draws sampled is read by nobody.
                    let lowered: Vec<Step> = steps.iter().map(|s| ties.lowered(s)).collect();
                    let lowered: Vec<&Step> = lowered.iter().collect();
                    reach::recording_reach(&lowered, scissor, images, now)
                }
                false => {
                    let kept = reach::kept_after(steps, scissor, images, now);
                    let whole = FrameReach {
                        clears: Vec::new(),
                        copies: Vec::new(),
                        texture_writes: Vec::new(),
                        kept,
                    };
                    (whole, KeptImages::new())
                }
            })
        });
        reached.clone()
    }

    /// What a frame recorded now may assume the outputs hold: `kept`, or
    /// nothing once an embedding records frames.
    fn kept_now(&self, kept: &KeptImages) -> KeptImages {
        match self.kept_unknown {
            true => KeptImages::new(),
            false => kept.clone(),
        }
    }

    /// What the outputs hold after a loop-by-loop frame of `plan` (its clears
    /// reach whole images): each loop as its head, tail and head again
    /// (`reach::kept_after`).
    fn kept_after_stepwise(&mut self, plan: &Plan) {
        if self.kept_unknown {
            return;
        }
        let steps: Vec<&Step> = plan
            .steps
            .iter()
            .flat_map(|s| match s {
                Step::Loop(l) => l.head.iter().chain(&l.tail).chain(&l.head).collect(),
                s => vec![s],
            })
            .collect();
        let unions = RectUnions::new(&self.rects.rects);
        let (w, h) = (self.desc.width, self.desc.height);
        let outputs = reach::outputs(plan.output_ds, self.normals);
        let images = self.reach_images(&outputs);
        self.kept = reach::kept_after(&steps, |s| unions.scissor(s, w, h), images, &self.kept);
    }

    /// The images `plan::reach` plans a frame on: `outputs`, read whole
    /// after it, the normal buffer with the colour when on, the image size.
    fn reach_images<'a>(&self, outputs: &'a [Resource]) -> reach::Images<'a> {
        reach::Images {
            outputs,
            normals: self.normals,
            size: (self.desc.width, self.desc.height),
        }
    }

    /// Adds the GPU times between the timestamps of the last command buffer.
    fn add_gpu_times(&self, stats: &mut ExecStats, marks: &[String]) -> Result<(), VkError> {
        if self.shared.timestamp_valid_bits == 0 || marks.len() < 2 {
            return Ok(());
        }
        let ts = submit::query_results(&self.shared.device, self.timestamps.pool, marks.len())?;
        let period = self.shared.limits.timestamp_period as f64;
        for i in 0..marks.len() - 1 {
            let ms = ts[i + 1].saturating_sub(ts[i]) as f64 * period * 1e-6;
            stats.gpu_ms += ms;
            if let Some(p) = stats.pass_entry(&marks[i]) {
                p.gpu_ms += ms;
            }
        }
        Ok(())
    }

    /// The frame with one submission per straight run of steps and per loop head
    /// and tail, waiting for each head's sample count on the CPU.
    fn run_stepwise(&mut self, plan: &Plan, clock: &mut Clock) -> Result<ExecStats, VkError> {
        let all: Vec<(&Step, Group)> = plan
            .steps
            .iter()
            .flat_map(|s| match s {
                Step::Loop(l) => l.head.iter().chain(&l.tail).collect::<Vec<_>>(),
                s => vec![s],
            })
            .map(|s| (s, None))
            .collect();
        self.ensure_queries(&all)?;
        let (occ_cap, ts_cap) = (self.occlusion.cap, self.timestamps.cap);
        let cmd = self.submit.cmd;
        let mut gpu = ExecStats::default();
        let mut loops = Vec::new();
        let mut samples_counted = 0;
        // The recorder borrows the executor's resources; submission and queries
        // are read through these copies of the handles.
        let shared = self.shared.clone();
        let (occ_pool, ts_pool) = (self.occlusion.pool, self.timestamps.pool);
        let mut run = |rec: &mut Recorder<'_>,
                       steps: &[Step],
                       finish: Option<u8>,
                       sub: &Submitter|
         -> Result<u64, VkError> {
            let t = CpuInstant::now();
            sub.begin(cmd, true)?;
            let listed: Vec<&Step> = steps.iter().collect();
            rec.plan_shades(&listed);
            rec.plan_blocks(&listed);
            rec.begin(cmd, occ_cap, ts_cap);
            for s in steps {
                rec.step(s)?;
            }
            if let Some(o) = finish {
                rec.finish_frame(o);
            }
            rec.end();
            sub.end(cmd)?;
            clock.record_ms += t.elapsed_ms();
            clock.submitting();
            sub.submit(cmd, &[], &[])?;
            sub.wait()?;
            rec.stats.counts.submits += 1;
            let samples: u64 = submit::query_results(&shared.device, occ_pool, rec.queries.len())?
                .iter()
                .sum();
            if shared.timestamp_valid_bits > 0 && rec.marks.len() >= 2 {
                let ts = submit::query_results(&shared.device, ts_pool, rec.marks.len())?;
                let period = shared.limits.timestamp_period as f64;
                for i in 0..rec.marks.len() - 1 {
                    let ms = ts[i + 1].saturating_sub(ts[i]) as f64 * period * 1e-6;
                    gpu.gpu_ms += ms;
                    if let Some(p) = gpu.pass_entry(&rec.marks[i]) {
                        p.gpu_ms += ms;
                    }
                }
            }
            Ok(samples)
        };
        let (mut rec, submit) = self.recorder_and_submitter();
        let mut pending: Vec<Step> = Vec::new();
        for step in &plan.steps {
            let Step::Loop(l) = step else {
                pending.push(step.clone());
                continue;
            };
            if !pending.is_empty() {
                samples_counted += run(&mut rec, &pending, None, submit)?;
                pending.clear();
            }
            let mut iterations = 0;
            while iterations < l.max_iterations {
                iterations += 1;
                let samples = run(&mut rec, &l.head, None, submit)?;
                samples_counted += samples;
                if samples == 0 || iterations >= l.max_iterations {
                    break;
                }
                samples_counted += run(&mut rec, &l.tail, None, submit)?;
            }
            loops.push(iterations);
        }
        let final_samples = run(&mut rec, &pending, Some(plan.output_ds), submit)?;
        samples_counted += final_samples;
        let mut stats = rec.stats;
        stats.recorded = Recorded::Stepwise;
        // Per-pass draws come from the recorder, GPU times from the timestamps.
        for p in &gpu.per_pass {
            if let Some(e) = stats.pass_entry(&p.name) {
                e.gpu_ms += p.gpu_ms;
            }
        }
        stats.gpu_ms = gpu.gpu_ms;
        stats.counts.loop_iterations = loops;
        stats.counts.samples_counted = samples_counted;
        stats.counts.final_samples = final_samples;
        Ok(stats)
    }

    /// Copies the last frame's colour, primitive ids and output depth to the CPU.
    pub fn read_back(&mut self) -> Result<Images, VkError> {
        let _layer = self.shared.layer_use();
        let output = self
            .last_output
            .ok_or_else(|| VkError::Plan("read_back before execute: no frame".into()))?;
        let (w, h) = (self.desc.width, self.desc.height);
        let plane = w as u64 * h as u64 * 4;
        if self.readback.as_ref().map(|b| b.size) != Some(plane * 3) {
            self.readback = None;
            self.readback = Some(Buffer::new(
                &self.shared,
                "readback",
                plane * 3,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?);
        }
        let device = &self.shared.device;
        let cmd = self.submit.cmd;
        let buffer = self.readback.as_ref().map(|b| b.raw).unwrap_or_default();
        self.submit.begin(cmd, true)?;
        let t = self.targets.as_ref().expect("a frame was executed");
        let copies = [
            (&t.color, vk::ImageAspectFlags::COLOR, 0),
            (&t.prim, vk::ImageAspectFlags::COLOR, plane),
            (
                &t.ds[output as usize],
                vk::ImageAspectFlags::DEPTH,
                plane * 2,
            ),
        ];
        // Frames leave every image in `REST`, a copy source.
        let layout = sync::access(REST).layout;
        for (img, aspect, offset) in copies {
            let region = whole_image_region(aspect, offset, w, h);
            // SAFETY: outside rendering; the image allows transfer src and rests in
            // `layout`; the region fits the buffer.
            unsafe { device.cmd_copy_image_to_buffer(cmd, img.raw, layout, buffer, &[region]) };
        }
        submit::transfer_to_host_barrier(device, cmd);
        self.submit.finish(cmd)?;
        let bytes = self
            .readback
            .as_ref()
            .map(|b| b.mapped())
            .transpose()?
            .unwrap_or(&[]);
        let scene = self.scene.as_ref().expect("scene uploaded");
        let plane = plane as usize;
        Ok(decode(
            Raw {
                width: w,
                height: h,
                color: &bytes[..plane],
                prim: &bytes[plane..2 * plane],
                depth: &bytes[2 * plane..3 * plane],
            },
            self.desc.depth_format,
            &scene.camera,
            gpu_scene::convention(&self.desc),
            scene.background,
        ))
    }
}

/// `plan`'s tie-free decisions on `scene` under its camera (`plan::tie_free`),
/// for a device snapping vertices to `subpixel_bits`; every final shade keeps
/// the tie rule unless `fixed_shade`.
fn tie_decisions(
    scene: &GpuScene,
    desc: &ExecDesc,
    subpixel_bits: u32,
    plan: &Plan,
    fixed_shade: bool,
    zones: bool,
) -> TieFree {
    let bounds = scene
        .bounds
        .iter()
        .fold(crate::geom::bounds(&[]), |a, b| Aabb {
            min: a.min.min(b.min),
            max: a.max.max(b.max),
        });
    let band = TieBand::new(
        &scene.camera,
        desc.width,
        desc.height,
        subpixel_bits,
        desc.reversed_z,
        &bounds,
    );
    let (w, h) = (desc.width, desc.height);
    let (view, proj, near) = (scene.cam.view, scene.cam.proj, scene.camera.near);
    let project = |b: &Aabb| bounds_rect(view, proj, near, std::slice::from_ref(b), w, h);
    let ties = TieFree::new(&scene.ties, &scene.shade_ties, &band, plan, &project);
    match (fixed_shade, zones) {
        (true, true) => ties,
        (true, false) => ties.without_zones(),
        (false, _) => ties.keep_shade_rule(),
    }
}

/// A copy of a whole `w × h` image aspect to `offset` of a tightly packed buffer.
pub(super) fn whole_image_region(
    aspect: vk::ImageAspectFlags,
    offset: u64,
    w: u32,
    h: u32,
) -> vk::BufferImageCopy {
    vk::BufferImageCopy {
        buffer_offset: offset,
        buffer_row_length: 0,
        buffer_image_height: 0,
        image_subresource: vk::ImageSubresourceLayers {
            aspect_mask: aspect,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        },
        image_offset: vk::Offset3D::default(),
        image_extent: vk::Extent3D {
            width: w,
            height: h,
            depth: 1,
        },
    }
}

/// Whether a frame unrolled to `layers` was right, by the GPU's occlusion
/// `samples` (tagged by `groups`): every head but the last of a loop passed
/// samples, the last none (or the loop hit its bound).
fn layers_fit(plan: &Plan, layers: &[u32], groups: &[Group], samples: &[u64]) -> bool {
    let mut per_head: Vec<Vec<u64>> = layers.iter().map(|&n| vec![0u64; n as usize]).collect();
    for (g, s) in groups.iter().zip(samples) {
        if let Some((l, k)) = g {
            per_head[*l][*k as usize] += s;
        }
    }
    let loops = plan.steps.iter().filter_map(|s| match s {
        Step::Loop(l) => Some(l.max_iterations),
        _ => None,
    });
    per_head
        .iter()
        .zip(loops)
        .all(|(heads, max)| match heads.split_last() {
            None => max == 0,
            Some((&last, before)) => {
                before.iter().all(|&s| s > 0) && (last == 0 || heads.len() as u32 >= max)
            }
        })
}

/// `plan`'s steps with each loop `i` unrolled to `layers[i]` head executions (the
/// last without its tail), head steps tagged with their loop and iteration.
fn unroll<'p>(plan: &'p Plan, layers: &[u32]) -> Vec<(&'p Step, Group)> {
    let mut loops = layers.iter();
    let len = plan.steps.iter().map(|s| match s {
        Step::Loop(l) => {
            let n = *loops.next().expect("a count per loop") as usize;
            n * l.head.len() + n.saturating_sub(1) * l.tail.len()
        }
        _ => 1,
    });
    let mut out = Vec::with_capacity(len.sum());
    let mut li = 0;
    for s in &plan.steps {
        let Step::Loop(l) = s else {
            out.push((s, None));
            continue;
        };
        let n = layers[li];
        for k in 0..n {
            out.extend(l.head.iter().map(|h| (h, Some((li, k)))));
            if k + 1 < n {
                out.extend(l.tail.iter().map(|t| (t, None)));
            }
        }
        li += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Loop;

    #[test]
    fn unroll_runs_every_head_and_all_tails_but_the_last() {
        let plan = Plan {
            algo: "t".into(),
            depth_stencils: 1,
            textures: 0,
            stencil_bits: 0,
            output_ds: 0,
            steps: vec![
                Step::Pass("a".into()),
                Step::Loop(Loop {
                    head: vec![Step::Pass("h".into())],
                    tail: vec![Step::Pass("t".into())],
                    max_iterations: 9,
                }),
                Step::Pass("b".into()),
            ],
        };
        let names: Vec<(String, Group)> = unroll(&plan, &[3])
            .into_iter()
            .map(|(s, g)| match s {
                Step::Pass(n) => (n.clone(), g),
                _ => unreachable!(),
            })
            .collect();
        let h = |k| ("h".to_string(), Some((0, k)));
        let t = ("t".to_string(), None);
        assert_eq!(
            names,
            vec![
                ("a".to_string(), None),
                h(0),
                t.clone(),
                h(1),
                t,
                h(2),
                ("b".to_string(), None)
            ]
        );
    }
}
