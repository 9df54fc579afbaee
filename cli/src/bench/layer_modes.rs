//! `bench --modes`: the rendering modes the layer peelers make possible, timed
//! side by side — opaque, transparent (the first four layers, Hable & Rossignac §6),
//! the three blueprint styles of the same layers (Kirsch, Nienhaus & Döllner §5) and
//! highlighted — with the layers peeled and the CSTs run, as the CST paper's second
//! table (Hable & Rossignac §8: Prims, CSTs, Time) reports them, for CST-Z/I/G and
//! kirsch (whose CSTs are 0; it refuses highlight, which is then skipped with a
//! warning), with the last frame's submissions and recording time: each mode
//! keeps its renderer from frame to frame, so from the second frame on a
//! layered frame is one submission replayed (`render::sequence`).
//! Writes `modes.csv` and `modes.md`.
#![deny(unsafe_code)]

use std::fmt::Write as _;
use std::path::Path;

use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use super::{median_iqr, scene_label, BenchConfig, BenchError, BenchScene};
use peeltrim::plan::cst::{leaf_csts, Variant};
use peeltrim::plan::{self, Algo, Prepared};

use crate::render::layers::{render_layered_in, LayerOptions, LayeredSession};
use crate::render::{GpuRenderer, RenderOptions};
use peeltrim::scene::style::Style;

use peeltrim::vk::ExecStats;

/// The modes timed: the opaque image, its first four layers composited
/// (transparent, and in the three blueprint styles of Kirsch, Nienhaus & Döllner §5),
/// and a highlight of the first primitive.
pub const MODES: [&str; 6] = [
    "opaque",
    "transparent",
    "blueprint",
    "wireframe",
    "blueprint-transparent",
    "highlight",
];

/// Layers the transparent mode composites (the paper's "Transparent" row).
pub const TRANSPARENT_LAYERS: u32 = 4;
/// Opacity of every point in the transparent mode.
pub const TRANSPARENT_ALPHA: f64 = 0.5;

