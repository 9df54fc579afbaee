//! The performance issue's checks on a finished benchmark (issue 9, "Measure and
//! report"): the overhead of each run (replayed frames, wall time against GPU
//! time), the growth of each algorithm's cost over a scaling family (a least
//! squares slope and a log-log exponent), and the summary's section that states
//! them. Typed until `report` writes them.
#![deny(unsafe_code)]

use std::fmt::Write;

use serde::Serialize;

use super::report::error_figures;
use super::Record;

/// Wall time may exceed GPU time by this factor …
pub const WALL_FACTOR: f64 = 1.2;
/// … plus this many milliseconds.
pub const WALL_SLACK_MS: f64 = 0.5;
/// Interior coverage and primitive mismatches (fractions) a "correct" run may have.
pub const CORRECT_FRAC: f64 = 0.0005;

/// The overhead check of one run: every timed frame replayed its recording
/// (`record_ms` 0) and `frame_ms ≤ 1.2 × gpu_ms + 0.5`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Overhead {
    /// Timed frames that replayed their recording.
    pub replayed_frames: u32,
    /// `WALL_FACTOR × gpu_ms_median + WALL_SLACK_MS`.
    pub wall_limit_ms: f64,
    pub ok: bool,
}

impl Overhead {
    pub fn of(frames: u32, replayed_frames: u32, gpu_ms: f64, frame_ms: f64) -> Overhead {
        let wall_limit_ms = WALL_FACTOR * gpu_ms + WALL_SLACK_MS;
        Overhead {
            replayed_frames,
            wall_limit_ms,
            ok: replayed_frames == frames && frame_ms <= wall_limit_ms,
        }
    }
}

/// How one algorithm's `frame_ms` grows over one scaling family.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ScalingFit {
    /// Least-squares slope of `frame_ms` against n: milliseconds per primitive.
    pub slope_ms_per_n: f64,
    pub intercept_ms: f64,
    /// Slope of ln(frame_ms) against ln(n): 1 is linear growth.
    pub exponent: f64,
    /// The family sizes fitted.
    pub ns: Vec<u32>,
}

/// Least squares `y = a + b x`: `(a, b)`; `None` for fewer than two distinct x.
fn line(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (points.len() >= 2 && sxx > 0.0).then(|| (my - sxy / sxx * mx, sxy / sxx))
}

impl ScalingFit {
    /// The fit of `(n, frame_ms)` points; `None` for fewer than two sizes.
    pub fn of(points: &[(u32, f64)]) -> Option<ScalingFit> {
        let lin: Vec<(f64, f64)> = points.iter().map(|&(n, t)| (n as f64, t)).collect();
        let (intercept_ms, slope_ms_per_n) = line(&lin)?;
        let logs: Vec<(f64, f64)> = points
            .iter()
            .filter(|&&(n, t)| n > 0 && t > 0.0)
            .map(|&(n, t)| ((n as f64).ln(), t.ln()))
            .collect();
        let exponent = line(&logs).map(|(_, b)| b).unwrap_or(f64::NAN);
        Some(ScalingFit {
            slope_ms_per_n,
            intercept_ms,
            exponent,
            ns: points.iter().map(|p| p.0).collect(),
        })
    }
}

/// Whether a run is correct by the definition.
pub fn correct(r: &Record) -> bool {
    let (cov, prim, _) = error_figures(r);
    r.failure.is_none() && cov <= CORRECT_FRAC && prim <= CORRECT_FRAC
}

/// Runs of one algorithm over one family at one size and depth set-up.
fn family_key(r: &Record) -> Option<(String, String, String, u32, u32)> {
    let fam = r.family.clone()?;
    Some((
        fam,
        r.algo.clone(),
        r.depth_setup.clone(),
        r.width,
        r.height,
    ))
}

/// Fills each family run's `scaling` with the fit over its algorithm's runs of
/// that family (runs that failed are left out).
pub fn fit_families(records: &mut [Record]) {
    let keys: Vec<_> = records.iter().filter_map(family_key).collect();
    for key in keys {
        let points: Vec<(u32, f64)> = records
            .iter()
            .filter(|r| family_key(r).as_ref() == Some(&key) && r.failure.is_none())
            .filter_map(|r| Some((r.n?, r.frame_ms_median)))
            .collect();
        let fit = ScalingFit::of(&points);
        for r in records
            .iter_mut()
            .filter(|r| family_key(r).as_ref() == Some(&key))
        {
            r.scaling = fit.clone();
        }
    }
}

