//! Pieces shared by the plan builders: a Blist target as a stencil label and
//! the full-screen sweep that rewrites stencil values (ChangeStencilState) of
//! the Blist-based ones (Blister, Hilbrich §5, and CST, Hable & Rossignac §4); a
//! plan's first steps; the layer-peeling loop of the peeling ones (Blister,
//! Goldfeather's layered variant, Stewart, Leach & John §4).
#![deny(unsafe_code)]

use super::stencil::Next;
use super::step::*;
use crate::csg::Target;

/// A plan's first steps: output depth-stencil image `ds` cleared to depth
/// `far` and stencil 0, the colour targets cleared.
pub(crate) fn init_output(ds: Ds, far: f32) -> Vec<Step> {
    vec![
        Step::Pass("init".into()),
        Step::Clear(Clear::DepthStencil {
            ds,
            depth: far,
            stencil: 0,
        }),
        Step::Clear(Clear::Color),
    ]
}

/// A layer-peeling loop over the faces of `meshes`: `head`, then `tail`, then
/// the layer just peeled (texture `cur`) kept as the previous one (`prev`).
/// Each layer holds at least one face per pixel it reaches, so there are at
/// most as many layers as faces; one more iteration finds none.
pub(crate) fn peel_loop(
    prep: &super::Prepared,
    meshes: &[MeshId],
    head: Vec<Step>,
    mut tail: Vec<Step>,
    cur: Tex,
    prev: Tex,
) -> Step {
    tail.push(Step::CopyTexture {
        src: cur,
        dst: prev,
    });
    Step::Loop(Loop {
        head,
        tail,
        max_iterations: prep.triangles_in(meshes).max(1) as u32 + 1,
    })
}

/// A Blist entry's target as a stencil label.
pub(crate) fn next(t: Target) -> Next {
    match t {
        Target::Label(l) => Next::Label(l),
        Target::True => Next::True,
        Target::False => Next::False,
    }
}

/// A full-screen stencil-only sweep on depth-stencil image `ds` (depth test off).
pub(crate) fn sweep(ds: Ds, scissor: Scissor, stencil: StencilState) -> Step {
    Step::Draw(Draw {
        geometry: Geometry::FullScreen { depth: 0.0 },
        scissor,
        cull: Cull::None,
        ds,
        depth: DepthState {
            compare: CompareOp::Always,
            write: false,
        },
        stencil: Some(stencil),
        fragment: Fragment::None,
        count_samples: false,
    })
}

/// Counts (occlusion query) the pixels of depth-stencil `ds` whose stored depth
/// is nearer than the far plane: where a layer is (the layer peelers' stop
/// test, Hable & Rossignac §6 and Kirsch, Nienhaus & Döllner §6). Changes no image.
pub(crate) fn count_covered(ds: Ds, scissor: Scissor) -> Step {
    Step::Draw(Draw {
        geometry: Geometry::FullScreen { depth: 1.0 },
        scissor,
        cull: Cull::None,
        ds,
        depth: DepthState {
            compare: CompareOp::Greater,
            write: false,
        },
        stencil: None,
        fragment: Fragment::None,
        count_samples: true,
    })
}
