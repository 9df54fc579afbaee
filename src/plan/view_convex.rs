//! View-dependent convexity (OpenCSG's "convexity", measured for one view;
//! Stewart, Leach & John §3.5: a literal needs peeling only where its faces overlap
//! on screen).
//!
//! The plans treat a mesh as convex (one front and one back face per pixel: SCS
//! applies, Goldfeather and Kirsch draw its surface without peeling, CST peels it
//! once per orientation) when [`super::is_convex`] says so for every view, or
//! when this module shows it for the current camera: no vertex lies at or in
//! front of the near plane (so no ray starts inside the mesh: neither the eye
//! nor the near plane is within it), and no two of its front-facing triangles,
//! nor two of its back-facing ones, share an interior point on screen. With the
//! rasterizer's fill rule, no sample is then covered twice. A false "convex" is
//! a wrong image and a false "not convex" only costs peeling, so the tests
//! allow for every vertex moving by up to [`Screen::delta`] pixels on the GPU
//! (the coarsest subpixel snapping Vulkan allows, and f32 transforms) wherever
//! that could make a real overlap, and refuse on doubt.
//!
//! Per pair of triangles of one orientation, on screen:
//! - sharing no vertex: a separating axis (an edge normal of either) with a gap
//!   over twice the vertex error: two parts of the surface that merely touch on
//!   screen (a seam) are refused;
//! - sharing an edge, run in opposite directions (as a consistently oriented
//!   closed mesh does): two triangles of one orientation lie on opposite sides
//!   of the shared edge, which is bit-identical on the GPU, whatever the error;
//! - sharing one vertex (bit-identical too): the directions they span at it are
//!   disjoint.
//!
//! Anything else (more work than [`MAX_PAIR_TESTS`], triangles sharing all
//! three vertices or an edge run the same way) counts as an overlap.
//!
//! **Rounding-level overlaps.** Along the silhouette of a curved mesh faces are
//! seen almost edge-on: a sliver whose orientation the vertex error could flip,
//! folded between neighbours that share a vertex with it or with each other.
//! Moving vertices by the error can fold such neighbours over each other by up
//! to that error — a band a tenth of a pixel wide along the silhouette — for
//! every mesh, convex or not, as the f32 rounding that [`super::is_convex`]
//! accepts does; the plans' tie rules absorb it. So slivers are classified by
//! their exact orientation, pairs sharing a vertex are compared exactly, and a
//! pair with a sliver needs only a positive gap. A sliver that crosses another
//! face (a fin seen edge-on in front of a wall) overlaps it exactly and is
//! refused.
#![deny(unsafe_code)]

use std::collections::HashMap;

use glam::DVec2;

use super::convex::U32;
use crate::scene::camera::DepthConvention;
use crate::scene::{Camera, Mesh};

/// The pair tests one mesh may cost before it is reported as not convex (a
/// camera move re-runs the test, so it must stay cheap).
pub const MAX_PAIR_TESTS: usize = 4_000_000;

/// How far a vertex may be off its exact position once snapped to the coarsest
/// subpixel grid Vulkan allows (4 bits: half a 1/16 pixel step per axis), in pixels.
const SNAP_PX: f64 = std::f64::consts::SQRT_2 / 32.0;

/// Whether, seen by `camera` in a `width × height` image, every sample is covered
/// by at most one front-facing and at most one back-facing triangle of `mesh`,
/// and the near plane cuts none of it (module documentation).
pub fn view_convex(mesh: &Mesh, camera: &Camera, width: u32, height: u32) -> bool {
    let Some(screen) = Screen::project(mesh, camera, width, height) else {
        return false;
    };
    let tris: Vec<Tri> = mesh
        .triangles
        .iter()
        .map(|&t| Tri::new(t, &screen))
        .collect();
    [1, -1].into_iter().all(|orientation| {
        let class: Vec<&Tri> = tris
            .iter()
            .filter(|t| t.orientation == orientation)
            .collect();
        disjoint_interiors(&class, &screen)
    })
}

