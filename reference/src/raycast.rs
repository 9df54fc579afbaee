//! The exact reference renderer: one `f64` line per pixel centre, all crossings with
//! every primitive an expression names, and the regularized classification of the
//! open intervals between them (Rossignac & Wu §2–4, Hable & Rossignac §1).
//!
//! Per pixel:
//! 1. all crossings of the whole line with each needed primitive ([`peeltrim::geom::bvh`]);
//!    a primitive's inside state on an interval is `(#entering − #exiting) > 0` of the
//!    crossings before it (outside before the first one);
//! 2. crossings closer than `tol` to their predecessor along the line form one event
//!    group and are applied together, so an interval of zero length (a coincident
//!    face, a touching contact, a zero-thickness sheet) is never classified: this is
//!    the regularization. `tol = 1e-10 × L`, `L` the diagonal of the box around all
//!    primitives, surfaces and the eye (line parameters are computed to about
//!    `1e-15 × L`, so distinct faces closer than `tol` count as coincident);
//! 3. each interval is classified against every solid (`[csg]` and `[[solid]]`s,
//!    united); the visible point is the start of the first interval inside the solid
//!    whose start has a view depth within `[near, far]` (what lies outside is clipped,
//!    like on the GPU: an interval starting before `near` shows nothing at `near`);
//! 4. its primitive is the lowest-index primitive (among those a solid names) with a
//!    crossing in that event group (lowest index wins on coincident faces, within
//!    `tol`), its normal that crossing's triangle's geometric normal;
//! 5. surfaces: the nearest crossing (within `[near, far]`) of each surface mesh whose
//!    point is in the trim volume (`keep = In`), outside it (`Out`), or any crossing
//!    (`Paint`, drawn in `paint_color` where in the volume). The point is classified
//!    with the primitive states just before it along the line (crossings within
//!    `tol` before it not yet applied). A surface replaces the solid's point only when
//!    it is nearer by more than `tol` (primitives have the lower indices).

use glam::DVec3;
use rayon::prelude::*;

use peeltrim::csg::expr::{Expr, Node};
use peeltrim::geom::bvh::{scene_scale, Crossing, Line, SceneBvh, WorldCrossing};
use peeltrim::images::{shade, Images};
use peeltrim::scene::{Keep, Scene};

/// Relative tolerance for grouping crossings into one event (× the scene scale).
pub const GROUP_TOL_REL: f64 = 1e-10;

/// An expression flattened to post-order for allocation-free evaluation.
#[derive(Clone, Debug)]
pub(super) struct Compiled {
    ops: Vec<Op>,
}

#[derive(Clone, Copy, Debug)]
enum Op {
    Leaf(u32),
    Not(u32),
    Union(u32, u32),
    Inter(u32, u32),
    Diff(u32, u32),
}

impl Compiled {
    fn new(e: &Expr) -> Compiled {
        let order = e.postorder();
        let mut slot = vec![u32::MAX; e.nodes.len()];
        let mut ops = Vec::with_capacity(order.len());
        for (i, &n) in order.iter().enumerate() {
            slot[n as usize] = i as u32;
            let s = |k: u32| slot[k as usize];
            ops.push(match e.nodes[n as usize] {
                Node::Leaf { prim } => Op::Leaf(prim),
                Node::Not(a) => Op::Not(s(a)),
                Node::Union(a, b) => Op::Union(s(a), s(b)),
                Node::Inter(a, b) => Op::Inter(s(a), s(b)),
                Node::Diff(a, b) => Op::Diff(s(a), s(b)),
            });
        }
        Compiled { ops }
    }

    pub(super) fn eval(&self, count: &[i32], vals: &mut Vec<bool>) -> bool {
        vals.clear();
        for op in &self.ops {
            let v = match *op {
                Op::Leaf(p) => count.get(p as usize).is_some_and(|&c| c > 0),
                Op::Not(a) => !vals[a as usize],
                Op::Union(a, b) => vals[a as usize] || vals[b as usize],
                Op::Inter(a, b) => vals[a as usize] && vals[b as usize],
                Op::Diff(a, b) => vals[a as usize] && !vals[b as usize],
            };
            vals.push(v);
        }
        vals.last().copied().unwrap_or(false)
    }
}

