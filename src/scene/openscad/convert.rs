//! The `.csg` tree → our primitives and one CSG [`Expr`], following OpenSCAD
//! 2021.01's CSG-tree evaluation (`CSGTreeEvaluator`, `CSGOperation::
//! createCSGNode`):
//!
//! - `group`/`union`/`render` → union; `difference` → the first child minus the
//!   union of the rest; `intersection`. Unions and intersections are built
//!   balanced (depth log n) rather than left-deep.
//! - A child that yields no node (an empty group, a `*` disabled or `%`
//!   background subtree) vanishes from its parent's child list, as in OpenSCAD's
//!   pruned tree; a degenerate primitive (`sphere(0)`) is the empty set and
//!   follows the set algebra (`A ∩ ∅ = ∅`, `A − ∅ = A`).
//! - `multmatrix` composes (row-major as printed); `color` colours the primitives
//!   below it, the outermost `color` winning as in 2021.01; `#` highlights.
//! - `!` makes the first such node the only root (its ancestors' transforms are
//!   not applied, as in OpenSCAD).
//!
//! Three passes over the pre-order arena, none recursive: top-down contexts
//! (ascending index), primitives in order of appearance, bottom-up operators
//! (descending index).

use glam::{DMat4, DVec3};

use super::args::{self, Args};
use super::parse::{Node, Tree, ValueKind};
use super::tessellate::{self, Resolution, F_MINIMUM};
use super::{ScadError, ScadPrimitive};
use crate::csg::expr::{Node as E, NodeId};
use crate::csg::Expr;
use crate::scene::cost;
use crate::scene::load::{MAX_DIVISIONS, MAX_GRID};
use crate::scene::validate::{check_closed, signed_volume, MeshProblem};
use crate::scene::Mesh;

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
        _ => return None,
    })
}

const SUPPORTED: &str = "multmatrix, cube, sphere, cylinder, polyhedron, union, difference, intersection, group, color, render";
const TWO_D: &[&str] = &[
    "square",
    "circle",
    "polygon",
    "text",
    "offset",
    "projection",
    "import",
    "surface",
];

