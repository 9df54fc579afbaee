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
//! - [`embed`]: the mesh-level embedding API (below).
//!
//! # Embedding in a host Vulkan engine
//!
//! The crate root re-exports what a host needs (the rest is the command line's
//! and the tests'): wrap the host's device with [`Context::from_raw`], give the
//! solids as plain meshes ([`MeshInput`]) and an expression ([`CsgExpr`]) to
//! [`CsgScene::new`], and each frame record the CSG into the host's command
//! buffer with [`Embedder::record`] through [`CsgScene::recorder`]. The record
//! draws the CSG's colour and depth into the host's attachments with the host's
//! depth test, so it lands depth-correct among the host's geometry, which the
//! host draws with [`CsgScene::view_proj`]. The library submits nothing in that
//! path; [`Embedder::record`]'s `# Safety` section is the synchronization
//! contract. `examples/embed.rs` is a complete windowless host.
//!
//! ```no_run
//! # fn host(ctx: &peeltrim::Context, cmd: ash::vk::CommandBuffer, color_view: ash::vk::ImageView,
//! #         depth_view: ash::vk::ImageView, cube: (&[[f32; 3]], &[[u32; 3]]),
//! #         ball: (&[[f32; 3]], &[[u32; 3]])) -> Result<(), Box<dyn std::error::Error>> {
//! use peeltrim::{Camera, CsgExpr, CsgScene, EmbedDesc, HostTargets, MeshInput, Projection};
//! use ash::vk::Format;
//! use glam::{DVec3, Mat4};
//! let meshes = [
//!     MeshInput { positions: cube.0, indices: cube.1, transform: Mat4::IDENTITY, color: [70, 130, 220] },
//!     MeshInput { positions: ball.0, indices: ball.1,
//!                 transform: Mat4::from_translation([0.6, 0.7, 0.6].into()), color: [220, 90, 60] },
//! ];
//! let camera = Camera { eye: DVec3::new(3.0, 2.0, 4.0), target: DVec3::ZERO, up: DVec3::Y,
//!                       projection: Projection::Perspective { fov_y_deg: 40.0 }, near: 1.0, far: 20.0 };
//! let desc = EmbedDesc { extent: [800, 600], reversed_z: true, ..EmbedDesc::default() };
//! let mut csg = CsgScene::new(ctx, &meshes, CsgExpr::Text("m0 - m1"), &camera, &desc)?;
//! // Each frame: move the camera (cheap), draw the host's geometry with
//! // `csg.view_proj()`, then record the CSG into the same attachments.
//! csg.set_camera(&camera)?;
//! let targets = HostTargets { color_view, color_format: Format::R8G8B8A8_UNORM,
//!                             depth_view, depth_format: Format::D32_SFLOAT, extent: [800, 600] };
//! // SAFETY: `cmd` records outside rendering; the targets are in attachment layouts.
//! unsafe { csg.recorder().record(cmd, &targets)? };
//! # Ok(()) }
//! ```
#![warn(unsafe_op_in_unsafe_fn)]

pub mod bench;
pub mod budget;
pub mod csg;
pub mod embed;
pub mod geom;
pub mod output;
pub mod plan;
pub mod reference;
pub mod render;
pub mod scene;
#[cfg(feature = "viewer")]
pub mod viewer;
pub mod vk;

pub use embed::{CsgExpr, CsgScene, EmbedDesc, EmbedError, MeshInput};
pub use plan::Algo;
pub use scene::{Camera, Projection};
pub use vk::{Context, Embedder, HostTargets};

#[cfg(test)]
mod fuzz_tests;
