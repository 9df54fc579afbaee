//! Cross-module property tests: every derived form (Blist, grouped Blist, products,
//! active zones) against the tree, on seeded random expressions; label bounds on
//! left-deep, right-deep, balanced and random trees up to 10⁶ leaves.

use super::blist::label_bound;
use super::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A random expression with `leaves` leaves over `prims` primitive names (so names
/// repeat), random shape, all four operators and random complements.
pub(crate) fn random_expr(rng: &mut impl Rng, leaves: usize, prims: u32) -> Expr {
    let mut nodes = Vec::new();
    let mut pool: Vec<NodeId> = Vec::new();
    let wrap = |nodes: &mut Vec<Node>, rng: &mut dyn rand::RngCore, id: NodeId| -> NodeId {
        if rng.gen_bool(0.2) {
            nodes.push(Node::Not(id));
            nodes.len() as NodeId - 1
        } else {
            id
        }
    };
    for _ in 0..leaves {
        nodes.push(Node::Leaf {
            prim: rng.gen_range(0..prims),
        });
        let id = nodes.len() as NodeId - 1;
        let id = wrap(&mut nodes, rng, id);
        pool.push(id);
    }
    // Combine random adjacent pairs, so leaf order is kept and shapes vary.
    while pool.len() > 1 {
        let i = rng.gen_range(0..pool.len() - 1);
        let (a, b) = (pool[i], pool[i + 1]);
        nodes.push(match rng.gen_range(0..3) {
            0 => Node::Union(a, b),
            1 => Node::Inter(a, b),
            _ => Node::Diff(a, b),
        });
        let id = nodes.len() as NodeId - 1;
        pool[i] = wrap(&mut nodes, rng, id);
        pool.remove(i + 1);
    }
    Expr {
        root: pool[0],
        nodes,
    }
}

/// Tree shapes for label-count tests, built directly as positive arenas.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Shape {
    LeftDeep,
    RightDeep,
    Balanced,
    Random(u64),
}

/// A positive expression of `n` leaves of the given shape; operators alternate by
/// depth (`alt`) or are random (`Random`).
pub(crate) fn shaped(n: usize, shape: Shape, alt: bool) -> PositiveExpr {
    let mut nodes: Vec<PNode> = (0..n)
        .map(|i| PNode::Leaf {
            prim: i as u32,
            leaf: i as u32,
            negated: i % 3 == 1,
        })
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(match shape {
        Shape::Random(s) => s,
        _ => 0,
    });
    let op = |nodes: &mut Vec<PNode>, a: u32, b: u32, level: usize, rng: &mut ChaCha8Rng| {
        let union = match shape {
            Shape::Random(_) => rng.gen_bool(0.5),
            _ => alt && level % 2 == 1,
        };
        nodes.push(if union {
            PNode::Union(a, b)
        } else {
            PNode::Inter(a, b)
        });
        nodes.len() as u32 - 1
    };
    let root = match shape {
        Shape::LeftDeep => {
            let mut acc = 0;
            for i in 1..n {
                acc = op(&mut nodes, acc, i as u32, i, &mut rng);
            }
            acc
        }
        Shape::RightDeep => {
            let mut acc = n as u32 - 1;
            for i in (0..n - 1).rev() {
                acc = op(&mut nodes, i as u32, acc, i, &mut rng);
            }
            acc
        }
        Shape::Balanced => {
            let mut level: Vec<u32> = (0..n as u32).collect();
            let mut depth = 0;
            while level.len() > 1 {
                let mut next = Vec::with_capacity(level.len() / 2 + 1);
                for pair in level.chunks(2) {
                    next.push(if pair.len() == 2 {
                        op(&mut nodes, pair[0], pair[1], depth, &mut rng)
                    } else {
                        pair[0]
                    });
                }
                level = next;
                depth += 1;
            }
            level[0]
        }
        Shape::Random(_) => {
            // Random adjacent merges: a random binary tree (expected depth ~ log n
            // in the middle, deep chains at times).
            let mut pool: Vec<u32> = (0..n as u32).collect();
            // Merge by random positions using a simple "stack of runs" to stay O(n):
            // push leaves, and pop-merge a random number of times.
            let mut stack: Vec<u32> = Vec::new();
            for leaf in pool.drain(..) {
                stack.push(leaf);
                while stack.len() > 1 && rng.gen_bool(0.5) {
                    let b = stack.pop().unwrap();
                    let a = stack.pop().unwrap();
                    let id = op(&mut nodes, a, b, 0, &mut rng);
                    stack.push(id);
                }
            }
            while stack.len() > 1 {
                let b = stack.pop().unwrap();
                let a = stack.pop().unwrap();
                let id = op(&mut nodes, a, b, 0, &mut rng);
                stack.push(id);
            }
            stack[0]
        }
    };
    PositiveExpr { nodes, root }
}

