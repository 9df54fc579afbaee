//! Active zones (Hable & Rossignac §5, after Rossignac & Voelcker): the region of
//! space where a leaf's boundary is on the solid's boundary. For leaf A, walk the
//! path from the root: the *i-nodes* are the siblings of the path under
//! intersections, the *u-nodes* the siblings under unions. The Z form is
//! `∩ i-nodes ∩ ∩ !u-nodes` (what CST-Z trims A against); the I form keeps the
//! i-nodes only (CST-I, cheaper, exact for the visible layer when peeling in depth
//! order).
//!
//! Zones are built per leaf on demand by copying the sibling subtrees, so scenes
//! that never ask for zones pay nothing, and the whole-scene cost is the sum of
//! zone sizes (fine for real scenes; quadratic for pathological deep chains).
//! Finding a leaf's branching nodes costs their number, not the leaf's depth (jump
//! pointers to the nearest intersection / union ancestor), and the size of every
//! zone is known in O(n) before any is built ([`ActiveZones::i_size`],
//! [`ActiveZones::z_size`]), so callers can refuse what would not fit first.

use super::positive::{PNode, PNodeId, PositiveExpr};
use super::LeafId;

/// The branching nodes of every leaf of a positive expression.
pub struct ActiveZones<'a> {
    pos: &'a PositiveExpr,
    /// Per node: `(p, sibling)` for its nearest ancestor `p` that is an
    /// intersection (reached through the path's child other than `sibling`).
    up_inter: Vec<Option<(PNodeId, PNodeId)>>,
    /// The same for the nearest union ancestor.
    up_union: Vec<Option<(PNodeId, PNodeId)>>,
    /// Per node: literals in the i-nodes / in all branching nodes of its path.
    i_size: Vec<u64>,
    z_size: Vec<u64>,
    /// Node of each leaf, indexed by [`LeafId`].
    leaf_node: Vec<PNodeId>,
}

impl<'a> ActiveZones<'a> {
    /// Jump pointers, zone sizes and leaf positions, in two linear passes.
    pub fn new(pos: &'a PositiveExpr) -> Self {
        let n = pos.nodes.len();
        let mut leaves = vec![0u64; n];
        let mut leaf_node = Vec::new();
        // Bottom-up (children have smaller indices): leaf counts.
        for (i, node) in pos.nodes.iter().enumerate() {
            leaves[i] = match *node {
                PNode::Leaf { leaf, .. } => {
                    if leaf_node.len() <= leaf as usize {
                        leaf_node.resize(leaf as usize + 1, u32::MAX);
                    }
                    leaf_node[leaf as usize] = i as PNodeId;
                    1
                }
                PNode::Union(a, b) | PNode::Inter(a, b) => leaves[a as usize] + leaves[b as usize],
                PNode::Universe => 0,
            };
        }
        // Top-down (parents have larger indices): what each child inherits.
        let (mut up_inter, mut up_union) = (vec![None; n], vec![None; n]);
        let (mut i_size, mut z_size) = (vec![0u64; n], vec![0u64; n]);
        for p in (0..n).rev() {
            let (a, b, inter) = match pos.nodes[p] {
                PNode::Inter(a, b) => (a, b, true),
                PNode::Union(a, b) => (a, b, false),
                _ => continue,
            };
            for (child, sib) in [(a, b), (b, a)] {
                let (c, s) = (child as usize, sib as usize);
                let link = Some((p as PNodeId, sib));
                up_inter[c] = if inter { link } else { up_inter[p] };
                up_union[c] = if inter { up_union[p] } else { link };
                i_size[c] = i_size[p] + if inter { leaves[s] } else { 0 };
                z_size[c] = z_size[p] + leaves[s];
            }
        }
        ActiveZones {
            pos,
            up_inter,
            up_union,
            i_size,
            z_size,
            leaf_node,
        }
    }

    /// Literals in the i-zone of a leaf (the I form's size), without building it.
    pub fn i_size(&self, leaf: LeafId) -> u64 {
        self.i_size[self.leaf_node(leaf) as usize]
    }

    /// Literals in the Z form of a leaf, without building it.
    pub fn z_size(&self, leaf: LeafId) -> u64 {
        self.z_size[self.leaf_node(leaf) as usize]
    }

