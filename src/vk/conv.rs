//! Pure mapping of the plan's depth/stencil vocabulary to `ash` types, including the
//! reversed-Z mirroring of compare ops and depth values. No GPU, no unsafe.

use ash::vk;

use crate::plan::{CompareOp, Cull, StencilFace, StencilOp};
use crate::vk::scissor::Rect;

/// Depth-stencil format of the plan's depth-stencil images (`--depth-format`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize)]
pub enum DepthFormat {
    /// `D24_UNORM_S8_UINT`.
    #[default]
    D24S8,
    /// `D32_SFLOAT_S8_UINT`.
    D32S8,
}

impl DepthFormat {
    /// The Vulkan format.
    pub fn vk(self) -> vk::Format {
        match self {
            DepthFormat::D24S8 => vk::Format::D24_UNORM_S8_UINT,
            DepthFormat::D32S8 => vk::Format::D32_SFLOAT_S8_UINT,
        }
    }

    /// The format of a plan's depth images: [`Self::vk`] where the plan uses
    /// stencil (`plan::formats::needs_stencil`); where it does not, `D32S8`
    /// becomes `D32_SFLOAT`, the same 32-bit float depth (reversed Z keeps its
    /// precision) in half the bytes on lavapipe, which stores `D32S8` as
    /// z32f + s8x24. `D24S8` stays: its depth-only twin `X8_D24` is as wide.
    pub fn vk_for(self, stencil: bool) -> vk::Format {
        match (self, stencil) {
            (DepthFormat::D32S8, false) => vk::Format::D32_SFLOAT,
            _ => self.vk(),
        }
    }
}

/// Whether `format` is one of the depth formats the executor uses (with or
/// without stencil).
pub fn is_depth(format: vk::Format) -> bool {
    matches!(
        format,
        vk::Format::D24_UNORM_S8_UINT | vk::Format::D32_SFLOAT_S8_UINT | vk::Format::D32_SFLOAT
    )
}

/// Whether `format` has a stencil aspect (to bind, clear and barrier).
pub fn has_stencil(format: vk::Format) -> bool {
    matches!(
        format,
        vk::Format::D24_UNORM_S8_UINT | vk::Format::D32_SFLOAT_S8_UINT
    )
}

/// The aspects of an image of `format`: depth (and stencil where it has one),
/// or colour.
pub fn aspects(format: vk::Format) -> vk::ImageAspectFlags {
    match (is_depth(format), has_stencil(format)) {
        (true, true) => vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
        (true, false) => vk::ImageAspectFlags::DEPTH,
        _ => vk::ImageAspectFlags::COLOR,
    }
}

/// Bytes per pixel lavapipe stores for the executor's formats (what a clear
/// fills): `D32_SFLOAT_S8_UINT` is a 32-bit float and a 32-bit stencil word.
/// For the `cleared_bytes` count; a format the executor does not use panics.
pub fn texel_bytes(format: vk::Format) -> u64 {
    match format {
        vk::Format::R8_UNORM => 1,
        vk::Format::R8G8B8A8_UNORM
        | vk::Format::R32_UINT
        | vk::Format::R32_SFLOAT
        | vk::Format::D24_UNORM_S8_UINT
        | vk::Format::D32_SFLOAT => 4,
        vk::Format::D32_SFLOAT_S8_UINT => 8,
        vk::Format::R32G32B32A32_SFLOAT => 16,
        other => panic!("texel_bytes: {other:?} is not an executor format"),
    }
}

/// `op` in the standard convention (smaller is nearer) as the op to use with
/// `reversed` Z, where nearer depths are larger.
pub fn mirror_compare(op: CompareOp, reversed: bool) -> CompareOp {
    if !reversed {
        return op;
    }
    match op {
        CompareOp::Less => CompareOp::Greater,
        CompareOp::Greater => CompareOp::Less,
        CompareOp::LessOrEqual => CompareOp::GreaterOrEqual,
        CompareOp::GreaterOrEqual => CompareOp::LessOrEqual,
        other => other,
    }
}

