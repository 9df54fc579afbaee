//! A frame's cost estimated from its pure plan, before anything runs: the plan
//! doubles as the cost model. Its steps are counted as the executor would count
//! them (draws, triangles, scissored pixels of mesh draws and full-screen
//! passes, pixels copied), each data-dependent peel loop taken as many times as
//! the scene has layers of the meshes it peels, and the counts weighed by
//! per-item costs of the device ([`CostModel`]).
//!
//! The bench skips a run whose estimate exceeds `--max-est-s` (on
//! lavapipe, Goldfeather and Kirsch draw ~1.2 M times per frame on block minus
//! 1,024 spheres, so one scaling run took over an hour) and reports it as
//! skipped with the estimate, not as a failure.
//!
//! Loop counts: a loop runs its head once per layer plus once more (the head
//! whose counted draws pass nothing), its tail once per layer. The layers of a
//! loop are the most crossings of the meshes its head counts along rays through
//! a coarse grid of pixel centres (exact crossings, [`peeltrim::geom::bvh`]); a
//! thin feature between grid rays can be missed, so this is an estimate, not a
//! bound, as the whole cost is.
#![deny(unsafe_code)]

use std::fmt;

use serde::Serialize;

use peeltrim::geom::bvh::{Line, SceneBvh, WorldCrossing};
use peeltrim::plan::step::{Geometry, Loop, MeshId, Plan, Step};
use peeltrim::plan::Prepared;
use peeltrim::scene::camera::{DepthConvention, Projection};
use peeltrim::scene::Scene;
use peeltrim::vk::scissor::{bounds_rect, Rect, RectUnions};

/// Seconds per counted item on a device: `seconds = Σ count × cost`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CostModel {
    pub per_draw_s: f64,
    pub per_triangle_s: f64,
    /// Per pixel of a mesh draw's scissor (a bound on its fragments).
    pub per_mesh_pixel_s: f64,
    /// Per pixel of a full-screen pass's scissor, and per pixel copied.
    pub per_sweep_pixel_s: f64,
}

impl CostModel {
    /// Lavapipe with two rasterizer threads (`LP_NUM_THREADS=2`) on this
    /// project's 2-core machine under load (15–19). First guessed at 40 µs
    /// a draw, 0.25 µs a triangle and 2 ns a pixel; the scaling run
    /// (docs/bench.md) then measured 1.7–20× the estimate
    /// (median about 8×: block-spheres 1024 blister 5.4 s against 0.71 s,
    /// deep-tree-311 cst-g 37.5 s against 3.6 s), so every cost is 10× that.
    pub const LAVAPIPE: CostModel = CostModel {
        per_draw_s: 400e-6,
        per_triangle_s: 2.5e-6,
        per_mesh_pixel_s: 20e-9,
        per_sweep_pixel_s: 20e-9,
    };

    pub fn seconds(&self, c: &EstimatedCounts) -> f64 {
        c.draws as f64 * self.per_draw_s
            + c.triangles as f64 * self.per_triangle_s
            + c.mesh_pixels as f64 * self.per_mesh_pixel_s
            + (c.fullscreen_pixels + c.copied_pixels) as f64 * self.per_sweep_pixel_s
    }
}

/// What one frame of a plan is estimated to execute (the executor's
/// `Counts` of the same names, steps with an empty scissor left out as it
/// leaves them out).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct EstimatedCounts {
    pub draws: u64,
    pub mesh_draws: u64,
    pub fullscreen_passes: u64,
    pub triangles: u64,
    pub mesh_pixels: u64,
    pub fullscreen_pixels: u64,
    pub copied_pixels: u64,
}

impl EstimatedCounts {
    fn add_times(&mut self, o: &EstimatedCounts, times: u64) {
        self.draws += o.draws * times;
        self.mesh_draws += o.mesh_draws * times;
        self.fullscreen_passes += o.fullscreen_passes * times;
        self.triangles += o.triangles * times;
        self.mesh_pixels += o.mesh_pixels * times;
        self.fullscreen_pixels += o.fullscreen_pixels * times;
        self.copied_pixels += o.copied_pixels * times;
    }
}

/// A plan's estimated frame: the counts, the most layers any loop peels, and
/// the time the model gives them.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FrameEstimate {
    pub counts: EstimatedCounts,
    /// The most iterations estimated for any loop (0: the plan has none).
    pub max_loop_iterations: u32,
    pub seconds: f64,
}

