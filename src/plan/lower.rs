//! The lowering pass: one plan draw becomes what is recorded for it.
//! `Recorder::draw` records this answer, `peeltrim plan` prints it (`passes`),
//! and the look-ahead
//! (`record/ahead.rs`) summarizes the same answer, so the two can never
//! disagree about which block a draw asks for. In order:
//!
//! - a depth texture written for nobody makes the draw depth-only
//!   (`plan::reach`, [`dead_write`]);
//! - a draw whose scissor is empty on screen records nothing;
//! - a one-primitive product's final shade draw records nothing and its direct
//!   draw shades instead (`plan::direct_shade`);
//! - a final shade of a mesh that can tie only in some zones becomes the rule
//!   draw over the zones and the depth-equal draw over the rest
//!   (`plan::tie_zones`);
//! - a draw whose result the tie rule cannot change runs plain fixed-function
//!   tests (`plan::tie_free`), and a final shade's rule draw culls the faces
//!   that can never win (`plan::visible_side`).
//!
//! The lowering is pure: the recorder's counters and queues stay its own.

use std::borrow::Cow;

use crate::plan::direct_shade::DirectShades;
use crate::plan::reach;
use crate::plan::scissor::{Rect, RectUnions};
use crate::plan::tie_free::TieFree;
use crate::plan::{Cull, Draw, Fragment, Geometry};

/// What the recorder records for one plan draw.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum RecordedDraw<'a> {
    /// Nothing: its scissor is empty on screen (no pixel could change, no
    /// sample could pass).
    OffScreen,
    /// Nothing: the final shade's draw of a product its direct draw shades.
    Dropped,
    /// One draw over the whole scissor, and how it came to be (the counts).
    One(Cow<'a, Draw>, Lowering),
    /// A final shade's draw of a mesh that can tie only in `zones`: `rule`
    /// (culling what never wins when `culled`) cut to each zone, `fixed` (the
    /// depth-equal draw) cut to each rectangle of the rest.
    Zoned {
        rule: Cow<'a, Draw>,
        culled: bool,
        fixed: Draw,
        zones: &'a [Rect],
    },
}

/// How a draw recorded as one draw came to be what it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Lowering {
    /// As planned (a dead texture write already depth-only), no tie rule.
    Planned,
    /// A parity, clip, merge or peel draw keeping its tie rule.
    TieRule,
    /// A direct draw shading its one-primitive product.
    DirectShade,
    /// Plain tests in place of the tie rule; `shade`: a final shade's draw,
    /// now depth-equal.
    FixedFunction { shade: bool },
    /// A parity or clip draw's tie rule as its depth test (`Fragment::TieDepth`).
    TieDepth,
    /// A final shade's draw keeping the tie rule over its whole rectangle;
    /// `culled`: culling the faces that never win.
    ShadeRule { culled: bool },
}

impl RecordedDraw<'_> {
    /// The draw whose usages say which block this one records in first: the
    /// draw itself, or a zoned shade's rule draw (which samples the copy);
    /// `None` when nothing is recorded.
    pub fn block_draw(&self) -> Option<&Draw> {
        match self {
            RecordedDraw::OffScreen | RecordedDraw::Dropped => None,
            RecordedDraw::One(d, _) | RecordedDraw::Zoned { rule: d, .. } => Some(d),
        }
    }
}

/// Whether `draw`'s texture write is dead, taking the next of
/// `plan::reach::FrameReach::texture_writes`' answers (`next`: one per draw
/// that writes a texture, in order; none planned: kept).
pub(crate) fn dead_write(draw: &Draw, next: impl FnOnce() -> Option<bool>) -> bool {
    reach::written_texture(draw).is_some() && next() == Some(false)
}

