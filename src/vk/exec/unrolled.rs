//! Frames with their peel loops unrolled (docs/executor.md): the loops run
//! to the layer counts the last frame of the plan needed, in one submission,
//! checked afterwards on the GPU's occlusion counts (`layers_fit`); the kept
//! recording replays when it fits.

use super::record::Group;
use super::scissors::Scissors;
use super::stats::{ExecStats, Recorded};
use super::{Executor, FrameStart};
use crate::plan::reach;
use crate::plan::{Plan, Step};
use crate::vk::error::VkError;
use crate::vk::instance::Shared;
use crate::vk::submit;

impl Executor {
    /// Makes the frame command buffer hold `plan` with its loops unrolled to
    /// `layers` for the current camera: the kept recording when it fits (see
    /// docs/executor.md), otherwise a new one. Returns how it came to be.
    pub(super) fn ready_unrolled(
        &mut self,
        plan: &Plan,
        layers: &[u32],
        f: &mut FrameStart,
    ) -> Result<Recorded, VkError> {
        let (exact, still) = (&f.exact, f.still);
        // A recording of this plan, objects and loop counts, made for some camera.
        let same = self
            .recording
            .as_ref()
            .filter(|r| r.key.epoch == self.epoch && r.key.layers == layers && r.key.plan == *plan);
        let kind = match same {
            // Scissors grown for a moving camera are made exact once it stops.
            Some(r)
                if r.key.rects.covers(exact)
                    && r.key.ties.serves(&self.ties)
                    && reach::holds(&self.kept, &r.key.assumed)
                    && !(still && r.key.rects.grown) =>
            {
                if r.key.rects.rects == exact.rects || still {
                    Recorded::Replayed
                } else {
                    Recorded::ReplayedMovedCamera
                }
            }
            Some(_) => Recorded::Camera,
            None => Recorded::New,
        };
        if matches!(kind, Recorded::Camera | Recorded::New) {
            self.rects = if kind == Recorded::Camera && !still {
                // The tie zones' rectangles grow with the scissors.
                let (mx, my) = Scissors::margins(&self.desc);
                self.ties = self.ties.grown(mx, my, self.desc.width, self.desc.height);
                exact.grown(&self.desc)
            } else {
                exact.clone()
            };
            self.recording = None;
            let now = self.kept.clone();
            f.clock.record_ms += self.record_kept(plan, layers, &now)?;
        }
        Ok(kind)
    }

    /// The stats of the unrolled frame just executed, from the GPU's counts:
    /// `None` when they show that `layers` no longer fit.
    pub(super) fn check_unrolled(
        &mut self,
        plan: &Plan,
        layers: &[u32],
        kind: Recorded,
    ) -> Result<Option<ExecStats>, VkError> {
        let rec = self.recording.as_ref().expect("recorded before submission");
        // The frame ran: the outputs hold what it leaves, whatever its counts.
        if !self.kept_unknown {
            self.kept = rec.after.clone();
        }
        let device = &self.shared.device;
        let samples = submit::query_results(device, self.occlusion.pool, rec.queries.len())?;
        if !layers_fit(plan, layers, &rec.queries, &samples) {
            self.layers = None;
            return Ok(None);
        }
        let mut stats = rec.stats.clone();
        stats.recorded = kind;
        stats.counts.loop_iterations = layers.to_vec();
        stats.counts.samples_counted = samples.iter().sum();
        // Queries are in recording order: those after the last loop head's.
        let after = rec
            .queries
            .iter()
            .rposition(Option::is_some)
            .map_or(0, |i| i + 1);
        stats.counts.final_samples = samples[after..].iter().sum();
        add_gpu_times(&mut stats, &self.shared, self.timestamps.pool, &rec.marks)?;
        Ok(Some(stats))
    }
}

