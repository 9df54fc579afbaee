//! The performance issue's checks on a finished benchmark (issue 9, "Measure and
//! report"): the overhead of each run (replayed frames, wall time against GPU
//! time), and the summary's section that states them with the scaling
//! families' fits ([`super::scaling`]). Typed until `report` writes them.
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

/// Whether a run is correct by the definition.
pub fn correct(r: &Record) -> bool {
    let (cov, prim, _) = error_figures(r);
    r.ran() && cov <= CORRECT_FRAC && prim <= CORRECT_FRAC
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
    s.push_str(&super::scaling::table(records));
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overhead_needs_every_frame_replayed_and_wall_near_gpu() {
        assert!(Overhead::of(5, 5, 10.0, 12.4).ok);
        assert!(!Overhead::of(5, 5, 10.0, 12.6).ok);
        assert!(!Overhead::of(5, 4, 10.0, 10.0).ok);
    }
}
