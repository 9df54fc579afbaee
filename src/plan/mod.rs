//! Algorithms as data: every CSG technique of the papers is a list of [`Step`]s —
//! rasterize some mesh with a particular depth test, culling and stencil rule, or
//! sweep the screen to rewrite stencil values — built by one module per algorithm
//! and executed by [`crate::vk`]. Nothing here touches `ash`.
//!
//! A plan is also a cost model: it can be printed ([`print`](mod@print)) and its executed
//! counts (rasterized triangles, full-screen passes, swept pixels) are
//! deterministic, unlike timings on a shared machine.
#![deny(unsafe_code)]

pub(crate) mod blister;
pub(crate) mod budget;
mod common;
mod convex;
pub mod cst;
pub mod cut_away;
pub(crate) mod direct_shade;
pub(crate) mod eye;
pub mod floor;
pub mod formats;
pub mod goldfeather;
pub(crate) mod kirsch;
pub(crate) mod lower;
pub(crate) mod memo;
pub mod passes;
pub mod print;
pub(crate) mod reach;
pub(crate) mod rect;
pub mod scissor;
pub mod screen;
pub(crate) mod scs;
pub(crate) mod stencil;
pub mod step;
#[cfg(test)]
pub(crate) mod testing;
pub(crate) mod tie;
pub(crate) mod tie_context;
pub mod tie_free;
pub(crate) mod tie_zones;
pub(crate) mod trickle;
pub(crate) mod usage;
pub(crate) mod validate;
mod view_convex;
pub(crate) mod visible_side;
pub(crate) mod visible_ties;
pub use convex::is_convex;
pub use step::*;
pub use tie::{shade_near_depth, SHADE_EPS};
pub use view_convex::view_convex;
pub use visible_side::VisibleSides;

use crate::csg::{Expr, Node, PositiveExpr};
use crate::scene::{Aabb, Keep, Scene};

/// The algorithms of the command line (`--algo`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Algo {
    /// The exact CPU ray caster (no GPU plan).
    Reference,
    /// Goldfeather's sum of products.
    Goldfeather,
    /// Goldfeather with layered O(kn) peeling.
    GoldfeatherLayered,
    /// Trickle's depth-interval buffer.
    Trickle,
    /// Blister (Blist-based layer peeling).
    Blister,
    /// Constructive Solid Trimming, variant Z.
    CstZ,
    /// Constructive Solid Trimming, variant I.
    CstI,
    /// Constructive Solid Trimming, variant G.
    CstG,
    /// Blister with the paper's depth-test parity (an extra
    /// algorithm, for measuring speckles against the tolerant `blister`).
    BlisterPaper,
    /// Kirsch, Nienhaus & Döllner's CSG depth peeling of products
    /// (§4); its opaque render is the first layer.
    Kirsch,
    /// Sequenced convex subtraction (Stewart, Leach & John; OpenCSG's SCS) for
    /// products of convex primitives, tie-correct; other products as Goldfeather.
    Scs,
}

impl Algo {
    /// Every algorithm, in the command line's order.
    pub const ALL: [Algo; 11] = [
        Algo::Reference,
        Algo::Goldfeather,
        Algo::GoldfeatherLayered,
        Algo::Trickle,
        Algo::Blister,
        Algo::CstZ,
        Algo::CstI,
        Algo::CstG,
        Algo::BlisterPaper,
        Algo::Kirsch,
        Algo::Scs,
    ];
    /// The name on the command line (`--algo`).
    pub fn name(self) -> &'static str {
        match self {
            Algo::Reference => "reference",
            Algo::Goldfeather => "goldfeather",
            Algo::GoldfeatherLayered => "goldfeather-layered",
            Algo::Trickle => "trickle",
            Algo::Blister => "blister",
            Algo::CstZ => "cst-z",
            Algo::CstI => "cst-i",
            Algo::CstG => "cst-g",
            Algo::BlisterPaper => "blister-paper",
            Algo::Kirsch => "kirsch",
            Algo::Scs => "scs",
        }
    }
    /// The algorithm named `s` on the command line, if any.
    pub fn parse(s: &str) -> Option<Algo> {
        Algo::ALL.into_iter().find(|a| a.name() == s)
    }
}

