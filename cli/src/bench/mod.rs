//! The benchmark harness: algorithms × scenes × sizes × depth set-ups, with
//! warm-up and N timed frames (median and spread of GPU time from timestamp
//! queries, CPU time per frame), the plans' deterministic counts, and each image's
//! error against the exact reference. Shared by `peeltrim bench` and
//! `benches/csg_bench.rs` so both measure the same thing.
//!
//! Speed is reported against error because either alone misleads: an algorithm
//! can be fast because it draws the wrong thing.
#![deny(unsafe_code)]

pub mod checks;
pub mod embedded;
pub mod estimate;
pub mod families;
pub mod floor;
pub mod layer_modes;
pub mod modes;
pub mod opencsg;
pub mod plot;
pub mod report;
pub mod rounds;
pub mod scaling;

use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use crate::output::Images;
use crate::render::{DepthSetup, FrameStats, GpuRenderer};
use peeltrim::plan::{self, Algo, Prepared};
use peeltrim::scene::{self, LoadOptions, Scene};
use peeltrim::vk::DeviceChoice;
use peeltrim_reference::compare::{compare, compare_samples, CompareReport, SampleReport};

/// What to run.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    pub algos: Vec<Algo>,
    pub sizes: Vec<(u32, u32)>,
    pub depth_setups: Vec<DepthSetup>,
    /// Fall back to D24S8 where the device cannot use a set-up's D32S8 (the
    /// default set-up; not when one was asked for by name), as `render` does.
    pub depth_fallback: bool,
    pub frames: u32,
    pub warmup: u32,
    /// A run whose warm-up frame takes longer than this (ms, wall clock) is
    /// timed on that one frame only, so scaling families reach large n.
    pub budget_ms: f64,
    /// A run whose frame is estimated from its plan ([`estimate`]) to take
    /// longer than this many seconds is skipped (and reported so); 0 runs all.
    pub max_est_s: f64,
    pub device: DeviceChoice,
    pub validation: bool,
    /// Algorithm options (`--trickle-eps`, `--max-products`).
    pub build: plan::BuildOptions,
    pub out: PathBuf,
    /// Write each run's images under `out/images/<scene>/<algo>-<depth>/`.
    pub save_images: bool,
    pub progress: bool,
    /// `--baseline opencsg`: also render each scene with OpenCSG (a separate
    /// program, see [`opencsg`]).
    pub baseline: Option<opencsg::OpenCsgBaseline>,
    /// `--embedded`: also time each GPU run through the embedding path
    /// ([`embedded`]).
    pub embedded: bool,
    /// `--samples`: samples per pixel of every frame (else each scene's own).
    pub samples: Option<u32>,
}

