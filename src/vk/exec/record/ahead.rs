//! The recorder's look-ahead over the steps it records next, so that steps
//! that need no barrier between them share one rendering block (pay
//! only for what the frame needs). On lavapipe every block end makes
//! llvmpipe rasterize its binned scene and join its threads, and a frame's
//! fixed cost is mostly its blocks.
//!
//! A draw that writes depth and stencil only (its program writes no colour,
//! `FragmentKind::writes_color`) needs no colour attachment, but runs as well
//! in a block that has some, with every colour write masked (the pipeline's
//! blend state). So a block that such a draw opens opens instead with the
//! attachments of the first draw after it that writes colour into the same
//! depth-stencil image, when every step between them records nothing or draws
//! depth-only into that image, and no draw up to it uses an image in a way
//! that needs a barrier: SCS's clip and direct draws then share their block with
//! the final shade's depth-equal draws (one render pass where there were two).
//! The decision over the steps' summaries ([`Ahead`]) is pure ([`widened`]).

use super::{BlockKey, Recorder};
use crate::plan::lower;
use crate::plan::usage::{self, Resource, Usage, Uses};
use crate::plan::{Draw, Step};
use crate::vk::scissor::Rect;
use crate::vk::sync;

/// How far the look-ahead reads: it runs at each block a depth-only draw
/// opens, so a bound keeps a long run of such blocks linear.
pub(super) const MAX_AHEAD: usize = 64;

/// What a step does to the open block, as the recorder will record it.
#[derive(Clone, Copy, Debug)]
pub(super) enum Ahead {
    /// Records nothing: a pass mark without a timestamp, a copy nobody reads,
    /// a draw whose scissor is empty on screen.
    Nothing,
    /// A draw as recorded (after `plan::tie_free`'s lowering): the block it
    /// asks for, its scissor on screen and its usages (the normal buffer with
    /// the colour when on).
    Draw {
        key: BlockKey,
        scissor: Rect,
        uses: Uses<(Resource, Usage)>,
    },
    /// Ends the open block or records outside one: a clear, a copy, a
    /// timestamp, a loop.
    Other,
}

/// The block a block of depth-only draws into depth-stencil `ds` that opens
/// now for a draw using `first` may open as instead, and the union of the
/// scissors of the draws up to it: the block of the first draw in `ahead`
/// that writes colour into `ds`, when every step before it records nothing
/// or draws depth-only into `ds`, and no draw up to it uses an image other
/// than as the wide block's attachment in a way that needs a barrier after
/// its last usage (`last`, then each draw's) or with a deferred clear
/// (`pending`). `None`: nothing to widen to.
pub(super) fn widened(
    ds: Option<u8>,
    first: &[(Resource, Usage)],
    ahead: &[Ahead],
    last: impl Fn(Resource) -> Usage,
    pending: impl Fn(Resource) -> bool,
) -> Option<(BlockKey, Rect)> {
    // Usages in the block so far, of images other than `ds`.
    let mut seen: Vec<(Resource, Usage)> = Vec::new();
    let attached = |r: Resource| ds_res(ds) == Some(r);
    for &(r, u) in first.iter().filter(|u| !attached(u.0)) {
        seen.push((r, u));
    }
    let mut reach = Rect::EMPTY;
    for a in ahead.iter().take(MAX_AHEAD) {
        let (key, scissor, uses) = match a {
            Ahead::Nothing => continue,
            Ahead::Other => return None,
            Ahead::Draw { key, scissor, uses } => (key, scissor, uses),
        };
        if key.ds != ds {
            return None;
        }
        reach = reach.union(scissor);
        for &(r, u) in uses.iter().filter(|u| !attached(u.0)) {
            let prev = seen.iter().rev().find(|s| s.0 == r).map(|s| s.1);
            let colour = key.colors().contains(&r);
            if colour {
                // Attached from the start: nothing before may use it.
                if prev.is_some() {
                    return None;
                }
                continue;
            }
            if pending(r) || sync::needs_barrier(prev.unwrap_or_else(|| last(r)), u, true) {
                return None;
            }
            seen.push((r, u));
        }
        if key.n_colors > 0 {
            return Some((*key, reach));
        }
    }
    None
}

