//! The Blist of a positive CSG expression: a linear list of literals, each with an
//! integer label and the labels to go to when its literal is true or false, so that
//! a point is classified by one left-to-right walk and a few stencil bits.
//!
//! Follows Hable & Rossignac §3: the `lml` pass (each node learns the
//! left-most leaf of its right child, stored as its `f` for a union and its `t` for
//! an intersection) and the `mb` pass (push `pt`/`pf` down, replacing them by the
//! node's values when going left), which are Hilbrich's next/match/flip (her
//! §5.3.2). Labels are integers allocated when a leaf is first referenced (the
//! smallest free one) and freed when its entry is reached (Hilbrich §5.3.3,
//! Hable & Rossignac Fig. 11). Both passes here are iterative.
//!
//! **Pivoting** (Hable & Rossignac §3, "left-heavy"): unions and intersections may
//! swap their operands. We choose, per node, the order that minimises the number of
//! labels the subtree needs, by an exact bottom-up dynamic programme (a
//! Sethi–Ullman/Strahler number refined by which of the node's two exits is already
//! holding a label when the walk enters it), then apply the choices top-down. See
//! `label_need` for the recurrence.

use super::positive::{Literal, PNode, PositiveExpr};
use super::LeafId;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// Where a Blist entry sends the walk.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Target {
    /// The entry (later in the list) carrying this label.
    Label(u32),
    /// Exit: the point is in the expression.
    True,
    /// Exit: the point is not in the expression.
    False,
}

/// One literal of a Blist with its label and its two successors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlistEntry {
    pub(crate) prim: u32,
    pub(crate) leaf: LeafId,
    pub(crate) negated: bool,
    pub(crate) label: u32,
    pub(crate) if_true: Target,
    pub(crate) if_false: Target,
}

impl BlistEntry {
    /// The entry's literal.
    pub fn literal(&self) -> Literal {
        Literal {
            prim: self.prim,
            leaf: self.leaf,
            negated: self.negated,
        }
    }
}

/// A Blist: entries in walk order and the number of distinct integer labels they use
/// (exits not counted). No entries means the universe (every point is in it).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Blist {
    pub(crate) entries: Vec<BlistEntry>,
    pub(crate) num_labels: u32,
}

/// Bits needed to store `values` distinct values (at least 1).
pub(crate) fn bits_for(values: u64) -> u32 {
    let mut bits = 1;
    while (1u64 << bits) < values {
        bits += 1;
    }
    bits
}

impl Blist {
    /// Builds the Blist of `pos`, pivoting commutative nodes to minimise labels.
    pub fn new(pos: &PositiveExpr) -> Self {
        Self::build(pos, true)
    }

    /// Builds the Blist of `pos` in the order written (no pivoting); for comparison.
    pub fn new_unpivoted(pos: &PositiveExpr) -> Self {
        Self::build(pos, false)
    }

    fn build(pos: &PositiveExpr, pivot: bool) -> Self {
        if pos.is_universe() {
            return Blist {
                entries: Vec::new(),
                num_labels: 0,
            };
        }
        let tree: Vec<BNode> = pos
            .nodes
            .iter()
            .enumerate()
            .map(|(i, n)| match *n {
                PNode::Leaf { .. } => BNode::Atom(i as u32),
                PNode::Union(a, b) => BNode::Union(a, b),
                PNode::Inter(a, b) => BNode::Inter(a, b),
                PNode::Universe => panic!("the universe is only ever a whole expression"),
            })
            .collect();
        let layout = layout(&tree, pos.root, pivot);
        let entries = layout
            .entries
            .iter()
            .map(|e| {
                let lit = pos.nodes[e.atom as usize].literal().unwrap();
                BlistEntry {
                    prim: lit.prim,
                    leaf: lit.leaf,
                    negated: lit.negated,
                    label: e.label,
                    if_true: e.if_true,
                    if_false: e.if_false,
                }
            })
            .collect();
        Blist {
            entries,
            num_labels: layout.num_labels,
        }
    }

