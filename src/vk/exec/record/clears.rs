//! The recorder's clears (issue 9 §4: "clears go through load ops, or are
//! scissored to what will be read"). A plan's `Clear` is deferred to the image's
//! next use and reaches only the part of the image that later steps can read
//! before the image is cleared or replaced again ([`clear_regions`], pure): the
//! union of the scissors of the draws that use it, grown by [`READ_MARGIN`], or
//! the whole image when it is copied, sampled by a full-screen copy or read back.
//! A clear nobody reads is dropped; so is one to the value an earlier clear
//! left with no write since ([`ClearNeed::Held`]).
//!
//! How a clear is recorded depends on [`ClearMode`] and the next use:
//! - the next use renders into the image: the new block's load op (`LoadOp`), or
//!   `vkCmdClearAttachments` of the region just after the block begins
//!   (`Command`; the load op is then `DONT_CARE`: nothing outside the region is
//!   read);
//! - the next use samples or copies it: a clear-only block with
//!   `vkCmdClearAttachments` of the region, or `vkCmdClear*Image` when the
//!   region is the whole image.
//!
//! On lavapipe every clear waits for the rasterizer threads and fills on the
//! calling thread (`rep stos` rows, ~9% of a small CST frame's CPU before this),
//! so the region is what it costs; its load-op clears are slower still (README,
//! "Executor").

use std::collections::VecDeque;

use ash::vk;

use super::{BlockKey, ClearMode, Recorder};
use crate::plan::usage::{Resource, Usage};
use crate::plan::{Clear, Scissor, Step};
use crate::vk::conv;
use crate::vk::image::range;
use crate::vk::scissor::Rect;
use crate::vk::sync;

/// Pixels beyond a draw's scissor that its fragment programs may read: the tie
/// test's neighbour fetch (`shaders/tie.glsl`, one texel), which a helper
/// invocation of the pixel quad just outside the scissor also makes (one more).
pub const READ_MARGIN: u32 = 2;

/// A deferred clear: its value and the region it must reach.
#[derive(Clone, Copy)]
pub(super) struct PendingClear {
    pub value: vk::ClearValue,
    pub rect: Rect,
}

/// The images `clear` clears, in recording order (`normals`: the normal buffer
/// goes with the colour).
pub fn cleared(clear: &Clear, normals: bool) -> Vec<Resource> {
    match *clear {
        Clear::DepthStencil { ds, .. } => vec![Resource::DepthStencil(ds)],
        Clear::Texture { tex, .. } => vec![Resource::Texture(tex)],
        Clear::Color => {
            let mut v = vec![Resource::Color, Resource::Prim];
            v.extend(normals.then_some(Resource::Normal));
            v
        }
    }
}

/// What one image's clear must do ([`clear_regions`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClearNeed {
    /// Clear this region (empty: nobody reads the value, drop the clear).
    Reach(Rect),
    /// Nothing: an earlier clear of the image to the same value, with no write
    /// since, already reaches everything read after this one.
    Held,
}

/// Whether `step` may write `r` (a target of a draw or depth copy, or a copy's
/// destination); clears are not counted.
fn may_write(step: &Step, r: Resource, normals: bool) -> bool {
    let uses = step.usage();
    let color = uses
        .iter()
        .any(|u| u.0 == Resource::Color && u.1 == Usage::ColorTarget);
    uses.iter()
        .any(|&(res, u)| res == r && u.writes() && u != Usage::Clear)
        || (normals && color && r == Resource::Normal)
}

