//! The dynamic state of a draw (scissor, cull, depth and stencil: everything a
//! Blist step changes between draws) and which of it must be recorded again.
//!
//! Dynamic state is command-buffer state: it survives pipeline binds (every
//! pipeline leaves the same states dynamic) and rendering blocks. So the recorder
//! keeps what it last set and records only the commands whose value changes —
//! consecutive parity or peel draws differ in a scissor or a stencil op, not in
//! all eleven. This is what makes re-recording cheap (issue 9 §3: ≤ 1 ms of CPU
//! per 1,000 draws); `Counts::state_commands` counts what is recorded.

use ash::vk;

use crate::plan::Draw;
use crate::vk::conv::{self, StencilFaceOps};
use crate::vk::scissor::Rect;

/// The dynamic state of one draw.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct DynState {
    pub scissor: Rect,
    pub cull: vk::CullModeFlags,
    pub depth_test: bool,
    pub depth_write: bool,
    pub depth_compare: vk::CompareOp,
    pub stencil_test: bool,
    pub front: StencilFaceOps,
    pub back: StencilFaceOps,
    pub compare_mask: u32,
    pub write_mask: u32,
    pub reference: u32,
}

/// One settable piece of [`DynState`]: one command each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Field {
    Scissor,
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

const FIELDS: [Field; 11] = [
    Field::Scissor,
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

impl DynState {
    /// The state of `draw` (`None`: an internal full-screen copy, no tests) within
    /// `scissor`; `reversed`: reversed depth.
    pub fn of(draw: Option<&Draw>, scissor: Rect, reversed: bool) -> DynState {
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
        DynState {
            scissor,
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

    fn same(&self, o: &DynState, f: Field) -> bool {
        match f {
            Field::Scissor => self.scissor == o.scissor,
            Field::Cull => self.cull == o.cull,
            Field::DepthTest => self.depth_test == o.depth_test,
            Field::DepthWrite => self.depth_write == o.depth_write,
            Field::DepthCompare => self.depth_compare == o.depth_compare,
            Field::StencilTest => self.stencil_test == o.stencil_test,
            Field::StencilFront => self.front == o.front,
            Field::StencilBack => self.back == o.back,
            Field::CompareMask => self.compare_mask == o.compare_mask,
            Field::WriteMask => self.write_mask == o.write_mask,
            Field::Reference => self.reference == o.reference,
        }
    }

    /// The fields to record to go from `prev` (`None`: nothing set yet in this
    /// command buffer) to `self`.
    pub fn changes<'a>(&'a self, prev: Option<&'a DynState>) -> impl Iterator<Item = Field> + 'a {
        FIELDS
            .into_iter()
            .filter(move |&f| prev.is_none_or(|p| !p.same(self, f)))
    }

    /// Records field `f` of `self` into `cmd`.
    pub fn record(&self, device: &ash::Device, cmd: vk::CommandBuffer, f: Field) {
        let both = vk::StencilFaceFlags::FRONT_AND_BACK;
        // SAFETY (every call below): `cmd` is recording and every bound pipeline
        // declares these states dynamic; Vulkan 1.3 core commands.
        match f {
            Field::Scissor => unsafe {
                device.cmd_set_scissor(cmd, 0, &[conv::rect2d(self.scissor)])
            },
            // SAFETY: see above.
            Field::Cull => unsafe { device.cmd_set_cull_mode(cmd, self.cull) },
            // SAFETY: see above.
            Field::DepthTest => unsafe { device.cmd_set_depth_test_enable(cmd, self.depth_test) },
            // SAFETY: see above.
            Field::DepthWrite => unsafe {
                device.cmd_set_depth_write_enable(cmd, self.depth_write)
            },
            // SAFETY: see above.
            Field::DepthCompare => unsafe {
                device.cmd_set_depth_compare_op(cmd, self.depth_compare)
            },
            // SAFETY: see above.
            Field::StencilTest => unsafe {
                device.cmd_set_stencil_test_enable(cmd, self.stencil_test)
            },
            Field::StencilFront | Field::StencilBack => {
                let (face, o) = if f == Field::StencilFront {
                    (vk::StencilFaceFlags::FRONT, self.front)
                } else {
                    (vk::StencilFaceFlags::BACK, self.back)
                };
                // SAFETY: see above.
                unsafe {
                    device.cmd_set_stencil_op(cmd, face, o.fail, o.pass, o.depth_fail, o.compare)
                }
            }
            // SAFETY: see above.
            Field::CompareMask => unsafe {
                device.cmd_set_stencil_compare_mask(cmd, both, self.compare_mask)
            },
            // SAFETY: see above.
            Field::WriteMask => unsafe {
                device.cmd_set_stencil_write_mask(cmd, both, self.write_mask)
            },
            // SAFETY: see above.
            Field::Reference => unsafe {
                device.cmd_set_stencil_reference(cmd, both, self.reference)
            },
        }
    }
}

/// Records the state every draw of a command buffer shares (viewport, front
/// face): once, before its first draw.
pub(super) fn record_fixed(device: &ash::Device, cmd: vk::CommandBuffer, width: u32, height: u32) {
    let vp = vk::Viewport {
        x: 0.0,
        y: 0.0,
        width: width as f32,
        height: height as f32,
        min_depth: 0.0,
        max_depth: 1.0,
    };
    // SAFETY: recording; the pipelines declare viewport and front face dynamic.
    unsafe { device.cmd_set_viewport(cmd, 0, &[vp]) };
    // SAFETY: as above.
    unsafe { device.cmd_set_front_face(cmd, conv::FRONT_FACE) };
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
        let r = Rect::full(8, 8);
        let a = DynState::of(Some(&draw(Cull::Back, 1)), r, false);
        assert_eq!(a.changes(None).count(), FIELDS.len());
        assert_eq!(a.changes(Some(&a)).count(), 0);
    }

    #[test]
    fn only_what_differs_is_recorded_again() {
        let r = Rect::full(8, 8);
        let a = DynState::of(Some(&draw(Cull::Back, 1)), r, false);
        let b = DynState::of(Some(&draw(Cull::Front, 2)), r, false);
        let got: Vec<Field> = b.changes(Some(&a)).collect();
        assert_eq!(got, vec![Field::Cull, Field::Reference]);
        let smaller = Rect { x1: 4, ..r };
        let c = DynState::of(Some(&draw(Cull::Front, 2)), smaller, false);
        assert_eq!(
            c.changes(Some(&b)).collect::<Vec<_>>(),
            vec![Field::Scissor]
        );
        // An internal copy turns the tests off.
        let copy = DynState::of(None, r, false);
        let off: Vec<Field> = copy.changes(Some(&b)).collect();
        assert!(off.contains(&Field::DepthTest) && off.contains(&Field::StencilTest));
    }
}