impl std::fmt::Display for Algo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Why no plan can be built for a scene.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    #[error("the scene has no solid to draw: add a [csg] expr or a [[solid]]")]
    /// The scene has no solid (and the algorithm draws no surface).
    NoSolid,
    #[error(
        "surfaces are drawn by cst-z, cst-i and cst-g; {0} draws solids only and this \
         scene has none (use --algo cst-i, or --algo reference)"
    )]
    /// The scene has surfaces only, and the algorithm is not a CST variant.
    SurfacesNeedCst(Algo),
    #[error(
        "the Blist needs {labels} labels, more than 7 stencil bits hold with the parity bit; \
         rebalance the expression (or use --algo cst-i, which classifies smaller active zones)"
    )]
    /// The Blist needs more labels than the stencil bits beside the parity bit hold.
    TooManyLabels {
        /// The labels the Blist needs.
        labels: u32,
    },
    #[error(
        "{algo} needs {} stencil bits ({label_bits} for Blist labels, {counter_bits} for a group counter), \
         more than the 8 a depth-stencil format has; use --algo cst-i",
        *label_bits as u32 + *counter_bits as u32
    )]
    /// Blist labels and a group counter need more than the 8 stencil bits.
    StencilBits {
        /// The algorithm.
        algo: &'static str,
        /// The bits for Blist labels.
        label_bits: u8,
        /// The bits for the group counter (CST-G's optimization 3).
        counter_bits: u8,
    },
    #[error("algorithm '{0}' is not implemented yet")]
    /// The algorithm has no plan builder.
    NotImplemented(Algo),
    #[error("{0}")]
    /// The sum of products is too large to draw (Goldfeather, Trickle, Kirsch, SCS).
    Products(String),
    /// The plan's estimated memory exceeds the budget ([`crate::budget`]).
    #[error("{0}")]
    OverBudget(crate::budget::OverBudget),
    /// The plan's estimated work exceeds what any device renders in reasonable time.
    #[error("{what}, over the limit of {limit} (a frame would take minutes); {fix}")]
    TooMuchWork {
        /// The work counted (products, passes, ...) and how much of it.
        what: String,
        /// The limit it exceeds.
        limit: u64,
        /// What the user can change instead.
        fix: String,
    },
}

/// A `[[surface]]` as the CST plans need it.
#[derive(Clone, Debug)]
pub struct PreparedSurface {
    /// Mesh id: number of primitives + surface index.
    pub mesh: MeshId,
    /// The trimming volume V in positive form.
    pub trim: PositiveExpr,
    /// Its complement !V in positive form (possibly unbounded: fine for trimming).
    pub trim_out: PositiveExpr,
    /// What CST keeps of the surface.
    pub keep: Keep,
    /// The colour of the part inside V, for [`Keep::Paint`].
    pub paint_color: [u8; 3],
}

/// What every plan builder needs of a scene, computed once.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// The union of all solids' expressions; `None` for a scene of surfaces only.
    pub expr: Option<Expr>,
    /// The positive form of `expr`; the universe (and no literal) without a solid:
    /// check [`Prepared::has_solid`].
    pub positive: PositiveExpr,
    /// Primitives named by a solid, in file order.
    pub solid_meshes: Vec<MeshId>,
    /// Triangle count per mesh (primitives, then surfaces).
    pub mesh_triangles: Vec<usize>,
    /// World bounds per mesh.
    pub mesh_bounds: Vec<Aabb>,
    /// Per mesh: known to bound a convex set (every vertex on or behind every face
    /// plane, see [`is_convex`]); `false` when unknown. CST stops peeling such a
    /// leaf after one layer (one face orientation) or two (both).
    pub mesh_convex: Vec<bool>,
    /// Per mesh: not known convex, but proved one front and one back face per
    /// pixel from this camera (`view_convex`); re-derived when the camera
    /// moves. Read both through [`Prepared::convex`].
    pub view_convex: Vec<bool>,
    /// Per mesh: the eye (perspective) lies inside this closed mesh. Parity counted
    /// from the near plane is then inverted for it, so the Blister and CST
    /// classifications flip its literals ([`Prepared::classified`]).
    pub eye_inside: Vec<bool>,
    /// Per mesh: an orthographic near plane cuts this primitive, so parity counted
    /// from it is inverted at some pixels only; plans get the per-pixel
    /// correction of `plan::eye`.
    pub near_cut: Vec<bool>,
    /// The scene's surfaces, in file order (drawn by the CST plans only).
    pub surfaces: Vec<PreparedSurface>,
    /// Per primitive: what SCS orders its cutters by (`plan::scs::Hull`); none
    /// from [`Prepared::from_parts`].
    pub hulls: std::sync::Arc<Vec<scs::Hull>>,
    /// Where the camera's rays come from; `None` from [`Prepared::from_parts`].
    pub viewpoint: Option<scs::Viewpoint>,
    /// Per primitive: where it projects at the scene's image size
    /// ([`screen`]); empty from [`Prepared::from_parts`].
    pub screen: Vec<Option<screen::ScreenBox>>,
}

