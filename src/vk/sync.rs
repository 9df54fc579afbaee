//! Pure mapping of the plan's resource usages (`plan::usage`) to Vulkan pipeline
//! stages, access masks and image layouts, and the rule for when two usages of
//! one image need a barrier between them (as wgpu-hal's `conv.rs` does). No GPU,
//! no unsafe: the executor's barriers are exactly what this table says.

use ash::vk;

use crate::plan::usage::Usage;

/// Where, how and in which layout an image is used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Access {
    pub stage: vk::PipelineStageFlags,
    pub access: vk::AccessFlags,
    pub layout: vk::ImageLayout,
}

/// The usage an image rests in between frames: ready to be copied back, so a
/// read-back needs no layout change. Recordings start and end with every image in it.
pub const REST: Usage = Usage::CopySrc;

/// Stage, access and layout of `usage` (colour and depth-stencil images share
/// the layouts of sampling and copies).
pub fn access(usage: Usage) -> Access {
    let frag_tests =
        vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS;
    match usage {
        Usage::ColorTarget => Access {
            stage: vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
            // Loaded (read) and stored (written).
            access: vk::AccessFlags::COLOR_ATTACHMENT_READ
                | vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
            layout: vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
        },
        Usage::DepthStencilTarget => Access {
            stage: frag_tests,
            access: vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
                | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
            layout: vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
        },
        Usage::Sampled => Access {
            stage: vk::PipelineStageFlags::FRAGMENT_SHADER,
            access: vk::AccessFlags::SHADER_READ,
            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        },
        Usage::CopySrc => Access {
            stage: vk::PipelineStageFlags::TRANSFER,
            access: vk::AccessFlags::TRANSFER_READ,
            layout: vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
        },
        Usage::CopyDst | Usage::Clear => Access {
            stage: vk::PipelineStageFlags::TRANSFER,
            access: vk::AccessFlags::TRANSFER_WRITE,
            layout: vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        },
    }
}

/// Whether `next` needs a barrier after `prev` on the same image. Two reads in
/// one layout need none; neither does a target written again inside the same
/// rendering block (rasterization order orders the draws).
pub fn needs_barrier(prev: Usage, next: Usage, same_block: bool) -> bool {
    if prev == next {
        let target = matches!(next, Usage::ColorTarget | Usage::DepthStencilTarget);
        return next.writes() && !(target && same_block);
    }
    true
}

/// The barrier that moves a whole image (every mip and layer of `aspect`) from
/// `src` to `dst` on one queue family; stages go to the enclosing
/// `vkCmdPipelineBarrier`. Written once for the recorder, the executor's first
/// layouts and the embedding's composite.
pub fn image_barrier(
    src: Access,
    dst: Access,
    image: vk::Image,
    aspect: vk::ImageAspectFlags,
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .src_access_mask(src.access)
        .dst_access_mask(dst.access)
        .old_layout(src.layout)
        .new_layout(dst.layout)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(crate::vk::image::range(aspect))
}

/// One image's transition from `prev` to `next`: `(src, dst)` where `src`'s
/// layout is `UNDEFINED` when `next` discards the contents. A read-only `prev`
/// needs an execution dependency only (write-after-read), so its access is empty.
pub fn transition(prev: Usage, next: Usage, discard: bool) -> (Access, Access) {
    let mut src = access(prev);
    if !prev.writes() {
        src.access = vk::AccessFlags::empty();
    }
    if discard {
        src.layout = vk::ImageLayout::UNDEFINED;
    }
    (src, access(next))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attachments_use_optimal_layouts() {
        assert_eq!(
            access(Usage::DepthStencilTarget).layout,
            vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL
        );
        assert_eq!(
            access(Usage::ColorTarget).layout,
            vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL
        );
        assert_eq!(
            access(Usage::Sampled).layout,
            vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL
        );
        assert_eq!(access(REST).layout, vk::ImageLayout::TRANSFER_SRC_OPTIMAL);
        assert_eq!(access(Usage::Clear), access(Usage::CopyDst));
    }

    #[test]
    fn reads_after_reads_and_draws_in_one_block_need_no_barrier() {
        assert!(!needs_barrier(Usage::Sampled, Usage::Sampled, false));
        assert!(!needs_barrier(Usage::CopySrc, Usage::CopySrc, false));
        assert!(!needs_barrier(
            Usage::DepthStencilTarget,
            Usage::DepthStencilTarget,
            true
        ));
        assert!(needs_barrier(
            Usage::DepthStencilTarget,
            Usage::DepthStencilTarget,
            false
        ));
        assert!(needs_barrier(Usage::ColorTarget, Usage::Sampled, false));
        assert!(needs_barrier(Usage::Sampled, Usage::ColorTarget, true));
        assert!(needs_barrier(Usage::Clear, Usage::Clear, false));
    }

    #[test]
    fn write_after_read_is_an_execution_dependency() {
        let (src, dst) = transition(Usage::Sampled, Usage::ColorTarget, false);
        assert_eq!(src.access, vk::AccessFlags::empty());
        assert_eq!(src.stage, vk::PipelineStageFlags::FRAGMENT_SHADER);
        assert_eq!(src.layout, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL);
        assert_eq!(dst.layout, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
        let (src, _) = transition(Usage::ColorTarget, Usage::Clear, true);
        assert_eq!(src.layout, vk::ImageLayout::UNDEFINED);
        assert_eq!(
            src.access,
            vk::AccessFlags::COLOR_ATTACHMENT_WRITE | vk::AccessFlags::COLOR_ATTACHMENT_READ
        );
    }
}