/// One benchmark run: one scene, size, algorithm and depth set-up.
#[derive(Clone, Debug, Serialize)]
pub struct Record {
    pub scene: String,
    pub family: Option<String>,
    pub n: Option<u32>,
    pub prims: usize,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel (`--samples`).
    pub samples: u32,
    pub algo: String,
    pub depth_setup: String,
    /// Why the requested set-up was replaced by D24S8, if it was.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub depth_setup_fallback: Option<String>,
    pub device: String,
    pub frames: u32,
    pub gpu_ms_median: f64,
    pub gpu_ms_min: f64,
    pub gpu_ms_max: f64,
    /// Interquartile range of the GPU time.
    pub gpu_ms_iqr: f64,
    pub cpu_ms_median: f64,
    pub cpu_ms_iqr: f64,
    /// Wall time from a frame's first submission to GPU idle (images left on the GPU).
    pub frame_ms_median: f64,
    pub frame_ms_iqr: f64,
    /// The process's CPU time over a frame, every thread (`ExecStats::frame_cpu_ms`:
    /// on lavapipe the rasterizer's work, steady on a loaded machine).
    pub frame_cpu_ms_median: f64,
    /// CPU time recording command buffers (0 when a recording is replayed).
    pub record_ms_median: f64,
    /// CPU time of the calling thread recording the frame anew (what a new plan
    /// costs), without submitting it: the median of [`RERECORD_REPS`]
    /// recordings.
    pub rerecord_ms: f64,
    /// `rerecord_ms` per executed draw, in microseconds.
    pub rerecord_us_per_draw: f64,
    /// The same with the executor's cached decisions (only device objects
    /// changed: `Executor::time_recording_cached`), µs per draw.
    pub rerecord_cached_us_per_draw: f64,
    /// CPU time recording the frame after the camera orbits by
    /// [`CAMERA_NUDGE_DEG`] in two half steps, of the second step (0: replayed,
    /// only the camera's buffer written).
    pub camera_move_record_ms: f64,
    /// How that frame came to be.
    pub camera_move: Option<peeltrim::vk::Recorded>,
    /// The overhead check of the timed frames.
    pub overhead: Option<checks::Overhead>,
    /// For a scaling family: the fit of this algorithm's `frame_ms` over the
    /// family's sizes.
    pub scaling: Option<scaling::ScalingFit>,
    /// Deterministic counts of the last frame (identical across frames and runs).
    pub counts: Option<RunCounts>,
    /// Per-pass GPU time of one frame with a timestamp at every pass.
    pub per_pass: Option<Vec<peeltrim::vk::PassStats>>,
    /// Error against the reference (the `compare` report).
    pub error: Option<CompareReport>,
    /// With samples above 1: the coverage fractions and resolved colours
    /// against the reference's (`compare_samples`).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub coverage: Option<SampleReport>,
    /// Set when the run could not be made (e.g. too many products); other
    /// figures are then zero.
    pub failure: Option<String>,
    /// The plan's estimated frame ([`estimate`]), made before running it.
    pub estimate: Option<estimate::FrameEstimate>,
    /// Set when the run was skipped for its estimate (over `--max-est-s`): why,
    /// with the estimate; other figures are then zero. Not a failure.
    pub skipped: Option<String>,
    /// With `--embedded`: the same frames through the embedding path.
    pub embedded: Option<embedded::EmbeddedTimes>,
    /// With a `[light]`: the light map's and the shadow test's times.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shadow: Option<modes::ShadowBench>,
    /// With `interference = true` (CST variants): the pair frames' time.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interference: Option<modes::InterferenceBench>,
    /// How the timed frames were ordered against the scene's other runs.
    pub timing: rounds::Timing,
    /// A digest of the plan's steps: runs with equal digests ran the same plan
    /// (CST-G where its counter pays for no group is CST-I's plan).
    pub plan_digest: String,
    /// Whether `--algo auto` picks this algorithm for this scene and size.
    pub auto_pick: bool,
    /// `--algo auto`'s estimate of this algorithm's frame (ms), for a candidate.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto_estimate_ms: Option<f64>,
    /// The rasterization floor of the same scene, size and depth set-up
    /// ([`floor`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub floor: Option<floor::Floor>,
}

impl Record {
    /// A record of no run: the given algorithm and depth set-up, every figure
    /// zero or absent.
    pub fn blank(algo: &str, depth: &str) -> Record {
        Record {
            scene: String::new(),
            family: None,
            n: None,
            prims: 0,
            width: 0,
            height: 0,
            samples: 1,
            algo: algo.to_string(),
            depth_setup: depth.to_string(),
            depth_setup_fallback: None,
            device: String::new(),
            frames: 0,
            gpu_ms_median: 0.0,
            gpu_ms_min: 0.0,
            gpu_ms_max: 0.0,
            gpu_ms_iqr: 0.0,
            cpu_ms_median: 0.0,
            cpu_ms_iqr: 0.0,
            frame_ms_median: 0.0,
            frame_ms_iqr: 0.0,
            frame_cpu_ms_median: 0.0,
            record_ms_median: 0.0,
            rerecord_ms: 0.0,
            rerecord_us_per_draw: 0.0,
            rerecord_cached_us_per_draw: 0.0,
            camera_move_record_ms: 0.0,
            camera_move: None,
            overhead: None,
            scaling: None,
            counts: None,
            per_pass: None,
            error: None,
            coverage: None,
            failure: None,
            estimate: None,
            skipped: None,
            embedded: None,
            shadow: None,
            interference: None,
            timing: rounds::Timing::Alone,
            plan_digest: String::new(),
            auto_pick: false,
            auto_estimate_ms: None,
            floor: None,
        }
    }

