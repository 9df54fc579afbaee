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
/// a frame again costs ≤ 1 µs per draw, issue 9 §3): a draw's rectangle
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
        kept: kept_after_items(items, infos, images, before),
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
    let items = items(steps);
    let infos = infos(&items, &scissor, images.normals);
    kept_after_items(&items, &infos, images, before)
}

fn kept_after_items(
    items: &[Item<'_>],
    infos: &[Info],
    images: Images<'_>,
    before: &KeptImages,
) -> KeptImages {
    let normals = images.normals;
    let mut kept = before.clone();
    for info in infos {
        for &(r, _) in info.uses.iter() {
            if !images.outputs.contains(&r) {
                kept.remove(&r);
            }
        }
    }
    for &r in images.outputs {
        match writes(items, infos, r, normals) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{Cull, Draw, Fragment, Geometry};

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

    fn off_screen(fragment: Fragment, ds: u8) -> Step {
        let Step::Draw(mut d) = draw(fragment, ds, 1) else {
            unreachable!()
        };
        d.scissor = Scissor::BoundsOf(vec![]);
        Step::Draw(d)
    }

    fn square(m: u32) -> Rect {
        scissor(&Scissor::BoundsOf(vec![m])).grown(READ_MARGIN, READ_MARGIN, W, H)
    }

    fn reach_of(steps: &[Step], outputs: &[Resource], before: &KeptImages) -> FrameReach {
        let refs: Vec<&Step> = steps.iter().collect();
        let images = Images {
            outputs,
            normals: false,
            size: (W, H),
        };
        frame_reach(&refs, scissor, images, before)
    }

    fn needs(steps: &[Step], outputs: &[Resource]) -> Vec<ClearNeed> {
        reach_of(steps, outputs, &KeptImages::new()).clears
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

    fn clear_ds(ds: u8) -> Step {
        Step::Clear(Clear::DepthStencil {
            ds,
            depth: 1.0,
            stencil: 0,
        })
    }

    fn clear_tex(tex: u8) -> Step {
        Step::Clear(Clear::Texture { tex, depth: 0.0 })
    }

    fn peel(prev: u8, out: u8, mesh: u32) -> Step {
        let f = Fragment::Peel {
            prev,
            out,
            shade: false,
        };
        draw(f, 0, mesh)
    }

    #[test]
    fn a_clear_reaches_the_scissors_of_the_draws_until_the_next_clear() {
        let steps = vec![
            clear_ds(1),
            draw(Fragment::None, 1, 1),
            draw(Fragment::None, 1, 3),
            // Another image: not a use of ds 1.
            draw(Fragment::None, 0, 6),
            clear_ds(1),
            draw(Fragment::None, 1, 2),
        ];
        let r = regions(&steps, &[]);
        assert_eq!(r, vec![square(1).union(&square(3)), square(2)]);
        let expected = Rect {
            x0: 8,
            y0: 8,
            x1: 42,
            y1: 42,
        };
        assert_eq!(r[0], expected);
    }

    #[test]
    fn sampled_textures_copies_and_outputs_need_what_they_read() {
        let steps = vec![
            clear_tex(0),
            clear_tex(1),
            Step::Clear(Clear::Color),
            peel(0, 1, 4),
            // The copy replaces 2 where it is read (nowhere) and reads 1 there.
            clear_tex(2),
            Step::CopyTexture { src: 1, dst: 2 },
            // Read by nobody.
            clear_tex(3),
        ];
        let r = regions(&steps, &[Resource::Color, Resource::Prim]);
        let full = Rect::full(W, H);
        // tex 0 sampled by the peel, tex 1 written there, colour and ids read
        // back whole (nothing known of them before), tex 2 replaced by the
        // copy, tex 3 unread.
        assert_eq!(
            r,
            vec![square(4), square(4), full, full, Rect::EMPTY, Rect::EMPTY]
        );
        assert_eq!(
            reach_of(&steps, &[], &KeptImages::new()).copies,
            vec![Rect::EMPTY]
        );
    }

    /// Goldfeather's layer loop: the layer `CUR` is copied to `PREV`, which the
    /// next peel samples, and to `SURF`, which the merge samples.
    #[test]
    fn a_copy_reaches_what_its_destination_is_read_at_and_reads_its_source_there() {
        let steps = vec![
            clear_tex(0),
            clear_tex(1),
            peel(0, 1, 2),
            Step::CopyTexture { src: 1, dst: 2 },
            draw(Fragment::DepthFromTexture { src: 2 }, 0, 5),
            Step::CopyTexture { src: 1, dst: 0 },
            peel(0, 1, 3),
        ];
        let r = reach_of(&steps, &[], &KeptImages::new());
        assert_eq!(r.copies, vec![square(5), square(3)]);
        // Texture 1 is read by both copies and written by both peels.
        let tex1 = square(2).union(&square(3)).union(&square(5));
        assert_eq!(
            r.clears,
            vec![ClearNeed::Reach(square(2)), ClearNeed::Reach(tex1)]
        );
    }

    #[test]
    fn a_depth_copy_reads_the_depth_where_its_texture_is_read_and_skipped_draws_read_nothing() {
        let steps = vec![
            clear_ds(0),
            clear_tex(5),
            Step::CopyDepthToTexture { ds: 0, dst: 5 },
            draw(
                Fragment::ShadeNearDepth {
                    tex: 5,
                    eps: 0.0,
                    equal_cull: Cull::None,
                },
                1,
                3,
            ),
            clear_tex(6),
            // Off screen (empty scissor): skipped by the recorder.
            off_screen(Fragment::WriteDepth { out: 6 }, 0),
        ];
        let r = reach_of(&steps, &[], &KeptImages::new());
        assert_eq!(r.copies, vec![square(3)]);
        assert_eq!(
            r.clears,
            vec![
                ClearNeed::Reach(square(3)),
                ClearNeed::Reach(Rect::EMPTY),
                ClearNeed::Reach(Rect::EMPTY)
            ]
        );
    }

    #[test]
    fn the_normal_buffer_goes_with_the_colour() {
        let steps = [Step::Clear(Clear::Color), draw(Fragment::Shade, 0, 2)];
        let refs: Vec<&Step> = steps.iter().collect();
        let images = Images {
            outputs: &[],
            normals: true,
            size: (W, H),
        };
        let r = frame_reach(&refs, scissor, images, &KeptImages::new());
        assert_eq!(r.clears, vec![ClearNeed::Reach(square(2)); 3]);
    }

    /// CST's floor: cleared to one value per product, only ever sampled. The
    /// first clear reaches every product's reads; the others need nothing.
    #[test]
    fn a_clear_to_the_value_the_image_holds_is_held() {
        let floor = clear_tex(0);
        let steps = vec![floor.clone(), peel(0, 1, 1), floor.clone(), peel(0, 1, 3)];
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
        let steps = vec![floor.clone(), peel(0, 1, 1), other, peel(0, 1, 3)];
        assert_eq!(regions(&steps, &[]), vec![square(1), square(3)]);
        let write = draw(Fragment::WriteDepth { out: 0 }, 0, 2);
        let steps = vec![
            floor.clone(),
            peel(0, 1, 1),
            write,
            floor.clone(),
            peel(0, 1, 3),
        ];
        // (The write itself is dead, nobody reading it before the second
        // clear: the first clear reaches only what peel 1 reads.)
        assert_eq!(regions(&steps, &[]), vec![square(1), square(3)]);
        assert_eq!(
            reach_of(&steps, &[], &KeptImages::new()).texture_writes,
            vec![false]
        );
        // A write that is skipped (empty scissor) writes nothing.
        let skipped = off_screen(Fragment::WriteDepth { out: 0 }, 0);
        let steps = vec![floor.clone(), skipped, floor, peel(0, 1, 3)];
        assert_eq!(
            needs(&steps, &[]),
            vec![ClearNeed::Reach(square(3)), ClearNeed::Held]
        );
    }

    /// The outputs of a frame that starts from what the last one left: their
    /// clears reach the pixels dirtied then and now, not the whole image.
    #[test]
    fn outputs_are_cleared_where_earlier_frames_and_this_one_draw() {
        let outputs = [Resource::Color, Resource::Prim, Resource::DepthStencil(0)];
        let steps = vec![
            clear_ds(0),
            Step::Clear(Clear::Color),
            draw(Fragment::Shade, 0, 2),
            draw(Fragment::Shade, 0, 3),
        ];
        let full = Rect::full(W, H);
        let first = reach_of(&steps, &outputs, &KeptImages::new());
        assert_eq!(first.clears, vec![ClearNeed::Reach(full); 3]);
        let written = scissor(&Scissor::BoundsOf(vec![2, 3]));
        let colour = Kept {
            value: Clear::Color,
            dirty: written,
        };
        assert_eq!(first.kept[&Resource::Color], colour);
        assert_eq!(first.kept[&Resource::DepthStencil(0)].dirty, written);
        // The next frame: only what it reads and what the last one dirtied.
        let next = reach_of(&steps, &outputs, &first.kept);
        let reads = square(2).union(&square(3));
        assert_eq!(next.clears, vec![ClearNeed::Reach(reads); 3]);
        assert_eq!(next.kept, first.kept);
        // Earlier frames dirtied a corner: it is cleared too.
        let mut corner = first.kept.clone();
        let c = Rect {
            x0: 90,
            y0: 70,
            x1: 100,
            y1: 80,
        };
        corner.get_mut(&Resource::Color).unwrap().dirty = c;
        let r = reach_of(&steps, &outputs, &corner);
        assert_eq!(r.clears[1], ClearNeed::Reach(reads.union(&c)));
        // Another value than the image holds: the whole image.
        let mut other = first.kept.clone();
        other.get_mut(&Resource::DepthStencil(0)).unwrap().value = Clear::DepthStencil {
            ds: 0,
            depth: 0.0,
            stencil: 0,
        };
        assert_eq!(
            reach_of(&steps, &outputs, &other).clears[0],
            ClearNeed::Reach(full)
        );
        // A frame that uses an output as a work image leaves it unknown.
        let work = [clear_ds(1), draw(Fragment::None, 1, 2)];
        let r = reach_of(&work, &outputs, &first.kept);
        assert!(r.kept.contains_key(&Resource::Color));
        let other_outputs = [Resource::Color, Resource::Prim, Resource::DepthStencil(1)];
        let steps = [clear_ds(0), draw(Fragment::None, 0, 1)];
        let r = reach_of(&steps, &other_outputs, &first.kept);
        assert!(!r.kept.contains_key(&Resource::DepthStencil(0)));
    }

    #[test]
    fn a_recording_assumes_what_it_leaves_and_holds_checks_it() {
        let a = Rect {
            x0: 0,
            y0: 0,
            x1: 5,
            y1: 5,
        };
        let b = Rect {
            x0: 10,
            y0: 10,
            x1: 20,
            y1: 20,
        };
        let k = |dirty| {
            KeptImages::from([(
                Resource::Color,
                Kept {
                    value: Clear::Color,
                    dirty,
                },
            )])
        };
        let assumed = assume(&k(a), &k(b));
        assert_eq!(assumed, k(a.union(&b)));
        assert!(holds(&k(a), &assumed) && holds(&k(b), &assumed));
        assert!(holds(&k(Rect::EMPTY), &assumed));
        assert!(!holds(&k(Rect::full(W, H)), &assumed));
        assert!(!holds(&KeptImages::new(), &assumed));
        assert!(holds(&KeptImages::new(), &KeptImages::new()));
        // Nothing known now: nothing assumed.
        assert_eq!(assume(&KeptImages::new(), &k(b)), KeptImages::new());
    }

    #[test]
    fn a_sequence_copy_reaches_what_later_plans_read_and_read_points_read_whole() {
        // One plan copies its depth; the next reads the copy. Between them the
        // colour is read whole (a keep).
        let (first, second) = (
            vec![
                clear_tex(1),
                Step::CopyDepthToTexture { ds: 0, dst: 1 },
                Step::Clear(Clear::Color),
            ],
            vec![draw(Fragment::DepthFromTexture { src: 1 }, 0, 3)],
        );
        let mut items: Vec<Item<'_>> = first.iter().map(Item::Step).collect();
        items.push(Item::ReadWhole(Resource::Color));
        items.extend(second.iter().map(Item::Step));
        let images = Images {
            outputs: &[],
            normals: false,
            size: (W, H),
        };
        let r = sequence_reach(&items, scissor, images);
        let full = Rect::full(W, H);
        // The copy replaces texture 1 where the second plan reads it; the
        // colour is read whole, the ids by nobody.
        assert_eq!(r.copies, vec![square(3)]);
        let reach = |r| ClearNeed::Reach(r);
        assert_eq!(
            r.clears,
            vec![reach(Rect::EMPTY), reach(full), reach(Rect::EMPTY)]
        );
        // The first plan alone: nobody reads its copy or its colour.
        let alone = reach_of(&first, &[], &KeptImages::new());
        assert_eq!(alone.copies, vec![Rect::EMPTY]);
    }

    /// SCS's candidate texture: written by the front and exit draws, read by
    /// the parity and clip draws. Once those test the depth image instead
    /// (`plan::tie_free`, [`Fragment::None`]), nobody reads it before the
    /// shade's depth copy replaces it: its writes are dead and its clear
    /// reaches nothing; one draw still sampling it keeps every write before it.
    #[test]
    fn a_texture_only_tie_free_draws_read_is_written_for_nobody() {
        let front = draw(Fragment::WriteDepth { out: 0 }, 0, 1);
        let exit = draw(Fragment::WriteDepth { out: 0 }, 0, 2);
        let lowered = draw(Fragment::None, 0, 2);
        let shade = [
            Step::CopyDepthToTexture { ds: 0, dst: 0 },
            draw(Fragment::DepthFromTexture { src: 0 }, 1, 1),
        ];
        let mut steps = vec![clear_tex(0), front.clone(), lowered.clone(), exit.clone()];
        steps.push(lowered.clone());
        steps.extend(shade.clone());
        let r = reach_of(&steps, &[], &KeptImages::new());
        assert_eq!(r.texture_writes, vec![false, false]);
        assert_eq!(r.clears, vec![ClearNeed::Reach(Rect::EMPTY)]);
        assert_eq!(r.copies, vec![square(1)]);
        // A parity draw that keeps its shader samples the texture after the
        // front draw: the front write is read, the exit's is not.
        let parity = draw(Fragment::NearerThan { tex: 0, eps: 1e-6 }, 0, 1);
        let mut steps = vec![clear_tex(0), front, parity, exit, lowered];
        steps.extend(shade);
        let r = reach_of(&steps, &[], &KeptImages::new());
        assert_eq!(r.texture_writes, vec![true, false]);
        assert_eq!(r.clears, vec![ClearNeed::Reach(square(1))]);
    }

    /// Pixel images of a simulated frame: a value per pixel and image.
    type Pixels = BTreeMap<Resource, Vec<u64>>;

    fn value_of(c: &Clear) -> u64 {
        match *c {
            Clear::DepthStencil { ds, depth, stencil } => {
                1 << 40 | (ds as u64) << 32 | (depth.to_bits() as u64) ^ stencil as u64
            }
            Clear::Texture { tex, depth } => 2 << 40 | (tex as u64) << 32 | depth.to_bits() as u64,
            Clear::Color => 3 << 40,
        }
    }

    fn each(rect: Rect, mut f: impl FnMut(usize)) {
        for y in rect.y0..rect.y1 {
            for x in rect.x0..rect.x1 {
                f((y * W + x) as usize);
            }
        }
    }

    /// Runs `steps` on `px` with the clears and copies reaching `reach` (or
    /// whole images): every value a draw reads (its images within its grown
    /// scissor) goes to `reads`; a draw writes a value of its own (`tag`,
    /// step) to the images it may write within its scissor.
    fn simulate(
        steps: &[Step],
        reach: Option<&FrameReach>,
        px: &mut Pixels,
        tag: u64,
        reads: &mut Vec<u64>,
    ) {
        let full = Rect::full(W, H);
        let mut clears = reach.map(|r| r.clears.iter());
        let mut copies = reach.map(|r| r.copies.iter());
        let mut texture_writes = reach.map(|r| r.texture_writes.iter());
        let get = |px: &mut Pixels, r| {
            px.entry(r)
                .or_insert(vec![u64::MAX; (W * H) as usize])
                .clone()
        };
        for (i, s) in steps.iter().enumerate() {
            match s {
                Step::Clear(c) => {
                    for r in cleared(c, false) {
                        let need = clears.as_mut().map_or(ClearNeed::Reach(full), |n| {
                            *n.next().expect("a need per cleared image")
                        });
                        let mut img = get(px, r);
                        if let ClearNeed::Reach(rect) = need {
                            each(rect, |p| img[p] = value_of(c));
                        }
                        px.insert(r, img);
                    }
                }
                Step::CopyTexture { src, dst } | Step::CopyDepthToTexture { ds: src, dst } => {
                    let rect = copies
                        .as_mut()
                        .map_or(full, |c| *c.next().expect("a region per copy"));
                    let src = match s {
                        Step::CopyTexture { .. } => Resource::Texture(*src),
                        _ => Resource::DepthStencil(*src),
                    };
                    let from = get(px, src);
                    let mut to = get(px, Resource::Texture(*dst));
                    each(rect, |p| to[p] = from[p]);
                    px.insert(Resource::Texture(*dst), to);
                }
                Step::Draw(d) => {
                    // The texture a draw only writes: not read by it, and
                    // left alone where nobody reads it after (`dead`).
                    let written = written_texture(d).map(Resource::Texture);
                    let dead = written.is_some()
                        && texture_writes
                            .as_mut()
                            .is_some_and(|w| !*w.next().expect("a flag per texture write"));
                    let Some(rect) = draw_rect(s, &scissor) else {
                        continue;
                    };
                    for (r, _) in uses(s, false) {
                        if Some(r) == written {
                            continue;
                        }
                        let img = get(px, r);
                        each(rect.grown(READ_MARGIN, READ_MARGIN, W, H), |p| {
                            reads.push(img[p])
                        });
                    }
                    for (r, _) in uses(s, false) {
                        if dead && Some(r) == written {
                            continue;
                        }
                        if may_write(s, r, false) {
                            let mut img = get(px, r);
                            each(rect, |p| img[p] = tag << 20 | i as u64);
                            px.insert(r, img);
                        }
                    }
                }
                Step::Pass(_) | Step::Loop(_) => {}
            }
        }
    }

    /// A random frame from a small vocabulary of steps on 2 depth-stencils
    /// and 3 textures, every image cleared at its start as plans do (a plan
    /// reads no image it has not cleared or written).
    fn random_frame(seed: u64) -> Vec<Step> {
        let mut x = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let mut next = |n: u64| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 33) % n
        };
        let mut steps = vec![clear_ds(0), Step::Clear(Clear::Color), clear_ds(1)];
        steps.extend((0..3).map(clear_tex));
        for _ in 0..12 {
            let (t, u, m) = (next(3) as u8, next(3) as u8, next(7) as u32);
            let ds = next(2) as u8;
            steps.push(match next(9) {
                0 => clear_ds(ds),
                1 => Step::Clear(Clear::Texture {
                    tex: t,
                    depth: next(2) as f32,
                }),
                2 => Step::CopyTexture { src: t, dst: u },
                3 => Step::CopyDepthToTexture { ds, dst: t },
                4 => draw(Fragment::Shade, ds, m),
                5 => draw(
                    Fragment::Peel {
                        prev: t,
                        out: u,
                        shade: next(2) == 0,
                    },
                    ds,
                    m,
                ),
                6 => draw(Fragment::DepthFromTexture { src: t }, ds, m),
                7 => draw(Fragment::WriteDepth { out: t }, ds, m),
                _ => draw(Fragment::None, ds, m),
            });
        }
        steps
    }

    /// Random frames, run several times in a row as the executor runs them:
    /// with clears and copies cut to `frame_reach` (outputs carried over from
    /// frame to frame) every draw reads the values it reads with whole clears
    /// and copies, and the outputs end the same, pixel for pixel.
    #[test]
    fn cut_clears_and_copies_read_and_leave_what_whole_ones_do() {
        let outputs = [Resource::Color, Resource::Prim, Resource::DepthStencil(0)];
        let mut writes = [0; 2];
        for seed in 0..300 {
            let steps = random_frame(seed);
            let (mut whole, mut cut) = (Pixels::new(), Pixels::new());
            let mut kept = KeptImages::new();
            for frame in 0..3 {
                let r = reach_of(&steps, &outputs, &kept);
                for &w in &r.texture_writes {
                    writes[w as usize] += 1;
                }
                let (mut a, mut b) = (Vec::new(), Vec::new());
                simulate(&steps, None, &mut whole, frame, &mut a);
                simulate(&steps, Some(&r), &mut cut, frame, &mut b);
                assert!(
                    a == b,
                    "seed {seed} frame {frame}: a draw read another value\n{steps:#?}"
                );
                for o in &outputs {
                    assert!(
                        whole[o] == cut[o],
                        "seed {seed} frame {frame}: output {o:?} differs"
                    );
                }
                kept = r.kept;
            }
            // From the second frame on, the outputs' clears are cut.
            assert!(kept.contains_key(&Resource::Color), "seed {seed}");
        }
        // Both dead and read texture writes were exercised.
        assert!(writes[0] > 0 && writes[1] > 0, "{writes:?}");
    }
}
