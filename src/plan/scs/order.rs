//! A subtraction sequence for one group of touching cutters without rounds
//! (Stewart, Leach & John, "Sequenced convex subtraction", §4: a sequence
//! that holds every chain of cutters a ray can pass through as a subsequence
//! leaves `z` outside them all; sorted front to back, disjoint cutters need one
//! pass).
//!
//! Along one ray, `z` moves from cutter to cutter: out of `Y` through its back
//! face and into a `Y'` that holds the point just behind it, so `Y` and `Y'`
//! touch (their boxes meet: that is how `scs::sequence` groups them). Two
//! touching cutters with a separating plane ([`hull::apart`]) meet every ray in
//! the same order, the one on the eye's side first, so a chain passes them in
//! that order only. Cutters that overlap (no plane found) can be passed in
//! either order: they form *clumps* (connected components of "overlaps").
//! A chain then runs through clumps along the edges "first, then" between
//! them, never returning to a clump it left, so it is a subsequence of:
//! the clumps in a topological order, each spelled out as a sequence that
//! holds every ordering of its members ([`all_orders`]: `a`, `aba`,
//! `abcabca`). That is one application per cutter where the rounds of
//! `scs::sequence` apply every cutter of the group as many times as the group
//! has members.
//!
//! It does not apply, and the group keeps its rounds (a loop with an early
//! out), when the precedence has a cycle, a clump has more than
//! [`MAX_CLUMP`] members (their sequences grow as k² and the rounds' early out
//! then wins), the group has more than [`MAX_GROUP`], or the view or the
//! primitives' hulls are unknown.
#![deny(unsafe_code)]

use super::hull::{self, Hull, Viewpoint};

/// Largest group ordered: the separating-axis tests are quadratic in it (a
/// group of thousands of overlapping cutters keeps its rounds as listed).
pub const MAX_GROUP: usize = 64;

/// Most pairs of cutters one plan tests for a separating plane (each test
/// projects both hulls on up to a few hundred axes): past it, groups keep
/// their rounds as listed.
pub const MAX_PAIR_TESTS: usize = 20_000;

/// Largest clump spelled out statically (its sequence holds `MAX_CLUMP`!
/// orderings in 7 applications).
pub const MAX_CLUMP: usize = 3;

/// How two touching cutters `i < j` of a group relate along rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pair {
    /// Every ray meets `i` first.
    IFirst,
    /// Every ray meets `j` first.
    JFirst,
    /// Either order.
    Overlap,
}

/// The touching pairs of a group of `hulls` (with their world `boxes` meeting),
/// seen from `view`.
pub fn pairs(
    hulls: &[&Hull],
    touch: impl Fn(usize, usize) -> bool,
    view: Viewpoint,
) -> Vec<(usize, usize, Pair)> {
    let mut out = Vec::new();
    for i in 0..hulls.len() {
        for j in i + 1..hulls.len() {
            if !touch(i, j) {
                continue;
            }
            let rel = match hull::apart(hulls[i], hulls[j]) {
                Some(s) if s.a_first(view) => Pair::IFirst,
                Some(_) => Pair::JFirst,
                None => Pair::Overlap,
            };
            out.push((i, j, rel));
        }
    }
    out
}

