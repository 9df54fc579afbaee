//! The tie-free lowering of one draw ([module doc](super)): a
//! tolerant parity, clip, merge or peel draw, or a final shade's draw, with
//! plain fixed-function tests in place of the tie rule where the decisions
//! say the rule cannot change its result; a final shade's draw as OpenCSG's
//! depth-`EQUAL` shading, cut to the rule's zones, or culling what never wins.

use super::super::rect::Rect;
use super::super::step::*;
use super::{ShadeRule, TieFree};

impl TieFree {
    /// A final shade's draw that keeps the tie rule, culling the faces of its
    /// mesh that are never visible where it can never be the lowest index of
    /// a tie on them (`visible_side::rule_may_cull`); `None` where it culls
    /// nothing more than `draw`.
    pub fn culled_rule(&self, draw: &Draw) -> Option<Draw> {
        let (
            Fragment::ShadeNearDepth {
                eps, equal_cull, ..
            },
            Geometry::Mesh(m),
        ) = (&draw.fragment, &draw.geometry)
        else {
            return None;
        };
        let key = eps.abs().to_bits();
        let may = self
            .rule_cull
            .iter()
            .find(|(k, _)| *k == key)
            .and_then(|(_, v)| v.get(*m as usize).copied())
            .unwrap_or(false);
        (may && is_final_shade(draw) && *equal_cull != draw.cull).then(|| Draw {
            cull: *equal_cull,
            ..draw.clone()
        })
    }

    /// The screen rectangles to which a final shade's draw keeps the tie rule,
    /// when that is not its whole rectangle: the draw runs the rule there and
    /// [`TieFree::depth_equal`] elsewhere ([`ShadeRule::Zones`]). `None` for
    /// every other draw.
    pub fn shade_zones(&self, draw: &Draw) -> Option<&[Rect]> {
        let (Fragment::ShadeNearDepth { eps, .. }, Geometry::Mesh(m)) =
            (&draw.fragment, &draw.geometry)
        else {
            return None;
        };
        if !is_final_shade(draw) {
            return None;
        }
        match self.shade_rules(*eps).get(*m as usize) {
            Some(ShadeRule::Zones(r)) => Some(r),
            _ => None,
        }
    }

    /// A final shade's draw as OpenCSG's depth-`EQUAL` shading
    /// ([`tie_free`](crate::plan::tie_free)), whatever the decisions: `None` for
    /// other draws. It culls the faces that are never visible (`equal_cull`,
    /// [`VisibleSides`](crate::plan::VisibleSides)): it passes only at its own
    /// faces' raster depth, so a culled face could pass only where it crosses the visible
    /// one, and it is drawn only where it cannot tie with it.
    pub fn depth_equal(draw: &Draw) -> Option<Draw> {
        let Fragment::ShadeNearDepth { equal_cull, .. } = draw.fragment else {
            return None;
        };
        is_final_shade(draw).then(|| Draw {
            cull: equal_cull,
            depth: DepthState {
                compare: CompareOp::Equal,
                write: false,
            },
            fragment: Fragment::Shade,
            ..draw.clone()
        })
    }

