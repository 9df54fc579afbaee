//! Which meshes could meet the tie rule at all: the camera-independent half of
//! the fixed-function fast path (docs/executor.md; the rule itself is
//! `plan::tie`: the lowest index wins).
//!
//! The tolerant parity and peel shaders differ from a plain depth test only
//! where a face of the drawn mesh lies within the tie band of the face recorded
//! in the depth texture at the same pixel: `eps'` (a few depth quanta) plus, for
//! faces whose depth gradients agree, `2^-bits · fwidth(z)`. Two faces come that
//! close on one view ray only when they
//!
//! - are (nearly) parallel: a face crossing another one is within `eps'` of it
//!   only on a band of `eps' / |Δ∇z|` pixels around the crossing line — a
//!   fraction of a pixel, on an edge of the image, where the tolerant answer is
//!   no more right than the plain one — and the slope part of the band applies
//!   only to faces with agreeing gradients;
//! - lie within a small world distance of each other (the band, converted for a
//!   camera by `plan::tie_free`): two points on one ray are at least as far apart
//!   as the faces;
//! - and overlap (their boxes, grown by that distance);
//! - with their interiors: seen along the normal, no edge of either separates
//!   them (`apart_in_plane`). Faces that only touch along an edge (the flush
//!   sides of two stacked boxes, a box's cap next to another's) cover no pixel
//!   centre in common but on a sliver along that edge (vertex snapping; faces
//!   a band apart add a band of lateral offset for an oblique ray), where the
//!   reference's ray meets one of them and the rule is no more right than the
//!   plain test, as for crossing faces.
//!
//! Faces of one mesh that face the same way never tie: where a ray crosses two
//! of them it crosses an opposite face in between, and adjacent faces of a
//! tessellated curve cover each pixel centre once (the raster rules). Opposite
//! faces of one mesh do (a wall thinner than the band).
//!
//! [`TieGaps::new`] records, per mesh, the smallest such distance to any
//! partner face, up to a cap ([`CAP_FRACTION`] of the scene's size): one pass
//! over the triangles into a uniform grid sorted by cell (`O(F log F)`), pairs
//! tested only within a cell. The camera decides later which of those gaps the
//! band reaches. Conservative throughout: a gap is a lower bound of the true
//! distance between the two triangles; a search past its work budget reports
//! every mesh as possibly tied.
//!
//! It also keeps where each pair of meshes can tie, its [`TieZone`]s: a tie
//! needs a point `x` of one triangle and a point `y` of the other on one view
//! ray, at most the band `w` apart, so `x` lies in the first triangle's box and
//! in the second's grown by `w` (and `y` the other way round): both lie in the
//! intersection of the two boxes grown by `w`. A zone keeps that intersection
//! ungrown (inverted along an axis where the boxes are apart), merged over the
//! triangle pairs of a mesh pair whose faces face the same way or opposite
//! ways ([`TieZone::opposite`]) and lie within the cap of each other (a few
//! per pair), with the smallest of their gaps; a camera grows it by its band
//! ([`TieZone::within`]) and projects it (`plan::tie_zones`: the tie rule only
//! there). Which zones can hold a visible point of the solid is
//! the plan's question (`plan::visible_ties`).
#![deny(unsafe_code)]

use glam::DVec3;

use crate::scene::{Aabb, Mesh};

/// Faces count as parallel when their normals are within this angle (radians,
/// either orientation): sixteen times the tie rule's gradient agreement of 1/32
/// seen at its most favourable orientation (about 1/64 rad).
pub const PARALLEL_ANGLE: f64 = 1.0 / 16.0;

/// Faces count as flat partners when their normals are within this angle
/// (radians, either orientation): parallel but for the rounding of the
/// tessellation, so their depth gradients agree under any camera
/// ([`TieZone::flat`]).
pub const FLAT_ANGLE: f64 = 1e-6;