/// The static sequence of a group of `n` cutters (indices into it) with these
/// touching `pairs`, or `None` where it does not apply (module documentation).
pub fn sequence(n: usize, pairs: &[(usize, usize, Pair)]) -> Option<Vec<usize>> {
    // Clumps: union-find over the overlapping pairs.
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for &(i, j, rel) in pairs {
        if rel == Pair::Overlap {
            let (ri, rj) = (root(&mut parent, i), root(&mut parent, j));
            parent[ri.max(rj)] = ri.min(rj);
        }
    }
    // Clumps numbered by their first member, members in group order.
    let mut clump_of = vec![usize::MAX; n];
    let mut clumps: Vec<Vec<usize>> = Vec::new();
    for i in 0..n {
        let r = root(&mut parent, i);
        if clump_of[r] == usize::MAX {
            clump_of[r] = clumps.len();
            clumps.push(Vec::new());
        }
        clump_of[i] = clump_of[r];
        clumps[clump_of[i]].push(i);
    }
    if clumps.iter().any(|c| c.len() > MAX_CLUMP) {
        return None;
    }
    // "First, then" between clumps; Kahn's topological sort, smallest first.
    let k = clumps.len();
    let mut after: Vec<Vec<usize>> = vec![Vec::new(); k];
    let mut before = vec![0usize; k];
    for &(i, j, rel) in pairs {
        let (a, b) = match rel {
            Pair::IFirst => (clump_of[i], clump_of[j]),
            Pair::JFirst => (clump_of[j], clump_of[i]),
            Pair::Overlap => continue,
        };
        if a != b && !after[a].contains(&b) {
            after[a].push(b);
            before[b] += 1;
        }
    }
    let mut ready: std::collections::BTreeSet<usize> = (0..k).filter(|&c| before[c] == 0).collect();
    let mut out = Vec::new();
    let mut done = 0;
    let touch = |a: usize, b: usize| {
        pairs
            .iter()
            .any(|&(i, j, _)| (i, j) == (a, b) || (i, j) == (b, a))
    };
    while let Some(c) = ready.pop_first() {
        done += 1;
        out.extend(match clumps[c][..] {
            // A path x – y – z (x and z apart, boxes not even touching): a
            // chain is a path of it, and x, z share batches.
            [a, b, c] if !touch(a, c) => vec![a, c, b, a, c],
            [a, b, c] if !touch(a, b) => vec![a, b, c, a, b],
            [a, b, c] if !touch(b, c) => vec![b, c, a, b, c],
            ref m => all_orders(m),
        });
        for &d in &after[c] {
            before[d] -= 1;
            if before[d] == 0 {
                ready.insert(d);
            }
        }
    }
    // A cycle leaves clumps unsorted.
    (done == k).then_some(out)
}

/// An order of a group's `n` cutters for rounds (where [`sequence`] does not
/// apply): separated pairs in ray order where they form no cycle, otherwise
/// (and between overlapping cutters) nearest `depth` first (the depth of a
/// cutter's box's nearest point: a cutter entered first is usually left
/// first). Any order is correct for rounds; a chain that follows it moves in
/// one round, so the rounds' early out comes sooner.
pub fn rounds_order(n: usize, pairs: &[(usize, usize, Pair)], depth: &[f64]) -> Vec<usize> {
    let mut after: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut before = vec![0usize; n];
    for &(i, j, rel) in pairs {
        let (a, b) = match rel {
            Pair::IFirst => (i, j),
            Pair::JFirst => (j, i),
            Pair::Overlap => continue,
        };
        after[a].push(b);
        before[b] += 1;
    }
    let nearest = |set: &[usize]| {
        set.iter()
            .copied()
            .min_by(|&a, &b| depth[a].total_cmp(&depth[b]).then(a.cmp(&b)))
    };
    let mut placed = vec![false; n];
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let left: Vec<usize> = (0..n).filter(|&i| !placed[i]).collect();
        let ready: Vec<usize> = left.iter().copied().filter(|&i| before[i] == 0).collect();
        // A cycle: break it at its nearest member.
        let next = nearest(&ready)
            .or_else(|| nearest(&left))
            .expect("cutters left to place");
        placed[next] = true;
        out.push(next);
        for &b in &after[next] {
            before[b] = before[b].saturating_sub(1);
        }
    }
    out
}

