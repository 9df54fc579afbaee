//! What part of each image a frame's clears and copies must reach (issue 9 §4:
//! "clears go through load ops, or are scissored to what will be read"). Pure:
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

use std::collections::BTreeMap;

use super::rect::Rect;
use super::step::{Clear, Scissor, Step};
use super::usage::{Resource, Usage};

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

/// An output image's contents between frames: `value` (a clear) everywhere
/// outside `dirty`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kept {
    pub value: Clear,
    pub dirty: Rect,
}

/// What the outputs hold between frames, by image (an image not listed: unknown).
pub type KeptImages = BTreeMap<Resource, Kept>;

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
    /// For every `CopyTexture` and `CopyDepthToTexture`, in order: the region
    /// to copy (empty: nobody reads the copy).
    pub copies: Vec<Rect>,
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

/// The images `step` uses and how, the normal buffer with the colour target.
fn uses(step: &Step, normals: bool) -> Vec<(Resource, Usage)> {
    let mut u = step.usage();
    if normals && u.contains(&(Resource::Color, Usage::ColorTarget)) {
        u.push((Resource::Normal, Usage::ColorTarget));
    }
    u
}

/// Whether `step` may write `r` (a target of a draw or depth copy, or a copy's
/// destination); clears are not counted.
fn may_write(step: &Step, r: Resource, normals: bool) -> bool {
    uses(step, normals)
        .iter()
        .any(|&(res, u)| res == r && u.writes() && u != Usage::Clear)
}

/// The rectangle a step works in, or `None` when it is skipped (a draw with
/// an empty scissor) or is not a draw.
fn draw_rect(step: &Step, scissor: &impl Fn(&Scissor) -> Rect) -> Option<Rect> {
    match step {
        Step::Draw(d) => Some(scissor(&d.scissor)).filter(|r| !r.is_empty()),
        _ => None,
    }
}

/// Which clears of `steps` are [`ClearNeed::Held`], per image cleared: a clear
/// to the value an earlier clear left, with no write to the image since (CST
/// clears its floor texture to the same depth for every product and only
/// samples it).
fn held_clears(
    steps: &[&Step],
    scissor: &impl Fn(&Scissor) -> Rect,
    normals: bool,
) -> Vec<Vec<bool>> {
    let mut held: Vec<(Resource, Clear)> = Vec::new();
    let mut out = Vec::new();
    for s in steps {
        match s {
            Step::Clear(c) => out.push(
                cleared(c, normals)
                    .into_iter()
                    .map(|r| {
                        let h = held.contains(&(r, *c));
                        if !h {
                            held.retain(|k| k.0 != r);
                            held.push((r, *c));
                        }
                        h
                    })
                    .collect(),
            ),
            Step::Draw(_) if draw_rect(s, scissor).is_none() => {}
            _ => held.retain(|&(r, _)| !may_write(s, r, normals)),
        }
    }
    out
}

/// The union of the regions `steps` may write in output `r`, and the value of
/// its last clear (`None`: not cleared): what the image holds after them, up
/// to the pixels written after that clear.
fn writes(
    steps: &[&Step],
    scissor: &impl Fn(&Scissor) -> Rect,
    r: Resource,
    normals: bool,
) -> (Rect, Option<Clear>, Rect) {
    let (mut all, mut last, mut after) = (Rect::EMPTY, None, Rect::EMPTY);
    for s in steps {
        if let Step::Clear(c) = s {
            if cleared(c, normals).contains(&r) {
                last = Some(*c);
                after = Rect::EMPTY;
            }
        } else if let Some(rect) = draw_rect(s, scissor).filter(|_| may_write(s, r, normals)) {
            all = all.union(&rect);
            after = after.union(&rect);
        }
    }
    (all, last, after)
}

