//! OpenSCAD 2021.01's 2D shapes (`circle`, `square`, `polygon`) and their
//! extrusions (`linear_extrude`, `rotate_extrude`) as closed meshes, following
//! its `primitives.cc` (the outlines) and `GeometryEvaluator.cc`
//! (`extrudePolygon`, `add_slice`, `rotatePolygon`, `fill_ring`), with the slice
//! counts of its `calc.cc` (`get_helix_slices`, `get_conical_helix_slices`,
//! `get_diagonal_slices`).
//!
//! # Why each 2D primitive is extruded on its own
//!
//! The reader never evaluates the 2D Booleans into an outline. An extrusion maps
//! the plane slice by slice through a bijection: `linear_extrude` takes the
//! point `p` of the profile at height `t` to `(S(t) R(t) p, t)` with `S(t)` an
//! invertible scale and `R(t)` a rotation, and `rotate_extrude` takes it, within
//! one fragment's wedge, to `p.x · w(t) + p.y · Z` with `w(t)` a unit direction in
//! the XY plane. A map `f` that is injective commutes with the set operations —
//! `f(A ∪ B) = f(A) ∪ f(B)`, `f(A ∩ B) = f(A) ∩ f(B)`, `f(A − B) = f(A) − f(B)`
//! (any textbook on sets, e.g. Halmos, *Naive Set Theory*, §8 on functions) — so
//! a 2D CSG subtree under an extrusion is the 3D CSG of its extruded primitives,
//! which the renderers draw without a boundary evaluation.
//!
//! Where it does not hold exactly:
//! - `scale = 0` makes the top map non-injective (every point goes to the
//!   apex): the sets still agree except on the top face, a set of measure zero,
//!   which a renderer never sees. The mesh closes at one apex vertex (a cone);
//!   a scale of 0 on one axis alone leaves a zero-area top face.
//! - `rotate_extrude` maps the axis (`x = 0`) to itself for every angle: again
//!   a set of measure zero.
//! - OpenSCAD's meshes are piecewise flat: with a twist, each slice's side is
//!   two triangles per outline edge, not the ruled surface. The outline of `A − B`
//!   has vertices where `A`'s and `B`'s edges cross, and OpenSCAD's triangles
//!   over those sub-edges differ from ours over whole edges by at most the
//!   chord error of one slice. Without a twist every side is flat and the
//!   results coincide.
//! - The slice and fragment counts depend on the whole 2D child (its largest
//!   radius or x); they are computed from the evaluated 2D child (below), so
//!   every primitive of one extrusion gets OpenSCAD's counts.
//!
//! # Libraries
//!
//! - `i_overlay` (robust integer-snapped polygon Booleans with even-odd and
//!   non-zero fill rules): turns a `polygon` (several paths, nesting,
//!   self-intersections) into simple outlines with holes by the even-odd rule,
//!   as OpenSCAD's Clipper `sanitize` does, and evaluates the 2D child of an
//!   extrusion for its extents. Polygon Booleans are hard to get robust; this
//!   is a maintained crate used by `geo`.
//! - `earcutr` (a port of Mapbox's earcut, ear clipping with hole bridging):
//!   triangulates the caps of outlines with holes, returning an error rather
//!   than panicking on bad input; its triangle count is checked against
//!   Euler's formula so an incomplete triangulation is refused, not rendered.

use glam::{DAffine2, DVec2, DVec3};
use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::overlay::ShapeType;
use i_overlay::core::overlay_rule::OverlayRule;
use i_overlay::float::overlay::FloatOverlay;
use i_overlay::i_float::adapter::FloatPointAdapter;
use i_overlay::i_float::float::rect::FloatRect;
use std::collections::HashSet;

use super::super::Mesh;
use super::tessellate::{cos_degrees, sin_degrees, Resolution};

/// OpenSCAD's `GRID_FINE`.
const GRID_FINE: f64 = 0.000_000_953_674_316_406_25;
/// Coordinates beyond this are refused: the polygon library snaps to an
/// integer grid over the bounding box.
pub const MAX_COORD: f64 = 1e12;

