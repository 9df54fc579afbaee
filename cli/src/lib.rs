//! The `peeltrim` command line's library: one frame of one algorithm (GPU or
//! the exact reference), the output files, the bench harness with its plots,
//! and the interactive viewer. The binary (`src/main.rs`) parses the flags and
//! calls into these; the GPU tests use them to run what the binary runs.
#![warn(unsafe_op_in_unsafe_fn)]

pub mod auto;
pub mod bench;
pub mod output;
pub mod render;
pub mod scad;
#[cfg(feature = "viewer")]
pub mod viewer;
#[cfg(feature = "viewer")]
pub mod watch;
