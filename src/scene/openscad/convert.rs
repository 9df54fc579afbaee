//! The `.csg` tree → our primitives and one CSG [`Expr`], following OpenSCAD
//! 2021.01's CSG-tree evaluation (`CSGTreeEvaluator`, `CSGOperation::
//! createCSGNode`):
//!
//! - `group`/`union`/`render` → union; `difference` → the first child minus the
//!   union of the rest; `intersection`. Unions and intersections are built
//!   balanced (depth log n) rather than left-deep.
//! - A `*` disabled or `%` background subtree, or a node dropped by
//!   `--skip-unsupported`, vanishes from its parent's child list. A child
//!   that yields nothing (an empty group, `render()` or an extrusion without
//!   children, a 2D shape among 3D objects, which OpenSCAD ignores with a
//!   warning) and a degenerate primitive (`sphere(0)`) are the empty set and
//!   follow the set algebra (`A ∩ ∅ = ∅`, `∅ − A = ∅`, `A − ∅ = A`), as
//!   OpenSCAD 2021.01's preview and CGAL render both draw
//!   `intersection() { cube(); render(); }` as nothing.
//! - `multmatrix` composes (row-major as printed); `color` colours the primitives
//!   below it, the outermost `color` winning as in 2021.01; `#` highlights.
//! - `!` makes the first such node the only root (its ancestors' transforms are
//!   not applied, as in OpenSCAD).
//! - Below `linear_extrude` / `rotate_extrude` the tree is 2D: `multmatrix`
//!   keeps its x/y part, operators stay operators, and each `circle`, `square`
//!   or `polygon` becomes one extruded primitive (`super::extrude`). The
//!   extrusion itself is the union of its children. A 2D shape among 3D objects,
//!   or a 3D object in a 2D subtree, is dropped with a warning, as OpenSCAD's
//!   CGAL evaluation drops it.
//!
//! Four passes over the pre-order arena, none recursive: top-down contexts
//! (ascending index), 2D regions and extrusion counts (descending), primitives
//! in order of appearance, bottom-up operators (descending index).

use glam::{DAffine2, DMat4, DVec2, DVec3};

use super::args::{self, Args};
use super::extrude::{self, Extents, Op2, Region};
use super::outline;
use super::parse::{Node, Tree, Value, ValueKind};
use super::pieces::{self, Piece};
use super::tessellate::{self, Resolution, F_MINIMUM};
use super::{mesh_import, orient, surface, ScadError, ScadPrimitive};
use crate::csg::expr::{Node as E, NodeId};
use crate::csg::Expr;
use crate::scene::cost;
use crate::scene::load::{MAX_DIVISIONS, MAX_GRID};
use crate::scene::validate::{check_closed, signed_volume, MeshProblem};
use crate::scene::Mesh;
use std::path::Path;

/// OpenSCAD's (Cornfield) colours: faces of the solid, faces of subtracted
/// parts, and `#` highlighted subtrees (with its alpha).
pub const FRONT_COLOR: [f32; 4] = [
    0xf9 as f32 / 255.0,
    0xd7 as f32 / 255.0,
    0x2c as f32 / 255.0,
    1.0,
];
pub const BACK_COLOR: [f32; 4] = [
    0x9d as f32 / 255.0,
    0xcb as f32 / 255.0,
    0x51 as f32 / 255.0,
    1.0,
];
pub const HIGHLIGHT_COLOR: [f32; 4] = [1.0, 0x51 as f32 / 255.0, 0x51 as f32 / 255.0, 0.5];
/// `%` background parts: OpenSCAD's `ColorMode::BACKGROUND`, `{180, 180, 180,
/// 128}` (Renderer.cc), drawn see-through and never part of the solid.
pub const BACKGROUND_COLOR: [f32; 4] = [180.0 / 255.0, 180.0 / 255.0, 180.0 / 255.0, 128.0 / 255.0];

/// The node kinds the reader evaluates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Union,
    Difference,
    Intersection,
    Multmatrix,
    Color,
    Cube,
    Sphere,
    Cylinder,
    Polyhedron,
    Circle,
    Square,
    Polygon,
    LinearExtrude,
    RotateExtrude,
    Text,
    Offset,
    Hull,
    Minkowski,
    Resize,
    Import,
    /// `import` of a DXF or SVG file: a 2D primitive (`super::import2d`).
    ImportOutline,
    Surface,
}

/// A node's kind; `import` of a DXF or SVG file is a 2D primitive.
fn kind_of(node: &Node) -> Option<Kind> {
    match kind(&node.name) {
        Some(Kind::Import) if super::import2d::is_2d_file(node) => Some(Kind::ImportOutline),
        k => k,
    }
}

fn kind(name: &str) -> Option<Kind> {
    Some(match name {
        "group" | "union" | "render" => Kind::Union,
        "difference" => Kind::Difference,
        "intersection" => Kind::Intersection,
        "multmatrix" => Kind::Multmatrix,
        "color" => Kind::Color,
        "cube" => Kind::Cube,
        "sphere" => Kind::Sphere,
        "cylinder" => Kind::Cylinder,
        "polyhedron" => Kind::Polyhedron,
        "circle" => Kind::Circle,
        "square" => Kind::Square,
        "polygon" => Kind::Polygon,
        "linear_extrude" => Kind::LinearExtrude,
        "rotate_extrude" => Kind::RotateExtrude,
        "text" => Kind::Text,
        "offset" => Kind::Offset,
        "hull" => Kind::Hull,
        "minkowski" => Kind::Minkowski,
        "resize" => Kind::Resize,
        "import" => Kind::Import,
        "surface" => Kind::Surface,
        _ => return None,
    })
}

const SUPPORTED: &str = "multmatrix, cube, sphere, cylinder, polyhedron, circle, square, polygon, text, offset, hull, minkowski, resize, linear_extrude, rotate_extrude, union, difference, intersection, group, color, render, import of STL/OFF/DXF/SVG, surface";
const TWO_D: &[&str] = &["projection"];

fn is_primitive(k: Kind) -> bool {
    is_3d_primitive(k) || is_2d_primitive(k) || is_outline(k)
}

/// 2D nodes whose outline is evaluated from their children (`super::outline`)
/// and extruded as one primitive.
fn is_outline(k: Kind) -> bool {
    matches!(k, Kind::Offset | Kind::Hull | Kind::Minkowski)
}

fn is_3d_primitive(k: Kind) -> bool {
    matches!(
        k,
        Kind::Cube
            | Kind::Sphere
            | Kind::Cylinder
            | Kind::Polyhedron
            | Kind::Import
            | Kind::Surface
    )
}

/// Evaluated from their children's vertices (`super::pieces`).
fn is_evaluated(k: Kind) -> bool {
    matches!(k, Kind::Hull | Kind::Minkowski | Kind::Resize)
}

fn is_2d_primitive(k: Kind) -> bool {
    matches!(
        k,
        Kind::Circle | Kind::Square | Kind::Polygon | Kind::Text | Kind::ImportOutline
    )
}

fn is_extrusion(k: Kind) -> bool {
    matches!(k, Kind::LinearExtrude | Kind::RotateExtrude)
}

/// Inside an extrusion: which one, and the 2D `multmatrix` composed below it
/// (OpenSCAD keeps a 3D matrix's x/y rows and columns for 2D children).
#[derive(Clone, Copy, Debug)]
struct Plane {
    extrusion: u32,
    matrix: DAffine2,
}

/// What a node's subtree inherits.
#[derive(Clone, Copy, Debug)]
struct Ctx {
    matrix: DMat4,
    /// From the outermost `color()`.
    color: Option<[f32; 4]>,
    highlight: bool,
    /// Under an odd number of difference subtrahends: OpenSCAD draws such faces
    /// in its back colour.
    negated: bool,
    /// Inside a `%` background subtree.
    background: bool,
    /// Inside an extrusion (its 2D subtree).
    plane: Option<Plane>,
    /// The outermost `hull`, `minkowski` or `resize` at or above the node.
    inside: Option<u32>,
}

/// A node's contribution to its parent.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Term {
    Empty,
    Node(NodeId),
}

/// The result: primitives in order of appearance and the solid (`None`: nothing
/// to draw), with warnings (`line:col: text`).
pub struct Converted {
    pub primitives: Vec<ScadPrimitive>,
    pub expr: Option<Expr>,
    pub warnings: Vec<String>,
    /// The `%` subtrees, each its own set (not part of the solid), in order of
    /// appearance.
    pub background: Vec<BackgroundTree>,
}

/// A `%` background subtree: its node, its primitives (in order of appearance)
/// and its own expression over them.
pub struct BackgroundTree {
    pub node: String,
    pub pos: super::Pos,
    pub primitives: Vec<ScadPrimitive>,
    pub expr: Expr,
}