/// What the recorder records for `draw` (its texture write dead when
/// `dead_write`), cut to `scissor` on screen, under tie decisions `ties` and
/// direct shades `direct` ([module doc](self)).
pub(crate) fn lower<'a>(
    draw: &'a Draw,
    dead_write: bool,
    scissor: Rect,
    ties: &'a TieFree,
    direct: &DirectShades,
) -> RecordedDraw<'a> {
    let draw = match dead_write {
        true => Cow::Owned(Draw {
            fragment: Fragment::None,
            ..draw.clone()
        }),
        false => Cow::Borrowed(draw),
    };
    if scissor.is_empty() {
        return RecordedDraw::OffScreen;
    }
    if direct.drops(&draw) {
        return RecordedDraw::Dropped;
    }
    if let Some(d) = direct.shaded(&draw) {
        return RecordedDraw::One(Cow::Owned(d), Lowering::DirectShade);
    }
    if let Some(zones) = ties.shade_zones(&draw) {
        let fixed = TieFree::depth_equal(&draw).expect("a zoned draw is a final shade's");
        let (rule, culled) = match ties.culled_rule(&draw) {
            Some(c) => (Cow::Owned(c), true),
            None => (draw, false),
        };
        return RecordedDraw::Zoned {
            rule,
            culled,
            fixed,
            zones,
        };
    }
    let shade = matches!(draw.fragment, Fragment::ShadeNearDepth { .. });
    if let Some(d) = ties.fixed_function(&draw) {
        let why = match d.fragment {
            Fragment::TieDepth { .. } => Lowering::TieDepth,
            _ => Lowering::FixedFunction { shade },
        };
        return RecordedDraw::One(Cow::Owned(d), why);
    }
    if shade {
        return match ties.culled_rule(&draw) {
            Some(c) => RecordedDraw::One(Cow::Owned(c), Lowering::ShadeRule { culled: true }),
            None => RecordedDraw::One(draw, Lowering::ShadeRule { culled: false }),
        };
    }
    let rule = matches!(
        draw.fragment,
        Fragment::NearerThan { .. }
            | Fragment::ParityBeforeExit { .. }
            | Fragment::BehindThan { .. }
            | Fragment::MergeBehind { .. }
            | Fragment::PeelTolerant { .. }
    );
    let why = match rule {
        true => Lowering::TieRule,
        false => Lowering::Planned,
    };
    RecordedDraw::One(draw, why)
}

