//! The kept frame recording (docs/executor.md): a plan unrolled to known
//! loop counts, recorded into the frame command buffer once and replayed while
//! its key — plan, loop counts, scissors, tie decisions, device objects and
//! what it assumes the outputs hold — stays; and the timing of recordings
//! (`time_recording`).

use ash::vk;

use super::record::{Group, HostShade};
use super::scissors::Scissors;
use super::stats::ExecStats;
use super::{unroll, Executor};
use crate::plan::reach::KeptImages;
use crate::plan::tie_free::TieFree;
use crate::plan::{Plan, Step};
use crate::vk::cpu_clock::CpuInstant;
use crate::vk::error::VkError;

/// What a kept recording was made for.
pub(super) struct RecordingKey {
    pub(super) plan: Plan,
    /// The screen rectangle of each mesh its scissors were made from.
    pub(super) rects: Scissors,
    pub(super) layers: Vec<u32>,
    pub(super) epoch: u64,
    /// The tie-free decisions its draws were recorded with.
    pub(super) ties: TieFree,
    /// What it assumes the outputs hold before it (`plan::reach::holds`).
    pub(super) assumed: KeptImages,
}

/// The kept frame recording and what its replays report.
pub(super) struct Recording {
    pub(super) key: RecordingKey,
    /// What the outputs hold after it runs.
    pub(super) after: KeptImages,
    pub(super) stats: ExecStats,
    pub(super) queries: Vec<Group>,
    pub(super) marks: Vec<String>,
}

/// A frame's recording: its stats, the loop group of each occlusion query, the
/// pass at each timestamp, and what it assumes the outputs hold before it and
/// leaves them holding.
pub(super) type FrameRecording = (ExecStats, Vec<Group>, Vec<String>, (KeptImages, KeptImages));

impl Executor {
    /// Records `plan` unrolled to `layers` into the frame command buffer and keeps
    /// the recording for replays (scissors from `self.rects`): the calling
    /// thread's CPU ms, from resetting the buffer to ending it.
    pub(super) fn record_kept(
        &mut self,
        plan: &Plan,
        layers: &[u32],
        now: &KeptImages,
    ) -> Result<f64, VkError> {
        let t = CpuInstant::now();
        let cmd = self.frame_cmd;
        self.submit.begin(cmd, false)?;
        let now = self.kept_now(now);
        let (mut stats, queries, marks, (assumed, after)) =
            self.record_frame_from(cmd, plan, layers, None, &now)?;
        stats.counts.submits = 1;
        self.submit.end(cmd)?;
        let ms = t.elapsed_ms();
        // The kept key when it is this one (a plan recorded anew): no clone.
        let key = match self.recording.take() {
            Some(r)
                if r.key.epoch == self.epoch
                    && r.key.layers == layers
                    && r.key.rects == self.rects
                    && r.key.ties == self.ties
                    && r.key.assumed == assumed
                    && r.key.plan == *plan =>
            {
                r.key
            }
            _ => RecordingKey {
                plan: plan.clone(),
                rects: self.rects.clone(),
                layers: layers.to_vec(),
                epoch: self.epoch,
                ties: self.ties.clone(),
                assumed,
            },
        };
        self.recording = Some(Recording {
            key,
            after,
            stats,
            queries,
            marks,
        });
        Ok(ms)
    }

    /// Records the kept frame of `plan` anew `reps` times without submitting it:
    /// what recording this plan costs the CPU (a new plan of its
    /// size), in the calling thread's CPU ms per recording, free of the GPU's
    /// work and of waiting for a core. The recording stays kept (the same
    /// commands). Each recording works out what its clears and copies reach
    /// anew (the cache of those regions is dropped first, as for a new plan).
    /// `None` when no recording of `plan` is kept: execute it until a frame
    /// replays first.
    pub fn time_recording(&mut self, plan: &Plan, reps: u32) -> Result<Option<Vec<f64>>, VkError> {
        self.time_recordings(plan, reps, true)
    }

    /// [`Self::time_recording`] with the regions of its clears and copies
    /// taken from the cache (`plan::memo`): what recording the plan again
    /// costs when only device objects changed (an interference frame's
    /// uploads, a replaced image).
    pub fn time_recording_cached(
        &mut self,
        plan: &Plan,
        reps: u32,
    ) -> Result<Option<Vec<f64>>, VkError> {
        self.time_recordings(plan, reps, false)
    }