/// `base`: the folder `import` and `surface` paths are relative to.
pub fn convert(tree: &Tree, skip_unsupported: bool, base: &Path) -> Result<Converted, ScadError> {
    let n = tree.nodes.len();
    let mut c = Converter {
        tree,
        skip_unsupported,
        base,
        own_matrix: vec![None; tree.nodes.len()],
        warnings: Vec::new(),
        ctx: vec![None; n],
        background_roots: Vec::new(),
        mesh_bytes: 0,
        unsupported: Vec::new(),
        // One more slot: the plate of a 2D model (`plate::PLATE`).
        extrusion_args: vec![None; n + 1],
        regions: vec![None; n],
        extrusions: vec![None; n + 1],
        inside_outline: vec![false; n],
        misplaced: vec![false; n],
        frames: vec![DAffine2::IDENTITY; n],
    };
    let roots = c.roots();
    let base = Ctx {
        matrix: DMat4::IDENTITY,
        color: None,
        highlight: false,
        negated: false,
        background: false,
        plane: c.plate(),
        inside: None,
    };
    for &r in &roots {
        c.ctx[r as usize] = c.enter(r, base)?;
    }
    // Top-down: a parent's index is below its children's.
    for i in 0..tree.nodes.len() {
        let Some(ctx) = c.ctx[i] else { continue };
        let node = &tree.nodes[i];
        let is_diff = kind_of(node) == Some(Kind::Difference);
        // Below a 2D `offset`, `hull` or `minkowski`, outlines are evaluated.
        let inside =
            c.inside_outline[i] || (ctx.plane.is_some() && kind_of(node).is_some_and(is_outline));
        for (k, &ch) in node.children.iter().enumerate() {
            let mut child = ctx;
            child.negated ^= is_diff && k > 0;
            c.inside_outline[ch as usize] = inside;
            c.ctx[ch as usize] = c.enter(ch, child)?;
        }
    }
    // Every unsupported node at once, in file order.
    if !c.unsupported.is_empty() {
        c.unsupported.sort_by_key(|(p, _)| (p.line, p.col));
        let (pos, first) = c.unsupported[0].clone();
        let fix = format!(
            "peeltrim reads {SUPPORTED}; remove {}, or pass --skip-unsupported to drop {} (and {} children) with a warning",
            if c.unsupported.len() == 1 { "the node" } else { "the nodes" },
            if c.unsupported.len() == 1 { "it" } else { "them" },
            if c.unsupported.len() == 1 { "its" } else { "their" },
        );
        let message = if c.unsupported.len() == 1 {
            format!("{first} is not supported: {fix}")
        } else {
            let all: Vec<String> = c
                .unsupported
                .iter()
                .map(|(p, what)| format!("{what} (line {})", p.line))
                .collect();
            format!(
                "{} nodes are not supported: {}; {fix}",
                all.len(),
                all.join(", ")
            )
        };
        return Err(ScadError::new(pos, message));
    }
    // A background root's term is its own set, not its parent's child. In order
    // of appearance (the arena's pre-order; top-level nodes are entered first).
    c.background_roots.sort_unstable();
    let mut is_background_root = vec![false; tree.nodes.len()];
    for &r in &c.background_roots {
        is_background_root[r as usize] = true;
    }
    c.two_d(&is_background_root)?;
    let mut pieces = c.evaluate(&is_background_root)?;
    // Warnings in file order (nodes are entered level by level).
    c.warnings.sort_by_key(|w| warning_pos(w));
    // Primitives in order of appearance.
    let mut out = Vec::new();
    let mut nodes: Vec<E> = Vec::new();
    let mut term: Vec<Option<Term>> = vec![None; tree.nodes.len()];
    for (i, slot) in term.iter_mut().enumerate() {
        let (Some(ctx), Some(k)) = (c.ctx[i], kind_of(&tree.nodes[i])) else {
            continue;
        };
        if let Some(root) = ctx.inside {
            if root as usize == i {
                let leaves: Vec<Term> = pieces[i]
                    .take()
                    .unwrap_or_default()
                    .into_iter()
                    .filter_map(|p| c.place_piece(p, &ctx))
                    .map(|p| {
                        out.push(p);
                        push(
                            &mut nodes,
                            E::Leaf {
                                prim: out.len() as u32 - 1,
                            },
                        )
                    })
                    .collect();
                *slot = Some(union(&mut nodes, &leaves));
            }
            continue;
        }
        if !is_primitive(k) || c.inside_outline[i] {
            continue;
        }
        *slot = Some(match c.primitive(i, k, &ctx)? {
            Some(p) => {
                nodes.push(E::Leaf {
                    prim: out.len() as u32,
                });
                out.push(p);
                Term::Node(nodes.len() as NodeId - 1)
            }
            None => Term::Empty,
        });
    }
    // Operators bottom-up.
    for i in (0..tree.nodes.len()).rev() {
        let (Some(ctx), Some(k)) = (c.ctx[i], kind_of(&tree.nodes[i])) else {
            continue;
        };
        if is_primitive(k) || c.inside_outline[i] || ctx.inside.is_some() {
            continue;
        }
        // A child that is there but yields nothing (`render()`, an empty
        // group, a dropped 2D shape among 3D ones) is the empty set; a `*`
        // or skipped one is not there.
        let kids: Vec<Term> = tree.nodes[i]
            .children
            .iter()
            .filter(|&&ch| !is_background_root[ch as usize])
            .filter_map(|&ch| {
                let there = c.ctx[ch as usize].is_some() || c.misplaced[ch as usize];
                term[ch as usize].or(there.then_some(Term::Empty))
            })
            .collect();
        term[i] = combine(&mut nodes, k, kids);
    }
    let top: Vec<Term> = roots
        .iter()
        .filter(|&&r| !is_background_root[r as usize])
        .filter_map(|&r| term[r as usize])
        .collect();
    let top = combine(&mut nodes, Kind::Union, top);
    let mut all = Expr { nodes, root: 0 };
    let background = c
        .background_roots
        .iter()
        .filter_map(|&r| match term[r as usize] {
            Some(Term::Node(root)) => {
                let node = &tree.nodes[r as usize];
                all.root = root;
                let (primitives, expr) = compact(&out, &all);
                Some(BackgroundTree {
                    node: node.name.clone(),
                    pos: node.pos,
                    primitives,
                    expr,
                })
            }
            _ => None,
        })
        .collect();
    let (primitives, expr) = match top {
        Some(Term::Node(root)) => {
            all.root = root;
            let (p, e) = compact(&out, &all);
            (p, Some(e))
        }
        _ => (Vec::new(), None),
    };
    Ok(Converted {
        primitives,
        expr,
        warnings: c.warnings,
        background,
    })
}

/// A warning's leading `line:col:`, for sorting into file order (none: last).
fn warning_pos(w: &str) -> (usize, usize) {
    let mut it = w.splitn(3, ':');
    match (it.next().map(str::parse), it.next().map(str::parse)) {
        (Some(Ok(l)), Some(Ok(c))) => (l, c),
        _ => (usize::MAX, usize::MAX),
    }
}

/// Keeps only what the solid reaches: primitives its leaves name (still in
/// order of appearance, renumbered) and its reachable nodes. A primitive can be
/// unreachable when an operator above it was pruned (`cube ∩ ∅`).
fn compact(prims: &[ScadPrimitive], e: &Expr) -> (Vec<ScadPrimitive>, Expr) {
    let mut used = vec![false; prims.len()];
    for p in e.leaves() {
        used[p as usize] = true;
    }
    let mut new_prim = vec![u32::MAX; prims.len()];
    let mut kept = Vec::new();
    for (i, p) in prims.iter().enumerate() {
        if used[i] {
            new_prim[i] = kept.len() as u32;
            kept.push(p.clone());
        }
    }
    let mut id = vec![NodeId::MAX; e.nodes.len()];
    let mut nodes = Vec::new();
    for n in e.postorder() {
        let m = |a: NodeId| id[a as usize];
        nodes.push(match e.nodes[n as usize] {
            E::Leaf { prim } => E::Leaf {
                prim: new_prim[prim as usize],
            },
            E::Not(a) => E::Not(m(a)),
            E::Union(a, b) => E::Union(m(a), m(b)),
            E::Inter(a, b) => E::Inter(m(a), m(b)),
            E::Diff(a, b) => E::Diff(m(a), m(b)),
        });
        id[n as usize] = nodes.len() as NodeId - 1;
    }
    let root = id[e.root as usize];
    (kept, Expr { nodes, root })
}

/// Combines the children's terms under operator `k`; `None` when no child gave
/// a term (the node vanishes).
fn combine(nodes: &mut Vec<E>, k: Kind, kids: Vec<Term>) -> Option<Term> {
    let first = *kids.first()?;
    Some(match k {
        Kind::Difference => match (first, union(nodes, &kids[1..])) {
            (Term::Empty, _) => Term::Empty,
            (a, Term::Empty) => a,
            (Term::Node(a), Term::Node(b)) => push(nodes, E::Diff(a, b)),
        },
        Kind::Intersection => {
            if kids.contains(&Term::Empty) {
                Term::Empty
            } else {
                balanced(nodes, &ids(&kids), E::Inter)
            }
        }
        _ => union(nodes, &kids),
    })
}

fn ids(kids: &[Term]) -> Vec<NodeId> {
    kids.iter()
        .filter_map(|t| match t {
            Term::Node(n) => Some(*n),
            Term::Empty => None,
        })
        .collect()
}

/// Union of the terms, the empty set dropped (`Empty` when nothing is left).
fn union(nodes: &mut Vec<E>, kids: &[Term]) -> Term {
    let ids = ids(kids);
    if ids.is_empty() {
        return Term::Empty;
    }
    balanced(nodes, &ids, E::Union)
}

/// A balanced binary tree of `op` over `ids` (non-empty), iterative.
fn balanced(nodes: &mut Vec<E>, ids: &[NodeId], op: fn(NodeId, NodeId) -> E) -> Term {
    let mut level: Vec<NodeId> = ids.to_vec();
    while level.len() > 1 {
        let mut next = Vec::with_capacity(level.len().div_ceil(2));
        for pair in level.chunks(2) {
            next.push(match *pair {
                [a, b] => match push(nodes, op(a, b)) {
                    Term::Node(n) => n,
                    Term::Empty => unreachable!("push returns a node"),
                },
                [a] => a,
                _ => unreachable!("chunks of 2"),
            });
        }
        level = next;
    }
    Term::Node(level[0])
}

