//! Interleaved A/B timing of executor settings in one process (issue 9): for
//! each scene and algorithm, frames of every variant alternate, so that a shared
//! machine's load falls on all of them alike. Prints the median process CPU time
//! (every thread: lavapipe's rasterizer work) and wall time per frame.
//!
//! `cargo run --release --example exec_ab -- SIZE FRAMES ALGOS SCENE...`
//! with ALGOS comma-separated (e.g. `400x400 15 cst-i,goldfeather scenes/complex.toml`).
//! Variants: whole-image or scissored clears (`Executor::set_scissored_clears`),
//! per-pass timestamps on or off (`Executor::set_pass_timestamps`), clear
//! commands or load ops (`Executor::set_clear_mode`). README,
//! "Executor fixed costs on lavapipe".

#[path = "ab_common/mod.rs"]
mod ab_common;

use ab_common::{for_each_run, median};
use peeltrim::vk::{ClearMode, Executor};

fn main() {
    // (name, clear mode, scissored clears, per-pass timestamps)
    let variants: Vec<(&str, ClearMode, bool, bool)> = vec![
        ("whole", ClearMode::Command, false, true),
        ("scissored", ClearMode::Command, true, true),
        // Load-op clears over render areas cut to the cleared regions.
        ("loadop", ClearMode::LoadOp, true, true),
    ];
    for_each_run(|ctx, scene, name, algo, plan, desc, frames| {
        let mut exs: Vec<Executor> = variants
            .iter()
            .map(|&(_, clears, scissored, ts)| {
                let mut e = Executor::new(ctx, desc).expect("executor");
                e.set_clear_mode(clears);
                e.set_scissored_clears(scissored);
                e.set_pass_timestamps(ts);
                e.upload(scene).expect("upload");
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
        let c = exs[1].execute(&plan).expect("frame").counts;
        print!("{:16} {:12}", name, algo.name());
        for (i, v) in variants.iter().enumerate() {
            print!(
                "  {}: {:7.2} cpu {:7.2} wall",
                v.0,
                median(cpu[i].clone()),
                median(wall[i].clone())
            );
        }
        println!(
            "  | barriers {} passes {} clears {} cleared {:.2} Mpx",
            c.barriers,
            c.render_passes,
            c.clear_commands,
            c.cleared_pixels as f64 * 1e-6
        );
    });
}