/// A 2D region: shapes of one outer ring (counter-clockwise) and its holes
/// (clockwise), not crossing each other.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Region {
    pub shapes: Vec<Vec<Vec<DVec2>>>,
    /// One convex ring (circle, square): the caps are a fan.
    pub convex: bool,
}

/// A ring's signed area (the shoelace sum): positive counter-clockwise.
pub fn ring_area(ring: &[DVec2]) -> f64 {
    (0..ring.len())
        .map(|j| ring[j].perp_dot(ring[(j + 1) % ring.len()]))
        .sum::<f64>()
        / 2.0
}

impl Region {
    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }
    /// The sum of its rings' signed areas.
    #[cfg(test)]
    pub fn signed_area(&self) -> f64 {
        self.rings().map(|r| ring_area(r)).sum()
    }
    fn rings(&self) -> impl Iterator<Item = &Vec<DVec2>> {
        self.shapes.iter().flatten()
    }
    pub fn vertex_count(&self) -> usize {
        self.rings().map(|r| r.len()).sum()
    }
    fn to_paths(&self) -> Vec<Vec<[f64; 2]>> {
        self.rings()
            .map(|r| r.iter().map(|p| [p.x, p.y]).collect())
            .collect()
    }
    pub fn from_shapes(shapes: Vec<Vec<Vec<[f64; 2]>>>) -> Region {
        let shapes: Vec<Vec<Vec<DVec2>>> = shapes
            .into_iter()
            .map(|s| {
                s.into_iter()
                    .map(|c| {
                        c.into_iter()
                            .map(|[x, y]| DVec2::new(x, y))
                            .collect::<Vec<_>>()
                    })
                    .filter(|c: &Vec<DVec2>| c.len() >= 3)
                    .collect::<Vec<_>>()
            })
            .filter(|s: &Vec<Vec<DVec2>>| !s.is_empty())
            .collect();
        Region {
            shapes,
            convex: false,
        }
    }

    /// The image under `m` (a 2D `multmatrix`); a mirroring map reverses the
    /// rings so outer ones stay counter-clockwise (OpenSCAD re-sanitizes then).
    pub fn transformed(mut self, m: &DAffine2) -> Region {
        let flip = m.matrix2.determinant() < 0.0;
        for ring in self.shapes.iter_mut().flatten() {
            for p in ring.iter_mut() {
                *p = m.transform_point2(*p);
            }
            if flip {
                ring.reverse();
            }
        }
        self
    }
}

/// `circle(r)` with `n` fragments: point `i` at `360 i / n` degrees.
pub fn circle(r: f64, n: u64) -> Region {
    if r <= 0.0 {
        return Region::default();
    }
    let ring = (0..n)
        .map(|i| {
            let phi = 360.0 * i as f64 / n as f64;
            DVec2::new(r * cos_degrees(phi), r * sin_degrees(phi))
        })
        .collect();
    Region {
        shapes: vec![vec![ring]],
        convex: true,
    }
}

/// `square(size, center)`.
pub fn square(size: DVec2, center: bool) -> Region {
    if size.min_element() <= 0.0 {
        return Region::default();
    }
    let (a, b) = if center {
        (-size / 2.0, size / 2.0)
    } else {
        (DVec2::ZERO, size)
    };
    Region {
        shapes: vec![vec![vec![a, DVec2::new(b.x, a.y), b, DVec2::new(a.x, b.y)]]],
        convex: true,
    }
}

/// `polygon(points, paths)` after `m`: the paths filled by the even-odd rule
/// (OpenSCAD's `ClipperUtils::sanitize`), self-intersections resolved.
pub fn polygon(paths: &[Vec<DVec2>], m: &DAffine2) -> Region {
    let contours: Vec<Vec<[f64; 2]>> = paths
        .iter()
        .filter(|p| p.len() >= 3)
        .map(|p| {
            p.iter()
                .map(|&q| {
                    let q = m.transform_point2(q);
                    [q.x, q.y]
                })
                .collect()
        })
        .collect();
    if contours.is_empty() {
        return Region::default();
    }
    Region::from_shapes(overlay(
        &contours,
        &[],
        OverlayRule::Subject,
        FillRule::EvenOdd,
    ))
}

