//! Interleaved A/B timing of the embedding path against the standalone path
//! (issue 14, "Speed"): for each scene and algorithm, a standalone frame
//! (`Executor::execute`, the kept recording replayed) and an embedded frame
//! (`CsgScene` recorded into an off-screen host's frame, the host's clear
//! submitted apart) alternate, so that a shared machine's load falls on both
//! alike. Prints the median process CPU time (every thread: lavapipe's
//! rasterizer work) and wall time per frame, their ratio and the frames' counts.
//!
//! `cargo run --release --example embed_ab -- SIZE FRAMES ALGOS SCENE...`
//! (e.g. `400x400 15 cst-i,goldfeather scenes/speckle.toml`). With
//! `EMBED_AB_ONLY=standalone` or `=embedded` only that path runs (for `perf`);
//! `EMBED_AB_UNCUT=off`: every final-shade piece keeps the check of the
//! output depth (`plan::cut_away` unused, A/B); `EMBED_AB_INSIDES=plan`:
//! the written final shade keeps the plan's order (no insides drawn last,
//! `Executor::set_insides_last`); `EMBED_AB_OPENINGS=off`: the final shade's
//! checks over the boxes' meeting and the insides whole
//! (`Executor::set_openings`).

#[path = "ab_common/mod.rs"]
mod ab_common;

use ab_common::{for_each_run, median};
use peeltrim::vk::{ExecStats, Executor, OffscreenHost};
use peeltrim::{CsgScene, EmbedDesc, LoopCounts};

fn main() {
    let only = std::env::var("EMBED_AB_ONLY").ok();
    let (alone_on, embedded_on) = match only.as_deref() {
        Some("standalone") => (true, false),
        Some("embedded") => (false, true),
        _ => (true, true),
    };
    for_each_run(|ctx, scene, name, algo, plan, desc, frames| {
        let mut exec = Executor::new(ctx, desc).expect("executor");
        // `EMBED_AB_ZONES=off`: the standalone frame without tie zones (A/B).
        if std::env::var("EMBED_AB_ZONES").as_deref() == Ok("off") {
            exec.set_tie_zones(false);
        }
        exec.upload(scene).expect("upload");
        let edesc = EmbedDesc {
            extent: [desc.width, desc.height],
            reversed_z: desc.reversed_z,
            frames_in_flight: 1,
            algo,
            loop_counts: LoopCounts::Learn,
            internal_depth: desc.depth_format,
        };
        let mut csg = CsgScene::from_scene(ctx, scene, &edesc).expect("embedded scene");
        if std::env::var("EMBED_AB_UNCUT").as_deref() == Ok("off") {
            // The camera does not move here, so nothing sets them again.
            csg.recorder()
                .set_cut_away(peeltrim::plan::cut_away::CutAway::none());
        }
        if std::env::var("EMBED_AB_INSIDES").as_deref() == Ok("plan") {
            csg.recorder().executor().set_insides_last(false);
        }
        if std::env::var("EMBED_AB_OPENINGS").as_deref() == Ok("off") {
            csg.recorder().executor().set_openings(false);
        }
        let mut host = OffscreenHost::new(ctx, edesc.extent).expect("host");
        let far = if desc.reversed_z { 0.0 } else { 1.0 };
        let bg = scene.render.background;
        let mut embedded = |host: &mut OffscreenHost| -> ExecStats {
            host.clear(bg, far).expect("host clear");
            host.frame(csg.recorder()).expect("embedded frame")
        };
        for _ in 0..3 {
            if alone_on {
                exec.execute(&plan).expect("warm-up");
            }
            if embedded_on {
                embedded(&mut host);
            }
        }
        let (mut a, mut e) = (Vec::new(), Vec::new());
        for i in 0..frames {
            // The order inside a pair alternates.
            for second in [i % 2 == 1, i % 2 == 0] {
                if second && alone_on {
                    a.push(exec.execute(&plan).expect("standalone"));
                } else if !second && embedded_on {
                    e.push(embedded(&mut host));
                }
            }
        }
        let med = |v: &[ExecStats], f: fn(&ExecStats) -> f64| {
            if v.is_empty() {
                0.0
            } else {
                median(v.iter().map(f).collect())
            }
        };
        let ratio = |f: fn(&ExecStats) -> f64| {
            if a.is_empty() || e.is_empty() {
                return 0.0;
            }
            median(e.iter().zip(&a).map(|(e, a)| f(e) / f(a)).collect())
        };
        print!("{name:16} {:20}", algo.name());
        print!(
            "  standalone {:7.2} cpu {:7.2} wall  embedded {:7.2} cpu {:7.2} wall  ratio cpu {:5.3} wall {:5.3}",
            med(&a, |s| s.frame_cpu_ms),
            med(&a, |s| s.frame_ms),
            med(&e, |s| s.frame_cpu_ms),
            med(&e, |s| s.frame_ms),
            ratio(|s| s.frame_cpu_ms),
            ratio(|s| s.frame_ms),
        );
        for (label, s) in [("standalone", a.last()), ("embedded", e.last())] {
            if let Some(s) = s {
                let c = &s.counts;
                print!(
                    "  | {label}: draws {} (mesh {:.2} Mpx; direct-shade {} dead-tex {} footprint {}; shade rule {} on {:.2} Mpx, fixed {}, written {} fetching on {:.3} Mpx, uncut {} on {:.3} Mpx, insides last {}, insides cut by {:.3} Mpx) barriers {} passes {} fullscreen {} ({:.2} Mpx) clears {} cleared {:.2} Mpx",
                    c.draws,
                    c.mesh_pixels as f64 * 1e-6,
                    c.direct_shade_draws,
                    c.dead_texture_writes,
                    c.footprint_passes,
                    c.shade_rule_draws,
                    c.shade_rule_pixels as f64 * 1e-6,
                    c.shade_fixed_draws,
                    c.shade_written_draws,
                    c.shade_written_fetch_pixels as f64 * 1e-6,
                    c.shade_uncut_draws,
                    c.shade_uncut_pixels as f64 * 1e-6,
                    c.shade_insides_last,
                    c.shade_insides_cut_pixels as f64 * 1e-6,
                    c.barriers,
                    c.render_passes,
                    c.fullscreen_passes,
                    c.fullscreen_pixels as f64 * 1e-6,
                    c.clear_commands,
                    c.cleared_pixels as f64 * 1e-6
                );
            }
        }
        println!();
    });
}
