//! The recorder's clears and copies ("clears go through load ops,
//! or are scissored to what will be read"). A plan's `Clear` is deferred to the
//! image's next use and reaches only the part of the image that later steps, or
//! the read-back after the frame, can read before the image is cleared or
//! replaced again; texture and depth copies copy only that part of their
//! destination (`plan::reach`, pure). A clear nobody reads is dropped; so is one
//! to the value an earlier clear left with no write since ([`ClearNeed::Held`]).
//! The outputs keep their pixels between frames, so their clears reach only
//! what earlier frames and this one dirty (`plan::reach::Kept`).
//!
//! How a clear is recorded depends on [`ClearMode`] and the next use:
//! - the next use renders into the image: the new block's load op over a render
//!   area cut to the cleared regions (`LoadOp`), or `vkCmdClearAttachments` of
//!   the region just after the block begins (`Command`; the load op is then
//!   `DONT_CARE` for images nothing outside the region is read of, `LOAD` for
//!   outputs);
//! - the next use samples or copies it: a clear-only block of the region, or
//!   `vkCmdClear*Image` when the region is the whole image.
//!
//! On lavapipe every clear command waits for the rasterizer threads and fills on
//! the calling thread (`rep stos` rows, ~9% of a small CST frame's CPU before
//! this), so the region is what it costs (docs/executor.md).

use crate::plan::lower;
use std::collections::VecDeque;

use ash::vk;

use super::{BlockKey, ClearMode, Recorder};
use crate::plan::reach::{self, cleared, ClearNeed, FrameReach};
use crate::plan::usage::{Resource, Usage};
use crate::plan::{Clear, Draw};
use crate::vk::conv;
use crate::vk::image::range;
use crate::vk::scissor::Rect;
use crate::vk::sync;

/// A deferred clear: its value and the region it must reach.
#[derive(Clone, Copy)]
pub(super) struct PendingClear {
    pub value: vk::ClearValue,
    pub rect: Rect,
}

impl Recorder<'_> {
    /// The frame's outputs, read whole after it (`output_ds`: its output depth).
    pub(super) fn outputs(&self, output_ds: u8) -> Vec<Resource> {
        reach::outputs(output_ds, self.b.normals)
    }

    /// Takes the regions of the clears and copies recorded next, in order to
    /// the end of the recording (`plan::reach`: empty lists, whole images),
    /// and the outputs of the frame or plan recorded next (`output_ds`: its
    /// output depth).
    pub fn use_reach(&mut self, reach: &FrameReach, output_ds: u8) {
        self.set_outputs(output_ds);
        self.clear_regions = VecDeque::from(reach.clears.clone());
        self.copy_regions = VecDeque::from(reach.copies.clone());
        self.texture_writes = VecDeque::from(reach.texture_writes.clone());
    }

    /// Whether `draw`'s texture write is read by nobody (`plan::reach`;
    /// unknown without planned regions: kept), counted; the draw then tests
    /// and writes depth and stencil only (`record/lower.rs`).
    pub(super) fn dead_texture_write(&mut self, draw: &Draw) -> bool {
        let dead = lower::dead_write(draw, || self.texture_writes.pop_front());
        self.stats.counts.dead_texture_writes += dead as u64;
        dead
    }

    /// The outputs of the plan recorded next (`output_ds`: its output depth).
    pub fn set_outputs(&mut self, output_ds: u8) {
        self.outputs = self.outputs(output_ds);
    }

    /// The region the next texture or depth copy copies (the whole image when
    /// no regions were planned).
    pub(super) fn copy_region(&mut self) -> Rect {
        let full = Rect::full(self.b.desc.width, self.b.desc.height);
        self.copy_regions.pop_front().unwrap_or(full)
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

    /// Whether pending clear `c` of `r` may discard `r`'s contents in its
    /// barrier (`reach::clear_discards`: it reaches the whole image, or `r`
    /// keeps nothing outside the region).
    pub(super) fn clear_discards(&self, r: Resource, c: &PendingClear) -> bool {
        let full = Rect::full(self.b.desc.width, self.b.desc.height);
        reach::clear_discards(r, c.rect, full, &self.outputs)
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
        let discarded: Vec<Resource> = clears
            .iter()
            .filter(|(r, c)| self.clear_discards(*r, c))
            .map(|c| c.0)
            .collect();
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
            self.count_cleared(r, c.rect.area());
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

    /// The load op of attachment `r` of a block about to begin over `area`
    /// (which holds the regions of its attachments' pending clears): its
    /// pending clear becomes the load op (`LoadOp`) or a clear of its region
    /// once the block has begun (`Command`, added to `in_block` as
    /// `(attachment index or None for depth-stencil, clear)`).
    pub(super) fn load_op(
        &mut self,
        r: Resource,
        index: Option<u32>,
        area: Rect,
        in_block: &mut Vec<(Option<u32>, Resource, PendingClear)>,
    ) -> (vk::AttachmentLoadOp, vk::ClearValue) {
        let Some(c) = self.pending_clear.remove(&r) else {
            return (vk::AttachmentLoadOp::LOAD, vk::ClearValue::default());
        };
        match self.b.clears {
            ClearMode::LoadOp => {
                self.stats.counts.load_op_clears += 1;
                self.count_cleared(r, area.area());
                (vk::AttachmentLoadOp::CLEAR, c.value)
            }
            ClearMode::Command => {
                in_block.push((index, r, c));
                // Only the region is read, and it is cleared just below; an
                // output keeps its other pixels for later frames.
                match self.outputs.contains(&r) {
                    true => (vk::AttachmentLoadOp::LOAD, vk::ClearValue::default()),
                    false => (vk::AttachmentLoadOp::DONT_CARE, vk::ClearValue::default()),
                }
            }
        }
    }

    /// The render area of a block with attachments `rs` about to begin: the
    /// union of their pending clears' regions, or the whole image when none
    /// has one. Every draw the block will hold lies inside each such region
    /// (they use the image before it is cleared again, `plan::reach`), so the
    /// load-op clear of the area reaches every pixel the region asks for.
    pub(super) fn render_area(&self, rs: impl Iterator<Item = Resource>) -> Rect {
        let area = rs
            .filter_map(|r| self.pending_clear.get(&r))
            .fold(Rect::EMPTY, |a, c| a.union(&c.rect));
        match area.is_empty() {
            true => Rect::full(self.b.desc.width, self.b.desc.height),
            false => area,
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
            // rectangle lies within the render area (`render_area`).
            unsafe {
                self.b
                    .device
                    .cmd_clear_attachments(self.cmd, &[att], &[rect])
            };
            self.stats.counts.clear_commands += 1;
            self.count_cleared(*r, c.rect.area());
        }
    }

    /// Counts `pixels` of `r` cleared, and their bytes in `r`'s format.
    fn count_cleared(&mut self, r: Resource, pixels: u64) {
        let format = self.b.targets.image(r).desc.format;
        self.stats.counts.cleared_pixels += pixels;
        self.stats.counts.cleared_bytes += pixels * conv::texel_bytes(format);
    }
}
