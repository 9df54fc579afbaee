//! Builders the plan's unit tests share (and the executor's pure lowering's,
//! `vk/exec/record/lower.rs`): a tolerant mesh draw, a plan around steps, and
//! tie decisions with one mesh tie-free and one not. Test code only.

use super::step::*;
use super::tie_free::{TieBand, TieFree};
use crate::geom::ties::TieGaps;
use crate::plan::rect::Rect;
use crate::scene::{shapes, Aabb, Camera, Mesh, Projection};
use glam::DVec3;

/// A draw of mesh `mesh` in its bounds into depth-stencil 0, no depth test,
/// nothing written but what `fragment` writes, no stencil, both sides.
pub(crate) fn mesh_draw(mesh: MeshId, fragment: Fragment) -> Draw {
    Draw {
        geometry: Geometry::Mesh(mesh),
        scissor: Scissor::BoundsOf(vec![mesh]),
        cull: Cull::None,
        ds: 0,
        depth: DepthState {
            compare: CompareOp::Always,
            write: false,
        },
        stencil: None,
        fragment,
        count_samples: false,
    }
}

/// SCS's tolerant parity draw of `mesh` against texture 1 at `eps`.
pub(crate) fn parity(mesh: MeshId, eps: f32) -> Step {
    Step::Draw(mesh_draw(mesh, Fragment::NearerThan { tex: 1, eps }))
}

/// The draw of a step that is one.
pub(crate) fn the_draw(s: Step) -> Draw {
    match s {
        Step::Draw(d) => d,
        other => panic!("not a draw: {other:?}"),
    }
}

/// A plan of `steps` into depth-stencil 0 with textures 0 and 1.
pub(crate) fn plan_of(steps: Vec<Step>) -> Plan {
    Plan {
        algo: "test".into(),
        depth_stencils: 1,
        textures: 2,
        stencil_bits: 1,
        output_ds: 0,
        steps,
    }
}

/// A camera looking at the origin from `eye`, near 3 and far 7.
pub(crate) fn camera(eye: DVec3, projection: Projection) -> Camera {
    Camera {
        eye,
        target: DVec3::ZERO,
        up: DVec3::Y,
        projection,
        near: 3.0,
        far: 7.0,
    }
}

/// The box from -1 to 1 on every axis.
pub(crate) fn unit() -> Aabb {
    Aabb {
        min: DVec3::splat(-1.0),
        max: DVec3::splat(1.0),
    }
}

/// The tie band of a 45° perspective camera 5 units from the unit box, at
/// `size` × `size` pixels with `bits` of vertex snapping.
pub(crate) fn band(size: u32, bits: u32, reversed: bool) -> TieBand {
    let cam = camera(
        DVec3::new(0.0, 0.0, 5.0),
        Projection::Perspective { fov_y_deg: 45.0 },
    );
    TieBand::new(&cam, size, size, bits, reversed, &unit())
}

/// A projection of every box to the whole of an 800 × 800 image.
pub(crate) fn whole(_: &Aabb) -> Rect {
    Rect::full(800, 800)
}

/// Tie decisions for `plan` where mesh 0 is tie-free and mesh 1 ties with
/// itself only, at every tolerance of the plan.
pub(crate) fn half_free(plan: &Plan) -> TieFree {
    let gaps = TieGaps {
        min_gap: vec![f64::INFINITY, 0.0],
        cap: 1.0,
        pairs: vec![(1, 1, 0.0)],
        zones: vec![],
    };
    TieFree::new(&gaps, &gaps, &band(800, 8, true), plan, &whole)
}

/// A box centred at `center` with half extents `half`.
pub(crate) fn cube(center: DVec3, half: DVec3) -> Mesh {
    let mut m = shapes::make_box(half * 2.0);
    for p in &mut m.positions {
        *p += center;
    }
    m
}

/// A plan of `before`, then a final shade of meshes `ms` (depth-stencil 0,
/// texture 1).
pub(crate) fn shaded(before: Vec<Step>, ms: &[MeshId]) -> Plan {
    let mut steps = before;
    steps.extend(super::shade_near_depth(
        ms,
        0,
        1,
        None,
        &super::VisibleSides::none(),
    ));
    plan_of(steps)
}

/// The steps of `plan`, as the executor's decisions take them.
pub(crate) fn refs(plan: &Plan) -> Vec<&Step> {
    plan.steps.iter().collect()
}