    /// The draw with plain tests in place of the tie rule, when the rule cannot
    /// change its result ([`tie_free`](crate::plan::tie_free)); `None` otherwise.
    pub fn fixed_function(&self, draw: &Draw) -> Option<Draw> {
        let meshes: &[MeshId] = match &draw.geometry {
            Geometry::Mesh(m) => std::slice::from_ref(m),
            Geometry::Meshes(ms) => ms,
            Geometry::FullScreen { .. } | Geometry::Footprint { .. } => return None,
        };
        match draw.fragment {
            Fragment::NearerThan { eps, .. } | Fragment::ParityBeforeExit { eps, .. } => {
                let compare = if eps < 0.0 {
                    CompareOp::Less
                } else {
                    CompareOp::LessOrEqual
                };
                // The exit's `Greater` test stands for the back faces' half of
                // the parity (`Fragment::ParityBeforeExit`).
                let cull = match draw.fragment {
                    Fragment::ParityBeforeExit { .. } => Cull::Back,
                    _ => draw.cull,
                };
                self.plain_test(draw, meshes, eps, compare)
                    .map(|d| Draw { cull, ..d })
                    .or_else(|| self.tie_depth(draw, meshes, eps, CompareOp::LessOrEqual))
            }
            // NearerThan's complement: the opposite plain compare.
            Fragment::BehindThan { eps, .. } => {
                let compare = if eps < 0.0 {
                    CompareOp::GreaterOrEqual
                } else {
                    CompareOp::Greater
                };
                self.plain_test(draw, meshes, eps, compare)
                    .or_else(|| self.tie_depth(draw, meshes, eps, CompareOp::Greater))
            }
            // The merge writes the texture's depth, so it keeps its program,
            // with the exact compare (one fetch, no derivatives).
            Fragment::MergeBehind { tex, eps }
                if eps != 0.0 && self.draw_free(draw, meshes, eps) =>
            {
                Some(Draw {
                    fragment: Fragment::MergeBehind { tex, eps: 0.0 },
                    ..draw.clone()
                })
            }
            Fragment::PeelTolerant { prev, out, eps } if self.draw_free(draw, meshes, eps) => {
                Some(Draw {
                    fragment: Fragment::Peel {
                        prev,
                        out,
                        shade: false,
                    },
                    ..draw.clone()
                })
            }
            Fragment::ShadeNearDepth { eps, .. } if self.shade_free(meshes, eps) => {
                Self::depth_equal(draw)
            }
            _ => None,
        }
    }

    /// `step` as the executor records it, for what it reads
    /// (`plan::reach`): a draw [`TieFree::fixed_function`] rewrites, rewritten;
    /// the final shades' draws as planned (what their depth copy must cover
    /// is [`TieFree::shade_copies`]' to decide); any other step as it is.
    pub fn lowered(&self, step: &Step) -> Step {
        match step {
            Step::Draw(d) if !matches!(d.fragment, Fragment::ShadeNearDepth { .. }) => self
                .fixed_function(d)
                .map_or_else(|| step.clone(), Step::Draw),
            _ => step.clone(),
        }
    }

    /// A tolerant parity-like `draw` of `meshes` as a depth-stencil draw with
    /// no program, tested `compare` against its image, when its meshes are
    /// tie-free at `eps` and it has no depth test of its own (the shader's
    /// compare can replace only that).
    fn plain_test(
        &self,
        draw: &Draw,
        meshes: &[MeshId],
        eps: f32,
        compare: CompareOp,
    ) -> Option<Draw> {
        if !self.draw_free(draw, meshes, eps) {
            return None;
        }
        as_depth_test(draw, compare, Fragment::None)
    }

    /// A tolerant parity-like `draw` of `meshes` that may meet a tie, with its
    /// rule as the depth test ([`Fragment::TieDepth`]) tested `compare`
    /// against its image, when the decisions allow it
    /// ([`TieFree::with_tie_depth`]), its meshes tie only with parallel faces
    /// (the depth test's rule widens by the slope term everywhere, the
    /// texture's only where the gradients agree: they differ at nearly
    /// tangent curves) and it has no depth test of its own. Every face stays
    /// drawn: at a tie a back face counts too, where the tie-free draw of a
    /// parity before an exit leaves back faces to the exit's `Greater` test.
    fn tie_depth(
        &self,
        draw: &Draw,
        meshes: &[MeshId],
        eps: f32,
        compare: CompareOp,
    ) -> Option<Draw> {
        // SCS's parity before an exit and its clip only: its exits write
        // the texture that those draws read, so each batch of subtractions
        // waited for the last (docs/precision.md). Blister's
        // and CST's parity draws keep the texture's rule: run as the depth
        // test, they moved 1–2 interior pixels of complex and of the
        // 311-primitive tree against the reference at 128×128.
        let scs = matches!(
            draw.fragment,
            Fragment::ParityBeforeExit { .. } | Fragment::BehindThan { .. }
        );
        if !(self.tie_depth && scs && self.ties_flat(meshes)) {
            return None;
        }
        as_depth_test(draw, compare, Fragment::TieDepth { eps })
    }
}

