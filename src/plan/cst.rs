//! Constructive Solid Trimming (Hable & Rossignac, §4–5, §7): CSG rendered
//! as the union of CST(P, Z(P)) over the leaves P, where Z(P) is P's active zone.
//!
//! [`cst`] is CST(S, V) for one surface: peel S layer by layer at unlocked pixels,
//! trim each layer against the Blist of V with parity draws and ChangeStencilState
//! sweeps, lock the pixels whose candidate is in V (label `T`), push the others back
//! (label reset, far depth) and stop when an occlusion query says the peel reached no
//! pixel. Render(S) then merges the kept points into the final image by the depth
//! test, shading only where a fragment's depth equals the kept depth bit-exactly
//! ([`Fragment::ShadeAtDepth`]; a solid's leaves merge their depth alone,
//! [`Fragment::DepthAtDepth`], since the final depth-equal shading colours every
//! pixel they win).
//!
//! Variants (Hable & Rossignac §7, §8):
//! - `cst-z`: trim against the Z form (i-nodes and complemented u-nodes);
//! - `cst-i`: trim against the i-nodes only (optimization 2);
//! - `cst-g`: as `cst-i`, with same-operator leaves grouped and classified by a
//!   stencil counter (optimization 3; see `group`).
//!
//! Every variant peels only the front faces of positive and the back faces of
//! negative leaves (optimization 1: opaque rendering shows only where rays enter
//! the solid), so the variants differ in their zones alone; `[[surface]]`s, which
//! may be open, peel both faces.
//!
//! Resources: depth-stencil 0 is the peel's CurrDepthStencil (depth *Back*, stencil
//! `[label | parity]`), depth-stencil 1 is *FinalColorDepth*; texture 0 is
//! *PrevDepth* (*Front*), texture 1 the layer the peel records (exact `f32` depths).
//!
//! **Overlaps** (Hable & Rossignac §5). Coincident faces are decided by a symbolic
//! perturbation chosen per parity draw through its depth compare: a face of Q at the
//! candidate's depth counts as "in front" (`LessOrEqual`) or not (`Less`). Parity
//! draws count the faces at or in front of the candidate, so this classifies the
//! candidate as if Q's face were moved slightly towards or away from the eye. For a
//! candidate X on a front face of the leaf P (the visible layer) and a literal Q of its
//! zone, writing "earlier" for the lower (primitive, leaf) index:
//! - Q in a u-node (their lowest common ancestor is a union): if Q is earlier, its
//!   face counts in front (X is in Q: P loses to Q), else not (X is out of Q: P wins).
//!   With equally oriented faces exactly one of them keeps the point, the earlier.
//! - Q in an i-node (common ancestor an intersection): if Q is later, `LessOrEqual`
//!   (X is in Q when their faces agree in orientation: P keeps it; out of Q when
//!   they are opposed: a zero-thickness sheet, dropped). If Q is earlier, its literal
//!   front faces are drawn with `Less` (X out of Q: P loses to Q) and its literal back
//!   faces with `LessOrEqual` (X out of Q: the sheet is dropped) — two culled draws.
//!
//! So where two primitives' faces coincide on the visible boundary the lower index
//! is kept and the other trimmed away (the lowest index wins), a zero-thickness
//! contact of an intersection or a flush cut of a difference shows nothing, and the
//! merge compares with `Less` in leaf order so an exact depth tie keeps the earlier
//! primitive too.
#![deny(unsafe_code)]

pub(crate) mod group;
pub mod layers;
mod peel;
mod ties;
mod trim;
mod zones;

pub use peel::{cst, Layers, Merge, PAINT_PENDING, SURFACE_MARK};
pub(crate) use ties::parity_draw;
pub use ties::{tie_draws, tie_eps, Candidates, Peeled, Relation};
pub(crate) use trim::BlistTrimmer;
pub use trim::{Codes, Trimmer};
pub(crate) use zones::disjoint;
pub use zones::{leaf_csts, LeafCst, TrimVolume};

use super::stencil;
use super::step::*;
use super::{Algo, PlanError, Prepared};
use crate::csg::{Blist, PositiveExpr};
use crate::scene::Keep;