type Paths = Vec<Vec<[f64; 2]>>;

/// `i_overlay`'s Boolean of `subj` and `clip`, on an integer grid of 2^26 steps
/// over the half extent (its default grid of 2^30 lets cross products of
/// edge vectors overflow 64 bits on extreme inputs). Paths with no extent (all
/// points within 10^-200) are empty, as OpenSCAD's 2^-16 grid makes them.
pub fn overlay(
    subj: &[Vec<[f64; 2]>],
    clip: &[Vec<[f64; 2]>],
    rule: OverlayRule,
    fill: FillRule,
) -> Vec<Paths> {
    let Some(rect) = FloatRect::with_iter(subj.iter().chain(clip).flatten()) else {
        return Vec::new();
    };
    let half = 0.5 * rect.width().max(rect.height());
    if !(half > 1e-200 && half.is_finite()) {
        return Vec::new();
    }
    // A power of two: the scaling is exact.
    let scale = (26.0 - half.log2().ceil()).exp2();
    let cap = subj.iter().chain(clip).map(|c| c.len()).sum();
    let mut o = FloatOverlay::with_adapter(FloatPointAdapter::with_scale(rect, scale), cap);
    for c in subj {
        o = o.unsafe_add_contour(c, ShapeType::Subject);
    }
    for c in clip {
        o = o.unsafe_add_contour(c, ShapeType::Clip);
    }
    o.overlay(rule, fill)
}

/// A 2D Boolean of regions (`i_overlay`), for the extents of an extrusion's
/// child.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op2 {
    Union,
    Difference,
    Intersection,
}

pub fn boolean(op: Op2, kids: Vec<Region>) -> Region {
    let mut it = kids.into_iter();
    let Some(first) = it.next() else {
        return Region::default();
    };
    let rest: Vec<Region> = it.collect();
    if rest.is_empty() {
        return first;
    }
    let union_of =
        |rs: &[Region]| -> Vec<Vec<[f64; 2]>> { rs.iter().flat_map(|r| r.to_paths()).collect() };
    match op {
        Op2::Union => {
            let mut all = first.to_paths();
            all.extend(union_of(&rest));
            Region::from_shapes(overlay(&all, &[], OverlayRule::Subject, FillRule::NonZero))
        }
        Op2::Difference => {
            let clip = union_of(&rest);
            Region::from_shapes(overlay(
                &first.to_paths(),
                &clip,
                OverlayRule::Difference,
                FillRule::NonZero,
            ))
        }
        Op2::Intersection => {
            let mut acc = first;
            for r in rest {
                if acc.is_empty() {
                    break;
                }
                acc = Region::from_shapes(overlay(
                    &acc.to_paths(),
                    &r.to_paths(),
                    OverlayRule::Intersect,
                    FillRule::NonZero,
                ));
            }
            acc
        }
    }
}

/// What the slice and fragment counts need of an extrusion's 2D child.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Extents {
    /// Largest squared distance of a vertex from the origin.
    pub max_r_sqr: f64,
    /// `min(0, smallest x)` and `max(0, largest x)`, as `rotatePolygon` starts them.
    pub min_x: f64,
    pub max_x: f64,
}

impl Extents {
    pub fn of(r: &Region) -> Extents {
        let mut e = Extents::default();
        for p in r.rings().flatten() {
            e.max_r_sqr = e.max_r_sqr.max(p.length_squared());
            e.min_x = e.min_x.min(p.x);
            e.max_x = e.max_x.max(p.x);
        }
        e
    }
    /// `rotatePolygon`'s check: all points on one side of the axis.
    pub fn one_side(&self) -> bool {
        let w = self.max_x - self.min_x;
        !(w > self.max_x && w > self.min_x.abs())
    }
}

/// `calc_max_delta_sqr` over the region's vertices.
pub fn max_delta_sqr(r: &Region, scale: DVec2) -> f64 {
    r.rings()
        .flatten()
        .map(|&v| (v - v * scale).length_squared())
        .fold(0.0, f64::max)
}

fn min_twist_slices(twist: f64) -> u64 {
    ((twist / 120.0).ceil() as i64).max(1) as u64
}

