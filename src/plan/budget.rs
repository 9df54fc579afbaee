//! Memory and work of a plan, estimated before it is built: CST trims
//! every leaf against its active zone, so its size is the sum of the zone sizes —
//! quadratic in the leaves for long intersection chains such as `A B A B …` or a
//! deep `A - (A - (… - B))`. The sum is known in O(n) from
//! [`ActiveZones::i_size`]/[`ActiveZones::z_size`] (Hable & Rossignac §5), so such
//! scenes are refused at once with the estimate, the limit and the way out, instead
//! of exhausting memory minutes later. The other algorithms are linear in the leaves
//! (Blister) or bounded by `--max-products` (Goldfeather, Trickle).

use super::cst::{disjoint, Variant};
use super::{PlanError, Prepared};
use crate::budget;
use crate::csg::{ActiveZones, LeafId, PNode, PNodeId, PositiveExpr};

/// Bytes a plan holds per literal of an active zone: the zone's node, its Blist
/// entry and the trim steps recorded for it (a parity draw and two sweeps; cst-z
/// records two parity draws, one per facing). Peak RSS of `plan` on a 1,000-leaf
/// `A B A B …` chain (10⁶ zone literals): 0.83 GB with cst-i, 1.8 GB with cst-z;
/// rounded up.
pub fn bytes_per_zone_literal(variant: Variant) -> u64 {
    match variant {
        Variant::Z => 2048,
        Variant::I | Variant::G => 1024,
    }
}

/// The most zone literals a CST plan may trim against, in all: each is two to four
/// draws per peel, so past this a frame takes minutes on lavapipe.
pub const MAX_ZONE_LITERALS: u64 = 500_000;

/// Literals visited at most when bounding boxes are used to tighten the estimate
/// (bounds the time of the check itself to well under a second).
const MAX_SCAN: u64 = 50_000_000;

/// Refuses a CST plan whose zones would exceed the memory budget or
/// [`MAX_ZONE_LITERALS`]. Zones are restricted by bounding boxes when the plan is
/// built (`cst::leaf_csts`); when the plain sum is too large the estimate counts
/// only the zone literals whose boxes meet the leaf's (an upper bound of the
/// restricted size), as long as that count is cheap.
pub fn check_cst(prep: &Prepared, variant: Variant) -> Result<(), PlanError> {
    if !prep.has_solid() {
        return Ok(());
    }
    let pos = &prep.positive;
    let zones = ActiveZones::new(pos);
    let lits = pos.literals();
    let size = |leaf: LeafId| match variant {
        Variant::Z => zones.z_size(leaf),
        Variant::I | Variant::G => zones.i_size(leaf),
    };
    let total: u64 = lits.iter().map(|l| size(l.leaf)).sum();
    let budget = budget::current();
    let per = bytes_per_zone_literal(variant);
    let fits = |n: u64| n <= MAX_ZONE_LITERALS && n.saturating_mul(per) <= budget.bytes;
    if fits(total) {
        return Ok(());
    }
    let boxes = &prep.mesh_bounds;
    let estimate = if !boxes.is_empty() && total <= MAX_SCAN {
        let mut n = 0u64;
        for l in &lits {
            let own = &boxes[l.prim as usize];
            let (i, u) = zones.branching_nodes(l.leaf);
            let roots = match variant {
                Variant::Z => [i, u].concat(),
                Variant::I | Variant::G => i,
            };
            for r in roots {
                n += count_leaves(pos, r, |prim| !disjoint(own, &boxes[prim as usize]));
            }
        }
        if fits(n) {
            return Ok(());
        }
        n
    } else {
        total
    };
    let algo = variant.algo();
    let what = || {
        format!(
            "{algo} trims each of the {} leaves against its active zone; the zones hold about {estimate} literals in all (quadratic in the leaves for a long intersection or difference chain)",
            lits.len()
        )
    };
    let fix = "use --algo blister (linear in the leaves), or write repeated operands once \
               (`A B A B` is `A B`, `A - (A - B)` is `A B`)";
    if estimate > MAX_ZONE_LITERALS {
        return Err(PlanError::TooMuchWork {
            what: what(),
            limit: MAX_ZONE_LITERALS,
            fix: fix.to_string(),
        });
    }
    // The budget's message goes on "… would need about N of memory": the
    // zones are its subject.
    let zones = || {
        format!(
            "{algo} trims each of the {} leaves against its active zone; the zones, about {estimate} literals in all (quadratic in the leaves for a long intersection or difference chain),",
            lits.len()
        )
    };
    budget
        .check(zones, estimate.saturating_mul(per), fix)
        .map_err(PlanError::OverBudget)
}

/// Leaves under `root` whose primitive satisfies `keep` (iterative).
fn count_leaves(pos: &PositiveExpr, root: PNodeId, keep: impl Fn(u32) -> bool) -> u64 {
    let mut n = 0;
    let mut stack = vec![root];
    while let Some(x) = stack.pop() {
        match pos.nodes[x as usize] {
            PNode::Leaf { prim, .. } => n += keep(prim) as u64,
            PNode::Union(a, b) | PNode::Inter(a, b) => stack.extend([a, b]),
            PNode::Universe => {}
        }
    }
    n
}
