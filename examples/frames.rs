//! Runs FRAMES timed-style frames of one algorithm on one scene, as the bench
//! times them (warm-up, per-pass timestamps off), for callgrind/perf:
//! the difference between two FRAMES counts is the per-frame cost.
//!
//! `cargo run --release --example frames -- SIZE FRAMES ALGO SCENE`;
//! `FRAMES_COUNTS=1` prints the last frame's counts.
//! (README "The per-pixel floor against OpenCSG").

use std::path::Path;

use peeltrim::plan::{self, Algo, Prepared};
use peeltrim::scene::load::{load, LoadOptions};
use peeltrim::vk::{
    ClearMode, Context, ContextDesc, DepthFormat, DeviceChoice, ExecDesc, Executor,
};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (w, h) = args[0].split_once('x').expect("SIZE is WxH");
    let size: (u32, u32) = (w.parse().unwrap(), h.parse().unwrap());
    let frames: usize = args[1].parse().expect("FRAMES");
    let algo = Algo::parse(&args[2]).expect("algo");
    let scene = load(Path::new(&args[3]), &LoadOptions { size: Some(size) }).expect("scene");
    let prep = Prepared::new(&scene).expect("prepared");
    let plan = plan::build(algo, &prep).expect("plan");
    let ctx = Context::new(&ContextDesc {
        device: DeviceChoice::Cpu,
        validation: false,
    })
    .expect("lavapipe");
    let desc = ExecDesc {
        width: size.0,
        height: size.1,
        depth_format: DepthFormat::D32S8,
        reversed_z: true,
    };
    let mut gpu = Executor::new(&ctx, &desc).expect("executor");
    gpu.upload(&scene).expect("upload");
    // FRAMES_CLEARS=command|load-op: the clear mode (default: the device's).
    match std::env::var("FRAMES_CLEARS").as_deref() {
        Ok("command") => gpu.set_clear_mode(ClearMode::Command),
        Ok("load-op") => gpu.set_clear_mode(ClearMode::LoadOp),
        _ => {}
    }
    for _ in 0..3 {
        gpu.execute(&plan).expect("warm-up");
    }
    gpu.set_pass_timestamps(false);
    gpu.execute(&plan).expect("record");
    let mut ms = Vec::new();
    let mut last = None;
    for _ in 0..frames {
        let f = gpu.execute(&plan).expect("frame");
        ms.push(f.frame_ms);
        last = Some(f.counts);
    }
    if std::env::var_os("FRAMES_COUNTS").is_some() {
        eprintln!("{last:#?}");
    }
    // FRAMES_SLEEP=S: stay alive S seconds (to attach a debugger to the JIT code).
    if let Some(s) = std::env::var("FRAMES_SLEEP")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        eprintln!("pid {}", std::process::id());
        std::thread::sleep(std::time::Duration::from_secs(s));
    }
    ms.sort_by(f64::total_cmp);
    if let Some(m) = ms.get(ms.len() / 2) {
        eprintln!("median frame_ms {m:.3} over {frames}");
    }
}
