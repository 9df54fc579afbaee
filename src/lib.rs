//! peeltrim: rendering Boolean combinations of triangle-mesh solids (CSG) on Vulkan
//! without computing their boundary, by peeling depth layers and classifying each
//! pixel's candidate point against the expression with a few stencil bits.
//!
//! This documentation is the **embedding API**: what a host engine needs to draw
//! CSG into its own frames (below). The crate root re-exports all of it; the
//! `embed` module holds the mesh-level types. The command line (the
//! `peeltrim-cli` crate: rendering, output files, benches, viewer), the exact CPU
//! ray caster (the `peeltrim-reference` crate) and the tests use the lower layers
//! too — `csg` (the Boolean algebra), `scene` (scene files, tessellation,
//! cameras), `geom`, `plan` (every algorithm as a list of steps), `vk` (the
//! executor) — which are public for them but not a stable API
//! (docs/architecture.md).
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
//!
//! ## Host formats
//!
//! The colour target may be any of [`COLOR_FORMATS`] (8-bit RGBA/BGRA in UNORM
//! or SRGB, 10-bit, 16-bit and float formats), the depth target any of
//! [`DEPTH_FORMATS`] (D16, D24, D32 float, with or without stencil; stencil is
//! never written), with standard or reversed Z ([`EmbedDesc::reversed_z`]). Any
//! other format, or one the device cannot render to, is
//! [`VkError::HostFormat`] from [`Embedder::record`], before anything is
//! recorded.
//!
//! ## Frames in flight and plan changes
//!
//! The host may keep up to [`EmbedDesc::frames_in_flight`] recorded frames
//! submitted and not waited for. [`CsgScene::set_camera`] never uploads; it
//! returns `true` when the plan changed (the eye entered or left a solid), and
//! then the host lets its pending frames of this scene complete before the next
//! record, as after [`CsgScene::set_algo`] and [`CsgScene::set_transform`].
//!
//! ## Loop counts without a CPU wait
//!
//! Depth peeling loops until an occlusion query counts nothing. Embedded frames
//! unroll each loop to a count: first a CPU estimate ([`LoopCounts`]), then the
//! GPU's own counts of each frame, read back through a ring of host-visible
//! slots once the host has waited for that frame anyway. Too few heads are
//! doubled, too many shrunk; too many never change the image.
#![warn(unsafe_op_in_unsafe_fn)]
#![warn(missing_docs)]

pub mod budget;
pub mod csg;
pub mod embed;
pub mod geom;
pub mod images;
pub mod plan;
pub mod scene;
pub mod vk;

pub use csg::{Expr, Node};
pub use embed::{CsgExpr, CsgScene, EmbedDesc, EmbedError, LoopCounts, MeshInput};
pub use images::Images;
pub use plan::Algo;
pub use scene::{Camera, Projection};
pub use vk::{
    Context, Counts, DepthFormat, Embedder, ExecStats, HostTargets, PassStats, VkError,
    COLOR_FORMATS, DEPTH_FORMATS,
};

#[cfg(test)]
mod fuzz_scad_tests;
#[cfg(test)]
mod fuzz_tests;
