//! Plan validation: every index a plan uses names a resource it declares or a
//! mesh of the scene, and loops do not nest. Pure, so it is tested without a GPU;
//! the executor runs it on every plan it is given.

use super::step::{Clear, Fragment, Geometry, Plan, Scissor, Step, Tex};

/// Why a plan cannot be executed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum InvalidPlan {
    #[error("texture {index} used, but the plan declares {declared}")]
    Texture { index: Tex, declared: u8 },
    #[error("depth-stencil {index} used, but the plan declares {declared}")]
    DepthStencil { index: u8, declared: u8 },
    #[error("mesh {index} used, but the scene has {meshes}")]
    Mesh { index: u32, meshes: u32 },
    #[error("nested loops are not supported")]
    NestedLoop,
    #[error("a fragment reads and writes texture {0}")]
    SameTexture(Tex),
    #[error("depth-stencil {0} is the output: it is drawn into and cleared, never copied into")]
    CopyIntoOutput(u8),
}

/// Checks `plan` against a scene of `meshes` meshes.
pub fn validate(plan: &Plan, meshes: u32) -> Result<(), InvalidPlan> {
    let n_ds = plan.depth_stencils.max(1);
    let tex = |t: Tex| {
        if t >= plan.textures {
            Err(InvalidPlan::Texture {
                index: t,
                declared: plan.textures,
            })
        } else {
            Ok(())
        }
    };
    let ds = |d: u8| {
        if d >= n_ds {
            Err(InvalidPlan::DepthStencil {
                index: d,
                declared: n_ds,
            })
        } else {
            Ok(())
        }
    };
    let mesh = |m: u32| {
        if m >= meshes {
            Err(InvalidPlan::Mesh { index: m, meshes })
        } else {
            Ok(())
        }
    };
    let distinct = |a: Tex, b: Tex| {
        tex(a)?;
        tex(b)?;
        if a == b {
            Err(InvalidPlan::SameTexture(a))
        } else {
            Ok(())
        }
    };
    ds(plan.output_ds)?;
    let check = |s: &Step| -> Result<(), InvalidPlan> {
        match s {
            Step::Draw(d) => {
                ds(d.ds)?;
                match &d.geometry {
                    Geometry::FullScreen { .. } => {}
                    g => g.meshes().iter().try_for_each(|m| mesh(*m))?,
                }
                match d.scissor {
                    // A run by its last id: O(1) where listing it is O(n), and
                    // Blister sweeps a run of every solid once per Blist entry
                    // (10^5 nested differences: 10^10 checks).
                    Scissor::Run { first, end } if first < end => mesh(end - 1)?,
                    _ => d.scissor.meshes().try_for_each(mesh)?,
                }
                match d.fragment {
                    Fragment::Peel { prev, out, .. } | Fragment::PeelTolerant { prev, out, .. } => {
                        distinct(prev, out)?
                    }
                    Fragment::CopyTexel { src, out } => distinct(src, out)?,
                    Fragment::WriteDepth { out } => tex(out)?,
                    Fragment::DepthFromTexture { src } => tex(src)?,
                    Fragment::ShadeNearDepth { tex: t, .. }
                    | Fragment::NearerThan { tex: t, .. }
                    | Fragment::ParityBeforeExit { tex: t, .. }
                    | Fragment::BehindThan { tex: t, .. }
                    | Fragment::MergeBehind { tex: t, .. }
                    | Fragment::ShadeAtDepth { tex: t }
                    | Fragment::DepthAtDepth { tex: t } => tex(t)?,
                    Fragment::None
                    | Fragment::Shade
                    | Fragment::Paint { .. }
                    | Fragment::TieDepth { .. }
                    | Fragment::Background => {}
                }
            }
            Step::Clear(Clear::DepthStencil { ds: d, .. }) => ds(*d)?,
            Step::Clear(Clear::Texture { tex: t, .. }) => tex(*t)?,
            Step::Clear(Clear::Color) | Step::Pass(_) => {}
            Step::CopyTexture { src, dst } => {
                tex(*src)?;
                tex(*dst)?;
            }
            Step::CopyDepthBound { src, dst } => {
                ds(*src)?;
                ds(*dst)?;
                if *dst == plan.output_ds {
                    return Err(InvalidPlan::CopyIntoOutput(*dst));
                }
            }
            Step::CopyDepthToTexture { ds: d, dst } => {
                ds(*d)?;
                tex(*dst)?;
            }
            Step::Loop(_) => return Err(InvalidPlan::NestedLoop),
        }
        Ok(())
    };
    for s in &plan.steps {
        match s {
            Step::Loop(l) => l.head.iter().chain(&l.tail).try_for_each(check)?,
            other => check(other)?,
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{Draw, Loop};

    fn draw(geometry: Geometry, fragment: Fragment) -> Step {
        Draw::for_test(geometry, fragment)
    }

    fn plan(steps: Vec<Step>) -> Plan {
        Plan {
            algo: "test".into(),
            depth_stencils: 1,
            textures: 2,
            stencil_bits: 0,
            output_ds: 0,
            steps,
        }
    }

    #[test]
    fn accepts_indices_in_range() {
        let p = plan(vec![
            Step::Clear(Clear::Texture { tex: 1, depth: 0.0 }),
            draw(
                Geometry::Mesh(2),
                Fragment::Peel {
                    prev: 0,
                    out: 1,
                    shade: false,
                },
            ),
        ]);
        assert_eq!(validate(&p, 3), Ok(()));
    }

    #[test]
    fn names_the_bad_index() {
        let p = plan(vec![draw(Geometry::Mesh(3), Fragment::Shade)]);
        assert_eq!(
            validate(&p, 3),
            Err(InvalidPlan::Mesh {
                index: 3,
                meshes: 3
            })
        );
        let p = plan(vec![draw(
            Geometry::FullScreen { depth: 0.0 },
            Fragment::WriteDepth { out: 2 },
        )]);
        assert_eq!(
            validate(&p, 1),
            Err(InvalidPlan::Texture {
                index: 2,
                declared: 2
            })
        );
        let mut p = plan(vec![]);
        p.output_ds = 1;
        assert!(matches!(
            validate(&p, 1),
            Err(InvalidPlan::DepthStencil { index: 1, .. })
        ));
    }

    /// A scissor's run of mesh ids is checked by its last id.
    #[test]
    fn a_scissor_run_is_checked_by_its_end() {
        let run = |first, end| {
            let Step::Draw(d) = draw(Geometry::FullScreen { depth: 0.0 }, Fragment::None) else {
                unreachable!("for_test makes a draw")
            };
            plan(vec![Step::Draw(Draw {
                scissor: Scissor::Run { first, end },
                ..d
            })])
        };
        assert_eq!(validate(&run(0, 3), 3), Ok(()));
        assert_eq!(
            validate(&run(2, 2), 2),
            Ok(()),
            "an empty run names no mesh"
        );
        assert_eq!(
            validate(&run(1, 4), 3),
            Err(InvalidPlan::Mesh {
                index: 3,
                meshes: 3
            })
        );
    }

    #[test]
    fn rejects_feedback_and_nesting() {
        let p = plan(vec![draw(
            Geometry::Mesh(0),
            Fragment::CopyTexel { src: 1, out: 1 },
        )]);
        assert_eq!(validate(&p, 1), Err(InvalidPlan::SameTexture(1)));
        let inner = Loop {
            head: vec![],
            tail: vec![],
            max_iterations: 1,
        };
        let p = plan(vec![Step::Loop(Loop {
            head: vec![Step::Loop(inner)],
            tail: vec![],
            max_iterations: 2,
        })]);
        assert_eq!(validate(&p, 1), Err(InvalidPlan::NestedLoop));
    }

    #[test]
    fn copies_depth_stencil_only_out_of_the_output() {
        let mut p = plan(vec![Step::CopyDepthBound { src: 0, dst: 1 }]);
        p.depth_stencils = 2;
        assert_eq!(validate(&p, 1), Ok(()));
        p.steps = vec![Step::CopyDepthBound { src: 1, dst: 0 }];
        assert_eq!(validate(&p, 1), Err(InvalidPlan::CopyIntoOutput(0)));
        p.steps = vec![Step::CopyDepthBound { src: 0, dst: 2 }];
        assert!(matches!(
            validate(&p, 1),
            Err(InvalidPlan::DepthStencil { index: 2, .. })
        ));
    }
}
