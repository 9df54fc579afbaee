//! Constructive Solid Trimming (Hable & Rossignac, seed 000 §4–5, §7): CSG rendered
//! as the union of CST(P, Z(P)) over the leaves P, where Z(P) is P's active zone.
//!
//! [`cst`] is CST(S, V) for one surface: peel S layer by layer at unlocked pixels,
//! trim each layer against the Blist of V with parity draws and ChangeStencilState
//! sweeps, lock the pixels whose candidate is in V (label `T`), push the others back
//! (label reset, far depth) and stop when an occlusion query says the peel reached no
//! pixel. Render(S) then merges the kept points into the final image by the depth
//! test, shading only where a fragment's depth equals the kept depth bit-exactly
//! ([`Fragment::ShadeAtDepth`]).
//!
//! Variants (seed 000 §7, §8):
//! - `cst-z`: trim against the Z form (i-nodes and complemented u-nodes), peel both
//!   faces;
//! - `cst-i`: trim against the i-nodes only, peel only the front faces of positive
//!   and the back faces of negative leaves (optimizations 1 and 2);
//! - `cst-g`: as `cst-i`, with same-operator leaves grouped and classified by a
//!   stencil counter (optimization 3; see [`group`]).
//!
//! Resources: depth-stencil 0 is the peel's CurrDepthStencil (depth *Back*, stencil
//! `[label | parity]`), depth-stencil 1 is *FinalColorDepth*; texture 0 is
//! *PrevDepth* (*Front*), texture 1 the layer the peel records (exact `f32` depths).
//!
//! **Overlaps** (seed 000 §5). Coincident faces are decided by a symbolic
//! perturbation chosen per parity draw through its depth compare: a face of Q at the
//! candidate's depth counts as "in front" (`LessOrEqual`) or not (`Less`). Parity
//! draws count the faces at or in front of the candidate, so this classifies the
//! candidate as if Q's face were moved slightly towards or away from the eye. For a
//! candidate X on a front face of the leaf P (the visible layer) and a literal Q of its
//! zone, writing "earlier" for the lower (primitive, leaf) index:
//! - Q in a u-node (their lowest common ancestor is a union): if Q is earlier, its
//!   face counts in front (X is in Q: P loses to Q), else not (X is out of Q: P wins).
//!   With equally oriented faces exactly one of them keeps the point, the earlier.
//! - Q in an i-node (common ancestor an intersection): if Q is later, `LessOrEqual`
//!   (X is in Q when their faces agree in orientation: P keeps it; out of Q when
//!   they are opposed: a zero-thickness sheet, dropped). If Q is earlier, its literal
//!   front faces are drawn with `Less` (X out of Q: P loses to Q) and its literal back
//!   faces with `LessOrEqual` (X out of Q: the sheet is dropped) — two culled draws.
//!
//! So where two primitives' faces coincide on the visible boundary the lower index
//! is kept and the other trimmed away (CONTRACT §4), a zero-thickness contact of an
//! intersection or a flush cut of a difference shows nothing, and the merge compares
//! with `Less` in leaf order so an exact depth tie keeps the earlier primitive too.
#![deny(unsafe_code)]

pub mod group;

use std::collections::HashSet;

use super::stencil::{self, LabelLayout, Next};
use super::step::*;
use super::{Algo, PlanError, Prepared, SHADE_EPS};
use crate::csg::active_zone::ActiveZones;
use crate::csg::{Blist, BlistEntry, LeafId, PNode, PNodeId, PositiveExpr, Restricted, Target};
use crate::scene::{Aabb, Keep};

/// CurrDepthStencil: candidate depth and `[label | parity]`.
pub const WORK: Ds = 0;
/// FinalColorDepth: the merged result.
pub const FINAL: Ds = 1;
/// PrevDepth (*Front*): the previous layer, read by the peel.
pub const PREV: Tex = 0;
/// The layer the peel records; after the loop, the kept depth (or far).
pub const CUR: Tex = 1;
const FAR: f32 = 1.0;

/// Which variant of seed 000 §8.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Variant {
    Z,
    I,
    G,
}

impl Variant {
    pub fn algo(self) -> Algo {
        match self {
            Variant::Z => Algo::CstZ,
            Variant::I => Algo::CstI,
            Variant::G => Algo::CstG,
        }
    }
}

pub(crate) fn next(t: Target) -> Next {
    match t {
        Target::Label(l) => Next::Label(l),
        Target::True => Next::True,
        Target::False => Next::False,
    }
}

/// The leaf whose boundary is peeled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Peeled {
    pub prim: MeshId,
    pub leaf: LeafId,
    pub negated: bool,
}

impl Peeled {
    /// Total order of seed 000 §5 ("L is considered slightly in front of R"):
    /// primitive index, then leaf occurrence.
    pub fn earlier(&self, prim: u32, leaf: LeafId) -> bool {
        (prim, leaf) < (self.prim, self.leaf)
    }
}

