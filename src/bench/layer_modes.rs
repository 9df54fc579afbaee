//! `bench --modes`: the rendering modes CST makes possible, timed side by side —
//! opaque, transparent (the first four layers, seed 000 §6) and highlighted —
//! with the layers peeled and the CSTs run, as the paper's second table
//! (seed 000 §8: Prims, CSTs, Time) reports them. Writes `modes.csv` and
//! `modes.md`.
#![deny(unsafe_code)]

use std::fmt::Write as _;
use std::path::Path;

use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use super::{median_iqr, scene_label, BenchConfig, BenchError, BenchScene};
use crate::plan::cst::{leaf_csts, Variant};
use crate::plan::{Algo, Prepared};
use crate::render::layers::{render_layered, LayerOptions};
use crate::render::{self, RenderOptions};
use crate::scene::{self, LoadOptions};

/// Layers the transparent mode composites (the paper's "Transparent" row).
pub const TRANSPARENT_LAYERS: u32 = 4;
/// Opacity of every point in the transparent mode.
pub const TRANSPARENT_ALPHA: f64 = 0.5;

/// One mode of one scene and algorithm.
#[derive(Clone, Debug, Serialize)]
pub struct ModeRecord {
    pub scene: String,
    pub algo: String,
    /// `opaque`, `transparent` or `highlight`.
    pub mode: &'static str,
    pub prims: usize,
    /// Layers of the image (1 for opaque).
    pub layers: u32,
    /// Layer plans run (entry and exit streams; 1 for opaque).
    pub stream_layers: u32,
    /// CSTs run.
    pub csts: u64,
    /// Median over the frames of the GPU time of all the mode's plans.
    pub gpu_ms_median: f64,
    /// Median wall time of the whole mode (device set-up included).
    pub wall_ms_median: f64,
    pub frames: u32,
}

