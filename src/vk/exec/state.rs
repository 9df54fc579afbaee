//! The depth, stencil and cull state of a draw (everything a Blist step changes
//! between draws but its scissor), and how the recorder gets it into the
//! command buffer with the fewest commands (re-recording 1,000
//! draws in ≤ 1 ms of CPU).
//!
//! A plan uses few distinct states (5 to 21 on the shipped scenes), but
//! consecutive draws differ in several fields: a CST trim alternates a mesh
//! draw and a full-screen sweep whose stencil reference, compare and write
//! masks all differ. So the state is baked into pipeline variants
//! ([`crate::vk::pipeline::Pipelines::get_fixed`]): one pipeline bind replaces
//! up to ten dynamic-state commands, and on lavapipe each command is an
//! allocation when recorded and a free when the buffer is reset. Past the
//! executor's budget of variants a draw falls back to the pipeline with every
//! field dynamic, and the recorder sets only the fields whose value changes
//! ([`RasterState::changes`]). The scissor, viewport and front face are dynamic
//! in every pipeline. `Counts::state_commands` counts what is recorded.

use ash::vk;

use crate::plan::Draw;
use crate::vk::conv::{self, StencilFaceOps};
use crate::vk::pipeline::RasterState;
use crate::vk::scissor::Rect;

/// One dynamic piece of [`RasterState`]: one command each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Field {
    Cull,
    DepthTest,
    DepthWrite,
    DepthCompare,
    StencilTest,
    StencilFront,
    StencilBack,
    CompareMask,
    WriteMask,
    Reference,
}

const FIELDS: [Field; 10] = [
    Field::Cull,
    Field::DepthTest,
    Field::DepthWrite,
    Field::DepthCompare,
    Field::StencilTest,
    Field::StencilFront,
    Field::StencilBack,
    Field::CompareMask,
    Field::WriteMask,
    Field::Reference,
];

const KEEP: StencilFaceOps = StencilFaceOps {
    fail: vk::StencilOp::KEEP,
    pass: vk::StencilOp::KEEP,
    depth_fail: vk::StencilOp::KEEP,
    compare: vk::CompareOp::ALWAYS,
};

/// The state of plan draw `draw` (`None`: an internal full-screen pass, no
/// tests, no culling); `reversed`: reversed depth. The one mapping from a
/// plan's cull, depth and stencil state to Vulkan's: a new `Fragment` or
/// `DepthState` a planner gives a draw needs nothing here.
pub(super) fn raster_state(draw: Option<&Draw>, reversed: bool) -> RasterState {
    let cull = draw
        .map(|d| conv::cull_mode(d.cull))
        .unwrap_or(vk::CullModeFlags::NONE);
    let (depth_test, depth_write, depth_compare) = match draw {
        Some(dr) => (
            true,
            dr.depth.write,
            conv::compare_op(dr.depth.compare, reversed),
        ),
        None => (false, false, vk::CompareOp::ALWAYS),
    };
    let stencil = draw.and_then(|d| d.stencil.as_ref());
    let (front, back, compare_mask, write_mask, reference) = match stencil {
        Some(s) => (
            conv::stencil_face(&s.front),
            conv::stencil_face(&s.back),
            s.compare_mask as u32,
            s.write_mask as u32,
            s.reference as u32,
        ),
        None => (KEEP, KEEP, 0, 0, 0),
    };
    RasterState {
        cull,
        depth_test,
        depth_write,
        depth_compare,
        stencil_test: stencil.is_some(),
        front,
        back,
        compare_mask,
        write_mask,
        reference,
    }
}

/// Whether field `f` of `a` and `b` agree.
fn same(a: &RasterState, b: &RasterState, f: Field) -> bool {
    match f {
        Field::Cull => a.cull == b.cull,
        Field::DepthTest => a.depth_test == b.depth_test,
        Field::DepthWrite => a.depth_write == b.depth_write,
        Field::DepthCompare => a.depth_compare == b.depth_compare,
        Field::StencilTest => a.stencil_test == b.stencil_test,
        Field::StencilFront => a.front == b.front,
        Field::StencilBack => a.back == b.back,
        Field::CompareMask => a.compare_mask == b.compare_mask,
        Field::WriteMask => a.write_mask == b.write_mask,
        Field::Reference => a.reference == b.reference,
    }
}

