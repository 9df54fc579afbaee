//! The per-mesh screen rectangles a recording's scissors come from, and when
//! a kept recording's scissors still serve a moved camera (docs/executor.md).

use super::gpu_scene::GpuScene;
use super::ExecDesc;
use crate::plan::cut_away::CutAway;
use crate::plan::MeshId;
use crate::scene::Aabb;
use crate::vk::scissor::{bounds_rect, Rect, RectUnions};

/// The screen rectangle of world boxes `boxes` under `scene`'s camera (the
/// union of each one's).
fn screen_rect(scene: &GpuScene, desc: &ExecDesc, boxes: &[Aabb]) -> Rect {
    let (view, proj, near) = (scene.cam.view, scene.cam.proj, scene.camera.near);
    bounds_rect(view, proj, near, boxes, desc.width, desc.height)
}

/// Per mesh, the screen rectangle its inside can be seen in
/// (`CutAway::inside_holes`; `None`: not known), computed once for the cutter
/// sets' camera rather than every frame: the sets hold for that camera only,
/// and the scene's bounds change only with an upload or a rewritten mesh,
/// which drop the sets ([`OpeningRects::clear`]).
#[derive(Debug, Default)]
pub(crate) struct OpeningRects(Option<Vec<Option<Rect>>>);

impl OpeningRects {
    /// Forgets the rectangles (new sets, or new geometry).
    pub(super) fn clear(&mut self) {
        self.0 = None;
    }

    /// The rectangles for `cut` under `scene`'s current camera: none when
    /// `cut` has no sets or holds for another camera.
    pub(super) fn get(
        &mut self,
        cut: &CutAway,
        scene: &GpuScene,
        desc: &ExecDesc,
    ) -> &[Option<Rect>] {
        if cut.is_empty() || cut.camera() != Some(&scene.camera) {
            return &[];
        }
        self.0.get_or_insert_with(|| {
            (0..scene.bounds.len() as MeshId)
                .map(|c| {
                    let boxes = cut.inside_holes(c, &scene.bounds, &scene.camera)?;
                    Some(screen_rect(scene, desc, &boxes))
                })
                .collect()
        })
    }
}

/// The per-mesh screen rectangles a recording's scissors come from: exact for a
/// still camera, grown by [`Scissors::MARGIN`] of the image after a camera move,
/// so that the next moves replay. Scissors only bound work (every plan is
/// correct with any scissor that contains its meshes' projections), so a
/// recording stays valid while each mesh's exact rectangle lies inside its
/// recorded one and no mesh recorded off screen has come on screen.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Scissors {
    pub rects: Vec<Rect>,
    /// Per mesh, the rectangle its inside can be seen in through an opening
    /// (`CutAway::inside_holes`, the cutter sets the executor was given);
    /// `None`: not known (`plan::Scissor::Openings` stays uncut). Empty:
    /// none known.
    pub openings: Vec<Option<Rect>>,
    pub grown: bool,
}

impl Scissors {
    /// Margin of grown rectangles, as a fraction of the image's width and height.
    pub const MARGIN: u32 = 8;

    /// Each mesh's exact rectangle under `cam`, with `openings`
    /// ([`OpeningRects::get`]).
    pub(super) fn exact(scene: &GpuScene, desc: &ExecDesc, openings: &[Option<Rect>]) -> Scissors {
        Scissors {
            rects: scene
                .bounds
                .iter()
                .map(|b| screen_rect(scene, desc, std::slice::from_ref(b)))
                .collect(),
            openings: openings.to_vec(),
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
        let openings = self
            .openings
            .iter()
            .map(|o| o.map(|r| r.grown(mx, my, desc.width, desc.height)))
            .collect();
        Scissors {
            rects,
            openings,
            grown: true,
        }
    }

    /// Whether a recording made with `self` is valid for `exact`.
    pub(super) fn covers(&self, exact: &Scissors) -> bool {
        // A mesh's openings as recorded hold the exact ones: none recorded
        // (the rectangle uncut), or both known and containing them.
        let opening = |m: usize| match (
            self.openings.get(m).copied().flatten(),
            exact.openings.get(m).copied().flatten(),
        ) {
            (None, _) => true,
            (Some(r), Some(e)) => e.is_empty() || r.contains(&e),
            (Some(_), None) => false,
        };
        self.rects.len() == exact.rects.len()
            && self
                .rects
                .iter()
                .zip(&exact.rects)
                .all(|(r, e)| e.is_empty() || r.contains(e))
            && (0..self.openings.len().max(exact.openings.len())).all(opening)
    }

    /// The rectangles' unions, with the openings.
    pub(super) fn unions(&self) -> RectUnions {
        RectUnions::new(&self.rects).with_openings(&self.openings)
    }
}