/// Tolerant `draw` with its shader's compare moved into the depth test,
/// tested `compare` and writing no depth, its program `fragment`; `None` when
/// it has a depth test of its own (the shader's compare can replace only the
/// absent one).
fn as_depth_test(draw: &Draw, compare: CompareOp, fragment: Fragment) -> Option<Draw> {
    let off = DepthState {
        compare: CompareOp::Always,
        write: false,
    };
    (draw.depth == off).then(|| Draw {
        depth: DepthState {
            compare,
            write: false,
        },
        fragment,
        ..draw.clone()
    })
}

/// Whether `draw` is a final shade's draw as `plan::tie::shade_near_depth`
/// makes it: the tie test in the shader, its depth written.
fn is_final_shade(draw: &Draw) -> bool {
    let shade = DepthState {
        compare: CompareOp::Always,
        write: true,
    };
    matches!(draw.fragment, Fragment::ShadeNearDepth { .. }) && draw.depth == shade
}

#[cfg(test)]
mod tests {
    use super::super::super::testing::{
        band, half_free, parity, plan_of, shaded, the_draw as draw, whole,
    };
    use super::super::super::SHADE_EPS;
    use super::*;
    use crate::geom::ties::TieGaps;

    #[test]
    fn tie_free_parity_draws_become_plain_depth_tests() {
        let steps = vec![
            parity(0, SHADE_EPS),
            parity(0, -SHADE_EPS),
            parity(1, SHADE_EPS),
        ];
        let free = half_free(&plan_of(steps.clone()));
        let fast: Vec<Option<Draw>> = steps
            .into_iter()
            .map(|s| free.fixed_function(&draw(s)))
            .collect();
        let compare = |d: &Option<Draw>| {
            let d = d.as_ref().expect("rewritten");
            assert_eq!(d.fragment, Fragment::None);
            assert!(!d.depth.write);
            d.depth.compare
        };
        assert_eq!(compare(&fast[0]), CompareOp::LessOrEqual);
        assert_eq!(compare(&fast[1]), CompareOp::Less);
        // The possibly tied mesh keeps the tie rule.
        assert_eq!(fast[2], None);
        assert!(fast.iter().flatten().all(|d| d.cull == Cull::None));
    }

    #[test]
    fn a_tie_free_parity_before_an_exit_draws_front_faces_only() {
        let before_exit = |mesh| {
            let mut d = draw(parity(mesh, SHADE_EPS));
            d.fragment = Fragment::ParityBeforeExit {
                tex: 1,
                eps: SHADE_EPS,
            };
            d
        };
        let plan = plan_of(vec![Step::Draw(before_exit(0)), Step::Draw(before_exit(1))]);
        let free = half_free(&plan);
        let fast = free.fixed_function(&before_exit(0)).expect("rewritten");
        assert_eq!(
            (
                fast.cull,
                fast.depth.compare,
                fast.depth.write,
                &fast.fragment
            ),
            (Cull::Back, CompareOp::LessOrEqual, false, &Fragment::None)
        );
        // The possibly tied mesh keeps every face and the tie rule.
        assert_eq!(free.fixed_function(&before_exit(1)), None);
    }

