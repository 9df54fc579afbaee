//! The Vulkan executor: runs [`crate::plan::Plan`]s. Knows images, pipelines,
//! stencil and depth state, queries; knows nothing of CSG.
//!
//! - [`instance`]: [`Context`] (instance, debug messenger, device, allocator)
//! - [`memory`], [`image`]: buffers and images that own their memory
//! - [`pipeline`]: pipelines per fragment program, all depth/stencil state dynamic
//! - [`conv`], [`scissor`]: pure mappings (tested without a GPU)
//! - [`exec`]: the plan executor and its statistics; readback lives there too
#![warn(unsafe_op_in_unsafe_fn)]

pub mod conv;
pub mod error;
pub mod exec;
pub mod image;
pub mod instance;
pub mod memory;
pub mod pipeline;
pub mod scissor;

pub use error::VkError;
pub use exec::{DepthFormat, ExecDesc, ExecStats, Executor, Frame, PassStats};
pub use instance::{Context, ContextDesc, DeviceChoice};
