//! Benchmark outputs: `results.json` (every figure of every run), `results.csv`,
//! and `summary.md` (a table per scene, plus the CST paper's timing table side by
//! side with ours as ratios to Blister, since absolute times on another machine
//! mean little).
#![deny(unsafe_code)]

use std::fmt::Write;
use std::path::Path;

use serde::Serialize;

use super::{BenchError, Record};
use peeltrim::vk::Counts;
use peeltrim_reference::compare::CompareReport;

/// The CST paper's §8 table (GeForce 6800 GT, 800×800): Prims, Blister, Z, I, G in ms.
pub const PAPER_TABLE: [(&str, u32, [f64; 4]); 2] = [
    ("complex", 20, [121.0, 96.0, 92.0, 100.0]),
    ("gear", 48, [481.0, 382.0, 312.0, 179.0]),
];

/// Interior coverage and primitive mismatches (fractions) and depth p99 of a
/// run; NaN for a run without an error report.
pub fn error_figures(r: &Record) -> (f64, f64, f64) {
    match &r.error {
        Some(e) => (
            e.coverage_mismatch_interior_frac,
            e.prim_mismatch_interior_frac,
            e.depth_abs_err_p99,
        ),
        None => (f64::NAN, f64::NAN, f64::NAN),
    }
}

/// A count of a GPU run's last frame, as written; `None` for a run without
/// frame counts (failed, skipped, the reference, a baseline).
pub fn frame_count(r: &Record, of: CountOf) -> Option<String> {
    Some(of(r.counts.as_ref()?.frame()?).to_string())
}

/// A figure read off a frame's counts.
type CountOf = fn(&Counts) -> u64;

/// A figure read off a compare report.
type ErrorOf = fn(&CompareReport) -> f64;

/// The frame counts the CSV and summary tables show, by column name.
const FRAME_COUNTS: [(&str, CountOf); 6] = [
    ("draws", |c| c.draws),
    ("mesh_draws", |c| c.mesh_draws),
    ("fullscreen_passes", |c| c.fullscreen_passes),
    ("triangles", |c| c.triangles),
    ("fullscreen_pixels", |c| c.fullscreen_pixels),
    ("samples_counted", |c| c.samples_counted),
];

/// The error columns of the CSV, by column name.
const CSV_ERRORS: [(&str, ErrorOf); 7] = [
    ("coverage_mismatch_frac", |e| e.coverage_mismatch_frac),
    ("prim_mismatch_frac", |e| e.prim_mismatch_frac),
    ("coverage_mismatch_interior_frac", |e| {
        e.coverage_mismatch_interior_frac
    }),
    ("prim_mismatch_interior_frac", |e| {
        e.prim_mismatch_interior_frac
    }),
    ("depth_abs_err_max", |e| e.depth_abs_err_max),
    ("depth_abs_err_p99", |e| e.depth_abs_err_p99),
    ("depth_abs_err_mean", |e| e.depth_abs_err_mean),
];

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> BenchError + '_ {
    move |source| BenchError::Io {
        path: path.to_path_buf(),
        source,
    }
}

pub fn write_all(out: &Path, records: &[Record]) -> Result<(), BenchError> {
    let p = out.join("results.json");
    let json =
        serde_json::to_string_pretty(records).map_err(|e| BenchError::Other(e.to_string()))?;
    std::fs::write(&p, json).map_err(io(&p))?;
    let p = out.join("results.csv");
    std::fs::write(&p, csv(records)).map_err(io(&p))?;
    let p = out.join("summary.md");
    std::fs::write(&p, summary(records)).map_err(io(&p))?;
    Ok(())
}

