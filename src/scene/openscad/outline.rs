//! Evaluated 2D outlines: OpenSCAD 2021.01's `offset`, 2D `hull` and 2D
//! `minkowski` (`GeometryEvaluator::visit(OffsetNode)`, `applyHull2D`,
//! `applyMinkowski2D`, `ClipperUtils::applyOffset` / `applyMinkowski`). Their
//! results are regions with holes that enter an extrusion as one 2D primitive
//! (`super::extrude`).
//!
//! # What is a library's and what is written here
//!
//! Every Boolean — the union that resolves an offset's raw contours, the union
//! of a Minkowski sum's pieces — is `i_overlay`'s (`super::extrude::overlay`),
//! with the fill rule OpenSCAD's Clipper uses (positive for offsets, non-zero
//! for sums).
//!
//! - **Offset contours.** `i_overlay`'s own outline offset
//!   (`mesh::outline::OutlineOffset`) splits a round join into equal angles and
//!   at least 8 segments per turn (its ratio is clamped to π/4); OpenSCAD's
//!   Clipper (`ClipperOffset::DoRound`, Johnson's Clipper 6.4) steps by a fixed
//!   angle, `2π / n` with `n` from `$fn`/`$fa`/`$fs`, and ends with a shorter
//!   step, so `offset(r = 1)` at the default resolution bevels a right angle
//!   in one segment. To draw OpenSCAD's vertices, the raw contour of each ring
//!   (Clipper's `OffsetPoint`: miter, square and round joins, and the
//!   three-point notch at reflex corners) is built here and `i_overlay` unions
//!   the contours with the positive fill rule, as Clipper does.
//! - **Convex hull.** Andrew's monotone chain (Andrew, "Another efficient
//!   algorithm for convex hulls in two dimensions", IPL 9(5), 1979). The
//!   maintained choice, `geo`'s `ConvexHull`, resolves under this crate's Rust
//!   1.80 floor only to `geo` 0.29, which pins `i_overlay` 1.9 against our 4.x,
//!   and would add `rstar`, `spade` and `geographiclib-rs`: thirty lines here
//!   weigh less.
//! - **Minkowski sums.** As Clipper's `MinkowskiSum` (closed) and OpenSCAD's
//!   `fill_minkowski_insides`: `A ⊕ B` is the union of the parallelograms
//!   `e ⊕ f` over the edges `e` of `A` and `f` of `B` (which cover `∂A ⊕ ∂B`),
//!   with `A + b₀` for each outer ring of `B` and `B + a₀` for each outer ring of
//!   `A` (the interiors); two convex rings take the hull of the pairwise sums
//!   instead (de Berg et al., *Computational Geometry*, 3rd ed., §13.3).

use glam::DVec2;
use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::overlay_rule::OverlayRule;

use super::extrude::{overlay, Region};
use super::tessellate::cos_degrees;

/// OpenSCAD's Clipper scale: 2¹⁶ integer steps per unit (its tolerances, such
/// as "collinear" corners, are in those steps).
const CLIPPER_SCALE: f64 = 65536.0;

/// The corner joins of `offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Join {
    /// `offset(r)`: arcs of `fragments` per full turn.
    Round { fragments: f64 },
    /// `offset(delta)`: sharp corners (OpenSCAD's miter limit of 10⁶).
    Miter,
    /// `offset(delta, chamfer = true)`: corners cut at distance `|delta|`.
    Square,
}

