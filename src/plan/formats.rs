//! What attachments a plan's steps need beyond depth: today whether any draw
//! tests or writes stencil. A plan that never does (a one-primitive product
//! drawn directly, CST-I without trims, …) can run on a depth-only format,
//! which on lavapipe halves the bytes its depth images clear and test
//! (`D32_SFLOAT` is 4 B/px where `D32_SFLOAT_S8_UINT` is 8:
//! docs/executor.md). Derived from the steps, not from the algorithm's name
//! or its reported `stencil_bits`, so a builder that stops using stencil gets
//! the cheaper format without being told.

use super::step::{Plan, Step};

/// Whether any draw of `steps` (loop bodies included) has a stencil test,
/// i.e. reads or writes a depth-stencil image's stencil. Clears alone do not
/// count: a stencil value that no draw reads is never observed (the outputs
/// are colour, ids and depth).
pub fn steps_need_stencil(steps: &[Step]) -> bool {
    steps.iter().any(|s| match s {
        Step::Draw(d) => d.stencil.is_some(),
        Step::Loop(l) => steps_need_stencil(&l.head) || steps_need_stencil(&l.tail),
        Step::Pass(_)
        | Step::Clear(_)
        | Step::CopyTexture { .. }
        | Step::CopyDepthBound { .. }
        | Step::CopyDepthToTexture { .. } => false,
    })
}

/// [`steps_need_stencil`] of the whole plan.
pub fn needs_stencil(plan: &Plan) -> bool {
    steps_need_stencil(&plan.steps)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{
        build, Algo, CompareOp, Fragment, Geometry, Loop, Prepared, StencilFace, StencilOp,
        StencilState,
    };
    use crate::scene::fixtures::block_minus_spheres;

    fn with_stencil(mut step: Step) -> Step {
        if let Step::Draw(d) = &mut step {
            let face = StencilFace {
                compare: CompareOp::Always,
                fail: StencilOp::Keep,
                pass: StencilOp::Invert,
                depth_fail: StencilOp::Keep,
            };
            d.stencil = Some(StencilState {
                front: face,
                back: face,
                compare_mask: 1,
                write_mask: 1,
                reference: 0,
            });
        }
        step
    }

    #[test]
    fn a_stencil_draw_anywhere_needs_stencil() {
        let plain = Draw::for_test(Geometry::Mesh(0), Fragment::Shade);
        let parity = with_stencil(Draw::for_test(Geometry::Mesh(1), Fragment::None));
        assert!(!steps_need_stencil(&[plain.clone()]));
        assert!(steps_need_stencil(&[plain.clone(), parity.clone()]));
        // Inside a loop's tail, after a stencil-free head.
        let l = Step::Loop(Loop {
            head: vec![plain.clone()],
            tail: vec![parity],
            max_iterations: 4,
        });
        assert!(steps_need_stencil(&[plain.clone(), l]));
        let l = Step::Loop(Loop {
            head: vec![plain.clone()],
            tail: vec![plain],
            max_iterations: 4,
        });
        assert!(!steps_need_stencil(&[l]));
    }

    /// The algorithms' own plans: a one-primitive product drawn directly needs
    /// none; parity counting (Goldfeather, SCS's subtraction) needs it.
    #[test]
    fn builders_plans_say_what_they_use() {
        let one = Prepared::new(&block_minus_spheres(0)).unwrap();
        for algo in [Algo::Scs, Algo::Goldfeather, Algo::CstI] {
            let p = build(algo, &one).unwrap();
            assert!(!needs_stencil(&p), "{algo:?} on one box:\n{:?}", p.steps);
        }
        let holes = Prepared::new(&block_minus_spheres(3)).unwrap();
        for algo in [Algo::Scs, Algo::Goldfeather, Algo::Blister] {
            assert!(needs_stencil(&build(algo, &holes).unwrap()), "{algo:?}");
        }
    }

    use crate::plan::Draw;
}