/// CurrDepthStencil: candidate depth and `[label | parity]`.
pub const WORK: Ds = 0;
/// FinalColorDepth: the merged result.
pub const FINAL: Ds = 1;
/// PrevDepth (*Front*): the previous layer, read by the peel.
pub const PREV: Tex = 0;
/// The layer the peel records; after the loop, the kept depth (or far).
pub const CUR: Tex = 1;
const FAR: f32 = 1.0;

/// Which variant of Hable & Rossignac §8.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Variant {
    /// `cst-z`: trim against the Z form (i-nodes and complemented u-nodes).
    Z,
    /// `cst-i`: trim against the i-nodes only (optimization 2).
    I,
    /// `cst-i` with same-operator leaves grouped and classified by a stencil
    /// counter (optimization 3).
    G,
}

impl Variant {
    pub(crate) fn algo(self) -> Algo {
        match self {
            Variant::Z => Algo::CstZ,
            Variant::I => Algo::CstI,
            Variant::G => Algo::CstG,
        }
    }
}

/// One CST of the plan: a leaf of the solid with its zone, or a surface with its
/// trimming volume.
struct Job {
    c: LeafCst,
    merge: Merge,
    surface: bool,
}

/// The CSTs that draw the scene's surfaces (Hable & Rossignac §4, §6): CST(S, V) for
/// `keep = "in"`, CST(S, !V) for `"out"`, both for `"paint"` (V in the paint
/// colour). An open S has no inside: both faces are peeled, and the loop stops on
/// the occlusion query (no convexity is assumed).
fn surface_jobs(prep: &Prepared) -> Vec<Job> {
    let mut jobs = Vec::new();
    for s in &prep.surfaces {
        let peeled = Peeled {
            prim: s.mesh,
            leaf: 0,
            negated: false,
            candidates: Candidates::Visible,
        };
        let job = |zone: &PositiveExpr, paint: Option<[u8; 3]>| {
            let universe = zone.is_universe();
            let volume = (!universe).then(|| {
                let blist = Blist::new(zone);
                let relation = vec![Relation::Surface; blist.entries.len()];
                TrimVolume { blist, relation }
            });
            Job {
                c: LeafCst {
                    peeled,
                    peel_cull: Cull::None,
                    volume,
                    zone: (!universe).then(|| zone.clone()),
                },
                merge: Merge { mark: true, paint },
                surface: true,
            }
        };
        match s.keep {
            Keep::In => jobs.push(job(&s.trim, None)),
            Keep::Out => jobs.push(job(&s.trim_out, None)),
            Keep::Paint => {
                jobs.push(job(&s.trim, Some(s.paint_color)));
                jobs.push(job(&s.trim_out, None));
            }
        }
    }
    jobs
}

/// A plan's first steps: *FinalColorDepth* and the colour targets cleared.
fn init_final() -> Vec<Step> {
    super::common::init_output(FINAL, FAR)
}

/// Records every job's CST into `steps` (peeling behind `floor` when given, see
/// [`cst`]); returns the stencil bits the trims need. CST-G groups a zone only
/// when none of its literals lies in a u-node: its counter applies one tie rule
/// to a whole group, the intersection's (a u-node literal needs the union's, so
/// such zones — Z forms, which layers use — get the plain Blist trim).
fn record_jobs(
    prep: &Prepared,
    variant: Variant,
    jobs: &[Job],
    floor: Option<Tex>,
    steps: &mut Vec<Step>,
) -> Result<u8, PlanError> {
    let mut bits = 0u8;
    let mut grouped = Vec::new();
    for Job { c, merge, surface } in jobs {
        let p = c.peeled.prim;
        let max_layers = if *surface {
            Layers::AtMost(prep.mesh_triangles[p as usize] as u32 + 1)
        } else {
            Layers::of(prep, p, c.peel_cull)
        };
        match &c.volume {
            None => cst(p, c.peel_cull, None, max_layers, *merge, floor, steps),
            Some(vol) => {
                let groups = variant == Variant::G && !vol.relation.contains(&Relation::Union);
                // A zone where the counter pays for no group is CST-I's trim, in
                // CST-I's entry order: the plans then agree step for step, so the
                // bench compares like with like (the grouped Blist lists the same
                // literals in another order, and its labels may differ).
                let g = match groups {
                    true => Some(group::GroupTrimmer::new(prep, c)?)
                        .filter(|g| g.blist().num_groups() > 0),
                    false => None,
                };
                let trimmer: Box<dyn Trimmer + '_> = match g {
                    None => Box::new(BlistTrimmer::new(c.peeled, vol)?),
                    Some(mut g) => {
                        if *surface {
                            g = g.with_relation(Relation::Surface);
                        }
                        grouped.push(g);
                        Box::new(grouped.last().unwrap().clone())
                    }
                };
                bits = bits.max(trimmer.codes().bits);
                cst(
                    p,
                    c.peel_cull,
                    Some(trimmer.as_ref()),
                    max_layers,
                    *merge,
                    floor,
                    steps,
                );
            }
        }
    }
    Ok(bits)
}

