//! The expression tree as written by the user, stored in an arena.

/// Index of a node in [`Expr::nodes`].
pub type NodeId = u32;
/// Index of a leaf occurrence, counted left to right (0-based).
pub type LeafId = u32;

/// One node of a parsed CSG expression. Children always have smaller indices than
/// their parent is not guaranteed; use [`Expr::postorder`] for bottom-up passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// An occurrence of a primitive; `prim` indexes the scene's primitives (file order,
    /// 0-based). Each occurrence is its own leaf.
    Leaf { prim: u32 },
    /// `!a`: the complement.
    Not(NodeId),
    /// `a + b`
    Union(NodeId, NodeId),
    /// `a * b` or `a b`
    Inter(NodeId, NodeId),
    /// `a - b`
    Diff(NodeId, NodeId),
}

/// A CSG expression as an arena of [`Node`]s.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Expr {
    pub nodes: Vec<Node>,
    pub root: NodeId,
}

impl Node {
    /// Children in left-to-right order.
    pub fn children(&self) -> impl Iterator<Item = NodeId> {
        let (a, b) = match *self {
            Node::Leaf { .. } => (None, None),
            Node::Not(a) => (Some(a), None),
            Node::Union(a, b) | Node::Inter(a, b) | Node::Diff(a, b) => (Some(a), Some(b)),
        };
        a.into_iter().chain(b)
    }
}

impl Expr {
    /// Nodes in post-order (children before parents, left before right), computed
    /// with an explicit stack so deep trees cannot overflow the call stack.
    pub fn postorder(&self) -> Vec<NodeId> {
        let mut out = Vec::with_capacity(self.nodes.len());
        let mut stack: Vec<(NodeId, bool)> = vec![(self.root, false)];
        while let Some((n, expanded)) = stack.pop() {
            if expanded {
                out.push(n);
                continue;
            }
            stack.push((n, true));
            let kids: Vec<NodeId> = self.nodes[n as usize].children().collect();
            for &k in kids.iter().rev() {
                stack.push((k, false));
            }
        }
        out
    }

    /// The primitive of every leaf occurrence, in left-to-right order (the index
    /// into this vector is the [`LeafId`]).
    pub fn leaves(&self) -> Vec<u32> {
        self.postorder()
            .into_iter()
            .filter_map(|n| match self.nodes[n as usize] {
                Node::Leaf { prim } => Some(prim),
                _ => None,
            })
            .collect()
    }

    /// `self * other`: the intersection of two expressions (their arenas joined).
    pub fn inter(&self, other: &Expr) -> Expr {
        let off = self.nodes.len() as NodeId;
        let shift = |n: Node| match n {
            Node::Leaf { .. } => n,
            Node::Not(a) => Node::Not(a + off),
            Node::Union(a, b) => Node::Union(a + off, b + off),
            Node::Inter(a, b) => Node::Inter(a + off, b + off),
            Node::Diff(a, b) => Node::Diff(a + off, b + off),
        };
        let mut nodes = self.nodes.clone();
        nodes.extend(other.nodes.iter().map(|&n| shift(n)));
        nodes.push(Node::Inter(self.root, other.root + off));
        Expr {
            root: nodes.len() as NodeId - 1,
            nodes,
        }
    }

    /// Evaluates the expression for a point given its membership in each leaf
    /// (`inside(leaf_id, prim)`), iteratively.
    pub fn eval(&self, mut inside: impl FnMut(LeafId, u32) -> bool) -> bool {
        let mut value = vec![false; self.nodes.len()];
        let mut leaf: LeafId = 0;
        for n in self.postorder() {
            let v = match self.nodes[n as usize] {
                Node::Leaf { prim } => {
                    let v = inside(leaf, prim);
                    leaf += 1;
                    v
                }
                Node::Not(a) => !value[a as usize],
                Node::Union(a, b) => value[a as usize] || value[b as usize],
                Node::Inter(a, b) => value[a as usize] && value[b as usize],
                Node::Diff(a, b) => value[a as usize] && !value[b as usize],
            };
            value[n as usize] = v;
        }
        value[self.root as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// (A + B) - !C over prims 0, 1, 2, built by hand.
    fn sample() -> Expr {
        let nodes = vec![
            Node::Leaf { prim: 0 },
            Node::Leaf { prim: 1 },
            Node::Union(0, 1),
            Node::Leaf { prim: 2 },
            Node::Not(3),
            Node::Diff(2, 4),
        ];
        Expr { nodes, root: 5 }
    }

    #[test]
    fn inter_is_the_intersection() {
        let (e, f) = (sample(), sample());
        let mut g = Expr {
            nodes: vec![Node::Leaf { prim: 3 }, Node::Not(0)],
            root: 1,
        };
        g = e.inter(&g);
        for bits in 0..16u32 {
            let inside = |_, p: u32| bits >> p & 1 == 1;
            assert_eq!(g.eval(inside), e.eval(inside) && bits >> 3 & 1 == 0);
            assert_eq!(e.inter(&f).eval(inside), e.eval(inside));
        }
        assert_eq!(g.leaves(), vec![0, 1, 2, 3]);
    }

    #[test]
    fn eval_matches_truth_table() {
        let e = sample();
        for bits in 0..8u32 {
            let got = e.eval(|_, p| bits >> p & 1 == 1);
            let (a, b, c) = (bits & 1 == 1, bits & 2 == 2, bits & 4 == 4);
            assert_eq!(got, (a || b) && c, "bits {bits:03b}");
        }
        assert_eq!(e.leaves(), vec![0, 1, 2]);
    }

    #[test]
    fn deep_chain_does_not_overflow() {
        // !!!...!A with 200k complements: iterative traversal handles it.
        let mut nodes = vec![Node::Leaf { prim: 0 }];
        for i in 0..200_000u32 {
            nodes.push(Node::Not(i));
        }
        let root = nodes.len() as u32 - 1;
        let e = Expr { nodes, root };
        assert!(e.eval(|_, _| true)); // even number of complements
    }
}
