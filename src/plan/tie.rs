//! The tie rule on coincident faces, and the tolerances that make it hold on any
//! conformant Vulkan device ("the lowest index wins";
//! docs/precision.md).
//!
//! Two faces of different primitives that lie in one plane are drawn as different
//! triangles. Where both cover a pixel, their rasterized depths differ by:
//!
//! 1. **Vertex snapping.** A device snaps framebuffer x, y of each vertex to
//!    2^-`subPixelPrecisionBits` pixel (Vulkan "Limits": at least 4 bits) and may
//!    interpolate depth from the snapped vertices (the NVIDIA H200 does; lavapipe
//!    does not). Moving each vertex by at most δ = 2^-(bits+1) per axis moves a
//!    point inside the triangle by at most δ per axis (its barycentric weights sum
//!    to 1), so the depth at a pixel moves by at most δ (|∂z/∂x| + |∂z/∂y|) =
//!    δ · fwidth(z). Two faces snapped independently: 2δ · fwidth(z) = 2^-bits ·
//!    fwidth(z), i.e. 1/16 of fwidth at the 4-bit minimum.
//! 2. **Depth representation.** The depth texture holds the depth buffer's value:
//!    D24 rounds to 2^-24, D32 float to one ulp at the value (2^(e-23), e the
//!    exponent: the "r" of Vulkan's depth-bias section). The fragment's own depth
//!    is an unrounded float. [`SHADE_EPS`] = 2^-20 covers 16 D24 quanta, and far
//!    more than an ulp of D32 near 1.0 (standard Z: ulp 2^-24); with reversed Z
//!    it becomes a few ulps of the value (below), matching float's relative ulp.
//!
//! A tolerance test therefore compares |z_fragment − z_texture| with
//! `eps' + TIE_SLOPES · 2^-bits · fwidth(z)`, `bits` the device's own
//! `subPixelPrecisionBits` (the executor passes it in the push constants' flags;
//! the rounding emulation passes the emulated device's), [`TIE_SLOPES`] = 1: the
//! two-sided bound above. `eps'` is [`SHADE_EPS`] with standard Z, and
//! [`REVERSED_SCALE`] · eps · z with reversed Z (1–2 ulps of the stored float).
//! The slope term is for coplanar faces snapped differently, so it applies only
//! where the fragment's depth gradient agrees (within 1/32) with the texture
//! face's, read from one-sided texel differences: a face crossing the other at a
//! shallow angle is not a tie (near-tangent sphere crossings in a deep tree were
//! taken as ties over bands wider than a pixel). The final shading accepts the
//! visible face by its own raster depth (within eps'), any other face by its
//! plane depth (unsnapped, below) within eps' plus the visible depth's one-sided
//! snapping and with an agreeing gradient. Every tolerant shader
//! (`shade_near_depth`, `nearer_than`, `peel_tolerant`) includes the same code,
//! `shaders/tie.glsl`, and adds the slope term in the direction of its signed eps;
//! an eps of 0 stays an exact compare. With the bound holding on every
//! conformant device, the set of primitives "coincident" at a pixel is the same
//! on every device, and drawing them in descending index order with the last
//! writer winning picks the lowest index deterministically: the result no longer
//! depends on which face the device happened to rasterize nearest. The device's
//! own precision (not the 4-bit minimum) keeps walls thinner than 1/16 pixel's
//! worth of depth slope resolvable where the device resolves them.
//!
//! The final pass also writes the depth output itself: the winning face's plane
//! evaluated at the pixel centre (`shaders/shade_near_depth.frag`), which removes
//! the snapping error (1.) from `depth.npy` to first order. Where a mesh cannot
//! tie under the camera the executor draws it as a plain depth-equal shade
//! instead (`plan::tie_free`), which leaves the raster depth and culls the
//! faces that are never visible (`plan::visible_side`). The rule draws cull
//! nothing: a positive primitive's back face coincident with the visible face
//! can be the lowest index there (`vk_tests/visible_side.rs`).

use super::{
    CompareOp, Cull, DepthState, Draw, Ds, Fragment, Geometry, MeshId, Scissor, StencilState, Step,
    Tex, VisibleSides,
};

/// Depth tolerance of depth-equal shading and tolerant parity (normalized depth,
/// 2⁻²⁰ ≈ 9.5e-7, about 16 quanta of a 24-bit buffer): faces of several
/// primitives closer than this (plus the slope term, `TIE_SLOPES`) to the
/// visible point count as coincident, and the lowest index wins (`prim.png`,
/// docs/precision.md). With reversed Z (a float buffer, relative precision) the
/// shaders scale it by `REVERSED_SCALE` times the depth value.
pub const SHADE_EPS: f32 = 1.0 / (1u32 << 20) as f32;

