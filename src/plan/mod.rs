//! Algorithms as data: every CSG technique of the papers is a list of [`Step`]s —
//! rasterize some mesh with a particular depth test, culling and stencil rule, or
//! sweep the screen to rewrite stencil values — built by one module per algorithm
//! and executed by [`crate::vk`]. Nothing here touches `ash`.
//!
//! A plan is also a cost model: [`Plan`] steps can be printed and counted
//! (rasterized triangles, full-screen passes, scissored pixels).
#![deny(unsafe_code)]

pub mod step;
pub use step::*;
