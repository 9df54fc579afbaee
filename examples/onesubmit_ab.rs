//! A/B of layered frames (issue 9 §2): the frame layer by layer (a submission
//! and a CPU wait per plan, as every frame ran before) against the same frame
//! in one submission replayed, interleaved on one renderer, medians of wall
//! and process CPU ms per frame, and each one's submissions.
//!
//! `cargo run --example onesubmit_ab -- [SIZE] [REPS]` (default 400, 5).

use peeltrim::plan::Algo;
use peeltrim::render::layers::{render_layered_in, LayerOptions, LayeredSession};
use peeltrim::render::{DepthSetup, RenderOptions};
use peeltrim::scene::{load, LoadOptions};
use peeltrim::vk::cpu_clock::{ms_since, process_ns};
use peeltrim::vk::DeviceChoice;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let size: u32 = args.get(1).map_or(400, |s| s.parse().expect("SIZE"));
    let reps: usize = args.get(2).map_or(5, |s| s.parse().expect("REPS"));
    let four = LayerOptions {
        max_layers: Some(4),
        ..Default::default()
    };
    let cases: [(&str, &str, Algo, Option<f64>, LayerOptions); 5] = [
        (
            "--alpha 0.5",
            "gear.toml",
            Algo::CstI,
            Some(0.5),
            LayerOptions::default(),
        ),
        (
            "--alpha 0.5 --layers 4",
            "gear.toml",
            Algo::Kirsch,
            Some(0.5),
            four.clone(),
        ),
        (
            "--alpha 0.5",
            "complex.toml",
            Algo::Kirsch,
            Some(0.5),
            LayerOptions::default(),
        ),
        ("--layers 4", "assembly.toml", Algo::CstG, None, four),
        (
            "--interference",
            "interference.toml",
            Algo::CstI,
            None,
            LayerOptions::default(),
        ),
    ];
    println!("| scene | algo | mode | submits A/B | wall ms A | wall ms B | CPU ms A | CPU ms B |");
    println!("|---|---|---|---|---|---|---|---|");
    for (mode, file, algo, alpha, lopts) in cases {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(file);
        let mut scene = load(
            &path,
            &LoadOptions {
                size: Some((size, size)),
            },
        )
        .expect("scene");
        if alpha.is_some() {
            scene.appearance.alpha = alpha;
        }
        let opts = RenderOptions {
            algo,
            device: DeviceChoice::Cpu,
            depth: DepthSetup::DEFAULT,
            depth_fallback: true,
            validation: false,
            build: Default::default(),
        };
        let mut s = LayeredSession::default();
        let frame = |s: &mut LayeredSession| {
            let (t, cpu) = (std::time::Instant::now(), process_ns());
            let f = render_layered_in(s, &scene, &opts, &lopts).expect("frame");
            let sub = f.frame.stats.exec.counts.submits;
            (t.elapsed().as_secs_f64() * 1e3, ms_since(cpu), sub)
        };
        // Warm-up: device, pipelines, the one-submission recording.
        for _ in 0..2 {
            frame(&mut s);
        }
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for _ in 0..reps {
            s.forget_layer_counts();
            a.push(frame(&mut s));
            b.push(frame(&mut s));
        }
        let col = |v: &[(f64, f64, u64)], k: usize| {
            median(v.iter().map(|x| if k == 0 { x.0 } else { x.1 }).collect())
        };
        println!(
            "| {} | {} | {mode} | {}/{} | {:.1} | {:.1} | {:.1} | {:.1} |",
            file.trim_end_matches(".toml"),
            algo.name(),
            a[0].2,
            b[0].2,
            col(&a, 0),
            col(&b, 0),
            col(&a, 1),
            col(&b, 1)
        );
    }
}
