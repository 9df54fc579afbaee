//! CST's overlap rules (Hable & Rossignac §5): which faces of a trimming literal
//! count as in front of a candidate, per draw, so that coincident faces are decided
//! by a symbolic perturbation (the earlier primitive is slightly in front); and the
//! parity draw that applies them. The rules are explained in the parent module.
#![deny(unsafe_code)]

use super::super::step::*;
use super::super::SHADE_EPS;
use super::{CUR, WORK};
use crate::csg::LeafId;

/// The leaf whose boundary is peeled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Peeled {
    pub(crate) prim: MeshId,
    pub(crate) leaf: LeafId,
    pub(crate) negated: bool,
    /// Which boundary points the peel's candidates are.
    pub candidates: Candidates,
}

/// The boundary points a leaf's CST keeps, which decides how coincident faces
/// are resolved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Candidates {
    /// Opaque rendering: the visible entry points. A candidate inside the solid
    /// is hidden behind a nearer entry anyway, so a u-node's coincident exit face
    /// needs no draw of its own.
    Visible,
    /// Every entry point exactly once (the odd layers of Hable & Rossignac §6): also
    /// where a u-node literal leaves as the leaf enters (two solids of a union
    /// touching face to face), the point is inside the union and dropped.
    Entry,
    /// Every exit point exactly once (the even layers): [`Candidates::Entry`]'s
    /// rule along the reversed ray.
    Exit,
}

impl Peeled {
    /// Total order of Hable & Rossignac §5 ("L is considered slightly in front of
    /// R"): primitive index, then leaf occurrence.
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
///
/// The rules are written for entry candidates. An exit candidate (`peeled.exit`)
/// is an entry candidate of the ray run backwards: "behind" becomes "in front"
/// and front faces become back faces. The parity of the faces at or in front of
/// X equals that of the faces strictly behind it (a closed mesh crosses the line
/// an even number of times; an eye inside flips both alike), so the mirrored
/// rule is the same rule with `Less` and `LessOrEqual` swapped and the culling
/// swapped: coincident faces are then decided as if X were moved along the
/// reversed ray, and each exit point is still kept exactly once.
pub fn tie_draws(
    peeled: &Peeled,
    prim: u32,
    leaf: LeafId,
    negated: bool,
    rel: Relation,
) -> Vec<(CompareOp, Cull)> {
    let draws = entry_tie_draws(peeled, prim, leaf, negated, rel);
    if peeled.candidates != Candidates::Exit {
        return draws;
    }
    draws
        .into_iter()
        .map(|(compare, cull)| {
            let compare = match compare {
                CompareOp::Less => CompareOp::LessOrEqual,
                CompareOp::LessOrEqual => CompareOp::Less,
                other => panic!("tie draws compare with Less or LessOrEqual, not {other:?}"),
            };
            let cull = match cull {
                Cull::Front => Cull::Back,
                Cull::Back => Cull::Front,
                Cull::None => Cull::None,
            };
            (compare, cull)
        })
        .collect()
}

/// [`tie_draws`] for a candidate where the ray enters the solid.
fn entry_tie_draws(
    peeled: &Peeled,
    prim: u32,
    leaf: LeafId,
    negated: bool,
    rel: Relation,
) -> Vec<(CompareOp, Cull)> {
    let earlier = peeled.earlier(prim, leaf);
    // Literal front faces are mesh front faces unless the literal is negated.
    let (keep_lit_front, keep_lit_back) = if negated {
        (Cull::Front, Cull::Back)
    } else {
        (Cull::Back, Cull::Front)
    };
    match (rel, earlier) {
        (Relation::Surface, _) => vec![(CompareOp::Less, Cull::None)],
        // The literal is the complement of an earlier u-node primitive Q. Where Q
        // enters with P, Q wins (X in Q: the literal's exit face counts); where Q
        // leaves as P enters, the point is inside the union (X stays in Q: the
        // literal's entry face does not count). The intersection's rule, below.
        (Relation::Union, true) if peeled.candidates != Candidates::Visible => vec![
            (CompareOp::Less, keep_lit_front),
            (CompareOp::LessOrEqual, keep_lit_back),
        ],
        (Relation::Union, true) => vec![(CompareOp::LessOrEqual, Cull::None)],
        (Relation::Union, false) => vec![(CompareOp::Less, Cull::None)],
        (Relation::Inter, false) => vec![(CompareOp::LessOrEqual, Cull::None)],
        (Relation::Inter, true) => vec![
            (CompareOp::Less, keep_lit_front),
            (CompareOp::LessOrEqual, keep_lit_back),
        ],
    }
}

/// The signed tolerance of a parity draw's compare against the candidate's exact
/// depth (texture [`CUR`]): `LessOrEqual` keeps faces up to [`SHADE_EPS`] behind the
/// candidate (a coincident face counts as in front whatever the rounding), `Less`
/// keeps only faces more than [`SHADE_EPS`] in front of it (a coincident face
/// never counts). So the symbolic perturbation of Hable & Rossignac §5 survives
/// different tessellations and rounding of the same plane.
pub fn tie_eps(compare: CompareOp) -> f32 {
    match compare {
        CompareOp::LessOrEqual => SHADE_EPS,
        CompareOp::Less => -SHADE_EPS,
        other => panic!("parity draws compare with Less or LessOrEqual, not {other:?}"),
    }
}

/// A parity draw of `mesh` over the candidates of the `peeled` surface at label
/// `here`, scissored to where both may be: depth test off, the
/// fragment keeps the faces in front of the candidate's exact depth within the
/// tolerance of [`tie_eps`].
pub(crate) fn parity_draw(
    mesh: MeshId,
    peeled: MeshId,
    compare: CompareOp,
    cull: Cull,
    stencil: StencilState,
) -> Step {
    Step::Draw(Draw {
        geometry: Geometry::Mesh(mesh),
        // Only pixels where the peeled surface has candidates are read (the
        // knock-out and the merge are scissored to it; the next CST clears WORK).
        scissor: Scissor::Overlap {
            of: vec![mesh],
            and: vec![peeled],
        },
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