impl Prepared {
    /// Errors with [`PlanError::NoSolid`] only when the scene has neither a solid
    /// nor a surface.
    pub fn new(scene: &Scene) -> Result<Self, PlanError> {
        let expr = union_of_solids(scene);
        if expr.is_none() && scene.surfaces.is_empty() {
            return Err(PlanError::NoSolid);
        }
        let meshes = scene
            .primitives
            .iter()
            .map(|p| &p.mesh)
            .chain(scene.surfaces.iter().map(|s| &s.mesh));
        let (mut mesh_triangles, mut mesh_bounds) = (Vec::new(), Vec::new());
        let mut mesh_convex = Vec::new();
        for m in meshes {
            mesh_triangles.push(m.triangles.len());
            mesh_bounds.push(bounds(&m.positions));
            mesh_convex.push(is_convex(m));
        }
        let mut p = match expr {
            Some(expr) => Self::from_parts(expr, mesh_triangles, mesh_bounds),
            None => Self::bare(
                None,
                PositiveExpr::universe(),
                Vec::new(),
                mesh_triangles,
                mesh_bounds,
            ),
        };
        p.mesh_convex = mesh_convex;
        p.view_convex = view_convex_meshes(scene, &p.mesh_convex);
        p.eye_inside = eye_inside(scene);
        p.near_cut = eye::near_cut(scene);
        p.hulls = std::sync::Arc::new(scs::hull::of_scene(scene));
        p.viewpoint = Some(scs::Viewpoint::of(&scene.camera));
        p.screen = screen::of_scene(scene);
        let first = scene.primitives.len() as MeshId;
        p.surfaces = scene
            .surfaces
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let mut out = s.trim.clone();
                out.nodes.push(Node::Not(out.root));
                out.root = out.nodes.len() as u32 - 1;
                PreparedSurface {
                    mesh: first + i as MeshId,
                    trim: PositiveExpr::from_expr(&s.trim),
                    trim_out: PositiveExpr::from_expr(&out),
                    keep: s.keep,
                    paint_color: s.paint_color,
                }
            })
            .collect();
        Ok(p)
    }

    /// Re-derives what depends on the camera alone (which primitives contain the
    /// eye, which meshes are convex in this view) after `scene`'s camera moved;
    /// the meshes are unchanged.
    pub fn camera_moved(&mut self, scene: &Scene) {
        self.eye_inside = eye_inside(scene);
        self.viewpoint = Some(scs::Viewpoint::of(&scene.camera));
        self.screen = screen::of_scene(scene);
        self.view_convex = view_convex_meshes(scene, &self.mesh_convex);
    }

    /// Whether mesh `m` has at most one front and one back face along every
    /// pixel's ray of this view, the near plane cutting neither: convex
    /// ([`is_convex`]), or proved so for this camera ([`view_convex`]).
    pub fn convex(&self, m: MeshId) -> bool {
        let flag = |v: &[bool]| v.get(m as usize).copied().unwrap_or(false);
        flag(&self.mesh_convex) || flag(&self.view_convex)
    }

    /// `expr` as the parity passes must classify it: literals of primitives that
    /// contain the eye flipped, since their parity counted from the near plane is
    /// the complement of membership.
    pub fn classified(&self, expr: &PositiveExpr) -> PositiveExpr {
        expr.flip_literals(|prim| self.eye_inside.get(prim as usize).copied().unwrap_or(false))
    }

    /// Whether the scene has a solid (else only surfaces).
    pub fn has_solid(&self) -> bool {
        self.expr.is_some()
    }

    /// What `algo` leaves out of this scene, for the command line to print.
    pub fn warnings(&self, algo: Algo) -> Vec<String> {
        let mut w = Vec::new();
        // Without a solid, `build` refuses with `PlanError::SurfacesNeedCst` instead.
        if self.has_solid()
            && !self.surfaces.is_empty()
            && !matches!(algo, Algo::CstZ | Algo::CstI | Algo::CstG)
        {
            if algo == Algo::Reference {
                return w;
            }
            w.push(format!(
                "surfaces are drawn by cst-z, cst-i and cst-g; {algo} draws the solids only \
                 ({} surface(s) left out)",
                self.surfaces.len()
            ));
        }
        if algo == Algo::Scs && self.has_solid() {
            w.extend(scs::fallback_warning(self));
        }
        w
    }

    /// From an expression and per-mesh triangle counts and bounds (tests and
    /// cost models that need no geometry).
    pub fn from_parts(expr: Expr, mesh_triangles: Vec<usize>, mesh_bounds: Vec<Aabb>) -> Self {
        let positive = PositiveExpr::from_expr(&expr);
        let mut solid_meshes: Vec<MeshId> = expr.leaves();
        solid_meshes.sort_unstable();
        solid_meshes.dedup();
        Self::bare(
            Some(expr),
            positive,
            solid_meshes,
            mesh_triangles,
            mesh_bounds,
        )
    }

    /// The solid's parts and per-mesh triangle counts and bounds, nothing
    /// else known: no mesh convex, no view, no surface.
    fn bare(
        expr: Option<Expr>,
        positive: PositiveExpr,
        solid_meshes: Vec<MeshId>,
        mesh_triangles: Vec<usize>,
        mesh_bounds: Vec<Aabb>,
    ) -> Self {
        Prepared {
            expr,
            positive,
            solid_meshes,
            mesh_convex: vec![false; mesh_triangles.len()],
            mesh_triangles,
            mesh_bounds,
            view_convex: Vec::new(),
            eye_inside: Vec::new(),
            near_cut: Vec::new(),
            surfaces: Vec::new(),
            hulls: Default::default(),
            viewpoint: None,
            screen: Vec::new(),
        }
    }

    /// The triangles of `meshes`, summed.
    pub fn triangles_in(&self, meshes: &[MeshId]) -> usize {
        meshes
            .iter()
            .map(|&m| self.mesh_triangles[m as usize])
            .sum()
    }
}

