//! Bounding-volume hierarchies over `f64` triangles and exact line queries.
//!
//! Shaped like parry's ray casts: [`MeshBvh`] answers queries for one shape in its own
//! (here: world) coordinates, [`SceneBvh`] wraps the shapes of a scene with their
//! world AABBs. Unlike a ray cast, a query returns **every** crossing of the whole
//! line `origin + t * dir`, `t` over all reals: the eye may be inside a primitive and
//! orthographic rays start on the eye plane, so the inside state of a primitive at a
//! point is only known from all crossings along the line.
//!
//! The ray–triangle test is the watertight one of Woop, Benthin and Wald (JCGT 2013),
//! with one addition: an edge function that evaluates to exactly zero is given a sign
//! by a tie-break rule that depends only on the edge's direction and flips with it
//! (like a top-left fill rule). Two triangles sharing an edge evaluate that edge from
//! the same rounded numbers with opposite signs, so a ray through a shared edge or
//! vertex is counted exactly once per sheet of surface (and twice, entering and
//! exiting, on a silhouette edge): the tie-break is an infinitesimal, consistent
//! perturbation of the ray. Closed meshes therefore always give consistent parity.
//! Triangles whose projection along the ray is degenerate (parallel to the ray) are
//! ignored.

use glam::DVec3;

use crate::scene::{Aabb, Camera, Mesh};

/// One crossing of a line with a triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// Line parameter: the point is `origin + t * dir`.
    pub t: f64,
    /// Triangle index in the mesh.
    pub tri: u32,
    /// `true` when the line enters the solid here (`dot(normal, dir) < 0`).
    pub entering: bool,
}

/// A line (`t` over all reals) prepared for the watertight test.
#[derive(Clone, Copy, Debug)]
pub struct Line {
    /// The point at `t = 0`.
    pub origin: DVec3,
    /// The direction: the point at `t` is `origin + t * dir`.
    pub dir: DVec3,
    inv_dir: DVec3,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f64,
    sy: f64,
    sz: f64,
}

impl Line {
    /// The line through `origin` along `dir` (not normalized), with the
    /// watertight test's axis permutation and shear precomputed.
    pub fn new(origin: DVec3, dir: DVec3) -> Line {
        let a = dir.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let kx = (kz + 1) % 3;
        let ky = (kx + 1) % 3;
        let dz = dir[kz];
        Line {
            origin,
            dir,
            inv_dir: DVec3::ONE / dir,
            kx,
            ky,
            kz,
            sx: dir[kx] / dz,
            sy: dir[ky] / dz,
            sz: 1.0 / dz,
        }
    }

    /// The whole line a camera ray lies on (`t` measured along the ray).
    pub fn from_ray(ray: &crate::scene::camera::Ray) -> Line {
        Line::new(ray.origin, ray.dir)
    }

    /// The point at parameter `t`.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }

    /// Whether the whole line meets the box (boxes are padded at build time, so a line
    /// lying in a face plane is never lost to `0 * inf`).
    #[inline]
    pub fn hits_aabb(&self, min: DVec3, max: DVec3) -> bool {
        let t1 = (min - self.origin) * self.inv_dir;
        let t2 = (max - self.origin) * self.inv_dir;
        let lo = t1.min(t2);
        let hi = t1.max(t2);
        lo.max_element() <= hi.min_element()
    }

    /// Sheared 2D position and scaled depth of a vertex (Woop et al. §3).
    #[inline]
    fn shear(&self, p: DVec3) -> (f64, f64, f64) {
        let q = p - self.origin;
        (
            q[self.kx] - self.sx * q[self.kz],
            q[self.ky] - self.sy * q[self.kz],
            self.sz * q[self.kz],
        )
    }

