//! Which side of each primitive's boundary can be the visible surface of the
//! solid: the faces the final shade's depth-equal draws may cull (less work
//! per algorithm; Stewart, Leach & John §3.4 for one product, here for
//! the whole expression).
//!
//! In the positive form (complements pushed to the leaves, `csg::positive`) a
//! primitive that occurs only as a positive literal is a monotone argument of
//! the solid's membership: leaving it can never take a point from outside the
//! solid to inside. The visible point is where a ray from the eye first goes
//! from outside to inside (after the near plane, `reference::raycast` step 3),
//! so a crossing where such a primitive is left, one of its back faces (the
//! meshes are closed and wound outward: `scene::validate`, and a mirroring
//! transform reverses the winding, `scene::shapes::apply_transform`), is
//! visible only where another face crosses the ray at the same point. A
//! primitive that occurs only complemented is the mirror case: only its back
//! faces can be visible. Whether the eye lies inside a primitive changes
//! nothing: the crossings along the ray are the same, only the parity counted
//! from the near plane is inverted (`Prepared::classified`).
//!
//! "At the same point" is the tie rule's business: a culled face coincident
//! with the visible one may be the lowest index there (`(A - C) + B` with A's
//! back face on B's front face shows A). So only draws that cannot tie cull
//! ([`super::tie_free`]: a depth-equal draw passes only at its own face's
//! raster depth, and a tie-free mesh has no parallel face of another mesh
//! within the tie band). A tie-rule draw culls too where its mesh can never
//! be that lowest index ([`rule_may_cull`]).

use super::step::Cull;
use super::{MeshId, Prepared};
use crate::geom::ties::TieGaps;

/// Whether the tie-rule draws of mesh `m` at a band of `band` world units may
/// cull its faces that are never visible: every other mesh with a face
/// parallel to one of `m`'s within the band has a lower index.
///
/// Why: where a culled face lies on the visible point, some face there crosses
/// the ray the other way (leaving `m` alone can only take a point out of the
/// solid: [module doc](self)). If that face is `m`'s own, `m` is drawn there
/// anyway; otherwise it belongs to a mesh whose face is parallel and within
/// the band, so of a lower index, which wins over `m` both in the reference
/// (the lowest index wins) and in the shade (drawn after `m`, in descending order).
/// The same holds for any face within the tie band of the visible one, so
/// culling changes no pixel of the rule draws. Pairs of one mesh's own faces
/// do not count: they give `m`'s id whichever face is drawn.
pub fn rule_may_cull(gaps: &TieGaps, m: MeshId, band: f64) -> bool {
    let known = band.is_finite() && band <= gaps.cap;
    known
        && gaps
            .pairs
            .iter()
            .all(|&(a, b, gap)| !(a == m && b > m && gap <= band))
}

/// Per mesh, the faces the final shade's depth-equal draws may cull: never
/// visible on the solid (or on one stream of its layers).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VisibleSides {
    /// Indexed by mesh; a mesh past the end culls nothing.
    cull: Vec<Cull>,
}

impl VisibleSides {
    /// The sides of the solid's visible surface, where rays enter it: a
    /// primitive named only positively shows its front faces ([`Cull::Back`]),
    /// one named only complemented its back faces ([`Cull::Front`]), one named
    /// both ways (or not at all) either.
    pub fn entries(prep: &Prepared) -> VisibleSides {
        let mut cull: Vec<Option<Cull>> = Vec::new();
        if prep.has_solid() {
            for lit in prep.positive.nodes.iter().filter_map(|n| n.literal()) {
                let i = lit.prim as usize;
                if cull.len() <= i {
                    cull.resize(i + 1, None);
                }
                let side = if lit.negated { Cull::Front } else { Cull::Back };
                cull[i] = match cull[i] {
                    None => Some(side),
                    Some(c) if c == side => Some(c),
                    Some(_) => Some(Cull::None),
                };
            }
        }
        VisibleSides {
            cull: cull.into_iter().map(|c| c.unwrap_or(Cull::None)).collect(),
        }
    }

    /// Nothing culled: every face may be visible (a layer of both streams).
    pub fn none() -> VisibleSides {
        VisibleSides::default()
    }

    /// The sides where rays leave the solid (the exit stream of its layers,
    /// Hable & Rossignac §6): the opposite of [`VisibleSides::entries`].
    pub fn exits(&self) -> VisibleSides {
        let flip = |c: &Cull| match c {
            Cull::Back => Cull::Front,
            Cull::Front => Cull::Back,
            Cull::None => Cull::None,
        };
        VisibleSides {
            cull: self.cull.iter().map(flip).collect(),
        }
    }