fn helix_slices(r_sqr: f64, h: f64, twist: f64, res: Resolution) -> u64 {
    let twist = twist.abs();
    let min = min_twist_slices(twist);
    if r_sqr.sqrt() < GRID_FINE || !res.fn_.is_finite() {
        return min;
    }
    if res.fn_ > 0.0 {
        return ((twist / 360.0 * res.fn_).ceil() as u64).max(min);
    }
    let t = twist.to_radians();
    let c = h / t;
    let len = t * (r_sqr + c * c).sqrt();
    let fa = (twist / res.fa).ceil() as u64;
    let fs = (len / res.fs).ceil() as u64;
    fa.min(fs).max(min)
}

fn archimedes_length(a: f64, theta: f64) -> f64 {
    0.5 * a * (theta * (1.0 + theta * theta).sqrt() + theta.asinh())
}

fn conical_helix_slices(r_sqr: f64, h: f64, twist: f64, scale: f64, res: Resolution) -> u64 {
    let twist = twist.abs();
    let r = r_sqr.sqrt();
    let min = min_twist_slices(twist);
    if r < GRID_FINE || !res.fn_.is_finite() {
        return min;
    }
    if res.fn_ > 0.0 {
        return ((twist * res.fn_ / 360.0).ceil() as u64).max(min);
    }
    let rads = twist.to_radians();
    let end = if scale > 1.0 {
        rads * scale / (scale - 1.0)
    } else {
        rads / (1.0 - scale)
    };
    let start = end - rads;
    let a = r / end;
    let spiral = archimedes_length(a, end) - archimedes_length(a, start);
    let total = (spiral * spiral + h * h).sqrt();
    let fs = (total / res.fs).ceil() as u64;
    let fa = (twist / res.fa).ceil() as u64;
    fs.min(fa).max(min)
}

fn diagonal_slices(delta_sqr: f64, h: f64, res: Resolution) -> u64 {
    if delta_sqr.sqrt() < GRID_FINE || !res.fn_.is_finite() {
        return 1;
    }
    if res.fn_ > 0.0 {
        return (res.fn_ as u64).max(1);
    }
    (((delta_sqr + h * h).sqrt() / res.fs).ceil() as u64).max(1)
}

/// OpenSCAD's default slice count of `linear_extrude` (no `slices` given).
pub fn default_slices(child: &Region, h: f64, twist: f64, scale: DVec2, res: Resolution) -> u64 {
    let e = Extents::of(child);
    let delta = || max_delta_sqr(child, scale);
    if twist != 0.0 {
        if scale == DVec2::ONE {
            helix_slices(e.max_r_sqr, h, twist, res)
        } else if scale.x != scale.y {
            diagonal_slices(delta(), h, res).max(helix_slices(e.max_r_sqr, h, twist, res))
        } else {
            conical_helix_slices(e.max_r_sqr, h, twist, scale.x, res)
        }
    } else if scale.x != scale.y {
        diagonal_slices(delta(), h, res)
    } else {
        1
    }
}

