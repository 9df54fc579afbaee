//! Reference layers against hand-computed crossings (holes, overlaps, coincident
//! faces, assemblies, clipping), against the opaque reference (layer 1) and against
//! point classification (every layer is a boundary point, entering/leaving alternate).

use super::*;
use crate::raycast::tests::random_scene;
use glam::DVec3;
use peeltrim::scene::fixtures::*;
use peeltrim::scene::{Projection, Solid};

/// Orthographic view down −Z from z = 5, 4 units high: pixel centre x maps to
/// world `(x + 0.5) / 10 − 2` at 40 × 40.
const N: u32 = 40;

fn ortho() -> peeltrim::scene::Camera {
    let mut c = camera(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, 40.0, 0.1, 100.0);
    c.projection = Projection::Orthographic { height: 4.0 };
    c
}

fn b(min: [f64; 3], max: [f64; 3]) -> peeltrim::scene::Mesh {
    box_mesh(DVec3::from(min), DVec3::from(max))
}

/// The layers at world `(x, y)` as `(depth, 1-based prim, entering)`.
fn at(l: &Layers, x: f64, y: f64) -> Vec<(f64, u32, bool)> {
    let px = (x + 2.0) * 10.0;
    let py = (2.0 - y) * 10.0;
    l.cast_pixel(px, py, N, N, None)
        .iter()
        .map(|h| ((h.depth * 1e9).round() / 1e9, h.prim + 1, h.entering))
        .collect()
}

fn expr(f: impl FnOnce(&mut ExprBuilder) -> u32) -> peeltrim::csg::Expr {
    let mut e = ExprBuilder::default();
    let r = f(&mut e);
    e.build(r)
}

/// A − B, B drilled through A's front half: the hole shows B's inner wall and
/// A's back; elsewhere A's front and back; the faces of B outside A give nothing.
#[test]
fn difference_layers() {
    let sc = scene(
        ortho(),
        vec![
            prim("a", b([-1.0; 3], [1.0; 3]), [200, 0, 0]),
            prim("b", b([-0.3, -0.3, 0.0], [0.3, 0.3, 2.0]), [0, 200, 0]),
        ],
        expr(|e| {
            let (a, bb) = (e.leaf(0), e.leaf(1));
            e.diff(a, bb)
        }),
    );
    let l = Layers::new(&sc);
    assert_eq!(at(&l, 0.05, 0.05), vec![(5.0, 2, true), (6.0, 1, false)]);
    assert_eq!(at(&l, 0.55, -0.45), vec![(4.0, 1, true), (6.0, 1, false)]);
    assert_eq!(at(&l, 1.55, 0.05), vec![]);
}

/// Overlapping and coincident primitives: every point once. A + B overlapping
/// gives two layers (the faces inside the union are no boundary); A + A' (the same
/// box, tessellated differently) gives two layers of the lower index; A * B with a
/// coincident front face gives one front layer of the lower index.
#[test]
fn overlaps_and_coincident_faces_count_once() {
    let a = || b([-1.0; 3], [1.0; 3]);
    let union = expr(|e| {
        let (x, y) = (e.leaf(0), e.leaf(1));
        e.union(x, y)
    });
    let sc = scene(
        ortho(),
        vec![
            prim("a", a(), [200, 0, 0]),
            prim("b", b([-0.5, -0.5, -0.5], [0.5, 0.5, 1.5]), [0, 200, 0]),
        ],
        union.clone(),
    );
    let l = Layers::new(&sc);
    assert_eq!(at(&l, 0.05, 0.05), vec![(3.5, 2, true), (6.0, 1, false)]);
    assert_eq!(at(&l, 0.75, 0.05), vec![(4.0, 1, true), (6.0, 1, false)]);

    for swap in [false, true] {
        let mut prims = vec![
            prim("a", a(), [200, 0, 0]),
            prim(
                "a2",
                grid_box_mesh(DVec3::splat(-1.0), DVec3::splat(1.0), 3),
                [0, 200, 0],
            ),
        ];
        if swap {
            prims.reverse();
        }
        let sc = scene(ortho(), prims, union.clone());
        let l = Layers::new(&sc);
        assert_eq!(at(&l, 0.35, -0.15), vec![(4.0, 1, true), (6.0, 1, false)]);
        let inter = scene(
            ortho(),
            vec![
                prim("a", a(), [200, 0, 0]),
                prim(
                    "c",
                    grid_box_mesh(DVec3::new(-0.5, -0.5, 0.0), DVec3::splat(1.0), 2),
                    [0, 0, 200],
                ),
            ],
            expr(|e| {
                let (x, y) = (e.leaf(0), e.leaf(1));
                e.inter(x, y)
            }),
        );
        let l = Layers::new(&inter);
        assert_eq!(at(&l, 0.15, 0.15), vec![(4.0, 1, true), (5.0, 2, false)]);
    }
}