/// For every image every `Clear` of `steps` clears, in order ([`cleared`]):
/// what the clear must do. A clear reaches the region of the `width × height`
/// image that the steps after it can read before the image is wholly replaced,
/// or cleared again after a write or to another value; a clear to the value an
/// earlier clear left, with no write since, is [`ClearNeed::Held`] and the
/// earlier clear reaches what is read after it (CST clears its floor texture
/// to the same depth for every product and only samples it). `scissor`
/// resolves a draw's scissor (an empty one: the draw is skipped); `outputs`
/// are read whole after the frame.
pub fn clear_regions(
    steps: &[&Step],
    scissor: impl Fn(&Scissor) -> Rect,
    outputs: &[Resource],
    normals: bool,
    (width, height): (u32, u32),
) -> Vec<ClearNeed> {
    let full = Rect::full(width, height);
    let region = |value: &Clear, after: &[&Step], r: Resource| -> Rect {
        let mut region = Rect::EMPTY;
        let mut written = false;
        for s in after {
            match s {
                Step::Clear(c) if cleared(c, normals).contains(&r) => {
                    if written || c != value {
                        return region;
                    }
                }
                Step::CopyTexture { src, dst } if src != dst => {
                    if r == Resource::Texture(*src) {
                        return full;
                    }
                    if r == Resource::Texture(*dst) {
                        return region;
                    }
                }
                // A full-screen draw: reads the whole depth, writes the whole texture.
                Step::CopyDepthToTexture { ds, dst } => {
                    if r == Resource::DepthStencil(*ds) {
                        return full;
                    }
                    if r == Resource::Texture(*dst) {
                        return region;
                    }
                }
                Step::Draw(d) => {
                    let uses = s.usage();
                    let color = uses.iter().any(|u| u.0 == Resource::Color);
                    let used = uses.iter().any(|u| u.0 == r)
                        || (normals && color && r == Resource::Normal);
                    let rect = scissor(&d.scissor);
                    if used && !rect.is_empty() {
                        region = region.union(&rect.grown(READ_MARGIN, READ_MARGIN, width, height));
                        written |= may_write(s, r, normals);
                    }
                }
                _ => {}
            }
        }
        if outputs.contains(&r) {
            full
        } else {
            region
        }
    };
    // The clear each image holds unchanged since (no write after it).
    let mut held: Vec<(Resource, Clear)> = Vec::new();
    let mut out = Vec::new();
    for (i, s) in steps.iter().enumerate() {
        if let Step::Clear(c) = s {
            for r in cleared(c, normals) {
                if held.contains(&(r, *c)) {
                    out.push(ClearNeed::Held);
                    continue;
                }
                held.retain(|h| h.0 != r);
                held.push((r, *c));
                out.push(ClearNeed::Reach(region(c, &steps[i + 1..], r)));
            }
        } else {
            let skipped = matches!(s, Step::Draw(d) if scissor(&d.scissor).is_empty());
            if !skipped {
                held.retain(|&(r, _)| !may_write(s, r, normals));
            }
        }
    }
    out
}

