//! Interleaved A/B of the tie-free fast path (`plan::tie_free`,
//! `Executor::set_tie_free`) in one process: for each scene and algorithm, a
//! frame with every parity and peel draw running its tie-rule shader alternates
//! with a frame where those that cannot tie run as plain depth tests, so a shared
//! machine's load falls on both alike. Prints the median process CPU time per
//! frame (every thread; with `LP_NUM_THREADS=0` lavapipe rasterizes in the
//! calling thread), the ratio, and the executed tie-free and tie-rule draws.
//!
//! `cargo run --release --example tie_ab -- SIZE FRAMES ALGOS SCENE...`
//! with ALGOS comma-separated (e.g. `800x800 7 cst-g,cst-i scenes/complex.toml`).
//! README, "Per-fragment work". With `TIE_AB=shade`, both frames run their
//! parity and peel draws tie-free and only the final shade differs: every draw
//! with the tie rule (A), or the tie-free meshes' draws as depth-`EQUAL` draws
//! (B, `Executor::set_fixed_shade`; README "The final shade as depth-equal
//! draws"); the counts are then the shade's depth-equal and tie-rule draws.
//! With `TIE_AB=zones`, both frames run the depth-equal shade where no tie is
//! possible and differ only in where a mesh that can tie runs the rule: over
//! its whole rectangle (A) or only inside its tie zones (B,
//! `Executor::set_tie_zones`; README "Tie zones"); the counts are then B's
//! tie-rule pixels of the shade, and A's. With `TIE_AB=direct`, both frames
//! run everything tie-free and differ only in one-primitive products: drawn
//! depth-only and shaded again in the final shade (A), or shaded in their
//! direct draw (B, `Executor::set_direct_shade`; README "One-primitive
//! products shaded in their own draw"); the counts are then B's direct draws
//! that shade, and B's mesh pixels against A's. With `TIE_AB=depth`, both
//! frames run everything else tie-free and differ only in the parity and clip
//! draws that may meet a tie: the texture's rule shaders (A) or the rule as
//! the depth test (B, `Executor::set_tie_depth`; README "Ties as the depth
//! test"); the counts are then B's depth-test draws and A's rule draws, and a
//! line more gives both frames' wall time, barriers and render passes.

#[path = "ab_common/mod.rs"]
mod ab_common;

use ab_common::{for_each_run, median};
use peeltrim::vk::Executor;

fn main() {
    let mode = std::env::var("TIE_AB").unwrap_or_default();
    let (shade_only, zones, direct) = (mode == "shade", mode == "zones", mode == "direct");
    let depth = mode == "depth";
    println!("scene            algo          tie-rule CPU ms  tie-free CPU ms  ratio  | tie-free draws, tie-rule draws left");
    let mut analysed = String::new();
    for_each_run(|ctx, scene, name, algo, plan, desc, frames| {
        if analysed != name {
            analysed = name.to_string();
            let meshes: Vec<&peeltrim::scene::Mesh> = scene
                .primitives
                .iter()
                .map(|p| &p.mesh)
                .chain(scene.surfaces.iter().map(|s| &s.mesh))
                .collect();
            let t = std::time::Instant::now();
            let gaps = peeltrim::geom::ties::TieGaps::new(&meshes);
            println!(
                "{name}: tie analysis of {} triangles {:.1} ms, {} mesh pairs within the cap",
                meshes.iter().map(|m| m.triangles.len()).sum::<usize>(),
                t.elapsed().as_secs_f64() * 1e3,
                gaps.pairs.len()
            );
        }
        let mut exs: Vec<Executor> = [false, true]
            .iter()
            .map(|&on| {
                let mut e = Executor::new(ctx, desc).expect("executor");
                if depth {
                    e.set_tie_depth(on);
                } else if direct {
                    e.set_direct_shade(on);
                } else if zones {
                    e.set_tie_zones(on);
                } else if shade_only {
                    e.set_fixed_shade(on);
                } else {
                    e.set_tie_free(on);
                }
                e.upload(scene).expect("upload");
                e.set_cut_away(ab_common::cut_away(scene, algo));
                for _ in 0..2 {
                    e.execute(&plan).expect("warm-up");
                }
                e
            })
            .collect();
        let (mut cpu, mut wall) = ([Vec::new(), Vec::new()], [Vec::new(), Vec::new()]);
        for _ in 0..frames {
            for (i, e) in exs.iter_mut().enumerate() {
                let s = e.execute(&plan).expect("frame");
                cpu[i].push(s.frame_cpu_ms);
                wall[i].push(s.frame_ms);
            }
        }
        let c = exs[1].execute(&plan).expect("frame").counts;
        let ac = exs[0].execute(&plan).expect("frame").counts;
        let a_rule_pixels = ac.shade_rule_pixels;
        let (a, b) = (median(cpu[0].clone()), median(cpu[1].clone()));
        if direct {
            println!(
                "{name:16} {:12} mesh pixels {} -> {}, draws {} -> {}, render passes {} -> {}",
                algo.name(),
                ac.mesh_pixels,
                c.mesh_pixels,
                ac.draws,
                c.draws,
                ac.render_passes,
                c.render_passes
            );
        }
        if depth {
            println!(
                "{name:16} {:12} wall ms {:.2} -> {:.2}, barriers {} -> {}, render passes {} -> {}",
                algo.name(),
                median(wall[0].clone()),
                median(wall[1].clone()),
                ac.barriers,
                c.barriers,
                ac.render_passes,
                c.render_passes
            );
        }
        let (free, rule) = match (zones, shade_only) {
            _ if depth => (c.tie_depth_draws, ac.tie_rule_draws),
            _ if direct => (c.direct_shade_draws, c.shade_fixed_draws),
            (true, _) => (c.shade_rule_pixels, a_rule_pixels),
            (false, true) => (c.shade_fixed_draws, c.shade_rule_draws),
            (false, false) => (c.tie_free_draws, c.tie_rule_draws),
        };
        println!(
            "{:16} {:12} {:15.1} {:16.1} {:6.2}  | {}, {}",
            name,
            algo.name(),
            a,
            b,
            b / a,
            free,
            rule
        );
    });
}
