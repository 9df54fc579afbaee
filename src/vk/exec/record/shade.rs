//! The recorder's side of the final shade as depth-equal draws (`plan::tie_free`,
//! docs/executor.md): the depth copy that opens a
//! final shade (`plan::tie::shade_near_depth`) reaches only the pixels its
//! tie-rule draws read, and none when every draw of the shade runs as a plain
//! depth-`EQUAL` draw (no pass whose result nobody reads). The
//! draws themselves are rewritten one by one (`TieFree::fixed_function`); a draw
//! of a mesh that can tie only in some zones (`plan::tie_zones`) becomes the
//! rule draw cut to each of their rectangles and the depth-equal draw cut to
//! each rectangle of the rest, and the copy reaches only those rule rectangles.
//! A one-primitive product whose shade draw would run depth-equal everywhere
//! is shaded in its direct draw instead, and that shade draw is not recorded
//! (`plan::direct_shade`).

use std::collections::VecDeque;

use super::{BlockKey, Recorder};
use crate::plan::direct_shade::DirectShades;
use crate::plan::lower::Lowering;
use crate::plan::reach::READ_MARGIN;
use crate::plan::tie_free::ShadeCopy;
use crate::plan::tie_zones::{self, MAX_COPY_RECTS};
use crate::plan::usage::Resource;
use crate::plan::{Draw, Ds, Step, Tex};
use crate::vk::error::VkError;
use crate::vk::pipeline::FragmentKind;
use crate::vk::scissor::Rect;

impl Recorder<'_> {
    /// Decides what each depth copy of `steps` covers, which the recorder then
    /// applies in this order (`TieFree::shade_copies`). Without this, every copy
    /// covers the whole image.
    pub fn plan_shades(&mut self, steps: &[&Step]) {
        self.shade_copies = VecDeque::from(self.b.ties.shade_copies(steps));
    }

    /// Decides which direct draws of a whole frame's `steps` shade in place
    /// of their meshes' final shade draws (`plan::direct_shade`): those whose
    /// shade draw runs depth-`EQUAL` over its whole rectangle under these
    /// tie decisions. Only for a frame recorded whole, shaded into the
    /// executor's own targets.
    pub fn plan_direct_shades(&mut self, steps: &[&Step], output_ds: Ds) {
        self.direct = self.direct_shades(steps, output_ds);
    }

    /// The one-primitive products of a whole frame's `steps` that
    /// [`Self::plan_direct_shades`] would shade in their direct draws (the
    /// embedding's host shade draws them without a check of the output
    /// depth, `record/host.rs`).
    pub fn direct_shades(&self, steps: &[&Step], output_ds: Ds) -> DirectShades {
        let ties = self.b.ties;
        DirectShades::decide(steps, output_ds, |m, eps| ties.shade_depth_equal(m, eps))
    }

    /// `Step::CopyDepthToTexture`: depth-stencil `ds` into texture `dst`, where
    /// it is read.
    pub(super) fn copy_depth(&mut self, step: &Step, ds: Ds, dst: Tex) -> Result<(), VkError> {
        // What later steps read of the copy (`plan::reach`).
        let reach = self.copy_region();
        let shade = self.shade_copies.pop_front();
        let rects = self.depth_copy_rects(reach, shade.as_ref());
        if rects.is_empty() {
            self.stats.counts.skipped_steps += 1;
            return Ok(());
        }
        let key = BlockKey::new(&[Resource::Texture(dst)], None);
        let set = self.b.targets.sampling_set(Resource::DepthStencil(ds));
        self.open(&key, &step.usage());
        for rect in rects {
            self.fullscreen_internal(&key, FragmentKind::CopyDepth, set, rect)?;
        }
        Ok(())
    }

    /// The rectangles the next depth copy copies (none: it records nothing):
    /// `reach`, what later steps read of it (`plan::reach`), within what the
    /// shade's tie-rule draws read of it (`shade`; `None`: all of it).
    pub(super) fn depth_copy_rects(&self, reach: Rect, shade: Option<&ShadeCopy>) -> Vec<Rect> {
        let (w, h) = (self.b.desc.width, self.b.desc.height);
        let rects = match shade {
            None | Some(ShadeCopy::AsPlanned) => vec![Rect::full(w, h).intersect(&reach)],
            Some(ShadeCopy::ReadBy(meshes)) => {
                let rects = &self.b.mesh_rects;
                let read = meshes.iter().flat_map(|(m, zones)| {
                    let r = rects.one(*m);
                    match zones {
                        None => vec![r],
                        Some(z) => z.iter().map(|z| z.intersect(&r)).collect(),
                    }
                });
                // The tie test also reads the texels next to a fragment's pixel.
                let grown = read.map(|r| r.grown(READ_MARGIN, READ_MARGIN, w, h));
                let grown: Vec<Rect> = grown.map(|r| r.intersect(&reach)).collect();
                // Without zones, one copy of the meshes' bounds (what the
                // embedding's host pass copies too).
                let max = match meshes.iter().any(|(_, z)| z.is_some()) {
                    true => MAX_COPY_RECTS,
                    false => 1,
                };
                tie_zones::merge(grown, max)
            }
        };
        rects.into_iter().filter(|r| !r.is_empty()).collect()
    }

    /// A final shade's draw of a mesh that can tie only in `zones` (screen
    /// rectangles, which may overlap): the tie rule `rule` (culling what never wins
    /// when `culled`, `plan::visible_side`) cut to each of them within
    /// `scissor`, the depth-equal draw `fixed` over the pieces
    /// `plan::tie_zones::depth_equal_pieces` gives (the rest of `scissor`
    /// for a few zones, all of it for more).
    pub(super) fn zoned_shade(
        &mut self,
        rule: &Draw,
        culled: bool,
        fixed: &Draw,
        scissor: Rect,
        zones: &[Rect],
    ) -> Result<(), VkError> {
        let rects: Vec<Rect> = zones
            .iter()
            .map(|z| z.intersect(&scissor))
            .filter(|r| !r.is_empty())
            .collect();
        for &r in &rects {
            self.stats
                .counts
                .count_lowering(Lowering::ShadeRule { culled }, rule, r);
            self.draw_in(rule, r)?;
        }
        for r in tie_zones::depth_equal_pieces(scissor, &rects) {
            // Outside the zones it cannot tie: a cavity's inside is drawn only
            // where it can be seen (`lower::seen_inside`).
            self.draw_seen(fixed, Lowering::FixedFunction { shade: true }, r)?;
        }
        Ok(())
    }
}
