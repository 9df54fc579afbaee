//! Scaling families (block minus n spheres should grow no faster than n·k; the
//! fitted slope is reported): each algorithm's cost over a family fitted by least
//! squares (ms per primitive) and in log-log (the exponent of n; 1 is linear), of
//! wall time, GPU time and the process's CPU time, and the summary's tables: the
//! fits with the best correct algorithm's verdict, and every run's figures per n
//! (skipped runs with their estimates).
#![deny(unsafe_code)]

use std::fmt::Write;

use serde::Serialize;

use super::checks::correct;
use super::report::frame_count;
use super::Record;

/// How one algorithm's cost grows over one scaling family.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ScalingFit {
    /// Least-squares slope of `frame_ms` against n: milliseconds per primitive.
    pub slope_ms_per_n: f64,
    pub intercept_ms: f64,
    /// Slope of ln(frame_ms) against ln(n): 1 is linear growth.
    pub exponent: f64,
    /// The same exponent of `gpu_ms` (timestamps) …
    pub gpu_exponent: f64,
    /// … and of the process's CPU time per frame (`frame_cpu_ms`: on lavapipe
    /// the rasterizer's work, steadier than wall time on a loaded machine).
    pub cpu_exponent: f64,
    /// The family sizes fitted.
    pub ns: Vec<u32>,
}

/// An exponent at most this far above 1 still counts as linear growth (n·k
/// with k fixed): fixed costs flatten small n, noise bends large n.
pub const LINEAR_TOLERANCE: f64 = 0.1;

/// Least squares `y = a + b x`: `(a, b)`; `None` for fewer than two distinct x.
fn line(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (points.len() >= 2 && sxx > 0.0).then(|| (my - sxy / sxx * mx, sxy / sxx))
}