/// A scene prepared for casting: BVHs, compiled expressions, tolerance.
pub struct Prepared<'a> {
    pub(super) scene: &'a Scene,
    pub(super) prims: SceneBvh,
    pub(super) needed: Vec<bool>,
    /// Primitives some solid names: only these give the visible point its index.
    in_solids: Vec<bool>,
    surfaces: SceneBvh,
    pub(super) solids: Vec<Compiled>,
    trims: Vec<Compiled>,
    /// Absolute grouping tolerance along the line (unit direction: scene units).
    pub tol: f64,
}

/// What one pixel's line sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f64,
    pub point: DVec3,
    /// View depth of `point`.
    pub depth: f64,
    /// 0-based index: primitives, then surfaces.
    pub index: u32,
    /// Unit geometric normal of the hit triangle.
    pub normal: DVec3,
    pub rgb: [u8; 3],
    /// Unit direction of the pixel's line.
    pub dir: DVec3,
}

#[derive(Default)]
struct Scratch {
    tmp: Vec<Crossing>,
    events: Vec<WorldCrossing>,
    surf: Vec<WorldCrossing>,
    count: Vec<i32>,
    vals: Vec<bool>,
}

impl<'a> Prepared<'a> {
    pub fn new(scene: &'a Scene) -> Prepared<'a> {
        let n = scene.primitives.len();
        let mut needed: Vec<bool> = scene.primitives.iter().map(|p| p.used).collect();
        let exprs = scene
            .solids
            .iter()
            .map(|s| &s.expr)
            .chain(scene.surfaces.iter().map(|s| &s.trim));
        for e in exprs {
            for p in e.leaves() {
                if let Some(x) = needed.get_mut(p as usize) {
                    *x = true;
                }
            }
        }
        let mut in_solids = vec![false; n];
        for sol in &scene.solids {
            for p in sol.expr.leaves() {
                if let Some(x) = in_solids.get_mut(p as usize) {
                    *x = true;
                }
            }
        }
        // Unneeded primitives get an empty BVH so indices stay aligned.
        let empty = peeltrim::scene::Mesh::default();
        let prims = SceneBvh::new((0..n).map(|i| {
            if needed[i] {
                &scene.primitives[i].mesh
            } else {
                &empty
            }
        }));
        let surfaces = SceneBvh::new(scene.surfaces.iter().map(|s| &s.mesh));
        let mut all = prims.clone();
        all.shapes.extend(surfaces.shapes.iter().cloned());
        let tol = GROUP_TOL_REL * scene_scale(&all, &scene.camera);
        Prepared {
            scene,
            prims,
            needed,
            in_solids,
            surfaces,
            solids: scene
                .solids
                .iter()
                .map(|s| Compiled::new(&s.expr))
                .collect(),
            trims: scene
                .surfaces
                .iter()
                .map(|s| Compiled::new(&s.trim))
                .collect(),
            tol,
        }
    }

    /// Classifies a point against the scene's solids (union) by counting crossings
    /// of a fixed generic line through it before it. Points within the grouping
    /// tolerance of a face are ambiguous.
    pub fn inside_solid(&self, p: DVec3) -> bool {
        let line = Line::new(
            p,
            DVec3::new(0.5257311121, 0.6070619982, 0.5957439617).normalize(),
        );
        let mut s = Scratch::default();
        let needed = &self.needed;
        self.prims
            .cast(&line, |i| needed[i], &mut s.tmp, &mut s.events);
        s.count.resize(self.prims.shapes.len(), 0);
        for e in s.events.iter().filter(|e| e.crossing.t < 0.0) {
            s.count[e.shape as usize] += if e.crossing.entering { 1 } else { -1 };
        }
        self.in_solid(&s.count, &mut s.vals)
    }

    fn in_solid(&self, count: &[i32], vals: &mut Vec<bool>) -> bool {
        self.solids.iter().any(|s| s.eval(count, vals))
    }

    /// Casts the line through pixel centre `(px, py)` of a `width × height` image.
    pub fn cast_pixel(&self, px: f64, py: f64, width: u32, height: u32) -> Option<Hit> {
        let mut s = Scratch::default();
        self.cast_with(&mut s, px, py, width, height)
    }

    fn cast_with(&self, s: &mut Scratch, px: f64, py: f64, w: u32, h: u32) -> Option<Hit> {
        let cam = &self.scene.camera;
        let ray = cam.ray(px, py, w, h);
        let line = Line::from_ray(&ray);
        let fwd = cam.forward();
        let depth_of = |t: f64| (line.at(t) - cam.eye).dot(fwd);
        let (near, far) = (cam.near, cam.far);

        s.events.clear();
        let needed = &self.needed;
        self.prims
            .cast(&line, |i| needed[i], &mut s.tmp, &mut s.events);
        s.events
            .sort_unstable_by(|a, b| a.crossing.t.total_cmp(&b.crossing.t));
        s.count.clear();
        s.count.resize(self.prims.shapes.len(), 0);

        // The solid: sweep event groups.
        let mut solid: Option<(WorldCrossing, f64)> = None;
        let mut prev = self.in_solid(&s.count, &mut s.vals);
        let mut i = 0;
        while i < s.events.len() {
            let mut j = i;
            let mut best = s.events[i];
            while j < s.events.len()
                && (j == i || s.events[j].crossing.t - s.events[j - 1].crossing.t <= self.tol)
            {
                let e = s.events[j];
                s.count[e.shape as usize] += if e.crossing.entering { 1 } else { -1 };
                // Lowest index among the crossing primitives a solid names (a
                // primitive only trimming surfaces is no face of the solid).
                let named = |p: u32| self.in_solids[p as usize];
                if (named(e.shape) && (!named(best.shape) || e.shape < best.shape))
                    || (!named(best.shape) && e.shape < best.shape)
                {
                    best = e;
                }
                j += 1;
            }
            let now = self.in_solid(&s.count, &mut s.vals);
            if !prev && now {
                let d = depth_of(best.crossing.t);
                if d > far {
                    break;
                }
                if d >= near {
                    solid = Some((best, d));
                    break;
                }
            }
            prev = now;
            i = j;
        }

        let solid_t = solid.map_or(f64::INFINITY, |(e, _)| e.crossing.t);
        let mut surf_hit: Option<(usize, Crossing, f64, bool)> = None;
        for (si, surface) in self.scene.surfaces.iter().enumerate() {
            s.surf.clear();
            self.surfaces
                .cast(&line, |k| k == si, &mut s.tmp, &mut s.surf);
            s.surf
                .sort_unstable_by(|a, b| a.crossing.t.total_cmp(&b.crossing.t));
            for k in 0..s.surf.len() {
                let c = s.surf[k].crossing;
                let limit = surf_hit.map_or(solid_t - self.tol, |(_, b, _, _)| {
                    b.t.min(solid_t - self.tol)
                });
                if c.t >= limit {
                    break;
                }
                let d = depth_of(c.t);
                if d < near || d > far {
                    continue;
                }
                // Primitive states just before the point.
                s.count.iter_mut().for_each(|x| *x = 0);
                for e in s
                    .events
                    .iter()
                    .take_while(|e| e.crossing.t < c.t - self.tol)
                {
                    s.count[e.shape as usize] += if e.crossing.entering { 1 } else { -1 };
                }
                let in_v = self.trims[si].eval(&s.count, &mut s.vals);
                let keep = match surface.keep {
                    Keep::In => in_v,
                    Keep::Out => !in_v,
                    Keep::Paint => true,
                };
                if keep {
                    surf_hit = Some((si, c, d, in_v));
                    break;
                }
            }
        }

        if let Some((si, c, d, in_v)) = surf_hit {
            let surface = &self.scene.surfaces[si];
            let rgb = if surface.keep == Keep::Paint && in_v {
                surface.paint_color
            } else {
                surface.color
            };
            return Some(Hit {
                t: c.t,
                point: line.at(c.t),
                depth: d,
                index: (self.scene.primitives.len() + si) as u32,
                normal: self.surfaces.shapes[si].normal(c.tri),
                rgb,
                dir: line.dir,
            });
        }
        solid.map(|(e, d)| Hit {
            t: e.crossing.t,
            point: line.at(e.crossing.t),
            depth: d,
            index: e.shape,
            normal: self.prims.shapes[e.shape as usize].normal(e.crossing.tri),
            rgb: self.scene.primitives[e.shape as usize].color,
            dir: line.dir,
        })
    }
}

/// Vulkan's standard sample locations (specification, "Multisampling",
/// table "Standard sample locations") within a pixel, in sample order, for
/// 1, 2, 4 and 8 samples: where a device with `standardSampleLocations`
/// classifies each sample, so the reference casts its rays there too.
pub fn sample_positions(samples: u32) -> &'static [(f64, f64)] {
    match samples {
        2 => &[(0.75, 0.75), (0.25, 0.25)],
        4 => &[
            (0.375, 0.125),
            (0.875, 0.375),
            (0.125, 0.625),
            (0.625, 0.875),
        ],
        8 => &[
            (0.5625, 0.3125),
            (0.4375, 0.6875),
            (0.8125, 0.5625),
            (0.3125, 0.1875),
            (0.1875, 0.8125),
            (0.0625, 0.4375),
            (0.6875, 0.9375),
            (0.9375, 0.0625),
        ],
        _ => &[(0.5, 0.5)],
    }
}

