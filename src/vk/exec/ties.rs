//! The tie-free decisions of a frame (`plan::tie_free`;
//! docs/precision.md, docs/perf/): which parity, peel
//! and shade draws may run as plain depth tests under the current camera,
//! decided once per plan, camera, scene and settings and kept (`plan::memo`).

use super::gpu_scene::GpuScene;
use super::{ExecDesc, Executor};
use crate::plan::passes::{self, PassFacts, View};
use crate::plan::tie_free::TieFree;
use crate::plan::Plan;
use crate::scene::Camera;

/// Everything the tie-free decisions of a plan depend on
/// ([`Executor::decide_ties`]): the plan, the camera, the scene (`epoch`) and
/// the settings that choose them.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct TieKey {
    plan: u64,
    camera: Camera,
    epoch: u64,
    subpixel_bits: u32,
    size: (u32, u32),
    reversed_z: bool,
    fixed_shade: bool,
    tie_depth: bool,
}

impl Executor {
    /// The tie-free decisions for `plan` under the scene's current camera:
    /// the kept ones while the plan, camera, scene and settings stay
    /// (`plan::memo`; a replayed frame decides nothing anew).
    pub(super) fn decide_ties(&mut self, plan: &Plan) -> TieFree {
        let Some(scene) = self.scene.as_ref() else {
            return TieFree::none();
        };
        let key = TieKey {
            plan: self.plan_ids.id(plan),
            camera: scene.camera,
            epoch: self.epoch,
            subpixel_bits: self.subpixel_bits(),
            size: (self.desc.width, self.desc.height),
            reversed_z: self.desc.reversed_z,
            fixed_shade: self.depth_equal_shades(),
            tie_depth: self.tie_depth(),
        };
        let (desc, bits) = (self.desc, key.subpixel_bits);
        let (fixed, tie_depth) = (key.fixed_shade, key.tie_depth);
        self.tie_memo
            .get_or_insert_with(key, || {
                tie_decisions(scene, &desc, bits, plan, fixed, tie_depth)
            })
            .clone()
    }
}

/// `plan`'s tie-free decisions on `scene` under its camera: the tie-free
/// pass (`plan::passes::tie_free`) on the uploaded scene's view.
fn tie_decisions(
    scene: &GpuScene,
    desc: &ExecDesc,
    subpixel_bits: u32,
    plan: &Plan,
    fixed_shade: bool,
    tie_depth: bool,
) -> TieFree {
    let view = View {
        camera: &scene.camera,
        view: scene.cam.view,
        proj: scene.cam.proj,
        width: desc.width,
        height: desc.height,
        reversed_z: desc.reversed_z,
        bounds: &scene.bounds,
    };
    let facts = PassFacts {
        subpixel_bits,
        depth_equal_shades: fixed_shade,
        tie_depth,
    };
    passes::tie_free(plan, &view, &scene.ties, &facts)
}