use crate::geom::bounds;

/// One expression for the whole scene: the union of its solids (an assembly is
/// drawn as the union of its parts; each keeps its primitives' colours).
pub fn union_of_solids(scene: &Scene) -> Option<Expr> {
    let mut nodes: Vec<Node> = Vec::new();
    let mut root: Option<u32> = None;
    for solid in &scene.solids {
        let off = nodes.len() as u32;
        nodes.extend(solid.expr.nodes.iter().map(|n| match *n {
            Node::Leaf { prim } => Node::Leaf { prim },
            Node::Not(a) => Node::Not(a + off),
            Node::Union(a, b) => Node::Union(a + off, b + off),
            Node::Inter(a, b) => Node::Inter(a + off, b + off),
            Node::Diff(a, b) => Node::Diff(a + off, b + off),
        }));
        let r = solid.expr.root + off;
        root = Some(match root {
            None => r,
            Some(prev) => {
                nodes.push(Node::Union(prev, r));
                nodes.len() as u32 - 1
            }
        });
    }
    root.map(|root| Expr { nodes, root })
}

/// Options of the algorithms that have them (the command line's `--trickle-eps`
/// and `--max-products`).
#[derive(Clone, Debug, Default)]
pub struct BuildOptions {
    /// Goldfeather*'s and Trickle's product limit and parity tolerance.
    pub products: goldfeather::ProductOptions,
    /// Trickle's depth tolerance (normalized depth); `None`: `trickle::DEFAULT_EPS`.
    pub trickle_eps: Option<f32>,
}

/// Builds the plan of a GPU algorithm with default options.
pub fn build(algo: Algo, prep: &Prepared) -> Result<Plan, PlanError> {
    build_with(algo, prep, &BuildOptions::default())
}

