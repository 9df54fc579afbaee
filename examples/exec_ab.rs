//! Interleaved A/B timing of executor settings in one process (issue 9): for
//! each scene and algorithm, frames of every variant alternate, so that a shared
//! machine's load falls on all of them alike. Prints the median process CPU time
//! (every thread: lavapipe's rasterizer work) and wall time per frame.
//!
//! `cargo run --release --example exec_ab -- SIZE FRAMES ALGOS SCENE...`
//! with ALGOS comma-separated (e.g. `400x400 15 cst-i,goldfeather scenes/complex.toml`).
//! Variants: whole-image or scissored clears (`Executor::set_scissored_clears`),
//! per-pass timestamps on or off (`Executor::set_pass_timestamps`), clear
//! commands or load ops (`Executor::set_clear_mode`), depth-only draws in
//! blocks of their own or sharing colour blocks masked
//! (`Executor::set_block_join`). `PEELTRIM_AB=join` runs only the variants of
//! the bench's timed frames (no per-pass timestamps). README, "Executor fixed
//! costs on lavapipe" and "One block for the depth-only draws and the shade".

#[path = "ab_common/mod.rs"]
mod ab_common;

use ab_common::{for_each_run, median};
use peeltrim::vk::{BlockJoin, ClearMode, Executor};

fn main() {
    // (name, clear mode, scissored clears, per-pass timestamps, block joining)
    let depth = BlockJoin::DepthOnly;
    let variants: Vec<(&str, ClearMode, bool, bool, BlockJoin)> =
        match std::env::var("PEELTRIM_AB").as_deref() {
            Ok("join") => vec![
                ("depth-only", ClearMode::Command, true, false, depth),
                ("masked", ClearMode::Command, true, false, BlockJoin::Masked),
                ("loadop", ClearMode::LoadOp, true, false, depth),
            ],
            _ => vec![
                ("whole", ClearMode::Command, false, true, depth),
                ("scissored", ClearMode::Command, true, true, depth),
                // Load-op clears over render areas cut to the cleared regions.
                ("loadop", ClearMode::LoadOp, true, true, depth),
            ],
        };
    for_each_run(|ctx, scene, name, algo, plan, desc, frames| {
        let mut exs: Vec<Executor> = variants
            .iter()
            .map(|&(_, clears, scissored, ts, join)| {
                let mut e = Executor::new(ctx, desc).expect("executor");
                e.set_clear_mode(clears);
                e.set_block_join(join);
                e.set_scissored_clears(scissored);
                e.set_pass_timestamps(ts);
                e.upload(scene).expect("upload");
                e.set_cut_away(ab_common::cut_away(scene, algo));
                for _ in 0..3 {
                    e.execute(&plan).expect("warm-up");
                }
                e
            })
            .collect();
        let mut cpu = vec![Vec::new(); variants.len()];
        let mut wall = vec![Vec::new(); variants.len()];
        for _ in 0..frames {
            for (i, e) in exs.iter_mut().enumerate() {
                let s = e.execute(&plan).expect("frame");
                cpu[i].push(s.frame_cpu_ms);
                wall[i].push(s.frame_ms);
            }
        }
        print!("{:16} {:12}", name, algo.name());
        for (i, v) in variants.iter().enumerate() {
            let c = exs[i].execute(&plan).expect("frame").counts;
            print!(
                "  {}: {:7.2} cpu {:7.2} wall [passes {} barriers {} clears {} {:.2} Mpx]",
                v.0,
                median(cpu[i].clone()),
                median(wall[i].clone()),
                c.render_passes,
                c.barriers,
                c.clear_commands + c.load_op_clears,
                c.cleared_pixels as f64 * 1e-6
            );
        }
        println!();
    });
}