/// One sequence out of `seqs`, sequences of cutters of different groups (no
/// cutter of one touches a cutter of another), by *level*: an entry's level is
/// one more than that of the latest earlier entry of its sequence whose
/// cutter it touches (0 if none). Entries of one level are pairwise apart, so
/// they fill one batch (`scs::subtract`); the order of touching entries,
/// the only order that matters (cutters apart commute: neither exit can land
/// in the other), is kept, and with it every chain the sequences hold.
pub fn by_levels<T: Copy>(seqs: &[Vec<T>], touch: impl Fn(T, T) -> bool) -> Vec<T> {
    let mut entries: Vec<(usize, usize, usize)> = Vec::new();
    for (s, seq) in seqs.iter().enumerate() {
        let mut level: Vec<usize> = Vec::with_capacity(seq.len());
        for (p, &x) in seq.iter().enumerate() {
            let l = (0..p)
                .filter(|&q| touch(seq[q], x))
                .map(|q| level[q] + 1)
                .max()
                .unwrap_or(0);
            level.push(l);
            entries.push((l, s, p));
        }
    }
    entries.sort_unstable();
    entries.into_iter().map(|(_, s, p)| seqs[s][p]).collect()
}

/// A shortest sequence holding every ordering of `members` (at most
/// [`MAX_CLUMP`]) as a subsequence.
pub fn all_orders<T: Copy>(members: &[T]) -> Vec<T> {
    match *members {
        [a] => vec![a],
        [a, b] => vec![a, b, a],
        [a, b, c] => vec![a, b, c, a, b, c, a],
        _ => panic!(
            "clumps of at most {MAX_CLUMP} cutters are spelled out, not {}",
            members.len()
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether `pattern` is a subsequence of `seq`.
    fn holds(seq: &[usize], pattern: &[usize]) -> bool {
        let mut it = seq.iter();
        pattern.iter().all(|p| it.any(|s| s == p))
    }

    fn permutations(v: &[usize]) -> Vec<Vec<usize>> {
        if v.len() <= 1 {
            return vec![v.to_vec()];
        }
        let mut out = Vec::new();
        for i in 0..v.len() {
            let mut rest = v.to_vec();
            let x = rest.remove(i);
            for mut p in permutations(&rest) {
                p.insert(0, x);
                out.push(p);
            }
        }
        out
    }

    #[test]
    fn a_clump_sequence_holds_every_ordering() {
        for n in 1..=MAX_CLUMP {
            let members: Vec<usize> = (0..n).collect();
            let seq = all_orders(&members);
            assert_eq!(seq.len(), [1, 3, 7][n - 1]);
            for p in permutations(&members) {
                assert!(holds(&seq, &p), "{seq:?} lacks {p:?}");
            }
        }
    }

    /// Every chain a ray can take (each step between touching cutters, a
    /// separated pair only in its order, no cutter twice) is a subsequence.
    fn every_chain_holds(n: usize, pairs: &[(usize, usize, Pair)], seq: &[usize]) {
        let rel = |a: usize, b: usize| {
            pairs
                .iter()
                .find_map(|&(i, j, r)| match (i == a && j == b, i == b && j == a) {
                    (true, _) => Some(r),
                    (_, true) => Some(match r {
                        Pair::IFirst => Pair::JFirst,
                        Pair::JFirst => Pair::IFirst,
                        Pair::Overlap => Pair::Overlap,
                    }),
                    _ => None,
                })
        };
        fn grow(
            chain: &mut Vec<usize>,
            n: usize,
            rel: &dyn Fn(usize, usize) -> Option<Pair>,
            seq: &[usize],
        ) {
            assert!(holds(seq, chain), "{seq:?} lacks the chain {chain:?}");
            let last = *chain.last().unwrap();
            for next in 0..n {
                let ok = !chain.contains(&next)
                    && matches!(rel(last, next), Some(Pair::IFirst | Pair::Overlap))
                    && chain.iter().all(|&c| rel(c, next) != Some(Pair::JFirst));
                if ok {
                    chain.push(next);
                    grow(chain, n, rel, seq);
                    chain.pop();
                }
            }
        }
        for start in 0..n {
            grow(&mut vec![start], n, &rel, seq);
        }
    }

    #[test]
    fn separated_cutters_are_applied_once_in_ray_order() {
        use Pair::*;
        // complex's holes: H3 before the counterbore clump {H1, CB1}; a chain
        // 0 → 1 → 2 of separated cutters in that order.
        let pairs = [(0, 1, JFirst), (1, 2, Overlap)];
        let seq = sequence(3, &pairs).unwrap();
        assert_eq!(seq, vec![1, 2, 1, 0]);
        every_chain_holds(3, &pairs, &seq);
        let chain = [(0, 1, IFirst), (1, 2, IFirst), (0, 3, JFirst)];
        let seq = sequence(4, &chain).unwrap();
        assert_eq!(seq, vec![3, 0, 1, 2]);
        every_chain_holds(4, &chain, &seq);
        // Clumps of two and three between separated cutters.
        let mixed = [
            (0, 1, Overlap),
            (1, 2, IFirst),
            (2, 3, Overlap),
            (3, 4, Overlap),
            (0, 5, JFirst),
            (4, 5, JFirst),
        ];
        let seq = sequence(6, &mixed).unwrap();
        assert_eq!(seq, vec![5, 0, 1, 0, 2, 4, 3, 2, 4]);
        every_chain_holds(6, &mixed, &seq);
        // A clump of three that all touch takes every ordering.
        let mut tight = mixed.to_vec();
        tight.push((2, 4, Overlap));
        let seq = sequence(6, &tight).unwrap();
        assert_eq!(seq, vec![5, 0, 1, 0, 2, 3, 4, 2, 3, 4, 2]);
        every_chain_holds(6, &tight, &seq);
        every_chain_holds(6, &mixed, &seq);
    }

    #[test]
    fn levels_fill_batches_and_keep_the_order_of_touching_cutters() {
        // complex's holes: H3 apart from H1; the clump H1, CB1, H1; a slot's
        // ends E1, E2 apart, the box between; EdgeCut alone.
        let seqs = vec![
            vec!["H3", "H1", "CB1", "H1"],
            vec!["E1", "E2", "Box", "E1", "E2"],
            vec!["Edge"],
        ];
        let touching = [("H3", "CB1"), ("H1", "CB1"), ("E1", "Box"), ("E2", "Box")];
        let touch =
            |a: &str, b: &str| a == b || touching.contains(&(a, b)) || touching.contains(&(b, a));
        let out = by_levels(&seqs, touch);
        assert_eq!(
            out,
            vec!["H3", "H1", "E1", "E2", "Edge", "CB1", "Box", "H1", "E1", "E2"]
        );
    }

    #[test]
    fn cycles_and_large_clumps_keep_the_rounds() {
        use Pair::*;
        let cycle = [(0, 1, IFirst), (1, 2, IFirst), (0, 2, JFirst)];
        assert_eq!(sequence(3, &cycle), None);
        let big = [(0, 1, Overlap), (1, 2, Overlap), (2, 3, Overlap)];
        assert_eq!(sequence(4, &big), None);
        // Their rounds follow the rays where they can, else the nearest first.
        assert_eq!(
            rounds_order(4, &big, &[3.0, 1.0, 2.0, 0.0]),
            vec![3, 1, 2, 0]
        );
        let gear = [
            (0, 1, Overlap),
            (0, 2, Overlap),
            (1, 3, Overlap),
            (2, 3, Overlap),
            (1, 2, JFirst),
        ];
        // 0 the top recess, 1 and 2 holes (2 nearer the eye), 3 the bottom recess.
        assert_eq!(
            rounds_order(4, &gear, &[0.0, 1.0, 1.5, 2.0]),
            vec![0, 2, 1, 3]
        );
        assert_eq!(rounds_order(3, &cycle, &[2.0, 1.0, 0.0]), vec![2, 0, 1]);
    }
}
