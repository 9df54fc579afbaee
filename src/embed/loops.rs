//! First loop counts of an embedded plan, found on the CPU without a GPU frame.
//!
//! The executor unrolls each data-dependent loop (`Step::Loop`: peel a layer,
//! count its samples, stop at the first empty head) to a count, and the embedder
//! checks that count on the GPU's occlusion results a few frames later (the ring
//! of `vk::Embedder`). Its first guess comes from here: a coarse grid of rays
//! through the meshes each loop's head draws, counting the faces a head can peel
//! (front faces where the head culls back faces, back faces where it culls front
//! faces). A loop needs one head per layer plus the empty one, so the guess is
//! the largest count on any ray, plus one. Rays between the grid's can see more
//! layers: the ring then doubles the count (docs/embedding.md, loop counts).

use crate::geom::bvh::{Line, SceneBvh};
use crate::plan::{Cull, Loop, Plan, Step};
use crate::scene::Scene;

/// Rays per side of the estimate's grid (2,304 rays).
pub const GRID: u32 = 48;

/// One count per loop of `plan`, in plan order, each within
/// `1..=max_iterations`.
pub fn estimate(plan: &Plan, scene: &Scene, grid: u32) -> Vec<u32> {
    let loops: Vec<&Loop> = plan.loops().collect();
    if loops.is_empty() {
        return Vec::new();
    }
    let heads: Vec<Vec<(u32, Cull)>> = loops.iter().map(|l| drawn(&l.head)).collect();
    let bvh = SceneBvh::new(
        scene
            .primitives
            .iter()
            .map(|p| &p.mesh)
            .chain(scene.surfaces.iter().map(|s| &s.mesh)),
    );
    let (w, h) = (scene.render.width, scene.render.height);
    let grid = grid.max(1);
    let mut most = vec![0u32; loops.len()];
    let (mut tmp, mut hits) = (Vec::new(), Vec::new());
    for gy in 0..grid {
        for gx in 0..grid {
            let px = (gx as f64 + 0.5) * w as f64 / grid as f64;
            let py = (gy as f64 + 0.5) * h as f64 / grid as f64;
            let line = Line::from_ray(&scene.camera.ray(px, py, w, h));
            hits.clear();
            bvh.cast(&line, |_| true, &mut tmp, &mut hits);
            for (m, head) in most.iter_mut().zip(&heads) {
                let n = hits
                    .iter()
                    .filter(|c| c.crossing.t > 0.0)
                    .filter(|c| {
                        head.iter().any(|&(mesh, cull)| {
                            mesh == c.shape
                                && match cull {
                                    Cull::None => true,
                                    Cull::Back => c.crossing.entering,
                                    Cull::Front => !c.crossing.entering,
                                }
                        })
                    })
                    .count() as u32;
                *m = (*m).max(n);
            }
        }
    }
    loops
        .iter()
        .zip(most)
        .map(|(l, n)| (n + 1).clamp(1, l.max_iterations.max(1)))
        .collect()
}

/// The meshes (and face culling) the mesh draws of `steps` rasterize.
fn drawn(steps: &[Step]) -> Vec<(u32, Cull)> {
    let mut out = Vec::new();
    for s in steps {
        let Step::Draw(d) = s else { continue };
        let meshes = d.geometry.meshes();
        for &m in meshes {
            if !out.contains(&(m, d.cull)) {
                out.push((m, d.cull));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{self, Algo, Prepared};
    use crate::scene::fixtures;
    use glam::DVec3;

    /// A box with two spheres bitten out of it, seen from the front.
    fn scene() -> Scene {
        let prims = vec![
            fixtures::prim(
                "A",
                fixtures::box_mesh(DVec3::splat(-1.0), DVec3::ONE),
                [200; 3],
            ),
            fixtures::prim(
                "B",
                fixtures::sphere_mesh(DVec3::new(0.4, 0.0, 0.5), 0.6, 24, 12),
                [100; 3],
            ),
            fixtures::prim(
                "C",
                fixtures::sphere_mesh(DVec3::new(-0.4, 0.0, -0.5), 0.6, 24, 12),
                [50; 3],
            ),
        ];
        let mut b = fixtures::ExprBuilder::default();
        let (a, s, t) = (b.leaf(0), b.leaf(1), b.leaf(2));
        let d = b.diff(a, s);
        let root = b.diff(d, t);
        let cam = fixtures::camera(DVec3::new(0.3, 0.2, 5.0), DVec3::ZERO, 35.0, 1.0, 20.0);
        let mut sc = fixtures::scene(cam, prims, b.build(root));
        sc.render.width = 64;
        sc.render.height = 64;
        sc
    }

    #[test]
    fn blister_peels_every_face_on_the_deepest_ray_plus_the_empty_head() {
        let sc = scene();
        let plan = plan::build(Algo::Blister, &Prepared::new(&sc).unwrap()).unwrap();
        let n = estimate(&plan, &sc, GRID);
        assert_eq!(n.len(), 1, "{n:?}");
        // Box front and back, each sphere front and back: 6 faces on rays
        // through both spheres' overlap in view, plus the empty head.
        assert_eq!(n[0], 7, "{n:?}");
    }

    #[test]
    fn counts_stay_within_one_and_the_loop_bound() {
        let sc = scene();
        for algo in [Algo::Goldfeather, Algo::GoldfeatherLayered, Algo::CstI] {
            let plan = plan::build(algo, &Prepared::new(&sc).unwrap()).unwrap();
            let n = estimate(&plan, &sc, GRID);
            let maxes: Vec<u32> = plan
                .steps
                .iter()
                .filter_map(|s| match s {
                    Step::Loop(l) => Some(l.max_iterations),
                    _ => None,
                })
                .collect();
            assert_eq!(n.len(), maxes.len(), "{algo}");
            for (c, m) in n.iter().zip(&maxes) {
                assert!(*c >= 1 && c <= m, "{algo}: {n:?} {maxes:?}");
            }
        }
        // A grid of one ray through the middle still gives every loop a count.
        let plan = plan::build(Algo::Blister, &Prepared::new(&sc).unwrap()).unwrap();
        assert!(estimate(&plan, &sc, 1)[0] >= 3);
    }
}