fn push(nodes: &mut Vec<E>, n: E) -> Term {
    nodes.push(n);
    Term::Node(nodes.len() as NodeId - 1)
}

struct Converter<'a> {
    tree: &'a Tree,
    skip_unsupported: bool,
    /// The folder of the `.csg` file.
    base: &'a Path,
    /// Per node: a 3D `multmatrix`'s own matrix.
    own_matrix: Vec<Option<DMat4>>,
    warnings: Vec<String>,
    ctx: Vec<Option<Ctx>>,
    /// The outermost `%` nodes entered.
    background_roots: Vec<u32>,
    /// Estimated bytes of the meshes tessellated so far (`scene::cost`).
    mesh_bytes: u64,
    /// Unsupported nodes met (without --skip-unsupported), each with what it is.
    unsupported: Vec<(super::Pos, String)>,
    /// Per node: an extrusion's arguments (from `enter`).
    extrusion_args: Vec<Option<ExtrusionArgs>>,
    /// Per node: a 2D primitive's region, in its extrusion's plane.
    regions: Vec<Option<Region>>,
    /// Per node: an extrusion with its counts resolved against its 2D child.
    extrusions: Vec<Option<Extrusion>>,
    /// Per node: below an `offset`, `hull` or `minkowski` in the plane (its
    /// outline is evaluated, not extruded).
    inside_outline: Vec<bool>,
    /// Per node: a 2D shape among 3D objects or the reverse, dropped.
    misplaced: Vec<bool>,
    /// Per `offset`/`hull`/`minkowski` node: its 2D transform (its children's
    /// outlines are evaluated in its own frame).
    frames: Vec<DAffine2>,
}

/// `linear_extrude` or `rotate_extrude` as read from the node.
#[derive(Clone, Copy, Debug)]
enum ExtrusionArgs {
    Linear {
        h1: f64,
        h2: f64,
        twist: f64,
        scale: DVec2,
        slices: Option<u64>,
        res: Resolution,
    },
    Rotate {
        angle: f64,
        res: Resolution,
    },
}

impl ExtrusionArgs {
    /// Whether the counts depend on the 2D child's vertices.
    fn needs_child(&self) -> bool {
        match *self {
            ExtrusionArgs::Linear {
                twist,
                scale,
                slices,
                ..
            } => slices.is_none() && (twist != 0.0 || scale.x != scale.y),
            ExtrusionArgs::Rotate { .. } => true,
        }
    }
}

/// An extrusion ready to apply to its 2D primitives (`None`: it makes nothing).
#[derive(Clone, Copy, Debug)]
enum Extrusion {
    Linear(extrude::Linear),
    Rotate {
        angle: f64,
        fragments: u64,
        min_x: f64,
    },
    Empty,
}