/// An assembly: each solid's boundary on its own, so two overlapping solids give
/// four layers, and two solids touching at a face two layers at that depth.
#[test]
fn assembly_counts_each_solid() {
    let mut sc = scene(
        ortho(),
        vec![
            prim("a", b([-1.0; 3], [1.0; 3]), [200, 0, 0]),
            prim("b", b([-0.5, -0.5, -2.0], [0.5, 0.5, 0.0]), [0, 200, 0]),
        ],
        expr(|e| e.leaf(0)),
    );
    sc.solids.push(Solid {
        name: "b".into(),
        expr: expr(|e| e.leaf(1)),
    });
    let l = Layers::new(&sc);
    assert_eq!(
        at(&l, 0.05, 0.05),
        vec![
            (4.0, 1, true),
            (5.0, 2, true),
            (6.0, 1, false),
            (7.0, 2, false)
        ]
    );
    sc.primitives[1] = prim("b", b([-0.5, -0.5, -2.0], [0.5, 0.5, -1.0]), [0, 200, 0]);
    let l = Layers::new(&sc);
    assert_eq!(
        at(&l, 0.05, 0.05),
        vec![
            (4.0, 1, true),
            (6.0, 1, false),
            (6.0, 2, true),
            (7.0, 2, false)
        ]
    );
}

/// Crossings before `near` or after `far` are clipped; `max` keeps the first ones.
#[test]
fn clipping_and_limit() {
    let mut c = ortho();
    c.near = 4.2;
    c.far = 5.8;
    let sc = scene(
        c,
        vec![
            prim("a", b([-1.0; 3], [1.0; 3]), [200, 0, 0]),
            prim("b", b([-0.5; 3], [0.5; 3]), [0, 200, 0]),
        ],
        expr(|e| {
            let (x, y) = (e.leaf(0), e.leaf(1));
            e.diff(x, y)
        }),
    );
    let l = Layers::new(&sc);
    assert_eq!(at(&l, 0.05, 0.05), vec![(4.5, 2, false), (5.5, 2, true)]);
    let mut narrow = sc.clone();
    narrow.camera.near = 4.6;
    narrow.camera.far = 5.4;
    assert_eq!(at(&Layers::new(&narrow), 0.05, 0.05), vec![]);
    let sc = scene(ortho(), sc.primitives.clone(), sc.solids[0].expr.clone());
    let l = Layers::new(&sc);
    assert_eq!(at(&l, 0.05, 0.05).len(), 4);
    let two = l.cast_pixel(20.5, 20.5, N, N, Some(2));
    assert_eq!(two.len(), 2);
    assert_eq!(
        (two[1].depth, two[1].prim, two[1].entering),
        (4.5, 1, false)
    );
}

/// Layer 1 is the opaque reference's visible point (depth, primitive, colour) when
/// the eye is outside the solid; later layers are boundary points whose sides
/// alternate, checked by classifying points just before and after them.
#[test]
fn layer_one_is_the_opaque_image_and_layers_are_boundary_points() {
    for seed in [1u64, 2, 3] {
        let sc = random_scene(15, seed);
        let (w, h) = (48u32, 40u32);
        let stack = render_layers(&sc, w, h, LayerLimit::default());
        let opaque = crate::render(&sc, w, h);
        assert!(
            stack.layers.len() >= 4,
            "seed {seed}: {}",
            stack.layers.len()
        );
        assert_eq!(stack.layers[0], opaque, "seed {seed}");
        assert_eq!(
            stack.composite, opaque.color,
            "opaque composite, seed {seed}"
        );

        let l = Layers::new(&sc);
        let prep = &l.prep;
        let (mut checked, mut bad) = (0, 0);
        for y in 0..h {
            for x in 0..w {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let hits = l.cast_pixel(px, py, w, h, None);
                let ray = sc.camera.ray(px, py, w, h);
                let fwd = sc.camera.forward();
                for (k, hit) in hits.iter().enumerate() {
                    assert_eq!(
                        hit.entering,
                        k % 2 == 0,
                        "seed {seed} pixel {x},{y} layer {k}"
                    );
                    let t = hit.depth / ray.dir.dot(fwd) - (ray.origin - sc.camera.eye).dot(fwd);
                    let p = ray.origin + ray.dir * t;
                    let d = 1e-7;
                    checked += 1;
                    if prep.inside_solid(p - ray.dir * d) == hit.entering
                        || prep.inside_solid(p + ray.dir * d) != hit.entering
                    {
                        bad += 1;
                    }
                }
            }
        }
        // Lines grazing an edge may have intervals shorter than 1e-7.
        assert!(
            checked > 300 && bad * 200 <= checked,
            "seed {seed}: {bad} of {checked}"
        );
    }
}