#[test]
fn label_bound_formula() {
    assert_eq!(label_bound(1), 3);
    assert_eq!(label_bound(3), 3);
    assert_eq!(label_bound(4), 4);
    assert_eq!(label_bound(9), 4);
    assert_eq!(label_bound(10), 5);
    assert_eq!(label_bound(3909), 13);
    assert_eq!(label_bound(1_000_000), 21);
}

#[test]
fn blist_walk_equals_tree() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for case in 0..600 {
        let leaves = rng.gen_range(1..=60);
        let prims = rng.gen_range(1..=8);
        let e = random_expr(&mut rng, leaves, prims);
        let pos = PositiveExpr::from_expr(&e);
        let pivoted = Blist::new(&pos);
        let plain = Blist::new_unpivoted(&pos);
        assert!(pivoted.num_labels <= plain.num_labels);
        assert!(
            pivoted.num_labels <= label_bound(leaves as u64),
            "case {case}"
        );
        for b in [&pivoted, &plain] {
            assert_eq!(b.entries.len(), leaves);
            let mut seen: Vec<u32> = b.entries.iter().map(|x| x.leaf).collect();
            seen.sort();
            assert_eq!(seen, (0..leaves as u32).collect::<Vec<_>>());
        }
        for _ in 0..24 {
            let bits: Vec<bool> = (0..leaves).map(|_| rng.gen_bool(0.5)).collect();
            let tree = e.eval(|l, _| bits[l as usize]);
            assert_eq!(
                pos.eval(|l| bits[l.leaf as usize]),
                tree,
                "positive form, case {case}"
            );
            assert_eq!(
                pivoted.eval(|x| bits[x.leaf as usize]),
                tree,
                "pivoted, case {case}"
            );
            assert_eq!(
                plain.eval(|x| bits[x.leaf as usize]),
                tree,
                "unpivoted, case {case}"
            );
        }
    }
}

#[test]
fn paper_examples() {
    // Hable & Rossignac Fig. 10/11: (A+B)(C-(!D-E)).
    let names = [
        "A", "B", "C", "D", "E", "F", "G", "H", "I", "J", "K", "L", "M", "N",
    ];
    let mut resolve = |n: &str| names.iter().position(|&x| x == n).map(|i| i as u32);
    let e = parse("(A+B)(C-(!D-E))", &mut resolve).unwrap();
    let b = Blist::new(&PositiveExpr::from_expr(&e));
    assert!(b.num_labels <= 3, "{b:?}");
    // Hable & Rossignac Fig. 12 claims 4 labels for (AB+CD)E+(FG+HI)J with its
    // strategy.
    let e = parse("(A B+C D)E+(F G+H I)J", &mut resolve).unwrap();
    let b = Blist::new(&PositiveExpr::from_expr(&e));
    assert!(b.num_labels <= 4, "{}", b.num_labels);
    // A single leaf: one label, exits T/F.
    let e = parse("A", &mut resolve).unwrap();
    let b = Blist::new(&PositiveExpr::from_expr(&e));
    assert_eq!(b.num_labels, 1);
    assert_eq!(
        (b.entries[0].if_true, b.entries[0].if_false),
        (Target::True, Target::False)
    );
    let names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    let j = b.to_json(&names);
    assert_eq!(j["leaves"], 1);
    assert_eq!(j["labels"], 1);
    assert_eq!(j["stencil_bits"], 3);
    assert_eq!(j["entries"][0]["if_true"], "T");
    assert_eq!(j["entries"][0]["prim"], "A");
    // The universe: no entries, everything inside.
    let u = Blist::new(&PositiveExpr::universe());
    assert!(u.entries.is_empty() && u.eval(|_| false));
}