impl Converter<'_> {
    /// The top-level statements, or the first `!` node alone.
    fn roots(&mut self) -> Vec<u32> {
        let marked: Vec<u32> = (0..self.tree.nodes.len() as u32)
            .filter(|&i| self.tree.nodes[i as usize].modifiers.root)
            .collect();
        match marked[..] {
            [] => self.tree.roots.clone(),
            [first, ..] => {
                if marked.len() > 1 {
                    let n = &self.tree.nodes[marked[1] as usize];
                    self.warnings.push(format!(
                        "{}:{}: more than one `!` root modifier: only the first (line {}) is drawn",
                        n.pos.line, n.pos.col, self.tree.nodes[first as usize].pos.line
                    ));
                }
                vec![first]
            }
        }
    }

    /// The context of node `i` given its parent's, or `None` when the node is
    /// not part of the solid (disabled, background, skipped).
    fn enter(&mut self, i: u32, parent: Ctx) -> Result<Option<Ctx>, ScadError> {
        let tree = self.tree;
        let node = &tree.nodes[i as usize];
        let at = format!("{}:{}", node.pos.line, node.pos.col);
        if node.modifiers.disabled {
            return Ok(None);
        }
        let mut ctx = parent;
        if node.modifiers.background && !parent.background {
            // Its own set, drawn see-through where the algorithm draws
            // transparency (`super::background`).
            self.background_roots.push(i);
            ctx.background = true;
        }
        let Some(k) = kind_of(node) else {
            let what = if TWO_D.contains(&node.name.as_str()) {
                format!("`{}` (it needs the 3D boundary)", node.name)
            } else {
                format!("`{}`", node.name)
            };
            return Ok(self.unsupported_node(node, &ctx, what));
        };
        if let Some(what) = self.refused_here(k, node, &parent) {
            return Ok(self.unsupported_node(node, &ctx, what));
        }
        let misplaced = if parent.plane.is_some() && (is_3d_primitive(k) || is_extrusion(k)) {
            Some("a 3D object inside a 2D subtree (below an extrusion)")
        } else if parent.plane.is_none() && (is_2d_primitive(k) || k == Kind::Offset) {
            Some("a 2D shape among 3D objects (not below linear_extrude or rotate_extrude)")
        } else {
            None
        };
        if let Some(why) = misplaced {
            self.warnings.push(format!(
                "{at}: `{}` is {why}; OpenSCAD drops it, and so does peeltrim (wrap a 2D shape in linear_extrude to give it volume)",
                node.name
            ));
            self.misplaced[i as usize] = true;
            return Ok(None);
        }
        if is_evaluated(k) && parent.plane.is_none() {
            ctx.inside = parent.inside.or(Some(i));
        }
        if is_primitive(k) && !is_outline(k) && !node.children.is_empty() {
            return Err(ScadError::new(
                node.pos,
                format!("`{}` takes no children: end it with `;`", node.name),
            ));
        }
        ctx.highlight |= node.modifiers.highlight;
        match k {
            Kind::Multmatrix => {
                let m = self.matrix(node)?;
                match &mut ctx.plane {
                    Some(plane) => {
                        plane.matrix = plane.matrix
                            * DAffine2::from_cols(
                                m.x_axis.truncate().truncate(),
                                m.y_axis.truncate().truncate(),
                                m.w_axis.truncate().truncate(),
                            )
                    }
                    None => {
                        ctx.matrix = parent.matrix * m;
                        self.own_matrix[i as usize] = Some(m);
                    }
                }
            }
            Kind::LinearExtrude | Kind::RotateExtrude => {
                self.extrusion_args[i as usize] = Some(self.extrusion_args(node, k)?);
                ctx.plane = Some(Plane {
                    extrusion: i,
                    matrix: DAffine2::IDENTITY,
                });
            }
            Kind::Color => {
                let c = self.color(node)?;
                ctx.color = parent.color.or(Some(c));
            }
            Kind::Offset | Kind::Hull | Kind::Minkowski => {
                if let Some(plane) = &mut ctx.plane {
                    self.frames[i as usize] = plane.matrix;
                    plane.matrix = DAffine2::IDENTITY;
                }
            }
            _ => {}
        }
        Ok(Some(ctx))
    }

    /// Drops an unsupported node with a warning (`--skip-unsupported`, or in a
    /// background part), or keeps it for the error that lists them all.
    fn unsupported_node(&mut self, node: &Node, ctx: &Ctx, what: String) -> Option<Ctx> {
        if self.skip_unsupported || ctx.background {
            let why = if ctx.background {
                "in a `%` background part"
            } else {
                "--skip-unsupported"
            };
            self.warnings.push(format!(
                "{}:{}: {what} is not supported and was dropped with its children ({why}): the picture lacks it",
                node.pos.line, node.pos.col
            ));
        } else {
            // Reported with every other one once all are found.
            self.unsupported.push((node.pos, what));
        }
        None
    }

    /// A known node kind that peeltrim cannot evaluate where it stands.
    fn refused_here(&self, k: Kind, node: &Node, parent: &Ctx) -> Option<String> {
        let name = &node.name;
        if parent.plane.is_some() && k == Kind::Import {
            return Some(format!(
                "`{name}` of a mesh or an unknown file in 2D (2D import reads DXF or SVG)"
            ));
        }
        if parent.plane.is_some() && k == Kind::Resize {
            return Some(format!("`{name}` of 2D shapes"));
        }
        if let (Some(root), Kind::Difference | Kind::Intersection) = (parent.inside, k) {
            let r = &self.tree.nodes[root as usize];
            return Some(format!(
                "`{name}` inside `{}` (line {}), whose result needs the {name}'s evaluated boundary (a mesh Boolean peeltrim does not compute)",
                r.name, r.pos.line
            ));
        }
        None
    }

    fn matrix(&mut self, node: &Node) -> Result<DMat4, ScadError> {
        let a = Args::new(node, &["m"], &[], &mut self.warnings)?;
        let Some(v) = a.get("m") else {
            return Ok(DMat4::IDENTITY);
        };
        let what = "`m` of `multmatrix`";
        let rows = args::vector(v, what)?;
        let mut m = [[0.0; 4]; 4];
        m[3] = [0.0, 0.0, 0.0, 1.0];
        if !(3..=4).contains(&rows.len()) {
            return Err(ScadError::new(
                v.pos,
                format!(
                    "{what} must be a 4×4 matrix (rows of 4 numbers), not {} rows",
                    rows.len()
                ),
            ));
        }
        for (r, row) in rows.iter().enumerate() {
            // An infinite or NaN entry is undef to OpenSCAD, which keeps the
            // identity's entry there.
            if args::has_non_finite(row) {
                self.warnings.push(format!(
                    "{}:{}: {what}: row {} holds an infinite or NaN number, which OpenSCAD reads as undef and replaces by the identity's entry; so does peeltrim",
                    row.pos.line, row.pos.col, r + 1
                ));
            }
            let nums: Vec<f64> = args::vector(row, what)?
                .iter()
                .enumerate()
                .map(|(c, x)| match x.kind {
                    ValueKind::Number(n) if !n.is_finite() => Ok(if r == c { 1.0 } else { 0.0 }),
                    _ => args::number(x, what),
                })
                .collect::<Result<_, _>>()?;
            if nums.len() != 4 {
                return Err(ScadError::new(
                    row.pos,
                    format!(
                        "{what}: row {} has {} numbers; each row needs 4",
                        r + 1,
                        nums.len()
                    ),
                ));
            }
            m[r].copy_from_slice(&nums);
        }
        if m[3] != [0.0, 0.0, 0.0, 1.0] {
            return Err(ScadError::new(
                v.pos,
                format!("{what}: the last row is {:?}; a projective transform is not supported (use [0, 0, 0, 1])", m[3]),
            ));
        }
        // Printed row-major; glam takes columns.
        Ok(DMat4::from_cols_array_2d(&m).transpose())
    }

    fn color(&mut self, node: &Node) -> Result<[f32; 4], ScadError> {
        let a = Args::new(node, &["c", "alpha"], &[], &mut self.warnings)?;
        let alpha = a.number("alpha")?;
        let Some(v) = a.get("c") else {
            return Ok([
                FRONT_COLOR[0],
                FRONT_COLOR[1],
                FRONT_COLOR[2],
                alpha.unwrap_or(1.0) as f32,
            ]);
        };
        let what = "`c` of `color`";
        let rgba: [f64; 4] = match &v.kind {
            ValueKind::Vector(_) => match args::numbers(v, what)?[..] {
                [r, g, b] => [r, g, b, 1.0],
                [r, g, b, a] => [r, g, b, a],
                _ => {
                    return Err(ScadError::new(
                        v.pos,
                        format!("{what} must be [r, g, b] or [r, g, b, a] with components 0 to 1"),
                    ))
                }
            },
            ValueKind::Str(s) => hex_color(s).ok_or_else(|| {
                ScadError::new(
                    v.pos,
                    format!("{what}: \"{s}\" is not a colour this reader knows: write \"#rrggbb\", \"#rrggbbaa\" or a vector [r, g, b, a] (OpenSCAD's export prints vectors)"),
                )
            })?,
            _ => return Err(ScadError::new(v.pos, format!("{what} must be a colour vector"))),
        };
        let alpha = alpha.unwrap_or(rgba[3]);
        Ok([rgba[0], rgba[1], rgba[2], alpha].map(|x| x.clamp(0.0, 1.0) as f32))
    }

    /// Tessellates primitive `i` and places it; `None` for a degenerate one.
    fn primitive(
        &mut self,
        i: usize,
        k: Kind,
        ctx: &Ctx,
    ) -> Result<Option<ScadPrimitive>, ScadError> {
        let node = &self.tree.nodes[i];
        let Some(local) = self.local(i, k, ctx)? else {
            return Ok(None);
        };
        let rgba = self.rgba(ctx);
        Ok(self.place(&node.name, node.pos, local, rgba, ctx))
    }

    /// A piece of an evaluated subtree, placed by the subtree's context.
    fn place_piece(&mut self, p: pieces::Piece, ctx: &Ctx) -> Option<ScadPrimitive> {
        if !(p.mesh.signed_volume() > 0.0) {
            self.warnings.push(format!(
                "{}:{}: `{}` encloses no volume where it stands (flattened by a transform); it is the empty set",
                p.pos.line, p.pos.col, p.node
            ));
            return None;
        }
        self.place(&p.node, p.pos, p.mesh, p.rgba, ctx)
    }

    /// The colour of a primitive in context `ctx`.
    fn rgba(&self, ctx: &Ctx) -> [f32; 4] {
        if ctx.background {
            BACKGROUND_COLOR
        } else if ctx.highlight {
            HIGHLIGHT_COLOR
        } else {
            ctx.color
                .unwrap_or(if ctx.negated { BACK_COLOR } else { FRONT_COLOR })
        }
    }

    /// Places a local mesh by the context's matrix; `None` when that is singular.
    fn place(
        &mut self,
        name: &str,
        pos: super::Pos,
        local: Mesh,
        rgba: [f32; 4],
        ctx: &Ctx,
    ) -> Option<ScadPrimitive> {
        let det = ctx.matrix.determinant();
        if !det.is_finite() || det.abs() < 1e-300 {
            self.warnings.push(format!(
                "{}:{}: `{name}` is flattened by a singular multmatrix (determinant {det}); it encloses no volume and is the empty set",
                pos.line, pos.col
            ));
            return None;
        }
        Some(ScadPrimitive {
            node: name.to_string(),
            line: pos.line,
            mesh: crate::scene::shapes::apply_transform(&local, &ctx.matrix),
            matrix: ctx.matrix,
            rgba,
        })
    }

    /// Primitive `i`'s mesh in its own frame (an extruded 2D shape: in its
    /// extrusion's); `None` for a degenerate one.
    fn local(&mut self, i: usize, k: Kind, ctx: &Ctx) -> Result<Option<Mesh>, ScadError> {
        let tree = self.tree;
        let node = &tree.nodes[i];
        Ok(match k {
            Kind::Cube => {
                let a = Args::new(node, &["size", "center"], &[], &mut self.warnings)?;
                let size = match a.get("size") {
                    None => DVec3::ONE,
                    Some(v) if matches!(v.kind, ValueKind::Number(_)) => {
                        DVec3::splat(args::number(v, "`size` of `cube`")?)
                    }
                    Some(v) => args::vec3(v, "`size` of `cube`")?,
                };
                tessellate::cube(size, a.boolean("center")?.unwrap_or(false))
            }
            Kind::Sphere => {
                let a = Args::new(node, &["r"], &["d"], &mut self.warnings)?;
                let r = match a.number("d")? {
                    Some(d) => d / 2.0,
                    None => a.number("r")?.unwrap_or(1.0),
                };
                let n = self.fragments(node, &a, r, 2)?;
                tessellate::sphere(r, n)
            }
            Kind::Cylinder => {
                let a = Args::new(
                    node,
                    &["h", "r1", "r2", "center"],
                    &["r", "d", "d1", "d2"],
                    &mut self.warnings,
                )?;
                let radius = |d: &str, r: &str| -> Result<Option<f64>, ScadError> {
                    Ok(match a.number(d)? {
                        Some(d) => Some(d / 2.0),
                        None => a.number(r)?,
                    })
                };
                let both = radius("d", "r")?;
                let r1 = radius("d1", "r1")?.or(both).unwrap_or(1.0);
                let r2 = radius("d2", "r2")?.or(both).unwrap_or(1.0);
                let h = a.number("h")?.unwrap_or(1.0);
                let n = self.fragments(node, &a, r1.max(r2), 1)?;
                tessellate::cylinder(h, r1, r2, a.boolean("center")?.unwrap_or(false), n)
            }
            Kind::Polyhedron => self.polyhedron(node)?,
            Kind::Import => self.import(node)?,
            Kind::Surface => self.surface(node)?,
            _ if ctx.plane.is_some() => self.extruded(i, node, ctx)?,
            _ => unreachable!("only primitives are tessellated"),
        })
    }

    /// `$fn`, `$fa`, `$fs` of a node, `$fa`/`$fs` clamped as OpenSCAD does.
    fn resolution(&mut self, a: &Args) -> Result<Resolution, ScadError> {
        resolution(a, &mut self.warnings)
    }

    /// `get_fragments_from_r` with `$fa`/`$fs` clamped as OpenSCAD does, and a cap
    /// on the vertex count (`rings_div`: 2 for a sphere's rings, 1 otherwise).
    fn fragments(
        &mut self,
        node: &Node,
        a: &Args,
        r: f64,
        rings_div: u64,
    ) -> Result<u64, ScadError> {
        let res = self.resolution(a)?;
        let n = tessellate::fragments(r, res);
        let rings = n.div_ceil(rings_div);
        if n > MAX_DIVISIONS as u64 || (rings_div == 2 && n.saturating_mul(rings) > MAX_GRID) {
            return Err(ScadError::new(
                node.pos,
                format!(
                    "`{}` would have {n} fragments (from $fn = {}, $fa = {}, $fs = {}); at most {MAX_DIVISIONS} (and {MAX_GRID} sphere vertices) are accepted: lower $fn or raise $fa/$fs",
                    node.name, res.fn_, res.fa, res.fs
                ),
            ));
        }
        // Legal counts can still be more than the memory budget holds: refuse
        // before tessellating, as the TOML loader does for `segments`.
        let (v, t) = if rings_div == 2 {
            (
                n.saturating_mul(rings),
                n.saturating_mul(rings).saturating_mul(2),
            )
        } else {
            (n.saturating_mul(2).saturating_add(2), n.saturating_mul(4))
        };
        self.mesh_bytes = self.mesh_bytes.saturating_add(cost::mesh_bytes(v, t));
        crate::budget::current()
            .check(
                || {
                    format!(
                        "`{}` with {n} fragments ({v} vertices; with the model's meshes before it)",
                        node.name
                    )
                },
                self.mesh_bytes,
                "lower $fn or raise $fa/$fs",
            )
            .map_err(|e| ScadError::new(node.pos, e.to_string()))?;
        Ok(n)
    }

    fn polyhedron(&mut self, node: &Node) -> Result<Option<Mesh>, ScadError> {
        let a = Args::new(
            node,
            &["points", "faces", "convexity"],
            &["triangles"],
            &mut self.warnings,
        )?;
        let Some(pv) = a.get("points") else {
            return Err(ScadError::new(
                node.pos,
                "`polyhedron` needs `points = [[x, y, z], ...]`",
            ));
        };
        let point_values = args::vector(pv, "`points` of `polyhedron`")?;
        if let Some(bad) = point_values.iter().find(|p| args::has_non_finite(p)) {
            // OpenSCAD reads `nan`/`inf` in a `.csg` as undef, cannot make the
            // point a vec3, and drops the polyhedron with an error.
            self.warnings.push(format!(
                "{}:{}: a point of `polyhedron` has an infinite or NaN coordinate; OpenSCAD drops the polyhedron, and so does peeltrim",
                bad.pos.line, bad.pos.col
            ));
            return Ok(None);
        }
        let points = point_values
            .iter()
            .map(|p| args::vec3(p, "a point of `polyhedron`"))
            .collect::<Result<Vec<DVec3>, _>>()?;
        let Some(fv) = a.get("faces").or_else(|| a.get("triangles")) else {
            return Err(ScadError::new(
                node.pos,
                "`polyhedron` needs `faces = [[0, 1, 2], ...]`",
            ));
        };
        let mut faces = Vec::new();
        let mut tri_face = Vec::new();
        for (fi, f) in args::vector(fv, "`faces` of `polyhedron`")?
            .iter()
            .enumerate()
        {
            let idx = args::vector(f, "a face of `polyhedron`")?
                .iter()
                .map(|x| args::index(x, &format!("face {fi} of `polyhedron`"), points.len()))
                .collect::<Result<Vec<u32>, _>>()?;
            if idx.len() < 3 {
                return Err(ScadError::new(
                    f.pos,
                    format!(
                        "face {fi} of `polyhedron` has {} point(s); a face needs at least 3",
                        idx.len()
                    ),
                ));
            }
            tri_face.extend(std::iter::repeat(fi).take(idx.len() - 2));
            faces.push(idx);
        }
        let Some(mut mesh) = tessellate::polyhedron(points, &faces) else {
            return Ok(None);
        };
        if let Err(MeshProblem::SameDirection { .. }) = check_closed(&mesh) {
            if let Ok(n) = orient::reorient(&mut mesh) {
                self.warnings.push(format!(
                    "{}:{}: `polyhedron`: its faces disagree in orientation; {n} triangle(s) were reversed to agree with their neighbours (OpenSCAD's preview draws it; its CGAL render drops it as not closed): list every face clockwise seen from outside",
                    node.pos.line, node.pos.col
                ));
            }
        }
        let bad = |msg: String| {
            ScadError::new(
                node.pos,
                format!("`polyhedron` is not a closed solid: {msg}"),
            )
        };
        if let Err(problem) = check_closed(&mesh) {
            let p = |i: u32| {
                let v = mesh.positions[i as usize];
                format!("points[{i}] ({}, {}, {})", v.x, v.y, v.z)
            };
            return Err(bad(match problem {
                MeshProblem::NoTriangles => "it has no faces".to_string(),
                MeshProblem::RepeatedVertex { triangle, .. } => format!(
                    "face {} names the same point twice; remove the repetition",
                    tri_face[triangle]
                ),
                MeshProblem::Open { a, b, .. } => format!(
                    "the edge {} – {} belongs to one face only; every edge must be shared by exactly two faces (close the hole)",
                    p(b), p(a)
                ),
                MeshProblem::SameDirection { a, b, .. } => format!(
                    "the edge {} → {} is traversed in the same direction by two faces, so their orientations disagree; list every face clockwise seen from outside",
                    p(b), p(a)
                ),
            }));
        }
        let v = signed_volume(&mesh);
        if v < 0.0 {
            for t in &mut mesh.triangles {
                t.swap(1, 2);
            }
            self.warnings.push(format!(
                "{}:{}: `polyhedron` is inside out (its faces are counter-clockwise seen from outside); turned outward, as OpenSCAD renders it: list each face clockwise seen from outside",
                node.pos.line, node.pos.col
            ));
        }
        if v == 0.0 {
            return Ok(None);
        }
        Ok(Some(mesh))
    }
}

