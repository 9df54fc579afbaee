//! Blister (Hable & Rossignac §2–3, Hilbrich §5 and appendix B):
//! peel the union of all primitives' faces front to back; classify each layer's
//! candidate points against the Blist of the whole expression with a parity bit
//! and the label bits; lock the pixels whose candidate is in the solid; stop when
//! an occlusion query says the peel reached no pixel.
//!
//! Per layer: one peel over all faces, then per Blist entry one parity draw of its
//! primitive and two ChangeStencilState sweeps (parity clear → `if_false`, set →
//! `if_true`; swapped for a complemented leaf), then one push sweep that resets
//! rejected pixels (`F`) to the first label with a far depth and the background.
//!
//! Parity counts the primitive's faces at or in front of the candidate, which
//! classifies the point just *behind* the candidate: the first layer whose
//! point-just-behind is in the solid is where the ray enters it. The paper counts
//! with the depth test (`LessOrEqual`), so a candidate lying on another
//! primitive's face is decided by rounding — Blister's speckles and cracks on
//! coincident faces (Hable & Rossignac Fig. 2). Here a face counts when it lies
//! within [`SHADE_EPS`] behind the candidate too (the peel's exact candidate depth is
//! in a texture), so coincident faces are all passed and the solid stays
//! regularized; features thinner than that tolerance are lost instead.
#![deny(unsafe_code)]

use super::common::{next, peel_loop, sweep};
use super::stencil::{self, LabelLayout, Next};
use super::step::*;
use super::{PlanError, Prepared, SHADE_EPS};
use crate::csg::Blist;

/// Depth texture holding the previous layer (read by the peel).
const PREV: Tex = 0;
/// Depth texture the peel writes the new layer into.
const CUR: Tex = 1;

/// How a parity draw decides whether a face is in front of the candidate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Parity {
    /// Faces within [`SHADE_EPS`] behind the candidate count as in front
    /// (regularized on coincident faces), then depth-equal shading within the same
    /// tolerance gives the lowest index: `--algo blister`.
    Tolerant,
    /// The paper as written: the depth test `LessOrEqual` against the candidate's
    /// quantized depth, colour and id from the peel — coincident faces are decided
    /// by rounding, which shows as speckles (Hable & Rossignac Fig. 2):
    /// `--algo blister-paper`.
    DepthTest,
}

/// Builds the Blister plan of the prepared scene's solid(s).
pub fn plan(prep: &Prepared) -> Result<Plan, PlanError> {
    plan_with(prep, Parity::Tolerant)
}

