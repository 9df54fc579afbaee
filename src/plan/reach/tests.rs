//! Unit tests of the reach pass: one behaviour per test, on small frames.

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
        Scissor::Within { .. }
        | Scissor::Overlap { .. }
        | Scissor::Run { .. }
        | Scissor::Openings { .. } => {
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

mod simulated;

#[test]
fn only_a_clear_that_keeps_nothing_outside_its_region_discards_the_image() {
    let full = Rect::full(W, H);
    let outs = outputs(0, false);
    // A scratch image: nothing outside the region is read before its next
    // clear, so its barrier may start from `UNDEFINED`.
    assert!(clear_discards(
        Resource::DepthStencil(1),
        square(2),
        full,
        &outs
    ));
    assert!(clear_discards(Resource::Texture(0), square(2), full, &outs));
    // An output cut to its dirty region keeps its other pixels for later
    // frames and the read-back.
    for r in [Resource::Color, Resource::Prim, Resource::DepthStencil(0)] {
        assert!(!clear_discards(r, square(2), full, &outs), "{r:?}");
        // Cleared whole, it keeps nothing.
        assert!(clear_discards(r, full, full, &outs), "{r:?}");
    }
    // Which depth-stencil image is the output follows the plan.
    assert!(!clear_discards(
        Resource::DepthStencil(1),
        square(2),
        full,
        &outputs(1, false)
    ));
    assert!(!clear_discards(
        Resource::Normal,
        square(2),
        full,
        &outputs(0, true)
    ));
}