/// A mesh's vertices on screen (pixels), and how far the GPU's may be off them.
struct Screen {
    points: Vec<DVec2>,
    /// The most any vertex may be off its pixel position on the GPU.
    delta: f64,
}

impl Screen {
    /// `None` when a vertex lies at or in front of the near plane (with a margin
    /// for f32 clipping), or the projection is not finite.
    fn project(mesh: &Mesh, camera: &Camera, width: u32, height: u32) -> Option<Screen> {
        let (w, h) = (width as f64, height as f64);
        let m = camera.proj(w / h, DepthConvention::Standard) * camera.view();
        let rows = [m.row(0), m.row(1), m.row(3)];
        let margin = 1e-5 * (camera.far - camera.near).max(camera.near);
        let mut points = Vec::with_capacity(mesh.positions.len());
        let mut err: f64 = 0.0;
        for &p in &mesh.positions {
            if camera.view_depth(p) <= camera.near + margin {
                return None;
            }
            let q = p.extend(1.0);
            let c = m * q;
            let (x, y) = (c.x / c.w, c.y / c.w);
            if !(x.is_finite() && y.is_finite()) || c.w <= 0.0 {
                return None;
            }
            // f32 input and an f32 matrix product: each clip coordinate is off
            // by a few ulps of the sum of its terms' magnitudes (8 here, for the
            // four products, their sum, and the upload's rounding), and the
            // division adds the relative error of w.
            let mag = rows.map(|r| r.abs().dot(q.abs()) * 8.0 * U32);
            let ex = (mag[0] + x.abs() * mag[2]) / c.w * 0.5 * w;
            let ey = (mag[1] + y.abs() * mag[2]) / c.w * 0.5 * h;
            err = err.max(ex.hypot(ey));
            points.push(DVec2::new((x + 1.0) * 0.5 * w, (y + 1.0) * 0.5 * h));
        }
        Some(Screen {
            points,
            delta: SNAP_PX + err,
        })
    }
}

/// A triangle on screen.
struct Tri {
    v: [u32; 3],
    /// The sign of its screen area (0: none, it covers no sample).
    orientation: i8,
    /// Whether the vertex error could flip it (module documentation, slivers).
    sliver: bool,
    min: DVec2,
    max: DVec2,
}

impl Tri {
    fn new(v: [u32; 3], s: &Screen) -> Tri {
        let [a, b, c] = v.map(|i| s.points[i as usize]);
        let area2 = (b - a).perp_dot(c - a);
        let perimeter = (b - a).length() + (c - b).length() + (a - c).length();
        // Each edge vector moves by up to 2δ: the doubled area by up to
        // 2δ·(|e1| + |e2|) + 4δ², less than this.
        let d = s.delta;
        Tri {
            v,
            orientation: if area2 == 0.0 {
                0
            } else {
                area2.signum() as i8
            },
            sliver: area2.abs() <= 2.0 * d * perimeter + 4.0 * d * d,
            min: a.min(b).min(c),
            max: a.max(b).max(c),
        }
    }

    fn corners(&self, s: &Screen) -> [DVec2; 3] {
        self.v.map(|i| s.points[i as usize])
    }
}