/// Gaps are looked for up to this fraction of the scene's bounding-box diagonal.
/// A band wider than that (a scene a few dozen pixels wide, or standard Z with a
/// near plane very close to the eye) makes every mesh possibly tied.
pub const CAP_FRACTION: f64 = 1.0 / 128.0;

/// Faces whose projections overlap by at most this fraction of the cap across
/// an edge only touch (`apart_in_plane`): f64 rounding of the tessellation
/// (about 1e-9 of the scene's size).
pub const TOUCH_FRACTION: f64 = 1e-7;

/// The most candidate pairs tested before the search gives up (then every mesh
/// counts as possibly tied: correct, only slower).
pub const MAX_PAIR_TESTS: u64 = 50_000_000;

/// Per mesh, the smallest world distance between one of its faces and a
/// parallel, overlapping face that could tie with it ([module doc](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct TieGaps {
    /// Per mesh: the smallest gap found, `f64::INFINITY` when none is at most `cap`.
    pub min_gap: Vec<f64>,
    /// The gaps are complete up to this distance; larger bands are not covered.
    pub cap: f64,
    /// The mesh pairs `(a, b)`, `a <= b`, with a gap of at most `cap`, and that
    /// gap (`a == b`: opposite faces of one mesh), sorted.
    pub pairs: Vec<(u32, u32, f64)>,
    /// Where those pairs can tie, sorted by `(a, b, opposite)`: at most
    /// [`MAX_ZONES_PER_PAIR`] per pair and orientation.
    pub zones: Vec<TieZone>,
}

/// The most zones kept per mesh pair and orientation: more are merged along
/// their pair's longest axis (a few screen rectangles per shade draw,
/// `plan::tie_zones`).
pub const MAX_ZONES_PER_PAIR: usize = 8;

/// Where meshes `a <= b` can tie ([module doc](self)): the intersection of the
/// boxes of triangle pairs within the cap of each other (`lo > hi` along an axis
/// where the boxes are apart), and the smallest gap among them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TieZone {
    pub a: u32,
    pub b: u32,
    /// The faces face opposite ways (solids on either side of the contact, or
    /// a thin wall); `false`: the same way (flush faces of overlapping
    /// solids). A zone holds one kind only.
    pub opposite: bool,
    /// Every triangle pair of the zone is parallel within [`FLAT_ANGLE`]:
    /// coplanar (flush) or parallel faces, no nearly tangent curves. A tie
    /// rule that widens by the slope term on every fragment agrees with the
    /// texture shaders', which widen only where the gradients agree, on such
    /// pairs (`plan::tie_free`, `Fragment::TieDepth`).
    pub flat: bool,
    pub gap: f64,
    pub lo: DVec3,
    pub hi: DVec3,
}

impl TieZone {
    /// The world box holding every point of either mesh that can tie with the
    /// other within a band of `band` world units; `None` when none can (the
    /// gap is wider than the band, or the triangles are more than the band
    /// apart along an axis).
    pub fn within(&self, band: f64) -> Option<Aabb> {
        if !(self.gap <= band) {
            return None;
        }
        let (lo, hi) = (self.lo - DVec3::splat(band), self.hi + DVec3::splat(band));
        lo.cmple(hi).all().then_some(Aabb { min: lo, max: hi })
    }

    /// Whether mesh `m` is one of the pair.
    pub fn has(&self, m: u32) -> bool {
        self.a == m || self.b == m
    }

    /// Both zones as one (same pair and orientation).
    fn union(&self, o: &TieZone) -> TieZone {
        TieZone {
            flat: self.flat && o.flat,
            gap: self.gap.min(o.gap),
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
            ..*self
        }
    }
}

/// One triangle as the search needs it.
struct Tri {
    mesh: u32,
    normal: DVec3,
    offset: f64,
    v: [DVec3; 3],
    lo: DVec3,
    hi: DVec3,
}

impl Tri {
    /// The distance from `self`'s vertices to `other`'s plane (0 when they lie
    /// on both sides): a lower bound of the distance between the triangles.
    fn gap_to_plane_of(&self, other: &Tri) -> f64 {
        let d = self.v.map(|p| other.normal.dot(p) - other.offset);
        let (lo, hi) = (d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2]));
        if lo > 0.0 {
            lo
        } else if hi < 0.0 {
            -hi
        } else {
            0.0
        }
    }
}

