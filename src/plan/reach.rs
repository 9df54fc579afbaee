//! What part of each image a frame's clears and copies must reach (clears
//! go through load ops, or are scissored to what will be read). Pure:
//! the executor resolves scissors to rectangles and records what this says.
//!
//! A backward pass over the frame's steps (loops unrolled) keeps, for every
//! image, the region that later steps can still read: a draw reads every image
//! it uses within its scissor (grown by [`READ_MARGIN`]), a copy reads its
//! source where its destination is read after it, and the frame's outputs are
//! read after the frame. A clear (or a copy into an image) reaches exactly the
//! region read after it, and nothing before it reads the image. So a pixel
//! outside that region is never read before the image is cleared or replaced
//! again, whatever it holds: the clear or copy may leave it alone.
//!
//! The outputs (colour, ids, output depth, normals) are read whole after the
//! frame, but they keep their pixels from one frame to the next: where an
//! output was last cleared to the value this frame clears it to and not
//! written since ([`Kept`]), it already holds that value and needs no clear.
//! The last clear of an output then reaches the pixels the previous frames
//! left dirty and those this frame writes before it; what stays outside holds
//! the background, the far depth and id 0 (the GPU test
//! `outside_the_csg_the_outputs_hold_the_background` checks it frame after
//! frame).
//!
//! The same pass finds the texture writes nobody reads: a draw that writes
//! a depth texture ([`Fragment::WriteDepth`]) where no later step reads it
//! before it is cleared or replaced ([`FrameReach::texture_writes`]). Run on
//! the steps as the executor draws them, tie-free draws lowered to plain
//! depth tests (`plan::tie_free`), this is SCS's candidate texture once
//! every parity and clip draw that sampled it tests the depth image instead:
//! its front and exit draws become depth-only, and its clear reaches nothing.

use std::collections::BTreeMap;

use super::rect::Rect;
use super::step::{Clear, Draw, Fragment, Scissor, Step};
use super::usage::{Resource, Usage, Uses};

mod kept;
#[cfg(test)]
mod tests;

#[cfg(test)]
use kept::Kept;
pub use kept::{assume, holds, kept_after, KeptImages};

/// Pixels beyond a draw's scissor that its fragment programs may read: the tie
/// test's neighbour fetch (`shaders/tie.glsl`, one texel), which a helper
/// invocation of the pixel quad just outside the scissor also makes (one more).
pub const READ_MARGIN: u32 = 2;

/// What one image's clear must do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClearNeed {
    /// Clear this region (empty: nobody reads the value, drop the clear).
    Reach(Rect),
    /// Nothing: an earlier clear of the image to the same value, with no write
    /// since, already reaches everything read after this one.
    Held,
}

/// The frame's images: its outputs, read whole after it, and whether the
/// normal buffer goes with the colour.
#[derive(Clone, Copy, Debug)]
pub struct Images<'a> {
    pub outputs: &'a [Resource],
    pub normals: bool,
    pub size: (u32, u32),
}

/// What a frame's clears and copies reach ([`frame_reach`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FrameReach {
    /// For every image every `Clear` clears, in order ([`cleared`]).
    pub clears: Vec<ClearNeed>,
    /// For every `CopyTexture`, `CopyDepthBound` and `CopyDepthToTexture`,
    /// in order: the region
    /// to copy (empty: nobody reads the copy).
    pub copies: Vec<Rect>,
    /// For every draw that writes a depth texture ([`written_texture`]), in
    /// order: whether a later step may read what it writes (`false`: the
    /// write is dead, and the draw may leave the texture alone).
    pub texture_writes: Vec<bool>,
    /// What the outputs hold after the frame.
    pub kept: KeptImages,
}

/// A frame's outputs, read whole after it: colour, ids, the depth-stencil
/// `output_ds` and, with `normals`, the normal buffer.
pub fn outputs(output_ds: u8, normals: bool) -> Vec<Resource> {
    let mut outputs = vec![
        Resource::Color,
        Resource::Prim,
        Resource::DepthStencil(output_ds),
    ];
    outputs.extend(normals.then_some(Resource::Normal));
    outputs
}