pub fn csv(records: &[Record]) -> String {
    let mut s = String::from(
        "scene,family,n,prims,width,height,algo,depth_setup,device,frames,gpu_ms_median,gpu_ms_min,gpu_ms_max,gpu_ms_iqr,cpu_ms_median,cpu_ms_iqr,frame_ms_median,frame_ms_iqr,record_ms_median,rerecord_ms",
    );
    for (c, _) in FRAME_COUNTS {
        let _ = write!(s, ",{c}");
    }
    for (e, _) in CSV_ERRORS {
        let _ = write!(s, ",{e}");
    }
    s.push_str(
        ",failure,embedded_frame_ms_median,embedded_ratio,embedded_cpu_ratio,est_s,skipped\n",
    );
    for r in records {
        let _ = write!(
            s,
            "{},{},{},{},{},{},{},{},\"{}\",{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
            r.scene,
            r.family.as_deref().unwrap_or(""),
            r.n.map(|n| n.to_string()).unwrap_or_default(),
            r.prims,
            r.width,
            r.height,
            r.algo,
            r.depth_setup,
            r.device.replace('"', "'"),
            r.frames,
            r.gpu_ms_median,
            r.gpu_ms_min,
            r.gpu_ms_max,
            r.gpu_ms_iqr,
            r.cpu_ms_median,
            r.cpu_ms_iqr,
            r.frame_ms_median,
            r.frame_ms_iqr,
            r.record_ms_median,
            r.rerecord_ms
        );
        for (_, of) in FRAME_COUNTS {
            let _ = write!(s, ",{}", frame_count(r, of).unwrap_or_default());
        }
        for (_, of) in CSV_ERRORS {
            // As JSON writes the figure: `null` where it is not finite.
            let v = r.error.as_ref().map(|e| serde_json::Value::from(of(e)));
            let _ = write!(s, ",{}", v.map(|v| v.to_string()).unwrap_or_default());
        }
        let (e_ms, e_ratio, e_cpu) = match &r.embedded {
            Some(e) => (
                format!("{:.4}", e.frame_ms_median),
                format!("{:.4}", e.ratio),
                format!("{:.4}", e.cpu_ratio),
            ),
            None => Default::default(),
        };
        let est = r
            .estimate
            .as_ref()
            .map(|e| format!("{:.4}", e.seconds))
            .unwrap_or_default();
        let _ = writeln!(
            s,
            ",\"{}\",{e_ms},{e_ratio},{e_cpu},{est},\"{}\"",
            r.failure.as_deref().unwrap_or("").replace('"', "'"),
            r.skipped.as_deref().unwrap_or("").replace('"', "'")
        );
    }
    s
}

/// Markdown (with `bench --embedded`): each run's standalone and embedded
/// `frame_ms` and their ratio; empty without embedded runs.
pub fn embedded_table(records: &[Record]) -> String {
    let rows: Vec<_> = records
        .iter()
        .filter_map(|r| r.embedded.as_ref().map(|e| (r, e)))
        .collect();
    if rows.is_empty() {
        return String::new();
    }
    let mut s = String::from("## Embedded path (`--embedded`)\n\nStandalone and embedded frames in pairs (order alternating; the host's clear submitted apart, untimed); ratios: medians over the pairs of embedded over standalone, of wall time from submission to completion (`frame ms`) and of the process's CPU time over it (`cpu ms`, all threads).\n\n| scene | algo | depth | pairs | standalone frame ms | embedded frame ms | ratio | standalone cpu ms | embedded cpu ms | cpu ratio | embedded record ms |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (r, e) in rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.2} | {:.2} | {:.3} | {:.2} | {:.2} | {:.3} | {:.2} |",
            r.scene,
            r.algo,
            r.depth_setup,
            e.pairs,
            e.standalone_frame_ms_median,
            e.frame_ms_median,
            e.ratio,
            e.standalone_frame_cpu_ms_median,
            e.frame_cpu_ms_median,
            e.cpu_ratio,
            e.record_ms_median
        );
    }
    s.push('\n');
    s
}