impl TieGaps {
    /// The gaps of `meshes` (indexed by mesh id).
    pub fn new(meshes: &[&Mesh]) -> TieGaps {
        let tris = triangles(meshes);
        let n = meshes.len();
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for t in &tris {
            lo = lo.min(t.lo);
            hi = hi.max(t.hi);
        }
        let diag = if tris.is_empty() {
            0.0
        } else {
            (hi - lo).length()
        };
        let cap = diag * CAP_FRACTION;
        let mut out = TieGaps {
            min_gap: vec![f64::INFINITY; n],
            cap,
            pairs: Vec::new(),
            zones: Vec::new(),
        };
        if !(cap > 0.0 && cap.is_finite()) {
            return out;
        }
        match pairs_within(&tris, cap) {
            Some(mut hits) => {
                hits.sort_by(|x, y| (x.a, x.b, x.opposite).cmp(&(y.a, y.b, y.opposite)));
                let key = |z: &TieZone| (z.a, z.b, z.opposite);
                let zones = hits
                    .chunk_by(|x, y| key(x) == key(y))
                    .flat_map(|run| merge_zones(run, cap))
                    .collect();
                out.set_zones(zones);
            }
            None => out.min_gap = vec![0.0; n],
        }
        out
    }

    /// These gaps with only the zones `keep` accepts: the pairs and smallest
    /// gaps are those of the zones left. Gaps without zones (none found, or
    /// the search gave up) are returned as they are.
    pub fn with_zones(&self, keep: impl Fn(&TieZone) -> bool) -> TieGaps {
        if self.zones.is_empty() {
            return self.clone();
        }
        let mut out = TieGaps {
            min_gap: vec![f64::INFINITY; self.min_gap.len()],
            cap: self.cap,
            pairs: Vec::new(),
            zones: Vec::new(),
        };
        out.set_zones(self.zones.iter().filter(|z| keep(z)).copied().collect());
        out
    }

    /// `zones` (sorted by pair), with the pairs and smallest gaps they give.
    fn set_zones(&mut self, zones: Vec<TieZone>) {
        for run in zones.chunk_by(|x, y| (x.a, x.b) == (y.a, y.b)) {
            let (a, b) = (run[0].a, run[0].b);
            let g = run.iter().map(|z| z.gap).fold(f64::INFINITY, f64::min);
            for m in [a, b] {
                let slot = &mut self.min_gap[m as usize];
                *slot = slot.min(g);
            }
            self.pairs.push((a, b, g));
        }
        self.zones = zones;
    }

    /// Whether every face that may tie with a face of mesh `m` is parallel to
    /// it within [`FLAT_ANGLE`] ([`TieZone::flat`]): `m` has no partner, or
    /// only flat ones. Not where the search gave up.
    pub fn ties_flat(&self, m: u32) -> bool {
        let none = self.min_gap.get(m as usize) == Some(&f64::INFINITY);
        none || (self.zones_of(m).next().is_some() && self.zones_of(m).all(|z| z.flat))
    }

    /// The zones of the pairs mesh `m` is in.
    pub fn zones_of(&self, m: u32) -> impl Iterator<Item = &TieZone> {
        self.zones.iter().filter(move |z| z.has(m))
    }

    /// No analysis: every mesh possibly tied (e.g. after a mesh moved).
    pub fn unknown(meshes: usize) -> TieGaps {
        TieGaps {
            min_gap: vec![0.0; meshes],
            cap: 0.0,
            pairs: Vec::new(),
            zones: Vec::new(),
        }
    }

    /// The gap between meshes `a` and `b` (either order), if at most `cap`.
    pub fn gap(&self, a: u32, b: u32) -> Option<f64> {
        let key = (a.min(b), a.max(b));
        self.pairs
            .binary_search_by(|p| (p.0, p.1).cmp(&key))
            .ok()
            .map(|i| self.pairs[i].2)
    }
}

