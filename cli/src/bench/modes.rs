//! Bench modes beyond the opaque frame (the bench times each mode):
//! shadows — the light's depth map rendered by the same algorithm (Rossignac & Wu's
//! shadow buffer) and the shadow test over the eye's frame — and interference —
//! one frame of `A·B` per pair of solids (Hable & Rossignac §6). Each is timed like
//! the eye's frame: warm-up, then the median GPU time over the timed frames.
#![deny(unsafe_code)]

use std::fmt::Write as _;
use std::time::Instant;

use serde::Serialize;

use super::{median_iqr, BenchConfig, Record};
use crate::output::Images;
use crate::render::{interference, shadow, DepthSetup, GpuRenderer};
use peeltrim::plan::{self, Algo, Prepared};
use peeltrim::scene::Scene;

/// The shadow figures of one run (`results.json` key `shadow`): each timed
/// frame renders the light's map, the eye's frame (with its normal buffer) and
/// the shadow pass, on one device with no read-back between them.
#[derive(Clone, Debug, Serialize)]
pub struct ShadowBench {
    /// The shadow map's side in texels.
    pub map_size: u32,
    /// Median GPU time of the light's depth map.
    pub light_map_gpu_ms_median: f64,
    /// Median GPU time of the eye's frame with the normal buffer the pass reads.
    pub eye_gpu_ms_median: f64,
    /// Median GPU time of the opaque eye frame (the run's `gpu_ms_median`).
    pub opaque_eye_gpu_ms_median: f64,
    /// Median GPU time of the shadow pass.
    pub shadow_pass_gpu_ms_median: f64,
    /// Median over the frames of map + eye + pass GPU time.
    pub frame_gpu_ms_median: f64,
    /// Median wall time of map + eye + pass (first submission to GPU idle).
    pub frame_ms_median: f64,
    /// Most queue submissions of a timed frame (map, eye and pass): 1 when
    /// both frames replayed and went in one submission with the pass.
    pub submits_max: u64,
    pub lit_pixels: u64,
    pub shadowed_pixels: u64,
}

/// The interference figures of one run (`results.json` key `interference`).
#[derive(Clone, Debug, Serialize)]
pub struct InterferenceBench {
    /// Pairs of solids rendered (n·(n−1)/2).
    pub pairs: usize,
    /// Timed frames per pair.
    pub frames_per_pair: u32,
    /// Sum over the pairs of each pair's median GPU time: one interference frame.
    pub gpu_ms_median: f64,
    /// Pairs with at least one pixel.
    pub interfering_pairs: usize,
}

/// Median GPU time of `scene` rendered by `algo` (warm-up, then timed frames),
/// and the last frame's images.
fn timed(
    cfg: &BenchConfig,
    scene: &Scene,
    algo: Algo,
    depth: DepthSetup,
) -> Result<(f64, Images, GpuRenderer), String> {
    let prep = Prepared::new(scene).map_err(|e| e.to_string())?;
    let plan = plan::build_with(algo, &prep, &cfg.build).map_err(|e| e.to_string())?;
    let mut gpu =
        GpuRenderer::with_fallback(scene, cfg.device, depth, cfg.depth_fallback, cfg.validation)
            .map_err(|e| e.to_string())?;
    for _ in 0..cfg.warmup {
        gpu.execute(&plan).map_err(|e| e.to_string())?;
    }
    let mut ms = Vec::new();
    for _ in 0..cfg.frames.max(1) {
        ms.push(gpu.execute(&plan).map_err(|e| e.to_string())?.exec.gpu_ms);
    }
    let images = gpu.read_back().map_err(|e| e.to_string())?;
    if let Some(m) = gpu.validation_messages().first() {
        return Err(format!("validation: {m}"));
    }
    Ok((median_iqr(&mut ms).0, images, gpu))
}

/// With a `[light]`: frames of the light's map, the eye (`plan` on `gpu`) and
/// the shadow pass, timed; and the last frame's shadowed images. `gpu` writes
/// no normals afterwards, as before.
pub fn shadows(
    cfg: &BenchConfig,
    scene: &Scene,
    algo: Algo,
    plan: &plan::Plan,
    gpu: &mut GpuRenderer,
    opaque_gpu_ms: f64,
) -> Result<Option<(ShadowBench, Images)>, String> {
    let Some(light) = &scene.appearance.light else {
        return Ok(None);
    };
    let out = shadow_frames(cfg, scene, light, algo, plan, gpu, opaque_gpu_ms);
    gpu.set_normals(false).map_err(|e| e.to_string())?;
    out.map(Some)
}

