//! Runs FRAMES frames of each algorithm on each scene as the bench times them
//! (warm-up, then per-pass timestamps off, one executor), for callgrind and
//! perf: the difference between two FRAMES counts is the per-frame cost
//! (docs/bench.md).
//!
//! `cargo run --release --example frames -- SIZE FRAMES ALGOS SCENE...`;
//! `FRAMES_CLEARS=command|load-op` picks the clear mode (default: the
//! device's), `FRAMES_COUNTS=1` prints the last frame's counts,
//! `FRAMES_SLEEP=S` stays alive S seconds after (to dump the JIT code),
//! `FRAMES_INDEXED=0` draws every mesh non-indexed (`Executor::set_indexed`),
//! `FRAMES_CLOSE=after|in-block` picks where the closing timestamp goes
//! (`Executor::set_frame_timestamps`; default: the device's).

#[path = "ab_common/mod.rs"]
mod ab_common;

use ab_common::{for_each_run, median};
use peeltrim::vk::{ClearMode, Executor, FrameTimestamps};

fn main() {
    for_each_run(|ctx, scene, name, algo, plan, desc, frames| {
        let mut gpu = Executor::new(ctx, desc).expect("executor");
        gpu.upload(scene).expect("upload");
        gpu.set_cut_away(ab_common::cut_away(scene, algo));
        match std::env::var("FRAMES_CLEARS").as_deref() {
            Ok("command") => gpu.set_clear_mode(ClearMode::Command),
            Ok("load-op") => gpu.set_clear_mode(ClearMode::LoadOp),
            _ => {}
        }
        match std::env::var("FRAMES_CLOSE").as_deref() {
            Ok("after") => gpu.set_frame_timestamps(FrameTimestamps::Outside),
            Ok("in-block") => gpu.set_frame_timestamps(FrameTimestamps::Binned),
            _ => {}
        }
        gpu.set_indexed(std::env::var("FRAMES_INDEXED").as_deref() != Ok("0"))
            .expect("the soup");
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
