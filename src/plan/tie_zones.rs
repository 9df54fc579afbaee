//! The final shade's tie rule only where ties can happen on screen
//! (docs/precision.md). A mesh that keeps the tie rule in the final shade
//! (`plan::tie_free`: a partner face within the band somewhere) can tie only
//! inside its [`TieZone`](crate::geom::ties::TieZone)s (`geom::ties`: where its near-parallel faces overlap
//! a partner's, grown by the camera's band). Projected to the screen, those
//! zones are where its shade runs the rule (`shade_near_depth`); over the rest
//! of its rectangle it is drawn as the depth-`EQUAL` shade of a tie-free mesh,
//! which passes exactly where its face is the visible one, as the rule does
//! where no other face is within the band. For a few zones the two parts cover
//! disjoint pixels ([`subtract`]); for more the depth-equal part covers the
//! whole rectangle, zones included ([`depth_equal_pieces`]: there it writes the
//! mesh's own id or nothing, fewer draws than the pieces around many small
//! zones). A depth-equal part of one
//! mesh and a rule part of another can both pass at a pixel only where the two
//! tie, which lies in their zone (a zone belongs to its pair), where the lower
//! index draws the rule (below). Crossing faces, which the zones do not hold, are the
//! tie-free path's approximation (`plan::tie_free`: a sliver of a pixel at the
//! crossing line).
//!
//! Of the two meshes of a zone only the lower index runs the rule there
//! ([`ShadeRule::decide`]): the shade draws the meshes in descending index
//! order and the last writer wins, so at a pixel where several faces tie the
//! lowest index's rule draw comes last whatever the others drew. Let `w` be
//! the lowest index whose rule passes at a pixel (the id the rule everywhere
//! gives). If another mesh's rule passes there too, the two tie, the pixel
//! lies in their zone, and `w`, the lower of the pair, runs the rule there and
//! is drawn after it. If no other rule passes, no depth-`EQUAL` draw of
//! another mesh can pass (the image holds the visible face's raster depth, at
//! which any face's rule passes; or a rule draw's depth, and only `w`'s rule
//! passes), and `w`'s own draw, rule or depth-equal, passes: its face is the
//! visible one. So the higher index of a pair draws depth-equal in their zone
//! (the gear's 36 teeth, flush with the body, one draw each where each took
//! the rule in two zones and four depth-equal pieces around them).
//!
//! Pure: rectangles come from a projection the executor passes in.

use super::rect::Rect;
use crate::geom::ties::{TieGaps, TieZone};
use crate::scene::Aabb;

/// The most rule rectangles of one shade draw (each is a draw).
pub const MAX_RULE_RECTS: usize = 64;

/// Rule pixels one more rule draw is counted as: two rule rectangles merge
/// while their bounding rectangle adds fewer pixels than this. A guess in
/// the spirit of `plan::scs`'s `DRAW_PIXELS`, smaller because a rule pixel
/// costs more than a plain one (three texel fetches, derivatives, a depth
/// write after the shader; about 5 ns on lavapipe at 800×800, where a draw
/// costs 15 µs: docs/perf/2026-12-08-gaps.md). The gear's body ties with the
/// 36 teeth flush with it, each in a strip of a few hundred pixels at the
/// rim: four rectangles covered the whole gear (0.36 M rule pixels).
const RULE_DRAW_PIXELS: u64 = 4096;

/// The depth-equal part of a zoned draw is cut around its rule rectangles
/// (`subtract`) only while they are at most this many; with more, the
/// complement's pieces would outnumber them, and the depth-equal draw covers
/// the draw's whole rectangle ([`depth_equal_pieces`]).
pub const MAX_CUT_RECTS: usize = 4;

/// The rectangles of the depth copy that opens a final shade (each a
/// full-screen pass over its rectangle).
pub const MAX_COPY_RECTS: usize = 4;

/// Zone rectangles are first merged down to this many in bulk (along x),
/// before the pairwise merge (quadratic in what is left).
const BULK: usize = 96;

