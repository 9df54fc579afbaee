//! Which tie zones can hold a visible point of the solid: the final shade keeps
//! the tie rule only where it can choose the pixel's primitive (the lowest
//! index wins; docs/precision.md).
//!
//! A tie zone of meshes `a` and `b` (`geom::ties`) is where a face of each lies
//! within the tie band of the other. The rule picks the shaded primitive only
//! where the visible point lies on such faces: where the ray's crossing of them,
//! one event (the reference groups crossings closer than its tolerance,
//! `reference::raycast` step 2; the tolerant passes group those within the
//! band), takes it from outside the solid to inside (the visible point starts
//! an interval inside the solid, step 3). Across a zone of coincident faces
//! `a` and `b` change state together: faces facing opposite ways (a contact,
//! one solid on either side) swap "in `a`, out of `b`" for "out of `a`, in
//! `b`"; faces facing the same way take the ray from outside both to inside
//! both. Where the solid's membership is the same on both sides, whatever the
//! other primitives' states there, no interval of the solid starts in the
//! zone, from either side, and the zone is dropped: the final shade's
//! depth-equal draws then pass only where their own face is the visible one
//! (`plan::tie_free`), which is no face of the zone. Two stacked boxes of one
//! union (`Base + Upright`) touch on faces that are never visible, while the
//! flush tops of a box and the cylinder it is united with (`Slot + End`) are
//! the visible surface of the union, and a subtracted pair's flush caps are
//! visible where nothing positive surrounds them.
//!
//! The other primitives' states near the zone (its box, shrunk by [`SHRINK`] of
//! the scene's size along its extents: what lies outside the shrunk box is a
//! sliver along the zone's edge, as for faces that only touch, `geom::ties`):
//! outside where their box misses it or, for a convex primitive, where one of
//! its face planes has the whole box outside; inside where every plane has it
//! inside; otherwise both values are tried. A primitive with a tie zone of its
//! own near this one may have a face on the same event: its states before and
//! after are tried independently. Only zones of faces that coincide (a gap of
//! at most [`COINCIDENT`] of the scene's size) are dropped: faces a gap apart
//! are two events to the reference, with an interval between them.

use std::cell::OnceCell;

use glam::DVec3;

use super::convex::is_convex;
use crate::csg::expr::Expr;
use crate::geom::ties::{TieGaps, TieZone};
use crate::scene::{Aabb, Mesh};

/// A zone's box is shrunk by this fraction of the scene's diagonal along each
/// axis where it extends (module doc).
pub const SHRINK: f64 = 1e-6;

/// A box is outside (inside) a convex primitive's face plane only by more than
/// this fraction of the scene's diagonal: `plan::convex` accepts vertices up
/// to about 1e-9 of a mesh's size beyond its planes.
const MARGIN: f64 = 1e-8;

/// Zones whose gap is at most this fraction of the scene's diagonal are of
/// coincident faces (module doc).
pub const COINCIDENT: f64 = 1e-9;

/// The most unknown states tried per zone (a free primitive counts one, one
/// that may flip with the zone two): `2^MAX_UNKNOWNS` evaluations. Past it the
/// zone is kept.
pub const MAX_UNKNOWNS: usize = 12;

/// The gaps the final shade needs ([`TieGaps::with_zones`]): the zones of
/// `gaps` where the membership of one of `exprs` may change (module doc):
/// the union of the solids, whose visible surface the opaque shade shows, and
/// each solid, whose boundary the layers count on its own
/// (docs/transparency-and-blueprints.md). `prims`: how many meshes are primitives
/// (surfaces follow: their zones are kept). Without a solid, `gaps` as they are.
pub fn visible_ties(gaps: &TieGaps, meshes: &[&Mesh], exprs: &[Expr], prims: usize) -> TieGaps {
    if exprs.is_empty() {
        return gaps.clone();
    }
    let bounds: Vec<Aabb> = meshes
        .iter()
        .map(|m| crate::geom::bounds(&m.positions))
        .collect();
    let all = bounds.iter().fold(crate::geom::bounds(&[]), |a, b| Aabb {
        min: a.min.min(b.min),
        max: a.max.max(b.max),
    });
    let diag = (all.max - all.min).length();
    if !diag.is_finite() {
        return gaps.clone();
    }
    let mut named = vec![false; prims];
    for p in exprs.iter().flat_map(Expr::leaves) {
        if let Some(n) = named.get_mut(p as usize) {
            *n = true;
        }
    }
    let scene = Scene {
        meshes,
        bounds,
        planes: (0..meshes.len()).map(|_| OnceCell::new()).collect(),
        named,
        gaps,
        diag,
    };
    gaps.with_zones(|z| exprs.iter().any(|e| scene.may_show(z, e)))
}

