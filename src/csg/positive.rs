//! The positive form of a CSG expression (Hable & Rossignac §3, first paragraph;
//! Fig. 4).
//!
//! Differences `L - R` become `L * !R` and complements are pushed to the leaves with
//! de Morgan's laws, so that only unions, intersections and possibly complemented
//! ("negative") leaves remain. Every later pass (Blist, active zones, products,
//! groups) works on this form because the Blist walk only needs, per leaf, "is the
//! literal true", and the literal already carries the complement.

use super::expr::{Expr, LeafId, Node};

/// Index of a node in `PositiveExpr::nodes`.
pub type PNodeId = u32;

/// A literal of the positive form: a leaf occurrence, possibly complemented.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Literal {
    /// The primitive (scene file order, 0-based).
    pub prim: u32,
    /// The leaf occurrence of the original expression this literal comes from.
    pub leaf: LeafId,
    /// True for a complemented ("negative") leaf.
    pub negated: bool,
}

impl Literal {
    /// The literal's value for a point whose membership in the primitive is `inside`.
    #[inline]
    pub fn holds(&self, inside: bool) -> bool {
        inside != self.negated
    }
}

/// One node of the positive form.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PNode {
    /// A leaf occurrence with its complement flag.
    Leaf {
        /// The primitive (mesh index).
        prim: u32,
        /// This occurrence's leaf: the same primitive may occur several times.
        leaf: LeafId,
        /// Whether the occurrence is complemented (`!P`).
        negated: bool,
    },
    /// `a + b`
    Union(PNodeId, PNodeId),
    /// `a * b`
    Inter(PNodeId, PNodeId),
    /// The whole space. Only ever the single node of an expression: it stands for an
    /// active zone with no constraint (a leaf that is the whole expression).
    Universe,
}

impl PNode {
    /// A leaf complemented when `flip` says so of its primitive; any other
    /// node as it is.
    fn complemented_if(self, flip: impl FnOnce(u32) -> bool) -> PNode {
        match self {
            PNode::Leaf {
                prim,
                leaf,
                negated,
            } => PNode::Leaf {
                prim,
                leaf,
                negated: negated != flip(prim),
            },
            other => other,
        }
    }
}

/// A CSG expression in positive form, stored in an arena.
///
/// Invariant (relied upon by every pass, and kept by every constructor in this
/// module tree): children have smaller indices than their parents, so a forward
/// loop over `nodes` is a bottom-up pass and no traversal stack is needed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PositiveExpr {
    pub(crate) nodes: Vec<PNode>,
    pub(crate) root: PNodeId,
}

impl PNode {
    /// The literal of a leaf node.
    pub fn literal(&self) -> Option<Literal> {
        match *self {
            PNode::Leaf {
                prim,
                leaf,
                negated,
            } => Some(Literal {
                prim,
                leaf,
                negated,
            }),
            _ => None,
        }
    }
}

impl PositiveExpr {
    /// The universe (an active zone with no constraint).
    pub fn universe() -> Self {
        PositiveExpr {
            nodes: vec![PNode::Universe],
            root: 0,
        }
    }

    /// True for the universe.
    pub fn is_universe(&self) -> bool {
        matches!(self.nodes[self.root as usize], PNode::Universe)
    }

