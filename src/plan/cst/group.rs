//! CST-G (Hable & Rossignac §7, optimization 3): trim against the grouped Blist of
//! the i-zone, classifying a whole same-operator group with a stencil counter instead
//! of one parity draw and two sweeps per literal.
//!
//! Stencil layout `[label | counter]`: the counter occupies the low `counter_bits`,
//! the label the bits above. A single-literal entry uses the counter's bit 0 as its
//! parity bit. For a group (an intersection-group, or a union-group by de Morgan,
//! which [`Group`] describes with `c_p`/`c_n`), each literal's mesh is drawn once
//! with the counter incremented on faces in front of the candidate that enter the
//! primitive and decremented on those that leave it (front/back faces swap for the
//! literals the counter treats as negative), so the counter ends at
//! `#(counter-positive primitives containing X) − #(counter-negative ones)`.
//!
//! The paper starts the counter at `c0 = c_n + k` so it stays positive with depth
//! complexity `k`. We count with wrapping increments under a write mask instead:
//! arithmetic is modulo `2^counter_bits`, intermediate values may wrap, and only the
//! final value matters; it lies in `[−c_n, c_p]`, so `counter_bits =
//! ⌈log₂(c_n + c_p + 1)⌉` distinguishes "in the group" (`≡ c_p`) from every other
//! outcome for any `k`, and `c0 = 0` needs no initialization sweep. Per group: the
//! draws, then three sweeps: matching counter → the group's "in" target; the rest
//! of the label → the "out" target's label, counter and all; zero the counters of
//! that label where a literal drew. Each is scissored to what it can touch (with
//! no counter-positive literal, the last two only cover the literals' boxes).
//!
//! A group is kept only where the counter pays ([`counter_pays`]): with label
//! reuse a plain entry costs one sweep, so a few small holes in a large leaf
//! are cheaper one by one (complex's base plate; Hable & Rossignac §7 counts two
//! sweeps per entry, without reuse).
#![deny(unsafe_code)]

use super::super::common::{next, sweep};
use super::super::stencil::{self, Next};
use super::super::step::*;
use super::super::{PlanError, Prepared};
use super::trim::literal_sweeps;
use super::{parity_draw, tie_draws, Codes, LeafCst, Peeled, Relation, Trimmer, WORK};
use crate::csg::groups::{Group, GroupedBlist, Item};
use crate::scene::Aabb;
use glam::DVec3;

/// Bits to hold `values` distinct values (at least 1).
fn bits_for(values: u32) -> u8 {
    (32 - values.saturating_sub(1).leading_zeros()).max(1) as u8
}

/// Counter bits a group needs (wrapping arithmetic, see the module comment).
pub fn group_counter_bits(g: &Group) -> u8 {
    bits_for(g.c_p() + g.c_n() + 1)
}

/// `[label | counter]` layout of one CST-G trim.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GroupLayout {
    pub labels: u32,
    pub label_bits: u8,
    pub counter_bits: u8,
}

impl GroupLayout {
    /// The layout of `blist` with `labels` distinct entry labels.
    pub fn new(blist: &GroupedBlist, labels: u32) -> Result<Self, PlanError> {
        let counter_bits = blist
            .entries
            .iter()
            .filter_map(|e| match &e.item {
                Item::Group(g) => Some(group_counter_bits(g)),
                Item::Literal(_) => None,
            })
            .max()
            .unwrap_or(1)
            .max(1);
        let label_bits = bits_for(labels + 2);
        if label_bits as u32 + counter_bits as u32 > 8 {
            return Err(PlanError::StencilBits {
                algo: "cst-g",
                label_bits,
                counter_bits,
            });
        }
        Ok(GroupLayout {
            labels,
            label_bits,
            counter_bits,
        })
    }
    pub fn bits(&self) -> u8 {
        self.label_bits + self.counter_bits
    }
    pub fn counter_mask(&self) -> u8 {
        ((1u32 << self.counter_bits) - 1) as u8
    }
    pub fn label_mask(&self) -> u8 {
        ((((1u32 << self.label_bits) - 1) << self.counter_bits) & 0xff) as u8
    }
    pub fn all_mask(&self) -> u8 {
        self.label_mask() | self.counter_mask()
    }
    pub fn value(&self, n: Next) -> u8 {
        let l = match n {
            Next::Label(l) => l,
            Next::True => self.labels,
            Next::False => self.labels + 1,
        };
        (l << self.counter_bits) as u8
    }
}

