//! The per-mesh screen rectangles a recording's scissors come from, and when
//! a kept recording's scissors still serve a moved camera (README "Executor").

use super::gpu_scene::GpuScene;
use super::ExecDesc;
use crate::vk::scissor::{bounds_rect, Rect};

/// The per-mesh screen rectangles a recording's scissors come from: exact for a
/// still camera, grown by [`Scissors::MARGIN`] of the image after a camera move,
/// so that the next moves replay. Scissors only bound work (every plan is
/// correct with any scissor that contains its meshes' projections), so a
/// recording stays valid while each mesh's exact rectangle lies inside its
/// recorded one and no mesh recorded off screen has come on screen.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Scissors {
    pub rects: Vec<Rect>,
    pub grown: bool,
}

impl Scissors {
    /// Margin of grown rectangles, as a fraction of the image's width and height.
    pub const MARGIN: u32 = 8;

    /// Each mesh's exact rectangle under `cam`.
    pub(super) fn exact(scene: &GpuScene, desc: &ExecDesc) -> Scissors {
        let rects = scene
            .bounds
            .iter()
            .map(|b| {
                bounds_rect(
                    scene.cam.view,
                    scene.cam.proj,
                    scene.camera.near,
                    std::slice::from_ref(b),
                    desc.width,
                    desc.height,
                )
            })
            .collect();
        Scissors {
            rects,
            grown: false,
        }
    }

    /// The pixels grown rectangles gain on each side, across and down.
    pub(super) fn margins(desc: &ExecDesc) -> (u32, u32) {
        (
            (desc.width / Self::MARGIN).max(1),
            (desc.height / Self::MARGIN).max(1),
        )
    }

    /// `self` grown by 1/MARGIN of the image on every side, within the image.
    pub(super) fn grown(&self, desc: &ExecDesc) -> Scissors {
        let (mx, my) = Self::margins(desc);
        let rects = self
            .rects
            .iter()
            .map(|r| r.grown(mx, my, desc.width, desc.height))
            .collect();
        Scissors { rects, grown: true }
    }

    /// Whether a recording made with `self` is valid for `exact`.
    pub(super) fn covers(&self, exact: &Scissors) -> bool {
        self.rects.len() == exact.rects.len()
            && self
                .rects
                .iter()
                .zip(&exact.rects)
                .all(|(r, e)| e.is_empty() || r.contains(e))
    }
}