/// Adds to `stats` the GPU times between the timestamps of the last completed
/// submission: the first `marks.len()` queries of `pool`, each tagged with the
/// pass it starts (`Recorder::marks`). The frame's total and each pass's.
/// A free function over handles, not a method, because the stepwise frame
/// calls it while its recorder borrows the executor.
pub(super) fn add_gpu_times(
    stats: &mut ExecStats,
    shared: &Shared,
    pool: ash::vk::QueryPool,
    marks: &[String],
) -> Result<(), VkError> {
    if shared.timestamp_valid_bits == 0 || marks.len() < 2 {
        return Ok(());
    }
    let ts = submit::query_results(&shared.device, pool, marks.len())?;
    let period = shared.limits.timestamp_period as f64;
    for (i, pair) in ts.windows(2).enumerate() {
        let ms = pair[1].saturating_sub(pair[0]) as f64 * period * 1e-6;
        stats.gpu_ms += ms;
        if let Some(p) = stats.pass_entry(&marks[i]) {
            p.gpu_ms += ms;
        }
    }
    Ok(())
}

/// Whether a frame unrolled to `layers` was right, by the GPU's occlusion
/// `samples` (tagged by `groups`): every head but the last of a loop passed
/// samples, the last none (or the loop hit its bound).
pub(super) fn layers_fit(plan: &Plan, layers: &[u32], groups: &[Group], samples: &[u64]) -> bool {
    let mut per_head: Vec<Vec<u64>> = layers.iter().map(|&n| vec![0u64; n as usize]).collect();
    for (g, s) in groups.iter().zip(samples) {
        if let Some((l, k)) = g {
            per_head[*l][*k as usize] += s;
        }
    }
    let loops = plan.steps.iter().filter_map(|s| match s {
        Step::Loop(l) => Some(l.max_iterations),
        _ => None,
    });
    per_head
        .iter()
        .zip(loops)
        .all(|(heads, max)| match heads.split_last() {
            None => max == 0,
            Some((&last, before)) => {
                before.iter().all(|&s| s > 0) && (last == 0 || heads.len() as u32 >= max)
            }
        })
}

/// `plan`'s steps with each loop `i` unrolled to `layers[i]` head executions (the
/// last without its tail), head steps tagged with their loop and iteration.
pub(super) fn unroll<'p>(plan: &'p Plan, layers: &[u32]) -> Vec<(&'p Step, Group)> {
    let mut loops = layers.iter();
    let len = plan.steps.iter().map(|s| match s {
        Step::Loop(l) => {
            let n = *loops.next().expect("a count per loop") as usize;
            n * l.head.len() + n.saturating_sub(1) * l.tail.len()
        }
        _ => 1,
    });
    let mut out = Vec::with_capacity(len.sum());
    let mut li = 0;
    for s in &plan.steps {
        let Step::Loop(l) = s else {
            out.push((s, None));
            continue;
        };
        let n = layers[li];
        for k in 0..n {
            out.extend(l.head.iter().map(|h| (h, Some((li, k)))));
            if k + 1 < n {
                out.extend(l.tail.iter().map(|t| (t, None)));
            }
        }
        li += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::Loop;

    #[test]
    fn unroll_runs_every_head_and_all_tails_but_the_last() {
        let plan = Plan {
            algo: "t".into(),
            depth_stencils: 1,
            textures: 0,
            stencil_bits: 0,
            output_ds: 0,
            steps: vec![
                Step::Pass("a".into()),
                Step::Loop(Loop {
                    head: vec![Step::Pass("h".into())],
                    tail: vec![Step::Pass("t".into())],
                    max_iterations: 9,
                }),
                Step::Pass("b".into()),
            ],
        };
        let names: Vec<(String, Group)> = unroll(&plan, &[3])
            .into_iter()
            .map(|(s, g)| match s {
                Step::Pass(n) => (n.clone(), g),
                _ => unreachable!(),
            })
            .collect();
        let h = |k| ("h".to_string(), Some((0, k)));
        let t = ("t".to_string(), None);
        assert_eq!(
            names,
            vec![
                ("a".to_string(), None),
                h(0),
                t.clone(),
                h(1),
                t,
                h(2),
                ("b".to_string(), None)
            ]
        );
    }
}