/// The cap triangles of `r`, counter-clockwise, indexing its vertices in ring
/// order (shape by shape). `Err` when the outline cannot be triangulated.
/// `touching`: rings may repeat a point ([`splice_touching`]); earcut may
/// then make fewer triangles, accepted when they cover the shape's area.
pub fn cap(r: &Region, touching: bool) -> Result<Vec<[u32; 3]>, String> {
    if r.convex {
        let n = r.vertex_count() as u32;
        return Ok((1..n.saturating_sub(1)).map(|k| [0, k, k + 1]).collect());
    }
    let mut out = Vec::new();
    let mut base = 0u32;
    for shape in &r.shapes {
        let mut flat = Vec::new();
        let mut holes = Vec::new();
        for (k, ring) in shape.iter().enumerate() {
            if k > 0 {
                holes.push(flat.len() / 2);
            }
            for p in ring {
                flat.push(p.x);
                flat.push(p.y);
            }
        }
        let n = flat.len() / 2;
        let tri = earcutr::earcut(&flat, &holes, 2)
            .map_err(|e| format!("its outline could not be triangulated ({e:?})"))?;
        let pts: Vec<DVec2> = shape.iter().flatten().copied().collect();
        let want = n + 2 * holes.len() - 2;
        // Rings joined at a point (`splice_touching`): the triangles must
        // still cover the shape exactly (their areas add up to its area).
        if tri.len() / 3 != want && !touching {
            return Err(format!(
                "its outline could not be triangulated ({} of {want} triangles; the outline may touch itself)",
                tri.len() / 3
            ));
        }
        if tri.len() / 3 != want {
            let area = ring_area(&shape[0]).abs()
                - shape[1..].iter().map(|r| ring_area(r).abs()).sum::<f64>();
            let covered: f64 = tri
                .chunks(3)
                .map(|t| {
                    (pts[t[1]] - pts[t[0]])
                        .perp_dot(pts[t[2]] - pts[t[0]])
                        .abs()
                        / 2.0
                })
                .sum();
            if !((covered - area).abs() <= 1e-9 * area.abs().max(f64::MIN_POSITIVE)) {
                return Err(format!(
                    "its outline could not be triangulated ({} of {want} triangles, covering {covered} of its area {area}; the outline may cross itself)",
                    tri.len() / 3
                ));
            }
        }
        let signed: f64 = tri
            .chunks(3)
            .map(|t| (pts[t[1]] - pts[t[0]]).perp_dot(pts[t[2]] - pts[t[0]]))
            .sum();
        for t in tri.chunks(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| base + i as u32);
            out.push(if signed < 0.0 { [a, c, b] } else { [a, b, c] });
        }
        base += n as u32;
    }
    Ok(out)
}

/// `r` with every ring vertex that lies on another ring's edge (of the same
/// shape) inserted into that edge: the polygon library drops collinear
/// points, so a hole touching the outline at a point leaves a T-junction that
/// no closed mesh can have. Exact tests (the library's output is on a grid);
/// quadratic in the shape's size, so only run when triangulation failed.
pub fn split_touching(r: &Region) -> Region {
    let shapes = r
        .shapes
        .iter()
        .map(|shape| {
            let all: Vec<DVec2> = shape.iter().flatten().copied().collect();
            shape
                .iter()
                .map(|ring| {
                    let mut out = Vec::with_capacity(ring.len());
                    for j in 0..ring.len() {
                        let (a, b) = (ring[j], ring[(j + 1) % ring.len()]);
                        out.push(a);
                        let mut on: Vec<DVec2> = all
                            .iter()
                            .copied()
                            .filter(|&p| {
                                p != a
                                    && p != b
                                    && (b - a).perp_dot(p - a) == 0.0
                                    && (p - a).dot(b - a) > 0.0
                                    && (p - b).dot(a - b) > 0.0
                            })
                            .collect();
                        on.sort_by(|p, q| {
                            (*p - a)
                                .length_squared()
                                .total_cmp(&(*q - a).length_squared())
                        });
                        on.dedup();
                        out.extend(on);
                    }
                    out
                })
                .collect()
        })
        .collect();
    Region {
        shapes,
        convex: r.convex,
    }
}

/// `r` with rings that share a point joined there into one ring (a later
/// ring spliced into the earlier: `…, p, its other points…, p, …`), as the
/// bridge of a keyhole without width. Each copy of `p` then bounds one wedge
/// of the shape, so the extruded walls stay manifold, and earcut triangulates
/// the joined ring whole. Run after [`split_touching`].
pub fn splice_touching(r: &Region) -> Region {
    let key = |p: &DVec2| p.to_array().map(f64::to_bits);
    let shapes = r
        .shapes
        .iter()
        .map(|shape| {
            let mut rings = shape.clone();
            let mut k = 1;
            while k < rings.len() {
                let shared = (0..k).find_map(|i| {
                    let at: std::collections::HashMap<_, usize> = rings[i]
                        .iter()
                        .enumerate()
                        .map(|(j, p)| (key(p), j))
                        .collect();
                    rings[k]
                        .iter()
                        .enumerate()
                        .find_map(|(b, p)| at.get(&key(p)).map(|&a| (i, a, b)))
                });
                match shared {
                    Some((i, a, b)) => {
                        let ring = rings.remove(k);
                        let joined: Vec<DVec2> =
                            ring[b + 1..].iter().chain(&ring[..=b]).copied().collect();
                        rings[i].splice(a + 1..a + 1, joined);
                    }
                    None => k += 1,
                }
            }
            rings
        })
        .collect();
    Region {
        shapes,
        convex: r.convex,
    }
}

