//! The mesh-level embedding API: solids given as plain triangle meshes with
//! transforms and an expression (our string syntax, or a [`crate::Expr`] built in
//! code), drawn into a host engine's frame by [`vk::Embedder`]. No scene file is
//! involved; this module builds the [`Scene`] and the plan a scene file would
//! give, and keeps the plan current as the camera or a transform changes.
//!
//! The algorithms are those of the seed papers (see `plan`); the GPU side is the
//! executor of the performance work (docs/executor.md, docs/embedding.md).
#![deny(unsafe_code)]
#![warn(missing_docs)]

mod loops;

use std::collections::HashMap;

use glam::{DMat4, DVec3, Mat4};

use crate::csg::Expr;
use crate::plan::cut_away::CutAway;
use crate::plan::{self, Algo, BuildOptions, Plan, PlanError, Prepared, Step};
use crate::scene::camera::DepthConvention;
use crate::scene::shapes::apply_transform;
use crate::scene::validate::check_closed;
use crate::scene::{Camera, Mesh, Primitive, RenderSettings, Scene, Shape, Solid};
use crate::vk::{self, Context, Embedder, ExecDesc, VkError};

/// One closed, outward-oriented triangle mesh of the host (a CSG primitive).
#[derive(Clone, Copy, Debug)]
pub struct MeshInput<'a> {
    /// Vertex positions in the mesh's own space.
    pub positions: &'a [[f32; 3]],
    /// Triangles, counter-clockwise seen from outside.
    pub indices: &'a [[u32; 3]],
    /// Model-to-world transform.
    pub transform: Mat4,
    /// Surface colour (sRGB bytes).
    pub color: [u8; 3],
}

/// The expression combining the meshes.
#[derive(Clone, Debug)]
pub enum CsgExpr<'a> {
    /// Our expression syntax (docs/scene-format.md) over the names `m0`, `m1`, …
    /// (mesh `i` of the input slice is `m{i}`), e.g. `"(m0 - m1) * m2"`.
    Text(&'a str),
    /// Built in code; leaf `prim` indexes the input slice.
    Built(Expr),
}

/// How the host's frame looks to peeltrim.
#[derive(Clone, Copy, Debug)]
pub struct EmbedDesc {
    /// The host's attachment size; peeltrim's internal images get the same.
    pub extent: [u32; 2],
    /// Whether the host's depth buffer is reversed (near 1, far 0); peeltrim's
    /// depth then uses a 32-bit float format.
    pub reversed_z: bool,
    /// The most recorded frames the host keeps submitted but not waited for.
    pub frames_in_flight: u32,
    /// The algorithm (CST and Goldfeather variants, Blister, Trickle).
    pub algo: Algo,
    /// Where the first loop counts come from (see [`LoopCounts`]).
    pub loop_counts: LoopCounts,
    /// peeltrim's own depth-stencil format (default D32S8; D24S8 where the device
    /// lacks it). Independent of the host's depth format.
    pub internal_depth: vk::DepthFormat,
    /// Samples per pixel of the host's attachments (and of peeltrim's images);
    /// 1, 2, 4 or 8 where the device supports it
    /// ([`Context::supported_samples`]).
    pub samples: u32,
}

/// The first counts the embedded frame's data-dependent loops are unrolled to.
/// Whatever the choice, the GPU's occlusion counts of each recorded frame are
/// checked when its ring slot comes round (`frames_in_flight + 1` frames later,
/// never with a CPU wait) and correct the counts of later frames: too few heads
/// double, too many shrink to one past the last head that found a layer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LoopCounts {
    /// Estimated on the CPU by casting a coarse grid of rays through the meshes
    /// each loop peels (no GPU work, no wait). A pixel deeper than every ray
    /// of the grid can show too few layers until the ring has corrected the count.
    #[default]
    Estimate,
    /// Learnt by one standalone frame on peeltrim's queue, waited for on the CPU
    /// in [`CsgScene::new`] (and after a change of plan, in [`CsgScene::relearn`]):
    /// every frame is right from the first.
    Learn,
    /// Every loop starts at this count (clamped to its bound; 0 counts as 1).
    Fixed(u32),
}