/// How a trimming literal relates to the peeled leaf: the operator of their lowest
/// common ancestor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Relation {
    /// The literal lies in an i-node of the peeled leaf.
    Inter,
    /// The literal lies in a (complemented) u-node.
    Union,
    /// The peeled mesh is a `[[surface]]` trimmed by a volume it is no part of: a
    /// candidate is classified with the primitive states just before it (faces
    /// coincident with it are not yet crossed), as the reference does.
    Surface,
}

/// The parity draws (depth compare, culling) that classify candidates of `peeled`
/// against the mesh of literal `(prim, leaf, negated)`; see the module comment.
pub fn tie_draws(
    peeled: &Peeled,
    prim: u32,
    leaf: LeafId,
    negated: bool,
    rel: Relation,
) -> Vec<(CompareOp, Cull)> {
    let earlier = peeled.earlier(prim, leaf);
    match (rel, earlier) {
        (Relation::Surface, _) => vec![(CompareOp::Less, Cull::None)],
        (Relation::Union, true) => vec![(CompareOp::LessOrEqual, Cull::None)],
        (Relation::Union, false) => vec![(CompareOp::Less, Cull::None)],
        (Relation::Inter, false) => vec![(CompareOp::LessOrEqual, Cull::None)],
        (Relation::Inter, true) => {
            // Literal front faces are mesh front faces unless the literal is negated.
            let (keep_lit_front, keep_lit_back) = if negated {
                (Cull::Front, Cull::Back)
            } else {
                (Cull::Back, Cull::Front)
            };
            vec![
                (CompareOp::Less, keep_lit_front),
                (CompareOp::LessOrEqual, keep_lit_back),
            ]
        }
    }
}

/// The trimming volume of one CST: a Blist with, per entry, its relation to the
/// peeled leaf.
#[derive(Clone, Debug)]
pub struct TrimVolume {
    pub blist: Blist,
    pub relation: Vec<Relation>,
}

/// One leaf's CST: what is peeled, how, and against what.
#[derive(Clone, Debug)]
pub struct LeafCst {
    pub peeled: Peeled,
    pub peel_cull: Cull,
    /// `None`: the zone is the universe (no trimming).
    pub volume: Option<TrimVolume>,
    /// The zone's expression (`None` for the universe).
    pub zone: Option<PositiveExpr>,
}

/// Leaves of the positive form under node `n` (iterative).
fn leaves_under(pos: &PositiveExpr, n: PNodeId, out: &mut HashSet<LeafId>) {
    let mut stack = vec![n];
    while let Some(n) = stack.pop() {
        match pos.nodes[n as usize] {
            PNode::Leaf { leaf, .. } => {
                out.insert(leaf);
            }
            PNode::Union(a, b) | PNode::Inter(a, b) => {
                stack.push(a);
                stack.push(b);
            }
            PNode::Universe => {}
        }
    }
}

/// Boxes that share no point (a gap on some axis); touching boxes overlap.
pub(crate) fn disjoint(a: &Aabb, b: &Aabb) -> bool {
    a.max.cmplt(b.min).any() || b.max.cmplt(a.min).any()
}

/// The per-leaf CSTs of a variant, in merge order (primitive, then leaf).
///
/// With `boxes` (world bounds per mesh; empty for none), each zone is restricted
/// to the primitives whose boxes meet the leaf's: elsewhere on the leaf's
/// boundary a primitive is outside, so `!P` is true and `P` false there. A block
/// minus n disjoint spheres then trims each sphere against the block only — O(n)
/// trim draws instead of O(n²) — and a leaf whose zone becomes empty is skipped.
///
/// `eye_inside` (per mesh; empty for none) flips the zone literals of primitives
/// that contain the eye: their parity counted from the near plane is inverted.
/// The leaf's own peel (which faces) is unchanged.
pub fn leaf_csts(
    pos: &PositiveExpr,
    variant: Variant,
    boxes: &[Aabb],
    eye_inside: &[bool],
) -> Vec<LeafCst> {
    let zones = ActiveZones::new(pos);
    let mut lits = pos.literals();
    lits.sort_by_key(|l| (l.prim, l.leaf));
    let mut out = Vec::with_capacity(lits.len());
    let mut untrimmed = HashSet::new();
    for lit in lits {
        let peeled = Peeled {
            prim: lit.prim,
            leaf: lit.leaf,
            negated: lit.negated,
        };
        let (zone, u_leaves) = match variant {
            Variant::Z => {
                let mut u = HashSet::new();
                for n in zones.u_nodes(lit.leaf) {
                    leaves_under(pos, n, &mut u);
                }
                (zones.z_form(lit.leaf), u)
            }
            Variant::I | Variant::G => (zones.i_form(lit.leaf), HashSet::new()),
        };
        let zone = match boxes.get(lit.prim as usize) {
            Some(own) if !zone.is_universe() => {
                match zone.restrict(|l| disjoint(own, &boxes[l.prim as usize]).then_some(l.negated))
                {
                    Restricted::Constant(false) => continue,
                    Restricted::Constant(true) => PositiveExpr::universe(),
                    Restricted::Expr(z) => z,
                }
            }
            _ => zone,
        };
        let zone = zone.flip_literals(|p| eye_inside.get(p as usize).copied().unwrap_or(false));
        // With the eye inside a primitive the solid's exit points are no longer
        // hidden behind its entry points, so Z too peels entry faces only.
        let eye_in_any = eye_inside.iter().any(|&b| b);
        let peel_cull = match variant {
            Variant::Z if !eye_in_any => Cull::None,
            // Opaque rendering: front faces of positive, back faces of negative leaves.
            Variant::Z | Variant::I | Variant::G => {
                if lit.negated {
                    Cull::Front
                } else {
                    Cull::Back
                }
            }
        };
        let universe = zone.is_universe();
        // An untrimmed leaf draws its primitive's faces as they are: a second leaf
        // of the same primitive, sign and peel draws the same points again and
        // loses every depth tie of the merge, so it is skipped (`A + B + A + …`
        // with 10⁵ leaves is two CSTs).
        if universe && !untrimmed.insert((lit.prim, lit.negated, peel_cull)) {
            continue;
        }
        let volume = (!universe).then(|| {
            let blist = Blist::new(&zone);
            let relation = blist
                .entries
                .iter()
                .map(|e| {
                    if u_leaves.contains(&e.leaf) {
                        Relation::Union
                    } else {
                        Relation::Inter
                    }
                })
                .collect();
            TrimVolume { blist, relation }
        });
        out.push(LeafCst {
            peeled,
            peel_cull,
            volume,
            zone: (!universe).then_some(zone),
        });
    }
    out
}