    /// Whether the run was made: neither failed nor skipped for its estimate.
    pub fn ran(&self) -> bool {
        self.failure.is_none() && self.skipped.is_none()
    }
}

#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// The scene's error names its file.
    #[error("{source}")]
    Scene {
        path: PathBuf,
        source: scene::SceneError,
    },
    #[error("writing {path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{0}")]
    Other(String),
}

/// A scene to benchmark: a file, or one generated by a scaling family.
#[derive(Clone, Debug)]
pub struct BenchScene {
    pub path: PathBuf,
    pub family: Option<String>,
    pub n: Option<u32>,
}

pub(crate) fn median_iqr(v: &mut [f64]) -> (f64, f64, f64, f64) {
    if v.is_empty() {
        return (0.0, 0.0, 0.0, 0.0);
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let q = |p: f64| {
        let x = p * (v.len() - 1) as f64;
        let (i, f) = (x.floor() as usize, x.fract());
        if i + 1 < v.len() {
            v[i] * (1.0 - f) + v[i + 1] * f
        } else {
            v[i]
        }
    };
    (q(0.5), v[0], v[v.len() - 1], q(0.75) - q(0.25))
}

fn scene_label(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

/// Runs the whole matrix and returns one record per run.
pub fn run(cfg: &BenchConfig, scenes: &[BenchScene]) -> Result<Vec<Record>, BenchError> {
    let gpu_algos: Vec<Algo> = cfg
        .algos
        .iter()
        .copied()
        .filter(|&a| a != Algo::Reference)
        .collect();
    let per_size =
        1 + gpu_algos.len() * cfg.depth_setups.len() + usize::from(cfg.baseline.is_some());
    let total = (scenes.len() * cfg.sizes.len() * per_size) as u64;
    let bar = if cfg.progress {
        ProgressBar::new(total)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let mut records = Vec::new();
    for bs in scenes {
        for &(w, h) in &cfg.sizes {
            let mut scene = load_scene(&bs.path, (w, h))?;
            if let Some(n) = cfg.samples {
                scene.render.samples = n;
            }
            let label = scene_label(&bs.path);
            bar.set_message(format!("{label} {w}x{h}: reference"));
            crate::render::check_frame_budget(w, h, false)
                .map_err(|e| BenchError::Other(format!("{}: {e}", bs.path.display())))?;
            let t = Instant::now();
            // At the scene's samples: the colour their mean, depth and
            // primitive sample 0's, and each pixel's coverage.
            let (reference, _, reference_coverage) =
                peeltrim_reference::render_samples(&scene, w, h);
            let ref_ms = t.elapsed().as_secs_f64() * 1e3;
            bar.inc(1);
            let base = |algo: &str, depth: &str| Record {
                scene: label.clone(),
                family: bs.family.clone(),
                n: bs.n,
                prims: scene.primitives.iter().filter(|p| p.used).count(),
                width: w,
                height: h,
                samples: scene.render.samples,
                ..Record::blank(algo, depth)
            };
            if cfg.algos.contains(&Algo::Reference) {
                let mut r = base("reference", "f64");
                r.device = format!("cpu ({} threads)", rayon::current_num_threads());
                r.frames = 1;
                r.cpu_ms_median = ref_ms;
                r.error = Some(
                    compare(&reference, &reference)
                        .map_err(|e| BenchError::Other(e.to_string()))?,
                );
                if cfg.save_images {
                    let shown = modes::shadowed_reference(&scene, &reference);
                    save(cfg, &label, w, h, "reference", "f64", &shown)?;
                }
                records.push(r);
            }
            let prep = Prepared::new(&scene);
            let costs = match (&prep, cfg.max_est_s > 0.0 && !gpu_algos.is_empty()) {
                (Ok(p), true) => {
                    bar.set_message(format!("{label} {w}x{h}: estimating"));
                    Some(estimate::SceneCosts::new(&scene, p, w, h))
                }
                _ => None,
            };
            let auto = prep
                .as_ref()
                .ok()
                .map(|p| crate::auto::pick(&scene, p, w, h, false, &cfg.build));
            // OpenCSG (a separate process) runs before and after our rounds; its
            // figures are the median of both runs (`opencsg::merge_runs`).
            let run_opencsg = |b: &opencsg::OpenCsgBaseline, when: &str| {
                let work = cfg.out.join("opencsg").join(format!("{label}-{w}x{h}"));
                let base = base("opencsg", "gl-d24s8");
                let (frames, warmup) = (cfg.frames, cfg.warmup);
                opencsg::run_scene(
                    b,
                    &scene,
                    &reference,
                    base,
                    frames,
                    warmup,
                    &work.join(when),
                )
            };
            let opencsg_before = cfg.baseline.as_ref().map(|b| {
                bar.set_message(format!("{label} {w}x{h}: opencsg (before)"));
                run_opencsg(b, "before")
            });
            let setup = RunSetup {
                scene: &scene,
                prep: &prep,
                costs: costs.as_ref(),
                reference: &reference,
                reference_coverage: &reference_coverage,
            };
            let timing = rounds::timing(
                gpu_algos.len(),
                rounds::renderer_bytes(&scene, w, h),
                peeltrim::budget::current().bytes,
            );
            // Interleaved: one group of every algorithm, each with its own renderer;
            // else one group per algorithm, sharing one renderer in turn.
            let groups: Vec<&[Algo]> = match timing {
                rounds::Timing::Interleaved { .. } => vec![&gpu_algos[..]],
                _ => gpu_algos.chunks(1).collect(),
            };
            let mut default_floor = None;
            for &depth in &cfg.depth_setups {
                let mut spare: Option<GpuRenderer> = None;
                let first = records.len();
                for &group in &groups {
                    let mut runs = Vec::new();
                    for &algo in group {
                        bar.set_message(format!(
                            "{label} {w}x{h}: {algo} {}: warm-up",
                            depth.name()
                        ));
                        runs.push(start(cfg, &setup, algo, depth, &mut spare));
                    }
                    bar.set_message(format!("{label} {w}x{h}: {}: timed frames", depth.name()));
                    time_rounds(cfg, &mut runs);
                    for (&algo, run) in group.iter().zip(runs) {
                        bar.set_message(format!("{label} {w}x{h}: {algo} {}", depth.name()));
                        let mut rec = base(algo.name(), depth.name());
                        let result = run.and_then(|mut started| {
                            let r = finish(cfg, &setup, &mut started, depth);
                            spare = Some(started.gpu);
                            r
                        });
                        match result {
                            Ok((r, images)) => {
                                rec = Record {
                                    scene: rec.scene,
                                    family: rec.family,
                                    n: rec.n,
                                    prims: rec.prims,
                                    timing: timing.clone(),
                                    ..r
                                };
                                if cfg.save_images {
                                    save(
                                        cfg,
                                        &label,
                                        w,
                                        h,
                                        algo.name(),
                                        &rec.depth_setup,
                                        &images,
                                    )?;
                                }
                            }
                            Err(RunError::Failed(e)) => rec.failure = Some(e),
                            Err(RunError::Skipped(est)) => {
                                rec.skipped = Some(format!(
                                    "skipped: {est}, over --max-est-s {}",
                                    cfg.max_est_s
                                ));
                                rec.estimate = Some(est);
                            }
                        }
                        if let Some(a) = &auto {
                            rec.auto_pick = a.algo() == algo;
                            rec.auto_estimate_ms = a.estimates.get(algo.name()).copied();
                        }
                        records.push(rec);
                        bar.inc(1);
                    }
                }
                // The rasterization floor, on the last run's renderer.
                if let (Some(gpu), Ok(p)) = (spare.as_mut(), &prep) {
                    bar.set_message(format!("{label} {w}x{h}: floor {}", depth.name()));
                    match floor::time(gpu, p, cfg.warmup, cfg.frames) {
                        Ok(f) => {
                            default_floor.get_or_insert(f);
                            for r in &mut records[first..] {
                                r.floor = Some(f);
                            }
                        }
                        Err(e) => bar.println(format!(
                            "{label} {w}x{h}: the rasterization floor did not run: {e}"
                        )),
                    }
                } else {
                    bar.println(format!("{label} {w}x{h}: no renderer left for the floor"));
                }
            }
            if let (Some(b), Some(before)) = (&cfg.baseline, opencsg_before) {
                bar.set_message(format!("{label} {w}x{h}: opencsg (after)"));
                let after = run_opencsg(b, "after");
                for (mut rec, images) in opencsg::merge_runs(before, after) {
                    if let (true, Some(images)) = (cfg.save_images, images) {
                        save(cfg, &label, w, h, &rec.algo, &rec.depth_setup, &images)?;
                    }
                    rec.floor = default_floor;
                    records.push(rec);
                }
                bar.inc(1);
            }
        }
    }
    bar.finish_with_message("done");
    scaling::fit_families(&mut records);
    Ok(records)
}

fn save(
    cfg: &BenchConfig,
    label: &str,
    w: u32,
    h: u32,
    algo: &str,
    depth: &str,
    images: &Images,
) -> Result<(), BenchError> {
    let dir = cfg
        .out
        .join("images")
        .join(format!("{label}-{w}x{h}"))
        .join(format!("{algo}-{depth}"));
    crate::output::write_images(&dir, images)
        .map_err(|e| BenchError::Other(format!("{}: {e}", dir.display())))
}

/// What every run on one scene and size shares.
struct RunSetup<'a> {
    scene: &'a Scene,
    prep: &'a Result<Prepared, plan::PlanError>,
    /// For the estimate (`None`: `--max-est-s 0`, nothing estimated).
    costs: Option<&'a estimate::SceneCosts>,
    reference: &'a Images,
    /// The reference's coverage per pixel (covered samples ×255 over the
    /// samples).
    reference_coverage: &'a [u8],
}

/// Why a run has no figures.
enum RunError {
    Failed(String),
    /// Its plan's estimate is over `--max-est-s`.
    Skipped(estimate::FrameEstimate),
}

impl From<String> for RunError {
    fn from(e: String) -> Self {
        RunError::Failed(e)
    }
}

/// A run warmed up and ready for its timed frames: its plan, its renderer (kept
/// across the rounds, so it replays its own recording) and its timed frames so far.
struct Started {
    algo: Algo,
    plan: plan::Plan,
    gpu: GpuRenderer,
    est: Option<estimate::FrameEstimate>,
    /// Its warm-up took longer than `budget_ms`: timed on one frame only.
    slow: bool,
    frames: Vec<FrameStats>,
}

/// The plan and warm-up of one algorithm, on `spare`'s renderer when there is
/// one (taken once the plan is made), else on a new one.
fn start(
    cfg: &BenchConfig,
    setup: &RunSetup,
    algo: Algo,
    depth: DepthSetup,
    spare: &mut Option<GpuRenderer>,
) -> Result<Started, RunError> {
    let scene = setup.scene;
    let prep = setup.prep.as_ref().map_err(|e| e.to_string())?;
    let plan = plan::build_with(algo, prep, &cfg.build).map_err(|e| e.to_string())?;
    let est = setup
        .costs
        .map(|c| c.estimate(&plan, prep, &estimate::CostModel::LAVAPIPE));
    if let Some(e) = est
        .as_ref()
        .filter(|e| estimate::over_budget(e, cfg.max_est_s))
    {
        return Err(RunError::Skipped(e.clone()));
    }
    let mut gpu = match spare.take() {
        Some(g) => g,
        None => {
            GpuRenderer::with_fallback(scene, cfg.device, depth, cfg.depth_fallback, cfg.validation)
                .map_err(|e| e.to_string())?
        }
    };
    gpu.set_cut_away(algo, prep, scene);
    let mut slow = false;
    let mut last = None;
    for _ in 0..cfg.warmup {
        let t = Instant::now();
        last = Some(gpu.execute(&plan).map_err(|e| e.to_string())?.exec.recorded);
        slow |= t.elapsed().as_secs_f64() * 1e3 > cfg.budget_ms;
    }
    // A plan's first frame runs loop by loop; the next records the frame that
    // later frames replay. Timed frames are those replays.
    if cfg.warmup > 0 && last == Some(peeltrim::vk::Recorded::Stepwise) {
        gpu.execute(&plan).map_err(|e| e.to_string())?;
    }
    // Timed frames carry the frame's two timestamps only: one per pass cuts
    // lavapipe's binned scene at every pass (3 per SCS product), which the
    // frame itself does not need; `finish` takes the per-pass times from one
    // more frame. The recording made with them is dropped (an untimed round
    // frame records the timed frames' one).
    gpu.executor_mut().set_pass_timestamps(false);
    Ok(Started {
        algo,
        plan,
        gpu,
        est,
        slow,
        frames: Vec::new(),
    })
}

/// The timed frames of a group of started runs, round-robin, each after an
/// untimed one of its run ([`rounds`]). They
/// leave their images on the GPU; each run's last one is read back once, after
/// timing, for the error against the reference. A run whose frame fails leaves
/// the rounds with that failure.
fn time_rounds(cfg: &BenchConfig, runs: &mut [Result<Started, RunError>]) {
    let counts: Vec<u32> = runs
        .iter()
        .map(|r| match r {
            Ok(s) if s.slow => 1,
            Ok(_) => cfg.frames.max(1),
            Err(_) => 0,
        })
        .collect();
    for slot in rounds::schedule(&counts, rounds::WARM_FRAMES) {
        let failed = match &mut runs[slot.run] {
            Ok(s) => match s.gpu.execute(&s.plan) {
                Ok(f) => {
                    if slot.timed {
                        s.frames.push(f);
                    }
                    None
                }
                Err(e) => Some(e.to_string()),
            },
            Err(_) => None,
        };
        if let Some(e) = failed {
            runs[slot.run] = Err(RunError::Failed(e));
        }
    }
}

/// A timed run's record: the camera-move and re-recording figures, the error of
/// its last image, and its modes (embedded, shadows, interference).
fn finish(
    cfg: &BenchConfig,
    setup: &RunSetup,
    started: &mut Started,
    depth: DepthSetup,
) -> Result<(Record, Images), RunError> {
    let (scene, reference) = (setup.scene, setup.reference);
    let Started {
        algo,
        ref plan,
        ref mut gpu,
        ref est,
        slow,
        ref frames,
    } = *started;
    let est = est.clone();
    // The error is the timed frames' own: the last one's images, read back
    // before the frames below (per-pass timestamps, a camera move and back)
    // replace them. Those may record other work than the timed frames did
    // (cutter sets hold for the scene's camera only, and a recording with
    // scissors grown by the move replays uncut), so an image read after
    // them would not check what was timed.
    let images = gpu.read_back().map_err(|e| e.to_string())?;
    // Multisampled: the coverage fractions against the reference's.
    let coverage = match gpu.executor().coverage() {
        Some(cov) => Some(
            compare_samples(reference, setup.reference_coverage, &images, cov)
                .map_err(|e| e.to_string())?,
        ),
        None => None,
    };
    let replayed = frames.iter().filter(|f| f.exec.record_ms == 0.0).count() as u32;
    // The per-pass GPU times, from one frame with a timestamp at every pass.
    let per_pass = match frames.is_empty() {
        true => None,
        false => {
            gpu.executor_mut().set_pass_timestamps(true);
            let f = gpu.execute(plan).map_err(|e| e.to_string())?;
            Some(f.exec.per_pass)
        }
    };
    // A camera move (a viewer's orbit), then one frame recorded anew at the
    // original camera: what a moved camera and a new plan cost the CPU (skipped
    // for runs over the time budget).
    let (mut camera_move_record_ms, mut camera_move, mut rerecord_ms) = (0.0, None, 0.0);
    let mut rerecord_cached_ms = 0.0;
    if !slow {
        let err = |e: crate::render::RenderError| e.to_string();
        // An orbit in two steps: the first records the frame with grown
        // scissors, the second is what each frame of an orbit then costs.
        gpu.set_camera(&nudged(&scene.camera, 0.5)).map_err(err)?;
        gpu.execute(plan).map_err(err)?;
        gpu.set_camera(&nudged(&scene.camera, 1.0)).map_err(err)?;
        let moved = gpu.execute(plan).map_err(err)?.exec;
        (camera_move_record_ms, camera_move) = (moved.record_ms, Some(moved.recorded));
        gpu.set_camera(&scene.camera).map_err(err)?;
        // Back at the scene's camera (relearning the loop counts should the moved
        // view have changed them), until a recording of the plan is kept; then
        // that frame recorded anew, a few times: the median CPU time.
        let mut times = None;
        for _ in 0..3 {
            gpu.execute(plan).map_err(err)?;
            times = gpu.time_recording(plan, RERECORD_REPS).map_err(err)?;
            if times.is_some() {
                break;
            }
        }
        if let Some(mut t) = times {
            rerecord_ms = median_iqr(&mut t).0;
            let cached = gpu
                .time_recording_cached(plan, RERECORD_REPS)
                .map_err(err)?;
            rerecord_cached_ms = cached.map_or(0.0, |mut t| median_iqr(&mut t).0);
        }
    }
    let embedded = match cfg.embedded && !slow {
        true => Some(embedded::measure(
            gpu,
            plan,
            scene,
            algo,
            (cfg.warmup, cfg.frames),
        )?),
        false => None,
    };
    let msgs = gpu.validation_messages();
    if !msgs.is_empty() {
        return Err(RunError::Failed(format!("validation: {}", msgs[0])));
    }
    let series = |f: fn(&FrameStats) -> f64| frames.iter().map(f).collect::<Vec<f64>>();
    let gpu_ms = series(|s| s.exec.gpu_ms);
    let last = frames.last().expect("at least one frame");
    let (gm, gmin, gmax, giqr) = median_iqr(&mut gpu_ms.clone());
    let (cm, _, _, ciqr) = median_iqr(&mut series(|s| s.exec.cpu_ms));
    let (fm, _, _, fiqr) = median_iqr(&mut series(|s| s.exec.frame_ms));
    let (rm, _, _, _) = median_iqr(&mut series(|s| s.exec.record_ms));
    let (pm, _, _, _) = median_iqr(&mut series(|s| s.exec.frame_cpu_ms));
    let counts = RunCounts::Frame(Box::new(FrameCounts {
        stencil_bits: last.stencil_bits.unwrap_or(0),
        counts: last.exec.counts.clone(),
    }));
    let error = compare(reference, &images).map_err(|e| e.to_string())?;
    // With a `[light]`: the light's map and the shadow pass timed too; the saved
    // images are shadowed, the error above is the opaque frame's.
    let shadowed = modes::shadows(cfg, scene, algo, plan, gpu, gm)?;
    let rec = Record {
        scene: String::new(),
        family: None,
        n: None,
        prims: 0,
        width: images.width,
        height: images.height,
        samples: scene.render.samples,
        algo: algo.name().into(),
        depth_setup: gpu.depth_setup().name().into(),
        depth_setup_fallback: gpu.depth_setup_fallback(),
        device: gpu.device_name(),
        frames: frames.len() as u32,
        gpu_ms_median: gm,
        gpu_ms_min: gmin,
        gpu_ms_max: gmax,
        gpu_ms_iqr: giqr,
        cpu_ms_median: cm,
        cpu_ms_iqr: ciqr,
        frame_ms_median: fm,
        frame_ms_iqr: fiqr,
        frame_cpu_ms_median: pm,
        record_ms_median: rm,
        rerecord_ms,
        rerecord_us_per_draw: rerecord_ms * 1e3 / (last.exec.counts.draws.max(1) as f64),
        rerecord_cached_us_per_draw: rerecord_cached_ms * 1e3
            / (last.exec.counts.draws.max(1) as f64),
        camera_move_record_ms,
        camera_move,
        overhead: Some(checks::Overhead::of(frames.len() as u32, replayed, gm, fm)),
        scaling: None,
        counts: Some(counts),
        per_pass,
        error: Some(error),
        coverage,
        failure: None,
        estimate: est,
        skipped: None,
        embedded,
        shadow: shadowed.as_ref().map(|(b, _)| b.clone()),
        interference: modes::interference(cfg, scene, algo, depth)?,
        timing: rounds::Timing::Alone,
        plan_digest: digest(plan),
        auto_pick: false,
        auto_estimate_ms: None,
        floor: None,
    };
    Ok((rec, shadowed.map_or(images, |(_, i)| i)))
}

/// A digest of a plan's steps (FNV-1a over their debug text): equal for equal
/// plans within one build, so the summary can tell two algorithms ran one plan.
fn digest(plan: &plan::Plan) -> String {
    let text = format!("{:?}", plan.steps);
    let h = text.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    });
    format!("{h:016x}")
}