impl fmt::Display for FrameEstimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let c = &self.counts;
        write!(
            f,
            "estimated {:.1} s per frame (plan: {} draws, {} triangles, {:.1} M mesh pixels, {} full-screen passes over {:.1} M pixels",
            self.seconds,
            c.draws,
            c.triangles,
            c.mesh_pixels as f64 / 1e6,
            c.fullscreen_passes,
            c.fullscreen_pixels as f64 / 1e6
        )?;
        if self.max_loop_iterations > 0 {
            write!(f, ", loops up to {} iterations", self.max_loop_iterations)?;
        }
        write!(f, ")")
    }
}

/// `--max-est-s`'s default: a frame estimated over 20 s on lavapipe (a run of
/// warm-up and timed frames of several minutes) is skipped.
pub const DEFAULT_MAX_EST_S: f64 = 20.0;

/// Rays per image side of the grid that counts layers.
pub const LAYER_GRID: u32 = 48;

/// What estimates need of a scene at one image size: each mesh's screen
/// rectangle and the meshes' crossings along a coarse grid of pixel rays.
pub struct SceneCosts {
    rects: RectUnions,
    width: u32,
    height: u32,
    /// Per grid ray, the mesh of each of its crossings in front of the eye.
    rays: Vec<Vec<MeshId>>,
    meshes: usize,
}

impl SceneCosts {
    pub fn new(scene: &Scene, prep: &Prepared, width: u32, height: u32) -> SceneCosts {
        let cam = &scene.camera;
        let meshes: Vec<&peeltrim::scene::Mesh> = scene
            .primitives
            .iter()
            .map(|p| &p.mesh)
            .chain(scene.surfaces.iter().map(|s| &s.mesh))
            .collect();
        let (view, proj) = (
            cam.view(),
            cam.proj(width as f64 / height as f64, DepthConvention::Standard),
        );
        let rects: Vec<Rect> = prep
            .mesh_bounds
            .iter()
            .map(|b| bounds_rect(view, proj, cam.near, std::slice::from_ref(b), width, height))
            .collect();
        let bvh = SceneBvh::new(meshes.iter().copied());
        let perspective = matches!(cam.projection, Projection::Perspective { .. });
        let (mut tmp, mut hits): (Vec<_>, Vec<WorldCrossing>) = (Vec::new(), Vec::new());
        let mut rays = Vec::new();
        for gy in 0..LAYER_GRID {
            for gx in 0..LAYER_GRID {
                let px = (gx as f64 + 0.5) * width as f64 / LAYER_GRID as f64;
                let py = (gy as f64 + 0.5) * height as f64 / LAYER_GRID as f64;
                let line = Line::from_ray(&cam.ray(px, py, width, height));
                hits.clear();
                bvh.cast(&line, |_| true, &mut tmp, &mut hits);
                // Behind a perspective eye nothing is drawn; an orthographic
                // ray starts on the eye plane.
                rays.push(
                    hits.iter()
                        .filter(|h| !perspective || h.crossing.t > 0.0)
                        .map(|h| h.shape)
                        .collect(),
                );
            }
        }
        SceneCosts {
            rects: RectUnions::new(&rects),
            width,
            height,
            rays,
            meshes: meshes.len(),
        }
    }

    /// The most crossings of `meshes` along one grid ray: the layers a loop
    /// peeling them runs.
    pub fn layers(&self, meshes: &[MeshId]) -> u32 {
        let mut mask = vec![false; self.meshes];
        for &m in meshes {
            if let Some(x) = mask.get_mut(m as usize) {
                *x = true;
            }
        }
        self.rays
            .iter()
            .map(|r| r.iter().filter(|&&m| mask[m as usize]).count() as u32)
            .max()
            .unwrap_or(0)
    }

    /// The estimate of one frame of `plan`.
    pub fn estimate(&self, plan: &Plan, prep: &Prepared, model: &CostModel) -> FrameEstimate {
        let mut max_loop_iterations = 0;
        let counts = self.count(&plan.steps, prep, &mut max_loop_iterations);
        FrameEstimate {
            seconds: model.seconds(&counts),
            counts,
            max_loop_iterations,
        }
    }

