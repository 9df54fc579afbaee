//! Blocks joined by the recorder's look-ahead (`vk::exec::record::ahead`): a
//! block of depth-only draws opens with the colour attachments of the shade
//! after it, their writes masked. A joined block must lose no write: the shade
//! still writes colour, ids and normals there, and the depth-only draws in it
//! (SCS's clip sweep over the whole screen, a direct product's depth) leave
//! colour, ids and normals untouched. Each frame (`BlockJoin::Masked`, the
//! default) is checked against the reference and, pixel for pixel, against
//! the same frame with depth-only draws in blocks of their own
//! (`BlockJoin::DepthOnly`) and cut into a block per pass (a timestamp at
//! every pass ends the look-ahead).

use peeltrim::plan::{build, Algo, Prepared};
use peeltrim::scene::Scene;
use peeltrim::vk::{BlockJoin, ClearMode, Executor};

use crate::algorithms::{assert_within_cst_bars, load, load_text};
use crate::{assert_clean, context};

/// One box seen whole (a single direct product: its depth-only draw, then the
/// depth-equal shade).
fn one_box() -> Scene {
    load_text(
        "[camera]\neye = [3.0, 2.5, 4.0]\ntarget = [0.0, 0.0, 0.0]\nfit = true\n\
         [[primitive]]\nname = \"Block\"\nshape = \"box\"\nsize = [2.0, 1.5, 1.0]\n\
         [[solid]]\nname = \"b\"\nexpr = \"Block\"\n",
        "one_box.toml",
    )
}

/// Frames of `algo` on `sc` with blocks joined, with depth-only blocks and
/// with a block per pass, in both clear modes, with and without normals,
/// three times each (loop by loop, recorded, replayed): the images (and
/// normals) agree, match the reference, and the joined frame has at most as
/// many blocks as the others. `direct`: one-primitive products shaded in
/// their direct draw (`Executor::set_direct_shade`, the default; the first,
/// loop-by-loop frame keeps the depth draw and the shade). Returns the render
/// passes of the last frames.
fn joined_frames_agree(name: &str, sc: &Scene, algo: Algo, direct: bool) -> [u64; 3] {
    let (w, h) = (sc.render.width, sc.render.height);
    let reference = peeltrim_reference::render(sc, w, h);
    let prep = Prepared::new(sc).expect("a solid");
    let plan = build(algo, &prep).expect("plan");
    let ctx = context();
    let desc = crate::scene_desc(sc);
    let mut passes = [0; 3];
    for mode in [ClearMode::Command, ClearMode::LoadOp] {
        for normals in [false, true] {
            // [joined blocks, depth-only blocks, a block per pass]
            let ways = [
                (BlockJoin::Masked, false),
                (BlockJoin::DepthOnly, false),
                (BlockJoin::Masked, true),
            ];
            let mut ex: Vec<Executor> = ways
                .iter()
                .map(|&(join, per_pass)| {
                    let mut e = Executor::new(&ctx, &desc).expect("executor");
                    e.set_clear_mode(mode);
                    e.set_block_join(join);
                    e.set_pass_timestamps(per_pass);
                    e.set_normals(normals);
                    e.set_direct_shade(direct);
                    e.upload(sc).expect("upload");
                    e
                })
                .collect();
            for i in 0..3 {
                let what =
                    format!("{name} {algo} {mode:?} normals {normals} direct {direct} frame {i}");
                let f: Vec<_> = ex
                    .iter_mut()
                    .map(|e| e.frame(&plan).expect("frame"))
                    .collect();
                for k in 1..3 {
                    assert!(
                        f[0].images == f[k].images,
                        "{what}: joined blocks change the image (against {:?})",
                        ways[k]
                    );
                }
                if normals {
                    let n: Vec<_> = ex
                        .iter_mut()
                        .map(|e| e.read_normals().expect("read").expect("normals on"))
                        .collect();
                    assert!(
                        n[0] == n[1] && n[0] == n[2],
                        "{what}: joined blocks change the normals"
                    );
                }
                assert_within_cst_bars(&reference, &f[0].images, &what);
                let c: Vec<_> = f.iter().map(|f| &f.stats.counts).collect();
                eprintln!(
                    "{what}: blocks (barriers) joined {} ({}), depth-only {} ({}), per pass {} ({})",
                    c[0].render_passes,
                    c[0].barriers,
                    c[1].render_passes,
                    c[1].barriers,
                    c[2].render_passes,
                    c[2].barriers
                );
                for k in 1..3 {
                    assert!(
                        c[0].render_passes <= c[k].render_passes && c[0].barriers <= c[k].barriers,
                        "{what}: {} blocks joined, {} with {:?}",
                        c[0].render_passes,
                        c[k].render_passes,
                        ways[k]
                    );
                }
                passes = [c[0].render_passes, c[1].render_passes, c[2].render_passes];
            }
        }
    }
    assert_clean(&ctx);
    passes
}

#[test]
fn a_direct_product_and_its_shade_share_one_block() {
    let box_frames = |direct| joined_frames_agree("one box", &one_box(), Algo::Scs, direct);
    let [joined, depth_only, per_pass] = box_frames(false);
    // The direct draw's block opens with the shade's attachments.
    assert_eq!(joined, 1, "one block for the box and its shade");
    assert_eq!(
        depth_only, 2,
        "depth-only blocks: the direct draw, the shade"
    );
    assert_eq!(per_pass, 2, "a block per pass: the direct draw, the shade");
    // Shaded in its direct draw: one colour block whichever way.
    assert_eq!(box_frames(true), [1, 1, 1]);
}

#[test]
fn a_clip_sweep_and_direct_draws_share_the_shade_block() {
    // SCS on interference: the tie-free parity and clip draws and the
    // clip's footprint sweep join one block, colour masked: were the sweep
    // to write colour, the images would differ. Since the front draw's
    // texture write is dead (nobody reads it, `plan::reach`), the front
    // draw is depth-only too, so depth-only blocks join as well.
    let sc = load(&crate::setup::scenes_dir().join("interference.toml"));
    let [joined, depth_only, per_pass] = joined_frames_agree("interference", &sc, Algo::Scs, true);
    assert!(
        joined <= depth_only && joined < per_pass,
        "{joined} blocks joined, {depth_only} depth-only, {per_pass} per pass"
    );
    for algo in [Algo::Goldfeather, Algo::CstI] {
        joined_frames_agree("interference", &sc, algo, true);
    }
}
