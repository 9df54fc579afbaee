//! A triangle clipped to an axis-aligned box (Sutherland–Hodgman against the
//! box's six planes), for the bounds of the part of a mesh's faces inside
//! another primitive's box (`plan::cut_away`: where a face may be cut away).
#![deny(unsafe_code)]

use glam::DVec3;

use super::{bounds, Aabb};

/// The bounds of the part of triangle `tri` inside the closed box `b`; `None`
/// where they do not meet. Exact up to the rounding of the plane crossings
/// (a few ulps of the coordinates), which a caller that needs a cover grows
/// its box for.
pub fn triangle_in_box(tri: [DVec3; 3], b: &Aabb) -> Option<Aabb> {
    let tb = bounds(&tri);
    if tb.min.cmpgt(b.max).any() || tb.max.cmplt(b.min).any() {
        return None;
    }
    if tb.min.cmpge(b.min).all() && tb.max.cmple(b.max).all() {
        return Some(tb);
    }
    // At most 3 + 6 vertices after six planes.
    let mut poly: Vec<DVec3> = tri.to_vec();
    let mut next = Vec::with_capacity(9);
    for axis in 0..3 {
        for (bound, keep_above) in [(b.min[axis], true), (b.max[axis], false)] {
            // Signed distance inside the plane: ≥ 0 is kept.
            let inside = |p: DVec3| match keep_above {
                true => p[axis] - bound,
                false => bound - p[axis],
            };
            next.clear();
            for i in 0..poly.len() {
                let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
                let (dp, dq) = (inside(p), inside(q));
                if dp >= 0.0 {
                    next.push(p);
                }
                if (dp >= 0.0) != (dq >= 0.0) {
                    let t = dp / (dp - dq);
                    let mut x = p + (q - p) * t;
                    // The crossing lies on the plane.
                    x[axis] = bound;
                    next.push(x);
                }
            }
            std::mem::swap(&mut poly, &mut next);
            if poly.is_empty() {
                return None;
            }
        }
    }
    Some(bounds(&poly))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b(min: [f64; 3], max: [f64; 3]) -> Aabb {
        Aabb {
            min: DVec3::from(min),
            max: DVec3::from(max),
        }
    }

    #[test]
    fn a_triangle_is_cut_to_the_box_it_crosses() {
        let unit = b([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
        // Inside: its own bounds.
        let t = [
            DVec3::new(0.1, 0.1, 0.5),
            DVec3::new(0.9, 0.1, 0.5),
            DVec3::new(0.1, 0.9, 0.5),
        ];
        assert_eq!(triangle_in_box(t, &unit), Some(bounds(&t)));
        // A large triangle in the plane z = 0.5 covering the box's section:
        // the section itself.
        let big = [
            DVec3::new(-10.0, -10.0, 0.5),
            DVec3::new(30.0, -10.0, 0.5),
            DVec3::new(-10.0, 30.0, 0.5),
        ];
        assert_eq!(
            triangle_in_box(big, &unit),
            Some(b([0.0, 0.0, 0.5], [1.0, 1.0, 0.5]))
        );
        // A triangle whose bounds meet the box but which passes beside it
        // (its hypotenuse, x + y = 2.2, runs outside the corner (1, 1)).
        let beside = [
            DVec3::new(1.6, 0.6, 0.5),
            DVec3::new(1.6, 1.6, 0.5),
            DVec3::new(0.6, 1.6, 0.5),
        ];
        assert_eq!(triangle_in_box(beside, &unit), None);
        // Only its corner inside: a small box at that corner.
        let corner = [
            DVec3::new(0.8, 0.8, 0.5),
            DVec3::new(3.0, 0.8, 0.5),
            DVec3::new(0.8, 3.0, 0.5),
        ];
        assert_eq!(
            triangle_in_box(corner, &unit),
            Some(b([0.8, 0.8, 0.5], [1.0, 1.0, 0.5]))
        );
        // Apart: none; touching a face: the touching part.
        let apart = big.map(|p| p + DVec3::new(0.0, 0.0, 2.0));
        assert_eq!(triangle_in_box(apart, &unit), None);
        let touching = big.map(|p| p + DVec3::new(0.0, 0.0, 0.5));
        assert_eq!(
            triangle_in_box(touching, &unit),
            Some(b([0.0, 0.0, 1.0], [1.0, 1.0, 1.0]))
        );
    }

    #[test]
    fn a_slanted_triangle_keeps_every_point_inside_the_box() {
        let unit = b([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
        let t = [
            DVec3::new(-1.0, 0.3, -1.0),
            DVec3::new(2.0, 0.6, 0.5),
            DVec3::new(0.2, 2.0, 2.0),
        ];
        let got = triangle_in_box(t, &unit).expect("they meet");
        // Sample the triangle: every point inside the box is inside `got`.
        let n = 60;
        for i in 0..=n {
            for j in 0..=(n - i) {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                let p = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
                if p.cmpge(unit.min).all() && p.cmple(unit.max).all() {
                    let eps = 1e-12;
                    assert!(
                        p.cmpge(got.min - eps).all() && p.cmple(got.max + eps).all(),
                        "{p} outside {got:?}"
                    );
                }
            }
        }
        assert!(got.min.cmpge(unit.min).all() && got.max.cmple(unit.max).all());
    }
}
