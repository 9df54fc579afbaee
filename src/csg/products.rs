//! Sum of products (Stewart, Leach & John, §3.2): the positive form expanded into
//! a union of intersections of literals, as Goldfeather-style algorithms render it.
//!
//! Expansion is bottom-up over the arena (no recursion). Products are pruned while
//! they are built, because the full expansion can be exponential:
//! - a product holding both `P` and `!P` for the same primitive is empty;
//! - a product whose positive literals' bounding boxes have an empty common
//!   intersection is empty;
//! - a repeated literal is kept once;
//!
//! and, at the end, a complemented literal whose box does not meet the product's
//! positive-box intersection cannot clip anything and is dropped.
//! Growth is counted before anything is allocated past `limit`, so that expressions
//! whose expansion is astronomically large fail at once with
//! [`ProductError::TooLarge`].

pub use super::positive::Literal;
use super::positive::{PNode, PositiveExpr};

/// One product: the intersection of its literals (an empty product is the universe).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Product {
    /// The literals intersected, each a primitive or its complement.
    pub literals: Vec<Literal>,
}

/// Why the expansion was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ProductError {
    /// `at_least`: candidate products counted at the stage that overflowed (before
    /// the pruning of later stages).
    #[error(
        "the sum-of-products form grows to at least {at_least} products (limit {limit}); \
         use an algorithm that works on the tree, e.g. --algo cst-i"
    )]
    TooLarge {
        /// Candidate products counted when the limit was passed.
        at_least: u64,
        /// The product limit.
        limit: usize,
    },
    /// Few products but long ones: a deep difference chain of distinct
    /// primitives (`A − (B − (C − …))`) has n/2 products of up to n literals.
    #[error(
        "expanding the sum-of-products form builds at least {at_least} literals (limit {limit}): \
         its products are too long; use an algorithm that works on the tree, e.g. --algo cst-i, \
         or write the expression with fewer nested differences"
    )]
    TooManyLiterals {
        /// Literals built when the limit was passed.
        at_least: u64,
        /// The literal limit ([`MAX_LITERALS`]).
        limit: u64,
    },
}

/// The most literals the expansion may build over all its stages (bounds its
/// time and memory; a Goldfeather plan of that many literals is far past a
/// frame of minutes anyway).
pub const MAX_LITERALS: u64 = 50_000_000;

type Aabb = ([f64; 3], [f64; 3]);

/// The intersection of two boxes; `None` when a strict gap separates them.
pub(crate) fn meet(a: &Aabb, b: &Aabb) -> Option<Aabb> {
    let mut out = *a;
    for k in 0..3 {
        out.0[k] = a.0[k].max(b.0[k]);
        out.1[k] = a.1[k].min(b.1[k]);
        // Touching boxes are kept: only a strict gap proves the product empty.
        if out.0[k] > out.1[k] {
            return None;
        }
    }
    Some(out)
}

/// A product under construction: literals sorted by (prim, negated), and the
/// intersection of the positive literals' boxes (`None` when there are none).
#[derive(Clone)]
struct Partial {
    literals: Vec<Literal>,
    bbox: Option<Aabb>,
}

/// Intersects two partial products, or `None` when the result is provably empty.
fn multiply(a: &Partial, b: &Partial) -> Option<Partial> {
    let bbox = match (&a.bbox, &b.bbox) {
        (Some(x), Some(y)) => Some(meet(x, y)?),
        (Some(x), None) | (None, Some(x)) => Some(*x),
        (None, None) => None,
    };
    let mut literals = Vec::with_capacity(a.literals.len() + b.literals.len());
    let (mut i, mut j) = (0, 0);
    let key = |l: &Literal| (l.prim, l.negated);
    while i < a.literals.len() || j < b.literals.len() {
        let next = if j == b.literals.len()
            || (i < a.literals.len() && key(&a.literals[i]) <= key(&b.literals[j]))
        {
            i += 1;
            a.literals[i - 1]
        } else {
            j += 1;
            b.literals[j - 1]
        };
        match literals.last() {
            Some(last) if key(last) == key(&next) => {} // repeated literal
            Some(last) if last.prim == next.prim => return None, // P and !P
            _ => literals.push(next),
        }
    }
    Some(Partial { literals, bbox })
}

/// Expands `pos` into a sum of products. `bounds(prim)` is the primitive's
/// world-space box `(min, max)`; `limit` caps the number of products held at any
/// stage of the expansion.
pub fn sum_of_products(
    pos: &PositiveExpr,
    bounds: &dyn Fn(u32) -> Aabb,
    limit: usize,
) -> Result<Vec<Product>, ProductError> {
    let too_large = |at_least: u64| ProductError::TooLarge { at_least, limit };
    // Only nodes reachable from the root matter; each is used by exactly one parent,
    // so a child's list can be moved out when its parent is built.
    let mut lists: Vec<Option<Vec<Partial>>> = vec![None; pos.nodes.len()];
    // Literals built by every multiplication so far (long products cost their
    // length at every stage).
    let mut built = 0u64;
    for (i, n) in pos.nodes.iter().enumerate() {
        let list = match *n {
            PNode::Universe => vec![Partial {
                literals: Vec::new(),
                bbox: None,
            }],
            PNode::Leaf { prim, negated, .. } => {
                let bbox = if negated { None } else { Some(bounds(prim)) };
                vec![Partial {
                    literals: vec![n.literal().unwrap()],
                    bbox,
                }]
            }
            PNode::Union(a, b) => {
                let (Some(mut x), Some(y)) = (lists[a as usize].take(), lists[b as usize].take())
                else {
                    continue; // unreachable from the root
                };
                let total = x.len() as u64 + y.len() as u64;
                if total > limit as u64 {
                    return Err(too_large(total));
                }

                x.extend(y);
                x
            }
            PNode::Inter(a, b) => {
                let (Some(x), Some(y)) = (lists[a as usize].take(), lists[b as usize].take())
                else {
                    continue;
                };
                let mut out = Vec::new();
                // Every pair is tried, so cap the work too: pruning may keep the
                // result small while the pairs are astronomically many.
                let pairs = x.len() as u64 * y.len() as u64;
                let work_cap = (limit as u64).saturating_mul(64).max(1 << 20);
                if pairs > work_cap {
                    return Err(too_large(pairs));
                }
                for p in &x {
                    for q in &y {
                        if let Some(r) = multiply(p, q) {
                            if out.len() == limit {
                                return Err(too_large(limit as u64 + 1));
                            }
                            built += r.literals.len() as u64;
                            if built > MAX_LITERALS {
                                return Err(ProductError::TooManyLiterals {
                                    at_least: built,
                                    limit: MAX_LITERALS,
                                });
                            }
                            out.push(r);
                        }
                    }
                }
                out
            }
        };
        lists[i] = Some(list);
    }
    let partials = lists[pos.root as usize].take().unwrap_or_default();
    Ok(partials
        .into_iter()
        .map(|p| {
            let literals = match p.bbox {
                None => p.literals,
                Some(bbox) => p
                    .literals
                    .into_iter()
                    .filter(|l| !l.negated || meet(&bbox, &bounds(l.prim)).is_some())
                    .collect(),
            };
            Product { literals }
        })
        .collect())
}

impl Product {
    /// The product's value for a point given its membership in each primitive.
    pub fn eval(&self, mut inside: impl FnMut(&Literal) -> bool) -> bool {
        self.literals.iter().all(|l| l.holds(inside(l)))
    }
}
