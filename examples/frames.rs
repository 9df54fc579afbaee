//! Runs FRAMES frames of each algorithm on each scene as the bench times them
//! (warm-up, then per-pass timestamps off, one executor), for callgrind and
//! perf: the difference between two FRAMES counts is the per-frame cost
//! (README "The per-pixel floor against OpenCSG").
//!
//! `cargo run --release --example frames -- SIZE FRAMES ALGOS SCENE...`;
//! `FRAMES_COUNTS=1` prints the last frame's counts, `FRAMES_SLEEP=S` stays
//! alive S seconds after (to dump the JIT code). Clears and the closing
//! timestamp follow the device profile (`PEELTRIM_DEVICE_PROFILE`).

#[path = "common/mod.rs"]
mod common;

use common::{for_each_run, median};
use peeltrim::vk::Executor;

fn main() {
    for_each_run(|ctx, scene, name, algo, plan, desc, frames| {
        let mut gpu = Executor::new(ctx, desc).expect("executor");
        gpu.upload(scene).expect("upload");
        gpu.set_cut_away(common::cut_away(scene, algo));
        for _ in 0..3 {
            gpu.execute(&plan).expect("warm-up");
        }
        gpu.set_pass_timestamps(false);
        gpu.execute(&plan).expect("record");
        let mut ms = Vec::new();
        let mut cpu = Vec::new();
        let mut gpu_ms = Vec::new();
        let mut proc_ms = Vec::new();
        let mut last = None;
        for _ in 0..frames {
            let f = gpu.execute(&plan).expect("frame");
            ms.push(f.frame_ms);
            cpu.push(f.cpu_ms);
            gpu_ms.push(f.gpu_ms);
            proc_ms.push(f.frame_cpu_ms);
            last = Some(f.counts);
        }
        if !ms.is_empty() {
            eprintln!(
                "{name} {}: median frame_ms {:.3}, cpu_ms {:.3}, gpu_ms {:.3}, frame_cpu_ms {:.3} over {frames}",
                algo.name(),
                median(ms),
                median(cpu),
                median(gpu_ms),
                median(proc_ms)
            );
        }
        if std::env::var_os("FRAMES_COUNTS").is_some() {
            eprintln!("{last:#?}");
        }
    });
    if let Some(s) = std::env::var("FRAMES_SLEEP")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        eprintln!("pid {}", std::process::id());
        std::thread::sleep(std::time::Duration::from_secs(s));
    }
}