/// Renders `scene` at `width × height` with the exact reference, at the
/// scene's samples per pixel (`[render] samples`).
pub fn render(scene: &Scene, width: u32, height: u32) -> Images {
    render_with_normals(scene, width, height).0
}

/// [`render`], plus the unit geometric normal of the visible triangle per pixel
/// (zero for background), row-major like the images.
pub fn render_with_normals(scene: &Scene, width: u32, height: u32) -> (Images, Vec<[f32; 3]>) {
    let (img, normals, _) = render_samples(scene, width, height);
    (img, normals)
}

/// [`render_with_normals`], plus each pixel's coverage: the samples a ray
/// hits the solid at, times 255 over the samples, rounded (255 or 0 at one
/// sample). One ray per sample at [`sample_positions`]: the colour is the
/// mean of the samples' shaded colours (rounded to the nearest byte, as a
/// UNORM resolve), depth, primitive and normal those of sample 0, the sample
/// the GPU's read-back reports (`vk::resolve`).
pub fn render_samples(scene: &Scene, width: u32, height: u32) -> (Images, Vec<[f32; 3]>, Vec<u8>) {
    let prep = Prepared::new(scene);
    let bg = scene.render.background;
    let background = [bg[0], bg[1], bg[2], 255];
    let positions = sample_positions(scene.render.samples);
    type Px = ([u8; 4], f32, u16, [f32; 3], u8);
    let rows: Vec<Vec<Px>> = (0..height)
        .into_par_iter()
        .map_init(Scratch::default, |s, y| {
            (0..width)
                .map(|x| {
                    let mut sum = [0u32; 3];
                    let mut hits = 0u32;
                    let mut first = None;
                    for (i, (sx, sy)) in positions.iter().enumerate() {
                        let px = x as f64 + sx;
                        let py = y as f64 + sy;
                        let (c, d, p, nrm) = match prep.cast_with(s, px, py, width, height) {
                            None => (background, f32::INFINITY, 0, [0.0; 3]),
                            Some(hit) => {
                                hits += 1;
                                let cos = hit.normal.dot(hit.dir).abs();
                                (
                                    shade(hit.rgb, cos),
                                    hit.depth as f32,
                                    (hit.index + 1).min(u16::MAX as u32) as u16,
                                    hit.normal.as_vec3().to_array(),
                                )
                            }
                        };
                        for (a, v) in sum.iter_mut().zip(c) {
                            *a += v as u32;
                        }
                        if i == 0 {
                            first = Some((d, p, nrm));
                        }
                    }
                    let n = positions.len() as f64;
                    let mean = |a: u32| (a as f64 / n).round() as u8;
                    let (d, p, nrm) = first.expect("at least one sample");
                    let cov = (hits as f64 * 255.0 / n).round() as u8;
                    (
                        [mean(sum[0]), mean(sum[1]), mean(sum[2]), 255],
                        d,
                        p,
                        nrm,
                        cov,
                    )
                })
                .collect()
        })
        .collect();
    let n = width as usize * height as usize;
    let mut img = Images {
        width,
        height,
        color: Vec::with_capacity(n),
        depth: Vec::with_capacity(n),
        prim: Vec::with_capacity(n),
    };
    let mut normals = Vec::with_capacity(n);
    let mut coverage = Vec::with_capacity(n);
    for row in rows {
        for (c, d, p, nrm, cov) in row {
            img.color.push(c);
            img.depth.push(d);
            img.prim.push(p);
            normals.push(nrm);
            coverage.push(cov);
        }
    }
    (img, normals, coverage)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use glam::DVec3;
    use peeltrim::scene::fixtures::*;
    use peeltrim::scene::{Keep, Projection};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const W: u32 = 48;
    const H: u32 = 40;

    fn cam() -> peeltrim::scene::Camera {
        camera(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, 40.0, 0.1, 100.0)
    }

    fn b(min: [f64; 3], max: [f64; 3]) -> peeltrim::scene::Mesh {
        box_mesh(DVec3::from(min), DVec3::from(max))
    }

    fn diff01() -> peeltrim::csg::Expr {
        let mut e = ExprBuilder::default();
        let (a, bb) = (e.leaf(0), e.leaf(1));
        let r = e.diff(a, bb);
        e.build(r)
    }

    /// Where the line of pixel (x, y) meets the plane z = `z`, or None when parallel.
    fn at_plane(scene: &Scene, x: u32, y: u32, z: f64) -> DVec3 {
        let r = scene.camera.ray(x as f64 + 0.5, y as f64 + 0.5, W, H);
        r.origin + r.dir * ((z - r.origin.z) / r.dir.z)
    }

    fn px(img: &Images, x: u32, y: u32) -> (f32, u16) {
        let i = (y * img.width + x) as usize;
        (img.depth[i], img.prim[i])
    }

    #[test]
    fn box_head_on_perspective_and_ortho() {
        for ortho in [false, true] {
            let mut c = cam();
            if ortho {
                c.projection = Projection::Orthographic { height: 3.0 };
            }
            let sc = scene(
                c,
                vec![prim("a", b([-1.0; 3], [1.0; 3]), [200, 100, 50])],
                union_all(1),
            );
            let img = render(&sc, W, H);
            let mut covered = 0;
            for y in 0..H {
                for x in 0..W {
                    let p = at_plane(&sc, x, y, 1.0);
                    let (d, id) = px(&img, x, y);
                    let m = p.x.abs().max(p.y.abs());
                    if (m - 1.0).abs() < 1e-9 {
                        continue;
                    }
                    if m < 1.0 {
                        covered += 1;
                        assert_eq!(id, 1);
                        assert_eq!(d, 4.0f32, "exact face depth");
                        let r = sc.camera.ray(x as f64 + 0.5, y as f64 + 0.5, W, H);
                        let i = (y * W + x) as usize;
                        assert_eq!(img.color[i], shade([200, 100, 50], r.dir.z.abs()));
                    } else {
                        assert_eq!((d, id), (f32::INFINITY, 0), "pixel {x},{y}");
                        assert_eq!(img.color[(y * W + x) as usize], [10, 20, 30, 255]);
                    }
                }
            }
            assert!(covered > 100, "{covered}");
        }
    }

    /// A − B with B poking out of A's front face: the hole shows B's inner back
    /// wall (z = 0, depth 5) with B's id.
    #[test]
    fn difference_hole_shows_inner_wall() {
        let sc = scene(
            cam(),
            vec![
                prim("a", b([-1.0; 3], [1.0; 3]), [200, 0, 0]),
                prim("b", b([-0.3, -0.3, 0.0], [0.3, 0.3, 2.0]), [0, 200, 0]),
            ],
            diff01(),
        );
        let img = render(&sc, W, H);
        let (mut hole, mut face) = (0, 0);
        for y in 0..H {
            for x in 0..W {
                let p0 = at_plane(&sc, x, y, 0.0);
                let p1 = at_plane(&sc, x, y, 1.0);
                let (d, id) = px(&img, x, y);
                if p0.x.abs().max(p0.y.abs()) < 0.299 {
                    hole += 1;
                    assert_eq!((d, id), (5.0, 2), "pixel {x},{y}");
                } else if p1.x.abs().max(p1.y.abs()) > 0.301 && p1.x.abs().max(p1.y.abs()) < 0.999 {
                    face += 1;
                    assert_eq!((d, id), (4.0, 1), "pixel {x},{y}");
                }
            }
        }
        assert!(hole > 4 && face > 50, "{hole} {face}");
    }

    /// A + B sharing the front face plane z = 1 (B tessellated differently): the
    /// lowest index wins, whatever the order.
    #[test]
    fn union_coincident_face_lowest_index_wins() {
        let big = || b([-1.0; 3], [1.0; 3]);
        let small = || grid_box_mesh(DVec3::new(-0.5, -0.5, 0.0), DVec3::new(0.5, 0.5, 1.0), 3);
        for swap in [false, true] {
            let prims = if swap {
                vec![
                    prim("b", small(), [0, 200, 0]),
                    prim("a", big(), [200, 0, 0]),
                ]
            } else {
                vec![
                    prim("a", big(), [200, 0, 0]),
                    prim("b", small(), [0, 200, 0]),
                ]
            };
            let sc = scene(cam(), prims, union_all(2));
            let img = render(&sc, W, H);
            for y in 0..H {
                for x in 0..W {
                    let p = at_plane(&sc, x, y, 1.0);
                    let m = p.x.abs().max(p.y.abs());
                    let (d, id) = px(&img, x, y);
                    if m < 0.499 {
                        assert_eq!((d, id), (4.0, 1), "swap {swap} pixel {x},{y}");
                    } else if m > 0.501 && m < 0.999 {
                        assert_eq!((d, id), (4.0, if swap { 2 } else { 1 }));
                    }
                }
            }
        }
    }

    /// Regularization: A − B with B's front face on A's front face leaves no
    /// zero-thickness sheet; A − A' (same box, other tessellation) and the
    /// intersection of two touching boxes are empty.
    #[test]
    fn coincident_faces_are_regularized() {
        let sc = scene(
            cam(),
            vec![
                prim("a", b([-1.0; 3], [1.0; 3]), [200, 0, 0]),
                prim(
                    "b",
                    grid_box_mesh(DVec3::new(-0.5, -0.5, 0.0), DVec3::new(0.5, 0.5, 1.0), 2),
                    [0, 200, 0],
                ),
            ],
            diff01(),
        );
        let img = render(&sc, W, H);
        let mut n = 0;
        for y in 0..H {
            for x in 0..W {
                let p = at_plane(&sc, x, y, 0.0);
                if p.x.abs().max(p.y.abs()) < 0.499 {
                    n += 1;
                    assert_eq!(px(&img, x, y), (5.0, 2), "pixel {x},{y}");
                }
            }
        }
        assert!(n > 10);

        let same = scene(
            cam(),
            vec![
                prim("a", b([-1.0; 3], [1.0; 3]), [200, 0, 0]),
                prim(
                    "a2",
                    grid_box_mesh(DVec3::splat(-1.0), DVec3::splat(1.0), 3),
                    [0, 200, 0],
                ),
            ],
            diff01(),
        );
        assert!(render(&same, W, H).prim.iter().all(|&p| p == 0));

        let mut e = ExprBuilder::default();
        let (l0, l1) = (e.leaf(0), e.leaf(1));
        let r = e.inter(l0, l1);
        let touching = scene(
            camera(DVec3::new(3.0, 2.0, 5.0), DVec3::ZERO, 40.0, 0.1, 100.0),
            vec![
                prim("l", b([-1.0; 3], [0.0, 1.0, 1.0]), [200, 0, 0]),
                prim(
                    "r",
                    grid_box_mesh(DVec3::new(0.0, -1.0, -1.0), DVec3::splat(1.0), 2),
                    [0, 200, 0],
                ),
            ],
            e.build(r),
        );
        assert!(render(&touching, W, H).prim.iter().all(|&p| p == 0));
    }

    /// The eye inside a big box A: A alone shows nothing (clipped at near); A − B
    /// shows B's back face (z = −1, depth 6).
    #[test]
    fn eye_inside_a_primitive() {
        let prims = || {
            vec![
                prim("a", b([-10.0; 3], [10.0; 3]), [200, 0, 0]),
                prim("b", b([-1.0; 3], [1.0; 3]), [0, 200, 0]),
            ]
        };
        for ortho in [false, true] {
            let mut c = cam();
            if ortho {
                c.projection = Projection::Orthographic { height: 3.0 };
            }
            let sc = scene(c, prims(), union_all(1));
            assert!(render(&sc, W, H).prim.iter().all(|&p| p == 0));
            let sc = scene(c, prims(), diff01());
            let img = render(&sc, W, H);
            let mut n = 0;
            for y in 0..H {
                for x in 0..W {
                    let p = at_plane(&sc, x, y, -1.0);
                    if p.x.abs().max(p.y.abs()) < 0.999 {
                        n += 1;
                        assert_eq!(px(&img, x, y), (6.0, 2), "ortho {ortho} pixel {x},{y}");
                    } else if at_plane(&sc, x, y, 1.0).abs().max_element() > 1.001 {
                        assert_eq!(px(&img, x, y).1, 0);
                    }
                }
            }
            assert!(n > 50);
        }
    }

    /// Points nudged just inside / outside each face of a box (and of a complement).
    #[test]
    fn nudged_points_classify_correctly() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let lo = DVec3::new(-0.7, -0.2, 0.3);
        let hi = DVec3::new(1.1, 0.9, 1.4);
        let sc = scene(
            cam(),
            vec![prim("a", grid_box_mesh(lo, hi, 3), [1, 2, 3])],
            union_all(1),
        );
        let prep = Prepared::new(&sc);
        let mut e = ExprBuilder::default();
        let l = e.leaf(0);
        let r = e.not(l);
        let nsc = scene(cam(), sc.primitives.clone(), e.build(r));
        let nprep = Prepared::new(&nsc);
        for axis in 0..3 {
            for (side, sign) in [(lo, -1.0), (hi, 1.0)] {
                for _ in 0..50 {
                    let mut p = DVec3::new(
                        rng.gen_range(lo.x..hi.x),
                        rng.gen_range(lo.y..hi.y),
                        rng.gen_range(lo.z..hi.z),
                    );
                    p[axis] = side[axis];
                    for eps in [1e-6, 1e-8] {
                        let mut n = DVec3::ZERO;
                        n[axis] = sign * eps;
                        assert!(prep.inside_solid(p - n), "{p} in");
                        assert!(!prep.inside_solid(p + n), "{p} out");
                        assert!(!nprep.inside_solid(p - n));
                        assert!(nprep.inside_solid(p + n));
                    }
                }
            }
        }
    }

    /// A trimmed plane z = 0.5 across a box: In / Out / Paint.
    #[test]
    fn trimmed_surface_keep_modes() {
        let plane = peeltrim::scene::Mesh {
            positions: vec![
                DVec3::new(-3.0, -3.0, 0.5),
                DVec3::new(3.0, -3.0, 0.5),
                DVec3::new(3.0, 3.0, 0.5),
                DVec3::new(-3.0, 3.0, 0.5),
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        };
        for keep in [Keep::In, Keep::Out, Keep::Paint] {
            let mut sc = scene(
                cam(),
                vec![prim("v", b([-1.0; 3], [1.0; 3]), [1, 2, 3])],
                union_all(1),
            );
            sc.solids.clear();
            sc.surfaces.push(surface(
                "s",
                plane.clone(),
                [100, 100, 100],
                union_all(1),
                keep,
                [0, 0, 250],
            ));
            let img = render(&sc, W, H);
            for y in 0..H {
                for x in 0..W {
                    let p = at_plane(&sc, x, y, 0.5);
                    let m = p.x.abs().max(p.y.abs());
                    if (m - 1.0).abs() < 1e-3 || m > 2.9 {
                        continue;
                    }
                    let inside = m < 1.0;
                    let (d, id) = px(&img, x, y);
                    let shown = match keep {
                        Keep::In => inside,
                        Keep::Out => !inside,
                        Keep::Paint => true,
                    };
                    if shown {
                        assert_eq!((d, id), (4.5, 2), "{keep:?} {x},{y}");
                        let c = img.color[(y * W + x) as usize];
                        assert_eq!(c[2] > c[0], keep == Keep::Paint && inside);
                    } else {
                        assert_eq!(id, 0);
                    }
                }
            }
        }
    }

    /// A scene of `n` random boxes and spheres (union), for timing.
    pub fn random_scene(n: u32, seed: u64) -> Scene {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let prims = (0..n)
            .map(|i| {
                let c = DVec3::new(
                    rng.gen_range(-3.0..3.0),
                    rng.gen_range(-3.0..3.0),
                    rng.gen_range(-3.0..3.0),
                );
                let r = rng.gen_range(0.2..0.9);
                let mesh = if i % 2 == 0 {
                    box_mesh(c - DVec3::splat(r), c + DVec3::splat(r))
                } else {
                    sphere_mesh(c, r, 32, 16)
                };
                prim(&format!("p{i}"), mesh, [rng.gen(), rng.gen(), rng.gen()])
            })
            .collect();
        // Alternate unions and differences: p0 - p1 + p2 - p3 ...
        let mut e = ExprBuilder::default();
        let mut acc = e.leaf(0);
        for i in 1..n {
            let l = e.leaf(i);
            acc = if i % 3 == 1 {
                e.diff(acc, l)
            } else {
                e.union(acc, l)
            };
        }
        scene(
            camera(DVec3::new(8.0, 6.0, 10.0), DVec3::ZERO, 45.0, 0.1, 100.0),
            prims,
            e.build(acc),
        )
    }

    #[test]
    #[ignore = "timing; run with --release --ignored --nocapture"]
    fn timing_reference() {
        for (n, w, h) in [(50u32, 800u32, 800u32), (300, 400, 400)] {
            let sc = random_scene(n, 42);
            let t = std::time::Instant::now();
            let img = render(&sc, w, h);
            let covered = img.prim.iter().filter(|&&p| p != 0).count();
            println!(
                "{n} prims {w}x{h}: {:.2?} ({covered} covered, {} threads)",
                t.elapsed(),
                rayon::current_num_threads()
            );
        }
    }

    /// Rendering is deterministic and a shuffled thread count does not matter.
    #[test]
    fn random_scene_renders_and_matches_itself() {
        let sc = random_scene(12, 9);
        let a = render(&sc, 40, 30);
        let b = render(&sc, 40, 30);
        assert_eq!(a, b.clone());
        assert!(a.prim.iter().any(|&p| p != 0));
        let r = crate::compare(&a, &b).unwrap();
        assert_eq!(r.coverage_mismatch + r.prim_mismatch, 0);
    }

    /// Self-consistency against point classification: just before each visible
    /// point the line is outside the solid, just after it inside.
    #[test]
    fn visible_points_are_solid_boundary_points() {
        for seed in [1u64, 2, 3] {
            let sc = random_scene(15, seed);
            let prep = Prepared::new(&sc);
            let (w, h) = (60u32, 50u32);
            let mut checked = 0;
            let mut bad = 0;
            for y in 0..h {
                for x in 0..w {
                    let Some(hit) = prep.cast_pixel(x as f64 + 0.5, y as f64 + 0.5, w, h) else {
                        continue;
                    };
                    let d = 1e-7;
                    checked += 1;
                    if prep.inside_solid(hit.point - hit.dir * d)
                        || !prep.inside_solid(hit.point + hit.dir * d)
                    {
                        bad += 1;
                    }
                }
            }
            // Lines grazing an edge may have intervals shorter than 1e-7.
            assert!(
                checked > 100 && bad * 200 <= checked,
                "seed {seed}: {bad} of {checked}"
            );
        }
    }

    /// Two solids are united; a primitive that only trims a surface never gives
    /// the solid its index, even on a coincident face with a lower index.
    #[test]
    fn several_solids_and_trim_only_primitives() {
        let mut sc = scene(
            cam(),
            vec![
                prim("t", b([-3.0, -3.0, 0.0], [3.0, 3.0, 1.0]), [9, 9, 9]),
                prim("a", b([-1.0; 3], [1.0; 3]), [200, 0, 0]),
                prim("c", b([-2.0, -0.2, -1.0], [-1.5, 0.2, 1.0]), [0, 0, 200]),
            ],
            {
                let mut e = ExprBuilder::default();
                let l = e.leaf(1);
                e.build(l)
            },
        );
        sc.solids.push(peeltrim::scene::Solid {
            name: "second".into(),
            expr: {
                let mut e = ExprBuilder::default();
                let l = e.leaf(2);
                e.build(l)
            },
        });
        let plane = box_mesh(DVec3::new(-5.0, -5.0, -5.0), DVec3::new(-4.0, -4.0, -4.0));
        sc.surfaces.push(surface(
            "s",
            plane,
            [1, 1, 1],
            union_all(1),
            Keep::In,
            [0, 0, 0],
        ));
        let img = render(&sc, W, H);
        let ids: std::collections::BTreeSet<u16> = img.prim.iter().copied().collect();
        assert_eq!(ids, [0u16, 2, 3].into_iter().collect());
        let c = img.prim[(H / 2 * W + W / 2) as usize];
        assert_eq!(c, 2);
    }
}
