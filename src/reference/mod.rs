//! The exact CPU reference (the oracle): one `f64` ray per pixel centre, all
//! crossings with every primitive, intervals classified against the expression and
//! regularized; plus the image comparison metrics of `compare`.
#![deny(unsafe_code)]

pub mod compare;
pub mod fixtures;
pub mod highlight;
pub mod interference;
pub mod layers;
pub mod precision;
pub mod raycast;
pub mod shadow;

/// The BVH lives in [`crate::geom`], shared with the plan builders.
pub use crate::geom::bvh;
pub use bvh::{Crossing, Line, MeshBvh, SceneBvh, WorldCrossing};
pub use compare::{compare, CompareError, CompareReport};
pub use layers::{render_layers, LayerHit, LayerLimit, LayerStack};
pub use raycast::{render, render_with_normals};
pub use raycast::{Hit, Prepared, GROUP_TOL_REL};
