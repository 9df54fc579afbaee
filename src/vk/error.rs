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
    #[error("Vulkan call {call} failed: {result}{}", advice(*result))]
    Call {
        call: &'static str,
        result: vk::Result,
    },
    #[error(
        "GPU memory allocation failed: {0}; the device is out of memory: use a smaller --size \
         (or fewer or coarser primitives)"
    )]
    Alloc(#[from] gpu_allocator::AllocationError),
    /// A frame the device cannot hold (see `limits.rs`).
    #[error("{0}")]
    FrameTooLarge(String),
    #[error("the device does not support {0}")]
    Unsupported(String),
    #[error("invalid plan: {0}")]
    Plan(String),
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