    /// Leaf ids present in the expression, in increasing order.
    pub fn leaves(&self) -> impl Iterator<Item = LeafId> + '_ {
        (0..self.leaf_node.len() as LeafId).filter(|&l| self.leaf_node[l as usize] != u32::MAX)
    }

    /// The node of a leaf.
    pub fn leaf_node(&self, leaf: LeafId) -> PNodeId {
        self.leaf_node[leaf as usize]
    }

    /// `(i_nodes, u_nodes)` of a leaf, nearest the leaf first.
    pub fn branching_nodes(&self, leaf: LeafId) -> (Vec<PNodeId>, Vec<PNodeId>) {
        (
            self.chain(&self.up_inter, leaf),
            self.chain(&self.up_union, leaf),
        )
    }

    /// Siblings along a jump-pointer chain from the leaf up.
    fn chain(&self, up: &[Option<(PNodeId, PNodeId)>], leaf: LeafId) -> Vec<PNodeId> {
        let mut out = Vec::new();
        let mut at = self.leaf_node(leaf);
        while let Some((p, sib)) = up[at as usize] {
            out.push(sib);
            at = p;
        }
        out
    }

    /// The i-nodes of a leaf.
    pub fn i_nodes(&self, leaf: LeafId) -> Vec<PNodeId> {
        self.chain(&self.up_inter, leaf)
    }

    /// The u-nodes of a leaf.
    pub fn u_nodes(&self, leaf: LeafId) -> Vec<PNodeId> {
        self.chain(&self.up_union, leaf)
    }

    /// The active zone Z = ∩ i-nodes ∩ ∩ !u-nodes, complements pushed to the leaves.
    /// The universe when the leaf is the whole expression.
    pub fn z_form(&self, leaf: LeafId) -> PositiveExpr {
        let (i, u) = self.branching_nodes(leaf);
        self.intersect(
            i.iter()
                .map(|&n| (n, false))
                .chain(u.iter().map(|&n| (n, true))),
        )
    }

    /// The i-zone I = ∩ i-nodes. The universe when there are none.
    pub fn i_form(&self, leaf: LeafId) -> PositiveExpr {
        self.intersect(self.i_nodes(leaf).into_iter().map(|n| (n, false)))
    }

    fn intersect(&self, parts: impl Iterator<Item = (PNodeId, bool)>) -> PositiveExpr {
        let mut out = PositiveExpr {
            nodes: Vec::new(),
            root: 0,
        };
        let mut acc: Option<PNodeId> = None;
        for (n, complement) in parts {
            let r = out.append_subtree(self.pos, n, complement);
            acc = Some(match acc {
                None => r,
                Some(a) => {
                    out.nodes.push(PNode::Inter(a, r));
                    out.nodes.len() as PNodeId - 1
                }
            });
        }
        match acc {
            None => PositiveExpr::universe(),
            Some(root) => {
                out.root = root;
                out
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// A random expression over `A`-`F` with `n` leaves, as text.
    fn random_text(rng: &mut impl Rng, n: usize) -> String {
        if n == 1 {
            let name = (b'A' + rng.gen_range(0..6u8)) as char;
            return if rng.gen_bool(0.2) {
                format!("!{name}")
            } else {
                name.to_string()
            };
        }
        let k = rng.gen_range(1..n);
        let op = ["+", "-", "*"][rng.gen_range(0..3)];
        format!("({} {op} {})", random_text(rng, k), random_text(rng, n - k))
    }

    /// The sizes known before building equal the built zones' literal counts, and
    /// the jump pointers give the same branching nodes as walking the parents.
    #[test]
    fn zone_sizes_and_branching_nodes_match_the_built_zones() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(15);
        for case in 0..300 {
            let n = rng.gen_range(1..=30);
            let text = random_text(&mut rng, n);
            let e =
                crate::csg::parse(&text, &mut |s| Some((s.as_bytes()[0] - b'A') as u32)).unwrap();
            let pos = PositiveExpr::from_expr(&e);
            let parent = pos.parents();
            let zones = ActiveZones::new(&pos);
            let count = |z: &PositiveExpr| {
                if z.is_universe() {
                    0
                } else {
                    z.num_leaves() as u64
                }
            };
            for leaf in zones.leaves() {
                assert_eq!(
                    zones.i_size(leaf),
                    count(&zones.i_form(leaf)),
                    "case {case}: {text}"
                );
                assert_eq!(
                    zones.z_size(leaf),
                    count(&zones.z_form(leaf)),
                    "case {case}: {text}"
                );
                let (mut i, mut u) = (Vec::new(), Vec::new());
                let mut c = zones.leaf_node(leaf);
                while let Some(p) = parent[c as usize] {
                    match pos.nodes[p as usize] {
                        PNode::Inter(a, b) => i.push(if a == c { b } else { a }),
                        PNode::Union(a, b) => u.push(if a == c { b } else { a }),
                        _ => unreachable!(),
                    }
                    c = p;
                }
                assert_eq!(zones.branching_nodes(leaf), (i, u), "case {case}: {text}");
            }
        }
    }

    /// A 10⁵-deep union chain: every i-zone is empty, found without walking.
    #[test]
    fn long_union_chain_has_empty_i_zones_in_linear_time() {
        let n = 100_000;
        let text = vec!["A"; n].join(" + ");
        let e = crate::csg::parse(&text, &mut |_| Some(0)).unwrap();
        let pos = PositiveExpr::from_expr(&e);
        let t = std::time::Instant::now();
        let zones = ActiveZones::new(&pos);
        let total: u64 = zones.leaves().map(|l| zones.i_size(l)).sum();
        assert_eq!(total, 0);
        assert!(zones.leaves().all(|l| zones.i_nodes(l).is_empty()));
        assert_eq!(zones.z_size(0), n as u64 - 1);
        assert!(
            t.elapsed() < std::time::Duration::from_secs(2),
            "{:?}",
            t.elapsed()
        );
    }
}