/// A full-screen stencil-only sweep on the work image (depth test off).
pub(crate) fn sweep(scissor: Scissor, stencil: StencilState) -> Step {
    Step::Draw(Draw {
        geometry: Geometry::FullScreen { depth: 0.0 },
        scissor,
        cull: Cull::None,
        ds: WORK,
        depth: DepthState {
            compare: CompareOp::Always,
            write: false,
        },
        stencil: Some(stencil),
        fragment: Fragment::None,
        count_samples: false,
    })
}

/// The signed tolerance of a parity draw's compare against the candidate's exact
/// depth (texture [`CUR`]): `LessOrEqual` keeps faces up to [`SHADE_EPS`] behind the
/// candidate (a coincident face counts as in front whatever the rounding), `Less`
/// keeps only faces more than [`SHADE_EPS`] in front of it (a coincident face
/// never counts). So the symbolic perturbation of seed 000 §5 survives different
/// tessellations and rounding of the same plane.
pub fn tie_eps(compare: CompareOp) -> f32 {
    match compare {
        CompareOp::LessOrEqual => SHADE_EPS,
        CompareOp::Less => -SHADE_EPS,
        other => panic!("parity draws compare with Less or LessOrEqual, not {other:?}"),
    }
}

/// A parity draw of `mesh` over the candidates at label `here`: depth test off, the
/// fragment keeps the faces in front of the candidate's exact depth within the
/// tolerance of [`tie_eps`].
pub(crate) fn parity_draw(
    mesh: MeshId,
    compare: CompareOp,
    cull: Cull,
    stencil: StencilState,
) -> Step {
    Step::Draw(Draw {
        geometry: Geometry::Mesh(mesh),
        scissor: Scissor::BoundsOf(vec![mesh]),
        cull,
        ds: WORK,
        depth: DepthState {
            compare: CompareOp::Always,
            write: false,
        },
        stencil: Some(stencil),
        fragment: Fragment::NearerThan {
            tex: CUR,
            eps: tie_eps(compare),
        },
        count_samples: false,
    })
}

