//! The exact CPU reference (the oracle): one `f64` ray per pixel centre, all
//! crossings with every primitive, intervals classified against the expression and
//! regularized; plus the image comparison metrics of `compare`.
#![deny(unsafe_code)]

pub mod compare;
pub mod edge_compare;
pub mod highlight;
pub mod interference;
pub mod layers;
pub mod precision;
pub mod products_reading;
pub mod raycast;
pub mod shadow;

pub use bvh::{Crossing, Line, MeshBvh, SceneBvh, WorldCrossing};
pub use compare::{compare, CompareError, CompareReport};
pub use layers::{render_layers, render_layers_read, LayerHit, LayerLimit, LayerStack};
/// The BVH lives in [`peeltrim::geom`], shared with the plan builders.
pub use peeltrim::geom::bvh;
pub use products_reading::LayerReading;
pub use raycast::{render, render_samples, render_with_normals, sample_positions};
pub use raycast::{Hit, Prepared, GROUP_TOL_REL};