impl Recorder<'_> {
    /// Summarizes `steps`, the steps recorded next and in this order, for
    /// the look-ahead (after `use_reach`, `plan_shades` and
    /// `plan_direct_shades`, which decide which copies and draws record
    /// nothing). Without this, no block widens.
    pub fn plan_blocks(&mut self, steps: &[&Step]) {
        let full = Rect::full(self.b.desc.width, self.b.desc.height);
        let (mut copies, mut depth_copies) = (0, 0);
        let mut writes = self.texture_writes.iter();
        let mut ahead = Vec::with_capacity(steps.len());
        for s in steps {
            let a = match s {
                Step::Pass(_) if self.b.pass_timestamps => Ahead::Other,
                Step::Pass(_) => Ahead::Nothing,
                Step::Clear(_) | Step::Loop(_) => Ahead::Other,
                Step::CopyTexture { src, dst } | Step::CopyDepthBound { src, dst } => {
                    let rect = self.copy_regions.get(copies).copied().unwrap_or(full);
                    copies += 1;
                    match src == dst || rect.is_empty() {
                        true => Ahead::Nothing,
                        false => Ahead::Other,
                    }
                }
                Step::CopyDepthToTexture { .. } => {
                    let reach = self.copy_regions.get(copies).copied().unwrap_or(full);
                    let shade = self.shade_copies.get(depth_copies);
                    copies += 1;
                    depth_copies += 1;
                    match self.depth_copy_rects(reach, shade).is_empty() {
                        true => Ahead::Nothing,
                        false => Ahead::Other,
                    }
                }
                Step::Draw(d) => {
                    // As `Recorder::draw` takes `dead_texture_write`'s answers.
                    let dead = lower::dead_write(d, || writes.next().copied());
                    self.ahead_draw(d, dead)
                }
            };
            ahead.push(a);
        }
        self.ahead = ahead;
        self.next = 0;
    }

    /// A draw as `Recorder::draw` will record it: the same lowering
    /// (`record/lower.rs`), summarized by the block its first recorded draw
    /// asks for.
    fn ahead_draw(&self, draw: &Draw, dead_write: bool) -> Ahead {
        let scissor = self.scissor(&draw.scissor);
        let lowered = lower::lower(draw, dead_write, scissor, self.b.ties, &self.direct);
        let Some(d) = lowered.block_draw() else {
            return Ahead::Nothing;
        };
        let uses = self.draw_uses(d);
        Ahead::Draw {
            key: BlockKey::of_draw(&uses, d.ds),
            scissor,
            uses,
        }
    }

    /// The block a draw that asks for block `own` (its program `writes` colour
    /// or not), cut to `scissor` and using `uses`, records in: the open block
    /// when it writes no colour, draws into the same depth-stencil image
    /// inside the block's render area and needs no barrier (a parity draw
    /// between two draws into the surface and its depth texture, SCS's front,
    /// parity and exit draws of each product, ends no block); the block of
    /// the colour draws that follow when it would open a block of its own
    /// ([`widened`]); otherwise `own`.
    pub(super) fn block_for(
        &self,
        own: BlockKey,
        writes: bool,
        scissor: Rect,
        uses: &[(Resource, Usage)],
    ) -> BlockKey {
        assert_eq!(
            own.n_colors == 0,
            !writes,
            "a program writes colour exactly when its draw has colour targets"
        );
        if writes {
            return own;
        }
        if let Some(open) = self.block.filter(|b| b.ds == own.ds) {
            // The depth-stencil image as the block's; nothing else the
            // block attaches (sampling a colour attachment would read what
            // the block writes), nothing that needs a barrier or a clear.
            let fits = self.render_area.contains(&scissor)
                && uses.iter().all(|&(r, u)| {
                    ds_res(open.ds) == Some(r)
                        || !(open.colors().contains(&r)
                            || self.pending_clear.contains_key(&r)
                            || sync::needs_barrier(self.state.get(r), u, true))
                });
            if fits {
                return open;
            }
        }
        let ahead = self.ahead.get(self.next..).unwrap_or_default();
        let wide = widened(
            own.ds,
            uses,
            ahead,
            |r| self.state.get(r),
            |r| self.pending_clear.contains_key(&r),
        );
        let Some((wide, reach)) = wide else {
            return own;
        };
        // The wide block's render area must hold every draw it will hold:
        // those up to its first colour draw, and the colour draws after,
        // which lie in their colour attachments' regions.
        let area = self.render_area(wide.colors().iter().copied().chain(ds_res(wide.ds)));
        let colours = self.render_area(wide.colors().iter().copied());
        match area.contains(&reach.union(&scissor)) && area.contains(&colours) {
            true => wide,
            false => own,
        }
    }

    /// A draw's usages as the recorder records them: the normal buffer goes
    /// with the colour, as the last attachment (the programs' `NORMALS`
    /// variants write it there).
    pub(super) fn draw_uses(&self, draw: &Draw) -> Uses<(Resource, Usage)> {
        usage::with_normals(draw.usage(), self.b.normals)
    }
}

fn ds_res(ds: Option<u8>) -> Option<Resource> {
    ds.map(Resource::DepthStencil)
}

#[cfg(test)]
mod tests {
    use super::*;

    const DS: Resource = Resource::DepthStencil(0);
    const TEX: Resource = Resource::Texture(0);

    fn rect(x0: u32, y0: u32, x1: u32, y1: u32) -> Rect {
        Rect { x0, y0, x1, y1 }
    }