    /// Converts a parsed expression to positive form, iteratively. Leaves keep the
    /// [`LeafId`] (left-to-right occurrence index) of the original expression, and
    /// nodes are emitted in post-order, which establishes the index invariant.
    pub fn from_expr(expr: &Expr) -> Self {
        enum Frame {
            /// Convert this node under `neg` complements.
            Enter(u32, bool),
            /// Both operands are on the value stack: combine them.
            Exit { union: bool },
        }
        let mut nodes = Vec::with_capacity(expr.nodes.len());
        let mut values: Vec<PNodeId> = Vec::new();
        let mut stack = vec![Frame::Enter(expr.root, false)];
        let mut next_leaf: LeafId = 0;
        while let Some(frame) = stack.pop() {
            match frame {
                Frame::Enter(n, neg) => match expr.nodes[n as usize] {
                    Node::Leaf { prim } => {
                        nodes.push(PNode::Leaf {
                            prim,
                            leaf: next_leaf,
                            negated: neg,
                        });
                        next_leaf += 1;
                        values.push(nodes.len() as PNodeId - 1);
                    }
                    Node::Not(a) => stack.push(Frame::Enter(a, !neg)),
                    // !(a + b) = !a * !b and !(a * b) = !a + !b (de Morgan).
                    Node::Union(a, b) | Node::Inter(a, b) => {
                        let union = matches!(expr.nodes[n as usize], Node::Union(..)) != neg;
                        stack.push(Frame::Exit { union });
                        stack.push(Frame::Enter(b, neg));
                        stack.push(Frame::Enter(a, neg));
                    }
                    // a - b = a * !b, and !(a - b) = !a + b.
                    Node::Diff(a, b) => {
                        stack.push(Frame::Exit { union: neg });
                        stack.push(Frame::Enter(b, !neg));
                        stack.push(Frame::Enter(a, neg));
                    }
                },
                Frame::Exit { union } => {
                    let b = values.pop().expect("right operand");
                    let a = values.pop().expect("left operand");
                    nodes.push(if union {
                        PNode::Union(a, b)
                    } else {
                        PNode::Inter(a, b)
                    });
                    values.push(nodes.len() as PNodeId - 1);
                }
            }
        }
        let root = values.pop().expect("an expression has a root");
        PositiveExpr { nodes, root }
    }

    /// Number of leaves.
    pub fn num_leaves(&self) -> usize {
        self.nodes
            .iter()
            .filter(|n| matches!(n, PNode::Leaf { .. }))
            .count()
    }

    /// The literals in left-to-right order (as reached from the root).
    pub fn literals(&self) -> Vec<Literal> {
        let mut out = Vec::new();
        let mut stack = vec![self.root];
        while let Some(n) = stack.pop() {
            match self.nodes[n as usize] {
                PNode::Leaf { .. } => out.push(self.nodes[n as usize].literal().unwrap()),
                PNode::Union(a, b) | PNode::Inter(a, b) => {
                    stack.push(b);
                    stack.push(a);
                }
                PNode::Universe => {}
            }
        }
        out
    }

    /// Evaluates the expression given the membership of the point in each leaf's
    /// primitive (`inside(literal)` answers "is the point inside `literal.prim`",
    /// the complement is applied here).
    pub fn eval(&self, mut inside: impl FnMut(&Literal) -> bool) -> bool {
        let mut value = vec![false; self.nodes.len()];
        for (i, n) in self.nodes.iter().enumerate() {
            value[i] = match *n {
                PNode::Leaf { .. } => {
                    let lit = n.literal().unwrap();
                    lit.holds(inside(&lit))
                }
                PNode::Union(a, b) => value[a as usize] || value[b as usize],
                PNode::Inter(a, b) => value[a as usize] && value[b as usize],
                PNode::Universe => true,
            };
        }
        value[self.root as usize]
    }

    /// Whether the solid is bounded: a positive leaf is, a negative one is not; a
    /// union is bounded when both operands are, an intersection when either is.
    /// (Conservative: it looks at the form, not at the geometry.)
    pub fn is_bounded(&self) -> bool {
        let mut bounded = vec![false; self.nodes.len()];
        for (i, n) in self.nodes.iter().enumerate() {
            bounded[i] = match *n {
                PNode::Leaf { negated, .. } => !negated,
                PNode::Union(a, b) => bounded[a as usize] && bounded[b as usize],
                PNode::Inter(a, b) => bounded[a as usize] || bounded[b as usize],
                PNode::Universe => false,
            };
        }
        bounded[self.root as usize]
    }

