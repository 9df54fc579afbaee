//! What the outputs hold between frames and what a recording's clears and
//! copies reach (`plan::reach`; docs/executor.md): worked out per recording and kept
//! while its steps, scissors and inputs stay (`plan::memo`).

use std::sync::Arc;

use super::Executor;
use crate::plan::passes;
use crate::plan::reach::{self, FrameReach, KeptImages};
use crate::plan::tie_free::TieFree;
use crate::plan::usage::Resource;
use crate::plan::{Plan, Scissor, Step};
use crate::vk::scissor::Rect;

/// Everything a recording's clears and copies depend on
/// ([`Executor::recording_reach`]): its steps (a plan unrolled to `layers`),
/// the mesh rectangles of its scissors, what the outputs hold before it, and
/// the settings that shape them.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct ReachKey {
    plan: u64,
    layers: Vec<u32>,
    rects: Vec<Rect>,
    openings: Vec<Option<Rect>>,
    now: KeptImages,
    normals: bool,
    /// The tie-free decisions its draws are lowered with: a texture only
    /// the lowered draws sampled is written for nobody.
    ties: TieFree,
}

/// A recording's reach (`plan::reach::recording_reach`) and what it assumes
/// the outputs hold before it.
pub(super) type Reached = (FrameReach, KeptImages);

impl Executor {
    /// What the clears and copies of a recording of `steps` (`plan` unrolled
    /// to `layers`) reach with the current scissors, for outputs that hold
    /// `now` before it, and what it assumes they hold: the kept result while
    /// its inputs stay (`plan::memo`).
    pub(super) fn recording_reach(
        &mut self,
        plan: &Plan,
        layers: &[u32],
        steps: &[&Step],
        now: &KeptImages,
    ) -> Arc<Reached> {
        let key = ReachKey {
            plan: self.plan_ids.id(plan),
            layers: layers.to_vec(),
            rects: self.rects.rects.clone(),
            openings: self.rects.openings.clone(),
            now: now.clone(),
            normals: self.normals,
            ties: self.ties.clone(),
        };
        let (w, h) = (self.desc.width, self.desc.height);
        let outputs = reach::outputs(plan.output_ds, self.normals);
        let images = self.reach_images(&outputs);
        let (rects, ties) = (&self.rects, &self.ties);
        let reached = self.reach_memo.get_or_insert_with(key, || {
            let unions = rects.unions();
            let scissor = |s: &Scissor| unions.scissor(s, w, h);
            Arc::new(passes::reach(steps, ties, scissor, images, now))
        });
        reached.clone()
    }

    /// What a frame recorded now may assume the outputs hold: `kept`, or
    /// nothing once an embedding records frames.
    pub(super) fn kept_now(&self, kept: &KeptImages) -> KeptImages {
        match self.kept_unknown {
            true => KeptImages::new(),
            false => kept.clone(),
        }
    }

    /// What the outputs hold after a loop-by-loop frame of `plan` (its clears
    /// reach whole images): each loop as its head, tail and head again
    /// (`reach::kept_after`).
    pub(super) fn kept_after_stepwise(&mut self, plan: &Plan) {
        if self.kept_unknown {
            return;
        }
        let steps: Vec<&Step> = plan
            .steps
            .iter()
            .flat_map(|s| match s {
                Step::Loop(l) => l.head.iter().chain(&l.tail).chain(&l.head).collect(),
                s => vec![s],
            })
            .collect();
        let unions = self.rects.unions();
        let (w, h) = (self.desc.width, self.desc.height);
        let outputs = reach::outputs(plan.output_ds, self.normals);
        let images = self.reach_images(&outputs);
        self.kept = reach::kept_after(&steps, |s| unions.scissor(s, w, h), images, &self.kept);
    }

    /// The images `plan::reach` plans a frame on: `outputs`, read whole
    /// after it, the normal buffer with the colour when on, the image size.
    pub(super) fn reach_images<'a>(&self, outputs: &'a [Resource]) -> reach::Images<'a> {
        reach::Images {
            outputs,
            normals: self.normals,
            size: (self.desc.width, self.desc.height),
        }
    }
}