/// Trim(V) against a plain Blist (seed 000 §4): per entry, its parity draw(s) and two
/// ChangeStencilState sweeps (parity set → the literal's "in" target, clear → "out").
///
/// `facing`: a stencil bit (outside the layout) in which the peel recorded whether
/// the candidate lies on a back face of the mesh (cst-z peels both faces). The tie
/// rules of [`tie_draws`] are written for candidates on a front face of the peeled
/// literal; for one on a back face of the literal they mirror (counting the faces
/// at or behind a candidate is counting those strictly in front of it, modulo the
/// even number of faces along the ray): `Less` ↔ `LessOrEqual`, except for an
/// earlier literal of an i-node (shrunk either way). Without it the point kept at
/// a back face coincident with a subtracted primitive's face would be a sliver.
fn trim_blist(
    peeled: &Peeled,
    vol: &TrimVolume,
    layout: &LabelLayout,
    facing: u8,
    steps: &mut Vec<Step>,
) {
    let label_mask = layout.label_mask();
    let all_mask = layout.all_mask();
    let me = vec![peeled.prim];
    for (e, &rel) in vol.blist.entries.iter().zip(&vol.relation) {
        let here = layout.value(Next::Label(e.label));
        let (on_inside, on_outside) = entry_targets(e);
        let shrunk = rel == Relation::Inter && peeled.earlier(e.prim, e.leaf);
        for (compare, cull) in tie_draws(peeled, e.prim, e.leaf, e.negated, rel) {
            if facing == 0 || shrunk {
                steps.push(parity_draw(
                    e.prim,
                    compare,
                    cull,
                    stencil::toggle_parity(here, label_mask, LabelLayout::PARITY),
                ));
                continue;
            }
            // Candidates on a front face of the literal: mesh front faces (bit
            // clear) of a positive leaf, mesh back faces (bit set) of a negated one.
            let lit_front = if peeled.negated { facing } else { 0 };
            let mirrored = match compare {
                CompareOp::Less => CompareOp::LessOrEqual,
                _ => CompareOp::Less,
            };
            for (value, compare) in [(lit_front, compare), (lit_front ^ facing, mirrored)] {
                steps.push(parity_draw(
                    e.prim,
                    compare,
                    cull,
                    stencil::toggle_parity(here | value, label_mask | facing, LabelLayout::PARITY),
                ));
            }
        }
        let inside = sweep(
            Scissor::BoundsOf(vec![e.prim]),
            stencil::change_stencil_state(
                here | LabelLayout::PARITY,
                layout.value(on_inside),
                all_mask,
            ),
        );
        let outside = sweep(
            Scissor::BoundsOf(me.clone()),
            stencil::change_stencil_state(here, layout.value(on_outside), all_mask),
        );
        // A freed label may be reused by the entry's own target (seed 000 Fig. 11):
        // then the pixels moved there must not be swept again by the other rule.
        if layout.value(on_inside) == here {
            steps.extend([outside, inside]);
        } else if layout.value(on_outside) == here {
            steps.push(inside);
        } else {
            steps.extend([inside, outside]);
        }
    }
}

/// Targets of an entry for a point inside / outside its mesh.
pub(crate) fn entry_targets(e: &BlistEntry) -> (Next, Next) {
    if e.negated {
        (next(e.if_false), next(e.if_true))
    } else {
        (next(e.if_true), next(e.if_false))
    }
}

/// How Trim(V) is done for one CST, with the stencil values it needs.
pub trait Trimmer {
    /// Stencil value of an unlocked pixel about to be classified (parity clear).
    fn start(&self) -> u8;
    /// Stencil value of a locked pixel (candidate in V).
    fn locked(&self) -> u8;
    /// Stencil value of a rejected pixel after the trim.
    fn rejected(&self) -> u8;
    /// All stencil bits in use.
    fn mask(&self) -> u8;
    fn bits(&self) -> u8;
    fn trim(&self, steps: &mut Vec<Step>);
    /// A stencil bit, outside [`Trimmer::mask`], in which the peel records that the
    /// candidate lies on a back face (set) or front face (clear); 0: not recorded.
    fn facing_bit(&self) -> u8 {
        0
    }
}

struct BlistTrimmer<'a> {
    peeled: Peeled,
    vol: &'a TrimVolume,
    layout: LabelLayout,
    start: u8,
    /// See [`trim_blist`]; 0: none.
    facing: u8,
}

impl Trimmer for BlistTrimmer<'_> {
    fn start(&self) -> u8 {
        self.start
    }
    fn locked(&self) -> u8 {
        self.layout.value(Next::True)
    }
    fn rejected(&self) -> u8 {
        self.layout.value(Next::False)
    }
    fn mask(&self) -> u8 {
        self.layout.all_mask()
    }
    fn bits(&self) -> u8 {
        self.layout.stencil_bits()
    }
    fn trim(&self, steps: &mut Vec<Step>) {
        trim_blist(&self.peeled, self.vol, &self.layout, self.facing, steps)
    }
    fn facing_bit(&self) -> u8 {
        self.facing
    }
}

/// How many layers of a surface the peel may need.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layers {
    /// Unknown: loop until an occlusion query says the peel reached no pixel (at
    /// most this many times).
    AtMost(u32),
    /// Exactly this many peels suffice (seed 000 §4: a convex surface needs one
    /// pass when only front faces are trimmed, two otherwise): the loop is
    /// unrolled, with no occlusion query, no empty last peel and no extra submits.
    Known(u32),
}

impl Layers {
    /// The bound for the mesh `m` peeled with `cull`.
    pub fn of(prep: &Prepared, m: MeshId, cull: Cull) -> Layers {
        if prep.mesh_convex.get(m as usize).copied().unwrap_or(false) {
            Layers::Known(if cull == Cull::None { 2 } else { 1 })
        } else {
            // A front-face (or back-face) peel of a closed mesh has at most half its
            // faces per pixel; both faces at most all of them.
            Layers::AtMost(prep.mesh_triangles[m as usize] as u32 + 1)
        }
    }
}