/// Whether a clear of `r` that reaches only `rect` of a `full` image may
/// discard the image's other pixels (an `UNDEFINED` old layout in its barrier,
/// which leaves the whole image's contents undefined: lavapipe keeps them, a
/// GPU that compresses attachments may not): when it reaches the whole image,
/// or when `r` is not among the
/// frame's `outputs`. Nothing reads an image outside its clear's region before
/// it is cleared again (that is how the region is chosen), but an output keeps
/// its pixels for later frames and the read-back: a clear cut to the dirty
/// region must leave the rest as it was.
pub fn clear_discards(r: Resource, rect: Rect, full: Rect, outputs: &[Resource]) -> bool {
    rect.contains(&full) || !outputs.contains(&r)
}

/// The images `clear` clears, in recording order (`normals`: the normal buffer
/// goes with the colour).
pub fn cleared(clear: &Clear, normals: bool) -> Uses<Resource> {
    match *clear {
        Clear::DepthStencil { ds, .. } => Uses::of(&[Resource::DepthStencil(ds)]),
        Clear::Texture { tex, .. } => Uses::of(&[Resource::Texture(tex)]),
        Clear::Color => {
            let mut v = Uses::of(&[Resource::Color, Resource::Prim]);
            if normals {
                v.push(Resource::Normal);
            }
            v
        }
    }
}

/// The depth texture a draw writes and nothing else reads from its
/// program: the write [`FrameReach::texture_writes`] decides on.
pub fn written_texture(draw: &Draw) -> Option<super::step::Tex> {
    match draw.fragment {
        Fragment::WriteDepth { out } => Some(out),
        _ => None,
    }
}

/// The images `step` uses and how, the normal buffer with the colour target.
fn uses(step: &Step, normals: bool) -> Uses<(Resource, Usage)> {
    super::usage::with_normals(step.usage(), normals)
}

/// Whether a step of usages `uses` may write `r` (a target of a draw or depth
/// copy, or a copy's destination); clears are not counted.
fn writes_to(uses: &[(Resource, Usage)], r: Resource) -> bool {
    uses.iter()
        .any(|&(res, u)| res == r && u.writes() && u != Usage::Clear)
}

#[cfg(test)]
fn may_write(step: &Step, r: Resource, normals: bool) -> bool {
    writes_to(&uses(step, normals), r)
}

/// The rectangle a step works in, or `None` when it is skipped (a draw with
/// an empty scissor) or is not a draw.
fn draw_rect(step: &Step, scissor: &impl Fn(&Scissor) -> Rect) -> Option<Rect> {
    match step {
        Step::Draw(d) => Some(scissor(&d.scissor)).filter(|r| !r.is_empty()),
        _ => None,
    }
}

/// One item of a frame as the passes below read it: a step, or a point
/// where an image is read whole (a sequence frame's copy of a layer to the
/// host or its accumulate pass, between its plans).
#[derive(Clone, Copy, Debug)]
pub enum Item<'s> {
    Step(&'s Step),
    ReadWhole(Resource),
}

/// What the passes ask of each item, worked out once per frame (recording
/// a frame again costs ≤ 1 µs per draw): a draw's rectangle
/// (`None`: skipped, or not a draw) and the item's usages.
struct Info {
    rect: Option<Rect>,
    uses: Uses<(Resource, Usage)>,
}