/// Runs the modes of every scene with every CST algorithm of `cfg` (others have
/// no layers).
pub fn run(cfg: &BenchConfig, scenes: &[BenchScene]) -> Result<Vec<ModeRecord>, BenchError> {
    let algos: Vec<Algo> = cfg
        .algos
        .iter()
        .copied()
        .filter(|a| matches!(a, Algo::CstZ | Algo::CstI | Algo::CstG))
        .collect();
    let &(w, h) = cfg.sizes.first().expect("at least one size");
    let total = (scenes.len() * algos.len() * 3) as u64;
    let bar = if cfg.progress {
        ProgressBar::new(total)
    } else {
        ProgressBar::hidden()
    };
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} modes {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    let mut out = Vec::new();
    for bs in scenes {
        let mut scene =
            scene::load(&bs.path, &LoadOptions { size: Some((w, h)) }).map_err(|source| {
                BenchError::Scene {
                    path: bs.path.clone(),
                    source,
                }
            })?;
        if scene.solids.is_empty() {
            bar.inc(3 * algos.len() as u64);
            continue;
        }
        let label = scene_label(&bs.path);
        for &algo in &algos {
            let opts = RenderOptions {
                algo,
                device: cfg.device,
                depth: cfg.depth_setups[0],
                depth_fallback: true,
                validation: cfg.validation,
                build: cfg.build.clone(),
            };
            for mode in ["opaque", "transparent", "highlight"] {
                bar.set_message(format!("{label}: {} {mode}", algo.name()));
                let mut gpu = Vec::new();
                let mut wall = Vec::new();
                let mut last = None;
                for _ in 0..cfg.frames.max(1) {
                    let t = std::time::Instant::now();
                    let r = (|| -> Result<(f64, u32, u32, u64), Box<dyn std::error::Error>> {
                        Ok(match mode {
                            "opaque" => {
                                scene.appearance.alpha = None;
                                let f = render::render(&scene, &opts)?;
                                let prep = Prepared::new(&scene)?;
                                let variant = match algo {
                                    Algo::CstZ => Variant::Z,
                                    Algo::CstI => Variant::I,
                                    _ => Variant::G,
                                };
                                let csts = leaf_csts(
                                    &prep.positive,
                                    variant,
                                    &prep.mesh_bounds,
                                    &prep.eye_inside,
                                )
                                .len() as u64;
                                (f.stats.exec.gpu_ms, 1, 1, csts)
                            }
                            _ => {
                                let transparent = mode == "transparent";
                                scene.appearance.alpha = transparent.then_some(TRANSPARENT_ALPHA);
                                let lopts = LayerOptions {
                                    max_layers: transparent.then_some(TRANSPARENT_LAYERS),
                                    highlight: if transparent { vec![] } else { vec![0] },
                                    ..Default::default()
                                };
                                let l = render_layered(&scene, &opts, &lopts)?;
                                let s = &l.layer_stats;
                                (
                                    l.frame.stats.exec.gpu_ms,
                                    s.layers,
                                    s.stream_layers.unwrap_or(0),
                                    s.csts.unwrap_or(0),
                                )
                            }
                        })
                    })();
                    let r = match r {
                        Ok(r) => r,
                        Err(e) => {
                            // An extra: a mode that cannot run is said and skipped.
                            bar.println(format!(
                                "peeltrim: warning: {label} {} {mode}: {e}",
                                algo.name()
                            ));
                            break;
                        }
                    };
                    wall.push(t.elapsed().as_secs_f64() * 1e3);
                    gpu.push(r.0);
                    last = Some(r);
                }
                let Some((_, layers, stream_layers, csts)) = last else {
                    bar.inc(1);
                    continue;
                };
                out.push(ModeRecord {
                    scene: label.clone(),
                    algo: algo.name().to_string(),
                    mode,
                    prims: scene.primitives.len(),
                    layers,
                    stream_layers,
                    csts,
                    gpu_ms_median: median_iqr(&mut gpu).0,
                    wall_ms_median: median_iqr(&mut wall).0,
                    frames: gpu.len() as u32,
                });
                bar.inc(1);
            }
        }
        scene.appearance.alpha = None;
    }
    bar.finish_and_clear();
    Ok(out)
}

/// The table of seed 000 §8's second kind: per scene, algorithm and mode.
pub fn table(records: &[ModeRecord]) -> String {
    let mut s = String::from(
        "| scene | prims | algo | mode | layers | layer plans | CSTs | GPU ms | wall ms |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for r in records {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {:.1} | {:.1} |",
            r.scene,
            r.prims,
            r.algo,
            r.mode,
            r.layers,
            r.stream_layers,
            r.csts,
            r.gpu_ms_median,
            r.wall_ms_median
        );
    }
    s
}

/// Writes `modes.csv` and `modes.md` into `dir`.
pub fn write(dir: &Path, records: &[ModeRecord]) -> Result<(), BenchError> {
    let io =
        |e: std::io::Error| BenchError::Other(format!("writing modes into {}: {e}", dir.display()));
    let mut csv = String::from(
        "scene,algo,mode,prims,layers,stream_layers,csts,gpu_ms_median,wall_ms_median,frames\n",
    );
    for r in records {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{:.3},{:.3},{}",
            r.scene,
            r.algo,
            r.mode,
            r.prims,
            r.layers,
            r.stream_layers,
            r.csts,
            r.gpu_ms_median,
            r.wall_ms_median,
            r.frames
        );
    }
    std::fs::write(dir.join("modes.csv"), csv).map_err(io)?;
    let md = format!(
        "# Rendering modes (seed 000 §8, second table)\n\n\
         Transparent: the first {TRANSPARENT_LAYERS} layers at opacity {TRANSPARENT_ALPHA}; \
         highlight: the first primitive, every layer. CSTs: leaves peeled and trimmed, \
         summed over the layer plans.\n\n{}",
        table(records)
    );
    std::fs::write(dir.join("modes.md"), md).map_err(io)?;
    Ok(())
}