/// CST(S, V) merged into [`FINAL`] (seed 000 §4): `Initialize; Repeat {Peel(S);
/// Trim(V); Push()} until Done; Render(S)`. `trimmer: None` means V is the universe:
/// the first layer of S is drawn directly.
pub fn cst(
    surface: MeshId,
    peel_cull: Cull,
    trimmer: Option<&dyn Trimmer>,
    layers: Layers,
    merge: Merge,
    steps: &mut Vec<Step>,
) {
    let me = vec![surface];
    let Some(t) = trimmer else {
        steps.push(Step::Pass("merge".into()));
        steps.push(Step::Draw(Draw {
            geometry: Geometry::Mesh(surface),
            scissor: Scissor::BoundsOf(me),
            cull: peel_cull,
            ds: FINAL,
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: merge.stencil(),
            fragment: Fragment::Shade,
            count_samples: false,
        }));
        merge.paint(surface, peel_cull, steps);
        return;
    };
    steps.push(Step::Pass("init".into()));
    steps.push(Step::Clear(Clear::DepthStencil {
        ds: WORK,
        depth: FAR,
        stencil: t.start(),
    }));
    steps.push(Step::Clear(Clear::Texture {
        tex: PREV,
        depth: 0.0,
    }));
    steps.push(Step::Clear(Clear::Texture {
        tex: CUR,
        depth: FAR,
    }));

    // Peel(S): the nearest face strictly behind Front, at unlocked pixels only.
    let head = vec![
        Step::Pass("peel".into()),
        Step::Draw(Draw {
            geometry: Geometry::Mesh(surface),
            scissor: Scissor::BoundsOf(me.clone()),
            cull: peel_cull,
            ds: WORK,
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: Some(match t.facing_bit() {
                0 => stencil::test_equal(t.start(), t.mask()),
                fb => {
                    // The nearest fragment passes the depth test last, so its
                    // orientation is what stays in the bit.
                    let face = |pass| StencilFace {
                        compare: CompareOp::Equal,
                        fail: StencilOp::Keep,
                        pass,
                        depth_fail: StencilOp::Keep,
                    };
                    StencilState {
                        front: face(StencilOp::Zero),
                        back: face(StencilOp::Replace),
                        compare_mask: t.mask(),
                        write_mask: fb,
                        reference: t.start() | fb,
                    }
                }
            }),
            fragment: Fragment::Peel {
                prev: PREV,
                out: CUR,
                shade: false,
            },
            count_samples: true,
        }),
    ];
    let mut tail = vec![Step::Pass("trim".into())];
    t.trim(&mut tail);
    // Push(): rejected candidates go back to the start label with a far depth, so the
    // next peel advances them; locked ones (label T) keep their depth.
    tail.push(Step::Pass("push".into()));
    tail.push(Step::Draw(Draw {
        geometry: Geometry::FullScreen { depth: FAR },
        scissor: Scissor::BoundsOf(me.clone()),
        cull: Cull::None,
        ds: WORK,
        depth: DepthState {
            compare: CompareOp::Always,
            write: true,
        },
        stencil: Some(stencil::change_stencil_state(
            t.rejected(),
            t.start(),
            t.mask(),
        )),
        fragment: Fragment::None,
        count_samples: false,
    }));
    tail.push(Step::CopyTexture {
        src: CUR,
        dst: PREV,
    });
    match layers {
        Layers::AtMost(max_iterations) => steps.push(Step::Loop(Loop {
            head,
            tail,
            max_iterations,
        })),
        Layers::Known(n) => {
            for i in 0..n {
                steps.extend(head.iter().cloned().map(|mut s| {
                    if let Step::Draw(d) = &mut s {
                        d.count_samples = false;
                    }
                    s
                }));
                // The last layer's copy to PrevDepth would feed no peel.
                let last = i + 1 == n;
                steps.extend(
                    tail.iter()
                        .filter(|s| !(last && matches!(s, Step::CopyTexture { .. })))
                        .cloned(),
                );
            }
        }
    }

    // Render(S). After the loop every pixel without a kept point has a far depth in
    // WORK (never peeled, pushed, or locked only because nothing was left to peel):
    // make the recorded layer far there too, then shade S where its depth equals it.
    steps.push(Step::Pass("merge".into()));
    steps.push(Step::Draw(Draw {
        geometry: Geometry::FullScreen { depth: FAR },
        scissor: Scissor::BoundsOf(me.clone()),
        cull: Cull::None,
        ds: WORK,
        depth: DepthState {
            compare: CompareOp::Equal,
            write: false,
        },
        stencil: None,
        fragment: Fragment::WriteDepth { out: CUR },
        count_samples: false,
    }));
    steps.push(Step::Draw(Draw {
        geometry: Geometry::Mesh(surface),
        scissor: Scissor::BoundsOf(me),
        cull: peel_cull,
        ds: FINAL,
        depth: DepthState {
            compare: CompareOp::Less,
            write: true,
        },
        stencil: merge.stencil(),
        fragment: Fragment::ShadeAtDepth { tex: CUR },
        count_samples: false,
    }));
    merge.paint(surface, peel_cull, steps);
}