/// `offset(r | delta)` of `region`: Clipper's raw contours of every ring, then
/// their union under the positive fill rule.
pub fn offset(region: &Region, delta: f64, join: Join) -> Region {
    if region.is_empty() || delta == 0.0 {
        return region.clone();
    }
    let d = delta * CLIPPER_SCALE;
    // ClipperOffset::DoOffset's step angle for round joins.
    let (mut step_sin, mut step_cos, mut steps_per_rad) = (0.0, 1.0, 0.0);
    if let Join::Round { fragments } = join {
        let arc_tolerance = d.abs() * (1.0 - cos_degrees(180.0 / fragments));
        let y = if arc_tolerance <= 0.0 {
            0.25
        } else if arc_tolerance > d.abs() * 0.25 {
            d.abs() * 0.25
        } else {
            arc_tolerance
        };
        let mut steps = std::f64::consts::PI / (1.0 - y / d.abs()).acos();
        if steps > d.abs() * std::f64::consts::PI {
            steps = d.abs() * std::f64::consts::PI;
        }
        let a = std::f64::consts::TAU / steps;
        (step_sin, step_cos) = a.sin_cos();
        steps_per_rad = steps / std::f64::consts::TAU;
        if d < 0.0 {
            step_sin = -step_sin;
        }
    }
    let mut contours: Vec<Vec<[f64; 2]>> = Vec::new();
    for ring in region.shapes.iter().flatten() {
        // Clipper's integer path: points in its units, repeats removed.
        let mut src: Vec<DVec2> = Vec::with_capacity(ring.len());
        for p in ring {
            let q = *p * CLIPPER_SCALE;
            if src.last() != Some(&q) {
                src.push(q);
            }
        }
        while src.len() > 1 && src.first() == src.last() {
            src.pop();
        }
        let n = src.len();
        if n < 3 {
            continue;
        }
        let normals: Vec<DVec2> = (0..n)
            .map(|j| {
                let e = src[(j + 1) % n] - src[j];
                DVec2::new(e.y, -e.x) / e.length()
            })
            .collect();
        let mut out: Vec<DVec2> = Vec::with_capacity(n * 2);
        let mut k = n - 1;
        for j in 0..n {
            let (nk, nj, p) = (normals[k], normals[j], src[j]);
            k = j;
            let mut sin_a = nk.x * nj.y - nj.x * nk.y;
            let cos_a = nk.dot(nj);
            if (sin_a * d).abs() < 1.0 {
                if cos_a > 0.0 {
                    out.push(p + nk * d);
                    continue;
                }
            } else {
                sin_a = sin_a.clamp(-1.0, 1.0);
            }
            if sin_a * d < 0.0 {
                out.push(p + nk * d);
                out.push(p);
                out.push(p + nj * d);
                continue;
            }
            match join {
                Join::Miter => {
                    let r = 1.0 + cos_a;
                    // Clipper's limit 2 / 10⁶² for OpenSCAD's miter limit.
                    if r >= 2e-12 {
                        out.push(p + (nk + nj) * (d / r));
                    } else {
                        square_corner(&mut out, p, nk, nj, sin_a, cos_a, d);
                    }
                }
                Join::Square => square_corner(&mut out, p, nk, nj, sin_a, cos_a, d),
                Join::Round { .. } => {
                    let a = sin_a.atan2(cos_a);
                    let steps = ((steps_per_rad * a.abs()).round() as i64).max(1);
                    let mut v = nk;
                    for _ in 0..steps {
                        out.push(p + v * d);
                        v = DVec2::new(
                            v.x * step_cos - step_sin * v.y,
                            v.x * step_sin + v.y * step_cos,
                        );
                    }
                    out.push(p + nj * d);
                }
            }
        }
        contours.push(
            out.iter()
                .map(|q| [q.x / CLIPPER_SCALE, q.y / CLIPPER_SCALE])
                .collect(),
        );
    }
    Region::from_shapes(overlay(
        &contours,
        &[],
        OverlayRule::Subject,
        FillRule::Positive,
    ))
}

/// Clipper's `DoSquare`: the corner cut perpendicular to its bisector at
/// distance `|d|` from the vertex.
fn square_corner(
    out: &mut Vec<DVec2>,
    p: DVec2,
    nk: DVec2,
    nj: DVec2,
    sin_a: f64,
    cos_a: f64,
    d: f64,
) {
    let dx = (sin_a.atan2(cos_a) / 4.0).tan();
    out.push(p + d * DVec2::new(nk.x - nk.y * dx, nk.y + nk.x * dx));
    out.push(p + d * DVec2::new(nj.x + nj.y * dx, nj.y - nj.x * dx));
}