/// Builds the CST plan of the prepared scene's solid(s) and surfaces.
pub fn plan(prep: &Prepared, variant: Variant) -> Result<Plan, PlanError> {
    let solid = prep.has_solid() && !prep.positive.literals().is_empty();
    if !solid && prep.surfaces.is_empty() {
        return Err(PlanError::NoSolid);
    }
    super::budget::check_cst(prep, variant)?;
    let mut jobs: Vec<Job> = if solid {
        leaf_csts(&prep.positive, variant, &prep.mesh_bounds, &prep.eye_inside)
            .into_iter()
            .map(|c| Job {
                c,
                merge: Merge::SOLID,
                surface: false,
            })
            .collect()
    } else {
        Vec::new()
    };
    // Surfaces merge after the solids with `Less`: a solid point wins an exact tie
    // (the reference keeps the solid unless a surface is nearer by more than its
    // tolerance), and between surfaces the earlier one wins.
    jobs.extend(surface_jobs(prep));
    let mut steps = init_final();
    let bits = record_jobs(prep, variant, &jobs, None, &mut steps)?;
    // Coincident faces of different tessellations rasterize a few ulps apart, which
    // the exact compares of the trim cannot see: give every visible point the lowest
    // index among the primitives whose faces pass through it (the tie rule), drawing
    // them in descending order over a copy of the final depth. Pixels a surface won
    // are left alone: they keep the surface's colour (or paint colour) and id.
    if solid {
        let stencil = (!prep.surfaces.is_empty()).then(|| stencil::test_equal(0, SURFACE_MARK));
        steps.extend(super::shade_near_depth(
            &prep.solid_meshes,
            FINAL,
            CUR,
            stencil,
            &super::VisibleSides::entries(prep),
        ));
    }
    Ok(Plan {
        algo: variant.algo().name().into(),
        depth_stencils: 2,
        textures: 2,
        stencil_bits: bits,
        output_ds: FINAL,
        steps,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::csg::parse;
    use crate::plan::print::count;
    use crate::plan::SHADE_EPS;
    use crate::scene::Aabb;

    /// `expr` over primitives `P0`, `P1`, … of `tris` triangles each in a
    /// unit box (also the other plan modules' tests).
    pub(crate) fn prepared(expr: &str, prims: u32, tris: usize) -> Prepared {
        let names: Vec<String> = (0..prims).map(|i| format!("P{i}")).collect();
        let e = parse(expr, &mut |n: &str| {
            names.iter().position(|x| x == n).map(|i| i as u32)
        })
        .unwrap();
        let b = Aabb {
            min: glam::DVec3::splat(-1.0),
            max: glam::DVec3::splat(1.0),
        };
        Prepared::from_parts(e, vec![tris; prims as usize], vec![b; prims as usize])
    }

    /// A gear: a disc plus 12 teeth, minus an axle hole.
    fn gear() -> Prepared {
        let teeth: Vec<String> = (1..=12).map(|i| format!("P{i}")).collect();
        prepared(&format!("(P0 + {}) - P13", teeth.join(" + ")), 14, 12)
    }

    #[test]
    fn cst_i_draws_fewer_triangles_and_sweeps_than_cst_z() {
        let p = gear();
        let z = count(&plan(&p, Variant::Z).unwrap().steps, &p);
        let i = count(&plan(&p, Variant::I).unwrap().steps, &p);
        let g = count(&plan(&p, Variant::G).unwrap().steps, &p);
        assert!(i.triangles < z.triangles, "{i:?} vs {z:?}");
        assert!(i.fullscreen_passes < z.fullscreen_passes);
        assert!(g.fullscreen_passes <= i.fullscreen_passes);
    }

    /// Where the counter pays for no group (every zone of the shipped gear and
    /// complex), CST-G is CST-I step for step: the bench's ordering check then
    /// compares one plan with itself.
    #[test]
    fn cst_g_is_cst_i_where_the_counter_does_not_pay() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        for f in ["gear.toml", "complex.toml"] {
            let scene =
                crate::scene::load(&dir.join(f), &crate::scene::LoadOptions::default()).unwrap();
            let p = Prepared::new(&scene).unwrap();
            let (i, g) = (plan(&p, Variant::I).unwrap(), plan(&p, Variant::G).unwrap());
            assert_eq!(g.steps, i.steps, "{f}");
            assert_eq!(g.stencil_bits, i.stencil_bits, "{f}");
        }
    }

    #[test]
    fn cst_g_groups_a_big_intersection_into_few_sweeps() {
        // The first leaf's i-zone is one intersection-group of 9 literals.
        let p = prepared("P0 P1 P2 !P3 P4 P5 !P6 P7 P8 P9", 10, 12);
        let i = count(&plan(&p, Variant::I).unwrap().steps, &p);
        let g = count(&plan(&p, Variant::G).unwrap().steps, &p);
        assert!(g.fullscreen_passes < i.fullscreen_passes, "{g:?} vs {i:?}");
        assert_eq!(g.triangles, i.triangles);
    }

    /// A solid's leaves merge depth alone; the final shading, the only step
    /// after the merges, colours every solid pixel (`Merge::at_depth`).
    #[test]
    fn solid_merges_write_depth_and_the_shade_pass_colours() {
        let p = gear();
        for variant in [Variant::Z, Variant::I, Variant::G] {
            let steps = plan(&p, variant).unwrap().steps;
            let draws: Vec<&Draw> = steps
                .iter()
                .filter_map(|s| match s {
                    Step::Draw(d) => Some(d),
                    _ => None,
                })
                .collect();
            let merges = draws
                .iter()
                .filter(|d| matches!(d.fragment, Fragment::DepthAtDepth { tex: CUR }))
                .count();
            assert_eq!(merges, 14, "{variant:?}: one merge per leaf");
            assert!(draws
                .iter()
                .all(|d| !matches!(d.fragment, Fragment::ShadeAtDepth { .. })));
            let shade = steps
                .iter()
                .position(|s| matches!(s, Step::Pass(n) if n == "shade"))
                .expect("a shade pass");
            let last_merge = steps
                .iter()
                .rposition(|s| {
                    matches!(s, Step::Draw(d) if matches!(d.fragment, Fragment::DepthAtDepth { .. }))
                })
                .unwrap();
            assert!(last_merge < shade);
        }
        // Surfaces keep their shaded merge: the final shading skips their pixels.
        let surface = Merge {
            mark: true,
            paint: None,
        };
        assert_eq!(surface.at_depth(), Fragment::ShadeAtDepth { tex: CUR });
        assert_eq!(Merge::SOLID.at_depth(), Fragment::DepthAtDepth { tex: CUR });
    }

    #[test]
    fn layouts_are_small_and_checked() {
        let p = gear();
        assert_eq!(plan(&p, Variant::I).unwrap().stencil_bits, 3);
        let pl = plan(&p, Variant::G).unwrap();
        assert!(pl.stencil_bits <= 8 && pl.depth_stencils == 2 && pl.output_ds == FINAL);
        // 300 literals in one group: chunks chained with label reuse fit in 8 bits.
        let names: Vec<String> = (1..301).map(|i| format!("P{i}")).collect();
        let big = prepared(&format!("P0 {}", names.join(" ")), 301, 12);
        assert!(plan(&big, Variant::G).unwrap().stencil_bits <= 8);
    }

    #[test]
    fn cst_g_chunks_a_36_tooth_union_into_8_bits() {
        // Body + 36 teeth, recessed: the recess's i-zone holds the 37-literal union.
        let teeth: Vec<String> = (1..=36).map(|i| format!("P{i}")).collect();
        // As in scenes/gear.toml, enough other entries that 3 label bits + a 6-bit
        // counter would not fit.
        let p = prepared(
            &format!("(P0 + {}) - P37 - P38 - P39 - P40 - P41", teeth.join(" + ")),
            42,
            12,
        );
        let pl = plan(&p, Variant::G).unwrap();
        assert!(pl.stencil_bits <= 8, "{}", pl.stencil_bits);
        let c = leaf_csts(&p.positive, Variant::G, &[], &[]);
        let recess = c.iter().find(|c| c.peeled.prim == 37).unwrap();
        let t = group::GroupTrimmer::new(&p, recess).unwrap();
        assert!(
            t.layout().bits() <= 8 && t.blist().num_groups() >= 2,
            "{t:?}"
        );
    }

    fn has_loop(steps: &[Step]) -> bool {
        steps.iter().any(|s| matches!(s, Step::Loop(_)))
    }

    #[test]
    fn convex_leaves_are_unrolled() {
        let mut p = gear();
        for v in [Variant::Z, Variant::I, Variant::G] {
            assert!(has_loop(&plan(&p, v).unwrap().steps));
        }
        p.mesh_convex = vec![true; 14];
        for (v, layers) in [(Variant::Z, 1), (Variant::I, 1), (Variant::G, 1)] {
            let pl = plan(&p, v).unwrap();
            assert!(!has_loop(&pl.steps));
            let peels = pl
                .steps
                .iter()
                .filter(|s| {
                    matches!(
                        s,
                        Step::Draw(Draw {
                            fragment: Fragment::Peel { .. },
                            ..
                        })
                    )
                })
                .count();
            // Leaf 0's zone is not the universe for any leaf here: one peel per layer.
            assert_eq!(peels, 14 * layers, "{v:?}");
        }
    }

    /// Full-screen knock-outs of the recorded layer (WriteDepth into CUR).
    fn knock_outs(steps: &[Step]) -> Vec<&Draw> {
        steps
            .iter()
            .filter_map(|s| match s {
                Step::Draw(d) if matches!(d.fragment, Fragment::WriteDepth { out: CUR }) => Some(d),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn one_layer_leaves_knock_out_rejected_pixels_by_label() {
        let mut p = gear();
        p.mesh_convex = vec![true; 14];
        for v in [Variant::Z, Variant::I, Variant::G] {
            let pl = plan(&p, v).unwrap();
            // One peel, no Push(): the knock-out tests the rejected label.
            assert!(!pl
                .steps
                .iter()
                .any(|s| matches!(s, Step::Pass(n) if n == "push")));
            let k = knock_outs(&pl.steps);
            assert_eq!(k.len(), 14, "{v:?}");
            for d in k {
                assert_eq!(d.depth.compare, CompareOp::Always);
                let st = d.stencil.expect("a stencil test");
                assert_eq!(st.front.compare, CompareOp::Equal);
                assert_eq!(st.write_mask, 0);
            }
        }
        // Leaves of unknown depth keep the loop with Push() and knock out the
        // pixels Push() left far.
        let p = gear();
        let pl = plan(&p, Variant::I).unwrap();
        assert!(has_loop(&pl.steps));
        for d in knock_outs(&pl.steps) {
            assert_eq!(d.depth.compare, CompareOp::Equal);
            assert!(d.stencil.is_none());
        }
    }

    #[test]
    fn parity_draws_are_eps_tolerant() {
        let p = gear();
        for v in [Variant::Z, Variant::I, Variant::G] {
            let pl = plan(&p, v).unwrap();
            let mut stack = vec![&pl.steps];
            let mut n = 0;
            while let Some(steps) = stack.pop() {
                for s in steps {
                    match s {
                        Step::Loop(l) => {
                            stack.push(&l.head);
                            stack.push(&l.tail);
                        }
                        Step::Draw(d)
                            if d.ds == WORK && matches!(d.geometry, Geometry::Mesh(_)) =>
                        {
                            if let Fragment::NearerThan { tex, eps } = d.fragment {
                                assert_eq!(tex, CUR);
                                assert_eq!(eps.abs(), SHADE_EPS);
                                assert_eq!(d.depth.compare, CompareOp::Always);
                                n += 1;
                            }
                        }
                        _ => {}
                    }
                }
            }
            assert!(n > 0, "{v:?}");
        }
    }

    /// Every draw of a plan, loops included.
    fn all_draws(steps: &[Step]) -> Vec<&Draw> {
        let mut out = Vec::new();
        for s in steps {
            match s {
                Step::Draw(d) => out.push(d),
                Step::Loop(l) => {
                    out.extend(all_draws(&l.head));
                    out.extend(all_draws(&l.tail));
                }
                _ => {}
            }
        }
        out
    }

    /// A full-screen pass that writes no stencil bit, no depth, no colour and
    /// counts nothing: a pass whose result nobody reads.
    pub(crate) fn assert_no_idle_passes(steps: &[Step], what: &str) {
        for d in all_draws(steps) {
            if matches!(d.geometry, Geometry::FullScreen { .. })
                && d.fragment == Fragment::None
                && !d.depth.write
                && !d.count_samples
            {
                let writes = d.stencil.is_some_and(|s| s.write_mask != 0);
                assert!(writes, "{what}: an idle full-screen pass {d:?}");
            }
        }
    }

    #[test]
    fn trims_are_scissored_to_the_peeled_leaf() {
        let p = gear();
        for v in [Variant::Z, Variant::I, Variant::G] {
            let pl = plan(&p, v).unwrap();
            assert_no_idle_passes(&pl.steps, &format!("{v:?}"));
            // The peeled mesh of the CST a step belongs to: the last peel before it.
            let mut peeled = None;
            let mut parity = 0;
            let mut flat = Vec::new();
            fn flatten<'a>(steps: &'a [Step], out: &mut Vec<&'a Step>) {
                for s in steps {
                    match s {
                        Step::Loop(l) => {
                            flatten(&l.head, out);
                            flatten(&l.tail, out);
                        }
                        s => out.push(s),
                    }
                }
            }
            flatten(&pl.steps, &mut flat);
            for s in flat {
                let Step::Draw(d) = s else { continue };
                match (&d.fragment, &d.geometry) {
                    (Fragment::Peel { .. }, Geometry::Mesh(m)) => peeled = Some(*m),
                    (Fragment::NearerThan { .. }, Geometry::Mesh(m)) => {
                        let me = peeled.expect("a parity draw after a peel");
                        assert_eq!(
                            d.scissor,
                            Scissor::Overlap {
                                of: vec![*m],
                                and: vec![me]
                            },
                            "{v:?}"
                        );
                        parity += 1;
                    }
                    // Every sweep of a trim stays inside the peeled leaf's bounds.
                    (Fragment::None, Geometry::FullScreen { .. }) if d.ds == WORK => {
                        let me = peeled.expect("a sweep after a peel");
                        match &d.scissor {
                            Scissor::BoundsOf(ms) => assert_eq!(ms, &vec![me], "{v:?}"),
                            Scissor::Overlap { of, and } => {
                                assert!(of.contains(&me) || and.contains(&me), "{v:?}")
                            }
                            Scissor::Full
                            | Scissor::Within { .. }
                            | Scissor::Run { .. }
                            | Scissor::Openings { .. } => {
                                panic!("{v:?}: not cut to the peeled leaf")
                            }
                        }
                    }
                    _ => {}
                }
            }
            assert!(parity > 0, "{v:?}");
        }
    }

    /// Runs a trim's steps for one pixel in the software stencil unit. The pixel
    /// has a candidate of the peeled leaf `me` (inside its screen rectangle);
    /// `in_rect[m]`: inside mesh m's rectangle; `inside[m]`: the candidate is
    /// inside primitive m (so also in its rectangle). A parity or counter draw
    /// of a mesh containing the point passes one more front face than back
    /// faces: its front-face op, once.
    fn run_trim(steps: &[Step], start: u8, inside: &[bool], in_rect: &[bool]) -> u8 {
        let rect = |s: &Scissor| match s {
            Scissor::Full => true,
            Scissor::BoundsOf(ms) => ms.iter().any(|m| in_rect[*m as usize]),
            Scissor::Run { first, end } => (*first..*end).any(|m| in_rect[m as usize]),
            Scissor::Overlap { of, and } => {
                of.iter().any(|m| in_rect[*m as usize]) && and.iter().all(|m| in_rect[*m as usize])
            }
            Scissor::Openings { of, and } => {
                in_rect[*of as usize] && and.iter().all(|m| in_rect[*m as usize])
            }
            Scissor::Within { meshes, within } => {
                meshes.iter().any(|m| in_rect[*m as usize])
                    && within.iter().any(|m| in_rect[*m as usize])
            }
        };
        let mut v = start;
        for d in all_draws(steps) {
            let Some(st) = &d.stencil else { continue };
            if !rect(&d.scissor) {
                continue;
            }
            match d.geometry {
                Geometry::Mesh(m) if inside[m as usize] && d.cull != Cull::Front => {
                    v = stencil::simulate(st, v, true)
                }
                Geometry::FullScreen { .. } => v = stencil::simulate(st, v, true),
                _ => {}
            }
        }
        v
    }

    /// Every variant's trim, scissors included, classifies like its zone: random
    /// products and sums with holes, random boxes (so CST-G keeps some groups and
    /// splits others), random points and screen rectangles.
    #[test]
    fn trims_classify_like_the_zone_within_their_scissors() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let ops = ["+", "-", " "];
        let mut kept = [0usize; 2];
        for case in 0..300 {
            let prims = rng.gen_range(2..10u32);
            let mut src = String::from("P0");
            for _ in 0..rng.gen_range(1..12) {
                src.push_str(ops[rng.gen_range(0..3)]);
                src.push_str(&format!("P{}", rng.gen_range(0..prims)));
            }
            let mut p = prepared(&src, prims, 12);
            for b in &mut p.mesh_bounds {
                let c = glam::DVec3::new(rng.gen(), rng.gen(), rng.gen());
                let h = glam::DVec3::new(rng.gen(), rng.gen(), rng.gen()) * 0.6 + 0.05;
                *b = Aabb {
                    min: c - h,
                    max: c + h,
                };
            }
            for v in [Variant::Z, Variant::I, Variant::G] {
                for c in leaf_csts(&p.positive, v, &[], &[]) {
                    let (Some(vol), Some(zone)) = (&c.volume, &c.zone) else {
                        continue;
                    };
                    let trimmer: Box<dyn Trimmer> =
                        if v == Variant::G && !vol.relation.contains(&Relation::Union) {
                            let g = group::GroupTrimmer::new(&p, &c).unwrap();
                            kept[(g.blist().num_groups() > 0) as usize] += 1;
                            Box::new(g)
                        } else {
                            Box::new(BlistTrimmer::new(c.peeled, vol).unwrap())
                        };
                    let mut steps = Vec::new();
                    trimmer.trim(&mut steps);
                    let me = c.peeled.prim as usize;
                    for _ in 0..24 {
                        let inside: Vec<bool> = (0..prims)
                            .map(|m| m as usize != me && rng.gen_bool(0.5))
                            .collect();
                        let in_rect: Vec<bool> = (0..prims as usize)
                            .map(|m| m == me || inside[m] || rng.gen_bool(0.5))
                            .collect();
                        let want = zone.eval(|l| inside[l.prim as usize]);
                        let codes = trimmer.codes();
                        let got = run_trim(&steps, codes.start, &inside, &in_rect);
                        let expect = if want { codes.locked } else { codes.rejected };
                        assert_eq!(
                            got, expect,
                            "case {case} {v:?} {src} leaf {me}: {inside:?} {in_rect:?}"
                        );
                    }
                }
            }
        }
        assert!(kept[0] > 0 && kept[1] > 0, "groups kept / split: {kept:?}");
    }

    #[test]
    fn tie_rules_follow_the_order() {
        let p = Peeled {
            prim: 2,
            leaf: 2,
            negated: false,
            candidates: Candidates::Visible,
        };
        assert_eq!(
            tie_draws(&p, 1, 1, false, Relation::Union),
            vec![(CompareOp::LessOrEqual, Cull::None)]
        );
        assert_eq!(
            tie_draws(&p, 3, 3, false, Relation::Union),
            vec![(CompareOp::Less, Cull::None)]
        );
        assert_eq!(
            tie_draws(&p, 3, 3, true, Relation::Inter),
            vec![(CompareOp::LessOrEqual, Cull::None)]
        );
        assert_eq!(tie_draws(&p, 1, 1, false, Relation::Inter).len(), 2);
    }
}
