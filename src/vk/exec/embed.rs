//! The executor's side of embedding (`vk::embed`): a frame recorded, unrolled to
//! learnt loop counts, into a command buffer someone else submits, and the check
//! of its occlusion counts read later without waiting. Same recording as the
//! standalone replay (`ready_unrolled`, `check_unrolled`), minus the submission.

use crate::plan::cut_away::CutAway;
use ash::vk;

use super::gpu_scene::GpuScene;
use super::record::{Group, HostShade};
use super::{layers_fit, ExecStats, Executor};
use crate::plan::usage::Resource;
use crate::plan::{Plan, Step, Tex};
use crate::scene::Mesh;
use crate::vk::error::VkError;
use crate::vk::scissor::{bounds_rect, Rect};

/// What an embedded recording needs to check its loop counts afterwards.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Unrolled {
    pub layers: Vec<u32>,
    /// Loop and iteration of each occlusion query, in query order.
    pub groups: Vec<Group>,
    pub stats: ExecStats,
}

/// Views of the images a frame leaves its result in (all in `sync::REST`).
pub(crate) struct Output {
    pub color: (vk::Image, vk::ImageView),
    pub prim: (vk::Image, vk::ImageView),
    pub depth: (vk::Image, vk::ImageView),
}

impl Executor {
    /// The loop counts a standalone frame of `plan` learnt, if any.
    pub(crate) fn learnt_layers(&self, plan: &Plan) -> Option<Vec<u32>> {
        match &self.layers {
            Some((p, n)) if p == plan => Some(n.clone()),
            _ => None,
        }
    }

    pub(crate) fn occlusion_pool(&self) -> vk::QueryPool {
        self.occlusion.pool
    }

    /// Records `plan`'s frame with its loops unrolled to `layers` into `cmd`
    /// (begun by the caller, outside any rendering); every image starts and ends
    /// in `sync::REST`. Submits nothing. With `host`, the plan's final shade
    /// (its last `host.1` steps, `final_shade`) is drawn into the host's
    /// attachments (`record::host`).
    pub(crate) fn record_unrolled(
        &mut self,
        cmd: vk::CommandBuffer,
        plan: &Plan,
        layers: &[u32],
        host: Option<(&HostShade, usize)>,
    ) -> Result<Unrolled, VkError> {
        let _layer = self.shared.layer_use();
        // The same checks, images and tie decisions as the standalone frame's:
        // the host's direct shade draws a tied mesh's rule in its tie zones
        // alone too.
        self.prepare_plan(plan)?;
        self.scene_ref()?;
        let scene = self.scene.as_ref().expect("checked above");
        let cam = scene.cam;
        let openings = self.opening_rects.get(&self.cut_away, scene, &self.desc);
        self.rects = super::Scissors::exact(scene, &self.desc, openings);
        // Earlier frames may be in flight: the camera is written in the stream.
        self.camera.record_update(cmd, &cam);
        let (mut stats, groups, _marks) = self.record_frame(cmd, plan, layers, host)?;
        stats.counts.submits = 0;
        stats.counts.loop_iterations = layers.to_vec();
        self.last_output = Some(plan.output_ds);
        Ok(Unrolled {
            layers: layers.to_vec(),
            groups,
            stats,
        })
    }

    /// The most occlusion queries a recording of `plan` unrolled to `layers`
    /// holds (draws skipped off screen hold none).
    pub(crate) fn counted_draws(plan: &Plan, layers: &[u32]) -> u32 {
        super::unroll(plan, layers)
            .iter()
            .filter(|(s, _)| matches!(s, Step::Draw(d) if d.count_samples))
            .count() as u32
    }

    /// Whether an embedded frame's counts show its unrolling was right.
    pub(crate) fn unrolled_fits(plan: &Plan, u: &Unrolled, samples: &[u64]) -> bool {
        layers_fit(plan, &u.layers, &u.groups, samples)
    }

    /// The images the last frame left its colour, ids and depth in: the
    /// output depth-stencil's depth, or `depth` (a texture holding it wherever
    /// the ids are not 0).
    pub(crate) fn output(&self, depth: Option<Tex>) -> Option<Output> {
        let out = self.last_output?;
        let t = self.targets.as_ref()?;
        let pair = |r: Resource| {
            let i = t.image(r);
            let view = if i.desc.is_depth_stencil() {
                i.depth_view
            } else {
                i.view
            };
            (i.raw, view)
        };
        Some(Output {
            color: pair(Resource::Color),
            prim: pair(Resource::Prim),
            depth: pair(depth.map_or(Resource::DepthStencil(out), Resource::Texture)),
        })
    }

    /// Rewrites mesh `i`'s vertices in place (same triangle count; the vertex
    /// buffer is host-visible): a moved mesh costs no new buffer and no upload of
    /// the others. Recordings are invalidated (their scissors used the old bounds).
    pub(crate) fn rewrite_mesh(&mut self, i: usize, mesh: &Mesh) -> Result<(), VkError> {
        let _layer = self.shared.layer_use();
        let scene = self
            .scene
            .as_mut()
            .ok_or_else(|| VkError::Plan("rewrite_mesh before upload".into()))?;
        GpuScene::rewrite(scene, i, mesh)?;
        // The sets were of the old geometry.
        self.cut_away = CutAway::none();
        self.opening_rects.clear();
        self.epoch += 1;
        self.recording = None;
        Ok(())
    }

    /// The screen rectangle the CSG can cover: the projected bounds of every
    /// mesh (the composite pass is scissored to it).
    pub fn output_rect(&self) -> Rect {
        let d = self.desc;
        match &self.scene {
            Some(s) => bounds_rect(
                s.cam.view,
                s.cam.proj,
                s.camera.near,
                &s.bounds,
                d.width,
                d.height,
            ),
            None => Rect::EMPTY,
        }
    }

    fn scene_ref(&self) -> Result<&GpuScene, VkError> {
        self.scene
            .as_ref()
            .ok_or_else(|| VkError::Plan("record before upload: no scene".into()))
    }
}
