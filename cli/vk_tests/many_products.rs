//! Many products in one frame (per-product fixed costs): products
//! apart on screen and products whose rectangles overlap (one sphere in front
//! of another, a cutter reaching into a neighbour's rectangle). A product's
//! depth-stencil-only draws (SCS's tie-free parity draws) share the block of
//! its surface draws, so the surface texture's colour attachment stays bound
//! while they run: its pipeline must leave it unwritten. Each frame is
//! checked against the exact reference and against the same frame cut into a
//! block per pass (a timestamp at every pass), pixel for pixel.

use peeltrim::plan::{build, Algo, Prepared};
use peeltrim::scene::Scene;
use peeltrim::vk::Executor;

use crate::algorithms::{assert_within_cst_bars, load_text};
use crate::{assert_clean, context};

/// Six products `Si - Ci` (sphere minus a cylinder through it): three apart
/// in a row, and a cluster of three whose spheres overlap on screen, one in
/// front of the others, with a cutter long enough to reach a neighbour's
/// rectangle.
fn scene() -> Scene {
    let spheres: [([f64; 3], f64); 6] = [
        ([-3.0, 0.0, -2.0], 0.6),
        ([0.0, 0.0, -2.0], 0.6),
        ([3.0, 0.0, -2.0], 0.6),
        ([-0.5, 0.0, 1.0], 0.7),
        ([0.3, 0.2, 1.5], 0.6),
        ([0.9, -0.1, 0.8], 0.5),
    ];
    let mut text =
        String::from("[camera]\neye = [0.5, 3.0, 6.0]\ntarget = [0.0, 0.0, -0.3]\nfit = true\n");
    let mut expr = Vec::new();
    for (i, (c, r)) in spheres.iter().enumerate() {
        let height = if i == 4 { 3.0 } else { 2.2 * r };
        text += &format!(
            "[[primitive]]\nname = \"S{i}\"\nshape = \"sphere\"\nradius = {r}\nsegments = 20\nrings = 10\n\
             translate = [{}, {}, {}]\ncolor = \"#4080c0\"\n\
             [[primitive]]\nname = \"C{i}\"\nshape = \"cylinder\"\nradius = {}\nheight = {height}\nsegments = 16\n\
             rotate_deg = [{}, 0.0, 0.0]\ntranslate = [{}, {}, {}]\ncolor = \"#c04040\"\n",
            c[0],
            c[1],
            c[2],
            0.4 * r,
            if i == 4 { 90.0 } else { 0.0 },
            c[0],
            c[1],
            c[2],
        );
        expr.push(format!("(S{i} - C{i})"));
    }
    text += &format!("[csg]\nexpr = \"{}\"\n", expr.join(" + "));
    load_text(&text, "many_products.toml")
}

#[test]
fn products_sharing_blocks_match_the_reference_and_the_unshared_frame() {
    let sc = scene();
    let (w, h) = (sc.render.width, sc.render.height);
    let reference = peeltrim_reference::render(&sc, w, h);
    let prep = Prepared::new(&sc).expect("a solid");
    let ctx = context();
    let desc = crate::scene_desc(&sc);
    for algo in [Algo::Scs, Algo::Goldfeather, Algo::CstI] {
        let plan = build(algo, &prep).expect("plan");
        // [shared blocks, a block per pass]
        let mut ex: Vec<Executor> = [false, true]
            .iter()
            .map(|&per_pass| {
                let mut e = Executor::new(&ctx, &desc).expect("executor");
                e.set_pass_timestamps(per_pass);
                e.upload(&sc).expect("upload");
                e
            })
            .collect();
        // Loop by loop, recorded, replayed.
        for i in 0..3 {
            let what = format!("{algo} frame {i}");
            let f: Vec<_> = ex
                .iter_mut()
                .map(|e| e.frame(&plan).expect("frame"))
                .collect();
            assert!(
                f[0].images == f[1].images,
                "{what}: shared blocks change the image"
            );
            assert_within_cst_bars(&reference, &f[0].images, &what);
            let (shared, per_pass) = (&f[0].stats.counts, &f[1].stats.counts);
            eprintln!(
                "{what}: blocks {} shared, {} per pass",
                shared.render_passes, per_pass.render_passes
            );
            assert!(
                shared.render_passes <= per_pass.render_passes,
                "{what}: {} blocks shared, {} per pass",
                shared.render_passes,
                per_pass.render_passes
            );
            if algo == Algo::Scs && i > 0 {
                // Per group of products side by side (`plan::scs::batch`:
                // the three apart share one; the cluster's stay alone):
                // its surface (front, parity and exit draws) and its
                // merge; then the shade.
                let groups = plan
                    .steps
                    .iter()
                    .filter(|s| matches!(s, peeltrim::plan::Step::Pass(n) if n == "scs-front"))
                    .count() as u64;
                assert!(groups < 6, "{what}: {groups} groups for 6 products");
                assert!(
                    shared.render_passes <= 2 * groups + 2,
                    "{what}: {} blocks for {groups} groups",
                    shared.render_passes
                );
                assert!(
                    per_pass.render_passes >= 3 * groups,
                    "{what}: {} blocks a pass each",
                    per_pass.render_passes
                );
            }
        }
        drop(ex);
    }
    assert_clean(&ctx);
}