/// Builds the Blister plan with the given parity test.
pub fn plan_with(prep: &Prepared, parity: Parity) -> Result<Plan, PlanError> {
    let blist = Blist::new(&prep.classified(&prep.positive));
    let layout = LabelLayout::new(blist.num_labels).ok_or(PlanError::TooManyLabels {
        labels: blist.num_labels,
    })?;
    let start = match blist.entries.first() {
        Some(e) => Next::Label(e.label),
        None => return Err(PlanError::NoSolid),
    };
    let all = prep.solid_meshes.clone();
    // One scissor of every solid, cloned per sweep in O(1) (a run of ids).
    let all_rect = Scissor::bounds_of_all(&all);
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
                compare: match parity {
                    Parity::Tolerant => CompareOp::Always,
                    Parity::DepthTest => CompareOp::LessOrEqual,
                },
                write: false,
            },
            stencil: Some(stencil::toggle_parity(
                here,
                label_mask,
                LabelLayout::PARITY,
            )),
            fragment: match parity {
                Parity::Tolerant => Fragment::NearerThan {
                    tex: CUR,
                    eps: SHADE_EPS,
                },
                Parity::DepthTest => Fragment::None,
            },
            count_samples: false,
        }));
        // Parity clear first: with label reuse `if_true` may be this entry's own
        // label, and [label, 0] written by the parity-set sweep would then be
        // taken again by a later parity-clear sweep. The parity-set sweep only
        // matches parity 1, which the parity-clear sweep never writes.
        // With label reuse the parity-clear target may be this entry's own label:
        // that sweep would change no bit (write mask 0), so it is left out.
        if layout.value(on_outside) != here {
            tail.push(sweep(
                0,
                all_rect.clone(),
                stencil::change_stencil_state(here, layout.value(on_outside), all_mask),
            ));
        }
        // Parity can only be set inside the primitive's screen bounds.
        tail.push(sweep(
            0,
            Scissor::BoundsOf(vec![e.prim]),
            stencil::change_stencil_state(
                here | LabelLayout::PARITY,
                layout.value(on_inside),
                all_mask,
            ),
        ));
    }
    // Push: rejected candidates go back to the first label with a far depth and the
    // background, so the next peel can advance them.
    tail.push(Step::Pass("push".into()));
    tail.push(Step::Draw(Draw {
        geometry: Geometry::FullScreen { depth: far },
        scissor: all_rect.clone(),
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
    // Each layer of the union of faces is peeled once.
    steps.push(peel_loop(prep, &all, head, tail, CUR, PREV));
    // Coincident faces: the peel kept whichever was nearest by a rounding error;
    // re-shade the locked pixels so the lowest index within tolerance wins.
    if parity == Parity::Tolerant {
        steps.extend(super::shade_near_depth(
            &all,
            0,
            PREV,
            Some(stencil::test_equal(locked, label_mask)),
            &super::VisibleSides::entries(prep),
        ));
    }
    Ok(Plan {
        algo: match parity {
            Parity::Tolerant => "blister",
            Parity::DepthTest => "blister-paper",
        }
        .into(),
        depth_stencils: 1,
        textures: 2,
        stencil_bits: layout.stencil_bits(),
        output_ds: 0,
        steps,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csg::{Expr, Node};
    use crate::plan::stencil::simulate;
    use crate::scene::Aabb;
    use glam::DVec3;
    use rand::{Rng, SeedableRng};

    /// A random expression over `prims` primitives with `leaves` leaves, all
    /// operators and complements, repeated names allowed.
    fn random_expr(rng: &mut impl Rng, leaves: usize, prims: u32) -> Expr {
        let mut nodes = Vec::new();
        let mut pool: Vec<u32> = (0..leaves)
            .map(|_| {
                nodes.push(Node::Leaf {
                    prim: rng.gen_range(0..prims),
                });
                nodes.len() as u32 - 1
            })
            .collect();
        while pool.len() > 1 {
            let a = pool.remove(rng.gen_range(0..pool.len()));
            let b = pool.remove(rng.gen_range(0..pool.len()));
            let n = match rng.gen_range(0..4) {
                0 => Node::Union(a, b),
                1 => Node::Inter(a, b),
                2 => Node::Diff(a, b),
                _ => {
                    nodes.push(Node::Not(a));
                    Node::Union(nodes.len() as u32 - 1, b)
                }
            };
            nodes.push(n);
            pool.push(nodes.len() as u32 - 1);
        }
        Expr {
            root: pool[0],
            nodes,
        }
    }

    /// Runs one layer's trim steps for one pixel in the software stencil unit:
    /// a parity draw of a mesh passes one fragment when the candidate is inside
    /// it (an odd crossing count), a sweep passes one fragment.
    fn classify(tail: &[Step], start: u8, inside: &[bool]) -> u8 {
        let mut v = start;
        for s in tail {
            if let Step::Draw(d) = s {
                let Some(st) = &d.stencil else { continue };
                match &d.geometry {
                    Geometry::Mesh(m) if inside[*m as usize] => v = simulate(st, v, true),
                    Geometry::FullScreen { .. } if d.fragment == Fragment::None => {
                        v = simulate(st, v, true)
                    }
                    _ => {}
                }
            }
        }
        v
    }

    #[test]
    fn no_sweep_changes_nothing() {
        // A difference chain: label reuse makes every parity-clear target the
        // entry's own label, so only the parity-set sweeps remain.
        let e = crate::csg::parse("A - B - C - D", &mut |n: &str| {
            "ABCD".find(n).map(|i| i as u32)
        })
        .unwrap();
        let unit = Aabb {
            min: DVec3::ZERO,
            max: DVec3::ONE,
        };
        let prep = Prepared::from_parts(e, vec![12; 4], vec![unit; 4]);
        let pl = plan(&prep).unwrap();
        crate::plan::cst::tests::assert_no_idle_passes(&pl.steps, "blister");
        let Some(Step::Loop(l)) = pl.steps.iter().find(|s| matches!(s, Step::Loop(_))) else {
            panic!("no loop")
        };
        let sweeps = l
            .tail
            .iter()
            .filter(
                |s| matches!(s, Step::Draw(d) if matches!(d.geometry, Geometry::FullScreen { .. })),
            )
            .count();
        // 4 parity-set sweeps (or fewer parity-clear ones) and the push: not 2 per entry.
        assert!(sweeps < 2 * 4 + 1, "{sweeps}");
    }

    /// Mesh ids a plan stores in its steps' geometry and scissors: its size.
    fn stored_ids(steps: &[Step]) -> usize {
        steps
            .iter()
            .map(|s| match s {
                Step::Draw(d) => {
                    let geo = match &d.geometry {
                        Geometry::Meshes(ms) => ms.len(),
                        _ => 1,
                    };
                    let sc = match &d.scissor {
                        Scissor::BoundsOf(ms) => ms.len(),
                        Scissor::Overlap { of, and } => of.len() + and.len(),
                        Scissor::Openings { and, .. } => 1 + and.len(),
                        Scissor::Within { meshes, within } => meshes.len() + within.len(),
                        Scissor::Full | Scissor::Run { .. } => 1,
                    };
                    geo + sc
                }
                Step::Loop(l) => stored_ids(&l.head) + stored_ids(&l.tail),
                _ => 1,
            })
            .sum()
    }

    #[test]
    fn the_plan_of_nested_differences_is_linear_in_their_depth() {
        // A0 - (A1 - (A2 - … - An)): one Blist entry and sweep(s) per leaf,
        // each sweep over every solid's bounds.
        for n in [500u32, 4000] {
            let mut nodes: Vec<Node> = (0..=n).map(|prim| Node::Leaf { prim }).collect();
            let mut acc = n;
            for i in (0..n).rev() {
                nodes.push(Node::Diff(i, acc));
                acc = nodes.len() as u32 - 1;
            }
            let e = Expr { nodes, root: acc };
            let unit = Aabb {
                min: DVec3::ZERO,
                max: DVec3::ONE,
            };
            let k = n as usize + 1;
            let prep = Prepared::from_parts(e, vec![12; k], vec![unit; k]);
            let pl = plan(&prep).unwrap();
            let ids = stored_ids(&pl.steps);
            assert!(ids < 12 * k, "n = {n}: {ids} mesh ids stored");
        }
    }

    /// The recorded stencil program equals the tree for random expressions and
    /// points: what the GPU does per pixel, checked without a GPU.
    #[test]
    fn trim_steps_classify_like_the_tree() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for case in 0..400 {
            let prims = rng.gen_range(1..12u32);
            let leaves = rng.gen_range(1..40);
            let expr = random_expr(&mut rng, leaves, prims);
            let unit = Aabb {
                min: DVec3::ZERO,
                max: DVec3::ONE,
            };
            let prep = Prepared::from_parts(
                expr.clone(),
                vec![12; prims as usize],
                vec![unit; prims as usize],
            );
            let parity = if case % 2 == 0 {
                Parity::Tolerant
            } else {
                Parity::DepthTest
            };
            let plan = match plan_with(&prep, parity) {
                Ok(p) => p,
                Err(PlanError::TooManyLabels { .. }) => continue,
                Err(e) => panic!("{e}"),
            };
            let Some(Step::Loop(l)) = plan.steps.iter().find(|s| matches!(s, Step::Loop(_))) else {
                panic!("no loop")
            };
            let start = match plan.steps[1] {
                Step::Clear(Clear::DepthStencil { stencil, .. }) => stencil,
                _ => panic!("first clear"),
            };
            let blist = Blist::new(&prep.positive);
            let layout = LabelLayout::new(blist.num_labels).unwrap();
            for _ in 0..16 {
                let inside: Vec<bool> = (0..prims).map(|_| rng.gen()).collect();
                let want = expr.eval(|_, p| inside[p as usize]);
                let got = classify(&l.tail, start, &inside);
                let expect = layout.value(if want { Next::True } else { Next::False });
                assert_eq!(got, expect, "case {case}: {inside:?}");
            }
        }
    }
}