/// Stencil bit of [`FINAL`] set where a `[[surface]]` won the merge: the final
/// depth-equal shading of the solids' meshes skips those pixels (a surface point
/// keeps its own colour, or its paint colour, even where a solid face passes
/// within [`SHADE_EPS`] of it).
pub const SURFACE_MARK: u8 = 0x01;
/// Stencil bit of [`FINAL`] set by a painted surface's merge and cleared by its
/// paint draw.
pub const PAINT_PENDING: u8 = 0x02;

/// How Render(S) writes into [`FINAL`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Merge {
    /// Mark the pixels won with [`SURFACE_MARK`] (surfaces; solids merge first).
    pub mark: bool,
    /// Repaint the pixels won in this colour (CST painting, seed 000 §6).
    pub paint: Option<[u8; 3]>,
}

impl Merge {
    /// A solid's leaf: shaded, unmarked.
    pub const SOLID: Merge = Merge {
        mark: false,
        paint: None,
    };

    fn stencil(&self) -> Option<StencilState> {
        let bits = match (self.mark, self.paint.is_some()) {
            (false, false) => return None,
            (true, false) => SURFACE_MARK,
            (false, true) => PAINT_PENDING,
            (true, true) => SURFACE_MARK | PAINT_PENDING,
        };
        Some(stencil::both(
            CompareOp::Always,
            StencilOp::Replace,
            0,
            bits,
            bits,
        ))
    }

    /// After the shaded merge: S again at exactly the depth it left in [`FINAL`]
    /// (the same rasterization reproduces it bit-exactly), in the paint colour, at
    /// the pixels this merge won; clears their pending bit.
    fn paint(&self, surface: MeshId, cull: Cull, steps: &mut Vec<Step>) {
        let Some(rgb) = self.paint else { return };
        steps.push(Step::Draw(Draw {
            geometry: Geometry::Mesh(surface),
            scissor: Scissor::BoundsOf(vec![surface]),
            cull,
            ds: FINAL,
            depth: DepthState {
                compare: CompareOp::Equal,
                write: false,
            },
            stencil: Some(stencil::both(
                CompareOp::Equal,
                StencilOp::Zero,
                PAINT_PENDING,
                PAINT_PENDING,
                PAINT_PENDING,
            )),
            fragment: Fragment::Paint { rgb },
            count_samples: false,
        }));
    }
}

/// One CST of the plan: a leaf of the solid with its zone, or a surface with its
/// trimming volume.
struct Job {
    c: LeafCst,
    merge: Merge,
    surface: bool,
}

/// The CSTs that draw the scene's surfaces (seed 000 §4, §6): CST(S, V) for
/// `keep = "in"`, CST(S, !V) for `"out"`, both for `"paint"` (V in the paint
/// colour). An open S has no inside: both faces are peeled, and the loop stops on
/// the occlusion query (no convexity is assumed).
fn surface_jobs(prep: &Prepared) -> Vec<Job> {
    let mut jobs = Vec::new();
    for s in &prep.surfaces {
        let peeled = Peeled {
            prim: s.mesh,
            leaf: 0,
            negated: false,
        };
        let job = |zone: &PositiveExpr, paint: Option<[u8; 3]>| {
            let universe = zone.is_universe();
            let volume = (!universe).then(|| {
                let blist = Blist::new(zone);
                let relation = vec![Relation::Surface; blist.entries.len()];
                TrimVolume { blist, relation }
            });
            Job {
                c: LeafCst {
                    peeled,
                    peel_cull: Cull::None,
                    volume,
                    zone: (!universe).then(|| zone.clone()),
                },
                merge: Merge { mark: true, paint },
                surface: true,
            }
        };
        match s.keep {
            Keep::In => jobs.push(job(&s.trim, None)),
            Keep::Out => jobs.push(job(&s.trim_out, None)),
            Keep::Paint => {
                jobs.push(job(&s.trim, Some(s.paint_color)));
                jobs.push(job(&s.trim_out, None));
            }
        }
    }
    jobs
}