/// All full binary trees with `n` leaves and every operator assignment, checked
/// against the bound (exhaustive for small n).
#[test]
fn label_bound_exhaustive_small() {
    // shapes[k]: list of trees as (nodes, root) with leaves numbered 0..k.
    let max_n = 9;
    let mut shapes: Vec<Vec<Vec<PNode>>> = vec![Vec::new(); max_n + 1];
    shapes[1].push(vec![PNode::Leaf {
        prim: 0,
        leaf: 0,
        negated: false,
    }]);
    for n in 2..=max_n {
        let mut out = Vec::new();
        for k in 1..n {
            for l in &shapes[k] {
                for r in &shapes[n - k] {
                    for union in [false, true] {
                        let mut nodes = l.clone();
                        let off = nodes.len() as u32;
                        let lroot = off - 1;
                        for node in r {
                            nodes.push(match *node {
                                PNode::Leaf { .. } => PNode::Leaf {
                                    prim: 0,
                                    leaf: 0,
                                    negated: false,
                                },
                                PNode::Union(a, b) => PNode::Union(a + off, b + off),
                                PNode::Inter(a, b) => PNode::Inter(a + off, b + off),
                                PNode::Universe => unreachable!(),
                            });
                        }
                        let rroot = nodes.len() as u32 - 1;
                        nodes.push(if union {
                            PNode::Union(lroot, rroot)
                        } else {
                            PNode::Inter(lroot, rroot)
                        });
                        out.push(nodes);
                    }
                }
            }
        }
        shapes[n] = out;
    }
    let mut worst = vec![0u32; max_n + 1];
    for n in 1..=max_n {
        for nodes in &shapes[n] {
            let root = nodes.len() as u32 - 1;
            let pos = PositiveExpr {
                nodes: nodes.clone(),
                root,
            };
            let b = Blist::new(&pos);
            worst[n] = worst[n].max(b.num_labels);
            assert!(
                b.num_labels <= label_bound(n as u64),
                "n={n}: {:?} needs {}",
                pos,
                b.num_labels
            );
        }
    }
    eprintln!("worst label counts by leaves: {worst:?}");
}

fn check_large(n: usize, shape: Shape, alt: bool) -> u32 {
    let t = std::time::Instant::now();
    let pos = shaped(n, shape, alt);
    let b = Blist::new(&pos);
    eprintln!(
        "{n} leaves {shape:?} alt={alt}: {} labels (bound {}), {} stencil bits, {:?}",
        b.num_labels,
        label_bound(n as u64),
        b.stencil_bits(),
        t.elapsed()
    );
    assert_eq!(b.entries.len(), n);
    assert!(b.num_labels <= label_bound(n as u64));
    assert!(b.stencil_bits() <= 8);
    b.num_labels
}

#[test]
fn label_bound_shapes() {
    for n in [1, 2, 3, 5, 10, 21, 22, 100, 1000, 4096, 10_000] {
        for alt in [false, true] {
            for shape in [
                Shape::LeftDeep,
                Shape::RightDeep,
                Shape::Balanced,
                Shape::Random(n as u64),
            ] {
                check_large(n, shape, alt);
            }
        }
    }
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..300 {
        let n = rng.gen_range(1..400);
        let pos = shaped(n, Shape::Random(rng.gen()), false);
        assert!(Blist::new(&pos).num_labels <= label_bound(n as u64));
    }
}

#[test]
fn label_bound_million() {
    for shape in [
        Shape::LeftDeep,
        Shape::RightDeep,
        Shape::Balanced,
        Shape::Random(3),
    ] {
        check_large(1_000_000, shape, true);
    }
}

/// Hable & Rossignac §5: a point on leaf L's boundary is on the solid's boundary iff
/// it is in L's active zone; in Boolean terms, toggling L's value changes the
/// expression's value exactly when Z(L) holds. The I form must contain Z, and both
/// Blists must agree with their trees.
#[test]
fn active_zone_property() {
    use active_zone::ActiveZones;
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for case in 0..300 {
        let leaves = rng.gen_range(1..=40);
        let prims = rng.gen_range(1..=6);
        let e = random_expr(&mut rng, leaves, prims);
        let pos = PositiveExpr::from_expr(&e);
        let zones = ActiveZones::new(&pos);
        for leaf in 0..leaves as u32 {
            let z = zones.z_form(leaf);
            let i = zones.i_form(leaf);
            let (zb, ib) = (Blist::new(&z), Blist::new(&i));
            for _ in 0..8 {
                let mut bits: Vec<bool> = (0..leaves).map(|_| rng.gen_bool(0.5)).collect();
                let before = e.eval(|l, _| bits[l as usize]);
                bits[leaf as usize] = !bits[leaf as usize];
                let after = e.eval(|l, _| bits[l as usize]);
                let zv = z.eval(|l| bits[l.leaf as usize]);
                let iv = i.eval(|l| bits[l.leaf as usize]);
                assert_eq!(before != after, zv, "case {case} leaf {leaf}");
                assert!(!zv || iv, "Z is inside I");
                assert_eq!(zb.eval(|x| bits[x.leaf as usize]), zv);
                assert_eq!(ib.eval(|x| bits[x.leaf as usize]), iv);
            }
        }
    }
}

