//! Errors of the Vulkan layer. Every Vulkan result is checked and surfaces here;
//! nothing in `vk/` unwraps a Vulkan call.

use ash::vk;

#[derive(Debug, thiserror::Error)]
/// Errors of the Vulkan layer (and of embedding's host targets).
pub enum VkError {
    /// No Vulkan loader or driver.
    #[error(
        "no Vulkan driver found: install mesa-vulkan-drivers libvulkan1 (tools/setup.sh) ({0})"
    )]
    Loader(String),
    /// Validation was asked for but its layer is missing.
    #[error(
        "Vulkan validation was requested (debug build or PEELTRIM_VALIDATION=1) but the layer \
         VK_LAYER_KHRONOS_validation is not installed: install vulkan-validationlayers, or \
         set PEELTRIM_VALIDATION=0"
    )]
    NoValidationLayer,
    /// No device with what peeltrim needs.
    #[error("no suitable Vulkan device: {0}")]
    NoDevice(String),
    /// A Vulkan call failed.
    #[error("Vulkan call {call} failed: {result}{}", advice(*result))]
    Call {
        /// The entry point.
        call: &'static str,
        /// Its result.
        result: vk::Result,
    },
    /// Device memory could not be allocated.
    #[error(
        "GPU memory allocation failed: {0}; the device is out of memory: use a smaller --size \
         (or fewer or coarser primitives)"
    )]
    Alloc(#[from] gpu_allocator::AllocationError),
    /// A frame the device cannot hold (see `limits.rs`).
    #[error("{0}")]
    FrameTooLarge(String),
    /// The device lacks a feature or format.
    /// A setting of the environment with a value it does not accept.
    #[error("{0}")]
    Config(String),

    /// The device lacks a format or feature the work needs.
    #[error("the device does not support {0}")]
    Unsupported(String),
    /// A plan (or a call sequence) the executor cannot run.
    #[error("invalid plan: {0}")]
    Plan(String),
    /// A host attachment format the embedding composite cannot write (see
    /// `vk::COLOR_FORMATS`, `vk::DEPTH_FORMATS`).
    #[error("host {attachment} attachment format {format:?}: {problem}")]
    HostFormat {
        /// `"colour"` or `"depth"`.
        attachment: &'static str,
        /// The format given.
        format: vk::Format,
        /// Why, and what to use instead.
        problem: String,
    },
    /// A plan that fails validation.
    #[error("invalid plan: {0}")]
    InvalidPlan(#[from] crate::plan::validate::InvalidPlan),
}

/// What the user can do about a failed call, for the results that have an answer.
fn advice(r: vk::Result) -> &'static str {
    match r {
        vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
            " (out of memory: use a smaller --size, or fewer or coarser primitives)"
        }
        vk::Result::ERROR_DEVICE_LOST => {
            " (the device was lost: the driver reset it or it crashed; run again, with a \
             smaller --size or a simpler scene if it repeats, and check the driver's log)"
        }
        _ => "",
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_of_memory_and_device_loss_say_what_to_do() {
        for (r, want) in [
            (vk::Result::ERROR_OUT_OF_DEVICE_MEMORY, "smaller --size"),
            (vk::Result::ERROR_OUT_OF_HOST_MEMORY, "smaller --size"),
            (vk::Result::ERROR_DEVICE_LOST, "the device was lost"),
        ] {
            let e = Err::<(), _>(r)
                .check("vkQueueSubmit")
                .unwrap_err()
                .to_string();
            assert!(e.contains("vkQueueSubmit") && e.contains(want), "{e}");
        }
        let e = Err::<(), _>(vk::Result::ERROR_INITIALIZATION_FAILED)
            .check("vkCreateDevice")
            .unwrap_err()
            .to_string();
        assert!(!e.contains("--size"), "{e}");
    }
}
