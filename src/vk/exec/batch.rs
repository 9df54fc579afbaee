//! Frames of several executors in one queue submission (one
//! submit per frame in every mode). A shadowed frame is the light's map, the
//! eye's frame and the shadow pass: each executor [`Executor::prepare`]s its
//! kept, unrolled recording, the caller submits all command buffers at once
//! and waits, then each executor [`Executor::complete`]s its frame from the
//! GPU's counts, as a standalone frame does after its own submission. A frame
//! whose loop counts are not known yet, or turn out not to fit, runs loop by
//! loop on its own, so images never depend on the batch.

use ash::vk;

use super::{ExecStats, Executor, FrameStart};
use crate::plan::Plan;
use crate::vk::error::VkError;

/// A frame recorded and not yet submitted: submit [`PreparedFrame::cmd`],
/// wait for it, then [`Executor::complete`] the frame.
pub struct PreparedFrame {
    /// The frame's command buffer (executable; owned by the executor).
    pub cmd: vk::CommandBuffer,
    start: FrameStart,
    layers: Vec<u32>,
    kind: super::Recorded,
}

impl Executor {
    /// Whether [`Executor::prepare`] would record `plan`: its loop counts are
    /// known from an earlier frame.
    pub fn knows_loops(&self, plan: &Plan) -> bool {
        matches!(&self.layers, Some((p, _)) if p == plan)
    }

    /// Records `plan`'s frame for a submission by the caller; `None` when its
    /// loop counts are not known yet (a plan's first frame: run it with
    /// [`Executor::execute`], which learns them). Nothing else may use this
    /// executor until [`Executor::complete`].
    pub fn prepare(&mut self, plan: &Plan) -> Result<Option<PreparedFrame>, VkError> {
        let _layer = self.shared.layer_use();
        if !self.knows_loops(plan) {
            return Ok(None);
        }
        let mut start = self.begin_frame(plan)?;
        let layers = start
            .known
            .clone()
            .expect("the counts were looked up above");
        let kind = self.ready_unrolled(plan, &layers, &mut start)?;
        start.clock.submitting();
        Ok(Some(PreparedFrame {
            cmd: self.frame_cmd,
            start,
            layers,
            kind,
        }))
    }

    /// Finishes `frame` of `plan` after the caller's submission of its command
    /// buffer completed; when the GPU's counts show that its loop counts no
    /// longer fit, runs the frame again loop by loop (`recorded` is then
    /// `stepwise`).
    pub fn complete(&mut self, plan: &Plan, frame: PreparedFrame) -> Result<ExecStats, VkError> {
        let _layer = self.shared.layer_use();
        let unrolled = self.check_unrolled(plan, &frame.layers, frame.kind)?;
        self.end_frame(plan, frame.start, unrolled)
    }
}
