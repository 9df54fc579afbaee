//! Active zones (seed 000 §5, after Rossignac & Voelcker): the region of space where
//! a leaf's boundary is on the solid's boundary. For leaf A, walk the path from the
//! root: the *i-nodes* are the siblings of the path under intersections, the
//! *u-nodes* the siblings under unions. The Z form is `∩ i-nodes ∩ ∩ !u-nodes` (what
//! CST-Z trims A against); the I form keeps the i-nodes only (CST-I, cheaper, exact
//! for the visible layer when peeling in depth order).
//!
//! Zones are built per leaf on demand by copying the sibling subtrees, so scenes
//! that never ask for zones pay nothing, and the whole-scene cost is the sum of
//! zone sizes (fine for real scenes; quadratic for pathological deep chains).

use super::positive::{PNode, PNodeId, PositiveExpr};
use super::LeafId;

/// The branching nodes of every leaf of a positive expression.
pub struct ActiveZones<'a> {
    pos: &'a PositiveExpr,
    parent: Vec<Option<PNodeId>>,
    /// Node of each leaf, indexed by [`LeafId`].
    leaf_node: Vec<PNodeId>,
}

impl<'a> ActiveZones<'a> {
    /// Parent pointers and leaf positions, in one linear pass.
    pub fn new(pos: &'a PositiveExpr) -> Self {
        let parent = pos.parents();
        let mut leaf_node = Vec::new();
        for (i, n) in pos.nodes.iter().enumerate() {
            if let PNode::Leaf { leaf, .. } = *n {
                if leaf_node.len() <= leaf as usize {
                    leaf_node.resize(leaf as usize + 1, u32::MAX);
                }
                leaf_node[leaf as usize] = i as PNodeId;
            }
        }
        ActiveZones {
            pos,
            parent,
            leaf_node,
        }
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
        let (mut i_nodes, mut u_nodes) = (Vec::new(), Vec::new());
        let mut child = self.leaf_node(leaf);
        while let Some(p) = self.parent[child as usize] {
            match self.pos.nodes[p as usize] {
                PNode::Inter(a, b) => i_nodes.push(if a == child { b } else { a }),
                PNode::Union(a, b) => u_nodes.push(if a == child { b } else { a }),
                _ => unreachable!("only operators are parents"),
            }
            child = p;
        }
        (i_nodes, u_nodes)
    }

    /// The i-nodes of a leaf.
    pub fn i_nodes(&self, leaf: LeafId) -> Vec<PNodeId> {
        self.branching_nodes(leaf).0
    }

    /// The u-nodes of a leaf.
    pub fn u_nodes(&self, leaf: LeafId) -> Vec<PNodeId> {
        self.branching_nodes(leaf).1
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

/// Z forms of all leaves, indexed by [`LeafId`].
pub fn z_forms(pos: &PositiveExpr) -> Vec<PositiveExpr> {
    let z = ActiveZones::new(pos);
    z.leaves().map(|l| z.z_form(l)).collect()
}

/// I forms of all leaves, indexed by [`LeafId`].
pub fn i_forms(pos: &PositiveExpr) -> Vec<PositiveExpr> {
    let z = ActiveZones::new(pos);
    z.leaves().map(|l| z.i_form(l)).collect()
}