    /// `reps` timed recordings of the kept frame of `plan`, each working out
    /// its reach anew when `fresh`.
    fn time_recordings(
        &mut self,
        plan: &Plan,
        reps: u32,
        fresh: bool,
    ) -> Result<Option<Vec<f64>>, VkError> {
        let _layer = self.shared.layer_use();
        let layers = match &self.recording {
            Some(r) if r.key.epoch == self.epoch && r.key.plan == *plan => r.key.layers.clone(),
            _ => return Ok(None),
        };
        // The scissors and tie decisions it was made with, so that the
        // recording stays what it was.
        let key = &self.recording.as_ref().expect("matched above").key;
        (self.rects, self.ties) = (key.rects.clone(), key.ties.clone());
        // Made for what it assumed, a recording assumes the same.
        let assumed = key.assumed.clone();
        (0..reps)
            .map(|_| {
                if fresh {
                    self.reach_memo.clear();
                }
                self.record_kept(plan, &layers, &assumed)
            })
            .collect::<Result<Vec<f64>, VkError>>()
            .map(Some)
    }

    /// Records `plan` with its loops unrolled to `layers` into `cmd` (begun by the
    /// caller): the stats, the loop group of each occlusion query, the pass at
    /// each timestamp. Every image starts and ends in `REST`. With `host`, the
    /// plan's last `host.1` steps (its final shade, `record::final_shade`) are
    /// drawn into an embedding host's attachments instead (`record::host`).
    /// Someone else submits it: from now on what the outputs hold is unknown
    /// here, and their clears reach whole images.
    pub(super) fn record_frame(
        &mut self,
        cmd: vk::CommandBuffer,
        plan: &Plan,
        layers: &[u32],
        host: Option<(&HostShade, usize)>,
    ) -> Result<(ExecStats, Vec<Group>, Vec<String>), VkError> {
        self.kept_unknown = true;
        self.kept.clear();
        let (stats, groups, marks, _) =
            self.record_frame_from(cmd, plan, layers, host, &KeptImages::new())?;
        Ok((stats, groups, marks))
    }

    /// [`Self::record_frame`] for outputs that hold `now` before it: also
    /// what the recording assumes they hold and what they hold after it
    /// (`Executor::recording_reach`).
    fn record_frame_from(
        &mut self,
        cmd: vk::CommandBuffer,
        plan: &Plan,
        layers: &[u32],
        host: Option<(&HostShade, usize)>,
        now: &KeptImages,
    ) -> Result<FrameRecording, VkError> {
        let flat = unroll(plan, layers);
        self.ensure_queries(&flat)?;
        let steps: Vec<&Step> = flat.iter().map(|(s, _)| *s).collect();
        // The host's shade reads the body's last depth copy: its draws count.
        let reached = self.recording_reach(plan, layers, &steps, now);
        let (occ_cap, ts_cap) = (self.occlusion.cap, self.timestamps.cap);
        let mut rec = self.recorder();
        let body = steps.len() - host.map_or(0, |h| h.1);
        rec.use_reach(&reached.0, plan.output_ds);
        // The host's shade draws decide what the last copy covers, as the
        // standalone shade's do.
        rec.plan_shades(&steps);
        if host.is_none() {
            rec.plan_direct_shades(&steps, plan.output_ds);
        }
        rec.plan_blocks(&steps[..body]);
        let shade = &steps[body..];
        rec.begin(cmd, occ_cap, ts_cap);
        for (s, g) in flat.iter().take(body) {
            rec.group = *g;
            rec.step(s)?;
        }
        match host {
            Some((h, _)) => {
                // The same products as the standalone frame's direct shades.
                let direct = rec.direct_shades(&steps, plan.output_ds);
                rec.host_shade(h, shade, &direct)?
            }
            None => rec.finish_frame(plan.output_ds),
        }
        rec.end();
        let kept = (reached.1.clone(), reached.0.kept.clone());
        Ok((rec.stats, rec.queries, rec.marks, kept))
    }
}
