//! Re-recording only (issue 9 §3: a changed plan re-recorded at ≤ 1 µs per
//! draw): for each scene and algorithm, the plan's frame is run until a
//! recording is kept, then recorded anew REPS times without submitting, with
//! its reach worked out anew (`Executor::time_recording`) and taken from the
//! cache (`Executor::time_recording_cached`). Prints the median thread-CPU µs
//! per draw of both and the state commands per draw. A loop to profile
//! (`perf record`, `valgrind --tool=callgrind`) that spends its time in the
//! recorder, not in the rasterizer.
//!
//! `cargo run --release --example rerecord_loop -- SIZE REPS ALGOS SCENE...`
//! (e.g. `800x800 200 goldfeather,scs,cst-i scenes/gear.toml`).

#[path = "common/mod.rs"]
mod common;

use common::{for_each_run, median};
use peeltrim::vk::Executor;

fn main() {
    println!(
        "{:16} {:12} {:>6} {:>10} {:>10} {:>12}",
        "scene", "algo", "draws", "anew us/dr", "cached", "state/draw"
    );
    for_each_run(|ctx, scene, name, algo, plan, desc, reps| {
        let mut e = Executor::new(ctx, desc).expect("executor");
        e.upload(scene).expect("upload");
        let mut stats = None;
        let mut anew = None;
        for _ in 0..3 {
            stats = Some(e.execute(&plan).expect("frame"));
            anew = e.time_recording(&plan, reps as u32).expect("re-record");
            if anew.is_some() {
                break;
            }
        }
        let Some(anew) = anew else {
            println!("{name:16} {:12} no recording kept", algo.name());
            return;
        };
        let cached = e
            .time_recording_cached(&plan, reps as u32)
            .expect("re-record")
            .expect("kept above");
        let c = stats.expect("ran above").counts;
        let draws = c.draws.max(1) as f64;
        println!(
            "{:16} {:12} {:>6} {:>10.3} {:>10.3} {:>12.2}",
            name,
            algo.name(),
            c.draws,
            median(anew) * 1e3 / draws,
            median(cached) * 1e3 / draws,
            c.state_commands as f64 / draws
        );
    });
}
