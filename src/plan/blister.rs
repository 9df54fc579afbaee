//! Blister (Hable & Rossignac; seed 000 §2–3, seed 002 §5 and appendix B):
//! peel the union of all primitives' faces front to back; classify each layer's
//! candidate points against the Blist of the whole expression with a parity bit
//! and the label bits; lock the pixels whose candidate is in the solid; stop when
//! an occlusion query says the peel reached no pixel.
//!
//! Per layer: one peel over all faces, then per Blist entry one parity draw of its
//! primitive and two ChangeStencilState sweeps (parity set → `if_true`, clear →
//! `if_false`; swapped for a complemented leaf), then one push sweep that resets
//! rejected pixels (`F`) to the first label with a far depth and the background.
//!
//! Parity counts the primitive's faces at or in front of the candidate (depth
//! `LessOrEqual`), which classifies the point just *behind* the candidate: the
//! first layer whose point-just-behind is in the solid is where the ray enters it.
//! A candidate lying on another primitive's face is thus decided by depth
//! quantization — Blister's known speckles (seed 000 Fig. 2), which CST removes.
#![deny(unsafe_code)]

use super::stencil::{self, LabelLayout, Next};
use super::step::*;
use super::{PlanError, Prepared};
use crate::csg::{Blist, Target};

/// Depth texture holding the previous layer (read by the peel).
const PREV: Tex = 0;
/// Depth texture the peel writes the new layer into.
const CUR: Tex = 1;

fn next(t: Target) -> Next {
    match t {
        Target::Label(l) => Next::Label(l),
        Target::True => Next::True,
        Target::False => Next::False,
    }
}

/// Builds the Blister plan of the prepared scene's solid(s).
pub fn plan(prep: &Prepared) -> Result<Plan, PlanError> {
    let blist = Blist::new(&prep.positive);
    let layout = LabelLayout::new(blist.num_labels).ok_or(PlanError::TooManyLabels {
        labels: blist.num_labels,
    })?;
    let start = match blist.entries.first() {
        Some(e) => Next::Label(e.label),
        None => return Err(PlanError::NoSolid),
    };
    let all = prep.solid_meshes.clone();
    let label_mask = layout.label_mask();
    let all_mask = layout.all_mask();
    let locked = layout.value(Next::True);
    let far = 1.0;

    let mut steps = vec![
        Step::Pass("init".into()),
        Step::Clear(Clear::DepthStencil {
            ds: 0,
            depth: far,
            stencil: layout.value(start),
        }),
        Step::Clear(Clear::Color),
        Step::Clear(Clear::Texture {
            tex: PREV,
            depth: 0.0,
        }),
        Step::Clear(Clear::Texture {
            tex: CUR,
            depth: 0.0,
        }),
    ];

    // Peel: the nearest face strictly behind the previous layer, at unlocked pixels.
    let head = vec![
        Step::Pass("peel".into()),
        Step::Draw(Draw {
            geometry: Geometry::Meshes(all.clone()),
            scissor: Scissor::Full,
            cull: Cull::None,
            ds: 0,
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: Some(stencil::test_not_equal(locked, label_mask)),
            fragment: Fragment::Peel {
                prev: PREV,
                out: CUR,
                shade: true,
            },
            count_samples: true,
        }),
    ];

    let mut tail = vec![Step::Pass("trim".into())];
    for e in &blist.entries {
        let here = layout.value(Next::Label(e.label));
        let (on_inside, on_outside) = if e.negated {
            (next(e.if_false), next(e.if_true))
        } else {
            (next(e.if_true), next(e.if_false))
        };
        tail.push(Step::Draw(Draw {
            geometry: Geometry::Mesh(e.prim),
            scissor: Scissor::BoundsOf(vec![e.prim]),
            cull: Cull::None,
            ds: 0,
            depth: DepthState {
                compare: CompareOp::LessOrEqual,
                write: false,
            },
            stencil: Some(stencil::toggle_parity(
                here,
                label_mask,
                LabelLayout::PARITY,
            )),
            fragment: Fragment::None,
            count_samples: false,
        }));
        // Parity can only be set inside the primitive's screen bounds.
        tail.push(sweep(
            Scissor::BoundsOf(vec![e.prim]),
            stencil::change_stencil_state(
                here | LabelLayout::PARITY,
                layout.value(on_inside),
                all_mask,
            ),
        ));
        tail.push(sweep(
            Scissor::BoundsOf(all.clone()),
            stencil::change_stencil_state(here, layout.value(on_outside), all_mask),
        ));
    }
    // Push: rejected candidates go back to the first label with a far depth and the
    // background, so the next peel can advance them.
    tail.push(Step::Pass("push".into()));
    tail.push(Step::Draw(Draw {
        geometry: Geometry::FullScreen { depth: far },
        scissor: Scissor::BoundsOf(all.clone()),
        cull: Cull::None,
        ds: 0,
        depth: DepthState {
            compare: CompareOp::Always,
            write: true,
        },
        stencil: Some(stencil::change_stencil_state(
            layout.value(Next::False),
            layout.value(start),
            all_mask,
        )),
        fragment: Fragment::Background,
        count_samples: false,
    }));
    tail.push(Step::CopyTexture {
        src: CUR,
        dst: PREV,
    });

    // Each layer of the union of faces is peeled once; the face count bounds them.
    let max_layers = prep.triangles_in(&all).max(1) as u32 + 1;
    steps.push(Step::Loop(Loop {
        head,
        tail,
        max_iterations: max_layers,
    }));
    Ok(Plan {
        algo: "blister".into(),
        depth_stencils: 1,
        textures: 2,
        stencil_bits: layout.stencil_bits(),
        output_ds: 0,
        steps,
    })
}

/// A full-screen stencil-only sweep (depth test off).
fn sweep(scissor: Scissor, stencil: StencilState) -> Step {
    Step::Draw(Draw {
        geometry: Geometry::FullScreen { depth: 0.0 },
        scissor,
        cull: Cull::None,
        ds: 0,
        depth: DepthState {
            compare: CompareOp::Always,
            write: false,
        },
        stencil: Some(stencil),
        fragment: Fragment::None,
        count_samples: false,
    })
}