    /// Parent of every node (`None` for the root and for unreachable nodes).
    pub fn parents(&self) -> Vec<Option<PNodeId>> {
        let mut parent = vec![None; self.nodes.len()];
        for (i, n) in self.nodes.iter().enumerate() {
            if let PNode::Union(a, b) | PNode::Inter(a, b) = *n {
                parent[a as usize] = Some(i as PNodeId);
                parent[b as usize] = Some(i as PNodeId);
            }
        }
        parent
    }

    /// Appends a copy of the subtree of `src` rooted at `node` to `self.nodes`,
    /// complemented (de Morgan pushed to the leaves) when `complement`; returns the
    /// new root. Iterative; keeps the index invariant.
    pub(crate) fn append_subtree(
        &mut self,
        src: &PositiveExpr,
        node: PNodeId,
        complement: bool,
    ) -> PNodeId {
        let mut values: Vec<PNodeId> = Vec::new();
        let mut stack: Vec<(PNodeId, bool)> = vec![(node, false)];
        while let Some((n, expanded)) = stack.pop() {
            let new = match src.nodes[n as usize] {
                leaf @ PNode::Leaf { .. } => leaf.complemented_if(|_| complement),
                PNode::Union(a, b) | PNode::Inter(a, b) if !expanded => {
                    stack.push((n, true));
                    stack.push((b, false));
                    stack.push((a, false));
                    continue;
                }
                PNode::Union(..) | PNode::Inter(..) => {
                    let b = values.pop().unwrap();
                    let a = values.pop().unwrap();
                    let union = matches!(src.nodes[n as usize], PNode::Union(..)) != complement;
                    if union {
                        PNode::Union(a, b)
                    } else {
                        PNode::Inter(a, b)
                    }
                }
                PNode::Universe => panic!("the universe is never part of a larger expression"),
            };
            self.nodes.push(new);
            values.push(self.nodes.len() as PNodeId - 1);
        }
        values.pop().unwrap()
    }
}

/// What [`PositiveExpr::restrict`] leaves of an expression.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Restricted {
    /// Every remaining point has this value.
    Constant(bool),
    /// The expression left where it is not constant.
    Expr(PositiveExpr),
}

impl PositiveExpr {
    /// The expression with every literal whose value `known` decides replaced by
    /// that value and the constants propagated (`x + true = true`, `x * false =
    /// false`, ...). CST uses it to drop from a leaf's active zone the primitives
    /// whose bounding boxes cannot meet the leaf: on the leaf's boundary they are
    /// outside, so `!P` is true and `P` false there. Leaf ids are kept, unreachable
    /// nodes are dropped and the index invariant holds.
    pub fn restrict(&self, known: impl Fn(&Literal) -> Option<bool>) -> Restricted {
        #[derive(Clone, Copy)]
        enum V {
            C(bool),
            N(PNodeId),
        }
        let mut nodes: Vec<PNode> = Vec::new();
        let mut val: Vec<V> = Vec::with_capacity(self.nodes.len());
        let push = |nodes: &mut Vec<PNode>, n: PNode| {
            nodes.push(n);
            V::N(nodes.len() as PNodeId - 1)
        };
        for n in &self.nodes {
            let v = match *n {
                PNode::Universe => V::C(true),
                PNode::Leaf { .. } => match known(&n.literal().expect("a leaf")) {
                    Some(b) => V::C(b),
                    None => push(&mut nodes, *n),
                },
                PNode::Union(a, b) => match (val[a as usize], val[b as usize]) {
                    (V::C(true), _) | (_, V::C(true)) => V::C(true),
                    (V::C(false), x) | (x, V::C(false)) => x,
                    (V::N(x), V::N(y)) => push(&mut nodes, PNode::Union(x, y)),
                },
                PNode::Inter(a, b) => match (val[a as usize], val[b as usize]) {
                    (V::C(false), _) | (_, V::C(false)) => V::C(false),
                    (V::C(true), x) | (x, V::C(true)) => x,
                    (V::N(x), V::N(y)) => push(&mut nodes, PNode::Inter(x, y)),
                },
            };
            val.push(v);
        }
        let root = match val[self.root as usize] {
            V::C(b) => return Restricted::Constant(b),
            V::N(r) => r,
        };
        // Absorbed subtrees left nodes behind; keep what the root reaches.
        let mut reach = vec![false; nodes.len()];
        reach[root as usize] = true;
        for i in (0..=root as usize).rev() {
            if reach[i] {
                if let PNode::Union(a, b) | PNode::Inter(a, b) = nodes[i] {
                    reach[a as usize] = true;
                    reach[b as usize] = true;
                }
            }
        }
        let mut map = vec![0 as PNodeId; nodes.len()];
        let mut kept = Vec::new();
        for (i, n) in nodes.iter().enumerate().take(root as usize + 1) {
            if !reach[i] {
                continue;
            }
            map[i] = kept.len() as PNodeId;
            kept.push(match *n {
                PNode::Union(a, b) => PNode::Union(map[a as usize], map[b as usize]),
                PNode::Inter(a, b) => PNode::Inter(map[a as usize], map[b as usize]),
                other => other,
            });
        }
        Restricted::Expr(PositiveExpr {
            root: kept.len() as PNodeId - 1,
            nodes: kept,
        })
    }
}