/// Surface area of a box (0 when empty): proportional to its mean projected
/// area over all view directions (Cauchy), so a camera-free estimate of the
/// pixels a sweep scissored to it covers.
fn area(b: &Aabb) -> f64 {
    let d = (b.max - b.min).max(DVec3::ZERO);
    2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
}

fn meet(a: &Aabb, b: &Aabb) -> Aabb {
    Aabb {
        min: a.min.max(b.min),
        max: a.max.min(b.max),
    }
}

/// Whether the counter classifies `g` with fewer swept pixels than one Blist
/// entry per literal, for the peeled leaf with box `me` (`boxes` per mesh).
///
/// The counter costs three sweeps (see [`GroupTrimmer::trim`]): one over the
/// leaf (or the counter-positive boxes in it), and two over the literals' boxes
/// in the leaf (or one of them and one over the leaf, when some literal is
/// counter-positive). One entry per literal costs one sweep each, label reuse
/// leaving out the other: over the literal's box in the leaf for a
/// counter-negative literal (e.g. a hole `!H` of an intersection: parity set →
/// rejected), over the whole leaf for a counter-positive one. A sweep's fixed
/// cost is counted as 1/16 of the leaf. So a block minus a few small holes
/// keeps one sweep per hole (complex's base plate: 3 sweeps over the plate cost
/// more than 10 over the holes), and a big intersection or a union of large
/// overlapping teeth is counted.
pub fn counter_pays(g: &Group, me: &Aabb, boxes: &[Aabb]) -> bool {
    let of = |l: &crate::csg::Literal| boxes.get(l.prim as usize).copied().unwrap_or(*me);
    let positive = |l: &crate::csg::Literal| l.negated == g.inverted();
    let leaf = area(me);
    let fixed = leaf / 16.0;
    let drawn = g
        .literals
        .iter()
        .map(|l| meet(&of(l), me))
        .reduce(|u, b| Aabb {
            min: u.min.min(b.min),
            max: u.max.max(b.max),
        });
    let drawn = drawn.map_or(0.0, |b| area(&b));
    let counter = if g.literals.iter().any(positive) {
        let inside = g
            .literals
            .iter()
            .filter(|l| positive(l))
            .fold(*me, |b, l| meet(&b, &of(l)));
        area(&inside) + leaf + drawn
    } else {
        leaf + 2.0 * drawn
    } + 3.0 * fixed;
    let literals: f64 = g
        .literals
        .iter()
        .map(|l| {
            fixed
                + if positive(l) {
                    leaf
                } else {
                    area(&meet(&of(l), me))
                }
        })
        .sum();
    counter <= literals
}

/// Trim(V) of one leaf against its grouped i-zone.
#[derive(Clone, Debug)]
pub struct GroupTrimmer {
    peeled: Peeled,
    blist: GroupedBlist,
    layout: GroupLayout,
    /// Per entry, its stencil label (see [`assign_labels`]).
    labels: Vec<u32>,
    /// Per entry, its (if_true, if_false) in stencil labels.
    targets: Vec<(Next, Next)>,
    /// How the literals relate to the peeled mesh: `Inter` for a leaf's i-zone,
    /// `Surface` for a `[[surface]]`'s trimming volume.
    relation: Relation,
}