#[test]
fn products_equal_tree() {
    use products::sum_of_products;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let all_overlap = |_p: u32| ([0.0; 3], [1.0; 3]);
    let mut checked = 0;
    for case in 0..400 {
        let leaves = rng.gen_range(1..=16);
        let prims = rng.gen_range(1..=8);
        let e = random_expr(&mut rng, leaves, prims);
        let pos = PositiveExpr::from_expr(&e);
        let Ok(sop) = sum_of_products(&pos, &all_overlap, 20_000) else {
            continue;
        };
        checked += 1;
        for _ in 0..32 {
            // Per primitive: repeated names must agree for P and !P pruning.
            let bits: Vec<bool> = (0..prims).map(|_| rng.gen_bool(0.5)).collect();
            let tree = e.eval(|_, p| bits[p as usize]);
            let sum = sop.iter().any(|p| p.eval(|l| bits[l.prim as usize]));
            assert_eq!(sum, tree, "case {case}");
        }
    }
    assert!(checked > 300);
}

#[test]
fn products_prune_by_boxes() {
    use products::sum_of_products;
    let names = ["A", "B", "C", "D"];
    let mut resolve = |n: &str| names.iter().position(|&x| x == n).map(|i| i as u32);
    // A, B overlap; C is far away; D overlaps A only.
    let boxes = |p: u32| match p {
        0 => ([0.0; 3], [2.0; 3]),
        1 => ([1.0; 3], [3.0; 3]),
        2 => ([10.0; 3], [11.0; 3]),
        _ => ([-1.0; 3], [0.5; 3]),
    };
    let e = parse("(A + C)(B + C) - D - C", &mut resolve).unwrap();
    let sop = sum_of_products(&PositiveExpr::from_expr(&e), &boxes, 100).unwrap();
    // AB!D!C: !D is outside A∩B, !C too -> AB. A C.., C B, C C: C alone, then !C kills it.
    assert_eq!(sop.len(), 1, "{sop:?}");
    let prims: Vec<(u32, bool)> = sop[0]
        .literals
        .iter()
        .map(|l| (l.prim, l.negated))
        .collect();
    assert_eq!(prims, vec![(0, false), (1, false)]);
}

#[test]
fn products_limit_fails_fast() {
    use products::{sum_of_products, ProductError};
    // A product of 40 unions of 2: 2^40 products.
    let mut src = String::new();
    for i in 0..40 {
        src.push_str(&format!("(P{} + Q{}) ", i, i));
    }
    let mut resolve = |n: &str| {
        let (k, i) = n.split_at(1);
        let i: u32 = i.parse().ok()?;
        Some(i * 2 + (k == "Q") as u32)
    };
    let e = parse(&src, &mut resolve).unwrap();
    let pos = PositiveExpr::from_expr(&e);
    let t = std::time::Instant::now();
    let err = sum_of_products(&pos, &|_| ([0.0; 3], [1.0; 3]), 100_000).unwrap_err();
    assert!(t.elapsed().as_secs_f64() < 1.0);
    let ProductError::TooLarge { at_least, limit } = err.clone() else {
        panic!("{err}");
    };
    assert!(at_least > limit as u64);
    assert!(err.to_string().contains("--algo cst-i"), "{err}");
}

/// A deep difference chain of distinct primitives, `P0 − (P1 − (P2 − …))`: few
/// products (n/2) but of up to n literals; refused by the literal count in
/// bounded time and memory instead of growing to n²/4 literals.
#[test]
fn long_products_are_refused_by_their_literals() {
    let n = 20_000u32;
    let mut src = String::new();
    for i in 0..n {
        src.push_str(&format!("P{i} - ("));
    }
    src.push('Q');
    src.push_str(&")".repeat(n as usize));
    let mut resolve = |s: &str| match s {
        "Q" => Some(n),
        _ => s[1..].parse().ok(),
    };
    let e = parse(&src, &mut resolve).unwrap();
    let pos = PositiveExpr::from_expr(&e);
    let t = std::time::Instant::now();
    let err = sum_of_products(&pos, &|_| ([0.0; 3], [1.0; 3]), 1 << 20).unwrap_err();
    assert!(t.elapsed().as_secs_f64() < 10.0, "{:?}", t.elapsed());
    assert!(
        matches!(err, ProductError::TooManyLiterals { at_least, limit } if at_least > limit),
        "{err}"
    );
    assert!(err.to_string().contains("--algo cst-i"), "{err}");
    // A short chain still expands: P0 − (P1 − Q) = P0·!P1 + P0·Q.
    let e = parse("P0 - (P1 - Q)", &mut resolve).unwrap();
    let p = sum_of_products(&PositiveExpr::from_expr(&e), &|_| ([0.0; 3], [1.0; 3]), 64).unwrap();
    assert_eq!(p.len(), 2);
}

