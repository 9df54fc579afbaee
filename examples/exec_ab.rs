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

#[path = "common/ab.rs"]
mod ab;

use std::path::Path;

use ab::{median, scene_name, Args};

use peeltrim::plan::{self, Prepared};
use peeltrim::scene::load::{load, LoadOptions};
use peeltrim::vk::{ClearMode, Executor};

fn main() {
    let Args {
        size,
        frames,
        algos,
        scenes,
    } = ab::args();
    // (name, clear mode, scissored clears, per-pass timestamps)
    let variants: Vec<(&str, ClearMode, bool, bool)> = vec![
        ("whole", ClearMode::Command, false, true),
        ("scissored", ClearMode::Command, true, true),
        ("whole-nots", ClearMode::Command, false, false),
        ("scissored-nots", ClearMode::Command, true, false),
        // Load-op clears (whole images, lavapipe's binned clear) re-checked.
        ("loadop-nots", ClearMode::LoadOp, true, false),
    ];
    let ctx = ab::lavapipe();
    for path in &scenes {
        let scene = load(Path::new(path), &LoadOptions { size: Some(size) }).expect("scene");
        let prep = Prepared::new(&scene).expect("prepared");
        for &algo in &algos {
            let plan = plan::build(algo, &prep).expect("plan");
            let desc = ab::desc(size);
            let mut exs: Vec<Executor> = variants
                .iter()
                .map(|&(_, clears, scissored, ts)| {
                    let mut e = Executor::new(&ctx, &desc).expect("executor");
                    e.set_clear_mode(clears);
                    e.set_scissored_clears(scissored);
                    e.set_pass_timestamps(ts);
                    e.upload(&scene).expect("upload");
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
            print!("{:16} {:12}", scene_name(path), algo.name());
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
        }
    }
}