    /// A draw into depth-stencil 0 with colour targets `colors`, sampling
    /// texture 0 when `samples`.
    fn draw(colors: &[Resource], samples: bool, scissor: Rect) -> Ahead {
        let mut uses = Uses::default();
        for &c in colors {
            uses.push((c, Usage::ColorTarget));
        }
        uses.push((DS, Usage::DepthStencilTarget));
        if samples {
            uses.push((TEX, Usage::Sampled));
        }
        Ahead::Draw {
            key: BlockKey::of_draw(&uses, 0),
            scissor,
            uses,
        }
    }

    fn shade(scissor: Rect) -> Ahead {
        draw(&[Resource::Color, Resource::Prim], false, scissor)
    }

    fn depth(scissor: Rect) -> Ahead {
        draw(&[], false, scissor)
    }

    /// Every image last used as `usage`; no clear pending.
    fn wide(
        first: &[(Resource, Usage)],
        ahead: &[Ahead],
        usage: Usage,
    ) -> Option<(BlockKey, Rect)> {
        widened(Some(0), first, ahead, |_| usage, |_| false)
    }

    const FIRST: [(Resource, Usage); 1] = [(DS, Usage::DepthStencilTarget)];

    #[test]
    fn a_direct_draw_opens_the_shade_block_past_marks_and_idle_copies() {
        // onebox: the direct draw, a pass mark, the skipped depth copy, the shade.
        let (a, b) = (rect(0, 0, 10, 10), rect(5, 5, 20, 20));
        let ahead = [Ahead::Nothing, depth(a), Ahead::Nothing, shade(b), shade(a)];
        let (key, reach) = wide(&FIRST, &ahead, Usage::CopySrc).expect("widens");
        assert_eq!(key.colors(), &[Resource::Color, Resource::Prim]);
        assert_eq!(key.ds, Some(0));
        assert_eq!(reach, a.union(&b), "the draws up to the first colour draw");
    }

    #[test]
    fn a_clear_copy_or_timestamp_between_ends_the_look_ahead() {
        let r = rect(0, 0, 4, 4);
        assert!(wide(&FIRST, &[depth(r), Ahead::Other, shade(r)], Usage::CopySrc).is_none());
        assert!(
            wide(&FIRST, &[], Usage::CopySrc).is_none(),
            "nothing follows"
        );
        assert!(
            wide(&FIRST, &[depth(r), depth(r)], Usage::CopySrc).is_none(),
            "no colour draw follows"
        );
    }

    #[test]
    fn another_depth_stencil_image_ends_the_look_ahead() {
        let r = rect(0, 0, 4, 4);
        let mut other = shade(r);
        if let Ahead::Draw { key, .. } = &mut other {
            key.ds = Some(1);
        }
        assert!(wide(&FIRST, &[other], Usage::CopySrc).is_none());
    }

    #[test]
    fn a_texture_written_then_sampled_needs_its_barrier() {
        let r = rect(0, 0, 4, 4);
        // The draw opening the block samples texture 0, which was last a
        // colour target: fine for it (its own barrier comes first), but a
        // draw after it may sample it in the same block only if nothing wrote it.
        let first = [(DS, Usage::DepthStencilTarget), (TEX, Usage::Sampled)];
        let sampling_shade = draw(&[Resource::Color, Resource::Prim], true, r);
        assert!(
            wide(
                &first,
                &[draw(&[], true, r), sampling_shade],
                Usage::Sampled
            )
            .is_some(),
            "sampled throughout: no barrier"
        );
        assert!(
            wide(&FIRST, &[sampling_shade], Usage::ColorTarget).is_none(),
            "written last: the shade's sampling needs a barrier"
        );
        assert!(
            widened(
                Some(0),
                &FIRST,
                &[sampling_shade],
                |_| Usage::Sampled,
                |r| r == TEX
            )
            .is_none(),
            "a deferred clear of the sampled texture is recorded before it"
        );
    }

    #[test]
    fn a_block_never_attaches_what_a_draw_in_it_samples() {
        // SCS's parity draw samples the surface texture its exit draw writes
        // as a colour target: they need a barrier between them.
        let r = rect(0, 0, 4, 4);
        let first = [(DS, Usage::DepthStencilTarget), (TEX, Usage::Sampled)];
        let exit = draw(&[TEX], false, r);
        assert!(wide(&first, &[exit], Usage::Sampled).is_none());
        let parity = draw(&[], true, r);
        assert!(wide(&FIRST, &[parity, exit], Usage::Sampled).is_none());
        // Without the sampling, the exit's block serves both.
        let (key, _) = wide(&FIRST, &[depth(r), exit], Usage::Sampled).expect("widens");
        assert_eq!(key.colors(), &[TEX]);
    }

    #[test]
    fn the_look_ahead_is_bounded() {
        let r = rect(0, 0, 4, 4);
        let mut ahead = vec![Ahead::Nothing; MAX_AHEAD];
        ahead.push(shade(r));
        assert!(wide(&FIRST, &ahead, Usage::CopySrc).is_none());
        ahead.remove(0);
        assert!(wide(&FIRST, &ahead, Usage::CopySrc).is_some());
    }
}