    #[test]
    fn draws_that_may_tie_run_the_rule_as_the_depth_test_where_allowed() {
        let with = |f: fn(Tex, f32) -> Fragment, mesh, eps| {
            let mut d = draw(parity(mesh, eps));
            d.fragment = f(1, eps);
            d
        };
        let nearer = |tex, eps| Fragment::NearerThan { tex, eps };
        let before_exit = |tex, eps| Fragment::ParityBeforeExit { tex, eps };
        let behind = |tex, eps| Fragment::BehindThan { tex, eps };
        let plan = plan_of(vec![
            Step::Draw(with(nearer, 1, -SHADE_EPS)),
            Step::Draw(with(before_exit, 1, SHADE_EPS)),
            Step::Draw(with(behind, 1, SHADE_EPS)),
        ]);
        // Mesh 0 has no partner; mesh 1 ties with itself (a thin wall), its
        // faces parallel or not.
        let tied = |flat: bool| {
            let zone = crate::geom::ties::TieZone {
                a: 1,
                b: 1,
                opposite: true,
                flat,
                gap: 0.0,
                lo: glam::DVec3::ZERO,
                hi: glam::DVec3::ONE,
            };
            let gaps = TieGaps {
                min_gap: vec![f64::INFINITY, 0.0],
                cap: 1.0,
                pairs: vec![(1, 1, 0.0)],
                zones: vec![zone],
            };
            TieFree::new(&gaps, &gaps, &band(800, 8, true), &plan, &whole)
        };
        // Not allowed (D24, or switched off), or a partner face not parallel
        // (nearly tangent curves): the tied mesh keeps its shader.
        assert_eq!(
            tied(true).fixed_function(&with(before_exit, 1, SHADE_EPS)),
            None
        );
        let curved = tied(false).with_tie_depth(true);
        assert_eq!(
            curved.fixed_function(&with(before_exit, 1, SHADE_EPS)),
            None
        );
        let free = tied(true).with_tie_depth(true);
        let lowered = |d: &Draw| {
            let l = free.fixed_function(d).expect("rewritten");
            assert!(!l.depth.write);
            // The tie-free parity before an exit culls back faces; at a tie a
            // back face counts, so every face stays.
            assert_eq!(l.cull, d.cull);
            (l.depth.compare, l.fragment)
        };
        // Blister's and CST's parity keeps the texture's rule; SCS's parity
        // before an exit and its clip run it as the depth test.
        assert_eq!(free.fixed_function(&with(nearer, 1, -SHADE_EPS)), None);
        assert_eq!(
            lowered(&with(before_exit, 1, SHADE_EPS)),
            (
                CompareOp::LessOrEqual,
                Fragment::TieDepth { eps: SHADE_EPS }
            )
        );
        // The complement: behind where the nearer test fails.
        assert_eq!(
            lowered(&with(behind, 1, SHADE_EPS)),
            (CompareOp::Greater, Fragment::TieDepth { eps: SHADE_EPS })
        );
        // A tie-free mesh still gets the plain test, and a draw with a depth
        // test of its own keeps its shader.
        assert_eq!(
            free.fixed_function(&with(before_exit, 0, SHADE_EPS))
                .map(|d| d.fragment),
            Some(Fragment::None)
        );
        let mut tested = with(behind, 1, SHADE_EPS);
        tested.depth.compare = CompareOp::Less;
        assert_eq!(free.fixed_function(&tested), None);
        // What reach sees: the lowered draw samples no texture.
        let step = free.lowered(&Step::Draw(with(before_exit, 1, SHADE_EPS)));
        let Step::Draw(d) = step else {
            panic!("a draw")
        };
        assert_eq!(crate::plan::usage::sampled_texture(&d.fragment), None);
    }

    #[test]
    fn only_draws_without_a_depth_test_and_known_tolerances_are_rewritten() {
        let free = half_free(&plan_of(vec![parity(0, SHADE_EPS)]));
        let mut d = draw(parity(0, SHADE_EPS));
        d.depth.compare = CompareOp::Less;
        assert_eq!(free.fixed_function(&d), None);
        // A tolerance the plan did not have was never decided.
        assert_eq!(free.fixed_function(&draw(parity(0, 1e-3))), None);
        assert_eq!(
            TieFree::none().fixed_function(&draw(parity(0, SHADE_EPS))),
            None
        );
        // Several meshes: all must be tie-free.
        let mut d = draw(parity(0, SHADE_EPS));
        d.geometry = Geometry::Meshes(vec![0, 1]);
        assert_eq!(free.fixed_function(&d), None);
    }