    fn count(&self, steps: &[Step], prep: &Prepared, max_iter: &mut u32) -> EstimatedCounts {
        let mut c = EstimatedCounts::default();
        let full = Rect::full(self.width, self.height).area();
        for s in steps {
            match s {
                Step::Draw(d) => {
                    let rect = self.rects.scissor(&d.scissor, self.width, self.height);
                    if rect.is_empty() {
                        continue;
                    }
                    c.draws += 1;
                    let meshes: &[MeshId] = match &d.geometry {
                        Geometry::FullScreen { .. } => {
                            c.fullscreen_passes += 1;
                            c.fullscreen_pixels += rect.area();
                            continue;
                        }
                        g => g.meshes(),
                    };
                    c.mesh_draws += 1;
                    c.triangles += prep.triangles_in(meshes) as u64;
                    c.mesh_pixels += rect.area();
                }
                Step::CopyTexture { .. }
                | Step::CopyDepthBound { .. }
                | Step::CopyDepthToTexture { .. } => {
                    c.copied_pixels += full;
                }
                Step::Loop(l) => {
                    let iterations = self.iterations(l);
                    *max_iter = (*max_iter).max(iterations);
                    let head = self.count(&l.head, prep, max_iter);
                    let tail = self.count(&l.tail, prep, max_iter);
                    c.add_times(&head, iterations as u64);
                    c.add_times(&tail, iterations.saturating_sub(1) as u64);
                }
                Step::Pass(_) | Step::Clear(_) => {}
            }
        }
        c
    }

    /// Head runs of a loop: one per layer of the meshes its head counts, and
    /// the one that finds none left; at most the loop's own bound.
    fn iterations(&self, l: &Loop) -> u32 {
        let mut counted: Vec<MeshId> = Vec::new();
        for s in &l.head {
            if let Step::Draw(d) = s {
                match (&d.geometry, d.count_samples) {
                    (Geometry::Mesh(m), true) => counted.push(*m),
                    (Geometry::Meshes(ms), true) => counted.extend(ms),
                    _ => {}
                }
            }
        }
        // A loop counting full-screen samples peels whatever its meshes are.
        if counted.is_empty() {
            counted = (0..self.meshes as MeshId).collect();
        }
        (self.layers(&counted) + 1).min(l.max_iterations.max(1))
    }
}