/// `$fn`, `$fa`, `$fs` of a node, `$fa`/`$fs` clamped as OpenSCAD does.
pub(super) fn resolution(a: &Args, warnings: &mut Vec<String>) -> Result<Resolution, ScadError> {
    let mut res = Resolution::default();
    if let Some(v) = a.get("$fn") {
        res.fn_ = args::number(v, "`$fn`")?;
    }
    for (name, slot) in [("$fa", &mut res.fa), ("$fs", &mut res.fs)] {
        if let Some(v) = a.get(name) {
            *slot = args::number(v, &format!("`{name}`"))?;
            if *slot < F_MINIMUM {
                warnings.push(format!(
                    "{}:{}: {name} = {} is too small; clamped to {F_MINIMUM} as OpenSCAD does",
                    v.pos.line, v.pos.col, *slot
                ));
                *slot = F_MINIMUM;
            }
        }
    }
    Ok(res)
}

/// `"#rrggbb"` or `"#rrggbbaa"` as components 0 to 1.
fn hex_color(s: &str) -> Option<[f64; 4]> {
    let h = s.strip_prefix('#')?;
    if !(h.len() == 6 || h.len() == 8) || !h.chars().all(|c| c.is_ascii_hexdigit()) {
        return None;
    }
    let b = |i: usize| {
        u8::from_str_radix(&h[i..i + 2], 16)
            .ok()
            .map(|v| v as f64 / 255.0)
    };
    let a = if h.len() == 8 { b(6)? } else { 1.0 };
    Some([b(0)?, b(2)?, b(4)?, a])
}