    /// The watertight test against triangle `(a, b, c)`: `Some((t, entering))`.
    #[inline]
    pub fn intersect(&self, a: DVec3, b: DVec3, c: DVec3) -> Option<(f64, bool)> {
        let (ax, ay, az) = self.shear(a);
        let (bx, by, bz) = self.shear(b);
        let (cx, cy, cz) = self.shear(c);
        // Edge functions: u for edge c→b, v for a→c, w for b→a (cross(P, Q) of the
        // edge P→Q evaluated at the line, which is the 2D origin).
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let su = edge_sign(u, bx - cx, by - cy);
        let sv = edge_sign(v, cx - ax, cy - ay);
        let sw = edge_sign(w, ax - bx, ay - by);
        if su != sv || sv != sw {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let t = (u * az + v * bz + w * cz) / det;
        if !t.is_finite() {
            return None;
        }
        // The shear has determinant one, so sign(dot(n, dir)) = sign(-det * dir[kz]).
        let entering = det * self.dir[self.kz] > 0.0;
        Some((t, entering))
    }
}

/// Sign of an edge function; an exact zero takes the sign of an infinitesimal
/// perturbation of the line by `(-ε, ε²)` in the sheared plane, which depends only on
/// the edge direction `d` and flips with it.
#[inline]
fn edge_sign(e: f64, dx: f64, dy: f64) -> bool {
    if e != 0.0 {
        e > 0.0
    } else {
        dy > 0.0 || (dy == 0.0 && dx > 0.0)
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    min: DVec3,
    max: DVec3,
    /// Leaf: first index into `order`; inner: index of the left child (right = +1).
    first: u32,
    /// Leaf: triangle count (> 0); inner: 0.
    count: u32,
}

const LEAF_MAX: usize = 4;

/// A median-split BVH over one mesh's triangles, built iteratively.
#[derive(Clone, Debug)]
pub struct MeshBvh {
    nodes: Vec<Node>,
    /// Triangle vertices, in leaf order.
    verts: Vec<[DVec3; 3]>,
    /// Original triangle index, in leaf order.
    tri_ids: Vec<u32>,
    /// Unit geometric normal per original triangle (zero when degenerate).
    normals: Vec<DVec3>,
    aabb: Aabb,
}

fn pad(min: DVec3, max: DVec3) -> (DVec3, DVec3) {
    let mag = min.abs().max(max.abs()).max_element() + (max - min).max_element();
    let p = DVec3::splat(mag * 1e-9 + f64::MIN_POSITIVE);
    (min - p, max + p)
}

impl MeshBvh {
    pub(crate) fn new(mesh: &Mesh) -> MeshBvh {
        let n = mesh.triangles.len();
        let tri_vert = |i: usize| -> [DVec3; 3] {
            let [a, b, c] = mesh.triangles[i];
            [
                mesh.positions[a as usize],
                mesh.positions[b as usize],
                mesh.positions[c as usize],
            ]
        };
        let normals: Vec<DVec3> = (0..n)
            .map(|i| {
                let [a, b, c] = tri_vert(i);
                (b - a).cross(c - a).normalize_or_zero()
            })
            .collect();
        let centroids: Vec<DVec3> = (0..n)
            .map(|i| {
                let [a, b, c] = tri_vert(i);
                (a + b + c) / 3.0
            })
            .collect();
        let mut order: Vec<u32> = (0..n as u32).collect();
        let empty = Node {
            min: DVec3::splat(f64::INFINITY),
            max: DVec3::splat(f64::NEG_INFINITY),
            first: 0,
            count: 0,
        };
        let mut nodes = vec![empty];
        let mut stack = vec![(0usize, 0usize, n)];
        while let Some((ni, s, e)) = stack.pop() {
            let (mut min, mut max) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            let (mut cmin, mut cmax) = (min, max);
            for &t in &order[s..e] {
                for p in tri_vert(t as usize) {
                    min = min.min(p);
                    max = max.max(p);
                }
                cmin = cmin.min(centroids[t as usize]);
                cmax = cmax.max(centroids[t as usize]);
            }
            let (pmin, pmax) = if s < e { pad(min, max) } else { (min, max) };
            nodes[ni].min = pmin;
            nodes[ni].max = pmax;
            let ext = cmax - cmin;
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            // `ext` may be NaN for non-finite input: make a leaf then too.
            if e - s <= LEAF_MAX || ext[axis].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
            {
                nodes[ni].first = s as u32;
                nodes[ni].count = (e - s) as u32;
                continue;
            }
            let mid = (s + e) / 2;
            order[s..e].select_nth_unstable_by(mid - s, |&a, &b| {
                centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
            });
            let left = nodes.len();
            nodes.push(empty);
            nodes.push(empty);
            nodes[ni].first = left as u32;
            nodes[ni].count = 0;
            stack.push((left, s, mid));
            stack.push((left + 1, mid, e));
        }
        // An empty mesh: a leaf with no triangles that no line hits.
        let verts = order.iter().map(|&t| tri_vert(t as usize)).collect();
        let aabb = Aabb {
            min: nodes[0].min,
            max: nodes[0].max,
        };
        MeshBvh {
            nodes,
            verts,
            tri_ids: order,
            normals,
            aabb,
        }
    }

    /// Padded bounds of the whole mesh.
    pub fn aabb(&self) -> Aabb {
        self.aabb
    }

    /// Unit geometric normal of triangle `tri` (outward for CCW-outward meshes).
    pub fn normal(&self, tri: u32) -> DVec3 {
        self.normals[tri as usize]
    }

    /// Appends every crossing of the whole line with this mesh to `out` (unsorted).
    pub fn cast_local(&self, line: &Line, out: &mut Vec<Crossing>) {
        if self.verts.is_empty() {
            return;
        }
        // Median splits halve the triangle count per level: depth ≤ 33 for u32 counts.
        let mut stack = [0u32; 64];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let node = &self.nodes[stack[sp] as usize];
            if !line.hits_aabb(node.min, node.max) {
                continue;
            }
            if node.count > 0 {
                let s = node.first as usize;
                for i in s..s + node.count as usize {
                    let [a, b, c] = self.verts[i];
                    if let Some((t, entering)) = line.intersect(a, b, c) {
                        out.push(Crossing {
                            t,
                            tri: self.tri_ids[i],
                            entering,
                        });
                    }
                }
            } else {
                stack[sp] = node.first;
                stack[sp + 1] = node.first + 1;
                sp += 2;
            }
        }
    }
}

/// A crossing of a scene line with shape `shape` (index into [`SceneBvh::shapes`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldCrossing {
    /// The shape crossed (mesh index).
    pub shape: u32,
    /// Where and how the line crosses it.
    pub crossing: Crossing,
}