/// How the final shade draws one mesh under one camera.
#[derive(Clone, Debug, PartialEq)]
pub enum ShadeRule {
    /// No face within the band of another: one depth-equal draw.
    Free,
    /// The tie rule inside these screen rectangles (clipped later to the
    /// draw's scissor; they may overlap, [`merge_priced`]: a pixel shaded
    /// twice by one mesh's rule gets the same answer), depth-equal elsewhere. Empty: no zone on screen,
    /// or only zones whose partner has the lower index.
    Zones(Vec<Rect>),
    /// The tie rule over the whole mesh (no zones known, or the band wider than
    /// the analysis reaches).
    Everywhere,
}

impl ShadeRule {
    /// Mesh `m`'s rule for a band of `band` world units; `project` gives the
    /// screen rectangle of a world box (the full screen for one crossing the
    /// near plane, `vk::scissor::bounds_rect`).
    pub fn decide(gaps: &TieGaps, m: u32, band: f64, project: &dyn Fn(&Aabb) -> Rect) -> ShadeRule {
        let known = band.is_finite() && band <= gaps.cap;
        let gap = gaps.min_gap.get(m as usize).copied().unwrap_or(0.0);
        if known && gap > band {
            return ShadeRule::Free;
        }
        if !known || gaps.zones.is_empty() {
            return ShadeRule::Everywhere;
        }
        let rects = gaps
            .zones_of(m)
            .filter(|z| wins_over_partner(z, m))
            .filter_map(|z| z.within(band))
            .map(|b| project(&b))
            .collect();
        ShadeRule::Zones(merge_priced(rects, MAX_RULE_RECTS, RULE_DRAW_PIXELS))
    }

    /// Whether a recording made with `self` draws the rule wherever one made
    /// with `exact` would: the same rule, the rule everywhere, or rectangles
    /// that contain each of `exact`'s.
    pub fn serves(&self, exact: &ShadeRule) -> bool {
        match (self, exact) {
            (a, b) if a == b => true,
            (ShadeRule::Everywhere, ShadeRule::Zones(_)) => true,
            (ShadeRule::Zones(r), ShadeRule::Zones(e)) => {
                e.iter().all(|e| r.iter().any(|r| r.contains(e)))
            }
            _ => false,
        }
    }

    /// The rule rectangles grown by `mx`, `my` pixels within a `width ×
    /// height` image (a moving camera's recording, like its scissors).
    pub fn grown(&self, mx: u32, my: u32, width: u32, height: u32) -> ShadeRule {
        match self {
            ShadeRule::Zones(r) => ShadeRule::Zones(merge_priced(
                r.iter().map(|r| r.grown(mx, my, width, height)).collect(),
                MAX_RULE_RECTS,
                RULE_DRAW_PIXELS,
            )),
            other => other.clone(),
        }
    }
}

/// Whether mesh `m`'s shade needs the tie rule in zone `z` of its pair:
/// only where its partner has the higher index (module documentation, the
/// lower index wins). The final shade draws the meshes in descending index
/// order ([`crate::plan::shade_near_depth`]), the last writer winning, so at
/// a tie the lower index's rule draw, drawn after the partner's, is the one
/// that decides; the higher index's depth-`EQUAL` draw passes only where its
/// own face is the visible one (bit-exact raster depth), and is overwritten
/// there by the lower index's rule wherever the two tie. A self-tie (both
/// sides of the zone the same mesh) names the same primitive either way.
fn wins_over_partner(z: &TieZone, m: u32) -> bool {
    z.a != z.b && (z.a == m && z.b > m || z.b == m && z.a > m)
}