/// 2D shapes and extrusions (`super::extrude` says why each 2D primitive is
/// extruded on its own).
impl Converter<'_> {
    /// `linear_extrude(height, center, twist, slices, scale)` or
    /// `rotate_extrude(angle)`, as OpenSCAD 2021.01's modules read them.
    fn extrusion_args(&mut self, node: &Node, k: Kind) -> Result<ExtrusionArgs, ScadError> {
        let (positional, known): (&[&'static str], &[&'static str]) = match k {
            Kind::LinearExtrude => (
                &["height", "center", "convexity", "twist", "slices", "scale"],
                &["file", "layer", "origin", "v"],
            ),
            _ => (&["angle", "convexity"], &["file", "layer", "origin"]),
        };
        let a = Args::new(node, positional, known, &mut self.warnings)?;
        if let Some(v) = a.get("file") {
            return Err(ScadError::new(
                v.pos,
                format!(
                    "`{}` of an imported file is not supported: export the profile as 2D shapes (circle, square, polygon) instead",
                    node.name
                ),
            ));
        }
        let res = self.resolution(&a)?;
        if k == Kind::RotateExtrude {
            let mut angle = a.number("angle")?.unwrap_or(360.0);
            if !(-360.0..=360.0).contains(&angle) {
                angle = 360.0;
            }
            return Ok(ExtrusionArgs::Rotate { angle, res });
        }
        let height = a.number("height")?.unwrap_or(100.0);
        let (h1, h2) = if a.boolean("center")?.unwrap_or(false) {
            (-height / 2.0, height / 2.0)
        } else {
            (0.0, height)
        };
        let twist = a.number("twist")?.unwrap_or(0.0);
        let slices = match a.get("slices") {
            None => None,
            Some(v) => {
                let n = args::number(v, "`slices` of `linear_extrude`")?;
                if n > MAX_DIVISIONS as f64 {
                    return Err(ScadError::new(
                        v.pos,
                        format!("`slices` of `linear_extrude` is {n}; at most {MAX_DIVISIONS} are accepted: lower it"),
                    ));
                }
                Some(n.max(1.0) as u64)
            }
        };
        let mut scale = match a.get("scale") {
            None => DVec2::ONE,
            Some(v) => number_or_pair(v, "`scale` of `linear_extrude`")?,
        };
        if scale.min_element() < 0.0 {
            let pos = a.get("scale").map(|v| v.pos).unwrap_or(node.pos);
            self.warnings.push(format!(
                "{}:{}: a negative `scale` of `linear_extrude` is taken as 0, as OpenSCAD does",
                pos.line, pos.col
            ));
            scale = scale.max(DVec2::ZERO);
        }
        Ok(ExtrusionArgs::Linear {
            h1,
            h2,
            twist,
            scale,
            slices,
            res,
        })
    }

    /// Each 2D primitive's region; each extrusion's counts, from its 2D child
    /// evaluated with `i_overlay` where the counts need it (bottom-up).
    fn two_d(&mut self, is_background_root: &[bool]) -> Result<(), ScadError> {
        let tree = self.tree;
        let mut evaluated: Vec<Option<Region>> = vec![None; tree.nodes.len()];
        for i in (0..tree.nodes.len()).rev() {
            let (Some(ctx), Some(k)) = (self.ctx[i], kind_of(&tree.nodes[i])) else {
                continue;
            };
            let node = &tree.nodes[i];
            let Some(plane) = ctx.plane else { continue };
            let inside = self.inside_outline[i];
            let needs =
                self.extrusion_args[plane.extrusion as usize].is_some_and(|e| e.needs_child());
            if is_2d_primitive(k) || is_outline(k) {
                let r = if is_outline(k) {
                    let kids = node
                        .children
                        .iter()
                        .filter(|&&ch| !is_background_root[ch as usize])
                        .filter_map(|&ch| evaluated[ch as usize].take())
                        .collect();
                    self.outline(i, k, kids)?
                } else {
                    self.region(node, k, &plane.matrix)?
                };
                if inside {
                    evaluated[i] = Some(r);
                    continue;
                }
                if needs {
                    evaluated[i] = Some(r.clone());
                }
                self.regions[i] = Some(r);
                continue;
            }
            let needs = needs || inside;
            let kids: Vec<Region> = if needs {
                node.children
                    .iter()
                    .filter(|&&ch| !is_background_root[ch as usize])
                    .filter_map(|&ch| evaluated[ch as usize].take())
                    .collect()
            } else {
                Vec::new()
            };
            let op = match k {
                Kind::Difference => Op2::Difference,
                Kind::Intersection => Op2::Intersection,
                _ => Op2::Union,
            };
            if plane.extrusion as usize != i {
                if needs && !kids.is_empty() {
                    evaluated[i] = Some(extrude::boolean(op, kids));
                }
                continue;
            }
            let child = extrude::boolean(Op2::Union, kids);
            let e = self.resolve(i, node, &child)?;
            self.extrusions[i] = Some(e);
        }
        Ok(())
    }

    /// The extrusion's counts against its evaluated 2D child.
    fn resolve(&mut self, i: usize, node: &Node, child: &Region) -> Result<Extrusion, ScadError> {
        let Some(args) = self.extrusion_args[i] else {
            unreachable!("extrusion arguments are read on entry")
        };
        let n = match args {
            ExtrusionArgs::Linear {
                h1,
                h2,
                twist,
                scale,
                slices,
                res,
            } => {
                if h2 - h1 <= 0.0 {
                    return Ok(Extrusion::Empty);
                }
                let slices = slices
                    .unwrap_or_else(|| extrude::default_slices(child, h2 - h1, twist, scale, res));
                if slices > MAX_DIVISIONS as u64 {
                    return Err(ScadError::new(
                        node.pos,
                        format!("`linear_extrude` would have {slices} slices (from $fn = {}, $fa = {}, $fs = {}); at most {MAX_DIVISIONS} are accepted: give `slices`, or raise $fa/$fs", res.fn_, res.fa, res.fs),
                    ));
                }
                return Ok(Extrusion::Linear(extrude::Linear {
                    h1,
                    h2,
                    twist,
                    scale,
                    slices,
                }));
            }
            ExtrusionArgs::Rotate { angle, res } => {
                if angle == 0.0 {
                    return Ok(Extrusion::Empty);
                }
                let e = Extents::of(child);
                if !e.one_side() {
                    self.warnings.push(format!(
                        "{}:{}: all points of a `rotate_extrude` profile must have the same sign of x (range {} to {}); OpenSCAD makes nothing of it, and so does peeltrim",
                        node.pos.line, node.pos.col, e.min_x, e.max_x
                    ));
                    return Ok(Extrusion::Empty);
                }
                (extrude::rotate_fragments(&e, angle, res), angle, e.min_x)
            }
        };
        let (fragments, angle, min_x) = n;
        if fragments > MAX_DIVISIONS as u64 {
            return Err(ScadError::new(
                node.pos,
                format!("`rotate_extrude` would have {fragments} fragments; at most {MAX_DIVISIONS} are accepted: lower $fn or raise $fa/$fs"),
            ));
        }
        Ok(Extrusion::Rotate {
            angle,
            fragments,
            min_x,
        })
    }

    /// A 2D primitive's region in its extrusion's plane (`m` applied).
    fn region(&mut self, node: &Node, k: Kind, m: &DAffine2) -> Result<Region, ScadError> {
        let det = m.matrix2.determinant();
        let r = match k {
            Kind::Circle => {
                let a = Args::new(node, &["r"], &["d"], &mut self.warnings)?;
                let r = match a.number("d")? {
                    Some(d) => d / 2.0,
                    None => a.number("r")?.unwrap_or(1.0),
                };
                let n = self.fragments(node, &a, r, 1)?;
                extrude::circle(r, n).transformed(m)
            }
            Kind::Square => {
                let a = Args::new(node, &["size", "center"], &[], &mut self.warnings)?;
                let size = match a.get("size") {
                    None => DVec2::ONE,
                    Some(v) => number_or_pair(v, "`size` of `square`")?,
                };
                extrude::square(size, a.boolean("center")?.unwrap_or(false)).transformed(m)
            }
            Kind::Text => super::text::region(node, &mut self.warnings)?.transformed(m),
            Kind::ImportOutline => {
                super::import2d::region(node, self.base, &mut self.warnings)?.transformed(m)
            }
            _ => self.polygon(node, m)?,
        };
        self.check_extent(node, &r)?;
        if !(det.abs() > 1e-300) {
            self.warnings.push(format!(
                "{}:{}: `{}` is flattened by a singular 2D multmatrix; OpenSCAD removes it, and so does peeltrim",
                node.pos.line, node.pos.col, node.name
            ));
            return Ok(Region::default());
        }
        Ok(r)
    }

    fn polygon(&mut self, node: &Node, m: &DAffine2) -> Result<Region, ScadError> {
        let a = Args::new(
            node,
            &["points", "paths", "convexity"],
            &[],
            &mut self.warnings,
        )?;
        let Some(pv) = a.get("points") else {
            return Err(ScadError::new(
                node.pos,
                "`polygon` needs `points = [[x, y], ...]`",
            ));
        };
        if args::has_non_finite(pv) {
            self.warnings.push(format!(
                "{}:{}: a point of `polygon` has an infinite or NaN coordinate; OpenSCAD drops the polygon, and so does peeltrim",
                pv.pos.line, pv.pos.col
            ));
            return Ok(Region::default());
        }
        let points = args::vector(pv, "`points` of `polygon`")?
            .iter()
            .map(|p| {
                let n = args::numbers(p, "a point of `polygon`")?;
                match n[..] {
                    [x, y] | [x, y, _]
                        if x.abs() <= extrude::MAX_COORD && y.abs() <= extrude::MAX_COORD =>
                    {
                        Ok(DVec2::new(x, y))
                    }
                    [_, _] | [_, _, _] => Err(ScadError::new(
                        p.pos,
                        format!(
                            "a point of `polygon` is beyond ±{:e}; scale the model down",
                            extrude::MAX_COORD
                        ),
                    )),
                    _ => Err(ScadError::new(
                        p.pos,
                        format!(
                            "a point of `polygon` must be [x, y], not {} numbers",
                            n.len()
                        ),
                    )),
                }
            })
            .collect::<Result<Vec<DVec2>, _>>()?;
        let paths: Vec<Vec<DVec2>> = match a.get("paths") {
            None => vec![points.clone()],
            Some(v) => args::vector(v, "`paths` of `polygon`")?
                .iter()
                .enumerate()
                .map(|(k, path)| {
                    args::vector(path, "a path of `polygon`")?
                        .iter()
                        .map(|x| {
                            args::index(x, &format!("path {k} of `polygon`"), points.len())
                                .map(|i| points[i as usize])
                        })
                        .collect::<Result<Vec<DVec2>, _>>()
                })
                .collect::<Result<_, _>>()?,
        };
        // The memory budget, before the polygon library sees the points.
        let total: usize = paths.iter().map(|p| p.len()).sum();
        self.mesh_bytes = self
            .mesh_bytes
            .saturating_add(cost::mesh_bytes(total as u64 * 2, total as u64 * 4));
        crate::budget::current()
            .check(
                || {
                    format!(
                        "`polygon` with {total} path points (with the model's meshes before it)"
                    )
                },
                self.mesh_bytes,
                "use fewer points",
            )
            .map_err(|e| ScadError::new(node.pos, e.to_string()))?;
        Ok(extrude::polygon(&paths, m))
    }

    /// A 2D primitive extruded by its extrusion, in the extrusion's frame.
    fn extruded(&mut self, i: usize, node: &Node, ctx: &Ctx) -> Result<Option<Mesh>, ScadError> {
        let Some(plane) = ctx.plane else {
            unreachable!("2D primitives outside an extrusion are dropped on entry")
        };
        let Some(region) = self.regions[i].take() else {
            return Ok(None);
        };
        let Some(e) = self.extrusions[plane.extrusion as usize] else {
            return Ok(None);
        };
        if region.is_empty() || matches!(e, Extrusion::Empty) {
            return Ok(None);
        }
        // Rings that touch at a point (a hole on the outline) fail the
        // strict triangulation: they are joined there into one ring.
        let strict = extrude::cap(&region, false);
        let region = if strict.is_err() {
            extrude::splice_touching(&extrude::split_touching(&region))
        } else {
            region
        };
        let cap = match strict {
            Ok(cap) => Ok(cap),
            Err(_) => extrude::cap(&region, true),
        }
        .map_err(|why| {
            ScadError::new(
                node.pos,
                format!(
                    "`{}` cannot be extruded: {why}; simplify the outline",
                    node.name
                ),
            )
        })?;
        let n = region.vertex_count() as u64;
        let levels = match e {
            Extrusion::Linear(l) => l.slices + 1,
            Extrusion::Rotate { fragments, .. } => fragments + 1,
            Extrusion::Empty => 0,
        };
        let (v, t) = (
            n.saturating_mul(levels),
            n.saturating_mul(levels).saturating_mul(2),
        );
        self.mesh_bytes = self.mesh_bytes.saturating_add(cost::mesh_bytes(v, t));
        crate::budget::current()
            .check(
                || {
                    format!(
                        "`{}` extruded ({v} vertices; with the model's meshes before it)",
                        node.name
                    )
                },
                self.mesh_bytes,
                "lower slices, $fn or the point count",
            )
            .map_err(|e| ScadError::new(node.pos, e.to_string()))?;
        let mut mesh = match e {
            Extrusion::Linear(l) => extrude::linear_mesh(&region, &cap, &l),
            Extrusion::Rotate {
                angle,
                fragments,
                min_x,
            } => extrude::rotate_mesh(&region, &cap, angle, fragments, min_x),
            Extrusion::Empty => return Ok(None),
        };
        if let Err(p) = check_closed(&mesh) {
            return Err(ScadError::new(
                node.pos,
                format!(
                    "`{}` extruded is not a closed solid ({}); simplify the outline",
                    node.name,
                    p.describe(&mesh)
                ),
            ));
        }
        let v = signed_volume(&mesh);
        if v == 0.0 || !v.is_finite() {
            return Ok(None);
        }
        if v < 0.0 {
            for t in &mut mesh.triangles {
                t.swap(1, 2);
            }
        }
        Ok(Some(mesh))
    }
}