/// Markdown: one table per scene and size, then the paper's table.
pub fn summary(records: &[Record]) -> String {
    let mut s = String::from("# peeltrim benchmark\n\n");
    if let Some(r) = records
        .iter()
        .find(|r| !r.device.is_empty() && r.algo != "reference")
    {
        let _ = writeln!(s, "Device: {}. GPU times are medians over {} frames (timestamp queries); spread is the interquartile range. Errors are against the exact reference: interior coverage / primitive mismatches as % of pixels, depth p99 in scene units.\n", r.device, r.frames);
    }
    let mut keys: Vec<(String, u32, u32)> = Vec::new();
    for r in records {
        let k = (r.scene.clone(), r.width, r.height);
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (scene, w, h) in &keys {
        let rows: Vec<&Record> = records
            .iter()
            .filter(|r| &r.scene == scene && r.width == *w && r.height == *h)
            .collect();
        let prims = rows.first().map(|r| r.prims).unwrap_or(0);
        let _ = writeln!(s, "## {scene} ({prims} primitives, {w}×{h})\n");
        s.push_str("| algo | depth | GPU ms (median ± IQR) | frame ms | record ms | CPU ms | draws | triangles | full-screen passes | cov. mism. % | prim mism. % | depth p99 |\n");
        s.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|\n");
        for r in rows {
            // A run without figures: why, in the first figure's column.
            let why = match (&r.skipped, &r.failure) {
                (Some(why), _) => Some(why.clone()),
                (None, Some(f)) => Some(format!("not run: {f}")),
                (None, None) => None,
            };
            if let Some(why) = why {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | | | | | | | | | |",
                    r.algo,
                    r.depth_setup,
                    why.replace('|', "/")
                );
                continue;
            }
            let (cov, prim, d99) = error_figures(r);
            let c = |of: CountOf| frame_count(r, of).unwrap_or_else(|| "-".into());
            let _ = writeln!(
                s,
                "| {}{} | {} | {:.2} ± {:.2} | {:.2} | {:.2} | {:.1} | {} | {} | {} | {:.3} | {:.3} | {:.2e} |",
                r.algo,
                if r.auto_pick { " (auto)" } else { "" },
                r.depth_setup,
                r.gpu_ms_median,
                r.gpu_ms_iqr,
                r.frame_ms_median,
                r.record_ms_median,
                r.cpu_ms_median,
                c(|c| c.draws),
                c(|c| c.triangles),
                c(|c| c.fullscreen_passes),
                cov * 100.0,
                prim * 100.0,
                d99
            );
        }
        s.push('\n');
    }
    s.push_str(&auto_table(records));
    s.push_str(&super::checks::section(records));
    s.push_str(&super::modes::summary(records));
    s.push_str(&super::opencsg::side_by_side(records));
    s.push_str(&super::floor::section(records));
    s.push_str(&embedded_table(records));
    s.push_str(&paper_table(records));
    s
}

/// Whether a run is correct for the `auto` table: it ran, and its interior
/// coverage and primitive mismatches are within [`AUTO_TOLERANCE`] of the
/// lowest any run of the same scene, size and depth set-up reached.
fn correct(r: &Record, rows: &[&Record]) -> bool {
    let best = |f: fn(&Record) -> f64| {
        rows.iter()
            .filter(|x| x.ran() && x.error.is_some())
            .map(|x| f(x))
            .fold(f64::INFINITY, f64::min)
    };
    let (cov, prim, _) = error_figures(r);
    r.ran()
        && r.error.is_some()
        && cov <= best(|x| error_figures(x).0) + AUTO_TOLERANCE
        && prim <= best(|x| error_figures(x).1) + AUTO_TOLERANCE
}

/// The time the auto table compares: on a software rasterizer (lavapipe) the
/// process's CPU time over the frame (`frame_cpu_ms`: the rasterizer's work,
/// steady on a loaded machine, where wall time varies severalfold), else the
/// frame's wall time.
pub fn auto_ms(r: &Record) -> f64 {
    if r.device.contains("llvmpipe") || r.device.contains("lavapipe") {
        r.frame_cpu_ms_median
    } else {
        r.frame_ms_median
    }
}

/// Mismatch (fraction of the pixels) a run may have above the best run of its
/// scene and still count as correct: 0.001 %, under one pixel in 100,000.
pub const AUTO_TOLERANCE: f64 = 1e-5;