/// For a frame of `steps` (loops unrolled) on `images`, whose outputs hold
/// `before` from earlier frames: the region each clear and copy must reach and
/// what the outputs hold after (module doc). `scissor` resolves a draw's
/// scissor (an empty one: the draw is skipped); outputs are only ever drawn
/// into and cleared, never copied into.
pub fn frame_reach(
    steps: &[&Step],
    scissor: impl Fn(&Scissor) -> Rect,
    images: Images<'_>,
    before: &KeptImages,
) -> FrameReach {
    let (w, h) = images.size;
    let full = Rect::full(w, h);
    let normals = images.normals;
    let mut live: BTreeMap<Resource, Rect> = BTreeMap::new();
    for &r in images.outputs {
        let (all, last, _) = writes(steps, &scissor, r, normals);
        // Every clear of the image must be to the value it keeps for its
        // pixels outside the dirty region to hold that value already.
        let one_value = steps.iter().all(|s| match s {
            Step::Clear(c) => !cleared(c, normals).contains(&r) || Some(*c) == last,
            _ => true,
        });
        let end = match (before.get(&r), last) {
            (Some(k), Some(v)) if k.value == v && one_value => k.dirty.union(&all),
            _ => full,
        };
        live.insert(r, end);
    }
    let held = held_clears(steps, &scissor, normals);
    let mut clears = Vec::new();
    let mut copies = Vec::new();
    let take = |live: &mut BTreeMap<Resource, Rect>, r| live.remove(&r).unwrap_or(Rect::EMPTY);
    let mut n_clear = held.len();
    for s in steps.iter().rev() {
        match s {
            Step::Clear(c) => {
                n_clear -= 1;
                let rs = cleared(c, normals);
                for (r, h) in rs.into_iter().zip(&held[n_clear]).rev() {
                    clears.push(match h {
                        // The earlier clear reaches what is read after this one.
                        true => ClearNeed::Held,
                        false => ClearNeed::Reach(take(&mut live, r)),
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
                if let Some(rect) = draw_rect(s, &scissor) {
                    let read = rect.grown(READ_MARGIN, READ_MARGIN, w, h);
                    for (r, _) in uses(s, normals) {
                        let l = live.entry(r).or_insert(Rect::EMPTY);
                        *l = l.union(&read);
                    }
                }
            }
        }
    }
    clears.reverse();
    copies.reverse();
    FrameReach {
        clears,
        copies,
        kept: kept_after(steps, &scissor, images, before),
    }
}

/// What the outputs hold after `steps` run from `before`, whether their clears
/// reach what [`frame_reach`] says or whole images: an output cleared in the
/// frame holds its last clear's value outside what is written after it (that
/// clear reaches every pixel earlier frames and this one dirtied); one not
/// cleared gains the frame's writes. Images the frame uses other than as
/// outputs hold nothing known. A frame run loop by loop is described by its
/// loops' head, tail and head again (every write that can follow a clear in
/// the loop follows it there).
pub fn kept_after(
    steps: &[&Step],
    scissor: impl Fn(&Scissor) -> Rect,
    images: Images<'_>,
    before: &KeptImages,
) -> KeptImages {
    let normals = images.normals;
    let mut kept = before.clone();
    for s in steps {
        for (r, _) in uses(s, normals) {
            if !images.outputs.contains(&r) {
                kept.remove(&r);
            }
        }
    }
    for &r in images.outputs {
        match writes(steps, &scissor, r, normals) {
            (_, Some(value), after) => {
                kept.insert(
                    r,
                    Kept {
                        value,
                        dirty: after,
                    },
                );
            }
            (all, None, _) => {
                if let Some(k) = kept.get_mut(&r) {
                    k.dirty = k.dirty.union(&all);
                }
            }
        }
    }
    kept
}

/// The outputs' state a recording made for a frame that starts from `now`
/// should assume so that its replays stay valid: `now` widened by the dirty
/// regions the frame itself leaves (`after`), where the values agree. A frame
/// recorded for the result is correct from `now` and from what it leaves.
pub fn assume(now: &KeptImages, after: &KeptImages) -> KeptImages {
    now.iter()
        .filter_map(|(r, k)| {
            let a = after.get(r)?;
            (a.value == k.value).then_some((
                *r,
                Kept {
                    value: k.value,
                    dirty: k.dirty.union(&a.dirty),
                },
            ))
        })
        .collect()
}

/// Whether images holding `now` satisfy what a recording assumed (`assumed`):
/// every output it counts on holds the same value outside a region inside the
/// one assumed.
pub fn holds(now: &KeptImages, assumed: &KeptImages) -> bool {
    assumed.iter().all(|(r, a)| {
        now.get(r).is_some_and(|k| {
            k.value == a.value && (k.dirty.is_empty() || a.dirty.contains(&k.dirty))
        })
    })
}
