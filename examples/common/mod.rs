//! Shared by the profiling examples (`frames`, `rerecord_loop`): their
//! arguments (`SIZE FRAMES ALGOS SCENE...`), the lavapipe context and the loop
//! over scenes and algorithms on the default depth set-up (D32S8, reversed Z),
//! and the cutter sets the bench gives its executor.

use std::path::Path;

use peeltrim::plan::cut_away::CutAway;
use peeltrim::plan::{self, Algo, Plan, Prepared};
use peeltrim::scene::load::{load, LoadOptions};
use peeltrim::scene::Scene;
use peeltrim::vk::{Context, ContextDesc, DepthFormat, DeviceChoice, ExecDesc};

/// The cutter sets `render` and the bench give the executor for `algo` on
/// `scene` (`plan::cut_away`), so that these frames do the bench's work.
#[allow(dead_code)] // rerecord_loop makes its own
pub fn cut_away(scene: &Scene, algo: Algo) -> CutAway {
    let prep = Prepared::new(scene).expect("prepared");
    CutAway::of(algo, &prep, scene)
}

pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Parses the command line and calls `run` for every scene and algorithm with
/// the context, the scene, its name, the algorithm, its plan, the executor
/// description and the number of timed frames asked for.
pub fn for_each_run(mut run: impl FnMut(&Context, &Scene, &str, Algo, Plan, &ExecDesc, usize)) {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (w, h) = args[0].split_once('x').expect("SIZE is WxH");
    let size: (u32, u32) = (w.parse().unwrap(), h.parse().unwrap());
    let frames: usize = args[1].parse().expect("FRAMES");
    let algos: Vec<Algo> = args[2]
        .split(',')
        .map(|a| Algo::parse(a).expect("algo"))
        .collect();
    let ctx = Context::new(&ContextDesc {
        device: DeviceChoice::Cpu,
        // `PEELTRIM_VALIDATION=1` checks a run (a validation message is printed).
        validation: ContextDesc::validation_default(),
    })
    .expect("lavapipe");
    let desc = ExecDesc {
        width: size.0,
        height: size.1,
        depth_format: DepthFormat::D32S8,
        reversed_z: true,
    };
    for path in &args[3..] {
        let scene = load(Path::new(path), &LoadOptions { size: Some(size) }).expect("scene");
        let prep = Prepared::new(&scene).expect("prepared");
        let name = Path::new(path)
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or(path);
        for &algo in &algos {
            let plan = plan::build(algo, &prep).expect("plan");
            run(&ctx, &scene, name, algo, plan, &desc, frames);
        }
    }
}