/// One row of the `auto` table: per scene, size and depth set-up, auto's pick
/// against the fastest correct run (frame time, median).
#[derive(Clone, Debug, Serialize)]
pub struct AutoRow {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub depth_setup: String,
    pub picked: String,
    pub picked_ms: f64,
    pub picked_correct: bool,
    pub fastest: String,
    pub fastest_ms: f64,
    /// picked_ms / fastest_ms.
    pub slowdown: f64,
    /// The pick ran the fastest's plan (CST-G is CST-I's plan where its
    /// counter pays for no group): a hit, whatever the timing noise.
    pub same_plan: bool,
    /// The fastest correct run of the algorithms auto may pick.
    pub fastest_candidate: Option<String>,
    pub fastest_candidate_ms: Option<f64>,
    /// The pick is that run, or runs its plan.
    pub candidate_hit: bool,
}

impl AutoRow {
    /// Whether auto picked the fastest correct run (or its very plan).
    pub fn hit(&self) -> bool {
        self.picked == self.fastest || self.same_plan
    }
}

/// The `auto` rows of a bench (scenes where auto picked an algorithm that ran).
pub fn auto_rows(records: &[Record]) -> Vec<AutoRow> {
    let mut out = Vec::new();
    let mut keys: Vec<(String, u32, u32, String)> = Vec::new();
    for r in records {
        let k = (r.scene.clone(), r.width, r.height, r.depth_setup.clone());
        if r.auto_pick && !keys.contains(&k) {
            keys.push(k);
        }
    }
    for (scene, w, h, depth) in keys {
        let rows: Vec<&Record> = records
            .iter()
            .filter(|r| {
                r.scene == scene
                    && r.width == w
                    && r.height == h
                    && r.algo != "reference"
                    && (r.depth_setup == depth || r.algo == "opencsg")
            })
            .collect();
        let Some(picked) = rows.iter().find(|r| r.auto_pick && r.ran()) else {
            continue;
        };
        let Some(fastest) = rows
            .iter()
            .filter(|r| r.algo != "opencsg" && correct(r, &rows))
            .min_by(|a, b| auto_ms(a).total_cmp(&auto_ms(b)))
        else {
            continue;
        };
        let cand = rows
            .iter()
            .filter(|r| {
                peeltrim::plan::Algo::parse(&r.algo).is_some_and(crate::auto::speckle_free)
                    && correct(r, &rows)
            })
            .min_by(|a, b| auto_ms(a).total_cmp(&auto_ms(b)));
        out.push(AutoRow {
            fastest_candidate: cand.map(|c| c.algo.clone()),
            fastest_candidate_ms: cand.map(|c| auto_ms(c)),
            candidate_hit: cand.is_some_and(|c| {
                c.algo == picked.algo
                    || (!c.plan_digest.is_empty() && c.plan_digest == picked.plan_digest)
            }),
            scene: scene.clone(),
            width: w,
            height: h,
            depth_setup: depth.clone(),
            picked: picked.algo.clone(),
            picked_ms: auto_ms(picked),
            picked_correct: correct(picked, &rows),
            fastest: fastest.algo.clone(),
            fastest_ms: auto_ms(fastest),
            slowdown: auto_ms(picked) / auto_ms(fastest).max(1e-9),
            same_plan: !picked.plan_digest.is_empty() && picked.plan_digest == fastest.plan_digest,
        });
    }
    out
}