/// The world wrapper: several shapes, each with its world AABB tested first.
#[derive(Clone, Debug, Default)]
pub struct SceneBvh {
    /// One hierarchy per mesh, in mesh-index order.
    pub shapes: Vec<MeshBvh>,
}

impl SceneBvh {
    /// Builds a hierarchy for each mesh, in order.
    pub fn new<'a>(meshes: impl IntoIterator<Item = &'a Mesh>) -> SceneBvh {
        SceneBvh {
            shapes: meshes.into_iter().map(MeshBvh::new).collect(),
        }
    }

    /// Appends the crossings of the line with each shape `s` for which `want(s)`.
    pub fn cast(
        &self,
        line: &Line,
        mut want: impl FnMut(usize) -> bool,
        tmp: &mut Vec<Crossing>,
        out: &mut Vec<WorldCrossing>,
    ) {
        for (s, bvh) in self.shapes.iter().enumerate() {
            if !want(s) {
                continue;
            }
            tmp.clear();
            bvh.cast_local(line, tmp);
            out.extend(tmp.iter().map(|&crossing| WorldCrossing {
                shape: s as u32,
                crossing,
            }));
        }
    }

    /// Bounds of all shapes together with `extra` points (for scale-relative tolerances).
    pub fn bounds_with(&self, extra: &[DVec3]) -> Aabb {
        let mut min = DVec3::splat(f64::INFINITY);
        let mut max = DVec3::splat(f64::NEG_INFINITY);
        for s in &self.shapes {
            if !s.verts.is_empty() {
                min = min.min(s.aabb.min);
                max = max.max(s.aabb.max);
            }
        }
        for &p in extra {
            min = min.min(p);
            max = max.max(p);
        }
        Aabb { min, max }
    }
}

