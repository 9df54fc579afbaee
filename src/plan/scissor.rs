//! Screen rectangles of projected mesh bounding boxes: full-screen sweeps and
//! scissored draws only touch the pixels their meshes can cover. Pure.

use glam::{DMat4, DVec3};

pub use crate::plan::rect::Rect;
use crate::plan::step::Scissor;
use crate::scene::Aabb;

/// The union of the rectangles of any run of consecutive meshes in a few
/// operations: a sparse table whose level `k` holds the union of the `2^k`
/// rectangles from each index (union is idempotent, so two overlapping halves
/// give a run's union). A scissor `BoundsOf` all of a product's n meshes, which
/// Blister and CST give many draws, costs O(1) instead of n unions; recording
/// a plan with n-mesh scissors on every draw stays linear in its draws.
#[derive(Clone, Debug, Default)]
pub struct RectUnions {
    levels: Vec<Vec<Rect>>,
    /// Per mesh, where its inside can be seen through an opening
    /// ([`Scissor::Openings`]); `None` (or no entry): not known, the
    /// rectangle stays uncut.
    openings: Vec<Option<Rect>>,
}

impl RectUnions {
    /// The unions of `rects` (one per mesh), built in levels of doubling spans.
    pub fn new(rects: &[Rect]) -> RectUnions {
        let mut levels = vec![rects.to_vec()];
        let mut span = 1;
        while 2 * span <= rects.len() {
            let prev = levels.last().expect("level 0 exists");
            let next = (0..=rects.len() - 2 * span)
                .map(|i| prev[i].union(&prev[i + span]))
                .collect();
            levels.push(next);
            span *= 2;
        }
        RectUnions {
            levels,
            openings: Vec::new(),
        }
    }

    /// With `openings`, per mesh, the rectangle its inside can be seen in
    /// (`None`: not known), which [`Scissor::Openings`] is cut to.
    pub fn with_openings(mut self, openings: &[Option<Rect>]) -> RectUnions {
        self.openings = openings.to_vec();
        self
    }

    /// Where mesh `id`'s inside can be seen through an opening, when known
    /// ([`Self::with_openings`]).
    pub fn opening(&self, id: u32) -> Option<Rect> {
        self.openings.get(id as usize).copied().flatten()
    }

    /// The rectangle of mesh `id`.
    pub fn one(&self, id: u32) -> Rect {
        self.levels[0][id as usize]
    }

    /// The union of rectangles `a..b` (empty for an empty run).
    pub fn run(&self, a: usize, b: usize) -> Rect {
        if a >= b {
            return Rect::EMPTY;
        }
        let k = (usize::BITS - 1 - (b - a).leading_zeros()) as usize;
        let level = &self.levels[k];
        level[a].union(&level[b - (1 << k)])
    }

    /// The union of the rectangles of `ids`, one [`Self::run`] per run of
    /// consecutive ids.
    pub fn of(&self, ids: &[u32]) -> Rect {
        let (Some(&first), Some(&last)) = (ids.first(), ids.last()) else {
            return Rect::EMPTY;
        };
        // The common case, one ascending run, is checked without branches.
        let ascending = ids.windows(2).fold(true, |ok, w| ok & (w[1] == w[0] + 1));
        if ascending {
            return self.run(first as usize, last as usize + 1);
        }
        let mut rect = Rect::EMPTY;
        let mut start = 0;
        for i in 1..=ids.len() {
            if i == ids.len() || ids[i] != ids[i - 1] + 1 {
                rect = rect.union(&self.run(ids[start] as usize, ids[i - 1] as usize + 1));
                start = i;
            }
        }
        rect
    }

    /// The rectangle of a plan's scissor on a `width × height` image (empty when
    /// the step can change no pixel): what the executor sets, and what a cost
    /// estimate charges a draw.
    pub fn scissor(&self, s: &Scissor, width: u32, height: u32) -> Rect {
        match s {
            Scissor::Full => Rect::full(width, height),
            Scissor::BoundsOf(ms) => self.of(ms),
            Scissor::Run { first, end } => self.run(*first as usize, *end as usize),
            Scissor::Within { meshes, within } => self.of(meshes).intersect(&self.of(within)),
            Scissor::Overlap { of, and } => and
                .iter()
                .fold(self.of(of), |acc, m| acc.intersect(&self.one(*m))),
            Scissor::Openings { of, and } => {
                let r = and
                    .iter()
                    .fold(self.one(*of), |acc, m| acc.intersect(&self.one(*m)));
                match self.opening(*of) {
                    Some(seen) => r.intersect(&seen),
                    None => r,
                }
            }
        }
    }
}

