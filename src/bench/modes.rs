//! Bench modes beyond the opaque frame (issue 11, "the bench times each mode"):
//! shadows — the light's depth map rendered by the same algorithm (seed 003's
//! shadow buffer) and the shadow test over the eye's frame — and interference —
//! one frame of `A·B` per pair of solids (seed 000 §6). Each is timed like the
//! eye's frame: warm-up, then the median GPU time over the timed frames.
#![deny(unsafe_code)]

use std::fmt::Write as _;
use std::time::Instant;

use serde::Serialize;

use super::{median_iqr, BenchConfig, Record};
use crate::output::Images;
use crate::plan::{self, Algo, Prepared};
use crate::render::{interference, shadow, DepthSetup, GpuRenderer};
use crate::scene::Scene;

/// The shadow figures of one run (`results.json` key `shadow`).
#[derive(Clone, Debug, Serialize)]
pub struct ShadowBench {
    /// The shadow map's side in texels.
    pub map_size: u32,
    /// Median GPU time of the light's depth map.
    pub light_map_gpu_ms_median: f64,
    /// Median GPU time of the eye's frame (the run's `gpu_ms_median`).
    pub eye_gpu_ms_median: f64,
    /// CPU time of the shadow test over the read-back depth images (once).
    pub shadow_test_cpu_ms: f64,
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

/// With a `[light]`: the light map's frames and the shadow test over the eye's
/// last frame `eye` (rendered by `eye_gpu`).
pub fn shadows(
    cfg: &BenchConfig,
    scene: &Scene,
    algo: Algo,
    depth: DepthSetup,
    eye: &Images,
    eye_gpu: &GpuRenderer,
    eye_gpu_ms: f64,
) -> Result<Option<ShadowBench>, String> {
    let Some(light) = &scene.appearance.light else {
        return Ok(None);
    };
    let size = shadow::shadow_map_size(scene.render.width, scene.render.height);
    let ls = shadow::light_scene(scene, light, size);
    let (map_ms, map, map_gpu) = timed(cfg, &ls, algo, depth)?;
    let t = Instant::now();
    let mask = shadow::shadow_test(
        scene,
        &shadow::DepthView {
            images: eye,
            camera: &scene.camera,
            precision: eye_gpu.precision(),
        },
        &shadow::DepthView {
            images: &map,
            camera: &ls.camera,
            precision: map_gpu.precision(),
        },
    );
    let test_ms = t.elapsed().as_secs_f64() * 1e3;
    let count = |v: bool| mask.iter().filter(|m| **m == Some(v)).count() as u64;
    Ok(Some(ShadowBench {
        map_size: size,
        light_map_gpu_ms_median: map_ms,
        eye_gpu_ms_median: eye_gpu_ms,
        shadow_test_cpu_ms: test_ms,
        lit_pixels: count(false),
        shadowed_pixels: count(true),
    }))
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
        s.push_str("## Shadows\n\n| scene | size | algo | depth | map side | light map GPU ms | eye GPU ms | shadow test CPU ms | lit px | shadowed px |\n|---|---|---|---|---|---|---|---|---|---|\n");
        for (r, b) in sh {
            let _ = writeln!(
                s,
                "| {} | {}×{} | {} | {} | {} | {:.2} | {:.2} | {:.1} | {} | {} |",
                r.scene,
                r.width,
                r.height,
                r.algo,
                r.depth_setup,
                b.map_size,
                b.light_map_gpu_ms_median,
                b.eye_gpu_ms_median,
                b.shadow_test_cpu_ms,
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
