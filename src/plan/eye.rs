//! Eye placement: parity counted from the near plane (Hable & Rossignac §4, Hilbrich
//! §3, Goldfeather's clipping) says "inside" only when the ray starts outside the
//! primitive. A perspective eye inside a primitive inverts that parity for every
//! pixel ([`super::Prepared::eye_inside`], handled by flipping literals). An
//! orthographic near plane that cuts a primitive inverts it only for the pixels
//! whose ray starts inside, so no per-primitive flip is right; this module
//! corrects those per pixel.
//!
//! The correction: after each parity draw of a cut primitive P (faces in front of
//! the candidate invert a stencil bit), the same draw again with the depth test off
//! and no fragment test, so *every* rasterized face of P inverts the bit once more.
//! The bit then holds the parity of P's faces *behind* the candidate, which is
//! P's membership at the candidate whatever the ray's start, as long as the far
//! plane cuts nothing (automatic planes never do). Faces counted "in front" by the
//! parity draw's tie rule are exactly those not counted behind, so the tie rules
//! (Hable & Rossignac §5) are kept. Culled parity draws (CST's split tie draws) are
//! corrected with the same culling, which together covers every face once.
//! Trickle counts faces behind its candidate already and needs none of this.
#![deny(unsafe_code)]

use super::step::*;
use crate::scene::{Projection, Scene};

/// Per primitive (then `false` for surfaces): whether an orthographic near plane
/// cuts it (its vertices' view depths lie on both sides of `near`).
pub fn near_cut(scene: &Scene) -> Vec<bool> {
    let n = scene.primitives.len() + scene.surfaces.len();
    let cam = &scene.camera;
    if !matches!(cam.projection, Projection::Orthographic { .. }) {
        return vec![false; n];
    }
    let mut out: Vec<bool> = scene
        .primitives
        .iter()
        .map(|p| {
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for &v in &p.mesh.positions {
                let d = cam.view_depth(v);
                lo = lo.min(d);
                hi = hi.max(d);
            }
            p.used && lo < cam.near && hi > cam.near
        })
        .collect();
    out.resize(n, false);
    out
}

/// Whether `draw` is a parity draw: a mesh whose passing fragments invert stencil
/// bits (Blister's and CST's `toggle_parity`, Goldfeather's clip bits).
fn parity_mesh(draw: &Draw) -> Option<MeshId> {
    match (&draw.geometry, &draw.stencil) {
        (Geometry::Mesh(m), Some(s)) if s.front.pass == StencilOp::Invert => Some(*m),
        _ => None,
    }
}

/// The correcting draw of a parity draw: every face of its mesh, same stencil rule.
fn all_faces(draw: &Draw) -> Draw {
    let stencil = draw.stencil.map(|mut s| {
        // Depth is off: only the stencil test decides, so a fragment that would
        // have failed the depth test of the parity draw inverts the bit too.
        s.front.depth_fail = s.front.pass;
        s.back.depth_fail = s.back.pass;
        s
    });
    Draw {
        depth: DepthState {
            compare: CompareOp::Always,
            write: false,
        },
        stencil,
        fragment: Fragment::None,
        count_samples: false,
        ..draw.clone()
    }
}

/// Inserts the correction after every parity draw of a primitive marked in `cut`.
pub fn correct(steps: Vec<Step>, cut: &[bool]) -> Vec<Step> {
    if !cut.iter().any(|&c| c) {
        return steps;
    }
    let mut out = Vec::with_capacity(steps.len());
    for step in steps {
        match step {
            Step::Draw(d) => {
                let fix = parity_mesh(&d)
                    .filter(|&m| cut.get(m as usize).copied().unwrap_or(false))
                    .map(|_| all_faces(&d));
                out.push(Step::Draw(d));
                out.extend(fix.map(Step::Draw));
            }
            Step::Loop(l) => out.push(Step::Loop(Loop {
                head: correct(l.head, cut),
                tail: correct(l.tail, cut),
                max_iterations: l.max_iterations,
            })),
            other => out.push(other),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::stencil;
    use super::*;

    fn parity(mesh: MeshId) -> Draw {
        Draw {
            geometry: Geometry::Mesh(mesh),
            scissor: Scissor::BoundsOf(vec![mesh]),
            cull: Cull::Back,
            ds: 0,
            depth: DepthState {
                compare: CompareOp::LessOrEqual,
                write: false,
            },
            stencil: Some(stencil::toggle_parity(2, 6, 1)),
            fragment: Fragment::NearerThan { tex: 0, eps: 1e-6 },
            count_samples: false,
        }
    }

    /// A cut primitive's parity bit ends as the parity of its faces behind the
    /// candidate: front count XOR all faces, simulated on the stencil unit.
    #[test]
    fn correction_counts_faces_behind() {
        let steps = vec![Step::Draw(parity(0)), Step::Draw(parity(1))];
        let out = correct(steps.clone(), &[false, true]);
        assert_eq!(out.len(), 3);
        let Step::Draw(fix) = &out[2] else {
            panic!("a draw")
        };
        assert_eq!(fix.geometry, Geometry::Mesh(1));
        assert_eq!(fix.cull, Cull::Back, "same culling as the parity draw");
        assert_eq!(fix.depth.compare, CompareOp::Always);
        assert_eq!(fix.fragment, Fragment::None);
        let s = fix.stencil.unwrap();
        // Faces: 3 in front of the candidate (depth pass), 2 behind (depth fail).
        let mut v = 2u8; // label 2, parity 0
        for pass in [true, true, true, false, false] {
            v = stencil::simulate(&parity(1).stencil.unwrap(), v, pass);
        }
        assert_eq!(v & 1, 1, "front parity: 3 faces");
        for _ in 0..5 {
            v = stencil::simulate(&s, v, true);
        }
        assert_eq!(v & 1, 0, "behind parity: 2 faces");
        assert_eq!(v & 6, 2, "the label is kept");
        // Nothing cut: the plan is unchanged.
        assert_eq!(correct(steps.clone(), &[false, false]), steps);
    }
}
