//! Fair timing within a scene: the timed frames
//! of a scene's algorithms run round-robin (frame 1 of every algorithm, then
//! frame 2, …) after every algorithm's warm-up, so a machine that speeds up or
//! slows down during the run (other processes, clocks) moves every algorithm's
//! median alike instead of turning drift into ratios. Each algorithm keeps its
//! own renderer across the rounds, so each replays its own recording; when those
//! renderers would not fit the memory budget together the runs go one after
//! another, and the records say so ([`Timing`]).
//!
//! Each timed frame follows an untimed frame of the same run: back-to-back
//! frames find their images in the CPU's caches on lavapipe, and a frame after
//! another algorithm's does not (shadow_block, whose frames touch a few MB:
//! kirsch +30% process CPU per frame), so without it interleaving would charge the
//! algorithms a cold cache that OpenCSG's back-to-back frames never pay.
#![deny(unsafe_code)]

use serde::Serialize;

use crate::render::FrameMemory;
use peeltrim::scene::Scene;

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

/// Untimed frames of a run just before each of its timed frames.
pub const WARM_FRAMES: u32 = 1;

/// One frame of the rounds: its run, and whether it is timed (else one of the
/// [`WARM_FRAMES`] before a timed one).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slot {
    pub run: usize,
    pub timed: bool,
}

/// The order of the frames, given each run's number of timed frames:
/// round-robin, each timed frame after `warm` untimed ones of its run, a run
/// leaving the rounds once its frames are done.
pub fn schedule(frames: &[u32], warm: u32) -> Vec<Slot> {
    let rounds = frames.iter().copied().max().unwrap_or(0);
    (0..rounds)
        .flat_map(|round| {
            frames
                .iter()
                .enumerate()
                .filter(move |&(_, &n)| round < n)
                .flat_map(move |(run, _)| {
                    (0..=warm).map(move |k| Slot {
                        run,
                        timed: k == warm,
                    })
                })
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

    fn timed(s: &[Slot]) -> Vec<usize> {
        s.iter().filter(|s| s.timed).map(|s| s.run).collect()
    }

    #[test]
    fn frames_go_round_robin_and_short_runs_leave_the_rounds() {
        assert_eq!(timed(&schedule(&[3, 1, 2], 0)), [0, 1, 2, 0, 2, 0]);
        assert_eq!(timed(&schedule(&[2, 2], 1)), [0, 1, 0, 1]);
        assert_eq!(timed(&schedule(&[0, 2], 1)), [1, 1]);
        assert!(schedule(&[], 1).is_empty());
        // Every run gets exactly its frames, each timed one right after `warm`
        // untimed ones of the same run.
        let f = [5, 1, 0, 4];
        for warm in [0, 1, 2] {
            let s = schedule(&f, warm);
            assert_eq!(s.len() as u32, f.iter().sum::<u32>() * (warm + 1));
            for (i, &n) in f.iter().enumerate() {
                assert_eq!(timed(&s).iter().filter(|&&j| j == i).count(), n as usize);
            }
            for (k, slot) in s.iter().enumerate().filter(|(_, s)| s.timed) {
                let before = &s[k - warm as usize..k];
                assert!(before.iter().all(|b| b.run == slot.run && !b.timed));
            }
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
        let scene = peeltrim::scene::load_str(
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
