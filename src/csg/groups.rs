//! Grouped Blist for CST-G (Hable & Rossignac §7, last part): maximal sets of leaves
//! that are operands of the same chain of one operator (e.g. `A+B+C+D` nested any
//! way) form a *group* that the GPU classifies at once with a stencil counter,
//! instead of one Blist entry (and two full-screen stencil passes) per leaf.
//!
//! An intersection-group G with `c_p` positive and `c_n` negative literals: start
//! the counter at `c0`, count +1 for each positive primitive containing X and -1 for
//! each negative primitive containing X; X ∈ G iff `counter == c0 + c_p`. A
//! union-group is handled by de Morgan (G = !(∩ !l)): positive and negative roles
//! swap and the result is inverted. With each primitive's depth complexity bounded
//! by k, the counter stays in `[c0 - c_n - k + 1, c0 + c_p + k - 1]`, so
//! `c0 = c_n + k` keeps it positive and ⌈log₂(c_n + c_p + 2k)⌉ bits hold it.
//!
//! The grouped tree (each cluster of one operator = its group, if any, combined with
//! its sub-clusters) is then linearised exactly like the plain Blist, with pivoting
//! and label reuse.

use super::blist::{bits_for, layout, walk, BNode, Target};
use super::positive::{Literal, PNode, PNodeId, PositiveExpr};

/// The operator of a group.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GroupKind {
    /// An intersection chain: a point is in the group when it is in all of it.
    Inter,
    /// A union chain: a point is in the group when it is in any of it.
    Union,
}

/// Leaves that are all operands of one operator chain.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Group {
    pub(crate) kind: GroupKind,
    pub(crate) literals: Vec<Literal>,
}

impl Group {
    /// Whether the counter classifies the complement (union-groups, by de Morgan).
    pub fn inverted(&self) -> bool {
        self.kind == GroupKind::Union
    }
    /// Primitives the counter treats as positive (incrementing when X is inside).
    pub fn c_p(&self) -> u32 {
        self.literals
            .iter()
            .filter(|l| l.negated == self.inverted())
            .count() as u32
    }
    /// Primitives the counter treats as negative.
    pub fn c_n(&self) -> u32 {
        self.literals.len() as u32 - self.c_p()
    }
    /// Initial counter value for depth complexity bound `k`.
    pub fn c0(&self, k: u32) -> u32 {
        self.c_n() + k
    }
    /// The counter value meaning "X is in the intersection-group".
    pub fn target_count(&self, k: u32) -> u32 {
        self.c0(k) + self.c_p()
    }
    /// Stencil bits for the counter: ⌈log₂(c_n + c_p + 2k)⌉ (at least 1).
    pub fn counter_bits(&self, k: u32) -> u32 {
        bits_for((self.c_n() + self.c_p() + 2 * k) as u64)
    }
    /// Membership of a point given its membership in each primitive.
    pub fn eval(&self, mut inside: impl FnMut(&Literal) -> bool) -> bool {
        match self.kind {
            GroupKind::Inter => self.literals.iter().all(|l| l.holds(inside(l))),
            GroupKind::Union => self.literals.iter().any(|l| l.holds(inside(l))),
        }
    }
}

/// What one grouped Blist entry classifies.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Item {
    /// One literal, classified by its parity bit.
    Literal(Literal),
    /// A group of literals, classified by a stencil counter.
    Group(Group),
}

impl Item {
    pub(crate) fn eval(&self, mut inside: impl FnMut(&Literal) -> bool) -> bool {
        match self {
            Item::Literal(l) => l.holds(inside(l)),
            Item::Group(g) => g.eval(inside),
        }
    }
}

/// One entry of a grouped Blist: labels and targets as in [`super::Blist`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GroupedEntry {
    pub(crate) item: Item,
    pub(crate) label: u32,
    pub(crate) if_true: Target,
    pub(crate) if_false: Target,
}

/// A Blist whose entries are literals or groups. No entries: the universe.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GroupedBlist {
    pub(crate) entries: Vec<GroupedEntry>,
    pub(crate) num_labels: u32,
}

impl GroupedBlist {
    /// Groups the leaves of `pos` and linearises the grouped tree (with pivoting).
    pub fn new(pos: &PositiveExpr) -> Self {
        Self::with_max_group(pos, usize::MAX)
    }

    /// As [`GroupedBlist::new`], with every group holding at most `max_group`
    /// literals (at least 2): a larger same-operator cluster is split into chunks,
    /// consecutive operands of the same operator (so consecutive entries), which
    /// keeps the counter small at the cost of more labels. Semantics unchanged.
    pub fn with_max_group(pos: &PositiveExpr, max_group: usize) -> Self {
        Self::grouped(pos, max_group, &|_| true)
    }