/// The non-degenerate triangles of `meshes` with unit normals and bounds.
fn triangles(meshes: &[&Mesh]) -> Vec<Tri> {
    let mut out = Vec::new();
    for (m, mesh) in meshes.iter().enumerate() {
        for t in &mesh.triangles {
            let v = t.map(|i| mesh.positions[i as usize]);
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            let len = n.length();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let normal = n / len;
            out.push(Tri {
                mesh: m as u32,
                normal,
                offset: normal.dot(v[0]),
                v,
                lo: v[0].min(v[1]).min(v[2]),
                hi: v[0].max(v[1]).max(v[2]),
            });
        }
    }
    out
}

/// The zones of one mesh pair's triangle pairs (`hits`): swept along x, each
/// joins the first zone it comes within `cap` of, or starts one (any grouping
/// is right: the zones only need to cover the hits), then at most
/// [`MAX_ZONES_PER_PAIR`] ([`fewer`]). `O(k · MAX_ZONES_PER_PAIR)` for `k` hits.
fn merge_zones(hits: &[TieZone], cap: f64) -> Vec<TieZone> {
    let near = |a: &TieZone, b: &TieZone| {
        let g = DVec3::splat(2.0 * cap);
        (a.lo - g).cmple(b.hi).all() && (b.lo - g).cmple(a.hi).all()
    };
    let mut order: Vec<&TieZone> = hits.iter().collect();
    order.sort_by(|a, b| a.lo.x.total_cmp(&b.lo.x));
    let mut zones: Vec<TieZone> = Vec::new();
    for h in order {
        match zones.iter_mut().find(|z| near(z, h)) {
            Some(z) => *z = z.union(h),
            None => zones.push(*h),
        }
        if zones.len() > 8 * MAX_ZONES_PER_PAIR {
            zones = fewer(zones);
        }
    }
    fewer(zones)
}

/// At most [`MAX_ZONES_PER_PAIR`] zones covering `zones`: runs of neighbours
/// along their longest axis merged.
fn fewer(mut zones: Vec<TieZone>) -> Vec<TieZone> {
    if zones.len() <= MAX_ZONES_PER_PAIR {
        return zones;
    }
    let all = zones[1..].iter().fold(zones[0], |a, z| a.union(z));
    let e = (all.hi - all.lo).abs();
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    zones.sort_by(|x, y| (x.lo + x.hi)[axis].total_cmp(&(y.lo + y.hi)[axis]));
    let per = zones.len().div_ceil(MAX_ZONES_PER_PAIR);
    zones
        .chunks(per)
        .map(|c| c[1..].iter().fold(c[0], |a, z| a.union(z)))
        .collect()
}

/// The gap of triangles `a` and `b` if they could tie within `cap`.
fn tie_gap(a: &Tri, b: &Tri, cap: f64) -> Option<f64> {
    let dot = a.normal.dot(b.normal);
    // Same-facing faces of one mesh never tie (module doc).
    if a.mesh == b.mesh && dot >= 0.0 {
        return None;
    }
    if dot.abs() < PARALLEL_ANGLE.cos() {
        return None;
    }
    let grow = DVec3::splat(cap);
    if (a.lo - grow).cmpgt(b.hi).any() || (b.lo - grow).cmpgt(a.hi).any() {
        return None;
    }
    let gap = a.gap_to_plane_of(b).max(b.gap_to_plane_of(a));
    (gap <= cap && !apart_in_plane(a, b, cap * TOUCH_FRACTION)).then_some(gap)
}

