//! Blocks joined by the recorder's look-ahead (`vk::exec::record::ahead`): a
//! block of depth-only draws opens with the colour attachments of the shade
//! after it, their writes masked. A joined block must lose no write: the shade
//! still writes colour, ids and normals there, and the depth-only draws in it
//! (SCS's clip sweep over the whole screen, a direct product's depth) leave
//! colour, ids and normals untouched. Each frame is checked against the
//! reference and, pixel for pixel, against the same frame cut into a block
//! per pass (a timestamp at every pass ends the look-ahead).

use peeltrim::plan::{build, Algo, Prepared};
use peeltrim::scene::Scene;
use peeltrim::vk::Executor;

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

/// Frames of `algo` on `sc` with blocks joined and with a block per pass
/// (clears as the device profile records them), with and without normals,
/// three times each (loop by loop, recorded, replayed): the images (and
/// normals) agree, match the reference, and the joined frame has at most as
/// many blocks as the other. One-primitive products are shaded in their
/// direct draw where the profile allows depth-equal shades (the first,
/// loop-by-loop frame keeps the depth draw and the shade). Returns the render
/// passes of the last frames.
fn joined_frames_agree(name: &str, sc: &Scene, algo: Algo) -> [u64; 2] {
    let (w, h) = (sc.render.width, sc.render.height);
    let reference = peeltrim_reference::render(sc, w, h);
    let prep = Prepared::new(sc).expect("a solid");
    let plan = build(algo, &prep).expect("plan");
    let ctx = context();
    let desc = crate::scene_desc(sc);
    let mut passes = [0; 2];
    for normals in [false, true] {
        // [joined blocks, a block per pass]
        let ways = [false, true];
        let mut ex: Vec<Executor> = ways
            .iter()
            .map(|&per_pass| {
                let mut e = Executor::new(&ctx, &desc).expect("executor");
                e.set_pass_timestamps(per_pass);
                e.set_normals(normals);
                e.upload(sc).expect("upload");
                e
            })
            .collect();
        for i in 0..3 {
            let what = format!("{name} {algo} normals {normals} frame {i}");
            let f: Vec<_> = ex
                .iter_mut()
                .map(|e| e.frame(&plan).expect("frame"))
                .collect();
            assert!(
                f[0].images == f[1].images,
                "{what}: joined blocks change the image (against a block per pass)"
            );
            if normals {
                let n: Vec<_> = ex
                    .iter_mut()
                    .map(|e| e.read_normals().expect("read").expect("normals on"))
                    .collect();
                assert!(n[0] == n[1], "{what}: joined blocks change the normals");
            }
            assert_within_cst_bars(&reference, &f[0].images, &what);
            let c: Vec<_> = f.iter().map(|f| &f.stats.counts).collect();
            eprintln!(
                "{what}: blocks (barriers) joined {} ({}), per pass {} ({})",
                c[0].render_passes, c[0].barriers, c[1].render_passes, c[1].barriers
            );
            assert!(
                c[0].render_passes <= c[1].render_passes && c[0].barriers <= c[1].barriers,
                "{what}: {} blocks joined, {} with a block per pass",
                c[0].render_passes,
                c[1].render_passes
            );
            passes = [c[0].render_passes, c[1].render_passes];
        }
    }
    assert_clean(&ctx);
    passes
}

#[test]
fn a_direct_product_and_its_shade_share_one_block() {
    let [joined, per_pass] = joined_frames_agree("one box", &one_box(), Algo::Scs);
    let shades = context()
        .profile()
        .depth_equal_shades(crate::scene_desc(&one_box()).depth_format);
    match shades {
        true => {
            // Shaded in its direct draw: one colour block whichever way.
            assert_eq!((joined, per_pass), (1, 1), "shaded in its direct draw");
        }
        false => {
            // The shade keeps the tie rule, which reads a copy of the depth
            // the direct draw wrote: the copy ends the direct draw's block.
            eprintln!("one box: {joined} blocks joined, {per_pass} per pass");
            assert!(
                joined <= per_pass,
                "{joined} blocks joined, {per_pass} per pass"
            );
        }
    }
}

#[test]
fn a_clip_sweep_and_direct_draws_share_the_shade_block() {
    // SCS on interference: the tie-free parity and clip draws and the
    // clip's footprint sweep join one block, colour masked: were the sweep
    // to write colour, the images would differ.
    let sc = load(&crate::setup::scenes_dir().join("interference.toml"));
    let [joined, per_pass] = joined_frames_agree("interference", &sc, Algo::Scs);
    assert!(
        joined < per_pass,
        "{joined} blocks joined, {per_pass} per pass"
    );
    for algo in [Algo::Goldfeather, Algo::CstI] {
        joined_frames_agree("interference", &sc, algo);
    }
}
