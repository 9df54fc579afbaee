//! Boolean algebra of CSG expressions, with no notion of pixels.
//!
//! Follows Hable & Rossignac, *CST* §3 (Blist, labels, pivoting) and §5
//! (active zones), Hilbrich's Blister notes §5.3, and Stewart, Leach & John §3.2
//! (sum of products). Trees are stored in arenas and every pass is iterative, so
//! 10⁵-deep nesting and 10⁶ leaves cannot overflow the stack.
#![deny(unsafe_code)]

pub(crate) mod active_zone;
pub(crate) mod blist;
pub mod expr;
pub(crate) mod groups;
pub mod normalize;
pub(crate) mod parse;
pub(crate) mod positive;
pub mod products;

pub use active_zone::ActiveZones;
pub use blist::{label_bound, Blist, BlistEntry, Target};
pub use expr::{Expr, LeafId, Node, NodeId};
pub use groups::{Group, GroupKind, GroupedBlist, GroupedEntry, Item};
pub use parse::{parse, ParseError, ParseErrorKind};
pub use positive::{Literal, PNode, PNodeId, PositiveExpr, Restricted};
pub use products::{sum_of_products, Product, ProductError};

#[cfg(test)]
mod tests;
