//! Tests that need a Vulkan device (lavapipe in CI), run with validation layers.
mod cst;