/// The convex hull of `points`, counter-clockwise, collinear points dropped
/// (Andrew's monotone chain); fewer than 3 points or no area: `None`.
pub fn convex_hull(mut points: Vec<DVec2>) -> Option<Vec<DVec2>> {
    points.retain(|p| p.is_finite());
    points.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    points.dedup();
    if points.len() < 3 {
        return None;
    }
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<DVec2> = Vec::with_capacity(points.len() + 1);
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 {
            Box::new(points.iter())
        } else {
            Box::new(points.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    (hull.len() >= 3).then_some(hull)
}

/// 2D `hull()`: the convex hull of every vertex of every child.
pub fn hull(children: &[Region]) -> Region {
    let points: Vec<DVec2> = children
        .iter()
        .flat_map(|r| r.shapes.iter().flatten().flatten().copied())
        .collect();
    match convex_hull(points) {
        Some(ring) => Region {
            shapes: vec![vec![ring]],
            convex: true,
        },
        None => Region::default(),
    }
}

/// 2D `minkowski()` of the children, left to right.
pub fn minkowski(children: Vec<Region>) -> Region {
    // A ⊕ ∅ = ∅.
    if children.iter().any(Region::is_empty) {
        return Region::default();
    }
    let mut it = children.into_iter();
    let Some(mut acc) = it.next() else {
        return Region::default();
    };
    for b in it {
        acc = minkowski2(&acc, &b);
    }
    acc
}

fn is_convex_ring(r: &Region) -> bool {
    match &r.shapes[..] {
        [shape] if shape.len() == 1 => {
            let ring = &shape[0];
            let n = ring.len();
            r.convex
                || (0..n).all(|i| {
                    let (a, b, c) = (ring[i], ring[(i + 1) % n], ring[(i + 2) % n]);
                    (b - a).perp_dot(c - b) >= 0.0
                })
        }
        _ => false,
    }
}

fn minkowski2(a: &Region, b: &Region) -> Region {
    if is_convex_ring(a) && is_convex_ring(b) {
        let (ra, rb) = (&a.shapes[0][0], &b.shapes[0][0]);
        let sums = ra
            .iter()
            .flat_map(|&p| rb.iter().map(move |&q| p + q))
            .collect();
        return hull(&[Region {
            shapes: vec![vec![sums]],
            convex: false,
        }]);
    }
    let mut pieces: Vec<Vec<[f64; 2]>> = Vec::new();
    let rings = |r: &Region| -> Vec<Vec<DVec2>> { r.shapes.iter().flatten().cloned().collect() };
    let (ra, rb) = (rings(a), rings(b));
    for pa in &ra {
        for pb in &rb {
            let (n, m) = (pa.len(), pb.len());
            for i in 0..n {
                for j in 0..m {
                    let q = [
                        pa[i] + pb[j],
                        pa[(i + 1) % n] + pb[j],
                        pa[(i + 1) % n] + pb[(j + 1) % m],
                        pa[i] + pb[(j + 1) % m],
                    ];
                    let area =
                        (q[1] - q[0]).perp_dot(q[2] - q[0]) + (q[2] - q[0]).perp_dot(q[3] - q[0]);
                    let mut quad: Vec<[f64; 2]> = q.iter().map(|p| [p.x, p.y]).collect();
                    if area < 0.0 {
                        quad.reverse();
                    }
                    pieces.push(quad);
                }
            }
        }
    }
    // The interiors: each region translated by a vertex of the other's outer rings.
    for (x, y) in [(a, b), (b, a)] {
        for shape in &y.shapes {
            let t = shape[0][0];
            for ring in x.shapes.iter().flatten() {
                pieces.push(ring.iter().map(|p| [p.x + t.x, p.y + t.y]).collect());
            }
        }
    }
    Region::from_shapes(overlay(
        &pieces,
        &[],
        OverlayRule::Subject,
        FillRule::NonZero,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(r: &Region) -> f64 {
        r.shapes
            .iter()
            .flatten()
            .map(|ring| {
                let n = ring.len();
                (0..n)
                    .map(|i| ring[i].perp_dot(ring[(i + 1) % n]))
                    .sum::<f64>()
                    / 2.0
            })
            .sum()
    }

    fn square(s: f64) -> Region {
        super::super::extrude::square(DVec2::splat(s), true)
    }

    #[test]
    fn offsets_of_a_square() {
        // delta: sharp corners, 12 × 12.
        assert!((area(&offset(&square(10.0), 1.0, Join::Miter)) - 144.0).abs() < 1e-6);
        // chamfer: cut at distance 1 from each corner, (√2 − 1)² off each.
        let c = offset(&square(10.0), 1.0, Join::Square);
        let want = 144.0 - 4.0 * (2f64.sqrt() - 1.0).powi(2);
        assert!((area(&c) - want).abs() < 1e-6, "{}", area(&c));
        // r = 1 at 5 fragments: one bevel per right angle (as OpenSCAD).
        let r = offset(&square(10.0), 1.0, Join::Round { fragments: 5.0 });
        assert_eq!(r.vertex_count(), 8);
        // r = 1 at 360 fragments: close to a rounded square.
        let r = offset(&square(10.0), 1.0, Join::Round { fragments: 360.0 });
        let want = 100.0 + 40.0 + std::f64::consts::PI;
        assert!((area(&r) - want).abs() < 1e-3, "{}", area(&r));
        // inset: 8 × 8.
        assert!(
            (area(&offset(&square(10.0), -1.0, Join::Round { fragments: 8.0 })) - 64.0).abs()
                < 1e-6
        );
        // inset past the middle: nothing.
        assert!(offset(&square(10.0), -6.0, Join::Miter).is_empty());
    }

    #[test]
    fn hull_and_minkowski() {
        let two = Region {
            shapes: vec![
                square(2.0).shapes[0].clone(),
                vec![square(2.0).shapes[0][0]
                    .iter()
                    .map(|p| *p + DVec2::new(10.0, 0.0))
                    .collect()],
            ],
            convex: false,
        };
        assert!((area(&hull(&[two.clone()])) - 24.0).abs() < 1e-9);
        // Convex ⊕ convex: 4 × 4.
        assert!((area(&minkowski(vec![square(2.0), square(2.0)])) - 16.0).abs() < 1e-9);
        // Two squares ⊕ a square: two 4 × 4 squares.
        assert!((area(&minkowski(vec![two, square(2.0)])) - 32.0).abs() < 1e-6);
        assert!(convex_hull(vec![DVec2::ZERO, DVec2::X, DVec2::X * 2.0]).is_none());
    }
}