/// The screen rectangle covering the projections of `boxes` (world space) through
/// `view` then `proj` (Vulkan clip space, y down) on a `width × height` image,
/// each box clipped to the near plane first as the GPU clips the triangles in
/// it: its corners at or behind `near` (view depth) and the points where its
/// edges cross the plane. A box wholly in front of the plane adds nothing. A
/// box that only reaches past the plane made the whole screen before: a fitted
/// camera puts `near` just in front of the nearest vertex, so the corner of a
/// rotated or L-shaped primitive's box (nonconvex_obj's bracket, complex's
/// chamfer box) lay in front of it (docs/bench.md). One pixel of
/// margin absorbs `f32` rounding on the GPU.
pub fn bounds_rect(
    view: DMat4,
    proj: DMat4,
    near: f64,
    boxes: &[Aabb],
    width: u32,
    height: u32,
) -> Rect {
    let mut rect = Rect::EMPTY;
    for b in boxes {
        let corners: [DVec3; 8] = std::array::from_fn(|i| {
            view.transform_point3(DVec3::new(
                if i & 1 == 0 { b.min.x } else { b.max.x },
                if i & 2 == 0 { b.min.y } else { b.max.y },
                if i & 4 == 0 { b.min.z } else { b.max.z },
            ))
        });
        let depth = |v: DVec3| -v.z;
        // The clipped box's vertices: the kept corners and, on each of the 12
        // edges (corners one bit apart) that crosses the plane, its crossing.
        let mut points = [DVec3::ZERO; 20];
        let mut n = 0;
        for (i, &c) in corners.iter().enumerate() {
            if depth(c) >= near {
                points[n] = c;
                n += 1;
            }
            for bit in [1, 2, 4] {
                let j = i | bit;
                let d = corners[j];
                if j != i && (depth(c) < near) != (depth(d) < near) {
                    let t = (near - depth(c)) / (depth(d) - depth(c));
                    let mut x = c.lerp(d, t);
                    // Exactly on the plane, not a rounding step in front of it.
                    x.z = -near;
                    points[n] = x;
                    n += 1;
                }
            }
        }
        let (mut lo_x, mut lo_y) = (f64::INFINITY, f64::INFINITY);
        let (mut hi_x, mut hi_y) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
        for v in &points[..n] {
            let clip = proj * v.extend(1.0);
            let (sx, sy) = (
                (clip.x / clip.w + 1.0) * 0.5 * width as f64,
                (clip.y / clip.w + 1.0) * 0.5 * height as f64,
            );
            lo_x = lo_x.min(sx);
            lo_y = lo_y.min(sy);
            hi_x = hi_x.max(sx);
            hi_y = hi_y.max(sy);
        }
        if n == 0 {
            // Wholly in front of the plane: nothing of it is drawn.
            continue;
        }
        if !(lo_x.is_finite() && lo_y.is_finite() && hi_x.is_finite() && hi_y.is_finite()) {
            // A projection that is not finite (`near` 0) covers the screen.
            return Rect::full(width, height);
        }
        let clamp_x = |v: f64| v.clamp(0.0, width as f64) as u32;
        let clamp_y = |v: f64| v.clamp(0.0, height as f64) as u32;
        let r = Rect {
            x0: clamp_x(lo_x.floor() - 1.0),
            y0: clamp_y(lo_y.floor() - 1.0),
            x1: clamp_x(hi_x.ceil() + 1.0),
            y1: clamp_y(hi_y.ceil() + 1.0),
        };
        if !r.is_empty() {
            rect = rect.union(&r);
        }
    }
    rect
}