/// What the test of one zone reads of the scene.
struct Scene<'a> {
    meshes: &'a [&'a Mesh],
    bounds: Vec<Aabb>,
    /// Per mesh, when convex, its face planes (unit normal, offset); computed
    /// when first asked.
    planes: Vec<OnceCell<Option<Vec<(DVec3, f64)>>>>,
    /// Per primitive: named by the solid.
    named: Vec<bool>,
    gaps: &'a TieGaps,
    diag: f64,
}

/// A primitive's state near a zone.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Near {
    Out,
    In,
    /// Either, the same on both sides of the zone.
    Free,
    /// Either, independently on each side (a face of it may be on the zone).
    Flips,
}

impl Scene<'_> {
    /// Whether zone `z` may hold a visible point of `expr` (module doc).
    fn may_show(&self, z: &TieZone, expr: &Expr) -> bool {
        let prims = self.named.len() as u32;
        if z.a == z.b || z.b >= prims || z.gap > COINCIDENT * self.diag {
            return true;
        }
        let bx = self.shrunk(z);
        let near_zone = |o: &TieZone| {
            let g = DVec3::splat(self.gaps.cap);
            let (lo, hi) = (o.lo.min(o.hi) - g, o.lo.max(o.hi) + g);
            lo.cmple(bx.max + g).all() && (bx.min - g).cmple(hi).all()
        };
        // A face of `a` or `b` on another face of its own: their states may
        // not simply change places.
        let own = |m: u32| self.gaps.zones_of(m).any(|o| o.a == o.b && near_zone(o));
        if own(z.a) || own(z.b) {
            return true;
        }
        let mut state = vec![false; prims as usize];
        let (mut free, mut flips) = (Vec::new(), Vec::new());
        for c in (0..prims).filter(|&c| c != z.a && c != z.b && self.named[c as usize]) {
            let near = match self.near(c, &bx) {
                Near::Free if self.gaps.zones_of(c).any(|o| near_zone(o)) => Near::Flips,
                n => n,
            };
            match near {
                Near::Out => {}
                Near::In => state[c as usize] = true,
                Near::Free => free.push(c as usize),
                Near::Flips => flips.push(c as usize),
            }
        }
        if free.len() + 2 * flips.len() > MAX_UNKNOWNS {
            return true;
        }
        let (a, b) = (z.a as usize, z.b as usize);
        // (a, b) on one side and on the other.
        let (one, other) = if z.opposite {
            ((true, false), (false, true))
        } else {
            ((false, false), (true, true))
        };
        let unknowns = free.len() + 2 * flips.len();
        let mut before = state.clone();
        let mut after = state;
        (0u32..1 << unknowns).any(|bits| {
            let bit = |k: usize| bits >> k & 1 == 1;
            for (k, &c) in free.iter().enumerate() {
                (before[c], after[c]) = (bit(k), bit(k));
            }
            for (k, &c) in flips.iter().enumerate() {
                let at = free.len() + 2 * k;
                (before[c], after[c]) = (bit(at), bit(at + 1));
            }
            (before[a], before[b]) = one;
            (after[a], after[b]) = other;
            let inside = |s: &[bool]| expr.eval(|_, p| s.get(p as usize).copied().unwrap_or(false));
            inside(&before) != inside(&after)
        })
    }

    /// The zone's box shrunk by [`SHRINK`] along each axis where it extends
    /// more than twice that (a flat zone keeps its plane).
    fn shrunk(&self, z: &TieZone) -> Aabb {
        let s = SHRINK * self.diag;
        let (mut lo, mut hi) = (z.lo.min(z.hi), z.lo.max(z.hi));
        for k in 0..3 {
            if hi[k] - lo[k] > 2.0 * s {
                lo[k] += s;
                hi[k] -= s;
            }
        }
        Aabb { min: lo, max: hi }
    }

    /// Primitive `c`'s state over box `bx` (its faces through it: [`Near::Free`]).
    fn near(&self, c: u32, bx: &Aabb) -> Near {
        let cb = &self.bounds[c as usize];
        if cb.max.cmplt(bx.min).any() || bx.max.cmplt(cb.min).any() {
            return Near::Out;
        }
        let Some(planes) = self.planes(c) else {
            return Near::Free;
        };
        let margin = MARGIN * self.diag;
        let centre = (bx.min + bx.max) * 0.5;
        let half = (bx.max - bx.min) * 0.5;
        // The smallest and largest signed distance of the box's corners.
        let range = |&(n, d): &(DVec3, f64)| {
            let (mid, r) = (n.dot(centre) - d, n.abs().dot(half));
            (mid - r, mid + r)
        };
        if planes.iter().any(|p| range(p).0 > margin) {
            Near::Out
        } else if planes.iter().all(|p| range(p).1 < -margin) {
            Near::In
        } else {
            Near::Free
        }
    }

    /// Mesh `c`'s face planes when it is convex (`plan::convex`).
    fn planes(&self, c: u32) -> Option<&Vec<(DVec3, f64)>> {
        self.planes[c as usize]
            .get_or_init(|| {
                let mesh = self.meshes[c as usize];
                is_convex(mesh).then(|| {
                    let p = &mesh.positions;
                    let b = crate::geom::bounds(p);
                    let size = (b.max - b.min).length();
                    mesh.triangles
                        .iter()
                        .filter_map(|t| {
                            // The faces `is_convex` tests: the others are
                            // slivers of no area, on the planes of these.
                            let [a, b, c] = t.map(|i| p[i as usize]);
                            let n = (b - a).cross(c - a);
                            (n.length() > 1e-12 * size * size).then(|| {
                                let n = n.normalize();
                                (n, n.dot(a))
                            })
                        })
                        .collect()
                })
            })
            .as_ref()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::csg::parse::parse;
    use crate::scene::shapes;

    fn cube(center: DVec3, half: DVec3) -> Mesh {
        let mut m = shapes::make_box(half * 2.0);
        for p in &mut m.positions {
            *p += center;
        }
        m
    }

    fn expr(src: &str) -> Expr {
        parse(src, &mut |n: &str| {
            n.strip_prefix('P').and_then(|i| i.parse().ok())
        })
        .expect("expression")
    }

    /// The pairs left for the shade of `meshes` under `src`, and all pairs.
    fn pairs(meshes: &[Mesh], src: &str) -> (Vec<(u32, u32)>, Vec<(u32, u32)>) {
        let refs: Vec<&Mesh> = meshes.iter().collect();
        let gaps = TieGaps::new(&refs);
        let e = expr(src);
        let shade = visible_ties(&gaps, &refs, &[e], meshes.len());
        let key = |g: &TieGaps| g.pairs.iter().map(|p| (p.0, p.1)).collect();
        (key(&shade), key(&gaps))
    }

    /// P0 on top of P1: P0's bottom face lies on P1's top face (y = 1), the
    /// footprints overlapping.
    fn stacked() -> Vec<Mesh> {
        vec![
            cube(DVec3::new(0.2, 1.5, 0.1), DVec3::new(0.5, 0.5, 0.5)),
            cube(DVec3::new(0.0, 0.5, 0.0), DVec3::new(1.0, 0.5, 1.0)),
        ]
    }

    #[test]
    fn a_contact_inside_a_union_or_outside_an_intersection_is_never_visible() {
        let all = vec![(0, 1)];
        for src in ["P0 + P1", "P0 * P1", "P1 + P0 + P0"] {
            assert_eq!(pairs(&stacked(), src), (vec![], all.clone()), "{src}");
        }
        // Not where one is subtracted: the ray enters P1 where it leaves P0
        // (seen from above: P1's top face under P0 is visible, P0's the
        // lowest index there); nor where the other is complemented.
        for src in ["P1 - P0", "P0 - P1", "P1 * !P0"] {
            assert_eq!(pairs(&stacked(), src), (all.clone(), all.clone()), "{src}");
        }
    }

    #[test]
    fn flush_faces_of_a_union_are_visible_unless_something_removes_them() {
        // Tops flush at y = 1, the boxes overlapping: a same-way pair.
        let flush = vec![
            cube(DVec3::new(0.3, 0.7, 0.0), DVec3::new(0.5, 0.3, 0.5)),
            cube(DVec3::new(0.0, 0.5, 0.0), DVec3::new(0.5, 0.5, 0.5)),
        ];
        let all = vec![(0, 1)];
        assert_eq!(pairs(&flush, "P0 + P1"), (all.clone(), all.clone()));
        let mut cut = flush.clone();
        // P2 holds the whole zone inside (convex): the caps are inside a
        // subtracted solid; P3 only half of it.
        cut.push(cube(DVec3::new(0.0, 1.0, 0.0), DVec3::splat(2.0)));
        cut.push(cube(DVec3::new(1.0, 1.0, 0.0), DVec3::new(0.7, 2.0, 2.0)));
        let (shade, _) = pairs(&cut, "(P0 + P1) - P2");
        assert!(!shade.contains(&(0, 1)), "{shade:?}");
        let (shade, _) = pairs(&cut, "(P0 + P1) - P3");
        assert!(shade.contains(&(0, 1)), "{shade:?}");
        // A primitive that is outside the zone, or not named, changes nothing.
        let (shade, _) = pairs(&cut, "(P0 + P1) + (P3 - P2)");
        assert!(shade.contains(&(0, 1)), "{shade:?}");
    }

    #[test]
    fn a_third_face_on_the_contact_may_make_it_visible() {
        // A's back face on B's front face, C's bottom face there too (the
        // `vk_tests/visible_side.rs` scene, y up): C flips with the zone.
        // `A + B` alone hides the contact; `(A - C) + B` shows B's face
        // where C removed A, with A the lowest index on it.
        let abc = vec![
            cube(DVec3::new(0.0, 1.5, 0.0), DVec3::splat(0.5)),
            cube(DVec3::new(0.0, 0.5, 0.0), DVec3::new(1.0, 0.5, 1.0)),
            cube(DVec3::new(0.0, 2.0, 0.0), DVec3::new(0.7, 1.0, 0.7)),
        ];
        let (shade, all) = pairs(&abc, "P0 + P1");
        assert!(
            all.contains(&(0, 1)) && !shade.contains(&(0, 1)),
            "{shade:?}"
        );
        let (shade, _) = pairs(&abc, "(P0 - P2) + P1");
        assert!(shade.contains(&(0, 1)), "{shade:?}");
    }

    #[test]
    fn faces_a_gap_apart_and_surfaces_keep_their_zones() {
        // P0 floats 1e-4 above P1: within the cap, not coincident.
        let gap = vec![
            cube(DVec3::new(0.2, 1.5001, 0.1), DVec3::new(0.5, 0.5, 0.5)),
            cube(DVec3::new(0.0, 0.5, 0.0), DVec3::new(1.0, 0.5, 1.0)),
        ];
        let (shade, all) = pairs(&gap, "P0 + P1");
        assert_eq!((shade, all), (vec![(0, 1)], vec![(0, 1)]));
        // Mesh 1 a surface (past the primitives): kept.
        let meshes = stacked();
        let refs: Vec<&Mesh> = meshes.iter().collect();
        let gaps = TieGaps::new(&refs);
        let shade = visible_ties(&gaps, &refs, &[expr("P0")], 1);
        assert_eq!(shade, gaps);
        // No solid: nothing known.
        assert_eq!(visible_ties(&gaps, &refs, &[], 2), gaps);
        // Two solids: a contact inside their union is still the boundary of
        // each (an assembly's layers count each solid on its own).
        let two = [expr("P0 + P1"), expr("P0"), expr("P1")];
        assert_eq!(visible_ties(&gaps, &refs, &two, 2), gaps);
    }
}
