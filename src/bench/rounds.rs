//! Fair timing within a scene (issue 9, "Measure and report"): the timed frames
//! of a scene's algorithms run round-robin (frame 1 of every algorithm, then
//! frame 2, …) after every algorithm's warm-up, so a machine that speeds up or
//! slows down during the run (other processes, clocks) moves every algorithm's
//! median alike instead of turning drift into ratios. Each algorithm keeps its
//! own renderer across the rounds, so each replays its own recording; when those
//! renderers would not fit the memory budget together the runs go one after
//! another, and the records say so ([`Timing`]).
#![deny(unsafe_code)]

use serde::Serialize;

use crate::render::FrameMemory;
use crate::scene::Scene;

/// How a run's timed frames were ordered against its scene's other runs.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Timing {
    /// Timed alone: the scene's only run, or a record of no run.
    Alone,
    /// Round-robin with the scene's other runs (`runs` in all, this one included).
    Interleaved { runs: u32 },
    /// One run after another: their renderers would not fit the memory budget
    /// together.
    Sequential { why: String },
}

/// The order of the timed frames: per frame, the index of its run, given each
/// run's number of timed frames; round-robin, a run leaving the rounds once its
/// frames are done.
pub fn schedule(frames: &[u32]) -> Vec<usize> {
    let rounds = frames.iter().copied().max().unwrap_or(0);
    (0..rounds)
        .flat_map(|round| {
            frames
                .iter()
                .enumerate()
                .filter(move |&(_, &n)| round < n)
                .map(|(i, _)| i)
        })
        .collect()
}

/// Bytes one GPU renderer of `scene` at `w`×`h` holds: the frame's images (on
/// lavapipe device memory is host memory) and the uploaded meshes.
pub fn renderer_bytes(scene: &Scene, w: u32, h: u32) -> u64 {
    let frame = FrameMemory {
        gpu: true,
        ..Default::default()
    }
    .host_bytes(w, h);
    // Positions and normals (f32 × 3 each) and u32 indices, per primitive.
    let meshes: u64 = scene
        .primitives
        .iter()
        .map(|p| p.mesh.positions.len() as u64 * 24 + p.mesh.triangles.len() as u64 * 12)
        .sum();
    frame.saturating_add(meshes)
}

/// How `runs` renderers of `each` bytes are timed under a memory budget of
/// `budget` bytes: interleaved when they fit in half of it at once (the rest
/// is the reference, the images read back and the plans).
pub fn timing(runs: usize, each: u64, budget: u64) -> Timing {
    let all = each.saturating_mul(runs as u64);
    if runs <= 1 {
        Timing::Alone
    } else if all <= budget / 2 {
        Timing::Interleaved { runs: runs as u32 }
    } else {
        Timing::Sequential {
            why: format!(
                "{runs} renderers of {} MiB each are over half the memory budget ({} MiB)",
                each >> 20,
                budget >> 20
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_go_round_robin_and_short_runs_leave_the_rounds() {
        assert_eq!(schedule(&[3, 1, 2]), [0, 1, 2, 0, 2, 0]);
        assert_eq!(schedule(&[2, 2]), [0, 1, 0, 1]);
        assert_eq!(schedule(&[0, 2]), [1, 1]);
        assert!(schedule(&[]).is_empty());
        // Every run gets exactly its frames.
        let f = [5, 1, 0, 4];
        let s = schedule(&f);
        for (i, &n) in f.iter().enumerate() {
            assert_eq!(s.iter().filter(|&&j| j == i).count(), n as usize);
        }
    }

    #[test]
    fn runs_interleave_only_within_half_the_budget() {
        assert_eq!(timing(4, 100, 800), Timing::Interleaved { runs: 4 });
        assert_eq!(timing(1, 100, 10), Timing::Alone);
        assert!(matches!(timing(5, 100, 800), Timing::Sequential { .. }));
    }

    #[test]
    fn a_renderer_holds_its_frame_and_meshes() {
        let scene = crate::scene::load_str(
            "[camera]\neye=[0,0,5]\n[[primitive]]\nname='A'\nshape='box'\nsize=[1,1,1]\n[csg]\nexpr='A'\n",
            std::path::Path::new("t.toml"),
            &Default::default(),
        )
        .unwrap();
        let frame = crate::render::GPU_HOST_BYTES_PER_PIXEL * 800 * 800;
        let b = renderer_bytes(&scene, 800, 800);
        assert!(b > frame && b < frame + (1 << 20), "{b}");
    }
}