fn infos(items: &[Item<'_>], scissor: &impl Fn(&Scissor) -> Rect, normals: bool) -> Vec<Info> {
    items
        .iter()
        .map(|it| match it {
            Item::Step(s) => Info {
                rect: draw_rect(s, scissor),
                uses: uses(s, normals),
            },
            Item::ReadWhole(_) => Info {
                rect: None,
                uses: Uses::default(),
            },
        })
        .collect()
}

/// Which clears of `items` are [`ClearNeed::Held`], per image cleared, in
/// order: a clear to the value an earlier clear left, with no write to the
/// image since (CST clears its floor texture to the same depth for every
/// product and only samples it).
fn held_clears(items: &[Item<'_>], infos: &[Info], normals: bool) -> Vec<bool> {
    let mut held: Vec<(Resource, Clear)> = Vec::new();
    let mut out = Vec::new();
    for (it, info) in items.iter().zip(infos) {
        match it {
            Item::Step(Step::Clear(c)) => {
                for r in cleared(c, normals) {
                    let h = held.contains(&(r, *c));
                    if !h {
                        held.retain(|k| k.0 != r);
                        held.push((r, *c));
                    }
                    out.push(h);
                }
            }
            Item::Step(Step::Draw(_)) if info.rect.is_none() => {}
            Item::Step(_) => held.retain(|&(r, _)| !writes_to(&info.uses, r)),
            Item::ReadWhole(_) => {}
        }
    }
    out
}

/// The union of the regions `items` may write in output `r`, and the value of
/// its last clear (`None`: not cleared): what the image holds after them, up
/// to the pixels written after that clear.
fn writes(
    items: &[Item<'_>],
    infos: &[Info],
    r: Resource,
    normals: bool,
) -> (Rect, Option<Clear>, Rect) {
    let (mut all, mut last, mut after) = (Rect::EMPTY, None, Rect::EMPTY);
    for (it, info) in items.iter().zip(infos) {
        if let Item::Step(Step::Clear(c)) = it {
            if cleared(c, normals).contains(&r) {
                last = Some(*c);
                after = Rect::EMPTY;
            }
        } else if let Some(rect) = info.rect.filter(|_| writes_to(&info.uses, r)) {
            all = all.union(&rect);
            after = after.union(&rect);
        }
    }
    (all, last, after)
}

/// The items of a frame of plain steps.
fn items<'s>(steps: &[&'s Step]) -> Vec<Item<'s>> {
    steps.iter().map(|&s| Item::Step(s)).collect()
}

/// For a frame of `steps` (loops unrolled) on `images`, whose outputs hold
/// `before` from earlier frames: the region each clear and copy must reach and
/// what the outputs hold after (module doc). `scissor` resolves a draw's
/// scissor (an empty one: the draw is skipped); outputs are only ever drawn
/// into and cleared, never copied into.
#[cfg(test)]
pub fn frame_reach(
    steps: &[&Step],
    scissor: impl Fn(&Scissor) -> Rect,
    images: Images<'_>,
    before: &KeptImages,
) -> FrameReach {
    let items = items(steps);
    let infos = infos(&items, &scissor, images.normals);
    reach_of_items(&items, &infos, images, before)
}

/// [`frame_reach`] for a recording kept for replays, from outputs that hold
/// `now`: also what it assumes they hold before it ([`assume`]), for which
/// the regions are made, so that it also holds after its own frame.
pub fn recording_reach(
    steps: &[&Step],
    scissor: impl Fn(&Scissor) -> Rect,
    images: Images<'_>,
    now: &KeptImages,
) -> (FrameReach, KeptImages) {
    let items = items(steps);
    let infos = infos(&items, &scissor, images.normals);
    let r = reach_of_items(&items, &infos, images, now);
    let assumed = assume(now, &r.kept);
    match assumed == *now {
        true => (r, assumed),
        false => (reach_of_items(&items, &infos, images, &assumed), assumed),
    }
}

