//! The checks on a finished benchmark: the overhead of each run (replayed frames,
//! wall time against GPU time), the CST variants' ordering (Hable & Rossignac §8:
//! cst-g ≤ cst-i ≤ cst-z ≤ blister on the gear), and the summary's section that
//! states them with the scaling families' fits ([`super::scaling`]). Typed until
//! `report` writes them.
#![deny(unsafe_code)]

use std::fmt::Write;

use serde::Serialize;

use super::report::error_figures;
use super::rounds::Timing;
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

/// The CST paper's ordering in `gpu_ms`, fastest first (the target on
/// the gear).
pub const ORDER: [&str; 4] = ["cst-g", "cst-i", "cst-z", "blister"];

/// How two neighbours of [`ORDER`] compare.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Link {
    /// Both ran the same plan (equal digests): one plan's time measured twice,
    /// whichever median is lower.
    SamePlan,
    /// The faster-by-rank median is at most the other.
    Holds,
    /// It is above, by no more than the larger interquartile range.
    WithinNoise,
    Fails,
}

impl Link {
    /// Where `a` should be at most `b`.
    pub fn of(a: &Record, b: &Record) -> Link {
        let gap = a.gpu_ms_median - b.gpu_ms_median;
        if !a.plan_digest.is_empty() && a.plan_digest == b.plan_digest {
            Link::SamePlan
        } else if gap <= 0.0 {
            Link::Holds
        } else if gap <= a.gpu_ms_iqr.max(b.gpu_ms_iqr) {
            Link::WithinNoise
        } else {
            Link::Fails
        }
    }
    fn symbol(self) -> &'static str {
        match self {
            Link::SamePlan => "≡",
            Link::Holds => "≤",
            Link::WithinNoise => "≈",
            Link::Fails => ">",
        }
    }
}

/// The ordering of [`ORDER`] on one scene, size and depth set-up where all four
/// ran: a line of medians with IQR and the links between them.
pub fn ordering_line(runs: &[&Record]) -> Option<(String, bool)> {
    let get = |a: &str| runs.iter().copied().find(|r| r.algo == a && r.ran());
    let rs: Vec<&Record> = ORDER.iter().map(|a| get(a)).collect::<Option<_>>()?;
    let mut line = String::new();
    let mut ok = true;
    for (i, r) in rs.iter().enumerate() {
        if i > 0 {
            let l = Link::of(rs[i - 1], r);
            ok &= l != Link::Fails;
            let _ = write!(line, " {} ", l.symbol());
        }
        let _ = write!(
            line,
            "{} {:.2} (IQR {:.2})",
            r.algo, r.gpu_ms_median, r.gpu_ms_iqr
        );
    }
    let timing = match &rs[0].timing {
        Timing::Interleaved { runs } => format!("frames interleaved across {runs} runs"),
        Timing::Sequential { .. } => "runs timed one after another".into(),
        Timing::Alone => "timed alone".into(),
    };
    let same = Link::of(rs[0], rs[1]) == Link::SamePlan;
    let r = rs[0];
    Some((
        format!(
            "- {} {}×{} {}: {line} GPU ms, medians of {} frames ({timing}){}: {}.",
            r.scene,
            r.width,
            r.height,
            r.depth_setup,
            r.frames,
            if same {
                "; CST-G = CST-I plan (its counter pays for no group here)"
            } else {
                ""
            },
            if ok { "holds" } else { "fails" }
        ),
        ok,
    ))
}

/// The ordering lines of every scene, size and depth set-up with the four runs.
pub fn ordering(records: &[Record]) -> String {
    let mut keys: Vec<(&str, u32, u32, &str)> = records
        .iter()
        .map(|r| (r.scene.as_str(), r.width, r.height, r.depth_setup.as_str()))
        .collect();
    keys.dedup();
    let lines: Vec<String> = keys
        .iter()
        .filter_map(|&(scene, w, h, depth)| {
            let runs: Vec<&Record> = records
                .iter()
                .filter(|r| {
                    (r.scene.as_str(), r.width, r.height, r.depth_setup.as_str())
                        == (scene, w, h, depth)
                })
                .collect();
            ordering_line(&runs).map(|(l, _)| l)
        })
        .collect();
    if lines.is_empty() {
        return String::new();
    }
    format!(
        "\nCST ordering (Hable & Rossignac §8; the target on the gear): `≤` holds, `≈` above by at most the larger IQR, `≡` the same plan, `>` fails.\n\n{}\n",
        lines.join("\n")
    )
}