/// The scale `L` of a scene for tolerances: the diagonal of the box around all shapes
/// and the eye.
pub fn scene_scale(bvh: &SceneBvh, camera: &Camera) -> f64 {
    let b = bvh.bounds_with(&[camera.eye]);
    let d = (b.max - b.min).length();
    if d.is_finite() && d > 0.0 {
        d
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::fixtures::{box_mesh, sphere_mesh};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn crossings(bvh: &MeshBvh, o: DVec3, d: DVec3) -> Vec<Crossing> {
        let mut out = vec![];
        bvh.cast_local(&Line::new(o, d), &mut out);
        // Crossings at equal t (a tangent line) are one event; list entering first.
        out.sort_by(|a, b| {
            a.t.partial_cmp(&b.t)
                .unwrap()
                .then(b.entering.cmp(&a.entering))
        });
        out
    }

    /// A brute-force check of the BVH: same crossings as testing every triangle.
    #[test]
    fn bvh_matches_brute_force() {
        let mesh = sphere_mesh(DVec3::new(0.1, 0.2, -0.3), 1.3, 24, 12);
        let bvh = MeshBvh::new(&mesh);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for _ in 0..500 {
            let o = DVec3::new(
                rng.gen_range(-2.0..2.0),
                rng.gen_range(-2.0..2.0),
                rng.gen_range(-2.0..2.0),
            );
            let d = DVec3::new(
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
                rng.gen_range(-1.0..1.0),
            )
            .normalize();
            let line = Line::new(o, d);
            let mut brute: Vec<(u32, u64)> = mesh
                .triangles
                .iter()
                .enumerate()
                .filter_map(|(i, &[a, b, c])| {
                    line.intersect(
                        mesh.positions[a as usize],
                        mesh.positions[b as usize],
                        mesh.positions[c as usize],
                    )
                    .map(|(t, _)| (i as u32, t.to_bits()))
                })
                .collect();
            let mut got: Vec<(u32, u64)> = crossings(&bvh, o, d)
                .iter()
                .map(|c| (c.tri, c.t.to_bits()))
                .collect();
            brute.sort();
            got.sort();
            assert_eq!(brute, got);
        }
    }

    /// Random lines through a closed mesh alternate entering/exiting, starting with
    /// entering, and the count is even.
    #[test]
    fn random_lines_give_even_alternating_crossings() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let meshes = [
            sphere_mesh(DVec3::ZERO, 1.0, 17, 9),
            box_mesh(DVec3::splat(-0.5), DVec3::splat(0.5)),
        ];
        for mesh in &meshes {
            let bvh = MeshBvh::new(mesh);
            let mut hits = 0;
            for _ in 0..4000 {
                let o = DVec3::new(
                    rng.gen_range(-1.5..1.5),
                    rng.gen_range(-1.5..1.5),
                    rng.gen_range(-1.5..1.5),
                );
                let d = DVec3::new(
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                );
                let cs = crossings(&bvh, o, d.normalize());
                assert_eq!(cs.len() % 2, 0, "odd crossings {cs:?}");
                for (i, c) in cs.iter().enumerate() {
                    assert_eq!(c.entering, i % 2 == 0, "{cs:?}");
                }
                hits += (!cs.is_empty()) as usize;
            }
            assert!(hits > 100);
        }
    }

    /// Lines aimed exactly at vertices and shared-edge midpoints of a tessellated
    /// mesh cross each sheet of surface exactly once.
    #[test]
    fn lines_through_shared_edges_and_vertices_hit_once() {
        // A grid-tessellated box: each face split into 4x4 quads, vertices shared.
        let mesh = crate::scene::fixtures::grid_box_mesh(DVec3::splat(-1.0), DVec3::splat(1.0), 4);
        let bvh = MeshBvh::new(&mesh);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut targets = vec![];
        for &[a, b, c] in &mesh.triangles {
            let (a, b, c) = (
                mesh.positions[a as usize],
                mesh.positions[b as usize],
                mesh.positions[c as usize],
            );
            targets.extend([a, (a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5]);
        }
        for p in targets {
            // Skip points on the box's own edges (silhouette cases are checked by parity).
            let on_faces = p.to_array().iter().filter(|x| x.abs() == 1.0).count();
            for _ in 0..4 {
                let d = DVec3::new(
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                    rng.gen_range(-1.0..1.0),
                )
                .normalize();
                // Axis-aligned directions too: exact zeros everywhere.
                for d in [d, DVec3::X, DVec3::Y, DVec3::Z] {
                    let cs = crossings(&bvh, p - d * 3.0, d);
                    assert_eq!(cs.len() % 2, 0, "p {p} d {d}: {cs:?}");
                    if on_faces == 1 {
                        let at_p = cs.iter().filter(|c| (c.t - 3.0).abs() < 1e-9).count();
                        let n = DVec3::new(
                            if p.x.abs() == 1.0 { 1.0 } else { 0.0 },
                            if p.y.abs() == 1.0 { 1.0 } else { 0.0 },
                            if p.z.abs() == 1.0 { 1.0 } else { 0.0 },
                        );
                        if d.dot(n).abs() > 1e-6 {
                            assert_eq!(at_p, 1, "p {p} d {d}: {cs:?}");
                        }
                    }
                }
            }
        }
    }

    /// Axis-aligned lines exactly through every vertex of a UV sphere (fans of up to
    /// 24 triangles at the poles, exact-zero edge functions everywhere): crossings
    /// still alternate entering/exiting, starting with entering.
    #[test]
    fn axis_lines_through_vertices_keep_parity() {
        let mesh = sphere_mesh(DVec3::new(0.25, -0.5, 0.125), 2.0, 24, 12);
        let bvh = MeshBvh::new(&mesh);
        let mut through = 0;
        for &p in &mesh.positions {
            for d in [
                DVec3::X,
                DVec3::Y,
                DVec3::Z,
                -DVec3::X,
                -DVec3::Y,
                -DVec3::Z,
            ] {
                let cs = crossings(&bvh, p, d);
                assert_eq!(cs.len() % 2, 0, "p {p} d {d}: {cs:?}");
                for (i, c) in cs.iter().enumerate() {
                    assert_eq!(c.entering, i % 2 == 0, "p {p} d {d}: {cs:?}");
                }
                through += cs.iter().any(|c| c.t == 0.0) as usize;
            }
        }
        assert!(through > 100, "{through}");
    }
}