impl PositiveExpr {
    /// The same tree with the literals of the primitives `flip` selects
    /// complemented (leaf ids kept).
    pub fn flip_literals(&self, flip: impl Fn(u32) -> bool) -> PositiveExpr {
        let nodes = self
            .nodes
            .iter()
            .map(|n| n.complemented_if(&flip))
            .collect();
        PositiveExpr {
            nodes,
            root: self.root,
        }
    }
}

#[cfg(test)]
mod restrict_tests {
    use super::*;
    use crate::csg::parse;
    use rand::{Rng, SeedableRng};

    /// Restricting equals evaluating with the known literals fixed, on random
    /// expressions and points.
    #[test]
    fn restrict_agrees_with_eval() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let names = ["A", "B", "C", "D", "E", "F", "G"];
        for _ in 0..300 {
            let mut src = String::new();
            for i in 0..rng.gen_range(1..12) {
                if i > 0 {
                    src.push_str(["+", "-", " ", "*"][rng.gen_range(0..4)]);
                }
                if rng.gen_bool(0.2) {
                    src.push('!');
                }
                src.push_str(names[rng.gen_range(0..names.len())]);
            }
            let e = parse(&src, &mut |n: &str| {
                names.iter().position(|x| *x == n).map(|i| i as u32)
            })
            .unwrap();
            let pos = PositiveExpr::from_expr(&e);
            // Fix a random subset of primitives to a random value.
            let fixed: Vec<Option<bool>> = (0..7)
                .map(|_| rng.gen_bool(0.4).then(|| rng.gen()))
                .collect();
            let r = pos.restrict(|l| fixed[l.prim as usize].map(|inside| l.holds(inside)));
            for _ in 0..20 {
                let pt: Vec<bool> = (0..7)
                    .map(|p| fixed[p].unwrap_or_else(|| rng.gen()))
                    .collect();
                let want = pos.eval(|l| pt[l.prim as usize]);
                let got = match &r {
                    Restricted::Constant(b) => *b,
                    Restricted::Expr(x) => x.eval(|l| pt[l.prim as usize]),
                };
                assert_eq!(got, want, "{src} fixed {fixed:?}");
            }
            if let Restricted::Expr(x) = &r {
                for (i, n) in x.nodes.iter().enumerate() {
                    if let PNode::Union(a, b) | PNode::Inter(a, b) = n {
                        assert!((*a as usize) < i && (*b as usize) < i, "index invariant");
                    }
                }
                assert!(x
                    .literals()
                    .iter()
                    .all(|l| fixed[l.prim as usize].is_none()));
            }
        }
    }
}
