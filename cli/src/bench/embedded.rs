//! `bench --embedded`: every GPU run also draws its frames through the embedding
//! path — a [`CsgScene`] made from the scene, recorded into the frames of an
//! off-screen host (`vk::OffscreenHost`: its own colour and depth attachments,
//! command buffer and submission) — on the same device, in pairs with standalone
//! frames so that load on a shared machine hits both alike (docs/embedding.md).
//! Fair by construction: the host's own pass (its clear) is submitted apart and
//! not timed, so both timed submissions hold peeltrim's commands alone; the
//! order inside a pair alternates; the ratios are medians over at least
//! [`MIN_PAIRS`] pairs, of wall time and of the process's CPU time (the latter
//! unaffected by other processes competing for a loaded machine's cores).

use serde::Serialize;

use crate::render::GpuRenderer;
use peeltrim::embed::{CsgScene, EmbedDesc, LoopCounts};
use peeltrim::plan::{Algo, Plan};
use peeltrim::scene::Scene;
use peeltrim::vk::embed::HostPath;
use peeltrim::vk::{ExecStats, OffscreenHost};

/// The fewest frame pairs the medians are taken over.
pub const MIN_PAIRS: u32 = 15;

/// The embedded path's figures of one run.
#[derive(Clone, Debug, Serialize)]
pub struct EmbeddedTimes {
    /// Frame pairs measured (after warm-up).
    pub pairs: u32,
    /// Median `frame_ms` of the standalone frames paired with these.
    pub standalone_frame_ms_median: f64,
    /// Median wall time from the host's submission to completion.
    pub frame_ms_median: f64,
    /// Median CPU time recording the host's command buffer (the embedded path
    /// records every frame).
    pub record_ms_median: f64,
    /// Median over the frame pairs of embedded over standalone `frame_ms`.
    pub ratio: f64,
    /// Median `frame_cpu_ms` (process CPU time, all threads, from submission to
    /// completion) of the standalone frames.
    pub standalone_frame_cpu_ms_median: f64,
    /// The same of the embedded frames.
    pub frame_cpu_ms_median: f64,
    /// Median over the pairs of embedded over standalone `frame_cpu_ms` (0
    /// where the CPU time cannot be read).
    pub cpu_ratio: f64,
    /// How the last embedded frame's final shading reached the host's targets
    /// (`direct`, or a composite fallback and why).
    pub host_path: Option<HostPath>,
    /// Draws of the last embedded frame (the standalone frame's).
    pub draws: u64,
    /// Triangles of the last embedded frame (the standalone frame's).
    pub triangles: u64,
    /// Full-screen passes of the last embedded frame (the standalone frame's;
    /// plus one for a composite fallback).
    pub fullscreen_passes: u64,
    /// Pipeline barriers of the last embedded frame.
    pub barriers: u64,
    /// Of `draws` and `triangles`: those the embedded frame adds by drawing a
    /// final-shade piece in parts, without the check of the output depth
    /// outside its mesh's cutters (`plan::cut_away`); the rest are the
    /// standalone frame's.
    pub split_draws: u64,
    pub split_triangles: u64,
}

/// At least [`MIN_PAIRS`] pairs (after `warmup`) of a standalone frame of `plan`
/// on `gpu` and an embedded frame of `scene` with `algo`, on `gpu`'s device; the
/// standalone frame first in even pairs, second in odd ones.
pub fn measure(
    gpu: &mut GpuRenderer,
    plan: &Plan,
    scene: &Scene,
    algo: Algo,
    (warmup, frames): (u32, u32),
) -> Result<EmbeddedTimes, String> {
    let (internal_depth, reversed_z) = gpu.depth_setup().exec_format();
    let extent = [scene.render.width, scene.render.height];
    let desc = EmbedDesc {
        extent,
        reversed_z,
        frames_in_flight: 1,
        algo,
        // The standalone path learns its loop counts too: equal work.
        loop_counts: LoopCounts::Learn,
        internal_depth,
        samples: scene.render.samples,
    };
    let ctx = gpu.context().clone();
    let mut csg = CsgScene::from_scene(&ctx, scene, &desc).map_err(|e| e.to_string())?;
    let mut host = OffscreenHost::new(&ctx, extent).map_err(|e| e.to_string())?;
    let far = if reversed_z { 0.0 } else { 1.0 };
    let bg = scene.render.background;
    let pairs = frames.max(MIN_PAIRS);
    let mut alone = Vec::new();
    let mut embedded = Vec::new();
    let mut last = None;
    for i in 0..warmup + pairs {
        let mut standalone = || gpu.execute(plan).map(|f| f.exec).map_err(|e| e.to_string());
        let s0 = if i % 2 == 0 {
            Some(standalone()?)
        } else {
            None
        };
        host.clear(bg, far).map_err(|e| e.to_string())?;
        let e = host.frame(csg.recorder()).map_err(|e| e.to_string())?;
        let s = match s0 {
            Some(s) => s,
            None => standalone()?,
        };
        if i >= warmup {
            alone.push(s);
            embedded.push(e.clone());
        }
        last = Some(e);
    }
    let last = last.expect("at least one pair");
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let series = |v: &[ExecStats], f: fn(&ExecStats) -> f64| v.iter().map(f).collect::<Vec<_>>();
    let ratios = |f: fn(&ExecStats) -> f64| {
        let r = embedded
            .iter()
            .zip(&alone)
            .map(|(e, s)| if f(s) > 0.0 { f(e) / f(s) } else { 0.0 })
            .collect();
        median(r)
    };
    Ok(EmbeddedTimes {
        pairs,
        standalone_frame_ms_median: median(series(&alone, |s| s.frame_ms)),
        frame_ms_median: median(series(&embedded, |s| s.frame_ms)),
        record_ms_median: median(series(&embedded, |s| s.record_ms)),
        ratio: ratios(|s| s.frame_ms),
        standalone_frame_cpu_ms_median: median(series(&alone, |s| s.frame_cpu_ms)),
        frame_cpu_ms_median: median(series(&embedded, |s| s.frame_cpu_ms)),
        cpu_ratio: ratios(|s| s.frame_cpu_ms),
        host_path: last.host_path,
        draws: last.counts.draws,
        triangles: last.counts.triangles,
        fullscreen_passes: last.counts.fullscreen_passes,
        barriers: last.counts.barriers,
        split_draws: last.counts.shade_split_draws,
        split_triangles: last.counts.shade_split_triangles,
    })
}
