//! One layer of a solid on the GPU (Hable & Rossignac §6, depth peeling for
//! transparency): the solid rendered again by CST with every leaf's peel initialized
//! at the previous layer's depth, so only candidates strictly behind it are
//! considered.
//!
//! §6 peels the front-facing and the back-facing boundary separately — layer
//! 2k − 1 is the k-th layer of the entry points, layer 2k the k-th of the exit
//! points — so an entry and an exit sharing a quantized depth (thin plates,
//! cracks, silhouettes) never hide each other. A plan here is one layer of one
//! of these two streams ([`Side`]); the caller runs a stream layer by layer, each
//! plan reading the previous one's depth from [`FLOOR`], and merges the streams.
//!
//! Every point of the boundary must count once, so the zones are the full Z form
//! whatever the variant: trimming against the i-nodes only (optimization 2 of §7)
//! keeps points inside u-nodes, which opaque rendering hides behind the visible
//! layer but a see-through layer would show. The overlap rule of §5 decides
//! coincident faces as in the opaque plan; exit candidates use it mirrored
//! ([`super::tie_draws`]).
#![deny(unsafe_code)]

use super::super::step::*;
use super::super::{PlanError, Prepared, VisibleSides};
use super::{init_final, leaf_csts, record_jobs, Candidates, Job, Merge, Variant, CUR, FINAL};

/// The previous layer of the stream: the depth the peels start behind. Kept on
/// the GPU between the plans of a stream (images persist between frames).
pub const FLOOR: Tex = 2;
/// The exit stream's floor when the two streams are peeled in turn (one solid
/// seen from outside, composited on the GPU as its layers come:
/// `render::gpu_layers::composite`).
pub const EXIT_FLOOR: Tex = 3;
/// Textures of every layer plan: both floors, so the executor's images stay the
/// same (and keep both floors) whichever stream runs.
const TEXTURES: u8 = EXIT_FLOOR + 1;

/// Which boundary points a stream peels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Side {
    /// Where rays enter the solid: front faces of positive leaves, back faces of
    /// negative ones (the odd layers).
    Entry,
    /// Where rays leave it (the even layers).
    Exit,
}

/// A layer's plan and the CSTs it runs (leaves peeled and trimmed).
#[derive(Clone, Debug)]
pub struct LayerPlan {
    /// The layer's plan.
    pub plan: Plan,
    /// How many CSTs (a leaf peeled and trimmed against its active zone) it runs.
    pub csts: usize,
}

/// The plan of the next layer of `side` of the prepared solid (one solid, no
/// surfaces): `first` starts the stream at the near plane. The layer's shaded
/// colour, primitive and depth are the plan's images; its exact depth is left in
/// `floor` ([`FLOOR`], or [`EXIT_FLOOR`] for an exit stream peeled in turn with
/// the entry stream) for the stream's next plan.
pub fn layer_plan(
    prep: &Prepared,
    variant: Variant,
    side: Side,
    first: bool,
    floor: Tex,
) -> Result<LayerPlan, PlanError> {
    assert!(
        floor == FLOOR || floor == EXIT_FLOOR,
        "a stream's floor is FLOOR or EXIT_FLOOR"
    );
    if !prep.has_solid() || prep.positive.literals().is_empty() {
        return Err(PlanError::NoSolid);
    }
    super::super::budget::check_cst(prep, Variant::Z)?;
    let jobs: Vec<Job> = leaf_csts(
        &prep.positive,
        Variant::Z,
        &prep.mesh_bounds,
        &prep.eye_inside,
    )
    .into_iter()
    .map(|mut c| {
        c.peeled.candidates = match side {
            Side::Entry => Candidates::Entry,
            Side::Exit => Candidates::Exit,
        };
        if side == Side::Exit {
            c.peel_cull = match c.peel_cull {
                Cull::Back => Cull::Front,
                Cull::Front => Cull::Back,
                Cull::None => Cull::None,
            };
        }
        Job {
            c,
            merge: Merge::SOLID,
            surface: false,
        }
    })
    .collect();
    let mut steps = init_final();
    if first {
        steps.push(Step::Clear(Clear::Texture {
            tex: floor,
            depth: 0.0,
        }));
    }
    let bits = record_jobs(prep, variant, &jobs, Some(floor), &mut steps)?;
    // The merged candidates' rasterized depths, before the tie shading below
    // replaces them by plane depths: the next peel of this stream must reject
    // exactly the faces it kept here.
    steps.push(Step::CopyDepthToTexture {
        ds: FINAL,
        dst: floor,
    });
    // A layer of one stream: its points are that stream's side of the solid.
    let entries = VisibleSides::entries(prep);
    let sides = match side {
        Side::Entry => entries,
        Side::Exit => entries.exits(),
    };
    steps.extend(super::super::shade_near_depth(
        &prep.solid_meshes,
        FINAL,
        CUR,
        None,
        &sides,
    ));
    Ok(LayerPlan {
        plan: Plan {
            algo: variant.algo().name().into(),
            depth_stencils: 2,
            textures: TEXTURES,
            stencil_bits: bits,
            output_ds: FINAL,
            steps,
        },
        csts: jobs.len(),
    })
}

