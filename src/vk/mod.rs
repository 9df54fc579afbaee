//! The Vulkan executor: runs [`crate::plan::Plan`]s. Knows images, pipelines,
//! stencil and depth state, queries; knows nothing of CSG.
#![warn(unsafe_op_in_unsafe_fn)]
