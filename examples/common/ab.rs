//! What the interleaved A/B examples (`exec_ab`, `tie_ab`) share: their
//! command line `SIZE FRAMES ALGOS SCENE...` and medians.

use peeltrim::plan::Algo;

/// The command line: image size, timed frames, algorithms, scene paths.
pub struct Args {
    pub size: (u32, u32),
    pub frames: usize,
    pub algos: Vec<Algo>,
    pub scenes: Vec<String>,
}

pub fn args() -> Args {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (w, h) = args[0].split_once('x').expect("SIZE is WxH");
    Args {
        size: (w.parse().unwrap(), h.parse().unwrap()),
        frames: args[1].parse().expect("FRAMES"),
        algos: args[2]
            .split(',')
            .map(|a| Algo::parse(a).expect("algo"))
            .collect(),
        scenes: args[3..].to_vec(),
    }
}

pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// A scene path's file stem.
pub fn scene_name(p: &str) -> &str {
    std::path::Path::new(p)
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or(p)
}

/// Lavapipe without validation.
pub fn lavapipe() -> peeltrim::vk::Context {
    peeltrim::vk::Context::new(&peeltrim::vk::ContextDesc {
        device: peeltrim::vk::DeviceChoice::Cpu,
        validation: false,
    })
    .expect("lavapipe")
}

/// The default depth set-up (D32S8, reversed Z) at `size`.
pub fn desc(size: (u32, u32)) -> peeltrim::vk::ExecDesc {
    peeltrim::vk::ExecDesc {
        width: size.0,
        height: size.1,
        depth_format: peeltrim::vk::DepthFormat::D32S8,
        reversed_z: true,
    }
}