    /// Number of distinct integer labels (exits not counted).
    pub fn num_labels(&self) -> u32 {
        self.num_labels
    }

    /// Stencil bits for a label: the labels plus the two exit values.
    pub fn label_bits(&self) -> u32 {
        bits_for(self.num_labels as u64 + 2)
    }

    /// Stencil bits for the Blister classification: label bits plus one parity bit.
    pub fn stencil_bits(&self) -> u32 {
        self.label_bits() + 1
    }

    /// Classifies a point by the Blist walk. `inside(entry)` says whether the
    /// point is inside `entry.prim`; the complement is applied here.
    pub fn eval(&self, mut inside: impl FnMut(&BlistEntry) -> bool) -> bool {
        walk(
            &self.entries,
            |e| e.label,
            |e| (e.if_true, e.if_false),
            |e| e.literal().holds(inside(e)),
        )
    }

    /// The JSON of `peeltrim blist` (docs/cli.md): `leaves`, `labels`,
    /// `stencil_bits`, `entries` with exits written `"T"` / `"F"`.
    pub fn to_json(&self, prim_names: &[String]) -> serde_json::Value {
        let target = |t: Target| match t {
            Target::Label(l) => serde_json::json!(l),
            Target::True => serde_json::json!("T"),
            Target::False => serde_json::json!("F"),
        };
        let entries: Vec<serde_json::Value> = self
            .entries
            .iter()
            .map(|e| {
                let name = prim_names
                    .get(e.prim as usize)
                    .cloned()
                    .unwrap_or_else(|| format!("#{}", e.prim));
                serde_json::json!({
                    "prim": name,
                    "negated": e.negated,
                    "label": e.label,
                    "if_true": target(e.if_true),
                    "if_false": target(e.if_false),
                })
            })
            .collect();
        serde_json::json!({
            "leaves": self.entries.len(),
            "labels": self.num_labels,
            "stencil_bits": self.stencil_bits(),
            "entries": entries,
        })
    }
}

/// The walk shared by the plain and the grouped Blist: start at the first entry's
/// label; an entry whose label is current moves to `if_true` or `if_false` by
/// `holds(entry)`; other entries are skipped. An empty list is the universe.
pub(crate) fn walk<E>(
    entries: &[E],
    label: impl Fn(&E) -> u32,
    targets: impl Fn(&E) -> (Target, Target),
    mut holds: impl FnMut(&E) -> bool,
) -> bool {
    let Some(first) = entries.first() else {
        return true;
    };
    let mut current = Target::Label(label(first));
    for e in entries {
        if current == Target::Label(label(e)) {
            let (t, f) = targets(e);
            current = if holds(e) { t } else { f };
        }
    }
    current == Target::True
}

// ---------------------------------------------------------------------------------
// The generic core: a binary tree of opaque atoms (literals here, literals or
// groups in `groups.rs`) to an ordered, labelled list.

/// A node of the tree handed to [`layout`]; children have smaller indices.
#[derive(Clone, Copy, Debug)]
pub(crate) enum BNode {
    Atom(u32),
    Union(u32, u32),
    Inter(u32, u32),
}

pub(crate) struct LaidOut {
    pub atom: u32,
    pub label: u32,
    pub if_true: Target,
    pub if_false: Target,
}

pub(crate) struct Layout {
    pub entries: Vec<LaidOut>,
    pub num_labels: u32,
}

/// State of one exit (`pt` or `pf`) of a subtree when the walk enters it.
/// `Exit`: T or F, never costs a label. `Live`: a label already referenced, held
/// throughout. `Pending`: a label not referenced yet; it costs from its first use on.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Exit {
    Exit = 0,
    Live = 1,
    Pending = 2,
}

impl Exit {
    const ALL: [Exit; 3] = [Exit::Exit, Exit::Live, Exit::Pending];
    /// The state after the subtree that can reach it has been walked: every subtree
    /// reaches both its exits, so a label exit is then referenced.
    fn referenced(self) -> Exit {
        if self == Exit::Exit {
            Exit::Exit
        } else {
            Exit::Live
        }
    }
    fn cost(self) -> u8 {
        (self == Exit::Live) as u8
    }
}

