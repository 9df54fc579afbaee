//! `bench --embedded`: every GPU run also draws its frames through the embedding
//! path — a [`CsgScene`] made from the scene, recorded into the frames of an
//! off-screen host (`vk::OffscreenHost`: its own colour and depth attachments,
//! command buffer and submission) — on the same device, each embedded frame right
//! after a standalone one, so that load on a shared machine hits both alike; the
//! ratio is the median of the pairs' ratios (README "Embedding").

use serde::Serialize;

use crate::embed::{CsgScene, EmbedDesc, LoopCounts};
use crate::plan::{Algo, Plan};
use crate::render::GpuRenderer;
use crate::scene::Scene;
use crate::vk::OffscreenHost;

/// The embedded path's figures of one run.
#[derive(Clone, Debug, Serialize)]
pub struct EmbeddedTimes {
    /// Median `frame_ms` of the standalone frames interleaved with these.
    pub standalone_frame_ms_median: f64,
    /// Median wall time from the host's submission to completion.
    pub frame_ms_median: f64,
    /// Median CPU time recording the host's command buffer (the embedded path
    /// records every frame).
    pub record_ms_median: f64,
    /// Median over the frame pairs of embedded over standalone `frame_ms`.
    pub ratio: f64,
    /// Draws of the last embedded frame (the standalone frame's plus nothing:
    /// the composite is a full-screen pass).
    pub draws: u64,
}

/// `frames` pairs (after `warmup`) of a standalone frame of `plan` on `gpu` and
/// an embedded frame of `scene` with `algo`, on `gpu`'s device.
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
    };
    let ctx = gpu.context().clone();
    let mut csg = CsgScene::from_scene(&ctx, scene, &desc).map_err(|e| e.to_string())?;
    let mut host = OffscreenHost::new(&ctx, extent).map_err(|e| e.to_string())?;
    let far = if reversed_z { 0.0 } else { 1.0 };
    let bg = scene.render.background;
    let (mut alone, mut embedded, mut record, mut ratios) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut draws = 0;
    for i in 0..warmup + frames.max(1) {
        let s = gpu.execute(plan).map_err(|e| e.to_string())?.exec.frame_ms;
        let e = host
            .frame(csg.recorder(), bg, far)
            .map_err(|e| e.to_string())?;
        if i >= warmup {
            alone.push(s);
            embedded.push(e.frame_ms);
            record.push(e.record_ms);
            ratios.push(e.frame_ms / s.max(1e-9));
            draws = e.counts.draws;
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Ok(EmbeddedTimes {
        standalone_frame_ms_median: median(alone),
        frame_ms_median: median(embedded),
        record_ms_median: median(record),
        ratio: median(ratios),
        draws,
    })
}