/// Two layers of one box at alpha 0.5 over the background: exactly
/// `0.5 c1 + 0.25 c2 + 0.25 bg`; primitive alpha beats solid beats render.
#[test]
fn composite_blends_front_to_back() {
    let mut sc = scene(
        ortho(),
        vec![prim("a", b([-1.0; 3], [1.0; 3]), [200, 100, 40])],
        expr(|e| e.leaf(0)),
    );
    sc.appearance.alpha = Some(0.5);
    let stack = render_layers(&sc, N, N, LayerLimit::default());
    assert_eq!(stack.layers.len(), 2);
    let i = (20 * N + 20) as usize;
    let bg = sc.render.background;
    let blend = |a: f64, k: usize| {
        let c = [200.0, 100.0, 40.0][k];
        (a * c + (1.0 - a) * a * c + (1.0 - a) * (1.0 - a) * bg[k] as f64).round() as u8
    };
    assert_eq!(
        stack.composite[i],
        [blend(0.5, 0), blend(0.5, 1), blend(0.5, 2), 255]
    );
    sc.appearance.solid_alpha = vec![Some(0.25)];
    assert_eq!(
        render_layers(&sc, N, N, LayerLimit::default()).composite[i][0],
        blend(0.25, 0)
    );
    sc.appearance.primitive_alpha = vec![Some(0.75)];
    assert_eq!(
        render_layers(&sc, N, N, LayerLimit::default()).composite[i][0],
        blend(0.75, 0)
    );
    // Background pixels stay background; one layer only with max = 1.
    assert_eq!(stack.composite[0], [bg[0], bg[1], bg[2], 255]);
    let one = render_layers(
        &sc,
        N,
        N,
        LayerLimit {
            max: Some(1),
            threshold: 0,
        },
    );
    assert_eq!(one.layers.len(), 1);
    let c1 = (0.75 * 200.0 + 0.25 * bg[0] as f64).round() as u8;
    assert_eq!(one.composite[i][0], c1);
}

/// The threshold stops at the first layer covering fewer pixels: a box behind a
/// wider one adds layers 3 and 4 on few pixels only.
#[test]
fn threshold_stops_peeling() {
    let mut sc = scene(
        ortho(),
        vec![
            prim("a", b([-1.5, -1.5, 0.0], [1.5, 1.5, 1.0]), [200, 0, 0]),
            prim("b", b([-0.2, -0.2, -2.0], [0.2, 0.2, -1.0]), [0, 200, 0]),
        ],
        expr(|e| e.leaf(0)),
    );
    sc.solids[0].expr = expr(|e| {
        let (x, y) = (e.leaf(0), e.leaf(1));
        e.union(x, y)
    });
    let all = render_layers(&sc, N, N, LayerLimit::default());
    assert_eq!(all.layers.len(), 4);
    let small = all.layers[2].prim.iter().filter(|&&p| p != 0).count() as u64;
    let big = all.layers[0].prim.iter().filter(|&&p| p != 0).count() as u64;
    assert_eq!((small, big), (16, 900));
    let cut = render_layers(
        &sc,
        N,
        N,
        LayerLimit {
            max: None,
            threshold: small + 1,
        },
    );
    assert_eq!(cut.layers, all.layers[..2].to_vec());
    let keep = render_layers(
        &sc,
        N,
        N,
        LayerLimit {
            max: None,
            threshold: small,
        },
    );
    assert_eq!(keep.layers.len(), 4);
}
