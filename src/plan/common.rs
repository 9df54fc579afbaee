//! Pieces shared by the Blist-based plan builders (Blister, seed 002 §5, and CST,
//! seed 000 §4): a Blist target as a stencil label, and the full-screen sweep
//! that rewrites stencil values (ChangeStencilState).
#![deny(unsafe_code)]

use super::stencil::Next;
use super::step::*;
use crate::csg::Target;

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
/// test, seed 000 §6 and seed 001 §6). Changes no image.
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
