//! What the shadow pass (`vk::shadow`) needs of an executor beyond its output
//! images: the normal buffer's image and the colour target's format.

use ash::vk;

use super::{targets, Executor};
use crate::plan::usage::Resource;

/// The format of every executor's colour target (the shadow pass blends into it).
pub(crate) fn color_format() -> vk::Format {
    targets::format(Resource::Color)
}

impl Executor {
    /// The last frame's normal buffer (image and view, resting in `sync::REST`);
    /// `None` without a frame or when normals are off.
    pub(crate) fn normal_output(&self) -> Option<(vk::Image, vk::ImageView)> {
        self.last_output?;
        let img = self.targets.as_ref()?.normal.as_ref()?;
        Some((img.raw, img.view))
    }
}
