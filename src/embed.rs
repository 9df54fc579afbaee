//! The mesh-level embedding API: solids given as plain triangle meshes with
//! transforms and an expression (our string syntax, or a [`csg::Expr`] built in
//! code), drawn into a host engine's frame by [`vk::Embedder`]. No scene file is
//! involved; this module builds the [`Scene`] and the plan a scene file would
//! give, and keeps the plan current as the camera or a transform changes.
//!
//! The algorithms are those of the seed papers (see `plan`); the GPU side is the
//! executor of the performance work (README "Executor", "Embedding").
#![deny(unsafe_code)]
#![warn(missing_docs)]

use std::collections::HashMap;

use glam::{DMat4, DVec3, Mat4};

use crate::csg::Expr;
use crate::plan::{self, Algo, BuildOptions, PlanError, Prepared};
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
    /// Our expression syntax (CONTRACT.md §2) over the names `m0`, `m1`, … (mesh
    /// `i` of the input slice is `m{i}`), e.g. `"(m0 - m1) * m2"`.
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
}

impl Default for EmbedDesc {
    fn default() -> Self {
        EmbedDesc {
            extent: [512, 512],
            reversed_z: false,
            frames_in_flight: 2,
            algo: Algo::Goldfeather,
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
    local: Vec<Mesh>,
}

impl CsgScene {
    /// Uploads `meshes` once, builds the plan of `expr` for `camera`, and learns
    /// its loop counts with one standalone frame on peeltrim's queue (the only
    /// submission the library makes; [`vk::Embedder::record`] makes none).
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
        let prepared = Prepared::new(&scene)?;
        let plan = plan::build_with(desc.algo, &prepared, &BuildOptions::default())?;
        let exec_desc = ExecDesc {
            width: desc.extent[0],
            height: desc.extent[1],
            // Float depth either way: the composite hands it to the host's buffer.
            depth_format: vk::DepthFormat::D32S8,
            reversed_z: desc.reversed_z,
        };
        let mut embedder = Embedder::new(ctx, &exec_desc, desc.frames_in_flight)?;
        embedder.executor().upload(&scene)?;
        embedder.set_plan(plan);
        embedder.prepare()?;
        Ok(CsgScene {
            embedder,
            scene,
            prepared,
            algo: desc.algo,
            local,
        })
    }

    /// The recorder of host frames: `unsafe { csg.recorder().record(cmd, &targets) }`.
    pub fn recorder(&mut self) -> &mut Embedder {
        &mut self.embedder
    }

    /// The camera peeltrim renders with.
    pub fn camera(&self) -> &Camera {
        &self.scene.camera
    }

    /// Moves the camera: no upload, a new plan only if the eye entered or left a
    /// primitive (the GPU recording is then made again for the new view).
    pub fn set_camera(&mut self, camera: &Camera) -> Result<(), EmbedError> {
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
        self.replan()
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

    fn replan(&mut self) -> Result<(), EmbedError> {
        let plan = plan::build_with(self.algo, &self.prepared, &BuildOptions::default())?;
        self.embedder.set_plan(plan);
        Ok(())
    }
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