/// Whether the projections of `a` and `b` onto `a`'s plane overlap by at most
/// `slack` across one of their edges (a separating axis): their interiors are
/// apart, or they only touch along an edge ([module doc](self)).
fn apart_in_plane(a: &Tri, b: &Tri, slack: f64) -> bool {
    let u = a.normal.any_orthonormal_vector();
    let v = a.normal.cross(u);
    let flat = |t: &Tri| t.v.map(|p| glam::DVec2::new(u.dot(p), v.dot(p)));
    let (p, q) = (flat(a), flat(b));
    let span = |pts: &[glam::DVec2; 3], axis: glam::DVec2| {
        let d = pts.map(|x| axis.dot(x));
        (d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2]))
    };
    [p, q].iter().any(|tri| {
        (0..3).any(|k| {
            let e = tri[(k + 1) % 3] - tri[k];
            let Some(axis) = glam::DVec2::new(-e.y, e.x).try_normalize() else {
                return false;
            };
            let ((p0, p1), (q0, q1)) = (span(&p, axis), span(&q, axis));
            p1 <= q0 + slack || q1 <= p0 + slack
        })
    })
}

/// Cell of a point in a grid of cell size `size` anchored at `origin`.
fn cell(p: DVec3, origin: DVec3, size: f64) -> [i64; 3] {
    let c = ((p - origin) / size).floor();
    [c.x as i64, c.y as i64, c.z as i64]
}

/// Every triangle pair of [`tie_gap`] at most `cap`, as a zone of its meshes
/// (not merged); `None` past [`MAX_PAIR_TESTS`].
fn pairs_within(tris: &[Tri], cap: f64) -> Option<Vec<TieZone>> {
    // Boxes grown by half the cap meet when the triangles' boxes are within it.
    let half = DVec3::splat(cap * 0.5);
    let origin = tris
        .iter()
        .fold(DVec3::splat(f64::INFINITY), |o, t| o.min(t.lo))
        - half;
    let size = cell_size(tris, half, origin);
    let range = |t: &Tri| {
        (
            cell(t.lo - half, origin, size),
            cell(t.hi + half, origin, size),
        )
    };
    let mut entries: Vec<([i64; 3], u32)> = Vec::new();
    for (i, t) in tris.iter().enumerate() {
        let (a, b) = range(t);
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    entries.push(([x, y, z], i as u32));
                }
            }
        }
    }
    entries.sort_unstable();
    let mut pairs = Vec::new();
    let mut tests = 0u64;
    for run in entries.chunk_by(|a, b| a.0 == b.0) {
        let here = run[0].0;
        for (k, &(_, i)) in run.iter().enumerate() {
            for &(_, j) in &run[k + 1..] {
                tests += 1;
                if tests > MAX_PAIR_TESTS {
                    return None;
                }
                let (a, b) = (&tris[i as usize], &tris[j as usize]);
                // Each pair once: in the cell holding the corner where their
                // grown boxes start to overlap (a cell both cover).
                if cell((a.lo - half).max(b.lo - half), origin, size) != here {
                    continue;
                }
                if let Some(gap) = tie_gap(a, b, cap) {
                    pairs.push(TieZone {
                        a: a.mesh.min(b.mesh),
                        b: a.mesh.max(b.mesh),
                        opposite: a.normal.dot(b.normal) < 0.0,
                        flat: a.normal.dot(b.normal).abs() >= FLAT_ANGLE.cos(),
                        gap,
                        lo: a.lo.max(b.lo),
                        hi: a.hi.min(b.hi),
                    });
                }
            }
        }
    }
    Some(pairs)
}