/// Stencil labels for the entries of a grouped Blist whose targets name entry
/// indices: the smallest free label when an entry is first referenced, freed when
/// it is reached (label reuse, Hilbrich §5.3.3). A group's label is freed only
/// after its own targets have theirs, so a group's target never shares its label:
/// a counter sweep could not tell pixels moved to such a target from pixels
/// still to be classified (at most one label over plain reuse). A literal
/// (`reuse[i]`) frees its label first: its parity sweeps handle a target at
/// their own label (`literal_sweeps`) and leave out that sweep.
pub fn assign_labels(targets: &[(Next, Next)], reuse: &[bool]) -> Vec<u32> {
    let mut label = vec![u32::MAX; targets.len()];
    let mut used: Vec<bool> = Vec::new();
    let alloc = |used: &mut Vec<bool>| match used.iter().position(|u| !u) {
        Some(i) => {
            used[i] = true;
            i as u32
        }
        None => {
            used.push(true);
            used.len() as u32 - 1
        }
    };
    if targets.is_empty() {
        return label;
    }
    label[0] = alloc(&mut used);
    for (i, &(t, f)) in targets.iter().enumerate() {
        if reuse[i] {
            used[label[i] as usize] = false;
        }
        for n in [t, f] {
            if let Next::Label(j) = n {
                if label[j as usize] == u32::MAX {
                    label[j as usize] = alloc(&mut used);
                }
            }
        }
        if !reuse[i] {
            used[label[i] as usize] = false;
        }
    }
    label
}

/// Entry-index targets mapped to stencil labels.
fn relabel(targets: &[(Next, Next)], labels: &[u32]) -> Vec<(Next, Next)> {
    let m = |n: Next| match n {
        Next::Label(j) => Next::Label(labels[j as usize]),
        other => other,
    };
    targets.iter().map(|&(t, f)| (m(t), m(f))).collect()
}

impl GroupTrimmer {
    pub fn new(prep: &Prepared, c: &LeafCst) -> Result<Self, PlanError> {
        let zone = c.zone.as_ref().expect("a trimmed leaf has a zone");
        let boxes = &prep.mesh_bounds;
        let keep = |g: &Group| match boxes.get(c.peeled.prim as usize) {
            Some(me) => counter_pays(g, me, boxes),
            None => true,
        };
        let (blist, layout) = Self::chunked(zone, &keep)?;
        let by_entry = Self::targets(&blist);
        let labels = assign_labels(&by_entry, &Self::literals(&blist));
        let targets = relabel(&by_entry, &labels);
        Ok(GroupTrimmer {
            peeled: c.peeled,
            blist,
            layout,
            labels,
            targets,
            relation: Relation::Inter,
        })
    }

    /// The same trim with another tie rule (see [`Relation`]).
    pub fn with_relation(mut self, relation: Relation) -> Self {
        self.relation = relation;
        self
    }

    /// The grouped Blist of `zone` with groups small enough that the labels and the
    /// counter fit in 8 stencil bits: a group of `n` literals needs
    /// `⌈log₂(n + 1)⌉` counter bits, so with `b` label bits groups are split into
    /// chunks of at most `2^(8 − b) − 1` literals; splitting adds entries (labels),
    /// so this repeats with the new label count until it fits (the cap only falls).
    pub fn chunked(
        zone: &crate::csg::PositiveExpr,
        keep: &dyn Fn(&Group) -> bool,
    ) -> Result<(GroupedBlist, GroupLayout), PlanError> {
        let mut max = usize::MAX;
        loop {
            let blist = GroupedBlist::grouped(zone, max, keep);
            let labels = assign_labels(&Self::targets(&blist), &Self::literals(&blist))
                .into_iter()
                .max()
                .map_or(1, |m| m + 1);
            let err = match GroupLayout::new(&blist, labels) {
                Ok(layout) => return Ok((blist, layout)),
                Err(e) => e,
            };
            let label_bits = bits_for(labels + 2) as u32;
            let largest = blist
                .entries
                .iter()
                .map(|e| match &e.item {
                    Item::Group(g) => g.literals.len(),
                    Item::Literal(_) => 1,
                })
                .max()
                .unwrap_or(1);
            let cap = if label_bits >= 8 {
                0
            } else {
                (1usize << (8 - label_bits)) - 1
            };
            let next = cap.min(largest - 1);
            if next < 2 {
                return Err(err);
            }
            max = next;
        }
    }