/// `v` as OpenSCAD's "a number or [x, y]" argument (`square`'s size,
/// `linear_extrude`'s scale): a number stands for both.
fn number_or_pair(v: &Value, what: &str) -> Result<DVec2, ScadError> {
    if matches!(v.kind, ValueKind::Number(_)) {
        return Ok(DVec2::splat(args::number(v, what)?));
    }
    match args::numbers(v, what)?[..] {
        [x, y] => Ok(DVec2::new(x, y)),
        _ => Err(ScadError::new(
            v.pos,
            format!("{what} must be a number or [x, y]"),
        )),
    }
}

/// `hull`, `minkowski` and `resize` subtrees (`super::pieces`), and the
/// imported meshes.
impl Converter<'_> {
    /// Each evaluated node's pieces, bottom-up (its children's taken), in the
    /// frame of the node's parent.
    fn evaluate(
        &mut self,
        is_background_root: &[bool],
    ) -> Result<Vec<Option<Vec<Piece>>>, ScadError> {
        let tree = self.tree;
        let mut pieces: Vec<Option<Vec<Piece>>> = (0..tree.nodes.len()).map(|_| None).collect();
        for i in (0..tree.nodes.len()).rev() {
            let (Some(ctx), Some(k)) = (self.ctx[i], kind_of(&tree.nodes[i])) else {
                continue;
            };
            if ctx.inside.is_none() {
                continue;
            }
            let node = &tree.nodes[i];
            let kids: Vec<Vec<Piece>> = node
                .children
                .iter()
                .filter(|&&ch| !is_background_root[ch as usize])
                .filter_map(|&ch| pieces[ch as usize].take())
                .collect();
            let at = |e: String| ScadError::new(node.pos, format!("`{}`: {e}", node.name));
            let out = match k {
                // Outlines below a 2D `offset`, `hull` or `minkowski` are
                // their evaluated node's.
                _ if self.inside_outline[i] => Vec::new(),
                _ if is_primitive(k) && (ctx.plane.is_some() || !is_outline(k)) => {
                    match self.local(i, k, &ctx)? {
                        Some(mesh) => vec![Piece {
                            node: node.name.clone(),
                            pos: node.pos,
                            mesh,
                            rgba: self.rgba(&ctx),
                            convex: matches!(k, Kind::Cube | Kind::Sphere | Kind::Cylinder)
                                .then_some(true),
                        }],
                        None => Vec::new(),
                    }
                }
                Kind::Multmatrix => match self.own_matrix[i] {
                    Some(m) => pieces::transform(kids.concat(), &m),
                    None => kids.concat(),
                },
                Kind::Hull => pieces::hull(kids.concat(), node.pos, self.rgba(&ctx)).map_err(at)?,
                Kind::Minkowski => {
                    pieces::minkowski(kids, node.pos, self.rgba(&ctx)).map_err(at)?
                }
                Kind::Resize => {
                    let (newsize, auto) = self.resize_args(node)?;
                    let all = kids.concat();
                    match pieces::resize_scale(&all, newsize, auto) {
                        Ok(s) => pieces::transform(all, &DMat4::from_scale(s)),
                        Err(e) => {
                            self.warnings
                                .push(format!("{}:{}: `resize`: {e}", node.pos.line, node.pos.col));
                            all
                        }
                    }
                }
                _ => kids.concat(),
            };
            pieces[i] = Some(out);
        }
        Ok(pieces)
    }

    /// `resize(newsize, auto)`: `newsize` [x, y] or [x, y, z] (0: keep),
    /// `auto` a boolean or one per axis.
    fn resize_args(&mut self, node: &Node) -> Result<(DVec3, [bool; 3]), ScadError> {
        let a = Args::new(
            node,
            &["newsize", "auto", "convexity"],
            &[],
            &mut self.warnings,
        )?;
        let mut newsize = DVec3::ZERO;
        if let Some(v) = a.get("newsize") {
            let n = args::numbers(v, "`newsize` of `resize`")?;
            if !(2..=3).contains(&n.len()) {
                return Err(ScadError::new(
                    v.pos,
                    "`newsize` of `resize` must be [x, y, z] (0 keeps that axis)",
                ));
            }
            if n.iter().any(|&x| x < 0.0) {
                self.warnings.push(format!(
                    "{}:{}: a negative `newsize` of `resize` keeps that axis (as 0 does), as in OpenSCAD",
                    v.pos.line, v.pos.col
                ));
            }
            for (k, x) in n.into_iter().enumerate() {
                newsize[k] = x.max(0.0);
            }
        }
        let mut auto = [false; 3];
        if let Some(v) = a.get("auto") {
            let truth = |v: &Value| match v.kind {
                ValueKind::Bool(b) => Ok(b),
                ValueKind::Number(n) => Ok(n != 0.0),
                _ => Err(ScadError::new(
                    v.pos,
                    "`auto` of `resize` must be true, false or one of them per axis",
                )),
            };
            match &v.kind {
                ValueKind::Vector(items) => {
                    for (k, x) in items.iter().take(3).enumerate() {
                        auto[k] = truth(x)?;
                    }
                }
                _ => auto = [truth(v)?; 3],
            }
        }
        Ok((newsize, auto))
    }

    /// `file` of `import` or `surface`, relative to the `.csg` file's folder.
    fn file_arg(&self, node: &Node, a: &Args) -> Result<std::path::PathBuf, ScadError> {
        match a.get("file").map(|v| (&v.kind, v.pos)) {
            Some((ValueKind::Str(f), _)) => Ok(self.base.join(f)),
            Some((_, pos)) => Err(ScadError::new(
                pos,
                format!("`file` of `{}` must be a string", node.name),
            )),
            None => Err(ScadError::new(
                node.pos,
                format!("`{}` needs `file = \"...\"`", node.name),
            )),
        }
    }

    /// The length of an imported file; `None` (with OpenSCAD's warning: the
    /// node is the empty set, the rest renders) when it cannot be opened.
    fn file_len(&mut self, node: &Node, path: &Path) -> Option<u64> {
        match std::fs::metadata(path) {
            Ok(m) if m.is_file() => Some(m.len()),
            r => {
                let why = r.map_or_else(|e| e.to_string(), |_| "not a file".to_string());
                self.warnings.push(format!(
                    "{}:{}: `{}`: cannot open {} ({why}; the path is relative to the .csg file's folder); OpenSCAD warns and makes nothing of it, and so does peeltrim",
                    node.pos.line,
                    node.pos.col,
                    node.name,
                    path.display()
                ));
                None
            }
        }
    }

    /// Charges `bytes` of mesh to the model's budget.
    fn charge(
        &mut self,
        node: &Node,
        what: String,
        bytes: u64,
        fix: &str,
    ) -> Result<(), ScadError> {
        self.mesh_bytes = self.mesh_bytes.saturating_add(bytes);
        crate::budget::current()
            .check(
                || format!("{what} (with the model's meshes before it)"),
                self.mesh_bytes,
                fix,
            )
            .map_err(|e| ScadError::new(node.pos, e.to_string()))
    }

    /// `import(file)` of an STL or OFF mesh.
    fn import(&mut self, node: &Node) -> Result<Option<Mesh>, ScadError> {
        let a = Args::new(
            node,
            &["file", "layer", "convexity", "origin", "scale"],
            &[
                "width",
                "height",
                "filename",
                "center",
                "dpi",
                "id",
                "timestamp",
            ],
            &mut self.warnings,
        )?;
        let path = self.file_arg(node, &a)?;
        let located = |e: String| {
            ScadError::new(
                node.pos,
                format!("`import`: {e} (the path is relative to the .csg file's folder)"),
            )
        };
        let Some(len) = self.file_len(node, &path) else {
            return Ok(None);
        };
        // At least 50 bytes a triangle (binary STL; ASCII STL and OFF take more).
        self.charge(
            node,
            format!("the imported file {} ({len} bytes)", path.display()),
            cost::mesh_bytes(len / 50, len / 50 * 2),
            "simplify the mesh (fewer triangles)",
        )?;
        let mesh = mesh_import::read(&path).map_err(located)?;
        self.closed_solid(node, mesh, &path.display().to_string())
    }

    /// `surface(file, center, invert)`: a height map (`super::surface`).
    fn surface(&mut self, node: &Node) -> Result<Option<Mesh>, ScadError> {
        let a = Args::new(
            node,
            &["file", "center", "invert", "convexity"],
            &["timestamp"],
            &mut self.warnings,
        )?;
        let path = self.file_arg(node, &a)?;
        let located = |e: String| {
            ScadError::new(
                node.pos,
                format!(
                    "`surface`: {}: {e} (the path is relative to the .csg file's folder)",
                    path.display()
                ),
            )
        };
        let Some(len) = self.file_len(node, &path) else {
            return Ok(None);
        };
        // A PNG's pixels can be many more than its bytes: the decoder's own
        // limits bound those; a `.dat` has at most one value per 2 bytes.
        self.charge(
            node,
            format!("the height map {} ({len} bytes)", path.display()),
            cost::mesh_bytes(len, len * 2),
            "use a smaller height map",
        )?;
        let bytes = std::fs::read(&path).map_err(|e| located(e.to_string()))?;
        let h = surface::heights(&bytes, a.boolean("invert")?.unwrap_or(false)).map_err(located)?;
        if let Some(why) = &h.stopped {
            self.warnings.push(format!(
                "{}:{}: `surface`: {}: {why}",
                node.pos.line,
                node.pos.col,
                path.display()
            ));
        }
        let cells = h.z.len() as u64 * h.z.first().map_or(0, |r| r.len()) as u64;
        self.charge(
            node,
            format!("the height map {} ({cells} cells)", path.display()),
            cost::mesh_bytes(cells * 2, cells * 4),
            "use a smaller height map",
        )?;
        Ok(surface::mesh(&h, a.boolean("center")?.unwrap_or(false)))
    }
}