impl Default for EmbedDesc {
    fn default() -> Self {
        EmbedDesc {
            extent: [512, 512],
            reversed_z: false,
            frames_in_flight: 2,
            algo: Algo::Goldfeather,
            loop_counts: LoopCounts::Estimate,
            internal_depth: vk::DepthFormat::D32S8,
            samples: 1,
        }
    }
}

/// Errors of the embedding API; each names the input at fault.
#[derive(Debug, thiserror::Error)]
pub enum EmbedError {
    /// A mesh is malformed (index past its positions, not finite, not closed).
    #[error("mesh {index}: {problem} (embedded meshes must be closed and outward-oriented)")]
    Mesh {
        /// Its index in the input slice.
        index: usize,
        /// What is wrong with it.
        problem: String,
    },
    /// The expression does not parse or names a mesh that was not given.
    #[error("expression: {0} (name meshes m0, m1, … in input order)")]
    Expr(String),
    /// The algorithm has no GPU plan (the CPU reference).
    #[error(
        "algorithm {0} has no GPU plan: choose a GPU algorithm (e.g. goldfeather, blister, cst-z)"
    )]
    Algo(Algo),
    /// The plan could not be built.
    #[error(transparent)]
    Plan(#[from] PlanError),
    /// The device failed.
    #[error(transparent)]
    Vk(#[from] VkError),
}

/// A CSG solid made of host meshes, ready to be recorded into host frames (see
/// the crate docs for a complete host).
pub struct CsgScene {
    // Field order is drop order: GPU objects before anything they refer to.
    embedder: Embedder,
    scene: Scene,
    prepared: Prepared,
    algo: Algo,
    loop_counts: LoopCounts,
    local: Vec<Mesh>,
}

impl CsgScene {
    /// Uploads `meshes` once, builds the plan of `expr` for `camera`, and sets its
    /// first loop counts as `desc.loop_counts` says: by default estimated on the
    /// CPU, with no GPU work and no wait. Only [`LoopCounts::Learn`] submits (one
    /// standalone frame on peeltrim's queue, waited for); [`vk::Embedder::record`]
    /// never does.
    pub fn new(
        ctx: &Context,
        meshes: &[MeshInput<'_>],
        expr: CsgExpr<'_>,
        camera: &Camera,
        desc: &EmbedDesc,
    ) -> Result<CsgScene, EmbedError> {
        if desc.algo == Algo::Reference {
            return Err(EmbedError::Algo(desc.algo));
        }
        let local: Vec<Mesh> = meshes
            .iter()
            .enumerate()
            .map(|(i, m)| local_mesh(i, m))
            .collect::<Result<_, _>>()?;
        let expr = match expr {
            CsgExpr::Text(src) => {
                let names: Vec<String> = (0..meshes.len()).map(|i| format!("m{i}")).collect();
                let map: HashMap<&str, u32> = names
                    .iter()
                    .enumerate()
                    .map(|(i, n)| (n.as_str(), i as u32))
                    .collect();
                crate::scene::load::parse_expr(src, &map).map_err(EmbedError::Expr)?
            }
            CsgExpr::Built(e) => {
                if let Some(bad) = e.leaves().into_iter().find(|&p| p as usize >= meshes.len()) {
                    return Err(EmbedError::Expr(format!(
                        "leaf names mesh {bad}, but {} meshes were given",
                        meshes.len()
                    )));
                }
                e
            }
        };
        let primitives = local
            .iter()
            .zip(meshes)
            .enumerate()
            .map(|(i, (mesh, m))| {
                let transform = m.transform.as_dmat4();
                Primitive {
                    name: format!("m{i}"),
                    shape: Shape::Mesh {
                        path: format!("embedded mesh {i}").into(),
                    },
                    transform,
                    mesh: apply_transform(mesh, &transform),
                    color: m.color,
                    used: true,
                }
            })
            .collect();
        let scene = Scene {
            name: Some("embedded".into()),
            path: "embedded".into(),
            camera: *camera,
            render: RenderSettings {
                width: desc.extent[0],
                height: desc.extent[1],
                background: [0, 0, 0],
                samples: desc.samples,
            },
            primitives,
            solids: vec![Solid {
                name: "csg".into(),
                expr,
            }],
            surfaces: Vec::new(),
            warnings: Vec::new(),
            appearance: Default::default(),
        };
        CsgScene::build(ctx, scene, local, desc)
    }

    /// A scene of peeltrim's own (a loaded scene file: its primitives, solids and
    /// trimmed surfaces, at the camera it has), drawn into host frames of
    /// `desc.extent` (the scene's own size is replaced). [`CsgScene::set_transform`]
    /// moves a primitive from where the scene placed it. The viewer's path.
    pub fn from_scene(
        ctx: &Context,
        scene: &Scene,
        desc: &EmbedDesc,
    ) -> Result<CsgScene, EmbedError> {
        if desc.algo == Algo::Reference {
            return Err(EmbedError::Algo(desc.algo));
        }
        let mut scene = scene.clone();
        scene.render.width = desc.extent[0];
        scene.render.height = desc.extent[1];
        let local = scene.primitives.iter().map(|p| p.mesh.clone()).collect();
        for p in &mut scene.primitives {
            p.transform = DMat4::IDENTITY;
        }
        CsgScene::build(ctx, scene, local, desc)
    }

    fn build(
        ctx: &Context,
        scene: Scene,
        local: Vec<Mesh>,
        desc: &EmbedDesc,
    ) -> Result<CsgScene, EmbedError> {
        let prepared = Prepared::new(&scene)?;
        let plan = plan::build_with(desc.algo, &prepared, &BuildOptions::default())?;
        let exec_desc = ExecDesc {
            width: desc.extent[0],
            height: desc.extent[1],
            depth_format: desc.internal_depth,
            reversed_z: desc.reversed_z,
            samples: desc.samples,
        };
        let mut embedder = Embedder::new(ctx, &exec_desc, desc.frames_in_flight)?;
        embedder.executor().upload(&scene)?;
        embedder.set_plan(plan);
        embedder.set_cut_away(CutAway::of(desc.algo, &prepared, &scene));
        let mut csg = CsgScene {
            embedder,
            scene,
            prepared,
            algo: desc.algo,
            loop_counts: desc.loop_counts,
            local,
        };
        csg.first_counts()?;
        Ok(csg)
    }

    /// Switches the algorithm (a new plan, with counts as `desc.loop_counts` said,
    /// estimated where that was [`LoopCounts::Learn`]). Like a new plan from
    /// [`CsgScene::set_camera`], the host's pending frames of this scene must
    /// complete before the next record.
    pub fn set_algo(&mut self, algo: Algo) -> Result<(), EmbedError> {
        if algo == Algo::Reference {
            return Err(EmbedError::Algo(algo));
        }
        if algo != self.algo {
            let plan = plan::build_with(algo, &self.prepared, &BuildOptions::default())?;
            self.algo = algo;
            self.set_plan(plan);
            self.set_counts(self.loop_counts.no_wait())?;
        }
        Ok(())
    }

    /// The algorithm recorded.
    pub fn algo(&self) -> Algo {
        self.algo
    }

    /// The recorder of host frames: `unsafe { csg.recorder().record(cmd, &targets) }`.
    pub fn recorder(&mut self) -> &mut Embedder {
        &mut self.embedder
    }

    /// The size of the host targets this scene records into.
    pub fn extent(&self) -> [u32; 2] {
        [self.scene.render.width, self.scene.render.height]
    }

    /// The camera peeltrim renders with.
    pub fn camera(&self) -> &Camera {
        &self.scene.camera
    }

    /// Moves the camera: no upload, a new plan only if the eye entered or left a
    /// primitive. Returns whether the plan changed: a new plan may need new
    /// internal images, so the host's pending frames of this scene must then
    /// complete before the next record.
    pub fn set_camera(&mut self, camera: &Camera) -> Result<bool, EmbedError> {
        self.scene.camera = *camera;
        self.embedder.executor().set_camera(camera)?;
        self.prepared.camera_moved(&self.scene);
        self.replan()
    }

    /// Moves mesh `index`: its vertices are rewritten in place in peeltrim's
    /// host-visible vertex buffer (no new buffer, the other meshes untouched).
    /// Like every call but `record` and `set_camera`, only while the host has no
    /// frame of this scene pending.
    pub fn set_transform(&mut self, index: usize, transform: Mat4) -> Result<(), EmbedError> {
        let local = self.local.get(index).ok_or_else(|| EmbedError::Mesh {
            index,
            problem: format!("no such mesh ({} were given)", self.local.len()),
        })?;
        let m = transform.as_dmat4();
        let world = apply_transform(local, &m);
        self.embedder.executor().rewrite_mesh(index, &world)?;
        let p = &mut self.scene.primitives[index];
        p.transform = m;
        p.mesh = world;
        self.prepared = Prepared::new(&self.scene)?;
        self.replan().map(|_| ())
    }

    /// World → Vulkan clip space of peeltrim's camera at the host's aspect and
    /// depth convention: the host draws its own geometry with it, so both depths
    /// compare.
    pub fn view_proj(&self) -> DMat4 {
        let r = &self.scene.render;
        let conv = if self.embedder.desc().reversed_z {
            DepthConvention::Reversed
        } else {
            DepthConvention::Standard
        };
        self.scene
            .camera
            .proj(r.width as f64 / r.height as f64, conv)
            * self.scene.camera.view()
    }

    /// The scene this API built (for the CPU reference of tests).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Learns the current plan's loop counts with one standalone frame on
    /// peeltrim's queue, waited for on the CPU ([`LoopCounts::Learn`]). Only while
    /// the host has no frame of this scene pending.
    pub fn relearn(&mut self) -> Result<(), EmbedError> {
        self.embedder.prepare()?;
        Ok(())
    }

    /// Gives the embedder `plan` and the cutter sets of the current scene,
    /// camera and algorithm (`plan::cut_away`), which change with the camera
    /// even where the plan does not.
    fn set_plan(&mut self, plan: Plan) {
        self.embedder.set_plan(plan);
        self.embedder
            .set_cut_away(CutAway::of(self.algo, &self.prepared, &self.scene));
    }

    /// Builds the plan for the current camera and transforms; whether it changed.
    fn replan(&mut self) -> Result<bool, EmbedError> {
        let plan = plan::build_with(self.algo, &self.prepared, &BuildOptions::default())?;
        let changed = self.embedder.plan() != Some(&plan);
        self.set_plan(plan);
        if !self.embedder.prepared() {
            // A plan with other loops: its counts are not known yet.
            self.set_counts(self.loop_counts.no_wait())?;
        }
        Ok(changed)
    }

    /// The first counts of a new scene.
    fn first_counts(&mut self) -> Result<(), EmbedError> {
        match self.loop_counts {
            LoopCounts::Learn => self.relearn(),
            c => self.set_counts(c),
        }
    }

    fn set_counts(&mut self, counts: LoopCounts) -> Result<(), EmbedError> {
        let Some(plan) = self.embedder.plan() else {
            return Ok(());
        };
        let counts = match counts {
            LoopCounts::Fixed(n) => loops_of(plan).map(|max| n.clamp(1, max.max(1))).collect(),
            _ => loops::estimate(plan, &self.scene, loops::GRID),
        };
        self.embedder.set_loop_counts(counts)?;
        Ok(())
    }
}

impl LoopCounts {
    /// The choice for a plan made while the host may have frames pending.
    fn no_wait(self) -> LoopCounts {
        match self {
            LoopCounts::Learn => LoopCounts::Estimate,
            c => c,
        }
    }
}

/// The bound of each loop of `plan`, in plan order.
fn loops_of(plan: &Plan) -> impl Iterator<Item = u32> + '_ {
    plan.steps.iter().filter_map(|s| match s {
        Step::Loop(l) => Some(l.max_iterations),
        _ => None,
    })
}

/// Mesh `i` in its own space, checked: indices in range, closed and oriented.
fn local_mesh(i: usize, m: &MeshInput<'_>) -> Result<Mesh, EmbedError> {
    let err = |problem: String| EmbedError::Mesh { index: i, problem };
    let n = m.positions.len();
    if let Some(t) = m
        .indices
        .iter()
        .find(|t| t.iter().any(|&v| v as usize >= n))
    {
        return Err(err(format!(
            "triangle {t:?} indexes past its {n} positions"
        )));
    }
    if let Some(p) = m
        .positions
        .iter()
        .find(|p| p.iter().any(|c| !c.is_finite()))
    {
        return Err(err(format!("position {p:?} is not finite")));
    }
    let mesh = Mesh {
        positions: m
            .positions
            .iter()
            .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .collect(),
        triangles: m.indices.to_vec(),
    };
    check_closed(&mesh).map_err(|p| err(p.describe(&mesh)))?;
    Ok(mesh)
}
