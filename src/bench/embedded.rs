//! `bench --embedded`: every GPU run also draws its frames through the embedding
//! path — a [`CsgScene`] made from the scene, recorded into the frames of an
//! off-screen host ([`vk::OffscreenHost`]: its own colour and depth attachments,
//! command buffer and submission) — on the same device, right after the
//! standalone frames, so the two `frame_ms` compare (README "Embedding").

use serde::Serialize;

use crate::embed::{CsgScene, EmbedDesc, LoopCounts};
use crate::plan::Algo;
use crate::render::DepthSetup;
use crate::scene::Scene;
use crate::vk::{self, OffscreenHost};

/// The embedded path's figures of one run.
#[derive(Clone, Debug, Serialize)]
pub struct EmbeddedTimes {
    /// Median wall time from the host's submission to completion.
    pub frame_ms_median: f64,
    /// Median CPU time recording the host's command buffer (the embedded path
    /// records every frame).
    pub record_ms_median: f64,
    /// `frame_ms_median` over the standalone path's.
    pub ratio: f64,
    /// Draws of the last embedded frame (the standalone frame's plus nothing:
    /// the composite is a full-screen pass).
    pub draws: u64,
}

/// `frames` embedded frames (after `warmup`) of `scene` with `algo`; `standalone`
/// is the standalone path's median `frame_ms`, for the ratio.
pub fn measure(
    ctx: &vk::Context,
    scene: &Scene,
    algo: Algo,
    depth: DepthSetup,
    (warmup, frames): (u32, u32),
    standalone: f64,
) -> Result<EmbeddedTimes, String> {
    let (internal_depth, reversed_z) = depth.exec_format();
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
    let mut csg = CsgScene::from_scene(ctx, scene, &desc).map_err(|e| e.to_string())?;
    let mut host = OffscreenHost::new(ctx, extent).map_err(|e| e.to_string())?;
    let far = if reversed_z { 0.0 } else { 1.0 };
    let bg = scene.render.background;
    let (mut frame_ms, mut record_ms, mut draws) = (Vec::new(), Vec::new(), 0);
    for i in 0..warmup + frames.max(1) {
        let st = host
            .frame(csg.recorder(), bg, far)
            .map_err(|e| e.to_string())?;
        if i >= warmup {
            frame_ms.push(st.frame_ms);
            record_ms.push(st.record_ms);
            draws = st.counts.draws;
        }
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let frame_ms_median = median(frame_ms);
    Ok(EmbeddedTimes {
        frame_ms_median,
        record_ms_median: median(record_ms),
        ratio: frame_ms_median / standalone.max(1e-9),
        draws,
    })
}
