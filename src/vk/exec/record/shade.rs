//! The recorder's side of the final shade as depth-equal draws (`plan::tie_free`,
//! README "The final shade as depth-equal draws"): the depth copy that opens a
//! final shade (`plan::tie::shade_near_depth`) reaches only the pixels its
//! tie-rule draws read, and none when every draw of the shade runs as a plain
//! depth-`EQUAL` draw (issue 9 §4: no pass whose result nobody reads). The
//! draws themselves are rewritten one by one (`TieFree::fixed_function`).

use std::collections::VecDeque;

use super::{BlockKey, Recorder};
use crate::plan::reach::READ_MARGIN;
use crate::plan::tie_free::ShadeCopy;
use crate::plan::usage::Resource;
use crate::plan::{Ds, Scissor, Step, Tex};
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

    /// `Step::CopyDepthToTexture`: depth-stencil `ds` into texture `dst`, where
    /// it is read.
    pub(super) fn copy_depth(&mut self, step: &Step, ds: Ds, dst: Tex) -> Result<(), VkError> {
        let (w, h) = (self.b.desc.width, self.b.desc.height);
        // What later steps read of the copy (`plan::reach`), within what the
        // shade's tie-rule draws read of it.
        let reach = self.copy_region();
        let rect = match self.shade_copies.pop_front() {
            None | Some(ShadeCopy::AsPlanned) => Rect::full(w, h),
            // The tie test also reads the texels next to a fragment's pixel.
            Some(ShadeCopy::ReadBy(meshes)) => {
                self.scissor(&Scissor::BoundsOf(meshes))
                    .grown(READ_MARGIN, READ_MARGIN, w, h)
            }
        }
        .intersect(&reach);
        if rect.is_empty() {
            self.stats.counts.skipped_steps += 1;
            return Ok(());
        }
        let key = BlockKey::new(&[Resource::Texture(dst)], None);
        let set = self.b.targets.sampling_set(Resource::DepthStencil(ds));
        self.open(&key, &step.usage());
        self.fullscreen_internal(&key, FragmentKind::CopyDepth, set, rect)
    }
}
