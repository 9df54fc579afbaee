//! `cargo bench`: the same harness as `peeltrim bench` (src/bench), on the shipped
//! Complex and Gear scenes with Blister and CST-Z/I/G, plus a small block-minus-
//! spheres scaling family. Results go to target/peeltrim-bench/.
//! Set PEELTRIM_BENCH_FRAMES to change the number of timed frames (default 10).

use std::path::PathBuf;

use peeltrim::plan::Algo;
use peeltrim::vk::DeviceChoice;
use peeltrim_cli::bench::{families, run_and_report, BenchConfig, BenchScene};
use peeltrim_cli::render::DepthSetup;

fn main() {
    let root = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/.."));
    let out = root.join("target/peeltrim-bench");
    let frames = std::env::var("PEELTRIM_BENCH_FRAMES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10);
    let mut scenes: Vec<BenchScene> = ["complex", "gear"]
        .iter()
        .map(|s| BenchScene {
            path: root.join(format!("scenes/{s}.toml")),
            family: None,
            n: None,
        })
        .collect();
    match families::generate("block-spheres", &[4, 16, 64], &out.join("scenes")) {
        Ok(v) => scenes.extend(v),
        Err(e) => eprintln!("skipping the scaling family: {e}"),
    }
    let cfg = BenchConfig {
        algos: vec![
            Algo::Blister,
            Algo::CstZ,
            Algo::CstI,
            Algo::CstG,
            Algo::Goldfeather,
            Algo::GoldfeatherLayered,
            Algo::Trickle,
        ],
        sizes: vec![(400, 400)],
        depth_setups: vec![DepthSetup::D32S8],
        depth_fallback: true,
        frames,
        warmup: 1,
        budget_ms: 60_000.0,
        max_est_s: peeltrim_cli::bench::estimate::DEFAULT_MAX_EST_S,
        device: DeviceChoice::Auto,
        validation: false,
        build: Default::default(),
        out: out.clone(),
        save_images: false,
        progress: true,
        baseline: None,
        embedded: false,
        samples: None,
    };
    match run_and_report(&cfg, &scenes) {
        Ok(records) => print!("{}", peeltrim_cli::bench::report::summary(&records)),
        Err(e) => {
            eprintln!("benchmark failed: {e}");
            std::process::exit(1);
        }
    }
}