/// Builds the CST plan of the prepared scene's solid(s) and surfaces.
pub fn plan(prep: &Prepared, variant: Variant) -> Result<Plan, PlanError> {
    let solid = prep.has_solid() && !prep.positive.literals().is_empty();
    if !solid && prep.surfaces.is_empty() {
        return Err(PlanError::NoSolid);
    }
    super::budget::check_cst(prep, variant)?;
    let mut jobs: Vec<Job> = if solid {
        leaf_csts(&prep.positive, variant, &prep.mesh_bounds, &prep.eye_inside)
            .into_iter()
            .map(|c| Job {
                c,
                merge: Merge::SOLID,
                surface: false,
            })
            .collect()
    } else {
        Vec::new()
    };
    // Surfaces merge after the solids with `Less`: a solid point wins an exact tie
    // (the reference keeps the solid unless a surface is nearer by more than its
    // tolerance), and between surfaces the earlier one wins.
    jobs.extend(surface_jobs(prep));
    let mut steps = vec![
        Step::Pass("init".into()),
        Step::Clear(Clear::DepthStencil {
            ds: FINAL,
            depth: FAR,
            stencil: 0,
        }),
        Step::Clear(Clear::Color),
    ];
    let mut bits = 0u8;
    let mut grouped = Vec::new();
    for Job { c, merge, surface } in &jobs {
        let p = c.peeled.prim;
        let max_layers = if *surface {
            Layers::AtMost(prep.mesh_triangles[p as usize] as u32 + 1)
        } else {
            Layers::of(prep, p, c.peel_cull)
        };
        match &c.volume {
            None => cst(p, c.peel_cull, None, max_layers, *merge, &mut steps),
            Some(vol) => {
                let trimmer: Box<dyn Trimmer + '_> = match variant {
                    Variant::Z | Variant::I => {
                        let layout = LabelLayout::new(vol.blist.num_labels).ok_or(
                            PlanError::TooManyLabels {
                                labels: vol.blist.num_labels,
                            },
                        )?;
                        let start = layout.value(Next::Label(vol.blist.entries[0].label));
                        // cst-z peels both faces: record which one (bit 7) when
                        // the layout leaves it free. A surface's tie rule does not
                        // depend on the facing.
                        let facing = if !*surface
                            && c.peel_cull == Cull::None
                            && layout.stencil_bits() < 8
                        {
                            0x80
                        } else {
                            0
                        };
                        Box::new(BlistTrimmer {
                            peeled: c.peeled,
                            vol,
                            layout,
                            start,
                            facing,
                        })
                    }
                    Variant::G => {
                        let mut g = group::GroupTrimmer::new(prep, c)?;
                        if *surface {
                            g = g.with_relation(Relation::Surface);
                        }
                        grouped.push(g);
                        Box::new(grouped.last().unwrap().clone())
                    }
                };
                bits = bits.max(if trimmer.facing_bit() != 0 {
                    8
                } else {
                    trimmer.bits()
                });
                cst(
                    p,
                    c.peel_cull,
                    Some(trimmer.as_ref()),
                    max_layers,
                    *merge,
                    &mut steps,
                );
            }
        }
    }
    // Coincident faces of different tessellations rasterize a few ulps apart, which
    // the exact compares of the trim cannot see: give every visible point the lowest
    // index among the primitives whose faces pass through it (CONTRACT §4), drawing
    // them in descending order over a copy of the final depth. Pixels a surface won
    // are left alone: they keep the surface's colour (or paint colour) and id.
    if solid {
        let stencil = (!prep.surfaces.is_empty()).then(|| stencil::test_equal(0, SURFACE_MARK));
        steps.extend(super::shade_near_depth(
            &prep.solid_meshes,
            FINAL,
            CUR,
            stencil,
        ));
    }
    Ok(Plan {
        algo: variant.algo().name().into(),
        depth_stencils: 2,
        textures: 2,
        stencil_bits: bits,
        output_ds: FINAL,
        steps,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csg::parse;
    use crate::plan::print::count;
    use crate::scene::Aabb;

    fn prepared(expr: &str, prims: u32, tris: usize) -> Prepared {
        let names: Vec<String> = (0..prims).map(|i| format!("P{i}")).collect();
        let e = parse(expr, &mut |n: &str| {
            names.iter().position(|x| x == n).map(|i| i as u32)
        })
        .unwrap();
        let positive = PositiveExpr::from_expr(&e);
        let mut solid_meshes = e.leaves();
        solid_meshes.sort_unstable();
        solid_meshes.dedup();
        let b = Aabb {
            min: glam::DVec3::splat(-1.0),
            max: glam::DVec3::splat(1.0),
        };
        Prepared {
            expr: Some(e),
            positive,
            solid_meshes,
            mesh_triangles: vec![tris; prims as usize],
            mesh_bounds: vec![b; prims as usize],
            mesh_convex: vec![false; prims as usize],
            eye_inside: Vec::new(),
            surfaces: Vec::new(),
        }
    }

    /// A gear: a disc plus 12 teeth, minus an axle hole.
    fn gear() -> Prepared {
        let teeth: Vec<String> = (1..=12).map(|i| format!("P{i}")).collect();
        prepared(&format!("(P0 + {}) - P13", teeth.join(" + ")), 14, 12)
    }

    #[test]
    fn cst_i_draws_fewer_triangles_and_sweeps_than_cst_z() {
        let p = gear();
        let z = count(&plan(&p, Variant::Z).unwrap().steps, &p);
        let i = count(&plan(&p, Variant::I).unwrap().steps, &p);
        let g = count(&plan(&p, Variant::G).unwrap().steps, &p);
        assert!(i.triangles < z.triangles, "{i:?} vs {z:?}");
        assert!(i.fullscreen_passes < z.fullscreen_passes);
        assert!(g.fullscreen_passes <= i.fullscreen_passes);
    }

    #[test]
    fn cst_g_groups_a_big_intersection_into_few_sweeps() {
        // The first leaf's i-zone is one intersection-group of 9 literals.
        let p = prepared("P0 P1 P2 !P3 P4 P5 !P6 P7 P8 P9", 10, 12);
        let i = count(&plan(&p, Variant::I).unwrap().steps, &p);
        let g = count(&plan(&p, Variant::G).unwrap().steps, &p);
        assert!(g.fullscreen_passes < i.fullscreen_passes, "{g:?} vs {i:?}");
        assert_eq!(g.triangles, i.triangles);
    }

    #[test]
    fn layouts_are_small_and_checked() {
        let p = gear();
        assert_eq!(plan(&p, Variant::I).unwrap().stencil_bits, 3);
        let pl = plan(&p, Variant::G).unwrap();
        assert!(pl.stencil_bits <= 8 && pl.depth_stencils == 2 && pl.output_ds == FINAL);
        // 300 literals in one group: chunks chained with label reuse fit in 8 bits.
        let names: Vec<String> = (1..301).map(|i| format!("P{i}")).collect();
        let big = prepared(&format!("P0 {}", names.join(" ")), 301, 12);
        assert!(plan(&big, Variant::G).unwrap().stencil_bits <= 8);
    }

    #[test]
    fn cst_g_chunks_a_36_tooth_union_into_8_bits() {
        // Body + 36 teeth, recessed: the recess's i-zone holds the 37-literal union.
        let teeth: Vec<String> = (1..=36).map(|i| format!("P{i}")).collect();
        // As in scenes/gear.toml, enough other entries that 3 label bits + a 6-bit
        // counter would not fit.
        let p = prepared(
            &format!("(P0 + {}) - P37 - P38 - P39 - P40 - P41", teeth.join(" + ")),
            42,
            12,
        );
        let pl = plan(&p, Variant::G).unwrap();
        assert!(pl.stencil_bits <= 8, "{}", pl.stencil_bits);
        let c = leaf_csts(&p.positive, Variant::G, &[], &[]);
        let recess = c.iter().find(|c| c.peeled.prim == 37).unwrap();
        let t = group::GroupTrimmer::new(&p, recess).unwrap();
        assert!(
            t.layout().bits() <= 8 && t.blist().num_groups() >= 2,
            "{t:?}"
        );
    }

    fn has_loop(steps: &[Step]) -> bool {
        steps.iter().any(|s| matches!(s, Step::Loop(_)))
    }

    #[test]
    fn convex_leaves_are_unrolled() {
        let mut p = gear();
        for v in [Variant::Z, Variant::I, Variant::G] {
            assert!(has_loop(&plan(&p, v).unwrap().steps));
        }
        p.mesh_convex = vec![true; 14];
        for (v, layers) in [(Variant::Z, 2), (Variant::I, 1), (Variant::G, 1)] {
            let pl = plan(&p, v).unwrap();
            assert!(!has_loop(&pl.steps));
            let peels = pl
                .steps
                .iter()
                .filter(|s| {
                    matches!(
                        s,
                        Step::Draw(Draw {
                            fragment: Fragment::Peel { .. },
                            ..
                        })
                    )
                })
                .count();
            // Leaf 0's zone is not the universe for any leaf here: one peel per layer.
            assert_eq!(peels, 14 * layers, "{v:?}");
        }
    }

    #[test]
    fn parity_draws_are_eps_tolerant() {
        let p = gear();
        for v in [Variant::Z, Variant::I, Variant::G] {
            let pl = plan(&p, v).unwrap();
            let mut stack = vec![&pl.steps];
            let mut n = 0;
            while let Some(steps) = stack.pop() {
                for s in steps {
                    match s {
                        Step::Loop(l) => {
                            stack.push(&l.head);
                            stack.push(&l.tail);
                        }
                        Step::Draw(d)
                            if d.ds == WORK && matches!(d.geometry, Geometry::Mesh(_)) =>
                        {
                            if let Fragment::NearerThan { tex, eps } = d.fragment {
                                assert_eq!(tex, CUR);
                                assert_eq!(eps.abs(), SHADE_EPS);
                                assert_eq!(d.depth.compare, CompareOp::Always);
                                n += 1;
                            }
                        }
                        _ => {}
                    }
                }
            }
            assert!(n > 0, "{v:?}");
        }
    }

    #[test]
    fn tie_rules_follow_the_order() {
        let p = Peeled {
            prim: 2,
            leaf: 2,
            negated: false,
        };
        assert_eq!(
            tie_draws(&p, 1, 1, false, Relation::Union),
            vec![(CompareOp::LessOrEqual, Cull::None)]
        );
        assert_eq!(
            tie_draws(&p, 3, 3, false, Relation::Union),
            vec![(CompareOp::Less, Cull::None)]
        );
        assert_eq!(
            tie_draws(&p, 3, 3, true, Relation::Inter),
            vec![(CompareOp::LessOrEqual, Cull::None)]
        );
        assert_eq!(tie_draws(&p, 1, 1, false, Relation::Inter).len(), 2);
    }
}
