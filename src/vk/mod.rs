//! The Vulkan executor: runs [`crate::plan::Plan`]s. Knows images, pipelines,
//! stencil and depth state, queries; knows nothing of CSG.
//!
//! Modules: `instance` ([`Context`]: instance, debug messenger, device, allocator);
//! `memory` and `image` (buffers and images that own their memory); `pipeline`
//! (one per fragment program, all depth/stencil state dynamic); `conv` and
//! `scissor` (pure mappings, tested without a GPU); `sync` (the pure table from a
//! step's resource usages to stages, accesses and layouts); `submit` (one-shot
//! command buffers, barriers, query pools, shared with `present`); `cmd_arena`
//! (the command pools' host allocator: lavapipe's recorded commands); `exec` (the plan
//! executor and its statistics); `readback` (GPU bytes to output images);
//! `profile` ([`DeviceProfile`]: what the device is and the workarounds it
//! needs, set once per context); `depth_probe` (the draw that measures
//! whether depth is interpolated from unsnapped vertices); `rounding` (emulating a coarser rasterizer's
//! vertex snapping); `present`
//! (feature `viewer`: a window's surface and swapchain).
#![warn(unsafe_op_in_unsafe_fn)]

pub mod cmd_arena;
pub(crate) mod composite;
pub(crate) mod conv;
pub(crate) mod cpu_clock;
pub mod depth_probe;
pub mod embed;
pub(crate) mod error;
pub(crate) mod exec;
pub(crate) mod host_frame;
pub(crate) mod image;
pub(crate) mod instance;
pub mod layer_lock;
pub(crate) mod limits;
pub(crate) mod memory;
pub(crate) mod pipeline;
#[cfg(feature = "present")]
pub mod present;
pub mod profile;
pub(crate) mod readback;
pub(crate) mod resolve;
pub(crate) mod rounding;
pub mod sample_depth_probe;
pub(crate) mod samples;
/// Screen rectangles of scissors, from the plan's passes.
pub use crate::plan::scissor;
pub mod shadow;
mod stages;
pub(crate) mod submit;
pub(crate) mod sync;

pub use composite::{COLOR_FORMATS, DEPTH_FORMATS};
pub use embed::{Embedder, HostTargets};
pub use error::VkError;
pub use exec::{
    ClearMode, Counts, DepthFormat, ExecDesc, ExecStats, Executor, Frame, FrameTimestamps,
    PassStats, PlanCounts, Recorded, SeqFrame, SeqItem,
};
pub use host_frame::OffscreenHost;
pub use instance::{Context, ContextDesc, DeviceChoice};
pub use profile::{DeviceProfile, ProfileKind};
pub use rounding::RoundingEmulation;
pub use samples::SAMPLE_COUNTS;