/// At most `max` pairwise disjoint rectangles covering `rects` (empty ones
/// dropped): overlapping ones are merged into their bounding rectangle, then
/// the pair whose bounding rectangle adds the least area, until `max` are left.
pub fn merge(rects: Vec<Rect>, max: usize) -> Vec<Rect> {
    let mut rects = bulk(rects, max);
    loop {
        let n = rects.len();
        let pair = (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .find(|&(i, j)| !rects[i].intersect(&rects[j]).is_empty())
            .or_else(|| {
                (n > max)
                    .then(|| {
                        (0..n)
                            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
                            .min_by_key(|&(i, j)| {
                                let u = rects[i].union(&rects[j]).area();
                                u - rects[i].area() - rects[j].area()
                            })
                    })
                    .flatten()
            });
        let Some((i, j)) = pair else {
            return rects;
        };
        let u = rects[i].union(&rects[j]);
        rects[i] = u;
        rects.swap_remove(j);
    }
}

/// At most `max` rectangles covering `rects` (empty ones dropped), which may
/// overlap: the pair whose bounding rectangle adds the fewest pixels to what
/// the two cover is merged while more than `max` are left or it adds at most
/// `draw_pixels` (one draw fewer is worth that many). Unlike [`merge`],
/// overlapping rectangles are not merged whatever it adds: around a ring of
/// small zones (the gear's teeth) merging every overlap grew arcs into
/// rectangles that overlapped across the ring, and the ring into one.
pub fn merge_priced(rects: Vec<Rect>, max: usize, draw_pixels: u64) -> Vec<Rect> {
    let mut rects = bulk(rects, max);
    loop {
        let n = rects.len();
        let added = |(i, j): (usize, usize)| {
            let (a, b) = (&rects[i], &rects[j]);
            a.union(b).area() + a.intersect(b).area() - a.area() - b.area()
        };
        let pair = (0..n)
            .flat_map(|i| (i + 1..n).map(move |j| (i, j)))
            .min_by_key(|&p| added(p))
            .filter(|&p| n > max || added(p) <= draw_pixels);
        let Some((i, j)) = pair else {
            return rects;
        };
        let u = rects[i].union(&rects[j]);
        rects[i] = u;
        rects.swap_remove(j);
    }
}

/// `rects` without empty ones, merged in bulk along x down to [`BULK`]
/// where there are more.
fn bulk(mut rects: Vec<Rect>, max: usize) -> Vec<Rect> {
    assert!(max >= 1, "merge to at least one rectangle");
    rects.retain(|r| !r.is_empty());
    if rects.len() > BULK {
        rects.sort_by_key(|r| r.x0 + r.x1);
        let per = rects.len().div_ceil(BULK);
        rects = rects.chunks(per).map(bounding).collect();
    }
    rects
}

fn bounding(rects: &[Rect]) -> Rect {
    rects.iter().fold(Rect::EMPTY, |a, r| a.union(r))
}

/// The rectangles of a zoned shade draw's depth-equal part within `scissor`,
/// its rule drawn over `rule` (within `scissor`, overlapping or not): the rest of
/// `scissor` ([`subtract`]) for a few rule rectangles, `scissor` itself for
/// more ([`MAX_CUT_RECTS`]). Over a rule rectangle the depth-equal draw writes
/// the mesh's own id or nothing: it passes where the mesh's raster depth is
/// the image's, which is the visible face's (the mesh's rule passes there
/// too) or a rule draw's depth written in its zone (where the mesh ties with
/// that rule's mesh, and its own rule runs: module documentation).
pub fn depth_equal_pieces(scissor: Rect, rule: &[Rect]) -> Vec<Rect> {
    match rule.len() <= MAX_CUT_RECTS {
        true => subtract(scissor, rule),
        false if scissor.is_empty() => Vec::new(),
        false => vec![scissor],
    }
}

/// Disjoint rectangles covering exactly the pixels of `outer` outside every
/// rectangle of `holes`: horizontal bands between the holes' edges, each cut
/// where holes cover it, with equal pieces of consecutive bands joined.
pub fn subtract(outer: Rect, holes: &[Rect]) -> Vec<Rect> {
    if outer.is_empty() {
        return Vec::new();
    }
    let holes: Vec<Rect> = holes
        .iter()
        .map(|h| h.intersect(&outer))
        .filter(|h| !h.is_empty())
        .collect();
    let mut ys: Vec<u32> = holes
        .iter()
        .flat_map(|h| [h.y0, h.y1])
        .chain([outer.y0, outer.y1])
        .collect();
    ys.sort_unstable();
    ys.dedup();
    let mut out: Vec<Rect> = Vec::new();
    for band in ys.windows(2) {
        let (y0, y1) = (band[0], band[1]);
        let mut cover: Vec<(u32, u32)> = holes
            .iter()
            .filter(|h| h.y0 <= y0 && y1 <= h.y1)
            .map(|h| (h.x0, h.x1))
            .collect();
        cover.sort_unstable();
        let mut x = outer.x0;
        let mut pieces = Vec::new();
        for (a, b) in cover.into_iter().chain([(outer.x1, outer.x1)]) {
            if a > x {
                pieces.push((x, a));
            }
            x = x.max(b);
        }
        for (x0, x1) in pieces {
            match out
                .iter_mut()
                .find(|r| r.y1 == y0 && r.x0 == x0 && r.x1 == x1)
            {
                Some(r) => r.y1 = y1,
                None => out.push(Rect { x0, y0, x1, y1 }),
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::ties::TieZone;
    use glam::DVec3;

    fn r(x0: u32, y0: u32, x1: u32, y1: u32) -> Rect {
        Rect { x0, y0, x1, y1 }
    }

    /// Every pixel of `outer` in exactly one of `parts` or in a hole, none
    /// outside `outer`.
    fn check_cover(outer: Rect, holes: &[Rect], parts: &[Rect]) {
        for y in 0..outer.y1 + 2 {
            for x in 0..outer.x1 + 2 {
                let p = r(x, y, x + 1, y + 1);
                let n = parts.iter().filter(|q| q.contains(&p)).count();
                let hole = holes.iter().any(|h| h.contains(&p));
                let want = usize::from(outer.contains(&p) && !hole);
                assert_eq!(n, want, "pixel ({x}, {y}): {parts:?}");
            }
        }
    }

    #[test]
    fn the_complement_of_holes_is_an_exact_disjoint_cover() {
        let outer = r(2, 3, 30, 25);
        for holes in [
            vec![],
            vec![r(5, 5, 10, 10)],
            vec![r(0, 0, 40, 40)],
            vec![r(5, 5, 10, 10), r(8, 8, 20, 12), r(25, 0, 40, 30)],
            vec![r(2, 3, 30, 4), r(2, 24, 30, 25), r(10, 10, 11, 11)],
        ] {
            let parts = subtract(outer, &holes);
            check_cover(outer, &holes, &parts);
        }
        // One hole inside: four pieces (above, left, right, below).
        assert_eq!(subtract(outer, &[r(5, 5, 10, 10)]).len(), 4);
        assert!(subtract(Rect::EMPTY, &[]).is_empty());
    }

    #[test]
    fn merged_rectangles_are_few_disjoint_and_cover_the_input() {
        let input = vec![
            r(0, 0, 10, 10),
            r(5, 5, 15, 15),
            r(40, 40, 50, 50),
            r(100, 0, 110, 10),
            r(0, 100, 10, 110),
            r(200, 200, 201, 201),
            Rect::EMPTY,
        ];
        for max in [1, 2, 4, 8] {
            let m = merge(input.clone(), max);
            assert!(m.len() <= max, "{m:?}");
            for (i, a) in m.iter().enumerate() {
                for b in &m[i + 1..] {
                    assert!(a.intersect(b).is_empty(), "{a:?} {b:?}");
                }
            }
            for a in input.iter().filter(|a| !a.is_empty()) {
                assert!(m.iter().any(|b| b.contains(a)), "{a:?} lost in {m:?}");
            }
        }
        // The two overlapping ones always merge; with room, the rest stay.
        assert_eq!(merge(input.clone(), 8).len(), 5);
        // Many at once: bulk-merged, still covering.
        let many: Vec<Rect> = (0..100).map(|i| r(3 * i, i, 3 * i + 2, i + 2)).collect();
        let m = merge(many.clone(), MAX_RULE_RECTS);
        assert!(m.len() <= MAX_RULE_RECTS);
        assert!(many.iter().all(|a| m.iter().any(|b| b.contains(a))));
    }

    fn gaps_with(zones: Vec<TieZone>, min_gap: Vec<f64>) -> TieGaps {
        TieGaps {
            min_gap,
            cap: 1.0,
            pairs: vec![(0, 1, 0.0)],
            zones,
        }
    }

    /// A projection that maps world x, y to pixels (10 per unit).
    fn flat(b: &Aabb) -> Rect {
        let px = |v: f64| (v * 10.0).max(0.0) as u32;
        r(
            px(b.min.x),
            px(b.min.y),
            px(b.max.x).max(px(b.min.x) + 1),
            px(b.max.y).max(px(b.min.y) + 1),
        )
    }

    #[test]
    fn a_mesh_keeps_the_rule_only_over_its_zones_within_the_band() {
        let zone = |a, b, gap, lo: [f64; 3], hi: [f64; 3]| TieZone {
            a,
            b,
            opposite: false,
            flat: true,
            gap,
            lo: DVec3::from(lo),
            hi: DVec3::from(hi),
        };
        let gaps = gaps_with(
            vec![
                zone(0, 1, 0.0, [1.0, 1.0, 0.0], [2.0, 2.0, 0.0]),
                zone(0, 2, 0.05, [5.0, 5.0, 0.0], [6.0, 6.0, 0.0]),
            ],
            vec![0.0, 0.0, 0.05, f64::INFINITY],
        );
        let rule = |m, band| ShadeRule::decide(&gaps, m, band, &flat);
        // Band 0.01: only the flush pair's zone, grown by the band.
        // Mesh 1 has a partner, of lower index: depth-equal everywhere.
        assert_eq!(rule(0, 0.01), ShadeRule::Zones(vec![r(9, 9, 20, 20)]));
        assert_eq!(rule(1, 0.01), ShadeRule::Zones(vec![]));
        assert_eq!(rule(2, 0.01), ShadeRule::Free);
        // Band 0.1: mesh 2's zone too, whose rule mesh 0 runs; mesh 0 has both.
        assert_eq!(rule(2, 0.1), ShadeRule::Zones(vec![]));
        // Two zones 28 pixels apart merge (one draw is worth more than the
        // 2,416 pixels the merge adds, `RULE_DRAW_PIXELS`).
        assert_eq!(rule(0, 0.1), ShadeRule::Zones(vec![r(9, 9, 61, 61)]));
        assert_eq!(rule(3, 0.1), ShadeRule::Free);
        // Beyond the analysis' cap: the rule everywhere (and for every mesh
        // when nothing is known).
        assert_eq!(rule(0, 2.0), ShadeRule::Everywhere);
        assert_eq!(rule(3, 2.0), ShadeRule::Everywhere);
        let unknown = TieGaps::unknown(2);
        assert_eq!(
            ShadeRule::decide(&unknown, 0, 0.01, &flat),
            ShadeRule::Everywhere
        );
    }

    #[test]
    fn small_zones_apart_stay_apart_and_near_ones_merge() {
        // Strips of 40×10 pixels around a 400-pixel ring (the gear's teeth):
        // each its own draw; the bounding rectangle was the whole ring.
        let strips: Vec<Rect> = (0..36)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 36.0;
                let (x, y) = (400.0 + 300.0 * a.cos(), 400.0 + 300.0 * a.sin());
                r(x as u32, y as u32, x as u32 + 40, y as u32 + 10)
            })
            .collect();
        let priced = merge_priced(strips.clone(), MAX_RULE_RECTS, RULE_DRAW_PIXELS);
        let area = |rs: &[Rect]| rs.iter().map(Rect::area).sum::<u64>();
        assert!(priced.len() > 4, "{}", priced.len());
        assert!(priced.len() <= MAX_RULE_RECTS);
        assert!(strips.iter().all(|a| priced.iter().any(|b| b.contains(a))));
        assert!(area(&priced) < area(&strips) * 4, "{priced:?}");
        assert!(merge(strips.clone(), 4).iter().map(Rect::area).sum::<u64>() > 100_000);
        // Two strips a pixel apart cost less merged than drawn twice.
        let near = merge_priced(
            vec![r(0, 0, 40, 10), r(41, 0, 80, 10)],
            MAX_RULE_RECTS,
            RULE_DRAW_PIXELS,
        );
        assert_eq!(near, vec![r(0, 0, 80, 10)]);
    }

    #[test]
    fn the_depth_equal_part_is_cut_around_a_few_rule_rectangles_only() {
        let outer = r(0, 0, 100, 100);
        let few = vec![r(10, 10, 20, 20), r(50, 50, 60, 60)];
        let pieces = depth_equal_pieces(outer, &few);
        check_cover(outer, &few, &pieces);
        let many: Vec<Rect> = (0..MAX_CUT_RECTS as u32 + 1)
            .map(|i| r(10 * i, 0, 10 * i + 5, 5))
            .collect();
        assert_eq!(depth_equal_pieces(outer, &many), vec![outer]);
        assert_eq!(depth_equal_pieces(Rect::EMPTY, &many), vec![]);
    }

    #[test]
    fn only_the_lower_index_of_a_pair_runs_the_rule_in_their_zone() {
        let zone = |a, b| TieZone {
            a,
            b,
            opposite: false,
            flat: true,
            gap: 0.0,
            lo: DVec3::ZERO,
            hi: DVec3::ONE,
        };
        assert!(wins_over_partner(&zone(0, 3), 0));
        assert!(!wins_over_partner(&zone(0, 3), 3));
        assert!(wins_over_partner(&zone(5, 2), 2));
        assert!(!wins_over_partner(&zone(5, 2), 5));
        assert!(
            !wins_over_partner(&zone(4, 4), 4),
            "a self-tie names one id"
        );
    }

    /// The shade at one pixel, as recorded: meshes `0..n` in descending
    /// order, each by its rule where `rule_here(m)` or depth-equal elsewhere;
    /// the last writer's id. `passes`: the meshes whose rule passes there
    /// (`visible` among them, whose raster depth the image holds). A rule
    /// draw writes its own depth, which no other mesh's raster equals.
    fn last_writer(
        n: u32,
        passes: &[u32],
        visible: Option<u32>,
        rule_here: impl Fn(u32) -> bool,
    ) -> Option<u32> {
        let (mut id, mut image_holds_visible) = (None, true);
        for m in (0..n).rev() {
            if rule_here(m) {
                if passes.contains(&m) {
                    id = Some(m);
                    image_holds_visible = false;
                }
            } else if image_holds_visible && Some(m) == visible {
                id = Some(m);
            }
        }
        id
    }

    #[test]
    fn the_lower_index_rule_alone_gives_the_ids_of_the_rule_everywhere() {
        // Every pixel configuration of four meshes: which rules pass, which
        // of those is the visible face. The zones hold every pair of meshes
        // whose rules pass together (the pixel lies in their zone).
        let n = 4u32;
        for set in 0u32..1 << n {
            let passes: Vec<u32> = (0..n).filter(|m| set & 1 << m != 0).collect();
            let visibles: Vec<Option<u32>> = match passes.is_empty() {
                true => vec![None],
                false => passes.iter().map(|&v| Some(v)).collect(),
            };
            for visible in visibles {
                let everywhere = last_writer(n, &passes, visible, |_| true);
                assert_eq!(everywhere, passes.first().copied());
                let zones: Vec<TieZone> = passes
                    .iter()
                    .flat_map(|&a| passes.iter().map(move |&b| (a, b)))
                    .filter(|(a, b)| a < b)
                    .map(|(a, b)| TieZone {
                        a,
                        b,
                        opposite: false,
                        flat: true,
                        gap: 0.0,
                        lo: DVec3::ZERO,
                        hi: DVec3::ONE,
                    })
                    .collect();
                let lower = |m: u32| zones.iter().any(|z| z.has(m) && wins_over_partner(z, m));
                assert_eq!(
                    last_writer(n, &passes, visible, lower),
                    everywhere,
                    "rules passing {passes:?}, visible {visible:?}"
                );
            }
        }
    }

    #[test]
    fn a_recording_serves_a_camera_whose_zones_it_contains() {
        let exact = ShadeRule::Zones(vec![r(10, 10, 20, 20)]);
        let grown = exact.grown(5, 5, 100, 100);
        assert_eq!(grown, ShadeRule::Zones(vec![r(5, 5, 25, 25)]));
        assert!(grown.serves(&exact));
        assert!(!exact.serves(&grown));
        assert!(ShadeRule::Everywhere.serves(&exact));
        assert!(!exact.serves(&ShadeRule::Everywhere));
        assert!(!ShadeRule::Free.serves(&exact));
        assert!(!exact.serves(&ShadeRule::Free));
        assert!(ShadeRule::Free.serves(&ShadeRule::Free));
    }
}