impl Converter<'_> {
    /// An imported mesh as a solid: closed (faces that disagree in orientation
    /// reversed, with a warning, as for `polyhedron`) and outward.
    fn closed_solid(
        &mut self,
        node: &Node,
        mut mesh: Mesh,
        file: &str,
    ) -> Result<Option<Mesh>, ScadError> {
        let bad = |why: String| {
            ScadError::new(
                node.pos,
                format!("`{}` of {file}: the mesh is not a closed, consistently oriented surface: {why}; repair it (close the holes) in a mesh editor", node.name),
            )
        };
        match check_closed(&mesh) {
            Ok(()) => {}
            Err(MeshProblem::SameDirection { .. }) => {
                let n = orient::reorient(&mut mesh).map_err(|p| bad(p.describe(&mesh)))?;
                self.warnings.push(format!(
                    "{}:{}: `{}` of {file}: its faces disagree in orientation; {n} triangle(s) were reversed to agree with their neighbours",
                    node.pos.line, node.pos.col, node.name
                ));
            }
            Err(p) => return Err(bad(p.describe(&mesh))),
        }
        let v = signed_volume(&mesh);
        if v < 0.0 {
            return Err(ScadError::new(
                node.pos,
                format!("`{}` of {file}: the mesh is inside out (negative signed volume: its triangles wind clockwise seen from outside); reverse the vertex order of every face", node.name),
            ));
        }
        Ok((v > 0.0).then_some(mesh))
    }
}

/// At most this many edge pairs in a 2D `minkowski` of non-convex outlines
/// (each a parallelogram for the polygon library).
const MAX_MINKOWSKI_PAIRS: u64 = 1_000_000;
/// At most this many estimated crossings of an offset's raw contours.
const MAX_OFFSET_CROSSINGS: u64 = 5_000_000;

/// Evaluated outlines (`super::outline`) and the plate of a 2D model.
impl Converter<'_> {
    /// A 2D model (2D nodes and no 3D ones) is drawn as OpenSCAD's preview
    /// draws 2D: a plate 1 unit thick centred on z = 0 (OpenSCAD 2021.01's
    /// `PolySet::render_surface` for 2D). Its plane stands for an extrusion in
    /// the extra slot `tree.nodes.len()`.
    fn plate(&mut self) -> Option<Plane> {
        let tree = self.tree;
        let mut two_d = false;
        for node in &tree.nodes {
            match kind_of(node) {
                Some(k) if is_2d_primitive(k) || k == Kind::Offset => two_d = true,
                Some(k) if is_3d_primitive(k) || is_extrusion(k) => return None,
                None if !TWO_D.contains(&node.name.as_str()) => return None,
                _ => {}
            }
        }
        if !two_d {
            return None;
        }
        let plate = tree.nodes.len();
        let l = extrude::Linear {
            h1: -0.5,
            h2: 0.5,
            twist: 0.0,
            scale: DVec2::ONE,
            slices: 1,
        };
        self.extrusion_args[plate] = Some(ExtrusionArgs::Linear {
            h1: l.h1,
            h2: l.h2,
            twist: 0.0,
            scale: DVec2::ONE,
            slices: Some(1),
            res: Resolution::default(),
        });
        self.extrusions[plate] = Some(Extrusion::Linear(l));
        self.warnings.push(
            "1:1: the model is 2D; it is drawn as OpenSCAD's preview draws 2D, a plate 1 unit thick centred on z = 0 (OpenSCAD's render and export make no solid of it)"
                .to_string(),
        );
        Some(Plane {
            extrusion: plate as u32,
            matrix: DAffine2::IDENTITY,
        })
    }

    /// The outline of `offset`, `hull` or `minkowski` node `i` from its
    /// children's (evaluated in its frame), placed by its 2D transform.
    fn outline(&mut self, i: usize, k: Kind, kids: Vec<Region>) -> Result<Region, ScadError> {
        let node = &self.tree.nodes[i];
        let r = match k {
            Kind::Offset => {
                let a = Args::new(node, &["r"], &["delta", "chamfer"], &mut self.warnings)?;
                let child = extrude::boolean(Op2::Union, kids);
                let (delta, join) = match (a.number("r")?, a.number("delta")?) {
                    (Some(r), _) => {
                        let n = self.fragments(node, &a, r.abs(), 1)?;
                        (
                            r,
                            outline::Join::Round {
                                fragments: n as f64,
                            },
                        )
                    }
                    (None, Some(d)) => (
                        d,
                        if a.boolean("chamfer")?.unwrap_or(false) {
                            outline::Join::Square
                        } else {
                            outline::Join::Miter
                        },
                    ),
                    (None, None) => {
                        let n = self.fragments(node, &a, 1.0, 1)?;
                        (
                            1.0,
                            outline::Join::Round {
                                fragments: n as f64,
                            },
                        )
                    }
                };
                let per_vertex = match join {
                    outline::Join::Round { fragments } => fragments as u64 + 3,
                    _ => 3,
                };
                // Where |delta| spans many edges, the raw contours cross each
                // other about (|delta| / mean edge length) times per edge.
                let n = child.vertex_count() as u64;
                let perimeter: f64 = child
                    .shapes
                    .iter()
                    .flatten()
                    .map(|ring| {
                        (0..ring.len())
                            .map(|j| ring[j].distance(ring[(j + 1) % ring.len()]))
                            .sum::<f64>()
                    })
                    .sum();
                // Edges within reach of one edge: along the outline, and by
                // the outline's density in its bounding box.
                let (lo, hi) = child.shapes.iter().flatten().flatten().fold(
                    (DVec2::splat(f64::MAX), DVec2::splat(f64::MIN)),
                    |(lo, hi), p| (lo.min(*p), hi.max(*p)),
                );
                let d2 = 2.0 * delta.abs();
                let area = ((hi.x - lo.x + d2) * (hi.y - lo.y + d2)).max(f64::MIN_POSITIVE);
                let mean = perimeter / n.max(1) as f64;
                let along = delta.abs() * n as f64 / perimeter.max(f64::MIN_POSITIVE);
                let around = n as f64 * d2 * (mean + d2) / area;
                let reach = along.max(around).ceil().min(n as f64) as u64;
                let crossings = n.saturating_mul(reach.saturating_add(1));
                if crossings > MAX_OFFSET_CROSSINGS {
                    return Err(ScadError::new(
                        node.pos,
                        format!("`offset` by {delta} spans about {reach} of its child's {n} outline edges each (about {crossings} crossings of the offset contours); at most {MAX_OFFSET_CROSSINGS} are accepted: use fewer, longer edges or a smaller offset"),
                    ));
                }
                self.charge_outline(node, n.saturating_mul(per_vertex).saturating_add(crossings))?;
                outline::offset(&child, delta, join)
            }
            Kind::Hull => {
                Args::new(node, &[], &[], &mut self.warnings)?;
                outline::hull(&kids)
            }
            _ => {
                Args::new(node, &[], &[], &mut self.warnings)?;
                let mut pieces = 0u64;
                let mut acc = 0u64;
                for r in &kids {
                    let n = r.vertex_count() as u64;
                    pieces =
                        pieces.saturating_add(if acc == 0 { 0 } else { acc.saturating_mul(n) });
                    acc = acc.saturating_add(n).max(1);
                }
                if pieces > MAX_MINKOWSKI_PAIRS {
                    return Err(ScadError::new(
                        node.pos,
                        format!("`minkowski` of these outlines pairs {pieces} edges; at most {MAX_MINKOWSKI_PAIRS} are accepted: use fewer points (lower $fn)"),
                    ));
                }
                self.charge_outline(node, pieces.saturating_mul(5))?;
                outline::minkowski(kids)
            }
        };
        let r = r.transformed(&self.frames[i]);
        self.check_extent(node, &r)?;
        Ok(r)
    }

    /// Charges `points` 2D points of intermediate outline against the memory
    /// budget, with the model's meshes so far.
    fn charge_outline(&mut self, node: &Node, points: u64) -> Result<(), ScadError> {
        self.charge(
            node,
            format!("`{}` with {points} outline points", node.name),
            cost::mesh_bytes(points, points),
            "lower $fn or the point count",
        )
    }

    /// Refuses outlines beyond `extrude::MAX_COORD` (the polygon library's grid).
    fn check_extent(&self, node: &Node, r: &Region) -> Result<(), ScadError> {
        let big = r
            .shapes
            .iter()
            .flatten()
            .flatten()
            .any(|p| !(p.abs().max_element() <= extrude::MAX_COORD));
        if big {
            return Err(ScadError::new(
                node.pos,
                format!(
                    "`{}` reaches coordinates beyond ±{:e} (after its transforms); scale the model down",
                    node.name,
                    extrude::MAX_COORD
                ),
            ));
        }
        Ok(())
    }
}
