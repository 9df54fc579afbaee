//! Small closed meshes and scene builders for tests, benchmarks and examples
//! (boxes, UV spheres), CCW outward like the loader's tessellation.

use glam::{DMat4, DVec3};

use crate::csg::expr::{Expr, Node};
use crate::scene::{
    Camera, Keep, Mesh, Primitive, Projection, RenderSettings, Scene, Shape, Solid, Surface,
};

/// An axis-aligned box: 8 corners, 12 CCW-outward triangles.
pub fn box_mesh(min: DVec3, max: DVec3) -> Mesh {
    grid_box_mesh(min, max, 1)
}

/// An axis-aligned box whose faces are split into `n × n` quads sharing vertices.
pub fn grid_box_mesh(min: DVec3, max: DVec3, n: u32) -> Mesh {
    let mut positions = vec![];
    let mut triangles = vec![];
    let mut index = std::collections::HashMap::new();
    let mut vid = |p: [i64; 3], positions: &mut Vec<DVec3>| -> u32 {
        *index.entry(p).or_insert_with(|| {
            let f = |i: usize| {
                let s = p[i] as f64 / n as f64;
                if p[i] == n as i64 {
                    max[i]
                } else {
                    min[i] + (max[i] - min[i]) * s
                }
            };
            positions.push(DVec3::new(f(0), f(1), f(2)));
            positions.len() as u32 - 1
        })
    };
    let n64 = n as i64;
    for axis in 0..3 {
        for side in [0i64, n64] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            for i in 0..n64 {
                for j in 0..n64 {
                    let corner = |di: i64, dj: i64| {
                        let mut p = [0i64; 3];
                        p[axis] = side;
                        p[u] = i + di;
                        p[v] = j + dj;
                        p
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                    let q: Vec<u32> = q.iter().map(|&c| vid(c, &mut positions)).collect();
                    // (u, v, axis) is right-handed: CCW in (u, v) faces +axis.
                    if side == n64 {
                        triangles.push([q[0], q[1], q[2]]);
                        triangles.push([q[0], q[2], q[3]]);
                    } else {
                        triangles.push([q[0], q[2], q[1]]);
                        triangles.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    Mesh {
        positions,
        triangles,
    }
}

/// A UV sphere with `segments` around and `rings` from pole to pole.
pub fn sphere_mesh(center: DVec3, radius: f64, segments: u32, rings: u32) -> Mesh {
    let mut positions = vec![center + DVec3::Y * radius];
    for r in 1..rings {
        let th = std::f64::consts::PI * r as f64 / rings as f64;
        for s in 0..segments {
            let ph = std::f64::consts::TAU * s as f64 / segments as f64;
            positions.push(
                center + DVec3::new(th.sin() * ph.cos(), th.cos(), -th.sin() * ph.sin()) * radius,
            );
        }
    }
    positions.push(center - DVec3::Y * radius);
    let south = positions.len() as u32 - 1;
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let mut triangles = vec![];
    for s in 0..segments {
        triangles.push([0, ring(1, s), ring(1, s + 1)]);
        for r in 1..rings - 1 {
            let (a, b, c, d) = (
                ring(r, s),
                ring(r + 1, s),
                ring(r + 1, s + 1),
                ring(r, s + 1),
            );
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
        triangles.push([ring(rings - 1, s), south, ring(rings - 1, s + 1)]);
    }
    Mesh {
        positions,
        triangles,
    }
}

/// One mesh of the triangles of `a` and `b` (a non-convex mesh of two boxes).
pub fn joined(mut a: Mesh, b: Mesh) -> Mesh {
    let off = a.positions.len() as u32;
    a.positions.extend(b.positions);
    let shifted = b
        .triangles
        .iter()
        .map(|t| [t[0] + off, t[1] + off, t[2] + off]);
    a.triangles.extend(shifted);
    a
}

/// A primitive from a mesh (shape and transform are placeholders).
pub fn prim(name: &str, mesh: Mesh, color: [u8; 3]) -> Primitive {
    Primitive {
        name: name.into(),
        shape: Shape::Mesh {
            path: "fixture".into(),
        },
        transform: DMat4::IDENTITY,
        mesh,
        color,
        used: true,
    }
}

/// A surface (open or closed mesh) trimmed by `trim`.
pub fn surface(
    name: &str,
    mesh: Mesh,
    color: [u8; 3],
    trim: Expr,
    keep: Keep,
    paint: [u8; 3],
) -> Surface {
    Surface {
        name: name.into(),
        shape: Shape::Mesh {
            path: "fixture".into(),
        },
        transform: DMat4::IDENTITY,
        mesh,
        color,
        trim,
        keep,
        paint_color: paint,
    }
}

/// A small expression builder over primitive indices.
#[derive(Default)]
pub struct ExprBuilder {
    nodes: Vec<Node>,
}

impl ExprBuilder {
    /// A leaf naming primitive `prim`; returns its node.
    pub fn leaf(&mut self, prim: u32) -> u32 {
        self.push(Node::Leaf { prim })
    }
    /// The complement of node `a`.
    pub fn not(&mut self, a: u32) -> u32 {
        self.push(Node::Not(a))
    }
    /// The union of nodes `a` and `b`.
    pub fn union(&mut self, a: u32, b: u32) -> u32 {
        self.push(Node::Union(a, b))
    }
    /// The intersection of nodes `a` and `b`.
    pub fn inter(&mut self, a: u32, b: u32) -> u32 {
        self.push(Node::Inter(a, b))
    }
    /// Node `a` minus node `b`.
    pub fn diff(&mut self, a: u32, b: u32) -> u32 {
        self.push(Node::Diff(a, b))
    }
    fn push(&mut self, n: Node) -> u32 {
        self.nodes.push(n);
        self.nodes.len() as u32 - 1
    }
    /// The expression rooted at node `root`.
    pub fn build(self, root: u32) -> Expr {
        Expr {
            nodes: self.nodes,
            root,
        }
    }
}

/// `p0 + p1 + ... + p(n-1)`.
pub fn union_all(n: u32) -> Expr {
    let mut b = ExprBuilder::default();
    let mut acc = b.leaf(0);
    for i in 1..n {
        let l = b.leaf(i);
        acc = b.union(acc, l);
    }
    b.build(acc)
}

/// A perspective camera looking from `eye` at `target`.
pub fn camera(eye: DVec3, target: DVec3, fov_y_deg: f64, near: f64, far: f64) -> Camera {
    Camera {
        eye,
        target,
        up: DVec3::Y,
        projection: Projection::Perspective { fov_y_deg },
        near,
        far,
    }
}

/// A scene with one solid.
pub fn scene(camera: Camera, primitives: Vec<Primitive>, expr: Expr) -> Scene {
    Scene {
        warnings: Vec::new(),
        appearance: Default::default(),
        name: Some("fixture".into()),
        path: "fixture.toml".into(),
        camera,
        render: RenderSettings {
            width: 64,
            height: 64,
            background: [10, 20, 30],
            samples: 1,
        },
        primitives,
        solids: vec![Solid {
            name: "csg".into(),
            expr,
        }],
        surfaces: vec![],
    }
}

/// A block minus `n` small spheres in a row along x (Stewart, Leach & John, Fig. 7–8).
pub fn block_minus_spheres(n: u32) -> Scene {
    let mut prims = vec![prim(
        "block",
        box_mesh(DVec3::new(-2.0, -0.5, -0.5), DVec3::new(2.0, 0.5, 0.5)),
        [200, 160, 60],
    )];
    let mut b = ExprBuilder::default();
    let mut acc = b.leaf(0);
    for i in 0..n {
        let x = -1.8 + 3.6 * (i as f64 + 0.5) / n as f64;
        let r = (1.6 / n as f64).min(0.4);
        prims.push(prim(
            &format!("s{i}"),
            sphere_mesh(DVec3::new(x, 0.0, 0.5), r, 12, 6),
            [80, 120, 200],
        ));
        let l = b.leaf(i + 1);
        acc = b.diff(acc, l);
    }
    let cam = camera(DVec3::new(0.0, 2.0, 6.0), DVec3::ZERO, 35.0, 1.0, 20.0);
    scene(cam, prims, b.build(acc))
}

/// `(A0 + B0)(A1 + B1)...(A(m-1) + B(m-1))`: 2^m products, all overlapping.
pub fn product_blowup(m: u32) -> Scene {
    let mut prims = Vec::new();
    let mut b = ExprBuilder::default();
    let mut acc = None;
    for i in 0..m {
        let s = 0.01 * i as f64;
        prims.push(prim(
            &format!("a{i}"),
            box_mesh(DVec3::splat(-1.0 - s), DVec3::splat(1.0)),
            [1, 2, 3],
        ));
        prims.push(prim(
            &format!("b{i}"),
            box_mesh(DVec3::splat(-1.0), DVec3::splat(1.0 + s)),
            [1, 2, 3],
        ));
        let (x, y) = (b.leaf(2 * i), b.leaf(2 * i + 1));
        let u = b.union(x, y);
        acc = Some(match acc {
            None => u,
            Some(a) => b.inter(a, u),
        });
    }
    let cam = camera(DVec3::new(0.0, 2.0, 6.0), DVec3::ZERO, 35.0, 1.0, 20.0);
    scene(cam, prims, b.build(acc.unwrap()))
}