    /// As [`GroupedBlist::with_max_group`], keeping as a group only the chunks
    /// `keep` accepts: the others become one entry per literal (under the same
    /// operator, so the semantics are unchanged).
    pub fn grouped(pos: &PositiveExpr, max_group: usize, keep: &dyn Fn(&Group) -> bool) -> Self {
        let max_group = max_group.max(2);
        if pos.is_universe() {
            return GroupedBlist {
                entries: Vec::new(),
                num_labels: 0,
            };
        }
        let (tree, root, items) = grouped_tree(pos, max_group, keep);
        let lay = layout(&tree, root, true);
        let entries = lay
            .entries
            .into_iter()
            .map(|e| GroupedEntry {
                item: items[e.atom as usize].clone(),
                label: e.label,
                if_true: e.if_true,
                if_false: e.if_false,
            })
            .collect();
        GroupedBlist {
            entries,
            num_labels: lay.num_labels,
        }
    }

    /// Number of groups (entries holding more than one literal).
    pub fn num_groups(&self) -> usize {
        self.entries
            .iter()
            .filter(|e| matches!(e.item, Item::Group(_)))
            .count()
    }

    /// Stencil bits for labels plus the two exits.
    pub fn label_bits(&self) -> u32 {
        bits_for(self.num_labels as u64 + 2)
    }

    /// The largest counter any group needs for depth complexity bound `k`.
    pub fn counter_bits(&self, k: u32) -> u32 {
        self.entries
            .iter()
            .filter_map(|e| match &e.item {
                Item::Group(g) => Some(g.counter_bits(k)),
                Item::Literal(_) => None,
            })
            .max()
            .unwrap_or(0)
    }

    /// All stencil bits: labels and exits, plus the counter. A single literal needs
    /// a parity bit instead; parity is the counter's lowest bit (both are reset
    /// before every entry), so the two share bits: `label_bits + max(1, counter)`.
    pub fn stencil_bits(&self, k: u32) -> u32 {
        self.label_bits() + self.counter_bits(k).max(1)
    }

    /// Classifies a point by the Blist walk, a group being classified at once.
    pub fn eval(&self, mut inside: impl FnMut(&Literal) -> bool) -> bool {
        walk(
            &self.entries,
            |e| e.label,
            |e| (e.if_true, e.if_false),
            |e| e.item.eval(&mut inside),
        )
    }
}

/// Builds the grouped tree: one atom per group or lone literal. Iterative.
fn grouped_tree(
    pos: &PositiveExpr,
    max_group: usize,
    keep: &dyn Fn(&Group) -> bool,
) -> (Vec<BNode>, u32, Vec<Item>) {
    let parent = pos.parents();
    let op_of = |n: PNodeId| match pos.nodes[n as usize] {
        PNode::Union(..) => Some(GroupKind::Union),
        PNode::Inter(..) => Some(GroupKind::Inter),
        _ => None,
    };
    let mut tree: Vec<BNode> = Vec::new();
    let mut items: Vec<Item> = Vec::new();
    let atom = |tree: &mut Vec<BNode>, items: &mut Vec<Item>, item: Item| -> u32 {
        items.push(item);
        tree.push(BNode::Atom(items.len() as u32 - 1));
        tree.len() as u32 - 1
    };
    if let Some(lit) = pos.nodes[pos.root as usize].literal() {
        let r = atom(&mut tree, &mut items, Item::Literal(lit));
        return (tree, r, items);
    }
    // Cluster roots in increasing index order: sub-clusters come first.
    let mut built: Vec<u32> = vec![u32::MAX; pos.nodes.len()];
    for c in 0..pos.nodes.len() as PNodeId {
        let Some(kind) = op_of(c) else { continue };
        let is_root = c == pos.root || parent[c as usize].is_some_and(|p| op_of(p) != Some(kind));
        if !is_root || (c != pos.root && parent[c as usize].is_none()) {
            continue;
        }
        let (mut literals, mut subs) = (Vec::new(), Vec::new());
        let mut stack = vec![c];
        while let Some(n) = stack.pop() {
            match pos.nodes[n as usize] {
                PNode::Union(a, b) | PNode::Inter(a, b) if op_of(n) == Some(kind) => {
                    stack.push(b);
                    stack.push(a);
                }
                PNode::Leaf { .. } => literals.push(pos.nodes[n as usize].literal().unwrap()),
                _ => subs.push(built[n as usize]),
            }
        }
        let mut parts = Vec::new();
        // Balanced chunks of at most `max_group` literals.
        let chunks = literals.len().div_ceil(max_group);
        let mut rest = &literals[..];
        for k in 0..chunks {
            let take = rest.len().div_ceil(chunks - k);
            let (chunk, tail) = rest.split_at(take);
            rest = tail;
            let group = Group {
                kind,
                literals: chunk.to_vec(),
            };
            if chunk.len() > 1 && keep(&group) {
                parts.push(atom(&mut tree, &mut items, Item::Group(group)));
            } else {
                for &lit in chunk {
                    parts.push(atom(&mut tree, &mut items, Item::Literal(lit)));
                }
            }
        }
        parts.extend(subs);
        let mut acc = parts[0];
        for &p in &parts[1..] {
            tree.push(match kind {
                GroupKind::Union => BNode::Union(acc, p),
                GroupKind::Inter => BNode::Inter(acc, p),
            });
            acc = tree.len() as u32 - 1;
        }
        built[c as usize] = acc;
    }
    let root = built[pos.root as usize];
    (tree, root, items)
}