/// Markdown: how often `--algo auto` picked the fastest correct algorithm.
pub fn auto_table(records: &[Record]) -> String {
    let rows = auto_rows(records);
    if rows.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "## --algo auto against the fastest correct run

",
    );
    s.push_str("Times are medians: on lavapipe the process's CPU time over a frame (`frame_cpu_ms`, the rasterizer's work, steady on a loaded machine), else the frame's wall time (`frame_ms`). Correct: interior coverage and primitive mismatches within 0.001 % of the pixels of the best run of the scene. Auto picks among the speckle-free algorithms by the plan's estimate; it cannot pick an algorithm the bench did not run. A pick that runs the fastest's very plan counts as a hit.

");
    s.push_str("| scene | size | auto picks | its ms | correct | fastest correct candidate | its ms | fastest correct | its ms | auto / fastest |\n|---|---|---|---|---|---|---|---|---|---|\n");
    for r in &rows {
        let _ = writeln!(
            s,
            "| {} | {}×{} | {}{} | {:.2} | {} | {} | {} | {} | {:.2} | {:.2} |",
            r.scene,
            r.width,
            r.height,
            r.picked,
            if r.same_plan && r.picked != r.fastest {
                " (same plan)"
            } else {
                ""
            },
            r.picked_ms,
            if r.picked_correct { "yes" } else { "no" },
            r.fastest_candidate.as_deref().unwrap_or("-"),
            r.fastest_candidate_ms
                .map_or("-".into(), |m| format!("{m:.2}")),
            r.fastest,
            r.fastest_ms,
            r.slowdown
        );
    }
    let cand_hits = rows.iter().filter(|r| r.candidate_hit).count();
    let _ = writeln!(
        s,
        "\nAuto picked the fastest correct of the algorithms it may pick (cst-i, cst-z, cst-g, blister, goldfeather, goldfeather-layered: those that ran) on {cand_hits} of {} scenes.",
        rows.len()
    );
    let hits = rows.iter().filter(|r| r.hit()).count();
    let misses: Vec<f64> = rows
        .iter()
        .filter(|r| !r.hit())
        .map(|r| r.slowdown)
        .collect();
    let _ = write!(
        s,
        "Auto picked the fastest correct run of all on {hits} of {} scenes",
        rows.len()
    );
    if !misses.is_empty() {
        let mean = misses.iter().sum::<f64>() / misses.len() as f64;
        let worst = misses.iter().cloned().fold(0.0, f64::max);
        let _ = write!(
            s,
            "; where it did not, its pick took {mean:.2}× the fastest's time on average (worst {worst:.2}×)"
        );
    }
    s.push_str(
        ".

",
    );
    s
}

/// The CST paper's table next to ours (same depth set-up, largest size run).
pub fn paper_table(records: &[Record]) -> String {
    let mut s = String::from("## The CST paper's table, side by side\n\n");
    s.push_str("Paper: GeForce 6800 GT, 800×800, ms. Ours: median GPU ms on this device; ratios are to Blister in the same row.\n\n");
    s.push_str("| model | prims | source | Blister | Z | I | G | Z/B | I/B | G/B |\n|---|---|---|---|---|---|---|---|---|---|\n");
    let mut any = false;
    for (name, prims, t) in PAPER_TABLE {
        let _ = writeln!(
            s,
            "| {name} | {prims} | paper | {} | {} | {} | {} | {:.2} | {:.2} | {:.2} |",
            t[0],
            t[1],
            t[2],
            t[3],
            t[1] / t[0],
            t[2] / t[0],
            t[3] / t[0]
        );
        let ours: Vec<&Record> = records
            .iter()
            .filter(|r| r.scene == name && r.ran())
            .collect();
        let mut setups: Vec<(&str, u32, u32)> = ours
            .iter()
            .map(|r| (r.depth_setup.as_str(), r.width, r.height))
            .collect();
        setups.sort();
        setups.dedup();
        for (depth, w, h) in setups {
            let get = |a: &str| {
                ours.iter()
                    .find(|r| {
                        r.algo == a && r.depth_setup == depth && r.width == w && r.height == h
                    })
                    .map(|r| r.gpu_ms_median)
            };
            let (b, z, i, g) = (get("blister"), get("cst-z"), get("cst-i"), get("cst-g"));
            let f = |x: Option<f64>| x.map(|v| format!("{v:.1}")).unwrap_or_else(|| "-".into());
            let ratio = |x: Option<f64>| match (x, b) {
                (Some(x), Some(b)) if b > 0.0 => format!("{:.2}", x / b),
                _ => "-".into(),
            };
            if b.is_none() && z.is_none() && i.is_none() && g.is_none() {
                continue;
            }
            any = true;
            let prims_ours = ours.first().map(|r| r.prims).unwrap_or(0);
            let _ = writeln!(
                s,
                "| {name} | {prims_ours} | ours {w}×{h} {depth} | {} | {} | {} | {} | {} | {} | {} |",
                f(b),
                f(z),
                f(i),
                f(g),
                ratio(z),
                ratio(i),
                ratio(g)
            );
        }
    }
    if !any {
        s.push_str("\n(no run of the shipped complex/gear scenes with blister or cst-* in this benchmark)\n");
    }
    s
}
