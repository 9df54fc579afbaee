//! The loop-by-loop frame (docs/executor.md): one submission per straight
//! run of steps and per loop head and tail, each head's occlusion count read
//! on the CPU. It runs a plan seen for the first time, or one whose unrolled
//! frame's counts no longer fit, and learns the loop counts.

use super::record::{Group, Recorder};
use super::stats::{ExecStats, Recorded};
use super::{add_gpu_times, Clock, Executor};
use crate::plan::{Plan, Step};
use crate::vk::cpu_clock::CpuInstant;
use crate::vk::error::VkError;
use crate::vk::submit::{self, Submitter};

impl Executor {
    /// The frame with one submission per straight run of steps and per loop head
    /// and tail, waiting for each head's sample count on the CPU.
    pub(super) fn run_stepwise(
        &mut self,
        plan: &Plan,
        clock: &mut Clock,
    ) -> Result<ExecStats, VkError> {
        let all: Vec<(&Step, Group)> = plan
            .steps
            .iter()
            .flat_map(|s| match s {
                Step::Loop(l) => l.head.iter().chain(&l.tail).collect::<Vec<_>>(),
                s => vec![s],
            })
            .map(|s| (s, None))
            .collect();
        self.ensure_queries(&all)?;
        let (occ_cap, ts_cap) = (self.occlusion.cap, self.timestamps.cap);
        let cmd = self.submit.cmd;
        let mut loops = Vec::new();
        let mut samples_counted = 0;
        // The recorder borrows the executor's resources; submission and queries
        // are read through these copies of the handles.
        let shared = self.shared.clone();
        let (occ_pool, ts_pool) = (self.occlusion.pool, self.timestamps.pool);
        let mut run = |rec: &mut Recorder<'_>,
                       steps: &[Step],
                       finish: Option<u8>,
                       sub: &Submitter|
         -> Result<u64, VkError> {
            let t = CpuInstant::now();
            sub.begin(cmd, true)?;
            let listed: Vec<&Step> = steps.iter().collect();
            rec.plan_shades(&listed);
            rec.plan_blocks(&listed);
            rec.begin(cmd, occ_cap, ts_cap);
            for s in steps {
                rec.step(s)?;
            }
            if let Some(o) = finish {
                rec.finish_frame(o);
            }
            rec.end();
            sub.end(cmd)?;
            clock.record_ms += t.elapsed_ms();
            clock.submitting();
            sub.submit(cmd, &[], &[])?;
            sub.wait()?;
            rec.stats.counts.submits += 1;
            let samples: u64 = submit::query_results(&shared.device, occ_pool, rec.queries.len())?
                .iter()
                .sum();
            add_gpu_times(&mut rec.stats, &shared, ts_pool, &rec.marks)?;
            Ok(samples)
        };
        let (mut rec, submit) = self.recorder_and_submitter();
        let mut pending: Vec<Step> = Vec::new();
        for step in &plan.steps {
            let Step::Loop(l) = step else {
                pending.push(step.clone());
                continue;
            };
            if !pending.is_empty() {
                samples_counted += run(&mut rec, &pending, None, submit)?;
                pending.clear();
            }
            let mut iterations = 0;
            while iterations < l.max_iterations {
                iterations += 1;
                let samples = run(&mut rec, &l.head, None, submit)?;
                samples_counted += samples;
                if samples == 0 || iterations >= l.max_iterations {
                    break;
                }
                samples_counted += run(&mut rec, &l.tail, None, submit)?;
            }
            loops.push(iterations);
        }
        let final_samples = run(&mut rec, &pending, Some(plan.output_ds), submit)?;
        samples_counted += final_samples;
        let mut stats = rec.stats;
        stats.recorded = Recorded::Stepwise;
        stats.counts.loop_iterations = loops;
        stats.counts.samples_counted = samples_counted;
        stats.counts.final_samples = final_samples;
        Ok(stats)
    }
}