#[test]
fn grouped_blist_equals_tree() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for case in 0..600 {
        let leaves = rng.gen_range(1..=60);
        let prims = rng.gen_range(1..=8);
        let e = random_expr(&mut rng, leaves, prims);
        let pos = PositiveExpr::from_expr(&e);
        let g = GroupedBlist::new(&pos);
        let n: usize = g
            .entries
            .iter()
            .map(|e| match &e.item {
                Item::Literal(_) => 1,
                Item::Group(g) => g.literals.len(),
            })
            .sum();
        assert_eq!(n, leaves);
        for _ in 0..24 {
            let bits: Vec<bool> = (0..leaves).map(|_| rng.gen_bool(0.5)).collect();
            let tree = e.eval(|l, _| bits[l as usize]);
            assert_eq!(g.eval(|l| bits[l.leaf as usize]), tree, "case {case}");
        }
    }
}

#[test]
fn chunked_grouped_blist_equals_tree() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for case in 0..400 {
        let leaves = rng.gen_range(1..=60);
        let prims = rng.gen_range(1..=8);
        let max = rng.gen_range(2..=7);
        let e = random_expr(&mut rng, leaves, prims);
        let pos = PositiveExpr::from_expr(&e);
        let g = GroupedBlist::with_max_group(&pos, max);
        let mut n = 0;
        for en in &g.entries {
            match &en.item {
                Item::Literal(_) => n += 1,
                Item::Group(gr) => {
                    assert!(gr.literals.len() <= max, "case {case}");
                    n += gr.literals.len();
                }
            }
        }
        assert_eq!(n, leaves);
        for _ in 0..24 {
            let bits: Vec<bool> = (0..leaves).map(|_| rng.gen_bool(0.5)).collect();
            let tree = e.eval(|l, _| bits[l as usize]);
            assert_eq!(g.eval(|l| bits[l.leaf as usize]), tree, "case {case}");
        }
    }
    // A 37-literal union in chunks of at most 7: six groups, one entry each.
    let names: Vec<String> = (0..37).map(|i| format!("P{i}")).collect();
    let mut resolve = |n: &str| names.iter().position(|x| x == n).map(|i| i as u32);
    let e = parse(&names.join(" + "), &mut resolve).unwrap();
    let g = GroupedBlist::with_max_group(&PositiveExpr::from_expr(&e), 7);
    assert_eq!((g.entries.len(), g.num_groups()), (6, 6), "{g:?}");
}

#[test]
fn groups_counter_data() {
    let names = ["A", "B", "C", "D", "E"];
    let mut resolve = |n: &str| names.iter().position(|&x| x == n).map(|i| i as u32);
    let e = parse("(A + B + C + !D) - E", &mut resolve).unwrap();
    let g = GroupedBlist::new(&PositiveExpr::from_expr(&e));
    assert_eq!(g.entries.len(), 2, "{g:?}");
    let union = g
        .entries
        .iter()
        .find_map(|e| match &e.item {
            Item::Group(g) => Some(g.clone()),
            _ => None,
        })
        .unwrap();
    assert_eq!(union.kind, GroupKind::Union);
    // De Morgan: !A !B !C D -> counter-positive D, counter-negative A, B, C.
    assert_eq!((union.c_p(), union.c_n()), (1, 3));
    assert_eq!(union.c0(2), 5);
    assert_eq!(union.counter_bits(2), 3); // ceil(log2(1 + 3 + 4)) = 3
    assert_eq!(g.stencil_bits(2), g.label_bits() + 3);
    // A left-deep chain of unions is one group.
    let e = parse("A + B + C + D", &mut resolve).unwrap();
    let g = GroupedBlist::new(&PositiveExpr::from_expr(&e));
    assert_eq!((g.entries.len(), g.num_groups()), (1, 1));
}

#[test]
fn boundedness() {
    let names = ["A", "B", "C"];
    let mut resolve = |n: &str| names.iter().position(|&x| x == n).map(|i| i as u32);
    let mut bounded =
        |s: &str| PositiveExpr::from_expr(&parse(s, &mut resolve).unwrap()).is_bounded();
    assert!(bounded("A"));
    assert!(!bounded("!A"));
    assert!(!bounded("!A + B"));
    assert!(bounded("A - B"));
    assert!(bounded("!A B"));
    assert!(!bounded("!(A B)"));
    assert!(bounded("!(!A + !B)"));
    assert!(!bounded("A - (B - C) + !C"));
}