/// Recordings of each run's frame made anew for `rerecord_ms` (their median).
pub const RERECORD_REPS: u32 = 7;

/// How far the bench orbits the camera (in two half steps) to time a camera move.
pub const CAMERA_NUDGE_DEG: f64 = 1.0;

/// `cam` orbited by `fraction` of [`CAMERA_NUDGE_DEG`] about its up axis through
/// its target.
fn nudged(cam: &peeltrim::scene::Camera, fraction: f64) -> peeltrim::scene::Camera {
    let turn = glam::DQuat::from_axis_angle(
        cam.up.normalize(),
        (fraction * CAMERA_NUDGE_DEG).to_radians(),
    );
    peeltrim::scene::Camera {
        eye: cam.target + turn * (cam.eye - cam.target),
        ..*cam
    }
}

/// The deterministic counts a record keeps: of a GPU run's last frame, or of
/// the plan an OpenCSG baseline run draws. Written as the one set's fields.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum RunCounts {
    /// A GPU run's last frame (boxed: some 30 counts against four).
    Frame(Box<FrameCounts>),
    /// An OpenCSG baseline run ([`opencsg`]).
    OpenCsg(opencsg::ProductCounts),
}

impl RunCounts {
    /// The frame's counts of a GPU run (`None` for a baseline run).
    pub fn frame(&self) -> Option<&peeltrim::vk::Counts> {
        match self {
            RunCounts::Frame(f) => Some(&f.counts),
            RunCounts::OpenCsg(_) => None,
        }
    }
}

