//! SCS products side by side: products whose pixels cannot meet on screen
//! share one clear of the surface image and texture, and each phase's block
//! (fronts and subtractions, then the merges or clips), where each product
//! alone costs two render passes, two barriers and two clears (many_50: 25
//! products of a sphere minus a cylinder). OpenCSG's SCS renders one product
//! at a time (`OpenCSG::render` per product); the candidate depth `z` of SCS
//! is per pixel, so products that touch disjoint pixels never see each
//! other's `z`.
//!
//! A product *touches* the pixels of its literals' projections: every draw of
//! its steps is a mesh draw of one of them (or a footprint of one), so
//! whatever the scissors (the executor may grow them after a camera move;
//! they only bound work) its fragments lie there. It *occupies* the pixels of
//! its positive primitives' projections: only there is `z` written by a front
//! face, and only there is it read (its exits move `z` only where a front face
//! set it: elsewhere the parity of a cutter every ray starts outside of is
//! even, module documentation of [`super`]; its merge or clip draws a
//! positive primitive). Two products go side by side when neither touches
//! what the other occupies ([`Footprint::apart`], on [`crate::plan::screen`]'s
//! boxes). Their steps interleave by phase: all fronts, all subtractions, all
//! merges. Each subtraction batch clears the stencil bits it set wherever it
//! drew, and each product's stencil and depth writes stay inside what it
//! touches, so one product's steps leave the other's pixels as they were.
//!
//! Only products whose steps are all mesh draws go side by side: no round
//! loop (its sample count would mix the products), and in the surface image
//! only a product of one positive primitive (its merge is one draw of that
//! primitive's back faces; the others sweep a quad over their rectangle,
//! which a grown scissor would widen). The products drawn in the output image
//! ([`super::Target::Output`]) are those apart from the first such product:
//! the output holds far everywhere before them.
#![deny(unsafe_code)]

use std::collections::HashMap;

use super::{back_face_clip_applies, Sequence, Target};
use crate::plan::goldfeather::Lit;
use crate::plan::screen::ScreenBox;
use crate::plan::step::Step;
use crate::plan::Prepared;

/// One product's steps by phase.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Parts {
    /// The clears of the image and texture holding `z` (the same for every
    /// product of a [`Target`]).
    pub clears: Vec<Step>,
    /// The front faces of the positive primitives.
    pub front: Vec<Step>,
    /// The subtractions applied once (no pass heading).
    pub once: Vec<Step>,
    /// The rounds' loop, if any.
    pub rounds: Option<Step>,
    /// The clip and merge, with their pass headings.
    pub finish: Vec<Step>,
}

/// The steps of products `parts` side by side: each phase once, its steps in
/// product order. One product's are its plain sequence.
pub(super) fn steps(parts: Vec<Parts>) -> Vec<Step> {
    let first = parts.first().expect("a group has a product");
    assert!(
        parts.len() == 1 || parts.iter().all(|p| p.rounds.is_none()),
        "products with rounds are never side by side"
    );
    assert!(
        parts.iter().all(|p| p.clears == first.clears),
        "products side by side keep `z` in the same images"
    );
    let mut steps = vec![Step::Pass("scs-front".into())];
    steps.extend(first.clears.iter().cloned());
    steps.extend(parts.iter().flat_map(|p| p.front.iter().cloned()));
    if parts.iter().any(|p| !p.once.is_empty()) {
        steps.push(Step::Pass("subtract".into()));
        steps.extend(parts.iter().flat_map(|p| p.once.iter().cloned()));
    }
    steps.extend(first.rounds.iter().cloned());
    // One heading per phase: the first product's, the others' dropped (every
    // product side by side finishes with the same passes).
    steps.extend(first.finish.iter().cloned());
    for p in &parts[1..] {
        let body = p.finish.iter().filter(|s| !matches!(s, Step::Pass(_)));
        steps.extend(body.cloned());
    }
    steps
}

/// Where a product can draw and where it keeps `z` (module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    pub touched: ScreenBox,
    pub occupied: ScreenBox,
}

impl Footprint {
    /// Product `p`'s footprint; `None` when a literal has no screen box.
    pub fn of(p: &[Lit], prep: &Prepared) -> Option<Footprint> {
        let screen = |l: &Lit| prep.screen.get(l.prim as usize).copied().flatten();
        // The union of the boxes of `ls`; `None` if one has none (or no literal).
        let union = |ls: Vec<&Lit>| {
            let boxes: Option<Vec<ScreenBox>> = ls.into_iter().map(screen).collect();
            boxes?.into_iter().reduce(|a, b| a.union(&b))
        };
        let touched = union(p.iter().collect())?;
        let occupied = union(p.iter().filter(|l| !l.negated).collect())?;
        Some(Footprint { touched, occupied })
    }