#[cfg(test)]
mod tests {
    #[test]
    fn an_openings_scissor_is_cut_where_they_are_known() {
        use super::{RectUnions, Scissor};
        let r = |x0, y0, x1, y1| super::Rect { x0, y0, x1, y1 };
        let rects = [r(0, 0, 100, 100), r(40, 40, 60, 90), r(10, 10, 30, 30)];
        let s = |of| Scissor::Openings { of, and: vec![0] };
        let plain = RectUnions::new(&rects);
        // Not known: the overlap, as `Overlap` gives it.
        assert_eq!(plain.scissor(&s(1), 100, 100), r(40, 40, 60, 90));
        let cut = RectUnions::new(&rects).with_openings(&[None, Some(r(45, 40, 55, 50)), None]);
        assert_eq!(cut.scissor(&s(1), 100, 100), r(45, 40, 55, 50));
        assert_eq!(cut.scissor(&s(2), 100, 100), r(10, 10, 30, 30));
        // Known to be nowhere on screen: nothing.
        let none = RectUnions::new(&rects).with_openings(&[None, Some(super::Rect::EMPTY)]);
        assert!(none.scissor(&s(1), 100, 100).is_empty());
    }

    #[test]
    fn intersections_are_the_common_pixels_or_empty() {
        let r = |x0, y0, x1, y1| super::Rect { x0, y0, x1, y1 };
        let a = r(0, 0, 10, 10);
        assert_eq!(a.intersect(&r(5, 2, 20, 8)), r(5, 2, 10, 8));
        assert_eq!(r(5, 2, 20, 8).intersect(&a), r(5, 2, 10, 8));
        assert_eq!(a.intersect(&r(10, 0, 20, 10)), super::Rect::EMPTY);
        assert_eq!(a.intersect(&r(12, 12, 20, 20)), super::Rect::EMPTY);
        assert_eq!(a.intersect(&super::Rect::EMPTY), super::Rect::EMPTY);
        assert!(a.contains(&a.intersect(&r(3, 3, 4, 40))));
    }

    #[test]
    fn grown_rectangles_stay_in_the_image_and_contain_the_original() {
        let r = Rect {
            x0: 2,
            y0: 10,
            x1: 30,
            y1: 40,
        };
        let g = r.grown(5, 5, 32, 64);
        assert_eq!(
            g,
            Rect {
                x0: 0,
                y0: 5,
                x1: 32,
                y1: 45
            }
        );
        assert!(g.contains(&r) && !r.contains(&g));
        assert!(Rect::EMPTY.grown(5, 5, 32, 64).is_empty());
    }

    use super::*;
    use crate::scene::camera::DepthConvention;

    #[test]
    fn rect_unions_equal_the_union_of_the_ids_rectangles() {
        // Rectangles of varied sizes, some empty.
        let rects: Vec<Rect> = (0..37u32)
            .map(|i| match i % 5 {
                0 => Rect::EMPTY,
                _ => Rect {
                    x0: (i * 7) % 50,
                    y0: (i * 13) % 40,
                    x1: (i * 7) % 50 + 1 + i % 9,
                    y1: (i * 13) % 40 + 1 + (i * 3) % 11,
                },
            })
            .collect();
        let t = RectUnions::new(&rects);
        let naive = |ids: &[u32]| {
            ids.iter()
                .fold(Rect::EMPTY, |r, &i| r.union(&rects[i as usize]))
        };
        for a in 0..rects.len() {
            for b in a..=rects.len() {
                let ids: Vec<u32> = (a as u32..b as u32).collect();
                assert_eq!(t.of(&ids), naive(&ids), "{a}..{b}");
            }
        }
        for ids in [
            vec![5, 6, 7, 20, 21, 3],
            vec![0],
            vec![],
            vec![36, 35, 34],
            vec![0, 36],
        ] {
            assert_eq!(t.of(&ids), naive(&ids), "{ids:?}");
        }
        assert_eq!(RectUnions::new(&[]).of(&[]), Rect::EMPTY);
    }
    use crate::scene::{Camera, Projection};

    fn cam() -> Camera {
        Camera {
            eye: DVec3::new(0.0, 0.0, 5.0),
            target: DVec3::ZERO,
            up: DVec3::Y,
            projection: Projection::Orthographic { height: 4.0 },
            near: 0.5,
            far: 20.0,
        }
    }

    fn unit_box(c: DVec3, h: f64) -> Aabb {
        Aabb {
            min: c - DVec3::splat(h),
            max: c + DVec3::splat(h),
        }
    }

