//! peeltrim: rendering Boolean combinations of triangle-mesh solids (CSG) on Vulkan
//! without computing their boundary, by peeling depth layers and classifying each
//! pixel's candidate point against the expression with a few stencil bits.
//!
//! Layers, from the bottom up (see README "Architecture"):
//! - [`csg`]: Boolean algebra only (parser, positive form, Blist, active zones,
//!   products, groups). No pixels, no GPU.
//! - [`scene`]: the scene file of CONTRACT.md, tessellation, OBJ, camera.
//! - [`geom`]: bounds, the BVH and point-in-mesh parity, shared by `plan` and
//!   `reference`.
//! - [`plan`]: every algorithm as a list of [`plan::Step`]s (what to rasterize with
//!   which depth and stencil state). No `ash`.
//! - [`vk`]: executes plans on a Vulkan device. Knows stencil ops and images, not CSG.
//! - [`reference`]: the exact CPU ray caster (the oracle) and image comparison.
//! - [`output`]: the contract's output files.
//! - `viewer` (feature `viewer`, on by default): the `peeltrim view` window.
#![warn(unsafe_op_in_unsafe_fn)]

pub mod bench;
pub mod budget;
pub mod csg;
pub mod geom;
pub mod output;
pub mod plan;
pub mod reference;
pub mod render;
pub mod scene;
#[cfg(feature = "viewer")]
pub mod viewer;
pub mod vk;

#[cfg(test)]
mod fuzz_tests;