impl Recorder<'_> {
    /// Computes the regions of the clears of `steps`, which the recorder then
    /// records in this order to the end of the frame (whose depth-stencil output
    /// is `output_ds`). Without this, clears reach the whole image.
    pub fn plan_clears(&mut self, steps: &[&Step], output_ds: u8) {
        let mut outputs = vec![
            Resource::Color,
            Resource::Prim,
            Resource::DepthStencil(output_ds),
        ];
        outputs.extend(self.b.normals.then_some(Resource::Normal));
        let size = (self.b.desc.width, self.b.desc.height);
        let regions = clear_regions(steps, |s| self.scissor(s), &outputs, self.b.normals, size);
        self.clear_regions = VecDeque::from(regions);
    }

    /// `Step::Clear`: deferred to each image's next use (dropped when nothing
    /// reads it).
    pub(super) fn clear(&mut self, clear: &Clear) {
        for r in cleared(clear, self.b.normals) {
            let full = Rect::full(self.b.desc.width, self.b.desc.height);
            let rect = match self.clear_regions.pop_front() {
                None => full,
                Some(ClearNeed::Reach(rect)) => rect,
                // The image holds the value wherever it is read: no command,
                // no barrier, its block goes on.
                Some(ClearNeed::Held) => continue,
            };
            let attached = self.block.as_ref().is_some_and(|b| {
                b.colors().contains(&r) || b.ds.map(Resource::DepthStencil) == Some(r)
            });
            if attached {
                self.end_block();
            }
            if rect.is_empty() {
                // An earlier clear's region is also never read now.
                self.pending_clear.remove(&r);
                continue;
            }
            let value = self.clear_value(clear, r);
            self.pending_clear.insert(r, PendingClear { value, rect });
        }
    }

    fn clear_value(&self, clear: &Clear, r: Resource) -> vk::ClearValue {
        let reversed = self.b.desc.reversed_z;
        let color = |float32| vk::ClearValue {
            color: vk::ClearColorValue { float32 },
        };
        match (*clear, r) {
            (Clear::DepthStencil { depth, stencil, .. }, _) => vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: conv::depth_value(depth, reversed),
                    stencil: stencil as u32,
                },
            },
            (Clear::Texture { depth, .. }, _) => {
                color([conv::depth_value(depth, reversed), 0.0, 0.0, 0.0])
            }
            (Clear::Color, Resource::Prim) => vk::ClearValue {
                color: vk::ClearColorValue { uint32: [0; 4] },
            },
            (Clear::Color, Resource::Normal) => color([0.0; 4]),
            (Clear::Color, _) => {
                let bg = self.b.scene.background.map(|c| c as f32 / 255.0);
                color([bg[0], bg[1], bg[2], 1.0])
            }
        }
    }

    /// Flushes the pending clears of images used other than as attachments, and
    /// drops those a whole-image write replaces. Attachments keep theirs for the
    /// block (`begin_block`).
    pub(super) fn settle_clears(&mut self, uses: &[(Resource, Usage)]) {
        let mut flush = Vec::new();
        for &(r, u) in uses {
            if !self.pending_clear.contains_key(&r) {
                continue;
            }
            match u {
                Usage::ColorTarget | Usage::DepthStencilTarget => {}
                Usage::CopyDst | Usage::Clear => {
                    self.pending_clear.remove(&r);
                }
                Usage::Sampled | Usage::CopySrc => flush.push(r),
            }
        }
        self.flush_clears(&flush);
    }

    /// Records the pending clears of `rs` now (their next use is not as an
    /// attachment of a new block), after one barrier for all of them (lavapipe
    /// waits for its rasterizer at every barrier): whole images by clear
    /// commands, smaller regions by a clear-only block each.
    pub(super) fn flush_clears(&mut self, rs: &[Resource]) {
        let full = Rect::full(self.b.desc.width, self.b.desc.height);
        let clears: Vec<(Resource, PendingClear)> = rs
            .iter()
            .filter_map(|r| self.pending_clear.remove(r).map(|c| (*r, c)))
            .collect();
        if clears.is_empty() {
            return;
        }
        let in_block = |r: Resource, c: &PendingClear| match r {
            _ if c.rect == full => Usage::Clear,
            Resource::DepthStencil(_) => Usage::DepthStencilTarget,
            _ => Usage::ColorTarget,
        };
        let uses: Vec<_> = clears.iter().map(|(r, c)| (*r, in_block(*r, c))).collect();
        let discarded: Vec<Resource> = clears.iter().map(|c| c.0).collect();
        self.end_block();
        self.transitions_with(&uses, false, &discarded);
        let layout = sync::access(Usage::Clear).layout;
        for (r, c) in clears {
            if in_block(r, &c) != Usage::Clear {
                let key = match r {
                    Resource::DepthStencil(d) => BlockKey::new(&[], Some(d)),
                    _ => BlockKey::new(&[r], None),
                };
                self.pending_clear.insert(r, c);
                self.begin_block(&key);
                self.end_block();
                continue;
            }
            let img = self.b.targets.image(r);
            self.stats.counts.clear_commands += 1;
            self.stats.counts.cleared_pixels += c.rect.area();
            if img.desc.is_depth_stencil() {
                // SAFETY: outside rendering; the image allows transfer dst and is in `layout`;
                // a depth-stencil clear value was stored for it.
                unsafe {
                    self.b.device.cmd_clear_depth_stencil_image(
                        self.cmd,
                        img.raw,
                        layout,
                        &c.value.depth_stencil,
                        &[range(img.desc.aspect())],
                    )
                };
            } else {
                // SAFETY: as above, with a colour clear value.
                unsafe {
                    self.b.device.cmd_clear_color_image(
                        self.cmd,
                        img.raw,
                        layout,
                        &c.value.color,
                        &[range(vk::ImageAspectFlags::COLOR)],
                    )
                };
            }
        }
    }

    /// The load op of attachment `r` of a block about to begin: its pending
    /// clear becomes the load op (`LoadOp`) or a clear of its region once the
    /// block has begun (`Command`, added to `in_block` as `(attachment index or
    /// None for depth-stencil, clear)`).
    pub(super) fn load_op(
        &mut self,
        r: Resource,
        index: Option<u32>,
        in_block: &mut Vec<(Option<u32>, Resource, PendingClear)>,
    ) -> (vk::AttachmentLoadOp, vk::ClearValue) {
        let Some(c) = self.pending_clear.remove(&r) else {
            return (vk::AttachmentLoadOp::LOAD, vk::ClearValue::default());
        };
        match self.b.clears {
            ClearMode::LoadOp => {
                self.stats.counts.load_op_clears += 1;
                self.stats.counts.cleared_pixels +=
                    Rect::full(self.b.desc.width, self.b.desc.height).area();
                (vk::AttachmentLoadOp::CLEAR, c.value)
            }
            ClearMode::Command => {
                in_block.push((index, r, c));
                // Only the region is read, and it is cleared just below.
                (vk::AttachmentLoadOp::DONT_CARE, vk::ClearValue::default())
            }
        }
    }

    /// `vkCmdClearAttachments` of each clear in `in_block` (the open block's).
    pub(super) fn clear_in_block(&mut self, in_block: &[(Option<u32>, Resource, PendingClear)]) {
        for (index, r, c) in in_block {
            let img = self.b.targets.image(*r);
            let att = vk::ClearAttachment {
                aspect_mask: img.desc.aspect(),
                color_attachment: index.unwrap_or(0),
                clear_value: c.value,
            };
            let rect = vk::ClearRect {
                rect: conv::rect2d(c.rect),
                base_array_layer: 0,
                layer_count: 1,
            };
            // SAFETY: inside the block that has `r` as this attachment; the
            // rectangle lies within the render area (the whole image).
            unsafe {
                self.b
                    .device
                    .cmd_clear_attachments(self.cmd, &[att], &[rect])
            };
            self.stats.counts.clear_commands += 1;
            self.stats.counts.cleared_pixels += c.rect.area();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{Draw, Fragment, Geometry};

    const W: u32 = 100;
    const H: u32 = 80;

    /// Scissors: `BoundsOf([m])` is the 10×10 square at (10m, 10m); full is full.
    fn scissor(s: &Scissor) -> Rect {
        match s {
            Scissor::Full => Rect::full(W, H),
            Scissor::BoundsOf(ms) => ms.iter().fold(Rect::EMPTY, |r, &m| {
                let o = 10 * m;
                r.union(&Rect {
                    x0: o,
                    y0: o,
                    x1: o + 10,
                    y1: o + 10,
                })
            }),
            Scissor::Within { .. } | Scissor::Overlap { .. } | Scissor::Run { .. } => {
                unreachable!("these tests draw with full and BoundsOf scissors")
            }
        }
    }

    fn draw(fragment: Fragment, ds: u8, mesh: u32) -> Step {
        let Step::Draw(mut d) = Draw::for_test(Geometry::Mesh(mesh), fragment) else {
            unreachable!()
        };
        d.ds = ds;
        d.scissor = Scissor::BoundsOf(vec![mesh]);
        Step::Draw(d)
    }

    fn square(m: u32) -> Rect {
        scissor(&Scissor::BoundsOf(vec![m])).grown(READ_MARGIN, READ_MARGIN, W, H)
    }

    fn needs(steps: &[Step], outputs: &[Resource]) -> Vec<ClearNeed> {
        let refs: Vec<&Step> = steps.iter().collect();
        clear_regions(&refs, scissor, outputs, false, (W, H))
    }

    /// The regions of clears that all reach something.
    fn regions(steps: &[Step], outputs: &[Resource]) -> Vec<Rect> {
        needs(steps, outputs)
            .into_iter()
            .map(|n| match n {
                ClearNeed::Reach(r) => r,
                ClearNeed::Held => panic!("no clear of these tests is held"),
            })
            .collect()
    }

    #[test]
    fn a_clear_reaches_the_scissors_of_the_draws_until_the_next_clear() {
        let clear_ds = Step::Clear(Clear::DepthStencil {
            ds: 1,
            depth: 1.0,
            stencil: 0,
        });
        let steps = vec![
            clear_ds.clone(),
            draw(Fragment::None, 1, 1),
            draw(Fragment::None, 1, 3),
            // Another image: not a use of ds 1.
            draw(Fragment::None, 0, 6),
            clear_ds,
            draw(Fragment::None, 1, 2),
        ];
        let r = regions(&steps, &[]);
        assert_eq!(r, vec![square(1).union(&square(3)), square(2)]);
        assert_eq!(
            r[0],
            Rect {
                x0: 8,
                y0: 8,
                x1: 42,
                y1: 42
            }
        );
    }

    #[test]
    fn sampled_textures_copies_and_outputs_need_what_they_read() {
        let clear_tex = |tex| Step::Clear(Clear::Texture { tex, depth: 0.0 });
        let peel = draw(
            Fragment::Peel {
                prev: 0,
                out: 1,
                shade: false,
            },
            0,
            4,
        );
        let steps = vec![
            clear_tex(0),
            clear_tex(1),
            Step::Clear(Clear::Color),
            peel,
            // The copy reads all of 1 and replaces all of 2.
            clear_tex(2),
            Step::CopyTexture { src: 1, dst: 2 },
            // Read by nobody.
            clear_tex(3),
        ];
        let r = regions(&steps, &[Resource::Color, Resource::Prim]);
        let full = Rect::full(W, H);
        // tex 0 sampled by the peel, tex 1 copied whole, colour and ids read
        // back, tex 2 replaced by the copy, tex 3 unread.
        assert_eq!(
            r,
            vec![square(4), full, full, full, Rect::EMPTY, Rect::EMPTY]
        );
    }

    #[test]
    fn a_depth_copy_reads_the_whole_depth_and_skipped_draws_read_nothing() {
        let steps = vec![
            Step::Clear(Clear::DepthStencil {
                ds: 0,
                depth: 1.0,
                stencil: 0,
            }),
            Step::Clear(Clear::Texture { tex: 5, depth: 1.0 }),
            Step::CopyDepthToTexture { ds: 0, dst: 5 },
            Step::Clear(Clear::Texture { tex: 6, depth: 1.0 }),
            // Off screen (empty scissor): skipped by the recorder.
            {
                let Step::Draw(mut d) = draw(Fragment::WriteDepth { out: 6 }, 0, 1) else {
                    unreachable!()
                };
                d.scissor = Scissor::BoundsOf(vec![]);
                Step::Draw(d)
            },
        ];
        let r = regions(&steps, &[]);
        assert_eq!(r, vec![Rect::full(W, H), Rect::EMPTY, Rect::EMPTY]);
    }

    #[test]
    fn the_normal_buffer_goes_with_the_colour() {
        let steps = vec![Step::Clear(Clear::Color), draw(Fragment::Shade, 0, 2)];
        let refs: Vec<&Step> = steps.iter().collect();
        let r = clear_regions(&refs, scissor, &[], true, (W, H));
        assert_eq!(r, vec![ClearNeed::Reach(square(2)); 3]);
    }

    /// CST's floor: cleared to one value per product, only ever sampled. The
    /// first clear reaches every product's reads; the others need nothing.
    #[test]
    fn a_clear_to_the_value_the_image_holds_is_held() {
        let floor = Step::Clear(Clear::Texture { tex: 0, depth: 0.0 });
        let peel = |mesh| {
            draw(
                Fragment::Peel {
                    prev: 0,
                    out: 1,
                    shade: false,
                },
                0,
                mesh,
            )
        };
        let steps = vec![floor.clone(), peel(1), floor.clone(), peel(3)];
        assert_eq!(
            needs(&steps, &[]),
            vec![
                ClearNeed::Reach(square(1).union(&square(3))),
                ClearNeed::Held
            ]
        );
        // Another value, or a write in between: the second clear is needed and
        // ends the first one's reach.
        let other = Step::Clear(Clear::Texture { tex: 0, depth: 1.0 });
        let steps = vec![floor.clone(), peel(1), other, peel(3)];
        assert_eq!(regions(&steps, &[]), vec![square(1), square(3)]);
        let write = draw(Fragment::WriteDepth { out: 0 }, 0, 2);
        let steps = vec![floor.clone(), peel(1), write, floor.clone(), peel(3)];
        assert_eq!(
            regions(&steps, &[]),
            vec![square(1).union(&square(2)), square(3)]
        );
        // A write that is skipped (empty scissor) writes nothing.
        let Step::Draw(mut skipped) = draw(Fragment::WriteDepth { out: 0 }, 0, 2) else {
            unreachable!()
        };
        skipped.scissor = Scissor::BoundsOf(vec![]);
        let steps = vec![floor.clone(), Step::Draw(skipped), floor, peel(3)];
        assert_eq!(
            needs(&steps, &[]),
            vec![ClearNeed::Reach(square(3)), ClearNeed::Held]
        );
    }
}
