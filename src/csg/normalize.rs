//! OpenSCAD's normalization of a CSG tree into a union of products, so that the
//! OpenCSG baseline (`peeltrim bench --baseline opencsg`) is driven exactly as
//! OpenSCAD's preview drives it (Stewart, Leach & John §3.2 describes the same
//! expansion; the rules are Goldfeather et al.'s, *Near real-time CSG rendering using
//! tree normalization and geometric pruning*, 1989).
//!
//! Unlike [`super::products::sum_of_products`] (bottom-up over the positive form,
//! deduplicating literals), this keeps OpenSCAD's shape of the work:
//! - complements are pushed to the leaves first (OpenSCAD has no `!`): a
//!   complemented leaf that ends up intersected is subtracted, and vice versa;
//! - the nine rewrite rules are applied top down, repeatedly, until none applies:
//!   `x−(y+z)→(x−y)−z`, `x*(y+z)→x*y+x*z`, `x−(y*z)→(x−y)+(x−z)`,
//!   `x*(y*z)→(x*y)*z`, `x−(y−z)→(x−y)+(x*z)`, `x*(y−z)→(x*y)−z`,
//!   `(x−y)*z→(x*z)−y`, `(x+y)−z→(x−z)+(y−z)`, `(x+y)*z→x*z+y*z`;
//! - every node is pruned as it is built: an intersection of operands whose boxes
//!   are disjoint is empty, a difference whose right operand's box misses the
//!   left's drops the right operand;
//! - a pass that visits more than `limit` nodes aborts (OpenSCAD's "Normalized
//!   tree is growing past … elements", 100,000 by default).
//!
//! Trees are immutable and shared (`Rc`), so the rules' duplication of `x` costs
//! a pointer. The passes recurse; they run on a thread with a large stack, and
//! expressions deeper than [`MAX_DEPTH`] are refused.
#![deny(unsafe_code)]

use std::rc::Rc;

use super::expr::{Expr, Node};
use super::products::meet;

/// World-space box `(min, max)`.
pub type Aabb = ([f64; 3], [f64; 3]);

/// OpenSCAD's default normalization limit (nodes visited per pass).
pub const OPENSCAD_NODE_LIMIT: u64 = 100_000;

/// Deepest expression accepted (the passes recurse along the tree).
pub const MAX_DEPTH: usize = 20_000;

/// One product as OpenCSG renders it: the intersection of `intersected` minus
/// the union of `subtracted` (primitive indices, file order, 0-based; in the
/// order OpenSCAD lists them, repetitions kept).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScadProduct {
    /// The primitives intersected.
    pub intersected: Vec<u32>,
    /// The primitives subtracted.
    pub subtracted: Vec<u32>,
}

impl ScadProduct {
    /// The product's value for a point given its membership in each primitive.
    pub fn eval(&self, inside: impl Fn(u32) -> bool) -> bool {
        self.intersected.iter().all(|&p| inside(p)) && !self.subtracted.iter().any(|&p| inside(p))
    }
}

