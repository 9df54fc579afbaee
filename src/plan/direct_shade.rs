//! One-primitive products shaded in their own draw (OpenCSG draws a
//! product of one primitive once, with colour). The plans draw such a product
//! depth-only into the output depth (`goldfeather::direct_steps`: `Less` and
//! write, its visible faces) and shade it again in the final shade
//! ([`super::tie::shade_near_depth`]). Where it is safe, the executor records
//! the direct draw with the shading program, colour and primitive id written
//! with its depth, and drops the mesh's draw from the final shade.
//!
//! Why that gives the old image: every pixel's final depth is some face's, and
//! its colour is written by the draw of whoever owns that face.
//! - Where the direct mesh `m` owns the final depth, its direct draw wrote it,
//!   and colour and id with it; nothing written after it touches colour there.
//! - Where a later step made the pixel nearer, the new owner's draw colours it:
//!   its own direct draw, or its final-shade draw, which runs after.
//!
//! It holds when ([`DirectShades::decide`]):
//! - `m` is drawn exactly twice in the frame: the direct draw and one draw of
//!   the final shade, not stencil-tested. Any other draw of `m` (a literal of
//!   another product, a cutter) could write `m`'s face depth before the
//!   direct draw, whose `Less` test would then fail and leave the pixel
//!   uncoloured; loops count their body twice, so a mesh drawn in one never
//!   qualifies.
//! - Its shade draw runs depth-`EQUAL` over its whole rectangle (`plan::tie_free`:
//!   no face of another mesh within the tie band of `m`'s, no tie zone on
//!   screen). Where `m` could tie, the tie rule's winner (the lowest index,
//!   drawn last) would be decided by the order of the `Less` tests instead.
//! - After the direct draw, no step clears the output depth or the colour
//!   targets, writes colour, ids or normals (but the final shade's draws of
//!   other meshes, which pass only on their own faces), reads them, or writes
//!   the output depth with a test that lets it move away from the eye (a
//!   full-screen sweep resetting rejected pixels to far, as SCS's in-place
//!   clip does, would leave `m`'s colour on a background pixel). `Less`,
//!   `LessOrEqual`, `Equal` and `Never` tests only bring it nearer.
//!
//! The loop-by-loop frame records its steps in pieces and keeps the old path
//! (the executor never asks this module there). The embedding's host shade
//! draws into the host's targets after the frame, so it keeps the direct draw
//! depth-only and the shade draw, but takes the same decision: a chosen
//! product's shade draw needs no check of the output depth there
//! (`vk::exec::record::host`), since no face of it lies nearer than that depth
//! (the conditions above: its direct draw wrote its nearest face's depth and
//! nothing after it moved the output depth farther).
#![deny(unsafe_code)]

use std::collections::BTreeMap;

use super::step::*;
use super::usage::Resource;

/// The meshes whose direct draw shades in a frame (sorted), and the output
/// depth-stencil image of that frame.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct DirectShades {
    meshes: Vec<MeshId>,
    output_ds: Ds,
}

impl DirectShades {
    /// No direct draw shades: every step is recorded as planned.
    pub fn none() -> DirectShades {
        DirectShades::default()
    }

    /// The meshes whose direct draw shades.
    #[cfg(test)]
    pub fn meshes(&self) -> &[MeshId] {
        &self.meshes
    }