fn state(pt: Exit, pf: Exit) -> usize {
    pt as usize * 3 + pf as usize
}

/// The label need of `op(first, second)` entered with exits `(pt, pf)`, given the
/// needs of its operands for every exit state.
///
/// Labels live while a subtree is walked are: those of its own entries referenced
/// so far, its two exits once referenced, and for every ancestor whose *first*
/// operand contains it, that ancestor's exit which the first operand cannot reach
/// (it stays held, unchanged, during the whole first operand). Hence:
/// - leaf: `1 + cost(pt) + cost(pf)` (its own label plus its held exits);
/// - union `x + y`: `x` gets `(pt, Pending)` (its false exit is `y`'s first leaf)
///   while `pf` stays held: `need(x) + cost(pf)`; then `y` gets `(pt referenced, pf)`;
/// - intersection `x y`: symmetric with the roles of `pt` and `pf` exchanged.
///
/// The label count of a Blist equals the largest number of simultaneously live
/// labels (labels are intervals from first reference to entry, coloured greedily in
/// order of first reference), so minimising this over the operand order at every
/// node gives the optimal pivoting (swaps only; reassociation is not attempted).
fn combine(union: bool, first: &[u8; 9], second: &[u8; 9], pt: Exit, pf: Exit) -> u8 {
    if union {
        (first[state(pt, Exit::Pending)] + pf.cost()).max(second[state(pt.referenced(), pf)])
    } else {
        (first[state(Exit::Pending, pf)] + pt.cost()).max(second[state(pt, pf.referenced())])
    }
}

/// Bottom-up label needs of every node for every `(pt, pf)` state.
fn label_need(tree: &[BNode], pivot: bool) -> Vec<[u8; 9]> {
    let mut need = vec![[0u8; 9]; tree.len()];
    for i in 0..tree.len() {
        let mut g = [0u8; 9];
        for pt in Exit::ALL {
            for pf in Exit::ALL {
                g[state(pt, pf)] = match tree[i] {
                    BNode::Atom(_) => 1 + pt.cost() + pf.cost(),
                    BNode::Union(a, b) | BNode::Inter(a, b) => {
                        let union = matches!(tree[i], BNode::Union(..));
                        let (na, nb) = (&need[a as usize], &need[b as usize]);
                        let written = combine(union, na, nb, pt, pf);
                        if pivot {
                            written.min(combine(union, nb, na, pt, pf))
                        } else {
                            written
                        }
                    }
                };
            }
        }
        need[i] = g;
    }
    need
}

