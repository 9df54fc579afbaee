//! Errors of the Vulkan layer. Every Vulkan result is checked and surfaces here;
//! nothing in `vk/` unwraps a Vulkan call.

use ash::vk;

#[derive(Debug, thiserror::Error)]
pub enum VkError {
    #[error(
        "no Vulkan driver found: install mesa-vulkan-drivers libvulkan1 (tools/setup.sh) ({0})"
    )]
    Loader(String),
    #[error(
        "Vulkan validation was requested (debug build or PEELTRIM_VALIDATION=1) but the layer \
         VK_LAYER_KHRONOS_validation is not installed: install vulkan-validationlayers, or \
         set PEELTRIM_VALIDATION=0"
    )]
    NoValidationLayer,
    #[error("no suitable Vulkan device: {0}")]
    NoDevice(String),
    #[error("Vulkan call {call} failed: {result}")]
    Call {
        call: &'static str,
        result: vk::Result,
    },
    #[error("GPU memory allocation failed: {0}")]
    Alloc(#[from] gpu_allocator::AllocationError),
    #[error("the device does not support {0}")]
    Unsupported(String),
    #[error("invalid plan: {0}")]
    Plan(String),
    #[error("invalid plan: {0}")]
    InvalidPlan(#[from] crate::plan::validate::InvalidPlan),
}

/// Attaches the name of the Vulkan entry point to a raw result.
pub(crate) trait Check<T> {
    fn check(self, call: &'static str) -> Result<T, VkError>;
}

impl<T> Check<T> for Result<T, vk::Result> {
    fn check(self, call: &'static str) -> Result<T, VkError> {
        self.map_err(|result| VkError::Call { call, result })
    }
}