/// Builds the plan of a GPU algorithm.
pub fn build_with(algo: Algo, prep: &Prepared, opts: &BuildOptions) -> Result<Plan, PlanError> {
    let cst = matches!(algo, Algo::CstZ | Algo::CstI | Algo::CstG);
    if !cst && !prep.has_solid() {
        return Err(if prep.surfaces.is_empty() || algo == Algo::Reference {
            PlanError::NoSolid
        } else {
            PlanError::SurfacesNeedCst(algo)
        });
    }
    let plan = match algo {
        Algo::Blister => blister::plan(prep),
        Algo::BlisterPaper => blister::plan_with(prep, blister::Parity::DepthTest),
        Algo::Goldfeather => goldfeather::plan(prep, &opts.products),
        Algo::GoldfeatherLayered => goldfeather::layered::plan(prep, &opts.products),
        Algo::Kirsch => kirsch::plan(prep, &opts.products),
        Algo::Scs => scs::plan(prep, &opts.products),
        Algo::Trickle => trickle::plan(
            prep,
            &trickle::TrickleOptions {
                products: opts.products,
                eps: opts.trickle_eps,
            },
        ),
        Algo::CstZ => cst::plan(prep, cst::Variant::Z),
        Algo::CstI => cst::plan(prep, cst::Variant::I),
        Algo::CstG => cst::plan(prep, cst::Variant::G),
        other => Err(PlanError::NotImplemented(other)),
    }?;
    // Trickle classifies by the faces behind its candidate: no correction needed.
    Ok(if algo == Algo::Trickle {
        checked(plan, prep)
    } else {
        corrected(plan, prep)
    })
}

/// Layer `layer` (1-based) of Kirsch's depth peeling (`plan::kirsch::plan_layer`),
/// with the eye correction and the checks of [`build_with`].
pub fn build_kirsch_layer(
    prep: &Prepared,
    opts: &BuildOptions,
    layer: u32,
) -> Result<Plan, PlanError> {
    if !prep.has_solid() {
        return Err(PlanError::NoSolid);
    }
    let plan = kirsch::plan_layer(prep, &opts.products, layer, true)?;
    Ok(corrected(plan, prep))
}

/// `plan` with the per-pixel eye correction ([`eye`]), checked.
fn corrected(plan: Plan, prep: &Prepared) -> Plan {
    let plan = Plan {
        steps: eye::correct(plan.steps, &prep.near_cut),
        ..plan
    };
    checked(plan, prep)
}

/// A builder that names a resource it did not declare is a bug, not bad input.
fn checked(plan: Plan, prep: &Prepared) -> Plan {
    if let Err(e) = validate::validate(&plan, prep.mesh_triangles.len() as u32) {
        panic!("the {} plan builder made an invalid plan: {e}", plan.algo);
    }
    plan
}

/// Per mesh (primitives, then surfaces): not convex ([`is_convex`]) but convex
/// from `scene`'s camera ([`view_convex`]). Unused primitives are not drawn and
/// get `false`.
fn view_convex_meshes(scene: &Scene, convex: &[bool]) -> Vec<bool> {
    let (w, h) = (scene.render.width, scene.render.height);
    let used = scene.primitives.iter().map(|p| (&p.mesh, p.used));
    let surfaces = scene.surfaces.iter().map(|s| (&s.mesh, true));
    used.chain(surfaces)
        .enumerate()
        .map(|(i, (mesh, used))| {
            used && !convex.get(i).copied().unwrap_or(false)
                && view_convex(mesh, &scene.camera, w, h)
        })
        .collect()
}

/// Per primitive (then `false` for surfaces): whether a perspective eye lies
/// inside its closed mesh ([`crate::geom::contains`]). Orthographic rays start on
/// the eye plane, one per pixel, so no single answer exists there; they get
/// `false` and the per-pixel correction of [`eye`] instead.
fn eye_inside(scene: &Scene) -> Vec<bool> {
    use crate::scene::Projection;
    let n = scene.primitives.len() + scene.surfaces.len();
    if !matches!(scene.camera.projection, Projection::Perspective { .. }) {
        return vec![false; n];
    }
    let mut out: Vec<bool> = scene
        .primitives
        .iter()
        .map(|p| p.used && crate::geom::contains(&p.mesh, scene.camera.eye))
        .collect();
    out.resize(n, false);
    out
}