/// Orders, links (`lml`/`mb`) and labels the atoms of `tree` rooted at `root`.
/// Children must have smaller indices than parents.
pub(crate) fn layout(tree: &[BNode], root: u32, pivot: bool) -> Layout {
    let need = label_need(tree, pivot);

    // Top-down: choose each reachable node's operand order for the exit state in
    // which the walk will enter it (ties keep the written order).
    let mut swapped = vec![false; tree.len()];
    let mut stack = vec![(root, Exit::Exit, Exit::Exit)];
    while let Some((n, pt, pf)) = stack.pop() {
        let (union, a, b) = match tree[n as usize] {
            BNode::Atom(_) => continue,
            BNode::Union(a, b) => (true, a, b),
            BNode::Inter(a, b) => (false, a, b),
        };
        let (na, nb) = (&need[a as usize], &need[b as usize]);
        let swap = pivot && combine(union, nb, na, pt, pf) < combine(union, na, nb, pt, pf);
        swapped[n as usize] = swap;
        let (x, y) = if swap { (b, a) } else { (a, b) };
        if union {
            stack.push((y, pt.referenced(), pf));
            stack.push((x, pt, Exit::Pending));
        } else {
            stack.push((y, pt, pf.referenced()));
            stack.push((x, Exit::Pending, pf));
        }
    }
    let order = |n: u32| -> (u32, u32) {
        match tree[n as usize] {
            BNode::Union(a, b) | BNode::Inter(a, b) => {
                if swapped[n as usize] {
                    (b, a)
                } else {
                    (a, b)
                }
            }
            BNode::Atom(_) => unreachable!(),
        }
    };

    // lml: the left-most (first-walked) leaf of every node, bottom-up.
    let mut lml = vec![0u32; tree.len()];
    for i in 0..tree.len() {
        lml[i] = match tree[i] {
            BNode::Atom(_) => i as u32,
            _ => lml[order(i as u32).0 as usize],
        };
    }

    // mb: push pt/pf down; going to the first operand, a union replaces pf and an
    // intersection replaces pt by the left-most leaf of the second operand.
    #[derive(Clone, Copy, PartialEq)]
    enum T {
        Node(u32),
        True,
        False,
    }
    let mut seq: Vec<(u32, T, T)> = Vec::new();
    let mut stack = vec![(root, T::True, T::False)];
    while let Some((n, pt, pf)) = stack.pop() {
        match tree[n as usize] {
            BNode::Atom(_) => seq.push((n, pt, pf)),
            BNode::Union(..) | BNode::Inter(..) => {
                let (x, y) = order(n);
                stack.push((y, pt, pf));
                let next = T::Node(lml[y as usize]);
                if matches!(tree[n as usize], BNode::Union(..)) {
                    stack.push((x, pt, next));
                } else {
                    stack.push((x, next, pf));
                }
            }
        }
    }

    // Labels: the first entry gets 0; a leaf gets the smallest free label when it
    // is first referenced; an entry's label is freed when the walk reaches it
    // (before its successors are allocated, so they may reuse it).
    const NONE: u32 = u32::MAX;
    let mut label = vec![NONE; tree.len()];
    let mut free: BinaryHeap<Reverse<u32>> = BinaryHeap::new();
    let mut fresh = 0u32;
    let mut alloc = |free: &mut BinaryHeap<Reverse<u32>>| -> u32 {
        if let Some(Reverse(l)) = free.pop() {
            l
        } else {
            fresh += 1;
            fresh - 1
        }
    };
    if let Some(&(first, _, _)) = seq.first() {
        label[first as usize] = alloc(&mut free);
    }
    let mut entries = Vec::with_capacity(seq.len());
    for &(atom, pt, pf) in &seq {
        let own = label[atom as usize];
        debug_assert_ne!(own, NONE, "every entry is referenced before it is reached");
        free.push(Reverse(own));
        let mut resolve = |t: T| -> Target {
            match t {
                T::True => Target::True,
                T::False => Target::False,
                T::Node(m) => {
                    if label[m as usize] == NONE {
                        label[m as usize] = alloc(&mut free);
                    }
                    Target::Label(label[m as usize])
                }
            }
        };
        let if_true = resolve(pt);
        let if_false = resolve(pf);
        entries.push(LaidOut {
            atom: tree[atom as usize].atom(),
            label: own,
            if_true,
            if_false,
        });
    }
    let num_labels = fresh;
    debug_assert_eq!(
        num_labels as u8,
        need[root as usize][state(Exit::Exit, Exit::Exit)],
        "the label need recurrence predicts the greedy labelling"
    );
    Layout {
        entries,
        num_labels,
    }
}

impl BNode {
    fn atom(&self) -> u32 {
        match *self {
            BNode::Atom(a) => a,
            _ => unreachable!(),
        }
    }
}

/// The label count promised for `n` leaves: ⌈log₂(2n/3 + 2)⌉ + 1.
pub fn label_bound(n: u64) -> u32 {
    // Smallest b with 2^b >= 2n/3 + 2, i.e. 3 * 2^b >= 2n + 6, in integers.
    let mut b = 0u32;
    while 3u128 * (1u128 << b) < 2 * n as u128 + 6 {
        b += 1;
    }
    b + 1
}