/// `linear_extrude` parameters (OpenSCAD's `LinearExtrudeNode`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Linear {
    pub h1: f64,
    pub h2: f64,
    pub twist: f64,
    pub scale: DVec2,
    pub slices: u64,
}

/// `extrudePolygon`: bottom cap, `slices` bands of `add_slice`, top cap (or an
/// apex where the scale is 0). CCW outward.
pub fn linear_mesh(r: &Region, cap: &[[u32; 3]], p: &Linear) -> Mesh {
    let n = r.vertex_count() as u32;
    let s = p.slices.max(1);
    let apex_top = p.scale == DVec2::ZERO;
    let mut positions = Vec::new();
    let at = |k: u64| -> (f64, DVec2, f64) {
        let t = k as f64 / s as f64;
        let rot = p.twist * k as f64 / s as f64;
        let sc = DVec2::new(
            1.0 - (1.0 - p.scale.x) * k as f64 / s as f64,
            1.0 - (1.0 - p.scale.y) * k as f64 / s as f64,
        );
        let _ = t;
        (rot, sc, p.h1 + (p.h2 - p.h1) * k as f64 / s as f64)
    };
    for k in 0..=s {
        let (rot, sc, z) = at(k);
        if k == s && apex_top {
            positions.push(DVec3::new(0.0, 0.0, z));
            break;
        }
        // Eigen's Scaling(scale) * Rotation2D(-rot).
        let (sn, cs) = (-rot.to_radians()).sin_cos();
        for v in r.rings().flatten() {
            let q = DVec2::new(cs * v.x - sn * v.y, sn * v.x + cs * v.y) * sc;
            positions.push(DVec3::new(q.x, q.y, z));
        }
    }
    let idx = |k: u64, i: u32| -> u32 {
        if k == s && apex_top {
            (s * n as u64) as u32
        } else {
            (k * n as u64) as u32 + i
        }
    };
    let mut triangles = Vec::new();
    for t in cap {
        triangles.push([t[0], t[2], t[1]]);
    }
    if !apex_top {
        for t in cap {
            triangles.push(t.map(|i| idx(s, i)));
        }
    }
    // The 2D position of vertex `i` at level `k`.
    let flat = |k: u64, i: u32| -> DVec2 { positions[idx(k, i) as usize].truncate() };
    for j in 0..s {
        let (rot1, _, _) = at(j);
        let (rot2, sc2, _) = at(j + 1);
        let any_zero = sc2.x == 0.0 || sc2.y == 0.0;
        // With equal diagonals, the choice follows the twist's direction and
        // the outline's orientation.
        let back_twist = rot2 <= rot1;
        let mut base = 0u32;
        for shape in &r.shapes {
            for (k, ring) in shape.iter().enumerate() {
                let positive = k == 0;
                let flip = !positive ^ back_twist;
                let m = ring.len() as u32;
                for i in 0..m {
                    let (a, b) = (base + i, base + (i + 1) % m);
                    let (prev1, curr1) = (idx(j, a), idx(j, b));
                    let (prev2, curr2) = (idx(j + 1, a), idx(j + 1, b));
                    // The shorter diagonal splits the quad (OpenSCAD's
                    // `add_slice` with `sgn_vdiff`), unless the top is scaled
                    // to 0 on an axis.
                    let d = sgn_vdiff(flat(j, a) - flat(j + 1, b), flat(j, b) - flat(j + 1, a));
                    let split_first = d < 0 || (d == 0 && !flip);
                    if split_first ^ any_zero {
                        triangles.push([prev1, curr1, curr2]);
                        if prev2 != curr2 {
                            triangles.push([curr2, prev2, prev1]);
                        }
                    } else {
                        triangles.push([prev1, curr1, prev2]);
                        if prev2 != curr2 {
                            triangles.push([prev2, curr1, curr2]);
                        }
                    }
                }
                base += m;
            }
        }
    }
    Mesh {
        positions,
        triangles,
    }
}