    /// Which direct draws of a frame's `steps` (loops unrolled, or each loop's
    /// body taken as repeated) shade, for the output depth-stencil image
    /// `output_ds`; `depth_equal(m, eps)`: whether the final shade's draw of
    /// mesh `m` at tolerance `eps` runs depth-`EQUAL` over its whole rectangle
    /// (module doc).
    pub fn decide(
        steps: &[&Step],
        output_ds: Ds,
        depth_equal: impl Fn(MeshId, f32) -> bool,
    ) -> DirectShades {
        let mut leaves = Vec::with_capacity(steps.len());
        for s in steps {
            flatten(s, 1, &mut leaves);
        }
        let Some((copy, shade)) = final_shade(&leaves, output_ds) else {
            return DirectShades::none();
        };
        // Draws of each mesh, anywhere in the frame.
        let mut drawn: BTreeMap<MeshId, u32> = BTreeMap::new();
        for (s, times) in &leaves {
            if let Step::Draw(d) = s {
                for m in d.geometry.meshes() {
                    *drawn.entry(*m).or_default() += times;
                }
            }
        }
        // The last step after which a direct draw may not shade.
        let in_shade = |j: usize| j == copy || shade.contains(&j);
        let last_spoiler = leaves
            .iter()
            .enumerate()
            .rev()
            .find(|(j, (s, _))| !in_shade(*j) && spoils(s, output_ds))
            .map(|(j, _)| j);
        let mut meshes: Vec<MeshId> = leaves[..copy]
            .iter()
            .enumerate()
            .filter(|(i, _)| last_spoiler.is_none_or(|l| *i > l))
            .filter_map(|(_, (s, _))| match s {
                Step::Draw(d) => direct_mesh(d, output_ds),
                _ => None,
            })
            .filter(|m| drawn.get(m) == Some(&2))
            .filter(|&m| {
                shade.iter().any(|&j| match leaves[j].0 {
                    Step::Draw(d) => {
                        d.geometry == Geometry::Mesh(m)
                            && d.stencil.is_none()
                            && shade_eps(d).is_some_and(|eps| depth_equal(m, eps))
                    }
                    _ => false,
                })
            })
            .collect();
        meshes.sort_unstable();
        meshes.dedup();
        DirectShades { meshes, output_ds }
    }

    /// A chosen direct draw as recorded: the shading program (colour and
    /// primitive id) with its depth test, culling and scissor; `None` for
    /// every other draw.
    pub fn shaded(&self, draw: &Draw) -> Option<Draw> {
        let m = direct_mesh(draw, self.output_ds)?;
        self.meshes.binary_search(&m).ok()?;
        Some(Draw {
            fragment: Fragment::Shade,
            ..draw.clone()
        })
    }

    /// Whether `draw` is the final shade's draw of a mesh whose direct draw
    /// shades: not recorded.
    pub fn drops(&self, draw: &Draw) -> bool {
        match (&draw.geometry, shade_eps(draw)) {
            (Geometry::Mesh(m), Some(_)) if draw.ds == self.output_ds => {
                self.meshes.binary_search(m).is_ok()
            }
            _ => false,
        }
    }
}

/// The leaves of `step` with how often each runs at most (loops: their body
/// twice, standing for "more than once").
fn flatten<'a>(step: &'a Step, times: u32, out: &mut Vec<(&'a Step, u32)>) {
    match step {
        Step::Loop(l) => {
            for s in l.head.iter().chain(&l.tail) {
                flatten(s, 2 * times, out);
            }
        }
        s => out.push((s, times)),
    }
}

/// The mesh of a direct draw (`goldfeather::direct_steps`): one mesh into the
/// output depth, `Less` and written, depth only, no stencil, not counted.
fn direct_mesh(d: &Draw, output_ds: Ds) -> Option<MeshId> {
    let less = DepthState {
        compare: CompareOp::Less,
        write: true,
    };
    match d.geometry {
        Geometry::Mesh(m)
            if d.ds == output_ds
                && d.depth == less
                && d.stencil.is_none()
                && d.fragment == Fragment::None
                && !d.count_samples =>
        {
            Some(m)
        }
        _ => None,
    }
}

/// The tolerance of a final shade's draw (`plan::tie::shade_near_depth`:
/// `Always` and written, the tie test in the shader).
fn shade_eps(d: &Draw) -> Option<f32> {
    let always = DepthState {
        compare: CompareOp::Always,
        write: true,
    };
    match d.fragment {
        Fragment::ShadeNearDepth { eps, .. } if d.depth == always => Some(eps),
        _ => None,
    }
}

/// The frame's final shade into `output_ds`: the index of its depth copy and
/// those of its draws (the last copy of the output depth followed by final
/// shade draws reading it).
fn final_shade(leaves: &[(&Step, u32)], output_ds: Ds) -> Option<(usize, Vec<usize>)> {
    (0..leaves.len()).rev().find_map(|c| {
        let Step::CopyDepthToTexture { ds, dst } = leaves[c].0 else {
            return None;
        };
        if *ds != output_ds || leaves[c].1 != 1 {
            return None;
        }
        let draws: Vec<usize> = (c + 1..leaves.len())
            .take_while(|&j| match leaves[j].0 {
                Step::Draw(d) => {
                    d.ds == output_ds
                        && shade_eps(d).is_some()
                        && matches!(d.fragment, Fragment::ShadeNearDepth { tex, .. } if tex == *dst)
                }
                _ => false,
            })
            .collect();
        (!draws.is_empty()).then_some((c, draws))
    })
}