/// A plan of one counted draw: the pixels the last layer covers, by an
/// occlusion query over the final depth (Hable & Rossignac §4's Done test, here the
/// stream's stop and `--layer-threshold`). Run right after a [`layer_plan`]; it
/// changes no image.
pub fn coverage_plan() -> Plan {
    Plan {
        algo: "layer-coverage".into(),
        depth_stencils: 2,
        textures: TEXTURES,
        stencil_bits: 0,
        output_ds: FINAL,
        steps: vec![
            Step::Pass("coverage".into()),
            crate::plan::common::count_covered(FINAL, Scissor::Full),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::cst::{tie_draws, Peeled, Relation};

    fn prepared(expr: &str, prims: u32) -> Prepared {
        crate::plan::cst::tests::prepared(expr, prims, 12)
    }

    fn peels(plan: &Plan) -> Vec<(Cull, Fragment)> {
        let mut out = Vec::new();
        for s in &plan.steps {
            let Step::Loop(l) = s else { continue };
            for s in &l.head {
                if let Step::Draw(d) = s {
                    out.push((d.cull, d.fragment.clone()));
                }
            }
        }
        out
    }

    #[test]
    fn exit_layers_peel_back_faces_behind_the_floor() {
        let p = prepared("(P0 + P1) - P2", 3);
        for v in [Variant::Z, Variant::I, Variant::G] {
            let entry = layer_plan(&p, v, Side::Entry, true, FLOOR).unwrap();
            let exit = layer_plan(&p, v, Side::Exit, false, FLOOR).unwrap();
            // Every leaf is trimmed against its Z form: three CSTs each.
            assert_eq!((entry.csts, exit.csts), (3, 3));
            let (e, x) = (peels(&entry.plan), peels(&exit.plan));
            assert_eq!(e.len(), 3);
            // Positive leaves keep front faces at entries, back faces at exits;
            // the negative leaf the opposite.
            assert_eq!(
                e.iter().map(|d| d.0).collect::<Vec<_>>(),
                [Cull::Back, Cull::Back, Cull::Front]
            );
            assert_eq!(
                x.iter().map(|d| d.0).collect::<Vec<_>>(),
                [Cull::Front, Cull::Front, Cull::Back]
            );
            assert!(x
                .iter()
                .all(|d| matches!(d.1, Fragment::PeelTolerant { .. })));
            // Only the first plan of a stream clears the floor; every CST starts
            // from it; the floor is saved before the tie shading rewrites depths.
            let clears_floor = |pl: &Plan| {
                pl.steps
                    .iter()
                    .any(|s| matches!(s, Step::Clear(Clear::Texture { tex, .. }) if *tex == FLOOR))
            };
            assert!(clears_floor(&entry.plan) && !clears_floor(&exit.plan));
            let starts = exit
                .plan
                .steps
                .iter()
                .filter(|s| matches!(s, Step::CopyTexture { src, .. } if *src == FLOOR))
                .count();
            assert_eq!(starts, 3);
            let save = exit
                .plan
                .steps
                .iter()
                .position(|s| matches!(s, Step::CopyDepthToTexture { dst, .. } if *dst == FLOOR))
                .unwrap();
            let shade = exit
                .plan
                .steps
                .iter()
                .position(|s| matches!(s, Step::Pass(n) if n == "shade"))
                .unwrap();
            assert!(save < shade);
            assert_eq!(exit.plan.textures, 4);
            // Peeled in turn, the exit stream keeps its own floor.
            let own = layer_plan(&p, v, Side::Exit, true, EXIT_FLOOR).unwrap();
            assert!(own.plan.steps.iter().any(|s| matches!(
                s,
                Step::CopyDepthToTexture { dst, .. } if *dst == EXIT_FLOOR
            )));
            assert!(!own.plan.steps.iter().any(|s| matches!(
                s,
                Step::Clear(Clear::Texture { tex, .. }) | Step::CopyTexture { src: tex, .. }
                    if *tex == FLOOR
            )));
        }
    }

    #[test]
    fn union_ties_are_regularized_for_layers_and_mirrored_at_exits() {
        let at = |candidates| Peeled {
            prim: 1,
            leaf: 1,
            negated: false,
            candidates,
        };
        // The complement of an earlier u-node primitive (the literal !P0).
        let visible = tie_draws(&at(Candidates::Visible), 0, 0, true, Relation::Union);
        assert_eq!(visible, vec![(CompareOp::LessOrEqual, Cull::None)]);
        let entry = tie_draws(&at(Candidates::Entry), 0, 0, true, Relation::Union);
        assert_eq!(
            entry,
            vec![
                (CompareOp::Less, Cull::Front),
                (CompareOp::LessOrEqual, Cull::Back)
            ]
        );
        // Exits: the same rule along the reversed ray (compare and culling swapped).
        let exit = tie_draws(&at(Candidates::Exit), 2, 2, false, Relation::Inter);
        assert_eq!(exit, vec![(CompareOp::Less, Cull::None)]);
        let exit = tie_draws(&at(Candidates::Exit), 0, 0, true, Relation::Union);
        assert_eq!(
            exit,
            vec![
                (CompareOp::LessOrEqual, Cull::Back),
                (CompareOp::Less, Cull::Front)
            ]
        );
    }

    #[test]
    fn coverage_counts_one_full_screen_draw() {
        let p = coverage_plan();
        let counted: Vec<&Draw> = p
            .steps
            .iter()
            .filter_map(|s| match s {
                Step::Draw(d) if d.count_samples => Some(d),
                _ => None,
            })
            .collect();
        assert_eq!(counted.len(), 1);
        assert_eq!(counted[0].ds, FINAL);
        assert!(!counted[0].depth.write);
    }
}