/// The skip rule: a run is skipped when its estimate exceeds a positive
/// budget (`--max-est-s`; 0 or less runs everything).
pub fn over_budget(estimate: &FrameEstimate, max_est_s: f64) -> bool {
    max_est_s > 0.0 && estimate.seconds > max_est_s
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use peeltrim::plan::step::{CompareOp, Cull, DepthState, Draw, Fragment, Scissor};
    use peeltrim::plan::{self, Algo};
    use peeltrim::scene::fixtures::{box_mesh, camera, prim, scene, union_all};

    const W: u32 = 64;

    /// Three unit-thick boxes one behind the other on the view axis, and a
    /// fourth far off screen; their union.
    fn row_of_boxes() -> (Scene, Prepared) {
        let b = |x: f64, z: f64| {
            box_mesh(
                DVec3::new(x - 1.0, -1.0, z),
                DVec3::new(x + 1.0, 1.0, z + 1.0),
            )
        };
        let prims = vec![
            prim("A", b(0.0, -3.0), [200, 0, 0]),
            prim("B", b(0.0, 0.0), [0, 200, 0]),
            prim("C", b(0.0, 3.0), [0, 0, 200]),
            prim("Far", b(1000.0, 0.0), [200, 200, 0]),
        ];
        let cam = camera(DVec3::new(0.0, 0.0, 10.0), DVec3::ZERO, 40.0, 0.1, 100.0);
        let s = scene(cam, prims, union_all(4));
        let p = Prepared::new(&s).expect("a solid");
        (s, p)
    }

    fn plan_of(steps: Vec<Step>) -> Plan {
        Plan {
            algo: "test".into(),
            depth_stencils: 1,
            textures: 2,
            stencil_bits: 1,
            output_ds: 0,
            steps,
        }
    }

    fn draw(geometry: Geometry, scissor: Scissor, count: bool) -> Step {
        Step::Draw(Draw {
            geometry,
            scissor,
            cull: Cull::None,
            ds: 0,
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: None,
            fragment: Fragment::None,
            count_samples: count,
        })
    }

    #[test]
    fn layers_are_the_most_crossings_of_the_meshes_along_a_grid_ray() {
        let (s, p) = row_of_boxes();
        let c = SceneCosts::new(&s, &p, W, W);
        assert_eq!(c.layers(&[0, 1, 2]), 6);
        assert_eq!(c.layers(&[1]), 2);
        assert_eq!(c.layers(&[0, 2]), 4);
        assert_eq!(c.layers(&[3]), 0, "off screen");
    }

    #[test]
    fn loops_count_one_head_per_layer_and_one_more_and_off_screen_steps_nothing() {
        let (s, p) = row_of_boxes();
        let c = SceneCosts::new(&s, &p, W, W);
        let peel = |max_iterations| {
            plan_of(vec![
                draw(Geometry::FullScreen { depth: 1.0 }, Scissor::Full, false),
                // Off screen: the executor skips it, so does the estimate.
                draw(Geometry::Mesh(3), Scissor::BoundsOf(vec![3]), false),
                Step::Loop(Loop {
                    head: vec![draw(Geometry::Meshes(vec![0, 1, 2]), Scissor::Full, true)],
                    tail: vec![
                        draw(
                            Geometry::FullScreen { depth: 1.0 },
                            Scissor::BoundsOf(vec![0, 1, 2]),
                            false,
                        ),
                        Step::CopyTexture { src: 0, dst: 1 },
                    ],
                    max_iterations,
                }),
            ])
        };
        let model = CostModel {
            per_draw_s: 1.0,
            per_triangle_s: 0.0,
            per_mesh_pixel_s: 0.0,
            per_sweep_pixel_s: 0.0,
        };
        let e = c.estimate(&peel(100), &p, &model);
        // 6 layers: 7 heads, 6 tails.
        assert_eq!(e.max_loop_iterations, 7);
        let full = (W * W) as u64;
        let rect = c.rects.of(&[0, 1, 2]).area();
        assert!(rect > 0 && rect < full, "{rect}");
        assert_eq!(
            e.counts,
            EstimatedCounts {
                draws: 1 + 7 + 6,
                mesh_draws: 7,
                fullscreen_passes: 1 + 6,
                triangles: 7 * 36,
                mesh_pixels: 7 * full,
                fullscreen_pixels: full + 6 * rect,
                copied_pixels: 6 * full,
            }
        );
        assert_eq!(e.seconds, 14.0, "draws × 1 s");
        // The loop's own bound caps the estimate.
        let capped = c.estimate(&peel(3), &p, &model);
        assert_eq!(capped.max_loop_iterations, 3);
        assert_eq!(capped.counts.draws, 1 + 3 + 2);
    }

    #[test]
    fn runs_over_a_positive_budget_are_skipped_and_zero_runs_everything() {
        let e = FrameEstimate {
            counts: EstimatedCounts::default(),
            max_loop_iterations: 0,
            seconds: 12.5,
        };
        assert!(over_budget(&e, 10.0));
        assert!(!over_budget(&e, 12.5), "at the budget it runs");
        assert!(!over_budget(&e, 20.0));
        assert!(!over_budget(&e, 0.0), "0 disables the check");
        let text = e.to_string();
        assert!(
            text.starts_with("estimated 12.5 s per frame (plan: 0 draws"),
            "{text}"
        );
    }

    /// Block minus n spheres (the bench's family), loaded as a user would.
    fn block_spheres(n: u32) -> (Scene, Prepared) {
        let dir = std::env::temp_dir().join(format!("peeltrim-estimate-{}", std::process::id()));
        let scenes = crate::bench::families::generate("block-spheres", &[n], &dir).unwrap();
        let opts = peeltrim::scene::LoadOptions {
            size: Some((200, 200)),
        };
        let s = peeltrim::scene::load(&scenes[0].path, &opts).unwrap();
        let p = Prepared::new(&s).unwrap();
        (s, p)
    }

    #[test]
    fn steps_off_their_scissor_are_not_charged_and_blisters_peel_grows_linearly() {
        let est = |n: u32, algo: Algo| {
            let (s, p) = block_spheres(n);
            let plan = plan::build(algo, &p).unwrap();
            let static_draws = peeltrim::plan::print::count(&plan.steps, &p).draws;
            let e = SceneCosts::new(&s, &p, 200, 200).estimate(&plan, &p, &CostModel::LAVAPIPE);
            (e, static_draws)
        };
        // Goldfeather clips each sphere's surface against every other sphere,
        // but disjoint spheres' rectangles do not meet: those draws are skipped.
        let (g, g_static) = est(64, Algo::Goldfeather);
        assert_eq!(g.max_loop_iterations, 0);
        assert!(
            g.counts.draws * 3 < g_static,
            "{g} of {g_static} static draws"
        );
        // Blister: one peel of the block and a sphere per layer (4 crossings), n
        // draws each.
        let ((b16, _), (b64, _)) = (est(16, Algo::Blister), est(64, Algo::Blister));
        assert!((5..=7).contains(&b64.max_loop_iterations), "{b64}");
        let br = b64.counts.draws as f64 / b16.counts.draws as f64;
        assert!(
            br > 2.5 && br < 5.0,
            "n 4× gives draws {br:.1}×: {b16} / {b64}"
        );
    }
}