/// The fields to record to go from `prev` (`None`: nothing valid set since the
/// command buffer began or a pipeline with static state was bound) to `next`.
pub(super) fn changes<'a>(
    next: &'a RasterState,
    prev: Option<&'a RasterState>,
) -> impl Iterator<Item = Field> + 'a {
    FIELDS
        .into_iter()
        .filter(move |&f| prev.is_none_or(|p| !same(p, next, f)))
}

/// Records field `f` of `s` into `cmd` as dynamic state.
pub(super) fn record(device: &ash::Device, cmd: vk::CommandBuffer, s: &RasterState, f: Field) {
    let both = vk::StencilFaceFlags::FRONT_AND_BACK;
    // SAFETY (every call below): `cmd` is recording and the bound pipeline
    // declares these states dynamic; Vulkan 1.3 core commands.
    match f {
        // SAFETY: see above.
        Field::Cull => unsafe { device.cmd_set_cull_mode(cmd, s.cull) },
        // SAFETY: see above.
        Field::DepthTest => unsafe { device.cmd_set_depth_test_enable(cmd, s.depth_test) },
        // SAFETY: see above.
        Field::DepthWrite => unsafe { device.cmd_set_depth_write_enable(cmd, s.depth_write) },
        // SAFETY: see above.
        Field::DepthCompare => unsafe { device.cmd_set_depth_compare_op(cmd, s.depth_compare) },
        // SAFETY: see above.
        Field::StencilTest => unsafe { device.cmd_set_stencil_test_enable(cmd, s.stencil_test) },
        Field::StencilFront | Field::StencilBack => {
            let (face, o) = if f == Field::StencilFront {
                (vk::StencilFaceFlags::FRONT, s.front)
            } else {
                (vk::StencilFaceFlags::BACK, s.back)
            };
            // SAFETY: see above.
            unsafe { device.cmd_set_stencil_op(cmd, face, o.fail, o.pass, o.depth_fail, o.compare) }
        }
        // SAFETY: see above.
        Field::CompareMask => unsafe {
            device.cmd_set_stencil_compare_mask(cmd, both, s.compare_mask)
        },
        // SAFETY: see above.
        Field::WriteMask => unsafe { device.cmd_set_stencil_write_mask(cmd, both, s.write_mask) },
        // SAFETY: see above.
        Field::Reference => unsafe { device.cmd_set_stencil_reference(cmd, both, s.reference) },
    }
}

/// Whether the scissor `current`, set in the command buffer, serves a mesh
/// draw that asks for `want` and whose triangles cover only pixels inside
/// `covered` (its meshes' screen rectangles), in a block of render area
/// `area`: both cut the same pixels out of what the meshes can cover, so the
/// draw needs no scissor command. Shading draws per mesh, each asking for
/// its own bounds, then keep the first (larger) scissor.
pub(super) fn scissor_serves(current: Rect, want: Rect, covered: Rect, area: Rect) -> bool {
    area.contains(&current) && current.intersect(&covered) == want.intersect(&covered)
}

/// Records the state every draw of a command buffer shares (viewport, front
/// face; dynamic in every pipeline): once, before its first draw.
pub(super) fn record_fixed(device: &ash::Device, cmd: vk::CommandBuffer, width: u32, height: u32) {
    set_viewport(device, cmd, width, height, 0.0..=1.0);
    // SAFETY: recording; the pipelines declare the front face dynamic.
    unsafe { device.cmd_set_front_face(cmd, conv::FRONT_FACE) };
}