/// Why an expression cannot be normalized into products as OpenSCAD does.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum NormalizeError {
    #[error(
        "the normalized tree grows past {limit} nodes (OpenSCAD's limit): \
         OpenSCAD cannot preview this expression"
    )]
    /// The normalized tree outgrows OpenSCAD's node limit.
    TooLarge {
        /// The limit.
        limit: u64,
    },
    #[error("the expression is {depth} levels deep (at most {MAX_DEPTH} are normalized)")]
    /// The expression is nested deeper than [`MAX_DEPTH`].
    TooDeep {
        /// Its depth.
        depth: usize,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Op {
    Union,
    Inter,
    Diff,
}

#[derive(Debug)]
enum Kind {
    Leaf { prim: u32, negated: bool },
    Op { op: Op, l: Rc<N>, r: Rc<N> },
}

/// A node with its box; `None` is unbounded (a complemented leaf, or a union
/// with one).
#[derive(Debug)]
struct N {
    kind: Kind,
    bbox: Option<Aabb>,
}

/// `None` is the empty set (a pruned node).
type T = Option<Rc<N>>;

fn hull(a: &Aabb, b: &Aabb) -> Aabb {
    let mut out = *a;
    for k in 0..3 {
        out.0[k] = a.0[k].min(b.0[k]);
        out.1[k] = a.1[k].max(b.1[k]);
    }
    out
}

/// Builds `l op r` with OpenSCAD's pruning and its handling of empty operands.
fn make(op: Op, l: T, r: T) -> T {
    let (l, r) = match (op, l, r) {
        (Op::Union, None, x) | (Op::Union, x, None) => return x,
        (Op::Inter, None, _) | (Op::Inter, _, None) | (Op::Diff, None, _) => return None,
        (Op::Diff, Some(l), None) => return Some(l),
        (_, Some(l), Some(r)) => (l, r),
    };
    let bbox = match (op, &l.bbox, &r.bbox) {
        (Op::Union, Some(a), Some(b)) => Some(hull(a, b)),
        (Op::Union, _, _) => None,
        (Op::Inter, Some(a), Some(b)) => Some(meet(a, b)?),
        (Op::Inter, Some(a), None) | (Op::Inter, None, Some(a)) => Some(*a),
        (Op::Inter, None, None) => None,
        (Op::Diff, Some(a), Some(b)) => {
            if meet(a, b).is_none() {
                return Some(l);
            }
            Some(*a)
        }
        (Op::Diff, a, _) => *a,
    };
    Some(Rc::new(N {
        kind: Kind::Op { op, l, r },
        bbox,
    }))
}

/// One of the nine rules at `n`, if any applies: the rewritten node.
fn rewrite(n: &Rc<N>) -> Option<T> {
    let Kind::Op { op, l: left, r } = &n.kind else {
        return None;
    };
    let (op, x) = (*op, || Some(left.clone()));
    if op == Op::Union {
        return None;
    }
    if let Kind::Op {
        op: rop,
        l: y,
        r: z,
    } = &r.kind
    {
        let (y, z) = (Some(y.clone()), Some(z.clone()));
        return Some(match (op, rop) {
            (Op::Diff, Op::Union) => make(Op::Diff, make(Op::Diff, x(), y), z),
            (Op::Inter, Op::Union) => {
                make(Op::Union, make(Op::Inter, x(), y), make(Op::Inter, x(), z))
            }
            (Op::Diff, Op::Inter) => {
                make(Op::Union, make(Op::Diff, x(), y), make(Op::Diff, x(), z))
            }
            (Op::Inter, Op::Inter) => make(Op::Inter, make(Op::Inter, x(), y), z),
            (Op::Diff, Op::Diff) => {
                make(Op::Union, make(Op::Diff, x(), y), make(Op::Inter, x(), z))
            }
            (Op::Inter, Op::Diff) => make(Op::Diff, make(Op::Inter, x(), y), z),
            (Op::Union, _) => unreachable!("returned above"),
        });
    }
    let z = || Some(r.clone());
    if let Kind::Op {
        op: lop,
        l: lx,
        r: ly,
    } = &left.kind
    {
        let (lx, ly) = (|| Some(lx.clone()), || Some(ly.clone()));
        return match (op, lop) {
            (Op::Diff, Op::Union) => Some(make(
                Op::Union,
                make(Op::Diff, lx(), z()),
                make(Op::Diff, ly(), z()),
            )),
            (Op::Inter, Op::Union) => Some(make(
                Op::Union,
                make(Op::Inter, lx(), z()),
                make(Op::Inter, ly(), z()),
            )),
            (Op::Inter, Op::Diff) => Some(make(Op::Diff, make(Op::Inter, lx(), z()), ly())),
            _ => None,
        };
    }
    None
}

struct Normalizer {
    limit: u64,
    visited: u64,
}

impl Normalizer {
    /// One top-down pass: rules at `n` until none applies, then the children.
    /// Returns `n` itself (the same `Rc`) when nothing changed below it.
    fn pass(&mut self, n: &Rc<N>) -> Result<T, NormalizeError> {
        let mut cur: T = Some(n.clone());
        while let Some(new) = cur.as_ref().and_then(rewrite) {
            cur = new;
        }
        self.visited += 1;
        if self.visited > self.limit {
            return Err(NormalizeError::TooLarge { limit: self.limit });
        }
        let Some(c) = cur else { return Ok(None) };
        let Kind::Op { op, l, r } = &c.kind else {
            return Ok(Some(c));
        };
        let (l2, r2) = (self.pass(l)?, self.pass(r)?);
        let same = |a: &T, b: &Rc<N>| a.as_ref().is_some_and(|a| Rc::ptr_eq(a, b));
        if same(&l2, l) && same(&r2, r) {
            return Ok(Some(c.clone()));
        }
        Ok(make(*op, l2, r2))
    }
}

/// The tree with complements pushed to the leaves (`negate`: build `!node`).
fn build(expr: &Expr, node: u32, negate: bool, boxes: &[Aabb]) -> T {
    let b = |n, neg| build(expr, n, neg, boxes);
    match expr.nodes[node as usize] {
        Node::Leaf { prim } => Some(Rc::new(N {
            kind: Kind::Leaf {
                prim,
                negated: negate,
            },
            bbox: (!negate).then(|| boxes[prim as usize]),
        })),
        Node::Not(a) => b(a, !negate),
        Node::Union(x, y) if !negate => make(Op::Union, b(x, false), b(y, false)),
        Node::Union(x, y) => make(Op::Inter, b(x, true), b(y, true)),
        Node::Inter(x, y) if !negate => make(Op::Inter, b(x, false), b(y, false)),
        Node::Inter(x, y) => make(Op::Union, b(x, true), b(y, true)),
        Node::Diff(x, y) if !negate => make(Op::Diff, b(x, false), b(y, false)),
        // !(x − y) = !x + y
        Node::Diff(x, y) => make(Op::Union, b(x, true), b(y, false)),
    }
}

fn depth(expr: &Expr) -> usize {
    let mut d = vec![0usize; expr.nodes.len()];
    for n in expr.postorder() {
        d[n as usize] = 1 + expr.nodes[n as usize]
            .children()
            .map(|c| d[c as usize])
            .max()
            .unwrap_or(0);
    }
    d[expr.root as usize]
}

/// The products of a normalized tree (every non-union node is a left-deep chain
/// of intersections and differences whose right operands are leaves).
fn products(root: &T) -> Vec<ScadProduct> {
    let mut out = Vec::new();
    let mut stack: Vec<Rc<N>> = root.iter().cloned().collect();
    while let Some(n) = stack.pop() {
        if let Kind::Op {
            op: Op::Union,
            l,
            r,
        } = &n.kind
        {
            stack.push(r.clone());
            stack.push(l.clone());
            continue;
        }
        let mut p = ScadProduct {
            intersected: Vec::new(),
            subtracted: Vec::new(),
        };
        // Collected from the right end of the chain; reversed below.
        let mut push = |leaf: &N, subtract: bool| {
            let Kind::Leaf { prim, negated } = leaf.kind else {
                panic!("normalize: a product's right operand is not a leaf after the fixpoint")
            };
            if subtract != negated {
                p.subtracted.push(prim);
            } else {
                p.intersected.push(prim);
            }
        };
        let mut cur = n;
        loop {
            let next = match &cur.kind {
                Kind::Leaf { .. } => {
                    push(&cur, false);
                    break;
                }
                Kind::Op {
                    op: Op::Inter,
                    l,
                    r,
                } => {
                    push(r, false);
                    l.clone()
                }
                Kind::Op { op: Op::Diff, l, r } => {
                    push(r, true);
                    l.clone()
                }
                Kind::Op { op: Op::Union, .. } => {
                    panic!("normalize: a union below an intersection after the fixpoint")
                }
            };
            cur = next;
        }
        p.intersected.reverse();
        p.subtracted.reverse();
        // A product without an intersected primitive is unbounded: OpenCSG cannot
        // draw it (and a bounded solid never needs it).
        if !p.intersected.is_empty() {
            out.push(p);
        }
    }
    out
}

/// Normalizes `expr` as OpenSCAD does. `boxes[prim]` is each primitive's world
/// box; `limit` bounds the nodes visited per pass ([`OPENSCAD_NODE_LIMIT`]).
pub fn normalize(
    expr: &Expr,
    boxes: &[Aabb],
    limit: u64,
) -> Result<Vec<ScadProduct>, NormalizeError> {
    let d = depth(expr);
    if d > MAX_DEPTH {
        return Err(NormalizeError::TooDeep { depth: d });
    }
    let work = || {
        let mut tree = build(expr, expr.root, false, boxes);
        loop {
            let mut nz = Normalizer { limit, visited: 0 };
            let Some(t) = &tree else {
                return Ok(Vec::new());
            };
            let next = nz.pass(t)?;
            if next.as_ref().is_some_and(|n| Rc::ptr_eq(n, t)) {
                return Ok(products(&tree));
            }
            tree = next;
        }
    };
    // The passes recurse along chains as long as a product; give them room.
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .name("normalize".into())
            .stack_size(256 << 20)
            .spawn_scoped(s, work)
            .expect("spawning the normalization thread")
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csg::parse;
    use rand::{Rng, SeedableRng};

    fn names(k: u32) -> Vec<String> {
        (0..k).map(|i| format!("P{i}")).collect()
    }

    fn parse_k(s: &str, k: u32) -> Expr {
        let n = names(k);
        parse(s, &mut |name: &str| {
            n.iter().position(|x| x == name).map(|i| i as u32)
        })
        .expect("test expression parses")
    }

    const BIG: Aabb = ([-1.0; 3], [1.0; 3]);

    #[test]
    fn nine_rules_give_openscad_products() {
        let e = parse_k("P0 - (P1 + P2)", 3);
        let p = normalize(&e, &[BIG; 3], OPENSCAD_NODE_LIMIT).unwrap();
        assert_eq!(
            p,
            vec![ScadProduct {
                intersected: vec![0],
                subtracted: vec![1, 2]
            }]
        );
        let e = parse_k("(P0 + P1) * (P2 + P3)", 4);
        assert_eq!(
            normalize(&e, &[BIG; 4], OPENSCAD_NODE_LIMIT).unwrap().len(),
            4
        );
        // x − (y − z) → (x − y) + (x * z)
        let e = parse_k("P0 - (P1 - P2)", 3);
        let p = normalize(&e, &[BIG; 3], OPENSCAD_NODE_LIMIT).unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[1].intersected, vec![0, 2]);
        // A complemented leaf intersected is subtracted.
        let e = parse_k("P0 * !P1", 2);
        let p = normalize(&e, &[BIG; 2], OPENSCAD_NODE_LIMIT).unwrap();
        assert_eq!(p[0].subtracted, vec![1]);
    }

    #[test]
    fn pruning_drops_disjoint_products_and_subtrahends() {
        let far: Aabb = ([5.0; 3], [6.0; 3]);
        // P1 misses P0: the difference keeps P0 alone, the intersection is empty.
        let e = parse_k("(P0 - P1) + P0 * P1", 2);
        let p = normalize(&e, &[BIG, far], OPENSCAD_NODE_LIMIT).unwrap();
        assert_eq!(
            p,
            vec![ScadProduct {
                intersected: vec![0],
                subtracted: vec![]
            }]
        );
    }

    #[test]
    fn node_limit_refuses_an_exponential_expansion() {
        // (P0 + P1)(P2 + P3)…(P38 + P39): 2^20 products.
        let k = 40;
        let pairs: Vec<String> = (0..k / 2)
            .map(|i| format!("(P{} + P{})", 2 * i, 2 * i + 1))
            .collect();
        let e = parse_k(&pairs.join(" "), k);
        let err = normalize(&e, &vec![BIG; k as usize], OPENSCAD_NODE_LIMIT).unwrap_err();
        assert_eq!(err, NormalizeError::TooLarge { limit: 100_000 });
        assert!(err.to_string().contains("OpenSCAD cannot preview"));
        // Eight pairs (256 products) are within the limit.
        let e = parse_k(&pairs[..8].join(" "), k);
        let p = normalize(&e, &vec![BIG; k as usize], OPENSCAD_NODE_LIMIT).unwrap();
        assert_eq!(p.len(), 256);
    }

    fn random_expr(rng: &mut impl Rng, k: u32, size: u32) -> String {
        if size <= 1 {
            let p = format!("P{}", rng.gen_range(0..k));
            return if rng.gen_bool(0.15) {
                format!("!{p}")
            } else {
                p
            };
        }
        let left = rng.gen_range(1..size);
        let op = ["+", "*", "-"][rng.gen_range(0..3)];
        let s = format!(
            "({} {op} {})",
            random_expr(rng, k, left),
            random_expr(rng, k, size - left)
        );
        if rng.gen_bool(0.1) {
            format!("!{s}")
        } else {
            s
        }
    }

    /// Primitives are their own boxes, so box pruning is exact and the union of
    /// products must equal the tree at every point.
    #[test]
    fn union_of_products_equals_the_tree_at_random_points() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(9);
        let k = 6u32;
        let mut checked = 0;
        for _ in 0..300 {
            let boxes: Vec<Aabb> = (0..k)
                .map(|_| {
                    let c: [f64; 3] = std::array::from_fn(|_| rng.gen_range(-1.0..1.0));
                    let h: [f64; 3] = std::array::from_fn(|_| rng.gen_range(0.1..0.9));
                    (
                        std::array::from_fn(|i| c[i] - h[i]),
                        std::array::from_fn(|i| c[i] + h[i]),
                    )
                })
                .collect();
            let size = rng.gen_range(1..12);
            // Intersected with a primitive, so the solid is bounded (a product
            // without an intersected primitive is dropped, as OpenSCAD must).
            let bound = rng.gen_range(0..k);
            let e = parse_k(
                &format!("({}) * P{bound}", random_expr(&mut rng, k, size)),
                k,
            );
            let Ok(prods) = normalize(&e, &boxes, OPENSCAD_NODE_LIMIT) else {
                continue;
            };
            for _ in 0..200 {
                let pt: [f64; 3] = std::array::from_fn(|_| rng.gen_range(-2.0..2.0));
                let inside = |p: u32| {
                    let b = &boxes[p as usize];
                    (0..3).all(|i| b.0[i] < pt[i] && pt[i] < b.1[i])
                };
                let tree = e.eval(|_, p| inside(p));
                let sop = prods.iter().any(|p| p.eval(inside));
                assert_eq!(tree, sop, "expr {e:?} at {pt:?}");
                checked += 1;
            }
        }
        assert!(checked > 10_000, "only {checked} points checked");
    }
}