/// Whether a run is correct by the bench's definition.
pub fn correct(r: &Record) -> bool {
    let (cov, prim, _) = error_figures(r);
    r.ran() && cov <= CORRECT_FRAC && prim <= CORRECT_FRAC
}

/// The summary's section: overhead, scaling and deep-tree figures.
pub fn section(records: &[Record]) -> String {
    let mut s = String::from("## Performance checks\n\n");
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
        let mut cached: Vec<f64> = recorded
            .iter()
            .map(|r| r.rerecord_cached_us_per_draw)
            .collect();
        cached.sort_by(f64::total_cmp);
        let moved = recorded
            .iter()
            .filter(|r| r.camera_move_record_ms == 0.0)
            .count();
        let _ = writeln!(
            s,
            "\nRecording anew: median {:.2} µs per draw (max {:.2}) over {} runs ({:.2} with the executor's cached reach and tie decisions); the second frame of an orbit by two steps of {}°/2 replayed without recording in {moved} of them.",
            per_draw[per_draw.len() / 2],
            per_draw[per_draw.len() - 1],
            recorded.len(),
            cached[cached.len() / 2],
            super::CAMERA_NUDGE_DEG
        );
    }
    let interleaved = runs
        .iter()
        .filter(|r| matches!(r.timing, Timing::Interleaved { .. }))
        .count();
    let sequential: Vec<&&Record> = runs
        .iter()
        .filter(|r| matches!(r.timing, Timing::Sequential { .. }))
        .collect();
    let _ = writeln!(
        s,
        "\nTiming: {interleaved} of {} runs had their timed frames interleaved round-robin with their scene's other runs (after every run's warm-up){}.",
        runs.len(),
        match sequential.first().map(|r| &r.timing) {
            Some(Timing::Sequential { why }) => format!(
                "; {} ran one after another ({}: {why})",
                sequential.len(),
                sequential[0].scene
            ),
            _ => String::new(),
        }
    );
    s.push_str(&ordering(records));
    s.push_str(&super::scaling::table(records));
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(algo: &str, ms: f64, iqr: f64, digest: &str) -> Record {
        Record {
            scene: "gear".into(),
            gpu_ms_median: ms,
            gpu_ms_iqr: iqr,
            plan_digest: digest.into(),
            timing: Timing::Interleaved { runs: 4 },
            frames: 5,
            ..crate::bench::tests::record(algo, None)
        }
    }

    #[test]
    fn ordering_compares_plans_not_names() {
        // CST-G slower than CST-I but the same plan: not a failure.
        let rs = [
            run("cst-g", 11.0, 0.5, "aa"),
            run("cst-i", 10.0, 0.5, "aa"),
            run("cst-z", 10.2, 0.1, "bb"),
            run("blister", 20.0, 1.0, "cc"),
        ];
        let refs: Vec<&Record> = rs.iter().collect();
        let (line, ok) = ordering_line(&refs).unwrap();
        assert!(ok, "{line}");
        assert!(
            line.contains("cst-g 11.00 (IQR 0.50) ≡ cst-i 10.00"),
            "{line}"
        );
        assert!(line.contains("CST-G = CST-I plan") && line.contains("interleaved across 4"));
        // Different plans: above by more than the IQR fails, within it is noise.
        assert_eq!(Link::of(&run("a", 11.0, 0.5, "x"), &rs[1]), Link::Fails);
        assert_eq!(
            Link::of(&run("a", 10.4, 0.5, "x"), &rs[1]),
            Link::WithinNoise
        );
        assert_eq!(
            Link::of(&run("a", 9.0, 0.0, ""), &run("b", 9.0, 0.0, "")),
            Link::Holds
        );
        let slow_z = [
            rs[0].clone(),
            rs[1].clone(),
            run("cst-z", 30.0, 0.1, "bb"),
            rs[3].clone(),
        ];
        let refs: Vec<&Record> = slow_z.iter().collect();
        let (line, ok) = ordering_line(&refs).unwrap();
        assert!(
            !ok && line.contains("cst-z 30.00 (IQR 0.10) > blister"),
            "{line}"
        );
        // A missing or failed run: no line.
        let mut failed = rs.clone();
        failed[3].failure = Some("x".into());
        assert!(ordering_line(&failed.iter().collect::<Vec<_>>()).is_none());
        assert!(ordering(&rs).contains("- gear 800×800 d32s8: cst-g"));
    }

    #[test]
    fn overhead_needs_every_frame_replayed_and_wall_near_gpu() {
        assert!(Overhead::of(5, 5, 10.0, 12.4).ok);
        assert!(!Overhead::of(5, 5, 10.0, 12.6).ok);
        assert!(!Overhead::of(5, 4, 10.0, 10.0).ok);
    }
}