/// Whether no two of `tris` (one orientation) may share an interior point on
/// the GPU (module documentation). Pairs are found through a grid of cells
/// about as many as triangles; each pair is tested in the one cell holding the
/// lower corner of the overlap of their (widened) boxes.
fn disjoint_interiors(tris: &[&Tri], s: &Screen) -> bool {
    if tris.len() < 2 {
        return true;
    }
    let pad = 2.0 * s.delta;
    let lo = tris.iter().fold(DVec2::INFINITY, |m, t| m.min(t.min)) - pad;
    let hi = tris.iter().fold(DVec2::NEG_INFINITY, |m, t| m.max(t.max)) + pad;
    let extent = (hi - lo).max(DVec2::splat(1e-9));
    let n = (tris.len() as f64).sqrt().ceil().clamp(1.0, 1024.0);
    let cell = extent / n;
    let cells = n as i64;
    let index = |p: DVec2| {
        let c = ((p - lo) / cell).floor();
        (
            (c.x as i64).clamp(0, cells - 1),
            (c.y as i64).clamp(0, cells - 1),
        )
    };
    let mut grid: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
    let mut entries = 0usize;
    for (k, t) in tris.iter().enumerate() {
        let (a, b) = (index(t.min - pad), index(t.max + pad));
        entries += ((b.0 - a.0 + 1) * (b.1 - a.1 + 1)) as usize;
        if entries > MAX_PAIR_TESTS {
            return false;
        }
        for x in a.0..=b.0 {
            for y in a.1..=b.1 {
                grid.entry((x, y)).or_default().push(k);
            }
        }
    }
    let mut tests = 0usize;
    for (&key, members) in &grid {
        for (i, &a) in members.iter().enumerate() {
            for &b in &members[i + 1..] {
                let (ta, tb) = (tris[a], tris[b]);
                let corner = (ta.min - pad).max(tb.min - pad);
                if corner.cmpgt(ta.max + pad).any() || corner.cmpgt(tb.max + pad).any() {
                    continue; // the boxes do not meet
                }
                if index(corner) != key {
                    continue; // tested in another cell
                }
                tests += 1;
                if tests > MAX_PAIR_TESTS || !apart(ta, tb, s) {
                    return false;
                }
            }
        }
    }
    true
}

/// Whether triangles `a` and `b` of one orientation keep disjoint interiors
/// under the vertex error (module documentation).
fn apart(a: &Tri, b: &Tri, s: &Screen) -> bool {
    let shared: Vec<(usize, usize)> = (0..3)
        .flat_map(|i| (0..3).map(move |j| (i, j)))
        .filter(|&(i, j)| a.v[i] == b.v[j])
        .collect();
    // Slivers are tested as they are (module documentation).
    let err = if a.sliver || b.sliver {
        0.0
    } else {
        2.0 * s.delta
    };
    match shared.as_slice() {
        [] => separated(a.corners(s), b.corners(s), err),
        // Run u → w in `a` and w → u in `b`, the two have the same sign of area
        // exactly when their third vertices lie on opposite sides of the edge:
        // then they meet only on it, which the fill rule gives to one.
        &[p, q] => {
            // Order the pair so that `a` runs from `from` to `to`.
            let (from, to) = if (p.0 + 1) % 3 == q.0 { (p, q) } else { (q, p) };
            (to.1 + 1) % 3 == from.1
        }
        &[(i, j)] => match (Arc::at(a, i, 0.0, s), Arc::at(b, j, 0.0, s)) {
            (Some(x), Some(y)) => x.apart(y),
            _ => false,
        },
        _ => false,
    }
}

/// Whether a separating axis among the edge normals of `a` and `b` leaves a gap
/// over `gap` between them.
fn separated(a: [DVec2; 3], b: [DVec2; 3], gap: f64) -> bool {
    let edges = |t: [DVec2; 3]| [t[1] - t[0], t[2] - t[1], t[0] - t[2]];
    edges(a).into_iter().chain(edges(b)).any(|e| {
        let len = e.length();
        if len == 0.0 {
            return false;
        }
        let n = e.perp() / len;
        let span = |t: [DVec2; 3]| {
            t.iter()
                .map(|p| n.dot(*p))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| {
                    (lo.min(d), hi.max(d))
                })
        };
        let ((alo, ahi), (blo, bhi)) = (span(a), span(b));
        blo - ahi > gap || alo - bhi > gap
    })
}

/// The directions a triangle spans at one of its corners: from `start` by
/// `width` (under half a turn) the way its orientation turns (angles taken
/// with y mirrored for orientation −1), each end uncertain by its angular
/// error. A triangle lies within its arc at each corner.
#[derive(Clone, Copy)]
struct Arc {
    start: f64,
    width: f64,
    start_err: f64,
    end_err: f64,
}