/// Slope of ln(t) against ln(n) over the positive points; NaN without two.
pub fn log_log_exponent(points: &[(u32, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|&&(n, t)| n > 0 && t > 0.0)
        .map(|&(n, t)| ((n as f64).ln(), t.ln()))
        .collect();
    line(&logs).map(|(_, b)| b).unwrap_or(f64::NAN)
}

impl ScalingFit {
    /// The fit of `(n, frame_ms)` points; `None` for fewer than two sizes. The
    /// GPU and CPU exponents are left NaN ([`ScalingFit::of_runs`] fills them).
    pub fn of(points: &[(u32, f64)]) -> Option<ScalingFit> {
        let lin: Vec<(f64, f64)> = points.iter().map(|&(n, t)| (n as f64, t)).collect();
        let (intercept_ms, slope_ms_per_n) = line(&lin)?;
        Some(ScalingFit {
            slope_ms_per_n,
            intercept_ms,
            exponent: log_log_exponent(points),
            gpu_exponent: f64::NAN,
            cpu_exponent: f64::NAN,
            ns: points.iter().map(|p| p.0).collect(),
        })
    }

    /// The fit of runs of one algorithm over a family (`n` set on each).
    pub fn of_runs(runs: &[&Record]) -> Option<ScalingFit> {
        let pts = |f: fn(&Record) -> f64| -> Vec<(u32, f64)> {
            runs.iter().filter_map(|r| Some((r.n?, f(r)))).collect()
        };
        let mut fit = ScalingFit::of(&pts(|r| r.frame_ms_median))?;
        fit.gpu_exponent = log_log_exponent(&pts(|r| r.gpu_ms_median));
        fit.cpu_exponent = log_log_exponent(&pts(|r| r.frame_cpu_ms_median));
        Some(fit)
    }

    /// Whether `frame_ms` grows no faster than linearly (within
    /// [`LINEAR_TOLERANCE`]).
    pub fn at_most_linear(&self) -> bool {
        self.exponent <= 1.0 + LINEAR_TOLERANCE
    }
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
/// that family (runs that failed or were skipped are left out).
pub fn fit_families(records: &mut [Record]) {
    let keys: Vec<_> = records.iter().filter_map(family_key).collect();
    for key in keys {
        let runs: Vec<&Record> = records
            .iter()
            .filter(|r| family_key(r).as_ref() == Some(&key) && r.ran())
            .collect();
        let fit = ScalingFit::of_runs(&runs);
        for r in records
            .iter_mut()
            .filter(|r| family_key(r).as_ref() == Some(&key))
        {
            r.scaling = fit.clone();
        }
    }
}

/// Per family: each algorithm's fit and the best correct algorithm's verdict,
/// then each run's figures by n.
pub fn table(records: &[Record]) -> String {
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
        let _ = writeln!(s, "\n### {fam} ({w}×{h}, {depth})\n");
        s.push_str(&verdict(&rows));
        s.push_str(&fits(&rows));
        s.push_str(&runs(&rows));
    }
    s
}

/// The best correct algorithm at the largest n any ran, and whether its cost
/// grows at most linearly.
fn verdict(rows: &[&Record]) -> String {
    let n_max = rows
        .iter()
        .filter(|r| r.ran())
        .filter_map(|r| r.n)
        .max()
        .unwrap_or(0);
    let best = rows
        .iter()
        .filter(|r| r.n == Some(n_max) && correct(r))
        .min_by(|a, b| a.frame_ms_median.total_cmp(&b.frame_ms_median));
    let Some(best) = best else {
        return format!("No correct run at n = {n_max}.\n\n");
    };
    let mut s = format!(
        "Best correct at n = {n_max}: {} ({:.2} ms per frame).",
        best.algo, best.frame_ms_median
    );
    match &best.scaling {
        Some(f) => {
            let _ = write!(
                s,
                " Its `frame_ms` grows as n^{:.2} (GPU time n^{:.2}, process CPU n^{:.2}) over n = {}: {}.",
                f.exponent,
                f.gpu_exponent,
                f.cpu_exponent,
                join(&f.ns),
                if f.at_most_linear() {
                    format!("at most linear (n·k; exponent ≤ 1 + {LINEAR_TOLERANCE})")
                } else {
                    "superlinear".to_string()
                }
            );
        }
        None => s.push_str(" (one size: no fit)"),
    }
    s.push_str("\n\n");
    s
}

fn join(ns: &[u32]) -> String {
    ns.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
}

/// One row per algorithm: its fit over the family.
fn fits(rows: &[&Record]) -> String {
    let mut algos: Vec<&str> = Vec::new();
    for r in rows {
        if !algos.contains(&r.algo.as_str()) {
            algos.push(&r.algo);
        }
    }
    if rows.iter().all(|r| r.scaling.is_none()) {
        return String::new();
    }
    let mut s = String::from("| algo | ms per n | intercept ms | exponent (frame) | exponent (GPU) | exponent (CPU) | n fitted |\n|---|---|---|---|---|---|---|\n");
    for a in algos {
        let fit = rows
            .iter()
            .find_map(|r| (r.algo == a).then_some(r.scaling.as_ref()).flatten());
        let _ = match fit {
            Some(f) => writeln!(
                s,
                "| {a} | {:.4} | {:.2} | {:.2} | {:.2} | {:.2} | {} |",
                f.slope_ms_per_n,
                f.intercept_ms,
                f.exponent,
                f.gpu_exponent,
                f.cpu_exponent,
                join(&f.ns)
            ),
            None => writeln!(s, "| {a} | - | - | - | - | - | - |"),
        };
    }
    s.push('\n');
    s
}

/// One row per run, by n: the figures the fits are made of, and the plan's
/// estimate (skipped runs say so).
fn runs(rows: &[&Record]) -> String {
    let mut s = String::from("| n | algo | frame ms | GPU ms | CPU ms | draws | estimate s | note |\n|---|---|---|---|---|---|---|---|\n");
    let mut sorted = rows.to_vec();
    sorted.sort_by_key(|r| r.n);
    for r in sorted {
        let est = r
            .estimate
            .as_ref()
            .map(|e| format!("{:.2}", e.seconds))
            .unwrap_or_else(|| "-".into());
        let n = r.n.map(|n| n.to_string()).unwrap_or_default();
        if !r.ran() {
            let why = r.skipped.as_deref().or(r.failure.as_deref()).unwrap_or("");
            let _ = writeln!(
                s,
                "| {n} | {} | | | | | {est} | {} |",
                r.algo,
                why.replace('|', "/")
            );
            continue;
        }
        let draws = frame_count(r, |c| c.draws).unwrap_or_else(|| "-".into());
        let note = if correct(r) { "" } else { "incorrect" };
        let _ = writeln!(
            s,
            "| {n} | {} | {:.2} | {:.2} | {:.2} | {draws} | {est} | {note} |",
            r.algo, r.frame_ms_median, r.gpu_ms_median, r.frame_cpu_ms_median
        );
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
    fn gpu_and_cpu_exponents_are_fitted_on_their_own_series() {
        // Synthetic runs: frame time n^1, GPU time n^2, CPU time n^0.5.
        let runs: Vec<Record> = [16u32, 64, 256, 1024]
            .iter()
            .map(|&n| {
                let mut r = super::super::tests::record("blister", Some(n));
                let x = n as f64;
                r.frame_ms_median = 0.1 * x;
                r.gpu_ms_median = 0.01 * x * x;
                r.frame_cpu_ms_median = x.sqrt();
                r
            })
            .collect();
        let refs: Vec<&Record> = runs.iter().collect();
        let f = ScalingFit::of_runs(&refs).unwrap();
        assert!((f.exponent - 1.0).abs() < 1e-9, "{f:?}");
        assert!((f.gpu_exponent - 2.0).abs() < 1e-9, "{f:?}");
        assert!((f.cpu_exponent - 0.5).abs() < 1e-9, "{f:?}");
        assert!((f.slope_ms_per_n - 0.1).abs() < 1e-9);
        assert!(f.at_most_linear());
        assert_eq!(f.ns, vec![16, 64, 256, 1024]);
    }

    #[test]
    fn the_summary_states_the_best_algorithms_exponent_and_leaves_skipped_runs_out() {
        let mut records = Vec::new();
        for &n in &[16u32, 64, 256] {
            let x = n as f64;
            // blister linear and fastest; goldfeather quadratic, skipped at 256.
            let mut b = super::super::tests::record("blister", Some(n));
            b.frame_ms_median = 2.0 * x;
            records.push(b);
            let mut g = super::super::tests::record("goldfeather", Some(n));
            g.frame_ms_median = 0.5 * x * x;
            if n == 256 {
                g.skipped = Some("skipped: estimated 40.0 s per frame".into());
                g.frame_ms_median = 0.0;
            }
            records.push(g);
        }
        fit_families(&mut records);
        let g = records.iter().find(|r| r.algo == "goldfeather").unwrap();
        let gf = g.scaling.as_ref().unwrap();
        assert_eq!(gf.ns, vec![16, 64], "the skipped run is not fitted");
        assert!((gf.exponent - 2.0).abs() < 1e-9);
        assert!(!gf.at_most_linear());
        let t = table(&records);
        assert!(
            t.contains("Best correct at n = 256: blister (512.00 ms per frame). Its `frame_ms` grows as n^1.00"),
            "{t}"
        );
        assert!(t.contains("at most linear"), "{t}");
        assert!(
            t.contains("| 256 | goldfeather | | | | | - | skipped: estimated 40.0 s per frame |"),
            "{t}"
        );
        // A superlinear best is called so.
        for r in records.iter_mut().filter(|r| r.algo == "blister") {
            r.frame_ms_median = 0.01 * (r.n.unwrap() as f64).powf(1.5);
        }
        fit_families(&mut records);
        assert!(table(&records).contains("superlinear"));
    }
}
