//! Per-leaf active zones (Hable & Rossignac §5, §7): the Z or I form of each leaf's
//! zone, restricted by bounding boxes, as the Blist its CST is trimmed against. A
//! zone that becomes `true` needs no trim (the leaf is drawn directly) and one that
//! becomes `false` drops the leaf.
#![deny(unsafe_code)]

use std::collections::HashSet;

use super::super::step::*;
use super::{Candidates, Peeled, Relation, Variant};
use crate::csg::active_zone::ActiveZones;
use crate::csg::{Blist, LeafId, PNode, PNodeId, PositiveExpr, Restricted};
use crate::scene::Aabb;

/// The trimming volume of one CST: a Blist with, per entry, its relation to the
/// peeled leaf.
#[derive(Clone, Debug)]
pub struct TrimVolume {
    pub(crate) blist: Blist,
    pub(crate) relation: Vec<Relation>,
}

/// One leaf's CST: what is peeled, how, and against what.
#[derive(Clone, Debug)]
pub struct LeafCst {
    pub(crate) peeled: Peeled,
    pub(crate) peel_cull: Cull,
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
            candidates: Candidates::Visible,
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
        // Opaque rendering (Hable & Rossignac §7): a visible point of the solid is
        // where a ray enters it, so on a front face of a positive or a back face of a
        // negative leaf. Every variant peels those faces only; Z differs from I
        // in its zones, not in its peel. (Peeling both faces for Z doubled its
        // layers and its parity draws on the gear: see docs/perf/.)
        let peel_cull = if lit.negated { Cull::Front } else { Cull::Back };
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
