//! One layer of a solid on the GPU (seed 000 §6, depth peeling for transparency):
//! the solid rendered again by CST with every leaf's peel initialized at the
//! previous layer's depth, so only candidates strictly behind it are considered.
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
use super::super::{PlanError, Prepared};
use super::{leaf_csts, record_jobs, Candidates, Job, Merge, Variant, CUR, FAR, FINAL};

/// The previous layer of the stream: the depth the peels start behind. Kept on
/// the GPU between the plans of a stream (images persist between frames).
pub const FLOOR: Tex = 2;

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
    pub plan: Plan,
    pub csts: usize,
}

/// The plan of the next layer of `side` of the prepared solid (one solid, no
/// surfaces): `first` starts the stream at the near plane. The layer's shaded
/// colour, primitive and depth are the plan's images; its exact depth is left in
/// [`FLOOR`] for the stream's next plan.
pub fn layer_plan(
    prep: &Prepared,
    variant: Variant,
    side: Side,
    first: bool,
) -> Result<LayerPlan, PlanError> {
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
    let mut steps = vec![
        Step::Pass("init".into()),
        Step::Clear(Clear::DepthStencil {
            ds: FINAL,
            depth: FAR,
            stencil: 0,
        }),
        Step::Clear(Clear::Color),
    ];
    if first {
        steps.push(Step::Clear(Clear::Texture {
            tex: FLOOR,
            depth: 0.0,
        }));
    }
    let bits = record_jobs(prep, variant, &jobs, Some(FLOOR), &mut steps)?;
    // The merged candidates' rasterized depths, before the tie shading below
    // replaces them by plane depths: the next peel of this stream must reject
    // exactly the faces it kept here.
    steps.push(Step::CopyDepthToTexture {
        ds: FINAL,
        dst: FLOOR,
    });
    steps.extend(super::super::shade_near_depth(
        &prep.solid_meshes,
        FINAL,
        CUR,
        None,
    ));
    Ok(LayerPlan {
        plan: Plan {
            algo: variant.algo().name().into(),
            depth_stencils: 2,
            textures: 3,
            stencil_bits: bits,
            output_ds: FINAL,
            steps,
        },
        csts: jobs.len(),
    })
}

/// A plan of one counted draw: the pixels the last layer covers, by an
/// occlusion query over the final depth (seed 000 §4's Done test, here the
/// stream's stop and `--layer-threshold`). Run right after a [`layer_plan`]; it
/// changes no image.
pub fn coverage_plan() -> Plan {
    Plan {
        algo: "layer-coverage".into(),
        depth_stencils: 2,
        textures: 3,
        stencil_bits: 0,
        output_ds: FINAL,
        steps: vec![
            Step::Pass("coverage".into()),
            Step::Draw(Draw {
                geometry: Geometry::FullScreen { depth: FAR },
                scissor: Scissor::Full,
                cull: Cull::None,
                ds: FINAL,
                // Passes where something nearer than the far plane was merged.
                depth: DepthState {
                    compare: CompareOp::Greater,
                    write: false,
                },
                stencil: None,
                fragment: Fragment::None,
                count_samples: true,
            }),
        ],
    }
}