/// A GPU run's last frame: the executor's counts and the stencil bits its
/// draws use.
#[derive(Clone, Debug, Serialize)]
pub struct FrameCounts {
    /// Stencil bits the plan's draws use (0: depth-only images possible).
    pub stencil_bits: u8,
    /// The executor's counts of the frame.
    #[serde(flatten)]
    pub counts: peeltrim::vk::Counts,
}

/// Runs the matrix and writes every output into `cfg.out`.
pub fn run_and_report(cfg: &BenchConfig, scenes: &[BenchScene]) -> Result<Vec<Record>, BenchError> {
    crate::output::create_out_dir(&cfg.out, "--out")
        .map_err(|e| BenchError::Other(e.to_string()))?;
    let records = run(cfg, scenes)?;
    report::write_all(&cfg.out, &records)?;
    // Plots are an optional extra: the table and results are already written.
    if let Err(e) = plot::write_all(&cfg.out, &records) {
        eprintln!("peeltrim: warning: no plots: {e}");
    }
    Ok(records)
}

/// A bench scene (a `.scad` exported first) at `size`.
pub(crate) fn load_scene(path: &std::path::Path, size: (u32, u32)) -> Result<Scene, BenchError> {
    scene::load(
        &crate::scad::csg_for(path).map_err(BenchError::Other)?,
        &LoadOptions { size: Some(size) },
    )
    .map_err(|source| BenchError::Scene {
        path: path.to_path_buf(),
        source,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::Record;
    use peeltrim_reference::compare::CompareReport;

    /// A run of `algo` on a scaling family's scene of size `n`, correct (no
    /// mismatch), every time zero.
    pub(crate) fn record(algo: &str, n: Option<u32>) -> Record {
        Record {
            scene: format!("fam-{}", n.unwrap_or(0)),
            family: n.map(|_| "fam".to_string()),
            n,
            width: 800,
            height: 800,
            error: Some(CompareReport::default()),
            ..Record::blank(algo, "d32s8")
        }
    }
}
