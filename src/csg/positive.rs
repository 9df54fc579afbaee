//! The positive form of a CSG expression (seed 000 §3, first paragraph; Fig. 4).
//!
//! Differences `L - R` become `L * !R` and complements are pushed to the leaves with
//! de Morgan's laws, so that only unions, intersections and possibly complemented
//! ("negative") leaves remain. Every later pass (Blist, active zones, products,
//! groups) works on this form because the Blist walk only needs, per leaf, "is the
//! literal true", and the literal already carries the complement.

use super::expr::{Expr, LeafId, Node};

/// Index of a node in [`PositiveExpr::nodes`].
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
        prim: u32,
        leaf: LeafId,
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

/// A CSG expression in positive form, stored in an arena.
///
/// Invariant (relied upon by every pass, and kept by every constructor in this
/// module tree): children have smaller indices than their parents, so a forward
/// loop over `nodes` is a bottom-up pass and no traversal stack is needed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PositiveExpr {
    pub nodes: Vec<PNode>,
    pub root: PNodeId,
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
                PNode::Leaf {
                    prim,
                    leaf,
                    negated,
                } => PNode::Leaf {
                    prim,
                    leaf,
                    negated: negated != complement,
                },
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