pub fn compare_op(op: CompareOp, reversed: bool) -> vk::CompareOp {
    match mirror_compare(op, reversed) {
        CompareOp::Never => vk::CompareOp::NEVER,
        CompareOp::Less => vk::CompareOp::LESS,
        CompareOp::Equal => vk::CompareOp::EQUAL,
        CompareOp::LessOrEqual => vk::CompareOp::LESS_OR_EQUAL,
        CompareOp::Greater => vk::CompareOp::GREATER,
        CompareOp::NotEqual => vk::CompareOp::NOT_EQUAL,
        CompareOp::GreaterOrEqual => vk::CompareOp::GREATER_OR_EQUAL,
        CompareOp::Always => vk::CompareOp::ALWAYS,
    }
}

/// Stencil compare ops compare stencil values, never depths: not mirrored.
pub fn stencil_compare_op(op: CompareOp) -> vk::CompareOp {
    compare_op(op, false)
}

pub fn stencil_op(op: StencilOp) -> vk::StencilOp {
    match op {
        StencilOp::Keep => vk::StencilOp::KEEP,
        StencilOp::Zero => vk::StencilOp::ZERO,
        StencilOp::Replace => vk::StencilOp::REPLACE,
        StencilOp::IncrementAndClamp => vk::StencilOp::INCREMENT_AND_CLAMP,
        StencilOp::DecrementAndClamp => vk::StencilOp::DECREMENT_AND_CLAMP,
        StencilOp::Invert => vk::StencilOp::INVERT,
        StencilOp::IncrementAndWrap => vk::StencilOp::INCREMENT_AND_WRAP,
        StencilOp::DecrementAndWrap => vk::StencilOp::DECREMENT_AND_WRAP,
    }
}

/// The ops of one face, in the order of `vkCmdSetStencilOp`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct StencilFaceOps {
    pub fail: vk::StencilOp,
    pub pass: vk::StencilOp,
    pub depth_fail: vk::StencilOp,
    pub compare: vk::CompareOp,
}

pub fn stencil_face(face: &StencilFace) -> StencilFaceOps {
    StencilFaceOps {
        fail: stencil_op(face.fail),
        pass: stencil_op(face.pass),
        depth_fail: stencil_op(face.depth_fail),
        compare: stencil_compare_op(face.compare),
    }
}

pub fn cull_mode(cull: Cull) -> vk::CullModeFlags {
    match cull {
        Cull::None => vk::CullModeFlags::NONE,
        Cull::Back => vk::CullModeFlags::BACK,
        Cull::Front => vk::CullModeFlags::FRONT,
    }
}

/// Front faces are counter-clockwise seen from the eye (outward faces of the CCW
/// meshes). `Camera::proj` flips clip y so that image row 0 is the top: the
/// picture is upright, not mirrored, and Vulkan computes winding in framebuffer
/// coordinates (y down) such that a triangle that looks counter-clockwise on the
/// displayed image has positive area. So outward faces are `COUNTER_CLOCKWISE`;
/// the vk test `front_face_convention` pins this.
pub const FRONT_FACE: vk::FrontFace = vk::FrontFace::COUNTER_CLOCKWISE;

/// A normalized depth of the plan (standard convention) in the buffer's convention.
pub fn depth_value(d: f32, reversed: bool) -> f32 {
    if reversed {
        1.0 - d
    } else {
        d
    }
}