/// One mode of one scene and algorithm.
#[derive(Clone, Debug, Serialize)]
pub struct ModeRecord {
    pub scene: String,
    pub algo: String,
    /// One of [`MODES`].
    pub mode: &'static str,
    pub prims: usize,
    /// Layers of the image (1 for opaque).
    pub layers: u32,
    /// Layer plans run (entry and exit streams; 1 for opaque).
    pub stream_layers: u32,
    /// CSTs run.
    pub csts: u64,
    /// Bytes read back from the GPU (the opaque frame's images; the layers'
    /// and the composite's: a transparent frame composited on the GPU reads
    /// back layer 1 and the composite only).
    pub readback_bytes: u64,
    /// Queue submissions of the last frame (one from a
    /// session's second frame on; the interference view two).
    pub submits: u64,
    /// CPU ms recording the last frame (0: its kept recording replayed).
    pub record_ms: f64,
    /// Median over the frames of the GPU time of all the mode's plans.
    pub gpu_ms_median: f64,
    /// Median wall time of a frame, the device kept from frame to frame (its
    /// set-up, and the first frame's learning run layer by layer, only in
    /// the first frame).
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
        .filter(|a| matches!(a, Algo::CstZ | Algo::CstI | Algo::CstG | Algo::Kirsch))
        .collect();
    let &(w, h) = cfg.sizes.first().expect("at least one size");
    let total = (scenes.len() * algos.len() * MODES.len()) as u64;
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
        let mut scene = super::load_scene(&bs.path, (w, h))?;
        if scene.solids.is_empty() {
            bar.inc((MODES.len() * algos.len()) as u64);
            continue;
        }
        let label = scene_label(&bs.path);
        for &algo in &algos {
            let opts = RenderOptions {
                algo,
                device: cfg.device,
                depth: cfg.depth_setups[0],
                depth_fallback: cfg.depth_fallback,
                validation: cfg.validation,
                build: cfg.build.clone(),
            };
            for mode in MODES {
                bar.set_message(format!("{label}: {} {mode}", algo.name()));
                // One renderer for all frames of the mode: later frames replay.
                let mut session = LayeredSession::default();
                let mut opaque: Option<(GpuRenderer, peeltrim::plan::Plan)> = None;
                let mut gpu = Vec::new();
                let mut wall = Vec::new();
                let mut last = None;
                for _ in 0..cfg.frames.max(1) {
                    let t = std::time::Instant::now();
                    let r =
                        (|| -> Result<(ExecStats, u32, u32, u64, u64), Box<dyn std::error::Error>> {
                            Ok(match mode {
                                "opaque" => {
                                    scene.appearance.alpha = None;
                                    let prep = Prepared::new(&scene)?;
                                    if opaque.is_none() {
                                        let plan = plan::build_with(algo, &prep, &opts.build)?;
                                        opaque = Some((GpuRenderer::for_options(&scene, &opts)?, plan));
                                    }
                                    let (r, plan) = opaque.as_mut().expect("made above");
                                    let f = r.frame(plan)?;
                                    let variant = match algo {
                                        Algo::CstZ => Some(Variant::Z),
                                        Algo::CstI => Some(Variant::I),
                                        Algo::CstG => Some(Variant::G),
                                        _ => None,
                                    };
                                    let csts = variant.map_or(0, |v| {
                                        leaf_csts(
                                            &prep.positive,
                                            v,
                                            &prep.mesh_bounds,
                                            &prep.eye_inside,
                                        )
                                        .len() as u64
                                    });
                                    // Colour, ids and depth: 4 bytes each a pixel.
                                    let bytes = 12 * w as u64 * h as u64;
                                    (f.stats.exec, 1, 1, csts, bytes)
                                }
                                _ => {
                                    let highlight = mode == "highlight";
                                    let transparent = mode == "transparent";
                                    scene.appearance.alpha =
                                        transparent.then_some(TRANSPARENT_ALPHA);
                                    // The blueprint styles (Kirsch,
                                    // Nienhaus & Döllner §5) of the same layers.
                                    scene.appearance.style = match mode {
                                        "blueprint" => Style::Blueprint,
                                        "wireframe" => Style::Wireframe,
                                        "blueprint-transparent" => Style::BlueprintTransparent,
                                        _ => Style::Opaque,
                                    };
                                    let lopts = LayerOptions {
                                        max_layers: (!highlight).then_some(TRANSPARENT_LAYERS),
                                        highlight: if highlight { vec![0] } else { vec![] },
                                        ..Default::default()
                                    };
                                    let l = render_layered_in(&mut session, &scene, &opts, &lopts);
                                    scene.appearance.style = Style::Opaque;
                                    let l = l?;
                                    let s = &l.layer_stats;
                                    let g = s.gpu.clone().unwrap_or_default();
                                    (
                                        l.frame.stats.exec.clone(),
                                        s.layers,
                                        g.stream_layers,
                                        g.csts,
                                        g.readback_bytes,
                                    )
                                }
                            })
                        })();
                    let r = match r {
                        Ok(r) => r,
                        Err(e) => {
                            // An extra: a mode that cannot run is said and skipped.
                            // (`suspend`, not `println`: a hidden bar prints nothing.)
                            bar.suspend(|| {
                                eprintln!("peeltrim: warning: {label} {} {mode}: {e}", algo.name())
                            });
                            break;
                        }
                    };
                    wall.push(t.elapsed().as_secs_f64() * 1e3);
                    gpu.push(r.0.gpu_ms);
                    last = Some(r);
                }
                let Some((exec, layers, stream_layers, csts, readback_bytes)) = last else {
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
                    readback_bytes,
                    submits: exec.counts.submits,
                    record_ms: exec.record_ms,
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

/// The table of Hable & Rossignac §8's second kind: per scene, algorithm and mode.
pub fn table(records: &[ModeRecord]) -> String {
    let mut s = String::from(
        "| scene | prims | algo | mode | layers | layer plans | CSTs | read back KiB | submits | record ms | GPU ms | wall ms |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in records {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.2} | {:.1} | {:.1} |",
            r.scene,
            r.prims,
            r.algo,
            r.mode,
            r.layers,
            r.stream_layers,
            r.csts,
            r.readback_bytes / 1024,
            r.submits,
            r.record_ms,
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
        "scene,algo,mode,prims,layers,stream_layers,csts,readback_bytes,submits,record_ms,gpu_ms_median,wall_ms_median,frames\n",
    );
    for r in records {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{},{:.3},{:.3},{:.3},{}",
            r.scene,
            r.algo,
            r.mode,
            r.prims,
            r.layers,
            r.stream_layers,
            r.csts,
            r.readback_bytes,
            r.submits,
            r.record_ms,
            r.gpu_ms_median,
            r.wall_ms_median,
            r.frames
        );
    }
    std::fs::write(dir.join("modes.csv"), csv).map_err(io)?;
    let md = format!(
        "# Rendering modes (Hable & Rossignac §8, second table)\n\n\
         Transparent: the first {TRANSPARENT_LAYERS} layers at opacity {TRANSPARENT_ALPHA}; \
         highlight: the first primitive, every layer. CSTs: leaves peeled and trimmed, \
         summed over the layer plans.\n\n{}",
        table(records)
    );
    std::fs::write(dir.join("modes.md"), md).map_err(io)?;
    Ok(())
}