    /// Per entry, whether it is a single literal.
    fn literals(blist: &GroupedBlist) -> Vec<bool> {
        blist
            .entries
            .iter()
            .map(|e| matches!(e.item, Item::Literal(_)))
            .collect()
    }

    /// The Blist's targets as entry indices: a target `Label(l)` of entry `i` is
    /// the first later entry carrying `l` (relabelled by [`assign_labels`]).
    fn targets(blist: &GroupedBlist) -> Vec<(Next, Next)> {
        let es = &blist.entries;
        let map = |i: usize, t: crate::csg::Target| match t {
            crate::csg::Target::Label(l) => Next::Label(
                (i + 1..es.len())
                    .find(|&j| es[j].label == l)
                    .expect("a label target has a later entry") as u32,
            ),
            other => next(other),
        };
        es.iter()
            .enumerate()
            .map(|(i, e)| (map(i, e.if_true), map(i, e.if_false)))
            .collect()
    }
    pub fn blist(&self) -> &GroupedBlist {
        &self.blist
    }
    #[cfg(test)]
    pub fn layout(&self) -> GroupLayout {
        self.layout
    }
}

impl Trimmer for GroupTrimmer {
    fn codes(&self) -> Codes {
        let l = &self.layout;
        Codes::new(
            Next::Label(self.labels.first().copied().unwrap_or(0)),
            |n| l.value(n),
            l.all_mask(),
            l.bits(),
        )
    }
    fn trim(&self, steps: &mut Vec<Step>) {
        let l = &self.layout;
        let (label_mask, all_mask, counter_mask) = (l.label_mask(), l.all_mask(), l.counter_mask());
        let me = vec![self.peeled.prim];
        for (i, e) in self.blist.entries.iter().enumerate() {
            let here = l.value(Next::Label(self.labels[i]));
            let (t, f) = self.targets[i];
            match &e.item {
                Item::Literal(lit) => {
                    let (on_inside, on_outside) = if lit.negated { (f, t) } else { (t, f) };
                    for (compare, cull) in
                        tie_draws(&self.peeled, lit.prim, lit.leaf, lit.negated, self.relation)
                    {
                        steps.push(parity_draw(
                            lit.prim,
                            self.peeled.prim,
                            compare,
                            cull,
                            stencil::toggle_parity(here, label_mask, 1),
                        ));
                    }
                    steps.extend(literal_sweeps(
                        lit.prim,
                        self.peeled.prim,
                        here,
                        1,
                        (l.value(on_inside), l.value(on_outside)),
                        all_mask,
                    ));
                }
                Item::Group(g) => {
                    let inverted = g.inverted();
                    let (mut meshes, mut positive) = (Vec::new(), Vec::new());
                    for lit in &g.literals {
                        // Counter-positive: the literal (or, inverted, its complement)
                        // holds inside the primitive.
                        let counter_positive = lit.negated == inverted;
                        let (enter, leave) = if counter_positive {
                            (StencilOp::IncrementAndWrap, StencilOp::DecrementAndWrap)
                        } else {
                            (StencilOp::DecrementAndWrap, StencilOp::IncrementAndWrap)
                        };
                        let face = |pass| StencilFace {
                            compare: CompareOp::Equal,
                            fail: StencilOp::Keep,
                            pass,
                            depth_fail: StencilOp::Keep,
                        };
                        // Front faces in front of X enter the mesh, back faces leave it.
                        let st = StencilState {
                            front: face(enter),
                            back: face(leave),
                            compare_mask: label_mask,
                            write_mask: counter_mask,
                            reference: here,
                        };
                        for (compare, cull) in
                            tie_draws(&self.peeled, lit.prim, lit.leaf, lit.negated, self.relation)
                        {
                            steps.push(parity_draw(lit.prim, self.peeled.prim, compare, cull, st));
                        }
                        meshes.push(lit.prim);
                        if counter_positive {
                            positive.push(lit.prim);
                        }
                    }
                    let target = (g.c_p() as u8) & counter_mask;
                    // In the intersection-group (or out of the union-group, inverted).
                    let (on_match, on_other) = if inverted { (f, t) } else { (t, f) };
                    let drawn = Scissor::Overlap {
                        of: meshes,
                        and: me.clone(),
                    };
                    // The counter reaches c_p only inside every counter-positive
                    // primitive, and is non-zero only where some literal drew.
                    steps.push(sweep(
                        WORK,
                        Scissor::Overlap {
                            of: me.clone(),
                            and: positive.clone(),
                        },
                        stencil::change_stencil_state(here | target, l.value(on_match), all_mask),
                    ));
                    // The rest of this label goes to the other target, counter
                    // and all: with no counter-positive literal (c_p = 0) the match
                    // took every pixel whose counter stayed 0, so the rest lies
                    // where a literal drew.
                    let rest = if positive.is_empty() {
                        drawn.clone()
                    } else {
                        Scissor::BoundsOf(me.clone())
                    };
                    let other = l.value(on_other);
                    steps.push(sweep(
                        WORK,
                        rest,
                        stencil::both(
                            CompareOp::Equal,
                            StencilOp::Invert,
                            label_mask,
                            here ^ other,
                            here,
                        ),
                    ));
                    // Then the counters they brought are zeroed (the other
                    // target's earlier pixels have zero counters already).
                    steps.push(sweep(
                        WORK,
                        drawn,
                        stencil::both(
                            CompareOp::Equal,
                            StencilOp::Zero,
                            label_mask,
                            counter_mask,
                            other,
                        ),
                    ));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csg::{parse, PositiveExpr};
    use rand::{Rng, SeedableRng};

    /// Labels are reused, a target never shares its source's label, and two
    /// entries pending at the same time never share one.
    #[test]
    fn assigned_labels_are_safe_and_reused() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let names = ["A", "B", "C", "D", "E", "F", "G", "H"];
        for _ in 0..200 {
            let mut src = String::new();
            for i in 0..rng.gen_range(2..30) {
                if i > 0 {
                    src.push_str(["+", "-", " "][rng.gen_range(0..3)]);
                }
                src.push_str(names[rng.gen_range(0..names.len())]);
            }
            let e = parse(&src, &mut |n: &str| {
                names.iter().position(|x| *x == n).map(|i| i as u32)
            })
            .unwrap();
            let blist = GroupedBlist::with_max_group(&PositiveExpr::from_expr(&e), 3);
            let by_entry = GroupTrimmer::targets(&blist);
            let literal = GroupTrimmer::literals(&blist);
            let labels = assign_labels(&by_entry, &literal);
            for (i, &(t, f)) in by_entry.iter().enumerate() {
                for n in [t, f] {
                    if let Next::Label(j) = n {
                        assert!(
                            literal[i] || labels[j as usize] != labels[i],
                            "{src}: group {i} targets its own label"
                        );
                        // No entry between i and j holds j's label while j is pending.
                        for k in i + 1..j as usize {
                            assert!(labels[k] != labels[j as usize] || k == j as usize, "{src}");
                        }
                    }
                }
            }
            let distinct = labels.iter().copied().max().unwrap_or(0) + 1;
            assert!(distinct as usize <= blist.entries.len());
        }
    }
}
