//! The exact CPU reference (the oracle): one `f64` ray per pixel centre, all
//! crossings with every primitive, intervals classified against the expression and
//! regularized; plus the image comparison metrics of `compare`.
#![deny(unsafe_code)]

pub mod bvh;
pub mod compare;
pub mod fixtures;
pub mod raycast;

pub use compare::{compare, CompareError, CompareReport};
pub use raycast::{render, render_with_normals};