/// Sets the viewport: the whole image, framebuffer depths `depths` (a
/// single value for a `Geometry::Footprint` draw, whose fragments all lie
/// at it).
pub(super) fn set_viewport(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    width: u32,
    height: u32,
    depths: std::ops::RangeInclusive<f32>,
) {
    let vp = vk::Viewport {
        x: 0.0,
        y: 0.0,
        width: width as f32,
        height: height as f32,
        min_depth: *depths.start(),
        max_depth: *depths.end(),
    };
    // SAFETY: recording; the pipelines declare the viewport dynamic.
    unsafe { device.cmd_set_viewport(cmd, 0, &[vp]) };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{
        CompareOp, Cull, DepthState, Fragment, Geometry, Scissor, StencilFace, StencilOp,
        StencilState,
    };

    fn draw(cull: Cull, reference: u8) -> Draw {
        let face = StencilFace {
            compare: CompareOp::Always,
            fail: StencilOp::Keep,
            pass: StencilOp::Invert,
            depth_fail: StencilOp::Keep,
        };
        Draw {
            geometry: Geometry::Mesh(0),
            cull,
            depth: DepthState {
                compare: CompareOp::Less,
                write: false,
            },
            stencil: Some(StencilState {
                front: face,
                back: face,
                compare_mask: 0xff,
                write_mask: 0xff,
                reference,
            }),
            fragment: Fragment::None,
            ds: 0,
            scissor: Scissor::Full,
            count_samples: false,
        }
    }

    #[test]
    fn the_first_draw_sets_everything_and_an_equal_one_nothing() {
        let a = raster_state(Some(&draw(Cull::Back, 1)), false);
        assert_eq!(changes(&a, None).count(), FIELDS.len());
        assert_eq!(changes(&a, Some(&a)).count(), 0);
    }

    #[test]
    fn only_what_differs_is_recorded_again() {
        let a = raster_state(Some(&draw(Cull::Back, 1)), false);
        let b = raster_state(Some(&draw(Cull::Front, 2)), false);
        let got: Vec<Field> = changes(&b, Some(&a)).collect();
        assert_eq!(got, vec![Field::Cull, Field::Reference]);
        // An internal copy turns the tests off.
        let copy = raster_state(None, false);
        let off: Vec<Field> = changes(&copy, Some(&b)).collect();
        assert!(off.contains(&Field::DepthTest) && off.contains(&Field::StencilTest));
    }

    #[test]
    fn a_scissor_serves_a_mesh_draw_that_cuts_its_meshes_alike() {
        let r = |x0, y0, x1, y1| Rect { x0, y0, x1, y1 };
        let area = r(0, 0, 100, 100);
        let mesh = r(10, 10, 30, 30);
        // A larger scissor serves a draw scissored to its own bounds.
        assert!(scissor_serves(area, mesh, mesh, area));
        assert!(scissor_serves(
            r(5, 5, 40, 40),
            r(10, 10, 30, 30),
            mesh,
            area
        ));
        // A scissor that cuts the meshes differently does not.
        assert!(!scissor_serves(r(20, 0, 100, 100), mesh, mesh, area));
        assert!(!scissor_serves(area, r(0, 0, 20, 20), mesh, area));
        // One that cuts them the same way does, even if it differs elsewhere.
        assert!(scissor_serves(r(0, 0, 20, 50), r(0, 5, 20, 40), mesh, area));
        // Both cut everything: nothing can be drawn either way.
        assert!(scissor_serves(
            r(50, 50, 60, 60),
            r(70, 70, 80, 80),
            mesh,
            area
        ));
        // Never a scissor outside the block's render area.
        assert!(!scissor_serves(area, mesh, mesh, r(0, 0, 50, 50)));
    }

    #[test]
    fn the_plan_state_maps_to_vulkan_values() {
        let s = raster_state(Some(&draw(Cull::Back, 3)), true);
        assert_eq!(s.cull, vk::CullModeFlags::BACK);
        assert!(s.depth_test && !s.depth_write && s.stencil_test);
        // Reversed depth mirrors the comparison.
        assert_eq!(s.depth_compare, vk::CompareOp::GREATER);
        assert_eq!((s.reference, s.compare_mask, s.write_mask), (3, 0xff, 0xff));
        assert_eq!(s.front.pass, vk::StencilOp::INVERT);
        let none = raster_state(None, true);
        assert!(!none.depth_test && !none.stencil_test);
    }
}