fn is_primitive(k: Kind) -> bool {
    matches!(
        k,
        Kind::Cube | Kind::Sphere | Kind::Cylinder | Kind::Polyhedron
    )
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

pub fn convert(tree: &Tree, skip_unsupported: bool) -> Result<Converted, ScadError> {
    let mut c = Converter {
        tree,
        skip_unsupported,
        warnings: Vec::new(),
        ctx: vec![None; tree.nodes.len()],
        background_roots: Vec::new(),
        mesh_bytes: 0,
        unsupported: Vec::new(),
    };
    let roots = c.roots();
    let base = Ctx {
        matrix: DMat4::IDENTITY,
        color: None,
        highlight: false,
        negated: false,
        background: false,
    };
    for &r in &roots {
        c.ctx[r as usize] = c.enter(r, base)?;
    }
    // Top-down: a parent's index is below its children's.
    for i in 0..tree.nodes.len() {
        let Some(ctx) = c.ctx[i] else { continue };
        let node = &tree.nodes[i];
        let is_diff = kind(&node.name) == Some(Kind::Difference);
        for (k, &ch) in node.children.iter().enumerate() {
            let mut child = ctx;
            child.negated ^= is_diff && k > 0;
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
    // Warnings in file order (nodes are entered level by level).
    c.warnings.sort_by_key(|w| warning_pos(w));
    // Primitives in order of appearance.
    let mut out = Vec::new();
    let mut nodes: Vec<E> = Vec::new();
    let mut term: Vec<Option<Term>> = vec![None; tree.nodes.len()];
    for (i, slot) in term.iter_mut().enumerate() {
        let (Some(ctx), Some(k)) = (c.ctx[i], kind(&tree.nodes[i].name)) else {
            continue;
        };
        if !is_primitive(k) {
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
    // A background root's term is its own set, not its parent's child. In order
    // of appearance (the arena's pre-order; top-level nodes are entered first).
    c.background_roots.sort_unstable();
    let mut is_background_root = vec![false; tree.nodes.len()];
    for &r in &c.background_roots {
        is_background_root[r as usize] = true;
    }
    // Operators bottom-up.
    for i in (0..tree.nodes.len()).rev() {
        let (Some(_), Some(k)) = (c.ctx[i], kind(&tree.nodes[i].name)) else {
            continue;
        };
        if is_primitive(k) {
            continue;
        }
        let kids: Vec<Term> = tree.nodes[i]
            .children
            .iter()
            .filter(|&&ch| !is_background_root[ch as usize])
            .filter_map(|&ch| term[ch as usize])
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
    warnings: Vec<String>,
    ctx: Vec<Option<Ctx>>,
    /// The outermost `%` nodes entered.
    background_roots: Vec<u32>,
    /// Estimated bytes of the meshes tessellated so far (`scene::cost`).
    mesh_bytes: u64,
    /// Unsupported nodes met (without --skip-unsupported), each with what it is.
    unsupported: Vec<(super::Pos, String)>,
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
        let Some(k) = kind(&node.name) else {
            let what = if TWO_D.contains(&node.name.as_str()) {
                format!("`{}` (a 2D shape or an import)", node.name)
            } else {
                format!("`{}`", node.name)
            };
            if self.skip_unsupported || ctx.background {
                let why = if ctx.background {
                    "in a `%` background part"
                } else {
                    "--skip-unsupported"
                };
                self.warnings.push(format!(
                    "{at}: {what} is not supported and was dropped with its children ({why}): the picture lacks it"
                ));
                return Ok(None);
            }
            // Reported with every other one once all are found.
            self.unsupported.push((node.pos, what));
            return Ok(None);
        };
        if is_primitive(k) && !node.children.is_empty() {
            return Err(ScadError::new(
                node.pos,
                format!("`{}` takes no children: end it with `;`", node.name),
            ));
        }
        ctx.highlight |= node.modifiers.highlight;
        match k {
            Kind::Multmatrix => ctx.matrix = parent.matrix * self.matrix(node)?,
            Kind::Color => {
                let c = self.color(node)?;
                ctx.color = parent.color.or(Some(c));
            }
            _ => {}
        }
        Ok(Some(ctx))
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
            let nums = args::numbers(row, what)?;
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
        let tree = self.tree;
        let node = &tree.nodes[i];
        let local = match k {
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
            _ => unreachable!("only primitives are tessellated"),
        };
        let Some(local) = local else {
            return Ok(None);
        };
        let det = ctx.matrix.determinant();
        if !det.is_finite() || det.abs() < 1e-300 {
            self.warnings.push(format!(
                "{}:{}: `{}` is flattened by a singular multmatrix (determinant {det}); it encloses no volume and is the empty set",
                node.pos.line, node.pos.col, node.name
            ));
            return Ok(None);
        }
        let rgba = if ctx.background {
            BACKGROUND_COLOR
        } else if ctx.highlight {
            HIGHLIGHT_COLOR
        } else {
            ctx.color
                .unwrap_or(if ctx.negated { BACK_COLOR } else { FRONT_COLOR })
        };
        Ok(Some(ScadPrimitive {
            node: node.name.clone(),
            line: node.pos.line,
            mesh: crate::scene::shapes::apply_transform(&local, &ctx.matrix),
            matrix: ctx.matrix,
            rgba,
        }))
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
        let mut res = Resolution::default();
        if let Some(v) = a.get("$fn") {
            res.fn_ = args::number(v, "`$fn`")?;
        }
        for (name, slot) in [("$fa", &mut res.fa), ("$fs", &mut res.fs)] {
            if let Some(v) = a.get(name) {
                *slot = args::number(v, &format!("`{name}`"))?;
                if *slot < F_MINIMUM {
                    self.warnings.push(format!(
                        "{}:{}: {name} = {} is too small; clamped to {F_MINIMUM} as OpenSCAD does",
                        v.pos.line, v.pos.col, *slot
                    ));
                    *slot = F_MINIMUM;
                }
            }
        }
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
        let points = args::vector(pv, "`points` of `polyhedron`")?
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
        let Some(mesh) = tessellate::polyhedron(points, &faces) else {
            return Ok(None);
        };
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
            return Err(bad(
                "it is inside out (its faces are counter-clockwise seen from outside); OpenSCAD lists each face clockwise seen from outside: reverse the point order of every face".to_string(),
            ));
        }
        if v == 0.0 {
            return Ok(None);
        }
        Ok(Some(mesh))
    }
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