fn shadow_frames(
    cfg: &BenchConfig,
    scene: &Scene,
    light: &peeltrim::scene::light::Light,
    algo: Algo,
    plan: &plan::Plan,
    gpu: &mut GpuRenderer,
    opaque_gpu_ms: f64,
) -> Result<(ShadowBench, Images), String> {
    let err = |e: crate::render::RenderError| e.to_string();
    let mut sh =
        shadow::GpuShadows::for_renderer(gpu, scene, light, algo, &cfg.build).map_err(err)?;
    // (map, eye, pass, wall, submits) per frame; warm-up frames learn both
    // plans' loops, so that timed frames are one submission each.
    let mut frame = |gpu: &mut GpuRenderer| -> Result<[f64; 5], String> {
        let t = Instant::now();
        let (eye, cost) = sh.frame(gpu, plan, &scene.camera, true).map_err(err)?;
        let map = cost.map.map_or(0.0, |m| m.gpu_ms);
        let wall = t.elapsed().as_secs_f64() * 1e3;
        let submits = cost.submits as f64;
        Ok([map, eye.exec.gpu_ms, cost.pass.gpu_ms, wall, submits])
    };
    for _ in 0..cfg.warmup.max(2) {
        frame(gpu)?;
    }
    let mut runs = Vec::new();
    for _ in 0..cfg.frames.max(1) {
        runs.push(frame(gpu)?);
    }
    let images = gpu.read_back().map_err(err)?;
    let st = sh.stats(&images.prim).map_err(err)?;
    if let Some(m) = gpu.validation_messages().first() {
        return Err(format!("validation: {m}"));
    }
    let med =
        |f: &dyn Fn(&[f64; 5]) -> f64| median_iqr(&mut runs.iter().map(f).collect::<Vec<_>>()).0;
    Ok((
        ShadowBench {
            map_size: sh.map_size(),
            light_map_gpu_ms_median: med(&|r| r[0]),
            eye_gpu_ms_median: med(&|r| r[1]),
            opaque_eye_gpu_ms_median: opaque_gpu_ms,
            shadow_pass_gpu_ms_median: med(&|r| r[2]),
            frame_gpu_ms_median: med(&|r| r[0] + r[1] + r[2]),
            frame_ms_median: med(&|r| r[3]),
            submits_max: runs.iter().map(|r| r[4] as u64).max().unwrap_or(0),
            lit_pixels: st.lit_pixels,
            shadowed_pixels: st.shadowed_pixels,
        },
        images,
    ))
}

/// The reference's image as the bench saves it: with the shadow rays' shadows
/// when the scene has a `[light]` (the GPU runs' saved images have theirs).
pub fn shadowed_reference(scene: &Scene, reference: &Images) -> Images {
    let mut shown = reference.clone();
    if let Some(light) = &scene.appearance.light {
        let rays = peeltrim_reference::shadow::shadow_rays(
            scene,
            light,
            reference.width,
            reference.height,
        );
        shadow::apply(&mut shown.color, &rays, light);
    }
    shown
}

/// With `interference = true` and a CST variant: every pair's `A·B` frames.
pub fn interference(
    cfg: &BenchConfig,
    scene: &Scene,
    algo: Algo,
    depth: DepthSetup,
) -> Result<Option<InterferenceBench>, String> {
    if !scene.appearance.interference || !interference::supported(algo) {
        return Ok(None);
    }
    let mut out = InterferenceBench {
        pairs: 0,
        frames_per_pair: cfg.frames.max(1),
        gpu_ms_median: 0.0,
        interfering_pairs: 0,
    };
    for (i, a) in scene.solids.iter().enumerate() {
        for b in &scene.solids[i + 1..] {
            let (ms, images, _) = timed(cfg, &interference::pair_scene(scene, a, b), algo, depth)?;
            out.pairs += 1;
            out.gpu_ms_median += ms;
            out.interfering_pairs += usize::from(images.prim.iter().any(|&p| p != 0));
        }
    }
    Ok(Some(out))
}

/// Markdown tables of the runs that timed shadows or interference (empty when none).
pub fn summary(records: &[Record]) -> String {
    let mut s = String::new();
    let sh: Vec<(&Record, &ShadowBench)> = records
        .iter()
        .filter_map(|r| r.shadow.as_ref().map(|b| (r, b)))
        .collect();
    if !sh.is_empty() {
        s.push_str("## Shadows\n\n| scene | size | algo | depth | map side | light map GPU ms | eye GPU ms (opaque) | shadow pass GPU ms | frame GPU ms | frame ms | lit px | shadowed px |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
        for (r, b) in sh {
            let _ = writeln!(
                s,
                "| {} | {}×{} | {} | {} | {} | {:.2} | {:.2} ({:.2}) | {:.2} | {:.2} | {:.1} | {} | {} |",
                r.scene,
                r.width,
                r.height,
                r.algo,
                r.depth_setup,
                b.map_size,
                b.light_map_gpu_ms_median,
                b.eye_gpu_ms_median,
                b.opaque_eye_gpu_ms_median,
                b.shadow_pass_gpu_ms_median,
                b.frame_gpu_ms_median,
                b.frame_ms_median,
                b.lit_pixels,
                b.shadowed_pixels
            );
        }
        s.push('\n');
    }
    let it: Vec<(&Record, &InterferenceBench)> = records
        .iter()
        .filter_map(|r| r.interference.as_ref().map(|b| (r, b)))
        .collect();
    if !it.is_empty() {
        s.push_str("## Interference\n\n| scene | size | algo | depth | pairs × frames | interfering pairs | GPU ms (sum of pair medians) | eye GPU ms |\n|---|---|---|---|---|---|---|---|\n");
        for (r, b) in it {
            let _ = writeln!(
                s,
                "| {} | {}×{} | {} | {} | {} × {} | {} | {:.2} | {:.2} |",
                r.scene,
                r.width,
                r.height,
                r.algo,
                r.depth_setup,
                b.pairs,
                b.frames_per_pair,
                b.interfering_pairs,
                b.gpu_ms_median,
                r.gpu_ms_median
            );
        }
        s.push('\n');
    }
    s
}
