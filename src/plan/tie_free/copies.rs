//! What the depth copy opening a final shade must cover once its draws are
//! lowered ([module doc](super), docs/executor.md): the meshes that keep the tie
//! rule, cut to their zones, or nothing (no pass whose result nobody reads).

use super::super::rect::Rect;
use super::super::step::*;
use super::TieFree;

impl TieFree {
    /// For every [`Step::CopyDepthToTexture`] of `steps`, in order, what it must
    /// cover once the final shades' draws are rewritten by
    /// [`TieFree::fixed_function`].
    pub fn shade_copies(&self, steps: &[&Step]) -> Vec<ShadeCopy> {
        let mut out = Vec::new();
        for (i, s) in steps.iter().enumerate() {
            let Step::CopyDepthToTexture { ds, dst } = s else {
                continue;
            };
            let group: Vec<&Draw> = steps[i + 1..]
                .iter()
                .map_while(|s| match s {
                    Step::Draw(d) => match d.fragment {
                        Fragment::ShadeNearDepth { tex, .. } if tex == *dst && d.ds == *ds => {
                            Some(d)
                        }
                        _ => None,
                    },
                    _ => None,
                })
                .collect();
            let after = &steps[i + 1 + group.len()..];
            if group.is_empty() || after.iter().any(|s| samples(s, *dst)) {
                out.push(ShadeCopy::AsPlanned);
                continue;
            }
            let mut rule: Vec<(MeshId, Option<Vec<Rect>>)> = group
                .into_iter()
                .filter(|d| self.fixed_function(d).is_none())
                .flat_map(|d| {
                    let zones = self.shade_zones(d).map(<[Rect]>::to_vec);
                    match &d.geometry {
                        Geometry::Mesh(m) => vec![(*m, zones)],
                        Geometry::Meshes(ms) => ms.iter().map(|&m| (m, None)).collect(),
                        Geometry::FullScreen { .. } | Geometry::Footprint { .. } => {
                            panic!("a final shade draws meshes (plan::tie::shade_near_depth)")
                        }
                    }
                })
                .collect();
            rule.sort_unstable_by_key(|r| r.0);
            out.push(ShadeCopy::ReadBy(rule));
        }
        out
    }
}

/// What a depth copy must cover ([`TieFree::shade_copies`]).
#[derive(Clone, Debug, PartialEq)]
pub enum ShadeCopy {
    /// The whole image, as planned: not the copy opening a final shade, or one
    /// whose texture a later step reads.
    AsPlanned,
    /// The copy opening a final shade, read by nothing but the shade's draws of
    /// these meshes, which keep the tie rule: the screen bounds of these meshes,
    /// each cut to its rule rectangles where it has them
    /// ([`TieFree::shade_zones`]; `None`: its whole rectangle), with the tie
    /// test's neighbour fetches. None: nobody reads the copy.
    ReadBy(Vec<(MeshId, Option<Vec<Rect>>)>),
}

/// Whether `step` (or a loop's body) reads texture `tex`.
fn samples(step: &Step, tex: Tex) -> bool {
    match step {
        Step::Loop(l) => l.head.iter().chain(&l.tail).any(|s| samples(s, tex)),
        s => s
            .usage()
            .iter()
            .any(|&(r, u)| r == super::super::usage::Resource::Texture(tex) && !u.writes()),
    }
}

#[cfg(test)]
mod tests {
    use super::super::super::testing::{half_free, parity, refs, shaded};
    use super::super::super::SHADE_EPS;
    use super::*;

    #[test]
    fn the_shade_copy_reaches_the_rule_meshes_or_nothing() {
        let plan = shaded(Vec::new(), &[0, 1]);
        assert_eq!(
            half_free(&plan).shade_copies(&refs(&plan)),
            vec![ShadeCopy::ReadBy(vec![(1, None)])]
        );
        // Every draw depth-equal: nobody reads the copy.
        let plan = shaded(Vec::new(), &[0]);
        assert_eq!(
            half_free(&plan).shade_copies(&refs(&plan)),
            vec![ShadeCopy::ReadBy(vec![])]
        );
        // Nothing decided: every mesh keeps the rule.
        assert_eq!(
            TieFree::none().shade_copies(&refs(&plan)),
            vec![ShadeCopy::ReadBy(vec![(0, None)])]
        );
        // A copy read by something else (CST layers' floor), or whose texture
        // a later step reads, stays as planned.
        let floor = Step::CopyDepthToTexture { ds: 0, dst: 1 };
        let mut plan = shaded(vec![floor.clone(), Step::Pass("x".into()), floor], &[0]);
        plan.steps.push(parity(0, SHADE_EPS));
        assert_eq!(
            half_free(&plan).shade_copies(&refs(&plan)),
            vec![
                ShadeCopy::AsPlanned,
                ShadeCopy::AsPlanned,
                ShadeCopy::AsPlanned
            ]
        );
    }
}