    /// The executor unions per-mesh rectangles: the same as one call on all boxes.
    #[test]
    fn bounds_rect_is_the_union_of_single_boxes() {
        let c = cam();
        let (view, proj) = (c.view(), c.proj(1.0, DepthConvention::Standard));
        let boxes = [
            Aabb {
                min: DVec3::new(-1.0, -0.5, -0.5),
                max: DVec3::new(-0.2, 0.5, 0.5),
            },
            Aabb {
                min: DVec3::new(0.3, 0.6, -1.0),
                max: DVec3::new(1.2, 1.4, 0.0),
            },
        ];
        let all = bounds_rect(view, proj, c.near, &boxes, 64, 64);
        let union = boxes.iter().fold(Rect::EMPTY, |r, b| {
            r.union(&bounds_rect(
                view,
                proj,
                c.near,
                std::slice::from_ref(b),
                64,
                64,
            ))
        });
        assert_eq!(all, union);
        assert!(!all.is_empty() && all != Rect::full(64, 64));
    }

    #[test]
    fn ortho_box_maps_to_expected_pixels() {
        let c = cam();
        let (w, h) = (100, 100);
        // Box [-1,1]^2 of a view 4 units high: pixels 25..75, plus the margin.
        let r = bounds_rect(
            c.view(),
            c.proj(1.0, DepthConvention::Standard),
            c.near,
            &[unit_box(DVec3::ZERO, 1.0)],
            w,
            h,
        );
        assert_eq!(
            r,
            Rect {
                x0: 24,
                y0: 24,
                x1: 76,
                y1: 76
            }
        );
        // y is downward: a box above the centre lands in the top half.
        let up = bounds_rect(
            c.view(),
            c.proj(1.0, DepthConvention::Standard),
            c.near,
            &[unit_box(DVec3::new(0.0, 1.5, 0.0), 0.25)],
            w,
            h,
        );
        assert!(up.y1 <= 50, "{up:?}");
    }

    #[test]
    fn near_plane_crossing_is_full_screen_and_union_and_clamp() {
        let c = Camera {
            projection: Projection::Perspective { fov_y_deg: 40.0 },
            ..cam()
        };
        let p = c.proj(2.0, DepthConvention::Reversed);
        let r = bounds_rect(
            c.view(),
            p,
            c.near,
            &[unit_box(DVec3::new(0.0, 0.0, 4.8), 0.5)],
            200,
            100,
        );
        assert_eq!(r, Rect::full(200, 100));
        let a = unit_box(DVec3::new(-0.5, 0.0, 0.0), 0.1);
        let b = unit_box(DVec3::new(0.5, 0.0, 0.0), 0.1);
        let ra = bounds_rect(c.view(), p, c.near, &[a], 200, 100);
        let rb = bounds_rect(c.view(), p, c.near, &[b], 200, 100);
        let rab = bounds_rect(c.view(), p, c.near, &[a, b], 200, 100);
        assert_eq!(rab, ra.union(&rb));
        assert!(ra.x1 < rb.x0);
        let far_off = unit_box(DVec3::new(100.0, 0.0, 0.0), 0.1);
        assert!(bounds_rect(c.view(), p, c.near, &[far_off], 200, 100).is_empty());
        assert!(bounds_rect(c.view(), p, c.near, &[], 200, 100).is_empty());
    }

    #[test]
    fn a_box_reaching_past_the_near_plane_is_clipped_to_it() {
        // The eye at z = 5 looks down -z, near 0.5: the box spans view depths
        // 0.3 to 3.0. Its rectangle is that of its part behind the near plane
        // (z <= 4.5), not the whole screen; a box wholly in front has none.
        let c = Camera {
            projection: Projection::Perspective { fov_y_deg: 40.0 },
            ..cam()
        };
        let p = c.proj(1.0, DepthConvention::Reversed);
        let rect = |b: Aabb| bounds_rect(c.view(), p, c.near, &[b], 200, 200);
        let span = |lo: DVec3, hi: DVec3| Aabb { min: lo, max: hi };
        let crossing = rect(span(DVec3::new(0.2, 0.1, 2.0), DVec3::new(0.4, 0.3, 4.7)));
        let behind = rect(span(DVec3::new(0.2, 0.1, 2.0), DVec3::new(0.4, 0.3, 4.5)));
        assert_eq!(crossing, behind);
        assert!(!crossing.is_empty() && crossing != Rect::full(200, 200));
        assert!(rect(span(
            DVec3::splat(-0.1) + DVec3::Z * 4.7,
            DVec3::splat(0.1) + DVec3::Z * 4.7
        ))
        .is_empty());
    }
}
