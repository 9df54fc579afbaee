//! The rasterization floor as a bench column: the frame of one plain
//! z-buffered draw of all of a scene's primitive triangles (`plan::floor`),
//! on the same device, size and depth set-up as the algorithms. No
//! image-based CSG frame can cost less; each run is reported as a multiple
//! of it, in the summary and the floor plot.

use std::fmt::Write as _;

use peeltrim::plan::{self, Prepared};

use super::report::auto_ms;
use super::{median_iqr, Record};
use crate::render::GpuRenderer;

/// The floor's medians: wall time and the process's CPU time over a frame.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Floor {
    /// Median `frame_ms` of the floor's frames.
    pub frame_ms: f64,
    /// Median `frame_cpu_ms` of the floor's frames (lavapipe's rasterizer work).
    pub frame_cpu_ms: f64,
}

/// Times the floor of `prep` on `gpu`: `warmup` frames, then `frames` timed
/// ones (replays of one recording, as the algorithms' timed frames are).
pub fn time(
    gpu: &mut GpuRenderer,
    prep: &Prepared,
    warmup: u32,
    frames: u32,
) -> Result<Floor, String> {
    let plan = plan::floor::plan(prep);
    // The first frame of a plan runs loop by loop, the second records what
    // later frames replay.
    for _ in 0..warmup.max(2) {
        gpu.execute(&plan).map_err(|e| e.to_string())?;
    }
    let (mut wall, mut cpu) = (Vec::new(), Vec::new());
    for _ in 0..frames.max(1) {
        let f = gpu.execute(&plan).map_err(|e| e.to_string())?;
        wall.push(f.exec.frame_ms);
        cpu.push(f.exec.frame_cpu_ms);
    }
    Ok(Floor {
        frame_ms: median_iqr(&mut wall).0,
        frame_cpu_ms: median_iqr(&mut cpu).0,
    })
}

/// A run's frame as a multiple of its floor, in the time the bench compares
/// ([`auto_ms`]: CPU time on a software rasterizer, else wall time).
pub fn multiple(r: &Record) -> Option<f64> {
    let f = r.floor?;
    let floor = match auto_ms(r) == r.frame_cpu_ms_median && !is_opencsg(r) {
        true => f.frame_cpu_ms,
        false => f.frame_ms,
    };
    (r.ran() && floor > 0.0 && auto_ms(r) > 0.0).then(|| auto_ms(r) / floor)
}

/// An OpenCSG baseline run (its own process: wall time only).
fn is_opencsg(r: &Record) -> bool {
    r.algo.starts_with(super::opencsg::PREFIX)
}

/// The summary's section: per scene, size and depth set-up, the floor's time
/// and every run as a multiple of it.
pub fn section(records: &[Record]) -> String {
    let mut algos: Vec<&str> = Vec::new();
    let mut keys: Vec<(&str, u32, u32)> = Vec::new();
    for r in records.iter().filter(|r| multiple(r).is_some()) {
        if !algos.contains(&r.algo.as_str()) {
            algos.push(&r.algo);
        }
        if !keys.contains(&(r.scene.as_str(), r.width, r.height)) {
            keys.push((&r.scene, r.width, r.height));
        }
    }
    if keys.is_empty() {
        return String::new();
    }
    let mut s = String::from("## Against the rasterization floor\n\n");
    s.push_str("The floor is one plain z-buffered draw of all of the scene's primitive triangles (back faces culled, depth only) on the same device, size and depth set-up: no image-based CSG frame costs less. Each cell is the run's frame time (as in the auto table) divided by the floor's; `opencsg` is compared with the floor of the default depth set-up.\n\n");
    let _ = write!(s, "| scene | size | floor ms |");
    for a in &algos {
        let _ = write!(s, " {a} |");
    }
    s.push_str("\n|---|---|---|");
    s.push_str(&"---|".repeat(algos.len()));
    s.push('\n');
    for (scene, w, h) in keys {
        let rows: Vec<&Record> = records
            .iter()
            .filter(|r| r.scene == scene && r.width == w && r.height == h)
            .collect();
        let floor = rows.iter().find_map(|r| r.floor.filter(|_| !is_opencsg(r)));
        let shown = floor.map_or(0.0, |f| match rows[0].device.contains("llvmpipe") {
            true => f.frame_cpu_ms,
            false => f.frame_ms,
        });
        let _ = write!(s, "| {scene} | {w}×{h} | {shown:.2} |");
        for a in &algos {
            let best = rows
                .iter()
                .filter(|r| r.algo == *a)
                .filter_map(|r| multiple(r))
                .fold(f64::INFINITY, f64::min);
            match best.is_finite() {
                true => {
                    let _ = write!(s, " {best:.1}× |");
                }
                false => s.push_str(" |"),
            }
        }
        s.push('\n');
    }
    s.push('\n');
    s
}