/// The part of `scissor` where the final shade's depth-equal draw `d`
/// (lowered `how`) of a cavity's inside can pass: within the screen
/// rectangle of the openings it is seen through (`openings`,
/// `CutAway::inside_holes`), where they are known; `scissor`
/// otherwise. Only a draw that cannot tie (`Lowering::FixedFunction`) is cut:
/// it passes only where its mesh's own face is the visible surface, and a
/// cutter that is never positive shows its inside (its back faces, the front
/// ones culled) only through an opening of a product it cuts. A draw that
/// keeps the tie rule may win a tie on another product's face, anywhere.
pub(crate) fn seen_inside(d: &Draw, how: Lowering, scissor: Rect, openings: &RectUnions) -> Rect {
    match (how, d.cull, &d.geometry) {
        (Lowering::FixedFunction { shade: true }, Cull::Front, Geometry::Mesh(c)) => {
            match openings.opening(*c) {
                Some(seen) => scissor.intersect(&seen),
                None => scissor,
            }
        }
        _ => scissor,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::ties::TieGaps;
    use crate::plan::testing::{
        band, cube, half_free, mesh_draw, parity, plan_of, the_draw, whole,
    };
    use crate::plan::tie_free::ShadeRule;
    use crate::plan::{shade_near_depth, CompareOp, Geometry, Step, VisibleSides, SHADE_EPS};
    use glam::DVec3;

    const ON: Rect = Rect {
        x0: 0,
        y0: 0,
        x1: 100,
        y1: 100,
    };

    fn none() -> DirectShades {
        DirectShades::none()
    }

    /// The final shade draws of meshes `ms` (descending, as planned).
    fn shade_draws(ms: &[u32]) -> Vec<Draw> {
        shade_near_depth(ms, 0, 1, None, &VisibleSides::none())
            .into_iter()
            .filter(|s| matches!(s, Step::Draw(_)))
            .map(the_draw)
            .collect()
    }

    #[test]
    fn a_dead_texture_write_draws_depth_only_and_off_screen_draws_nothing() {
        let front = mesh_draw(0, Fragment::WriteDepth { out: 1 });
        let ties = TieFree::none();
        let live = lower(&front, false, ON, &ties, &none());
        assert_eq!(
            live,
            RecordedDraw::One(Cow::Borrowed(&front), Lowering::Planned)
        );
        let dead = lower(&front, true, ON, &ties, &none());
        let RecordedDraw::One(d, Lowering::Planned) = &dead else {
            panic!("{dead:?}")
        };
        assert_eq!(
            **d,
            Draw {
                fragment: Fragment::None,
                ..front.clone()
            }
        );
        assert_eq!(
            lower(&front, true, Rect::EMPTY, &ties, &none()),
            RecordedDraw::OffScreen
        );
        // Only a draw that writes a texture takes an answer.
        let mut answers = vec![Some(false), Some(true)].into_iter();
        let shade = mesh_draw(0, Fragment::Shade);
        assert!(!dead_write(&shade, || answers.next().flatten()));
        assert!(dead_write(&front, || answers.next().flatten()));
        assert!(!dead_write(&front, || answers.next().flatten()));
        assert!(
            !dead_write(&front, || answers.next().flatten()),
            "unknown: kept"
        );
    }

    #[test]
    fn tie_free_draws_run_plain_tests_and_the_others_keep_the_rule() {
        let steps = vec![parity(0, SHADE_EPS), parity(1, SHADE_EPS)];
        let ties = half_free(&plan_of(steps.clone()));
        let (free, tied) = (the_draw(steps[0].clone()), the_draw(steps[1].clone()));
        let RecordedDraw::One(d, how) = lower(&free, false, ON, &ties, &none()) else {
            panic!("one draw")
        };
        assert_eq!(how, Lowering::FixedFunction { shade: false });
        assert_eq!(
            (&d.fragment, d.depth.compare),
            (&Fragment::None, CompareOp::LessOrEqual)
        );
        assert_eq!(
            lower(&tied, false, ON, &ties, &none()),
            RecordedDraw::One(Cow::Borrowed(&tied), Lowering::TieRule)
        );
    }

    #[test]
    fn final_shade_draws_run_depth_equal_or_keep_the_rule_culled() {
        let plan = plan_of(shade_near_depth(&[0, 1], 0, 1, None, &VisibleSides::none()));
        let ties = half_free(&plan);
        let shade = shade_draws(&[0, 1]);
        let (one, zero) = (&shade[0], &shade[1]);
        let RecordedDraw::One(d, how) = lower(zero, false, ON, &ties, &none()) else {
            panic!("one draw")
        };
        assert_eq!(how, Lowering::FixedFunction { shade: true });
        assert_eq!(
            (&d.fragment, d.depth.compare),
            (&Fragment::Shade, CompareOp::Equal)
        );
        assert_eq!(
            lower(one, false, ON, &ties, &none()),
            RecordedDraw::One(Cow::Borrowed(one), Lowering::ShadeRule { culled: false })
        );
        // Mesh 1 ties only with itself: its rule draw may cull its hidden side.
        let sided = Draw {
            fragment: Fragment::ShadeNearDepth {
                tex: 1,
                eps: SHADE_EPS,
                equal_cull: Cull::Front,
            },
            ..one.clone()
        };
        let culled = lower(&sided, false, ON, &ties, &none());
        let RecordedDraw::One(d, Lowering::ShadeRule { culled: true }) = &culled else {
            panic!("{culled:?}")
        };
        assert_eq!(d.cull, Cull::Front);
        assert_eq!(culled.block_draw(), Some(&**d));
    }

    #[test]
    fn a_direct_draw_shades_and_its_shade_draw_is_dropped() {
        let direct = the_draw(Draw::for_test(Geometry::Mesh(0), Fragment::None));
        let mut steps = vec![Step::Draw(direct.clone())];
        steps.extend(shade_near_depth(&[0], 0, 1, None, &VisibleSides::none()));
        let refs: Vec<&Step> = steps.iter().collect();
        let shades = DirectShades::decide(&refs, 0, |_, _| true);
        let ties = TieFree::none();
        let lowered = lower(&direct, false, ON, &ties, &shades);
        let RecordedDraw::One(d, Lowering::DirectShade) = &lowered else {
            panic!("{lowered:?}")
        };
        assert_eq!(d.fragment, Fragment::Shade);
        let shade = &shade_draws(&[0])[0];
        assert_eq!(
            lower(shade, false, ON, &ties, &shades),
            RecordedDraw::Dropped
        );
        assert_eq!(RecordedDraw::Dropped.block_draw(), None);
    }

    #[test]
    fn a_shade_that_ties_in_zones_is_cut_into_rule_and_depth_equal_draws() {
        // Two boxes with coplanar, overlapping top faces: both tie in a zone.
        let a = cube(DVec3::ZERO, DVec3::splat(0.5));
        let b = cube(DVec3::new(0.2, 0.3, 0.0), DVec3::new(0.5, 0.2, 0.4));
        let gaps = TieGaps::new(&[&a, &b]);
        let plan = plan_of(shade_near_depth(&[0, 1], 0, 1, None, &VisibleSides::none()));
        let ties = TieFree::new(&gaps, &gaps, &band(800, 8, true), &plan, &whole);
        let shade = &shade_draws(&[0])[0];
        let Some(zones) = ties.shade_zones(shade) else {
            panic!(
                "zones expected: {:?}",
                ShadeRule::decide(&gaps, 0, band(800, 8, true).world(SHADE_EPS), &whole)
            )
        };
        let lowered = lower(shade, false, ON, &ties, &none());
        let RecordedDraw::Zoned {
            rule,
            fixed,
            zones: z,
            ..
        } = &lowered
        else {
            panic!("{lowered:?}")
        };
        assert_eq!(*z, zones);
        assert_eq!(
            rule.fragment, shade.fragment,
            "the rule draw keeps the rule"
        );
        assert_eq!(Some(fixed), TieFree::depth_equal(shade).as_ref());
        // The look-ahead sees the rule draw first: it samples the copy.
        assert_eq!(lowered.block_draw(), Some(&**rule));
    }

    #[test]
    fn only_a_depth_equal_shade_of_a_cavity_inside_is_cut_to_its_openings() {
        let r = |x0, y0, x1, y1| Rect { x0, y0, x1, y1 };
        let rects = [ON, ON];
        let openings = RectUnions::new(&rects).with_openings(&[None, Some(r(10, 20, 30, 40))]);
        let inside = |m| Draw {
            cull: Cull::Front,
            ..mesh_draw(m, Fragment::Shade)
        };
        let fixed = Lowering::FixedFunction { shade: true };
        assert_eq!(
            seen_inside(&inside(1), fixed, ON, &openings),
            r(10, 20, 30, 40)
        );
        // Within the draw's own scissor; none known for mesh 0.
        let part = r(0, 30, 100, 100);
        assert_eq!(
            seen_inside(&inside(1), fixed, part, &openings),
            r(10, 30, 30, 40)
        );
        assert_eq!(seen_inside(&inside(0), fixed, ON, &openings), ON);
        // Its outside (front faces), a draw keeping the tie rule, other
        // lowerings: whole.
        let outside = Draw {
            cull: Cull::Back,
            ..inside(1)
        };
        assert_eq!(seen_inside(&outside, fixed, ON, &openings), ON);
        for how in [
            Lowering::ShadeRule { culled: true },
            Lowering::FixedFunction { shade: false },
            Lowering::Planned,
        ] {
            assert_eq!(seen_inside(&inside(1), how, ON, &openings), ON, "{how:?}");
        }
    }
}