    /// The faces of mesh `m` that are never visible.
    pub fn cull(&self, m: MeshId) -> Cull {
        self.cull.get(m as usize).copied().unwrap_or(Cull::None)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::shapes::{apply_transform, make_box, transform};
    use glam::DVec3;

    fn prepared(expr: &str, prims: u32) -> Prepared {
        crate::plan::cst::tests::prepared(expr, prims, 12)
    }

    fn sides(expr: &str, prims: u32) -> Vec<Cull> {
        let s = VisibleSides::entries(&prepared(expr, prims));
        (0..prims + 1).map(|m| s.cull(m)).collect()
    }

    #[test]
    fn positive_primitives_show_front_faces_and_subtracted_ones_back_faces() {
        use Cull::{Back, Front, None};
        // P3 is not named: nothing known, nothing culled (nor past the end).
        assert_eq!(
            sides("(P0 * P1) - P2", 4),
            vec![Back, Back, Front, None, None]
        );
        // A double complement is positive again; a complemented difference
        // makes its subtrahend positive.
        assert_eq!(sides("!!P0 - !(P1 - P2)", 3), vec![Back, Back, Front, None]);
        assert_eq!(sides("!(P0 + P1) * P2", 3), vec![Front, Front, Back, None]);
    }

    #[test]
    fn a_primitive_named_both_ways_culls_nothing() {
        use Cull::{Back, Front, None};
        // Exclusive or: both primitives both ways.
        assert_eq!(sides("(P0 - P1) + (P1 - P0)", 2), vec![None, None, None]);
        // P1 subtracted in one solid part, intersected in another.
        assert_eq!(
            sides("(P0 - P1) + (P2 * P1)", 3),
            vec![Back, None, Back, None]
        );
        assert_eq!(sides("P0 - P1 - P1", 2), vec![Back, Front, None]);
    }

    #[test]
    fn exits_are_the_other_side_and_none_culls_nothing() {
        let s = VisibleSides::entries(&prepared("(P0 - P1) + (P1 - P2) + P3", 4));
        let exits = s.exits();
        let got: Vec<(Cull, Cull)> = (0..4).map(|m| (s.cull(m), exits.cull(m))).collect();
        assert_eq!(
            got,
            vec![
                (Cull::Back, Cull::Front),
                (Cull::None, Cull::None),
                (Cull::Front, Cull::Back),
                (Cull::Back, Cull::Front)
            ]
        );
        assert_eq!(VisibleSides::none().cull(0), Cull::None);
    }

    #[test]
    fn rule_draws_cull_only_where_every_tie_partner_has_a_lower_index() {
        // 0 ties 1 at 0; 1 has opposite faces of its own at 0 and ties 2 at 0.5;
        // 3 ties nothing.
        let gaps = TieGaps {
            min_gap: vec![0.0, 0.0, 0.5, f64::INFINITY],
            cap: 1.0,
            pairs: vec![(0, 1, 0.0), (1, 1, 0.0), (1, 2, 0.5)],
            zones: vec![],
        };
        let may = |band| {
            (0..4)
                .map(|m| rule_may_cull(&gaps, m, band))
                .collect::<Vec<_>>()
        };
        assert_eq!(may(0.1), vec![false, true, true, true]);
        // A wider band reaches 1's higher partner 2.
        assert_eq!(may(0.6), vec![false, false, true, true]);
        // Beyond the analysis' reach nothing is known.
        assert_eq!(may(2.0), vec![false; 4]);
        assert!(!rule_may_cull(&TieGaps::unknown(4), 3, 1e-9));
    }

    /// The analysis names faces by their winding: a mirrored primitive must
    /// still wind its faces counter-clockwise seen from outside, so that the
    /// faces a positive literal keeps ([`Cull::Back`] culls the others) are the
    /// ones where a ray from outside enters it.
    #[test]
    fn a_mirrored_primitive_keeps_its_entry_faces_front_facing() {
        let mirror = transform(
            DVec3::new(-1.0, 2.0, 1.0),
            DVec3::new(10.0, 20.0, 30.0),
            DVec3::new(0.5, 0.0, -2.0),
        );
        assert!(mirror.determinant() < 0.0);
        let mesh = apply_transform(&make_box(DVec3::ONE), &mirror);
        let centre = mirror.transform_point3(DVec3::ZERO);
        let eye = centre + DVec3::new(3.0, 7.0, 11.0);
        let mut front = 0;
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            let normal = (b - a).cross(c - a);
            let mid = (a + b + c) / 3.0;
            // Counter-clockwise seen from outside: the winding's normal points
            // away from the (convex) box's centre.
            assert!(normal.dot(mid - centre) > 0.0, "inward triangle {t:?}");
            // So a face counter-clockwise seen from the eye (front-facing) is
            // one whose outside faces the eye: where the ray enters.
            front += (normal.dot(eye - mid) > 0.0) as u32;
        }
        // Three faces of a box face the eye: six of its twelve triangles.
        assert_eq!(front, 6);
        let s = VisibleSides::entries(&prepared("P0 - P1", 2));
        assert_eq!(
            s.cull(0),
            Cull::Back,
            "a positive primitive keeps front faces"
        );
    }
}