impl Arc {
    /// The arc of `t` at its corner `k` when the apex and each other corner
    /// move by up to `err` relative to each other; `None` when a side is not
    /// longer than that. A triangle that keeps its orientation still turns the
    /// same way, from its next corner to the one after.
    fn at(t: &Tri, k: usize, err: f64, s: &Screen) -> Option<Arc> {
        use std::f64::consts::TAU;
        let p = |i: usize| s.points[t.v[i % 3] as usize];
        let apex = p(k);
        let sigma = t.orientation as f64;
        let side = |q: DVec2| {
            let d = q - apex;
            let len = d.length();
            (len > err).then(|| ((sigma * d.y).atan2(d.x), (err / len).asin()))
        };
        let ((a, ea), (b, eb)) = (side(p(k + 1))?, side(p(k + 2))?);
        Some(Arc {
            start: a,
            width: (b - a).rem_euclid(TAU),
            start_err: ea,
            end_err: eb,
        })
    }

    /// Whether `self` and `o` (at one apex, of one orientation), with their
    /// errors, do not meet.
    fn apart(self, o: Arc) -> bool {
        use std::f64::consts::TAU;
        // From the end of self to the start of o, and from the end of o to the
        // start of self (before the errors).
        let g1 = (o.start - (self.start + self.width)).rem_euclid(TAU);
        let g2 = TAU - self.width - o.width - g1;
        g1 > self.end_err + o.start_err && g2 > o.end_err + self.start_err
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::fixtures::{box_mesh, sphere_mesh};
    use crate::scene::Projection;
    use glam::DVec3;

    fn camera(eye: DVec3, target: DVec3) -> Camera {
        Camera {
            eye,
            target,
            up: DVec3::Y,
            projection: Projection::Perspective { fov_y_deg: 40.0 },
            near: 0.1,
            far: 100.0,
        }
    }

    /// Two unit boxes side by side along x, as one closed mesh (touching at x = 1
    /// but not sharing vertices: an L-like union of two boxes).
    fn two_boxes(gap: f64) -> Mesh {
        let mut m = box_mesh(DVec3::ZERO, DVec3::ONE);
        let other = box_mesh(
            DVec3::new(1.0 + gap, 0.0, 0.0),
            DVec3::new(2.0 + gap, 1.0, 1.0),
        );
        let off = m.positions.len() as u32;
        m.positions.extend(other.positions);
        m.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + off)));
        m
    }

    #[test]
    fn a_convex_mesh_is_convex_in_every_view_outside_it() {
        let s = sphere_mesh(DVec3::ZERO, 1.0, 32, 16);
        for eye in [
            DVec3::new(3.0, 2.0, 4.0),
            DVec3::new(0.0, 0.0, 5.0),
            DVec3::new(-4.0, 1.0, 0.5),
        ] {
            assert!(
                view_convex(&s, &camera(eye, DVec3::ZERO), 800, 600),
                "{eye}"
            );
        }
        let b = box_mesh(DVec3::ZERO, DVec3::ONE);
        assert!(view_convex(
            &b,
            &camera(DVec3::new(3.0, 2.0, 4.0), DVec3::splat(0.5)),
            64,
            64
        ));
        // The eye inside, or the near plane through it: not provable.
        assert!(!view_convex(
            &s,
            &camera(DVec3::new(0.2, 0.0, 0.0), DVec3::X),
            64,
            64
        ));
    }

    #[test]
    fn two_boxes_are_convex_seen_across_their_row_not_along_it() {
        // Gaps apart: seen from the side (x row across the view) their images
        // are disjoint; seen along x one is behind the other.
        let m = two_boxes(0.5);
        let side = camera(DVec3::new(1.25, 0.5, 8.0), DVec3::new(1.25, 0.5, 0.5));
        assert!(view_convex(&m, &side, 400, 300));
        let along = camera(DVec3::new(8.0, 0.7, 0.6), DVec3::new(1.0, 0.5, 0.5));
        assert!(!view_convex(&m, &along, 400, 300));
        // Touching boxes (no vertex shared) may double-cover the seam: refused.
        let touching = two_boxes(0.0);
        assert!(!view_convex(&touching, &side, 400, 300));
    }

    #[test]
    fn separation_needs_a_gap_over_the_vertex_error() {
        let a = [DVec2::ZERO, DVec2::new(10.0, 0.0), DVec2::new(0.0, 10.0)];
        let shift = |d: f64| a.map(|p| p + DVec2::new(10.0 + d, 0.0));
        assert!(separated(a, shift(0.5), 0.2));
        assert!(!separated(a, shift(0.1), 0.2));
        assert!(!separated(a, shift(-0.1), 0.0));
    }

    /// The L-bracket of `scenes/nonconvex_obj.toml` and its camera.
    fn l_bracket() -> (Mesh, Camera) {
        use crate::scene::load::{load, LoadOptions};
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/nonconvex_obj.toml");
        let s = load(&path, &LoadOptions::default()).unwrap();
        (s.primitives[0].mesh.clone(), s.camera)
    }

    /// The most times a pixel centre's ray enters `mesh` (exact ray casting).
    fn most_entries(mesh: &Mesh, cam: &Camera, w: u32, h: u32) -> usize {
        use crate::geom::bvh::{Line, MeshBvh};
        let bvh = MeshBvh::new(mesh);
        let mut hits = Vec::new();
        let mut most = 0;
        for y in 0..h {
            for x in 0..w {
                let ray = cam.ray(x as f64 + 0.5, y as f64 + 0.5, w, h);
                hits.clear();
                bvh.cast_local(&Line::from_ray(&ray), &mut hits);
                most = most.max(hits.iter().filter(|c| c.t > 0.0 && c.entering).count());
            }
        }
        most
    }

    #[test]
    fn the_l_bracket_is_convex_from_its_scene_camera_not_along_its_notch() {
        let (l, cam) = l_bracket();
        assert!(!crate::plan::is_convex(&l));
        assert!(view_convex(&l, &cam, 800, 800));
        // Along x + y = 2.15 a ray crosses the vertical arm, the notch, then the
        // horizontal arm: two entries.
        let notch = Camera {
            eye: DVec3::new(4.0, -1.85, 1.5),
            target: DVec3::new(0.25, 1.9, 0.5),
            ..cam
        };
        assert!(!view_convex(&l, &notch, 800, 800));
        assert!(most_entries(&l, &notch, 96, 96) >= 2);
    }

    #[test]
    fn views_called_convex_have_one_entry_per_pixel() {
        // Eyes all around the L-bracket: wherever the test says convex, no
        // pixel centre's ray enters twice, and both answers occur.
        let (l, cam) = l_bracket();
        let centre = DVec3::new(0.8, 0.8, 0.5);
        let (mut yes, mut no) = (0, 0);
        for k in 0..48 {
            let (a, b) = (k as f64 * 0.7, (k % 7) as f64 * 0.45 - 1.3);
            let dir = DVec3::new(a.cos() * b.cos(), a.sin() * b.cos(), b.sin());
            let view = Camera {
                eye: centre + dir * 6.0,
                target: centre,
                up: if b.abs() > 1.2 { DVec3::X } else { DVec3::Z },
                near: 1.0,
                far: 20.0,
                ..cam
            };
            if view_convex(&l, &view, 64, 64) {
                yes += 1;
                assert_eq!(most_entries(&l, &view, 64, 64), 1, "{}", view.eye);
            } else {
                no += 1;
            }
        }
        eprintln!("{yes} convex, {no} not");
        assert!(yes > 0 && no > 0, "{yes} convex, {no} not");
    }
}