/// A screen rectangle (pixels, exclusive upper corner) as a Vulkan scissor.
pub fn rect2d(r: Rect) -> vk::Rect2D {
    vk::Rect2D {
        offset: vk::Offset2D {
            x: r.x0 as i32,
            y: r.y0 as i32,
        },
        extent: vk::Extent2D {
            width: r.width(),
            height: r.height(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: [CompareOp; 8] = [
        CompareOp::Never,
        CompareOp::Less,
        CompareOp::Equal,
        CompareOp::LessOrEqual,
        CompareOp::Greater,
        CompareOp::NotEqual,
        CompareOp::GreaterOrEqual,
        CompareOp::Always,
    ];

    fn eval(op: vk::CompareOp, a: f32, b: f32) -> bool {
        match op {
            vk::CompareOp::NEVER => false,
            vk::CompareOp::LESS => a < b,
            vk::CompareOp::EQUAL => a == b,
            vk::CompareOp::LESS_OR_EQUAL => a <= b,
            vk::CompareOp::GREATER => a > b,
            vk::CompareOp::NOT_EQUAL => a != b,
            vk::CompareOp::GREATER_OR_EQUAL => a >= b,
            vk::CompareOp::ALWAYS => true,
            _ => unreachable!(),
        }
    }

    /// Testing mirrored depths with the mirrored op gives the standard answer.
    #[test]
    fn reversed_compare_agrees_with_standard() {
        let vals = [0.0f32, 0.25, 0.5, 1.0];
        for op in ALL {
            for &a in &vals {
                for &b in &vals {
                    let std = eval(compare_op(op, false), a, b);
                    let rev = eval(
                        compare_op(op, true),
                        depth_value(a, true),
                        depth_value(b, true),
                    );
                    assert_eq!(std, rev, "{op:?} {a} {b}");
                }
            }
        }
    }

    #[test]
    fn mirror_is_an_involution_and_stencil_is_unmirrored() {
        for op in ALL {
            assert_eq!(mirror_compare(mirror_compare(op, true), true), op);
            assert_eq!(stencil_compare_op(op), compare_op(op, false));
        }
        assert_eq!(stencil_compare_op(CompareOp::Less), vk::CompareOp::LESS);
    }

    #[test]
    fn ops_and_cull() {
        assert_eq!(stencil_op(StencilOp::Invert), vk::StencilOp::INVERT);
        assert_eq!(
            stencil_op(StencilOp::DecrementAndWrap),
            vk::StencilOp::DECREMENT_AND_WRAP
        );
        assert_eq!(cull_mode(Cull::Back), vk::CullModeFlags::BACK);
        assert_eq!(cull_mode(Cull::None), vk::CullModeFlags::NONE);
        let f = stencil_face(&StencilFace {
            compare: CompareOp::Equal,
            fail: StencilOp::Keep,
            pass: StencilOp::Replace,
            depth_fail: StencilOp::Zero,
        });
        assert_eq!(f.compare, vk::CompareOp::EQUAL);
        assert_eq!(f.pass, vk::StencilOp::REPLACE);
        assert_eq!(f.depth_fail, vk::StencilOp::ZERO);
        assert_eq!(depth_value(0.25, true), 0.75);
    }

    /// Only D32S8 has a depth-only twin; a plan that needs stencil keeps
    /// the set-up's format.
    #[test]
    fn depth_only_format_where_no_stencil_is_used() {
        use vk::Format as F;
        assert_eq!(DepthFormat::D32S8.vk_for(true), F::D32_SFLOAT_S8_UINT);
        assert_eq!(DepthFormat::D32S8.vk_for(false), F::D32_SFLOAT);
        assert_eq!(DepthFormat::D24S8.vk_for(true), F::D24_UNORM_S8_UINT);
        assert_eq!(DepthFormat::D24S8.vk_for(false), F::D24_UNORM_S8_UINT);
        for (f, stencil) in [
            (F::D32_SFLOAT, false),
            (F::D32_SFLOAT_S8_UINT, true),
            (F::D24_UNORM_S8_UINT, true),
        ] {
            assert!(is_depth(f));
            assert_eq!(has_stencil(f), stencil, "{f:?}");
            assert_eq!(
                aspects(f).contains(vk::ImageAspectFlags::STENCIL),
                stencil,
                "{f:?}"
            );
            assert!(aspects(f).contains(vk::ImageAspectFlags::DEPTH));
        }
        assert!(!is_depth(F::R32_SFLOAT) && !has_stencil(F::R32_UINT));
        assert_eq!(aspects(F::R8G8B8A8_UNORM), vk::ImageAspectFlags::COLOR);
        assert_eq!(texel_bytes(F::D32_SFLOAT), 4);
        assert_eq!(texel_bytes(F::D32_SFLOAT_S8_UINT), 8);
    }

    #[test]
    fn rect2d_keeps_corner_and_size() {
        let r = Rect {
            x0: 3,
            y0: 5,
            x1: 10,
            y1: 6,
        };
        let v = rect2d(r);
        assert_eq!((v.offset.x, v.offset.y), (3, 5));
        assert_eq!((v.extent.width, v.extent.height), (7, 1));
    }
}