/// Whether `step`, after a direct draw, could leave that draw's colour where
/// the mesh no longer owns the depth, or read it (module doc).
fn spoils(step: &Step, output_ds: Ds) -> bool {
    let outputs = [Resource::Color, Resource::Prim, Resource::Normal];
    match step {
        Step::Clear(Clear::Color) => true,
        Step::Clear(Clear::DepthStencil { ds, .. }) => *ds == output_ds,
        Step::Draw(d) => {
            let colour = step.usage().iter().any(|(r, _)| outputs.contains(r));
            let farther = d.ds == output_ds
                && d.depth.write
                && !matches!(
                    d.depth.compare,
                    CompareOp::Less | CompareOp::LessOrEqual | CompareOp::Equal | CompareOp::Never
                );
            colour || farther
        }
        Step::Loop(_) => unreachable!("loops are flattened"),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::super::{shade_near_depth, VisibleSides};
    use super::*;

    fn direct(m: MeshId) -> Step {
        super::super::goldfeather::direct_steps(
            &[super::super::goldfeather::Lit {
                prim: m,
                negated: false,
            }],
            &super::super::Prepared::from_parts(
                crate::csg::Expr {
                    nodes: vec![crate::csg::Node::Leaf { prim: m }],
                    root: 0,
                },
                vec![12; m as usize + 1],
                vec![crate::geom::bounds(&[]); m as usize + 1],
            ),
        )
        .expect("a one-primitive product is drawn directly")
        .pop()
        .expect("its draw")
    }

    /// A product's merge into the output depth (`goldfeather::merge_steps`).
    fn merge() -> Step {
        let mut d = match Draw::for_test(
            Geometry::FullScreen { depth: 1.0 },
            Fragment::DepthFromTexture { src: 0 },
        ) {
            Step::Draw(d) => d,
            _ => unreachable!(),
        };
        d.scissor = Scissor::BoundsOf(vec![0]);
        Step::Draw(d)
    }

    /// SCS's in-place clip sweep: rejected pixels back to far.
    fn sweep_to_far() -> Step {
        let mut s = merge();
        if let Step::Draw(d) = &mut s {
            d.fragment = Fragment::None;
            d.depth.compare = CompareOp::Always;
        }
        s
    }

    /// `before`, then the final shade of `shaded` (descending, as planned).
    fn frame(before: Vec<Step>, shaded: &[MeshId]) -> Vec<Step> {
        let mut steps = before;
        steps.extend(shade_near_depth(shaded, 0, 0, None, &VisibleSides::none()));
        steps
    }

    fn decide(steps: &[Step], free: &[MeshId]) -> Vec<MeshId> {
        let refs: Vec<&Step> = steps.iter().collect();
        DirectShades::decide(&refs, 0, |m, eps| {
            assert_eq!(eps, super::super::SHADE_EPS);
            free.contains(&m)
        })
        .meshes
    }

    #[test]
    fn a_direct_draw_of_a_tie_free_mesh_shades_and_its_shade_draw_goes() {
        let steps = frame(vec![direct(3)], &[3]);
        let refs: Vec<&Step> = steps.iter().collect();
        let d = DirectShades::decide(&refs, 0, |_, _| true);
        assert_eq!(d.meshes(), &[3]);
        let Step::Draw(draw) = &steps[0] else {
            unreachable!()
        };
        let shaded = d.shaded(draw).expect("the direct draw shades");
        assert_eq!(shaded.fragment, Fragment::Shade);
        assert_eq!(
            (shaded.depth, shaded.cull, &shaded.scissor),
            (draw.depth, draw.cull, &draw.scissor)
        );
        let Step::Draw(shade) = steps.last().unwrap() else {
            unreachable!()
        };
        assert!(d.drops(shade));
        assert!(!d.drops(draw));
        // Nothing decided: nothing changes.
        assert_eq!(DirectShades::none().shaded(draw), None);
        assert!(!DirectShades::none().drops(shade));
    }

    #[test]
    fn a_mesh_that_may_tie_keeps_its_shade_draw() {
        let steps = frame(vec![direct(0), direct(1)], &[0, 1]);
        assert_eq!(decide(&steps, &[1]), vec![1]);
        assert_eq!(decide(&steps, &[]), Vec::<MeshId>::new());
    }

    #[test]
    fn merges_after_a_direct_draw_leave_it_shading_and_sweeps_to_far_do_not() {
        // Other products merged after it only bring pixels nearer; their
        // meshes' shade draws colour those.
        let steps = frame(vec![direct(1), merge(), direct(2)], &[0, 1, 2]);
        assert_eq!(decide(&steps, &[0, 1, 2]), vec![1, 2]);
        // A sweep to far after it would leave its colour on background.
        let steps = frame(vec![direct(1), sweep_to_far(), direct(2)], &[1, 2]);
        assert_eq!(decide(&steps, &[1, 2]), vec![2]);
        // Before it, a sweep is harmless.
        let steps = frame(vec![sweep_to_far(), direct(1)], &[1]);
        assert_eq!(decide(&steps, &[1]), vec![1]);
    }

    #[test]
    fn colour_writes_or_clears_after_a_direct_draw_keep_the_old_path() {
        let mut paint = direct(0);
        if let Step::Draw(d) = &mut paint {
            d.fragment = Fragment::Background;
            d.geometry = Geometry::FullScreen { depth: 1.0 };
        }
        let steps = frame(vec![direct(1), paint], &[1]);
        assert_eq!(decide(&steps, &[1]), Vec::<MeshId>::new());
        let steps = frame(vec![direct(1), Step::Clear(Clear::Color)], &[1]);
        assert_eq!(decide(&steps, &[1]), Vec::<MeshId>::new());
        let clear = Step::Clear(Clear::DepthStencil {
            ds: 0,
            depth: 1.0,
            stencil: 0,
        });
        let steps = frame(vec![direct(1), clear], &[1]);
        assert_eq!(decide(&steps, &[1]), Vec::<MeshId>::new());
        // Another image's clear does not matter.
        let other = Step::Clear(Clear::DepthStencil {
            ds: 1,
            depth: 1.0,
            stencil: 0,
        });
        let steps = frame(vec![direct(1), other], &[1]);
        assert_eq!(decide(&steps, &[1]), vec![1]);
    }

    #[test]
    fn a_mesh_drawn_anywhere_else_keeps_the_old_path() {
        // Mesh 1 is also a literal of another product (its surface draw):
        // that product's merge may write 1's face depth before the direct
        // draw, whose `Less` test would then fail there.
        let mut surface = direct(1);
        if let Step::Draw(d) = &mut surface {
            d.ds = 1;
            d.fragment = Fragment::WriteDepth { out: 0 };
        }
        let steps = frame(vec![surface, merge(), direct(1), direct(2)], &[1, 2]);
        assert_eq!(decide(&steps, &[1, 2]), vec![2]);
        // Drawn in a loop: more than once.
        let looped = Step::Loop(Loop {
            head: vec![direct(1)],
            tail: vec![],
            max_iterations: 3,
        });
        let steps = frame(vec![looped], &[1]);
        assert_eq!(decide(&steps, &[1]), Vec::<MeshId>::new());
        // Not in the final shade, or shaded under a stencil test.
        let steps = frame(vec![direct(1)], &[2]);
        assert_eq!(decide(&steps, &[1, 2]), Vec::<MeshId>::new());
        let mut steps = frame(vec![direct(1)], &[1]);
        if let Some(Step::Draw(d)) = steps.last_mut() {
            d.stencil = Some(crate::plan::stencil::test_equal(1, 1));
        }
        assert_eq!(decide(&steps, &[1]), Vec::<MeshId>::new());
    }

    #[test]
    fn without_a_final_shade_nothing_shades_directly() {
        let steps = vec![direct(1)];
        assert_eq!(decide(&steps, &[1]), Vec::<MeshId>::new());
        // A direct draw into another image than the output is not one.
        let steps = frame(vec![direct(1)], &[1]);
        let refs: Vec<&Step> = steps.iter().collect();
        assert!(DirectShades::decide(&refs, 1, |_, _| true)
            .meshes
            .is_empty());
    }
}