/// OpenSCAD's `sgn_vdiff`: −1, 0 or 1 as `|v1|` is shorter than, within 10 ppm
/// of, or longer than `|v2|`.
fn sgn_vdiff(v1: DVec2, v2: DVec2) -> i32 {
    let (l1, l2) = (v1.length(), v2.length());
    if 2.0 * (l1 - l2).abs() * 1e5 > l1 + l2 {
        if l1 < l2 {
            -1
        } else {
            1
        }
    } else {
        0
    }
}

/// `rotatePolygon`'s fragment count: `get_fragments_from_r(max_x − min_x)`
/// scaled by `|angle| / 360` and truncated, at least 1.
pub fn rotate_fragments(e: &Extents, angle: f64, res: Resolution) -> u64 {
    let f = super::tessellate::fragments(e.max_x - e.min_x, res) as f64;
    (f * angle.abs() / 360.0).max(1.0) as u64
}

/// `rotatePolygon`: rings of the profile (x the radius, y the height) at each
/// fragment, OpenSCAD's triangles between them, and the two end caps when
/// `angle` is not 360. CCW outward.
pub fn rotate_mesh(r: &Region, cap: &[[u32; 3]], angle: f64, fragments: u64, min_x: f64) -> Mesh {
    let full = angle == 360.0;
    let flip = (min_x >= 0.0 && angle > 0.0 && !full) || (min_x < 0.0 && (angle < 0.0 || full));
    let n = r.vertex_count() as u32;
    let rings = if full { fragments } else { fragments + 1 };
    let verts: Vec<DVec2> = r.rings().flatten().copied().collect();
    let mut positions = Vec::with_capacity((rings * n as u64) as usize);
    // Ring slots: `fill_ring` reverses each outline when flipping.
    let mut slot = vec![0u32; n as usize];
    let mut base = 0u32;
    for ring in r.rings() {
        let m = ring.len() as u32;
        for i in 0..m {
            slot[(base + i) as usize] = base + if flip { m - 1 - i } else { i };
        }
        base += m;
    }
    let mut order = vec![0u32; n as usize];
    for (v, &s) in slot.iter().enumerate() {
        order[s as usize] = v as u32;
    }
    for k in 0..rings {
        let a = if full {
            -90.0 + k as f64 * 360.0 / fragments as f64
        } else {
            90.0 - k as f64 * angle / fragments as f64
        };
        let (sa, ca) = (sin_degrees(a), cos_degrees(a));
        for &v in &order {
            let p = verts[v as usize];
            positions.push(DVec3::new(p.x * sa, p.x * ca, p.y));
        }
    }
    let at = |k: u64, s: u32| -> u32 { ((k % rings) * n as u64) as u32 + s };
    let mut triangles = Vec::new();
    for j in 0..fragments {
        let mut base = 0u32;
        for ring in r.rings() {
            let m = ring.len() as u32;
            for i in 0..m {
                let (s0, s1) = (base + i, base + (i + 1) % m);
                // OpenSCAD's two triangles per quad, reversed to our winding.
                triangles.push([at(j, s0), at(j, s1), at(j + 1, s1)]);
                triangles.push([at(j, s0), at(j + 1, s1), at(j + 1, s0)]);
            }
            base += m;
        }
    }
    if !full {
        let sides: HashSet<(u32, u32)> = triangles
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .collect();
        for k in [0, fragments] {
            let tris: Vec<[u32; 3]> = cap
                .iter()
                .map(|t| t.map(|v| at(k, slot[v as usize])))
                .collect();
            // Orient the cap against the sides it closes.
            let same = tris
                .iter()
                .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
                .any(|e| sides.contains(&e));
            for t in tris {
                triangles.push(if same { [t[0], t[2], t[1]] } else { t });
            }
        }
    }
    Mesh {
        positions,
        triangles,
    }
}