/// The slope part of every non-zero depth tolerance, in snapping steps: the
/// shaders add `TIE_SLOPES · 2^-bits · fwidth(gl_FragCoord.z)` (module doc). The
/// shaders hold the same literal (`shaders/tie.glsl`), checked by a test.
#[cfg(test)]
pub const TIE_SLOPES: f32 = 1.0;

/// With reversed Z the shaders scale eps by `REVERSED_SCALE · z`: 2⁻²³ z, between
/// 1 and 2 ulps of the stored float (`shaders/tie.glsl`, checked by a
/// test). Thinner than 2⁻²⁰ z so that a 1e-4 wall 300 units away (3e-7 of its
/// depth) stays resolvable.
pub const REVERSED_SCALE: f32 = 0.125;

/// The final depth-equal shading of locked pixels: every mesh with a face within
/// [`SHADE_EPS`] (+ slope term) of the visible depth (held in `tex`) writes colour,
/// id and its plane's depth at the pixel centre, the lowest index last so that it
/// wins. `sides`: the faces of each mesh that can be the visible ones, which a
/// draw run as a plain depth-equal draw keeps alone (`plan::tie_free`).
pub fn shade_near_depth(
    meshes: &[MeshId],
    ds: Ds,
    tex: Tex,
    stencil: Option<StencilState>,
    sides: &VisibleSides,
) -> Vec<Step> {
    let mut steps = vec![
        Step::Pass("shade".into()),
        Step::CopyDepthToTexture { ds, dst: tex },
    ];
    let mut order = meshes.to_vec();
    order.sort_unstable_by(|a, b| b.cmp(a));
    steps.extend(order.into_iter().map(|m| {
        Step::Draw(Draw {
            geometry: Geometry::Mesh(m),
            scissor: Scissor::BoundsOf(vec![m]),
            cull: Cull::None,
            ds,
            // The comparison is the shader's (against `tex`); the depth written is
            // the winner's plane depth, the output.
            depth: DepthState {
                compare: CompareOp::Always,
                write: true,
            },
            stencil,
            fragment: Fragment::ShadeNearDepth {
                tex,
                eps: SHADE_EPS,
                equal_cull: sides.cull(m),
            },
            count_samples: false,
        })
    }));
    steps
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shaders carry the constants as literals (in `tie_band.glsl`, included
    /// by `tie.glsl`, which every tolerant shader includes, and by
    /// `tie_depth.frag`); they must agree with the plan's.
    #[test]
    fn shaders_use_the_plans_tie_constants() {
        let tie = include_str!("../../shaders/tie_band.glsl");
        for want in [
            format!("const float TIE_SLOPES = {TIE_SLOPES:?};"),
            format!("const float REVERSED_SCALE = {REVERSED_SCALE:?};"),
        ] {
            assert!(tie.contains(&want), "tie_band.glsl lacks `{want}`");
        }
        let texture_rule = include_str!("../../shaders/tie.glsl");
        let tie_depth = include_str!("../../shaders/tie_depth.frag");
        for (name, src) in [("tie.glsl", texture_rule), ("tie_depth.frag", tie_depth)] {
            assert!(
                src.contains("#include \"tie_band.glsl\""),
                "{name} does not include tie_band.glsl"
            );
        }
        for (name, src) in [
            (
                "shade_near_depth",
                include_str!("../../shaders/shade_near_depth.frag"),
            ),
            (
                "nearer_than",
                include_str!("../../shaders/nearer_than.frag"),
            ),
            (
                "peel_tolerant",
                include_str!("../../shaders/peel_tolerant.frag"),
            ),
        ] {
            assert!(
                src.contains("#include \"tie.glsl\""),
                "{name}.frag does not include tie.glsl"
            );
        }
    }

    #[test]
    fn lowest_index_is_drawn_last_and_writes_depth() {
        let steps = shade_near_depth(&[3, 0, 7], 1, 2, None, &VisibleSides::none());
        let order: Vec<MeshId> = steps
            .iter()
            .filter_map(|s| match s {
                Step::Draw(d) => {
                    assert!(d.depth.write && d.depth.compare == CompareOp::Always);
                    match d.geometry {
                        Geometry::Mesh(m) => Some(m),
                        _ => None,
                    }
                }
                _ => None,
            })
            .collect();
        assert_eq!(order, vec![7, 3, 0]);
    }
}