/// The summary's section: overhead, scaling and deep-tree figures.
pub fn section(records: &[Record]) -> String {
    let mut s = String::from("## Performance checks (issue 9)\n\n");
    let runs: Vec<&Record> = records.iter().filter(|r| r.overhead.is_some()).collect();
    let ok = runs
        .iter()
        .filter(|r| r.overhead.as_ref().is_some_and(|o| o.ok))
        .count();
    let _ = writeln!(
        s,
        "Overhead: {ok} of {} runs replay every timed frame (`record_ms` 0) with `frame_ms` ≤ {WALL_FACTOR} × `gpu_ms` + {WALL_SLACK_MS} ms.",
        runs.len()
    );
    let failing: Vec<&&Record> = runs
        .iter()
        .filter(|r| r.overhead.as_ref().is_some_and(|o| !o.ok))
        .collect();
    if !failing.is_empty() {
        s.push_str("\n| scene | algo | frames replayed | gpu ms | frame ms | limit ms |\n|---|---|---|---|---|---|\n");
        for r in failing {
            let o = r.overhead.as_ref().expect("filtered");
            let _ = writeln!(
                s,
                "| {} | {} | {}/{} | {:.2} | {:.2} | {:.2} |",
                r.scene,
                r.algo,
                o.replayed_frames,
                r.frames,
                r.gpu_ms_median,
                r.frame_ms_median,
                o.wall_limit_ms
            );
        }
    }
    let recorded: Vec<&Record> = runs
        .iter()
        .copied()
        .filter(|r| r.rerecord_ms > 0.0)
        .collect();
    if !recorded.is_empty() {
        let mut per_draw: Vec<f64> = recorded.iter().map(|r| r.rerecord_us_per_draw).collect();
        per_draw.sort_by(f64::total_cmp);
        let moved = recorded
            .iter()
            .filter(|r| r.camera_move_record_ms == 0.0)
            .count();
        let _ = writeln!(
            s,
            "\nRecording anew: median {:.2} µs per draw (max {:.2}) over {} runs; the second frame of an orbit by two steps of {}°/2 replayed without recording in {moved} of them.",
            per_draw[per_draw.len() / 2],
            per_draw[per_draw.len() - 1],
            recorded.len(),
            super::CAMERA_NUDGE_DEG
        );
    }
    s.push_str(&scaling_table(records));
    s.push('\n');
    s
}

/// Per family: each algorithm's fit, the best correct algorithm at the largest n
/// marked.
fn scaling_table(records: &[Record]) -> String {
    let mut s = String::new();
    let mut families: Vec<(String, String, u32, u32)> = records
        .iter()
        .filter(|r| r.algo != "reference")
        .filter_map(|r| Some((r.family.clone()?, r.depth_setup.clone(), r.width, r.height)))
        .collect();
    families.sort();
    families.dedup();
    for (fam, depth, w, h) in families {
        let rows: Vec<&Record> = records
            .iter()
            .filter(|r| {
                r.family.as_deref() == Some(&fam)
                    && r.depth_setup == depth
                    && r.width == w
                    && r.height == h
                    && r.algo != "reference"
            })
            .collect();
        let n_max = rows.iter().filter_map(|r| r.n).max().unwrap_or(0);
        let best = rows
            .iter()
            .filter(|r| r.n == Some(n_max) && correct(r))
            .min_by(|a, b| a.frame_ms_median.total_cmp(&b.frame_ms_median));
        let _ = writeln!(
            s,
            "\n{fam} ({w}×{h}, {depth}): `frame_ms` against n (least squares), best correct at n = {n_max}: {}.\n",
            best.map(|r| format!("{} ({:.2} ms)", r.algo, r.frame_ms_median))
                .unwrap_or_else(|| "none".into())
        );
        s.push_str("| algo | ms per n | intercept ms | exponent | n | frame ms at largest n |\n|---|---|---|---|---|---|\n");
        let mut algos: Vec<&str> = Vec::new();
        for r in &rows {
            if !algos.contains(&r.algo.as_str()) {
                algos.push(&r.algo);
            }
        }
        for a in algos {
            let at_max = rows.iter().find(|r| r.algo == a && r.n == Some(n_max));
            let fit = rows
                .iter()
                .find_map(|r| (r.algo == a).then_some(r.scaling.as_ref()).flatten());
            let mark = if best.is_some_and(|b| b.algo == a) {
                " (best)"
            } else {
                ""
            };
            let t = at_max
                .filter(|r| r.failure.is_none())
                .map(|r| format!("{:.2}", r.frame_ms_median))
                .unwrap_or_else(|| "-".into());
            match fit {
                Some(f) => {
                    let _ = writeln!(
                        s,
                        "| {a}{mark} | {:.4} | {:.2} | {:.2} | {} | {t} |",
                        f.slope_ms_per_n,
                        f.intercept_ms,
                        f.exponent,
                        f.ns.iter()
                            .map(u32::to_string)
                            .collect::<Vec<_>>()
                            .join(", ")
                    );
                }
                None => {
                    let _ = writeln!(s, "| {a}{mark} | - | - | - | - | {t} |");
                }
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_linear_cost_fits_its_slope_and_exponent_one() {
        let f = ScalingFit::of(&[(16, 3.0 + 0.5 * 16.0), (64, 35.0), (256, 131.0)]).unwrap();
        assert!((f.slope_ms_per_n - 0.5).abs() < 1e-9, "{f:?}");
        assert!((f.intercept_ms - 3.0).abs() < 1e-9);
        let g = ScalingFit::of(&[(10, 2.0), (100, 20.0), (1000, 200.0)]).unwrap();
        assert!((g.exponent - 1.0).abs() < 1e-9, "{g:?}");
        let q = ScalingFit::of(&[(10, 1.0), (100, 100.0)]).unwrap();
        assert!((q.exponent - 2.0).abs() < 1e-9);
        assert_eq!(ScalingFit::of(&[(10, 1.0)]), None);
    }

    #[test]
    fn overhead_needs_every_frame_replayed_and_wall_near_gpu() {
        assert!(Overhead::of(5, 5, 10.0, 12.4).ok);
        assert!(!Overhead::of(5, 5, 10.0, 12.6).ok);
        assert!(!Overhead::of(5, 4, 10.0, 10.0).ok);
    }
}