    #[test]
    fn tie_free_tolerant_peels_become_exact_peels() {
        let peel = |mesh| {
            Step::Draw(Draw {
                fragment: Fragment::PeelTolerant {
                    prev: 0,
                    out: 1,
                    eps: SHADE_EPS,
                },
                depth: DepthState {
                    compare: CompareOp::Less,
                    write: true,
                },
                ..draw(parity(mesh, SHADE_EPS))
            })
        };
        let plan = plan_of(vec![Step::Loop(Loop {
            head: vec![peel(0), peel(1)],
            tail: vec![],
            max_iterations: 3,
        })]);
        let free = half_free(&plan);
        let fast = free.fixed_function(&draw(peel(0))).expect("tie-free");
        assert_eq!(
            fast.fragment,
            Fragment::Peel {
                prev: 0,
                out: 1,
                shade: false
            }
        );
        assert_eq!(fast.depth, draw(peel(0)).depth);
        assert_eq!(free.fixed_function(&draw(peel(1))), None);
    }

    #[test]
    fn tie_free_shade_draws_become_depth_equal_shading() {
        let plan = shaded(vec![parity(0, SHADE_EPS)], &[0, 1]);
        let free = half_free(&plan);
        let shade: Vec<Draw> = plan.steps[3..].iter().cloned().map(draw).collect();
        // Descending order: mesh 1 (can tie) first, then mesh 0.
        assert_eq!(shade[0].geometry, Geometry::Mesh(1));
        assert_eq!(free.fixed_function(&shade[0]), None);
        let fast = free.fixed_function(&shade[1]).expect("mesh 0 is tie-free");
        assert_eq!(fast.fragment, Fragment::Shade);
        assert_eq!(
            fast.depth,
            DepthState {
                compare: CompareOp::Equal,
                write: false
            }
        );
        assert_eq!((fast.ds, fast.stencil, fast.cull), (0, None, Cull::None));
        // Where the device profile allows no depth-equal shade, it keeps the rule.
        assert_eq!(
            free.clone().keep_shade_rule().fixed_function(&shade[1]),
            None
        );
    }

    /// `d` with the culling its depth-equal form may take set to `c`.
    fn sided(mut d: Draw, c: Cull) -> Draw {
        if let Fragment::ShadeNearDepth { equal_cull, .. } = &mut d.fragment {
            *equal_cull = c;
        }
        d
    }

    #[test]
    fn shade_draws_cull_the_faces_never_visible_where_no_tie_can_need_them() {
        let plan = shaded(Vec::new(), &[0, 1]);
        let shade: Vec<Draw> = plan.steps[2..].iter().cloned().map(draw).collect();
        let (one, zero) = (
            sided(shade[0].clone(), Cull::Front),
            sided(shade[1].clone(), Cull::Back),
        );
        // Mesh 0 is tie-free: its depth-equal draw culls.
        let free = half_free(&plan);
        assert_eq!(free.fixed_function(&zero).map(|d| d.cull), Some(Cull::Back));
        assert_eq!(free.culled_rule(&zero).map(|d| d.cull), Some(Cull::Back));
        // Mesh 1 keeps the rule, but ties only with itself: its rule draw culls.
        assert_eq!(free.fixed_function(&one), None);
        let rule = free.culled_rule(&one).expect("no other mesh ties with 1");
        assert_eq!(
            rule,
            Draw {
                cull: Cull::Front,
                ..one.clone()
            }
        );
        // Nothing to cull, or nothing decided: no culled draw.
        assert_eq!(free.culled_rule(&shade[0]), None);
        assert_eq!(TieFree::none().culled_rule(&one), None);
        // Mesh 0 tied with the higher mesh 1: 0's hidden faces may win a tie.
        let gaps = TieGaps {
            min_gap: vec![0.0, 0.0],
            cap: 1.0,
            pairs: vec![(0, 1, 0.0)],
            zones: vec![],
        };
        let tied = TieFree::new(&gaps, &gaps, &band(800, 8, true), &plan, &whole);
        assert_eq!(tied.culled_rule(&zero), None);
        assert_eq!(tied.culled_rule(&one).map(|d| d.cull), Some(Cull::Front));
    }
}