/// A cell size near the typical triangle's extent, doubled until the grid holds
/// at most 16 entries per triangle (large faces among small ones).
fn cell_size(tris: &[Tri], half: DVec3, origin: DVec3) -> f64 {
    let mut extents: Vec<f64> = tris
        .iter()
        .map(|t| (t.hi - t.lo + 2.0 * half).max_element())
        .collect();
    let mid = extents.len() / 2;
    let (_, median, _) = extents.select_nth_unstable_by(mid, f64::total_cmp);
    let mut size = median.max(half.x * 4.0);
    loop {
        let entries: u64 = tris
            .iter()
            .map(|t| {
                let (a, b) = (
                    cell(t.lo - half, origin, size),
                    cell(t.hi + half, origin, size),
                );
                (0..3).map(|k| (b[k] - a[k] + 1) as u64).product::<u64>()
            })
            .sum();
        if entries <= 16 * tris.len() as u64 {
            return size;
        }
        size *= 2.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::shapes;

    fn cube(center: DVec3, half: DVec3) -> Mesh {
        let mut m = shapes::make_box(half * 2.0);
        for p in &mut m.positions {
            *p += center;
        }
        m
    }

    fn gaps(meshes: &[Mesh]) -> TieGaps {
        let refs: Vec<&Mesh> = meshes.iter().collect();
        TieGaps::new(&refs)
    }

    #[test]
    fn coplanar_overlapping_faces_tie() {
        // Two unit boxes whose top faces share the plane z = 1 and overlap.
        let a = cube(DVec3::new(0.0, 0.0, 0.5), DVec3::splat(0.5));
        let b = cube(DVec3::new(0.3, 0.2, 0.6), DVec3::new(0.5, 0.5, 0.4));
        let g = gaps(&[a, b]);
        assert_eq!(g.gap(0, 1), Some(0.0));
        assert_eq!(g.min_gap, vec![0.0, 0.0]);
    }

    #[test]
    fn the_zone_of_two_flush_boxes_is_the_overlap_of_their_coplanar_faces() {
        // a's top face (z = 1, x and y in [-0.5, 0.5]) and b's bottom face
        // (z = 1, x in [-0.2, 0.8], y in [-0.3, 0.7]); their other faces are
        // parallel only at 0.2 or more, beyond the cap (~0.019).
        let a = cube(DVec3::new(0.0, 0.0, 0.5), DVec3::splat(0.5));
        let b = cube(DVec3::new(0.3, 0.2, 1.3), DVec3::new(0.5, 0.5, 0.3));
        let g = gaps(&[a, b]);
        assert_eq!(g.zones.len(), 1, "{:?}", g.zones);
        let z = g.zones[0];
        assert_eq!((z.a, z.b, z.gap), (0, 1, 0.0));
        let close = |p: DVec3, q: DVec3| (p - q).abs().max_element() < 1e-12;
        let overlap = z.within(0.0).expect("they touch");
        assert!(
            close(overlap.min, DVec3::new(-0.2, -0.3, 1.0))
                && close(overlap.max, DVec3::new(0.5, 0.5, 1.0)),
            "{overlap:?}"
        );
        // A camera's band grows it on every side.
        let grown = z.within(0.01).expect("within the band");
        assert!(close(grown.min, overlap.min - DVec3::splat(0.01)));
        assert!(close(grown.max, overlap.max + DVec3::splat(0.01)));
        assert!(z.has(0) && z.has(1) && !z.has(2));
        assert_eq!(g.zones_of(1).count(), 1);
        // Coplanar faces: flat partners.
        assert!(z.flat && g.ties_flat(0) && g.ties_flat(1));
    }

    #[test]
    fn nearly_parallel_faces_are_partners_but_not_flat_ones() {
        // A box resting on another one, tilted by 0.01 rad (as the facets of
        // nearly tangent curves): its bottom face is within PARALLEL_ANGLE of
        // the other's top face and within the cap, but not parallel.
        let a = cube(DVec3::ZERO, DVec3::splat(0.5));
        let mut b = cube(DVec3::ZERO, DVec3::splat(0.5));
        let tilt = glam::DQuat::from_rotation_y(0.01);
        for p in &mut b.positions {
            *p = tilt * *p + DVec3::new(0.0, 0.0, 1.0 + 0.006);
        }
        let g = gaps(&[a.clone(), b]);
        assert!(g.min_gap[0].is_finite(), "{:?}", g.min_gap);
        assert!(!g.ties_flat(0) && !g.ties_flat(1));
        assert!(g.zones.iter().all(|z| !z.flat));
        // A mesh without partners has nothing to tie with.
        let mut far = a.clone();
        for p in &mut far.positions {
            p.x += 10.0;
        }
        let g = gaps(&[a.clone(), far]);
        assert!(g.ties_flat(0) && g.ties_flat(1));
        // The search gave up, or no analysis: unknown, so not flat.
        assert!(!TieGaps::unknown(2).ties_flat(0));
    }

    #[test]
    fn zones_beyond_the_band_or_apart_are_empty() {
        // Parallel faces 1e-3 apart: no zone for a band of 1e-4.
        let z = TieZone {
            a: 0,
            b: 1,
            opposite: false,
            flat: true,
            gap: 1e-3,
            lo: DVec3::ZERO,
            hi: DVec3::ONE,
        };
        assert_eq!(z.within(1e-4), None);
        assert!(z.within(1e-3).is_some());
        // Coplanar triangles whose boxes are 0.01 apart along x: they tie
        // nowhere within a band of 4e-3, somewhere within 6e-3.
        let apart = TieZone {
            gap: 0.0,
            lo: DVec3::new(0.51, 0.0, 1.0),
            hi: DVec3::new(0.5, 1.0, 1.0),
            ..z
        };
        assert_eq!(apart.within(4e-3), None);
        assert!(apart.within(6e-3).is_some());
    }

    #[test]
    fn many_zones_of_one_pair_merge_to_a_few() {
        // A plate under 20 disjoint thin tiles flush with it, in a row.
        let plate = cube(DVec3::new(0.0, 0.0, -0.5), DVec3::new(20.0, 1.0, 0.5));
        let mut tiles = Mesh {
            positions: vec![],
            triangles: vec![],
        };
        for i in 0..20 {
            let t = cube(
                DVec3::new(-19.0 + 2.0 * i as f64, 0.0, 0.25),
                DVec3::new(0.5, 0.5, 0.25),
            );
            let base = tiles.positions.len() as u32;
            tiles.positions.extend(t.positions);
            tiles
                .triangles
                .extend(t.triangles.iter().map(|tr| tr.map(|i| i + base)));
        }
        let g = gaps(&[plate, tiles]);
        let zones: Vec<&TieZone> = g.zones_of(0).collect();
        assert!((2..=MAX_ZONES_PER_PAIR).contains(&zones.len()), "{zones:?}");
        // Together they cover every tile's footprint, and little else.
        for i in 0..20 {
            let x = -19.0 + 2.0 * i as f64;
            assert!(
                zones.iter().any(|z| z.lo.x <= x - 0.5 && x + 0.5 <= z.hi.x),
                "tile {i}"
            );
        }
        assert!(zones.iter().all(|z| z.hi.y - z.lo.y <= 1.0 + 1e-12));
    }

    #[test]
    fn coplanar_disjoint_faces_do_not_tie() {
        // Same top plane, boxes two units apart.
        let a = cube(DVec3::new(0.0, 0.0, 0.5), DVec3::splat(0.5));
        let b = cube(DVec3::new(3.0, 0.0, 0.5), DVec3::splat(0.5));
        let g = gaps(&[a, b]);
        assert_eq!(g.gap(0, 1), None);
        assert!(g.min_gap.iter().all(|x| x.is_infinite()), "{:?}", g.min_gap);
    }

    #[test]
    fn parallel_faces_keep_their_distance() {
        // b's top and bottom faces 1e-3 above a's, overlapping (its other faces
        // are 0.1 or more from a's): a gap of 1e-3, within the cap (the scene is
        // about 2 wide: cap ≈ 0.016), so a camera decides.
        let a = cube(DVec3::new(0.0, 0.0, 0.5), DVec3::splat(0.5));
        let b = cube(DVec3::new(0.2, 0.0, 0.501), DVec3::new(0.5, 0.4, 0.5));
        let g = gaps(&[a, b]);
        let gap = g.gap(0, 1).expect("within the cap");
        assert!((gap - 1e-3).abs() < 1e-9, "{gap}");
        // Offset far beyond the cap: no pair at all.
        let c = cube(DVec3::new(0.2, 0.0, 0.8), DVec3::new(0.5, 0.4, 0.5));
        let a = cube(DVec3::new(0.0, 0.0, 0.5), DVec3::splat(0.5));
        let g = gaps(&[a, c]);
        assert!(g.gap(0, 1).is_none(), "{:?}", g.pairs);
    }

    #[test]
    fn faces_that_only_touch_along_an_edge_do_not_tie() {
        // Two stacked boxes, one footprint: their side faces share planes and
        // touch along y = 1 only; their contact faces (opposite ways) tie.
        let a = cube(DVec3::new(0.0, 0.5, 0.0), DVec3::splat(0.5));
        let b = cube(DVec3::new(0.0, 1.5, 0.0), DVec3::splat(0.5));
        let g = gaps(&[a.clone(), b]);
        assert_eq!(g.zones.len(), 1, "{:?}", g.zones);
        let z = g.zones[0];
        assert!(z.opposite && z.lo.y == 1.0 && z.hi.y == 1.0, "{z:?}");
        // Sunk 0.01 into `a`, the side faces overlap on a strip (the same
        // way, coincident); the contact faces are 0.01 apart.
        let sunk = cube(DVec3::new(0.0, 1.49, 0.0), DVec3::splat(0.5));
        let g = gaps(&[a, sunk]);
        assert!(
            g.zones.iter().any(|z| !z.opposite && z.gap == 0.0),
            "{:?}",
            g.zones
        );
        // Two slabs tilted 45° about x, 0.3 apart (beyond the cap): their end
        // faces share the planes x = ±1 and their boxes overlap, but the faces
        // lie apart in those planes.
        let r = glam::DQuat::from_rotation_x(std::f64::consts::FRAC_PI_4);
        let slab = |offset: f64| {
            let mut m = cube(DVec3::new(0.0, 0.0, offset), DVec3::new(1.0, 0.5, 0.1));
            for p in &mut m.positions {
                *p = r * *p;
            }
            m
        };
        let g = gaps(&[slab(0.0), slab(0.5)]);
        assert!(g.pairs.is_empty(), "{:?}", g.pairs);
    }

    #[test]
    fn crossing_faces_do_not_tie() {
        // b rotated 45° about z: its faces cross a's, none is parallel to a side
        // face... except top and bottom, which lie 0.3 away from a's.
        let a = cube(DVec3::ZERO, DVec3::splat(0.5));
        let mut b = cube(DVec3::ZERO, DVec3::new(0.5, 0.5, 0.2));
        let r = glam::DQuat::from_rotation_z(std::f64::consts::FRAC_PI_4);
        for p in &mut b.positions {
            *p = r * *p;
        }
        let g = gaps(&[a, b]);
        assert!(g.pairs.is_empty(), "{:?}", g.pairs);
    }

    #[test]
    fn thin_walls_tie_within_one_mesh() {
        // A slab 1e-3 thick: its top and bottom faces face away from each other.
        let slab = cube(DVec3::ZERO, DVec3::new(0.5, 0.5, 0.5e-3));
        let g = gaps(&[slab]);
        let gap = g.gap(0, 0).expect("thin wall");
        assert!((gap - 1e-3).abs() < 1e-12, "{gap}");
        // A 0.1-thick slab's faces are 10 caps apart; its side faces touch only
        // faces facing the same way or crossing ones.
        let slab = cube(DVec3::ZERO, DVec3::new(0.5, 0.5, 0.05));
        assert!(gaps(&[slab]).pairs.is_empty());
    }

    #[test]
    fn finely_tessellated_curves_do_not_tie_with_themselves() {
        let s = shapes::make_sphere(1.0, 128, 64);
        let g = gaps(&[s]);
        assert!(g.pairs.is_empty(), "{:?}", g.pairs);
    }

    #[test]
    fn degenerate_input_gives_no_gaps() {
        let empty = Mesh {
            positions: vec![],
            triangles: vec![],
        };
        assert_eq!(gaps(&[empty]).min_gap, vec![f64::INFINITY]);
        assert_eq!(TieGaps::unknown(2).min_gap, vec![0.0, 0.0]);
    }
}