    /// Whether neither product touches what the other occupies.
    pub fn apart(&self, o: &Footprint) -> bool {
        self.touched.apart(&o.occupied) && o.touched.apart(&self.occupied)
    }
}

/// The SCS products grouped side by side: each group's leader (its first
/// product in plan order), target and members.
pub(super) struct Groups<'a> {
    by_leader: HashMap<usize, (Target, Vec<(usize, &'a Sequence)>)>,
}

impl<'a> Groups<'a> {
    /// The group product `i` leads, if it leads one (a member that does not
    /// lead is drawn with its leader).
    pub(super) fn led_by(&self, i: usize) -> Option<(Target, &[(usize, &'a Sequence)])> {
        self.by_leader.get(&i).map(|(t, m)| (*t, m.as_slice()))
    }
}

/// Groups the SCS products `scs` (index into `prods` and subtraction
/// sequence, in plan order): `in_place`, drawn in the output, with every
/// later product apart from the group that may be drawn there too; the
/// others first fit into groups of products of one positive primitive,
/// pairwise apart; any other product alone.
pub(super) fn groups<'a>(
    prods: &[Vec<Lit>],
    scs: &'a [(usize, Sequence)],
    in_place: Option<usize>,
    prep: &Prepared,
) -> Groups<'a> {
    struct Open<'a> {
        target: Target,
        members: Vec<(usize, &'a Sequence)>,
        prints: Vec<Footprint>,
    }
    let mut groups: Vec<Open> = Vec::new();
    let fits = |g: &Open, f: &Option<Footprint>| {
        let Some(f) = f else { return false };
        g.prints.len() == g.members.len() && g.prints.iter().all(|o| o.apart(f))
    };
    for (i, seq) in scs {
        let p = &prods[*i];
        let print = seq
            .rounds
            .is_empty()
            .then(|| Footprint::of(p, prep))
            .flatten();
        let back_faces = back_face_clip_applies(p, prep);
        let positives = p.iter().filter(|l| !l.negated).count();
        let target = match (Some(*i) == in_place, groups.first()) {
            (true, _) => Target::Output,
            (false, Some(g)) if g.target == Target::Output && back_faces && fits(g, &print) => {
                Target::Output
            }
            _ => Target::Surface,
        };
        let joins = match target {
            Target::Output if Some(*i) == in_place => None,
            Target::Output => Some(0),
            Target::Surface if positives == 1 && back_faces => groups
                .iter()
                .position(|g| g.target == Target::Surface && fits(g, &print)),
            Target::Surface => None,
        };
        // A group whose members all have footprints takes more (`fits`).
        let batchable = positives == 1 || target == Target::Output;
        let prints = print.filter(|_| batchable && back_faces).into_iter();
        match joins {
            Some(g) => {
                groups[g].members.push((*i, seq));
                groups[g].prints.extend(prints);
            }
            None => groups.push(Open {
                target,
                members: vec![(*i, seq)],
                prints: prints.collect(),
            }),
        }
    }
    Groups {
        by_leader: groups
            .into_iter()
            .map(|g| (g.members[0].0, (g.target, g.members)))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use glam::{DVec2, DVec3};

    use super::*;
    use crate::plan::goldfeather::{OUTPUT, SURFACE};
    use crate::plan::step::{Draw, Scissor};
    use crate::plan::{scs, Prepared};
    use crate::scene::fixtures::ExprBuilder;
    use crate::scene::Aabb;

    /// `(0 − 1) ∪ (2 − 3) ∪ … ∪ (2n−2 − 2n−1)`: boxes with cutters, far apart
    /// in the world; `screen` gives each product's box on screen (the
    /// cutter's 2 pixels wider on the right).
    fn products(screen: &[(f64, f64)]) -> Prepared {
        let n = screen.len() as u32;
        let mut e = ExprBuilder::default();
        let mut acc = None;
        let mut bounds = Vec::new();
        for k in 0..n {
            let (x, c) = (e.leaf(2 * k), e.leaf(2 * k + 1));
            let d = e.diff(x, c);
            acc = Some(acc.map_or(d, |a| e.union(a, d)));
            let at = DVec3::new(10.0 * k as f64, 0.0, 0.0);
            let b = Aabb {
                min: at - DVec3::ONE,
                max: at + DVec3::ONE,
            };
            bounds.extend([b, b]);
        }
        let mut prep =
            Prepared::from_parts(e.build(acc.unwrap()), vec![12; 2 * n as usize], bounds);
        prep.mesh_convex = vec![true; 2 * n as usize];
        prep.screen = screen
            .iter()
            .flat_map(|&(x0, x1)| {
                let b = |x1| ScreenBox {
                    lo: DVec2::new(x0, 0.0),
                    hi: DVec2::new(x1, 10.0),
                };
                [Some(b(x1)), Some(b(x1 + 2.0))]
            })
            .collect();
        prep
    }

    /// Per `scs-front` pass, the meshes and images of its front draws.
    fn fronts(prep: &Prepared) -> Vec<Vec<(u32, u8)>> {
        let plan = scs::plan(prep, &Default::default()).unwrap();
        let mut out: Vec<Vec<(u32, u8)>> = Vec::new();
        let mut on = false;
        for s in &plan.steps {
            match s {
                Step::Pass(n) => {
                    on = n == "scs-front";
                    if on {
                        out.push(Vec::new());
                    }
                }
                Step::Draw(Draw { geometry, ds, .. }) if on => {
                    out.last_mut().unwrap().push((geometry.meshes()[0], *ds))
                }
                _ => {}
            }
        }
        out
    }

    #[test]
    fn products_apart_on_screen_are_drawn_in_the_output_side_by_side() {
        let prep = products(&[(0.0, 10.0), (20.0, 30.0), (40.0, 50.0)]);
        assert_eq!(
            fronts(&prep),
            vec![vec![(0, OUTPUT), (2, OUTPUT), (4, OUTPUT)]]
        );
        let plan = scs::plan(&prep, &Default::default()).unwrap();
        // No surface image; one texture clear, one pass per phase.
        assert_eq!(plan.depth_stencils, 1);
        let count = |f: &dyn Fn(&Step) -> bool| plan.steps.iter().filter(|s| f(s)).count();
        assert_eq!(count(&|s| matches!(s, Step::Clear(_))), 2 + 1);
        for name in ["scs-front", "subtract", "clip"] {
            assert_eq!(count(&|s| matches!(s, Step::Pass(n) if n == name)), 1);
        }
        // Each product's clip (its positive's back faces and footprint) only
        // where its cutter may have moved `z`.
        let clips: Vec<&Scissor> = plan
            .steps
            .iter()
            .filter_map(|s| match s {
                Step::Draw(d)
                    if d.stencil.is_some_and(|s| s.write_mask == 1)
                        && d.ds == OUTPUT
                        && d.geometry.meshes()[0] % 2 == 0 =>
                {
                    Some(&d.scissor)
                }
                _ => None,
            })
            .collect();
        for k in 0..3u32 {
            // Cut as the cutter's exits are (`scs::clip_cut`).
            let moved = Scissor::Openings {
                of: 2 * k + 1,
                and: vec![2 * k],
            };
            assert_eq!(clips.iter().filter(|&&s| *s == moved).count(), 2);
        }
    }

    #[test]
    fn pixels_closer_than_the_margin_keep_products_apart() {
        // Product 1's cutter reaches to 2 pixels short of product 2 (its
        // positive primitive does not): not apart. Product 0 is.
        let prep = products(&[(0.0, 10.0), (20.0, 30.0), (33.5, 50.0)]);
        assert_eq!(
            fronts(&prep),
            vec![vec![(0, OUTPUT), (2, OUTPUT)], vec![(4, SURFACE)]]
        );
        // A cutter 2 pixels or more away: apart.
        let prep = products(&[(0.0, 10.0), (20.0, 30.0), (34.0, 50.0)]);
        assert_eq!(fronts(&prep).len(), 1);
    }

    #[test]
    fn products_overlapping_the_first_share_the_surface_image_when_apart() {
        // Product 0 overlaps every other; 1 and 3 are apart, 2 overlaps 1.
        let prep = products(&[(0.0, 100.0), (10.0, 20.0), (15.0, 25.0), (40.0, 50.0)]);
        assert_eq!(
            fronts(&prep),
            vec![
                vec![(0, OUTPUT)],
                vec![(2, SURFACE), (6, SURFACE)],
                vec![(4, SURFACE)]
            ]
        );
        // One clear of the surface image and one merge pass for 1 and 3.
        let plan = scs::plan(&prep, &Default::default()).unwrap();
        let clears = plan
            .steps
            .iter()
            .filter(|s| {
                matches!(
                    s,
                    Step::Clear(crate::plan::Clear::DepthStencil { ds: 1, .. })
                )
            })
            .count();
        assert_eq!(clears, 2);
    }

    #[test]
    fn without_screen_boxes_every_product_is_alone() {
        let mut prep = products(&[(0.0, 10.0), (20.0, 30.0)]);
        prep.screen.clear();
        assert_eq!(fronts(&prep), vec![vec![(0, OUTPUT)], vec![(2, SURFACE)]]);
        // A primitive reaching the near plane (no box) keeps its product alone.
        let mut prep = products(&[(0.0, 10.0), (20.0, 30.0)]);
        prep.screen[3] = None;
        assert_eq!(fronts(&prep).len(), 2);
    }
}