/// [`frame_reach`] of a sequence frame's `items` (several plans' steps, with
/// the images read whole between them), from outputs whose contents are
/// unknown: a copy one plan makes reaches what the later plans read of it.
pub fn sequence_reach(
    items: &[Item<'_>],
    scissor: impl Fn(&Scissor) -> Rect,
    images: Images<'_>,
) -> FrameReach {
    let infos = infos(items, &scissor, images.normals);
    reach_of_items(items, &infos, images, &KeptImages::new())
}

fn reach_of_items(
    items: &[Item<'_>],
    infos: &[Info],
    images: Images<'_>,
    before: &KeptImages,
) -> FrameReach {
    let (w, h) = images.size;
    let full = Rect::full(w, h);
    let normals = images.normals;
    let mut live: BTreeMap<Resource, Rect> = BTreeMap::new();
    for &r in images.outputs {
        let (all, last, _) = writes(items, infos, r, normals);
        // Every clear of the image must be to the value it keeps for its
        // pixels outside the dirty region to hold that value already.
        let one_value = items.iter().all(|it| match it {
            Item::Step(Step::Clear(c)) => !cleared(c, normals).contains(&r) || Some(*c) == last,
            _ => true,
        });
        let end = match (before.get(&r), last) {
            (Some(k), Some(v)) if k.value == v && one_value => k.dirty.union(&all),
            _ => full,
        };
        live.insert(r, end);
    }
    let mut held = held_clears(items, infos, normals);
    let mut clears = Vec::with_capacity(held.len());
    let (mut copies, mut texture_writes) = (Vec::new(), Vec::new());
    let take = |live: &mut BTreeMap<Resource, Rect>, r| live.remove(&r).unwrap_or(Rect::EMPTY);
    for (it, info) in items.iter().zip(infos).rev() {
        let s = match it {
            Item::Step(s) => s,
            Item::ReadWhole(r) => {
                live.insert(*r, full);
                continue;
            }
        };
        match s {
            Step::Clear(c) => {
                for r in cleared(c, normals).iter().rev() {
                    let h = held.pop().expect("a held flag per cleared image");
                    clears.push(match h {
                        // The earlier clear reaches what is read after this one.
                        true => ClearNeed::Held,
                        false => ClearNeed::Reach(take(&mut live, *r)),
                    });
                }
            }
            Step::CopyTexture { src, dst } if src != dst => {
                let region = take(&mut live, Resource::Texture(*dst));
                let src = live.entry(Resource::Texture(*src)).or_insert(Rect::EMPTY);
                *src = src.union(&region);
                copies.push(region);
            }
            Step::CopyTexture { .. } => copies.push(Rect::EMPTY),
            Step::CopyDepthBound { src, dst } if src != dst => {
                let region = take(&mut live, Resource::DepthStencil(*dst));
                let src = live
                    .entry(Resource::DepthStencil(*src))
                    .or_insert(Rect::EMPTY);
                *src = src.union(&region);
                copies.push(region);
            }
            Step::CopyDepthBound { .. } => copies.push(Rect::EMPTY),
            // A full-screen draw reading the depth at the pixel it writes.
            Step::CopyDepthToTexture { ds, dst } => {
                let region = take(&mut live, Resource::Texture(*dst));
                let ds = live
                    .entry(Resource::DepthStencil(*ds))
                    .or_insert(Rect::EMPTY);
                *ds = ds.union(&region);
                copies.push(region);
            }
            _ => {
                // A texture write no later step reads within the draw's
                // rectangle: dead, and the draw needs none of its pixels.
                let written = match s {
                    Step::Draw(d) => written_texture(d).map(Resource::Texture),
                    _ => None,
                };
                let dead = match (written, info.rect) {
                    (Some(t), Some(rect)) => {
                        let read = live.get(&t).map_or(Rect::EMPTY, |l| l.intersect(&rect));
                        read.is_empty()
                    }
                    _ => false,
                };
                if written.is_some() {
                    texture_writes.push(!dead);
                }
                if let Some(rect) = info.rect {
                    let read = rect.grown(READ_MARGIN, READ_MARGIN, w, h);
                    for &(r, _) in info.uses.iter() {
                        if dead && Some(r) == written {
                            continue;
                        }
                        let l = live.entry(r).or_insert(Rect::EMPTY);
                        *l = l.union(&read);
                    }
                }
            }
        }
    }
    clears.reverse();
    copies.reverse();
    texture_writes.reverse();
    FrameReach {
        clears,
        copies,
        texture_writes,
        kept: kept::kept_after_items(items, infos, images, before),
    }
}
