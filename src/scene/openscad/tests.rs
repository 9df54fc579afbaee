//! The `.csg` reader: parsing (values, modifiers, located errors, 10^5 nesting),
//! OpenSCAD's tessellation formulas, the tree → expression conversion (checked
//! by evaluating the expression against the intended set), and a fuzz test.

use glam::DVec3;
use proptest::prelude::*;
use std::path::Path;

use super::parse::{parse, ValueKind};
use super::tessellate::{self, cos_degrees, fragments, sin_degrees, Resolution};
use super::{model_from_str, Model};
use crate::csg::{Expr, Node};
use crate::scene::load::SceneError;
use crate::scene::validate::{check_closed, signed_volume};
use crate::scene::{Mesh, Shape};

pub(super) fn model(text: &str) -> Model {
    model_from_str(text, Path::new("t.csg"), false).unwrap_or_else(|e| panic!("{e}"))
}

pub(super) fn err(text: &str) -> String {
    match model_from_str(text, Path::new("t.csg"), false) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// The `n` points of a star outline (radii 10 and 9 alternating), as
/// OpenSCAD point literals.
pub(super) fn star_points(n: usize) -> Vec<String> {
    (0..n)
        .map(|i| {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            let r = if i % 2 == 0 { 10.0 } else { 9.0 };
            format!("[{}, {}]", r * a.cos(), r * a.sin())
        })
        .collect()
}

pub(super) fn closed_outward(m: &Mesh) {
    check_closed(m).unwrap_or_else(|p| panic!("{}", p.describe(m)));
    assert!(signed_volume(m) > 0.0, "inside out");
}

/// Whether `p` is in the model's solid, deciding each primitive by its mesh's
/// signed volume test (a point-in-convex-mesh test: all shapes used below are convex).
fn inside(m: &Model, p: DVec3) -> bool {
    m.expr.eval(|_, prim| {
        let mesh = &m.primitives[prim as usize].mesh;
        mesh.triangles.iter().all(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            (b - a).cross(c - a).dot(p - a) <= 0.0
        })
    })
}

// ---------------------------------------------------------------- parsing

#[test]
fn parses_openscad_export() {
    // As printed by `openscad -o t.csg` (2021.01).
    let t = parse(
        "difference() {\n\tcube(size = [10, 10, 2], center = true);\n#\tmultmatrix([[1, 0, 0, 2], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) {\n\t\tcylinder($fn = 12, $fa = 12, $fs = 2, h = 5, r1 = 1.5, r2 = 1.5, center = true);\n\t}\n}\n%sphere($fn = 0, $fa = 12, $fs = 2, r = 3);\ngroup();\n",
    )
    .unwrap();
    assert_eq!(t.roots.len(), 3);
    let d = &t.nodes[t.roots[0] as usize];
    assert_eq!(d.name, "difference");
    assert_eq!(d.children.len(), 2);
    let mm = &t.nodes[d.children[1] as usize];
    assert!(mm.modifiers.highlight);
    assert_eq!((mm.pos.line, mm.pos.col), (3, 3));
    let cyl = &t.nodes[mm.children[0] as usize];
    assert_eq!(cyl.args.len(), 7);
    assert_eq!(cyl.args[0].name.as_deref(), Some("$fn"));
    assert!(t.nodes[t.roots[1] as usize].modifiers.background);
    // Pre-order: parents before children.
    for (i, n) in t.nodes.iter().enumerate() {
        assert!(n.children.iter().all(|&c| c as usize > i));
    }
}

#[test]
fn values_as_openscad_prints_them() {
    let t = parse(
        r#"color(c = [1e-06, -0.5, 1.23457, 2.5E+10], alpha = -inf, x = nan, b = [true, false, undef], s = "a\"b\\\n\t\x41\u00e9", e = [], n = [[1, [2]], 3,]);"#,
    )
    .unwrap();
    let a = &t.nodes[0].args;
    let ValueKind::Vector(v) = &a[0].value.kind else {
        panic!()
    };
    let nums: Vec<f64> = v
        .iter()
        .map(|x| match x.kind {
            ValueKind::Number(n) => n,
            _ => panic!(),
        })
        .collect();
    assert_eq!(nums, [1e-6, -0.5, 1.23457, 2.5e10]);
    assert_eq!(a[1].value.kind, ValueKind::Number(f64::NEG_INFINITY));
    assert!(matches!(a[2].value.kind, ValueKind::Number(n) if n.is_nan()));
    let ValueKind::Vector(b) = &a[3].value.kind else {
        panic!()
    };
    assert_eq!(b[0].kind, ValueKind::Bool(true));
    assert_eq!(b[1].kind, ValueKind::Bool(false));
    assert_eq!(b[2].kind, ValueKind::Undef);
    assert_eq!(a[4].value.kind, ValueKind::Str("a\"b\\\n\tAé".to_string()));
    assert_eq!(a[5].value.kind, ValueKind::Vector(vec![]));
    let ValueKind::Vector(n) = &a[6].value.kind else {
        panic!()
    };
    assert_eq!(n.len(), 2);
}

#[test]
fn nesting_of_100k_blocks_and_single_children() {
    let n = 100_000;
    let mut s = "group() {\n".repeat(n);
    s.push_str("cube(size = 1);\n");
    s.push_str(&"}\n".repeat(n));
    let m = model(&s);
    assert_eq!(m.primitives.len(), 1);
    assert_eq!(m.primitives[0].name, format!("cube_L{}", n + 1));
    // `multmatrix(...) child` without braces, 10^5 deep: translations add up.
    let mut s = "multmatrix([[1, 0, 0, 0.5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) ".repeat(n);
    s.push_str("cube(size = 1);");
    let m = model(&s);
    let x = m.primitives[0]
        .mesh
        .positions
        .iter()
        .map(|p| p.x)
        .fold(f64::INFINITY, f64::min);
    assert!((x - 0.5 * n as f64).abs() < 1e-6, "{x}");
}

#[test]
fn syntax_errors_are_located() {
    for (src, line, col, want) in [
        ("cube(size = 1;", 1, 14, "expected `,` or `)`"),
        ("group() {\n  cube();\n", 1, 9, "never closed"),
        ("cube();\n}", 2, 1, "unmatched `}`"),
        ("cube(size = 1 + 2);", 1, 15, "unexpected character '+'"),
        ("cube(size = \"abc);", 1, 13, "unterminated string"),
        ("cube(size = [1, 2);", 1, 18, "expected `,` or `]`"),
        ("cube(size = x);", 1, 13, "`x` is not a value"),
        ("cube()", 1, 7, "file ends after a node call"),
        ("% ;", 1, 3, "expected a node name"),
        ("cube(s = \"\\q\");", 1, 11, "unknown escape"),
    ] {
        let e = err(src);
        let at = format!("t.csg:{line}:{col}:");
        assert!(e.starts_with(&at), "{src:?}: want {at} in {e}");
        assert!(e.contains(want), "{src:?}: want {want:?} in {e}");
        assert!(e.contains('^'), "caret snippet in {e}");
    }
}

#[test]
fn deep_vectors_are_an_error_not_a_stack_overflow() {
    let src = format!(
        "cube(size = {}1{});",
        "[".repeat(100_000),
        "]".repeat(100_000)
    );
    let e = err(&src);
    assert!(
        e.starts_with("t.csg:1:45:") && e.contains("nested deeper than 32"),
        "{e}"
    );
}

// ---------------------------------------------------------------- tessellation

#[test]
fn fragments_follow_get_fragments_from_r() {
    let r = |fn_, fa, fs| Resolution { fn_, fa, fs };
    for (radius, res, want) in [
        (10.0, r(0.0, 12.0, 2.0), 30),   // min(360/12, 31.4) = 30
        (5.0, r(0.0, 12.0, 2.0), 16),    // ceil(15.7)
        (1.0, r(0.0, 12.0, 2.0), 5),     // at least 5
        (5.0, r(0.0, 6.0, 1.0), 32),     // ceil(31.4)
        (100.0, r(0.0, 1.0, 0.01), 360), // 360 / fa
        (5.0, r(7.9, 12.0, 2.0), 7),     // $fn truncated
        (5.0, r(2.0, 12.0, 2.0), 3),     // $fn at least 3
        (0.0, r(64.0, 12.0, 2.0), 3),    // r below GRID_FINE
        (5.0, r(64.0, 12.0, 2.0), 64),
    ] {
        assert_eq!(fragments(radius, res), want, "r={radius} {res:?}");
    }
    assert_eq!(sin_degrees(30.0), 0.5);
    assert_eq!(cos_degrees(90.0), 0.0);
    assert_eq!(sin_degrees(270.0), -1.0);
    assert!((sin_degrees(17.0) - 17f64.to_radians().sin()).abs() < 1e-15);
}

#[test]
fn sphere_rings_and_caps() {
    for (n, r) in [(3u64, 1.0), (5, 2.0), (8, 1.5), (12, 3.0), (31, 0.7)] {
        let m = tessellate::sphere(r, n).unwrap();
        let rings = n.div_ceil(2);
        assert_eq!(m.positions.len() as u64, rings * n, "n={n}");
        assert_eq!(
            m.triangles.len() as u64,
            2 * (n - 2) + 2 * n * (rings - 1),
            "n={n}"
        );
        for i in 0..rings {
            let phi = (180.0 * (i as f64 + 0.5) / rings as f64).to_radians();
            for j in 0..n {
                let t = (360.0 * j as f64 / n as f64).to_radians();
                let want = DVec3::new(
                    r * phi.sin() * t.cos(),
                    r * phi.sin() * t.sin(),
                    r * phi.cos(),
                );
                let got = m.positions[(i * n + j) as usize];
                assert!(
                    got.distance(want) < 1e-12,
                    "n={n} ring {i} point {j}: {got} vs {want}"
                );
            }
        }
        closed_outward(&m);
    }
    assert!(tessellate::sphere(0.0, 8).is_none());
}

#[test]
fn cylinders_cones_and_centre() {
    for n in [3u64, 5, 16, 30] {
        let m = tessellate::cylinder(2.0, 1.0, 1.0, false, n).unwrap();
        assert_eq!(m.positions.len() as u64, 2 * n);
        assert_eq!(m.triangles.len() as u64, 2 * n + 2 * (n - 2));
        for (k, p) in m.positions.iter().enumerate() {
            let i = k as u64 % n;
            let phi = (360.0 * i as f64 / n as f64).to_radians();
            let z = if (k as u64) < n { 0.0 } else { 2.0 };
            assert!(p.distance(DVec3::new(phi.cos(), phi.sin(), z)) < 1e-12);
        }
        closed_outward(&m);
        // Cones: an apex where a radius is 0; frustum r1 != r2.
        for (r1, r2) in [(1.0, 0.0), (0.0, 1.0), (2.0, 0.5)] {
            let m = tessellate::cylinder(3.0, r1, r2, true, n).unwrap();
            let apex = r1 == 0.0 || r2 == 0.0;
            assert_eq!(m.positions.len() as u64, if apex { n + 1 } else { 2 * n });
            let zs: Vec<f64> = m.positions.iter().map(|p| p.z).collect();
            assert_eq!(zs.iter().cloned().fold(f64::INFINITY, f64::min), -1.5);
            assert_eq!(zs.iter().cloned().fold(f64::NEG_INFINITY, f64::max), 1.5);
            closed_outward(&m);
        }
    }
    assert!(tessellate::cylinder(0.0, 1.0, 1.0, false, 8).is_none());
    assert!(tessellate::cylinder(1.0, 0.0, 0.0, false, 8).is_none());
}

#[test]
fn cube_size_and_centre() {
    let m = tessellate::cube(DVec3::new(1.0, 2.0, 3.0), false).unwrap();
    let lo = m.positions.iter().fold(DVec3::INFINITY, |a, &p| a.min(p));
    let hi = m
        .positions
        .iter()
        .fold(DVec3::NEG_INFINITY, |a, &p| a.max(p));
    assert_eq!((lo, hi), (DVec3::ZERO, DVec3::new(1.0, 2.0, 3.0)));
    closed_outward(&m);
    let m = tessellate::cube(DVec3::splat(2.0), true).unwrap();
    assert!(m.positions.iter().all(|p| p.abs() == DVec3::ONE));
    assert!(tessellate::cube(DVec3::new(1.0, 0.0, 1.0), true).is_none());
}

#[test]
fn node_arguments_drive_fragments() {
    // $fa = 12, $fs = 2: r = 10 → 30 fragments, 15 rings.
    let m = model("sphere($fn = 0, $fa = 12, $fs = 2, r = 10);");
    assert_eq!(m.primitives[0].mesh.positions.len(), 30 * 15);
    let m = model("sphere(d = 4, $fn = 7);");
    assert_eq!(m.primitives[0].mesh.positions.len(), 7 * 4);
    assert!((m.primitives[0].mesh.positions[0].length() - 2.0).abs() < 1e-12);
    // Cylinder: fragments from the larger radius.
    let m = model("cylinder(h = 1, r1 = 10, r2 = 1, center = false, $fs = 2, $fa = 12);");
    assert_eq!(m.primitives[0].mesh.positions.len(), 60);
    let e = err("sphere(r = 1, $fn = 1e9);");
    assert!(e.contains("t.csg:1:1:") && e.contains("fragments"), "{e}");
}

#[test]
fn polyhedron_clockwise_faces_become_ccw() {
    // OpenSCAD's own example: faces clockwise seen from outside.
    let m = model(
        "polyhedron(points = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], faces = [[0, 4, 1], [1, 4, 2], [2, 4, 3], [3, 4, 0], [0, 1, 2, 3]], convexity = 1);",
    );
    closed_outward(&m.primitives[0].mesh);
    assert_eq!(m.primitives[0].mesh.triangles.len(), 6);
    // A face removed: open, the line and an edge named.
    let e = err("group() {\n polyhedron(points = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], faces = [[0, 4, 1], [1, 4, 2], [3, 4, 0], [0, 1, 2, 3]]);\n}");
    assert!(
        e.starts_with("t.csg:2:2:") && e.contains("edge") && e.contains("points["),
        "{e}"
    );
    // One face flipped: reversed to agree with its neighbours, with a warning.
    let m = model("polyhedron(points = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], faces = [[0, 1, 2], [0, 3, 1], [1, 3, 2], [0, 3, 2]]);");
    closed_outward(&m.primitives[0].mesh);
    assert!(
        warned(&m, "1 triangle(s) were reversed"),
        "{:?}",
        m.warnings
    );
    // A non-manifold edge (three faces) stays an error.
    let e = err("polyhedron(points = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], faces = [[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0], [0, 1, 2]]);");
    assert!(
        e.starts_with("t.csg:1:1:") && e.contains("same direction"),
        "{e}"
    );
    // Counter-clockwise faces: inside out, turned outward with a warning.
    let m = model("polyhedron(points = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], faces = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]);");
    closed_outward(&m.primitives[0].mesh);
    assert!(warned(&m, "inside out"), "{:?}", m.warnings);
    let e = err("polyhedron(points = [[0, 0, 0], [1, 0, 0]], faces = [[0, 1, 7]]);");
    assert!(e.contains("point index"), "{e}");
}

// ---------------------------------------------------------------- conversion

#[test]
fn difference_union_intersection_as_sets() {
    let m = model(
        "difference() {\n  cube(size = [4, 4, 4], center = true);\n  cube(size = [2, 2, 10], center = true);\n  multmatrix([[1, 0, 0, 2], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) cube(size = 1, center = true);\n}\nintersection() {\n  multmatrix([[1, 0, 0, 10], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) cube(size = 2, center = true);\n  multmatrix([[1, 0, 0, 11], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) cube(size = 2, center = true);\n  *cube(size = 5);\n}\n",
    );
    let names: Vec<&str> = m.primitives.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(
        names,
        ["cube_L2", "cube_L3", "cube_L4", "cube_L7", "cube_L8"]
    );
    for (p, want) in [
        (DVec3::new(1.2, 0.0, 0.0), true),
        (DVec3::new(0.0, 0.0, 0.0), false), // the hole
        (DVec3::new(1.8, 0.0, 0.0), false), // the notch at x = 2
        (DVec3::new(3.0, 0.0, 0.0), false),
        (DVec3::new(10.5, 0.0, 0.0), true), // intersection; the `*` child vanished
        (DVec3::new(9.5, 0.0, 0.0), false),
    ] {
        assert_eq!(inside(&m, p), want, "{p}");
    }
    // Subtracted parts get OpenSCAD's back colour, the rest its front colour.
    assert_eq!(m.primitives[0].color, [0xf9, 0xd7, 0x2c]);
    assert_eq!(m.primitives[1].color, [0x9d, 0xcb, 0x51]);
}

#[test]
fn empty_primitives_follow_set_algebra() {
    // sphere(0) is the empty set: it empties an intersection, not a difference.
    let m = model("intersection() { cube(size = 1); sphere(r = 0); }\ncube(size = 2);");
    assert_eq!(m.primitives.len(), 1);
    assert_eq!(m.primitives[0].name, "cube_L2");
    let m = model("difference() { cube(size = 1); sphere(r = 0); }");
    assert_eq!(m.expr.nodes, vec![Node::Leaf { prim: 0 }]);
    let e = err("difference() { group(); }\n*cube(size = 1);");
    assert!(e.contains("no solid"), "{e}");
    // So is a child that yields nothing (OpenSCAD 2021.01 draws these
    // intersections and this difference as nothing, in preview and render).
    for empty in [
        "group();",
        "render();",
        "linear_extrude(height = 1);",
        "minkowski();",
        "circle(r = 2);",
    ] {
        let m = model(&format!(
            "intersection() {{ cube(size = 1); {empty} }}\ncube(size = 2);"
        ));
        assert_eq!(m.primitives.len(), 1, "{empty}");
        assert_eq!(m.primitives[0].name, "cube_L2", "{empty}");
    }
    let e = err("difference() { render(); cube(size = 1); }");
    assert!(e.contains("no solid"), "{e}");
    // A `%` child is not part of the solid: the intersection is the cube.
    let m = model("intersection() { cube(size = 1); %sphere(r = 0.2); }");
    assert_eq!(m.primitives.len(), 1);
}

#[test]
fn multmatrix_composes_row_major_and_colour_keeps_alpha() {
    // Translate (1, 2, 3) then scale x by 2: x' = 2x + 1.
    let m = model(
        "multmatrix([[1, 0, 0, 1], [0, 1, 0, 2], [0, 0, 1, 3], [0, 0, 0, 1]]) {\n multmatrix([[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) {\n  color([0, 0, 1, 0.25]) color([1, 0, 0, 1]) cube(size = 1);\n }\n}",
    );
    let p = &m.primitives[0];
    let hi = p
        .mesh
        .positions
        .iter()
        .fold(DVec3::NEG_INFINITY, |a, &q| a.max(q));
    assert_eq!(hi, DVec3::new(3.0, 3.0, 4.0));
    // The outermost colour wins (OpenSCAD 2021.01), alpha kept.
    assert_eq!(p.color, [0, 0, 255]);
    assert!(matches!(p.shape, Shape::OpenScad { rgba, .. } if rgba[3] == 0.25));
    // A mirror keeps the mesh outward.
    let m = model("multmatrix([[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) sphere(r = 1, $fn = 8);");
    closed_outward(&m.primitives[0].mesh);
    let e = err("multmatrix([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]]) cube();");
    assert!(e.contains("projective"), "{e}");
}

#[test]
fn modifiers() {
    // `%` is left out with a warning; `#` stays, highlighted; `*` vanishes.
    let m = model("%sphere(r = 1);\n#cube(size = 1);\n*cube(size = 5);");
    assert_eq!(m.primitives.len(), 1);
    assert_eq!(m.primitives[0].color, [255, 81, 81]);
    assert!(m
        .warnings
        .iter()
        .any(|w| w.contains("t.csg:1:2:") && w.contains("background")));
    // The `%` part is a set of its own, in OpenSCAD's background grey.
    assert_eq!(m.background.len(), 1);
    assert_eq!(m.background[0].name, "background_sphere_L1");
    assert_eq!(m.background[0].primitives[0].color, [180, 180, 180]);
    // `!`: only that subtree, without its ancestors' transforms.
    let m = model("cube(size = 9);\nmultmatrix([[1, 0, 0, 5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) { !sphere(r = 1, $fn = 6); }");
    assert_eq!(m.primitives.len(), 1);
    assert_eq!(m.primitives[0].name, "sphere_L2");
    assert!(m.primitives[0]
        .mesh
        .positions
        .iter()
        .all(|p| p.length() < 1.0 + 1e-9));
}

#[test]
fn unsupported_nodes_and_geometry_errors() {
    for (node, name) in [
        ("projection(cut = false) { cube(); }", "projection"),
        (
            "hull() { difference() { cube(); sphere(); } }",
            "difference",
        ),
    ] {
        let e = err(&format!("group() {{\n  cube();\n  {node}\n}}"));
        assert!(
            e.starts_with("t.csg:3:")
                && e.contains(&format!("`{name}`"))
                && e.contains("not supported"),
            "{e}"
        );
        let m = model_from_str(
            &format!("group() {{\n  cube();\n  {node}\n}}"),
            Path::new("t.csg"),
            true,
        )
        .unwrap();
        assert_eq!(m.primitives.len(), 1);
        assert!(
            m.warnings.iter().any(|w| w.contains(":3:")),
            "{:?}",
            m.warnings
        );
    }
    // `inf` and `nan` are undef to OpenSCAD: the parameter's default, the
    // identity's matrix entry, or the polyhedron dropped (observed with
    // OpenSCAD 2021.01's CGAL render of such a `.csg`).
    for (src, want, prims) in [
        ("cube(size = [1, inf, 1]);", "t.csg:1:13:", 1),
        ("sphere(r = nan);", "t.csg:1:12:", 1),
        ("cylinder(h = -inf, r1 = 1, r2 = 1);", "t.csg:1:14:", 1),
        (
            "multmatrix([[1, 0, 0, nan], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) cube();",
            "t.csg:1:13:",
            1,
        ),
        (
            "polyhedron(points = [[0, 0, inf]], faces = []);",
            "t.csg:1:22:",
            0,
        ),
    ] {
        let m = model(&format!(
            "{src}\nmultmatrix([[1, 0, 0, 9], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) cube();"
        ));
        assert_eq!(m.primitives.len(), prims + 1, "{src}");
        assert!(
            m.warnings
                .iter()
                .any(|w| w.starts_with(want) && w.contains("infinite or NaN")),
            "{src}: {:?}",
            m.warnings
        );
        let first = m.primitives[0].mesh.aabb().unwrap();
        if prims == 1 {
            assert!(first.max.x <= 1.0 + 1e-12, "{src}: the default size");
        }
    }
    let e = err("cube(size = 1) { sphere(); }");
    assert!(e.contains("takes no children"), "{e}");
    let e = err("cube(1, true, 3);");
    assert!(e.contains("positional"), "{e}");
}

#[test]
fn two_thousand_cylinders_are_one_balanced_union() {
    let mut s = String::from("union() {\n");
    for i in 0..2000 {
        s.push_str(&format!(
            "multmatrix([[1, 0, 0, {}], [0, 1, 0, {}], [0, 0, 1, 0], [0, 0, 0, 1]]) cylinder($fn = 16, h = 2, r1 = 0.4, r2 = 0.4, center = false);\n",
            i % 50,
            i / 50
        ));
    }
    s.push_str("}\n");
    let t = std::time::Instant::now();
    let m = model(&s);
    eprintln!("2000 cylinders: {:?} (dev profile)", t.elapsed());
    assert_eq!(m.primitives.len(), 2000);
    assert_eq!(m.expr.leaves().len(), 2000);
    assert_eq!(depth(&m.expr), 12); // ceil(log2 2000) + 1
}

fn depth(e: &Expr) -> usize {
    let mut d = vec![0usize; e.nodes.len()];
    for n in e.postorder() {
        d[n as usize] = 1 + e.nodes[n as usize]
            .children()
            .map(|c| d[c as usize])
            .max()
            .unwrap_or(0);
    }
    d[e.root as usize]
}

// ---------------------------------------------------------------- fuzzing

const VALID: &str = "difference() {\n\tcube(size = [10, 10, 2], center = true);\n#\tmultmatrix([[1, 0, 0, 2], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) {\n\t\tcylinder($fn = 12, $fa = 12, $fs = 2, h = 5, r1 = 1.5, r2 = 1.5, center = true);\n\t}\n}\n%sphere(r = 3);\ncolor([1, 0, 0, 0.5]) polyhedron(points = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], faces = [[0, 1, 2], [0, 3, 1], [1, 3, 2], [0, 2, 3]]);\n";

const PIECES: &[&str] = &[
    "group()",
    "cube(",
    "sphere(",
    "cylinder(",
    "polyhedron(",
    "multmatrix(",
    "color(",
    "difference()",
    "intersection()",
    "hull()",
    "(",
    ")",
    "{",
    "}",
    "[",
    "]",
    ",",
    ";",
    "=",
    "%",
    "#",
    "!",
    "*",
    "-",
    "1",
    "0",
    "-2.5",
    "1e-06",
    "inf",
    "nan",
    "undef",
    "true",
    "\"s\\n\"",
    "r",
    "size",
    "$fn",
    " ",
    "\n",
    "/*",
    "*/",
    "//",
    "\"",
    "\\",
    "é",
];

pub(super) fn check_outcome(text: &str) {
    match model_from_str(text, Path::new("f.csg"), false) {
        Ok(m) => {
            assert!(!m.primitives.is_empty());
            for p in &m.primitives {
                assert!(p.mesh.positions.iter().all(|v| v.is_finite()));
            }
        }
        Err(SceneError::Syntax { line, column, .. }) => {
            assert!(line >= 1 && column >= 1);
            assert!(line <= text.lines().count().max(1) + 1);
        }
        Err(e) => panic!("unexpected error kind: {e}"),
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 10_000, failure_persistence: None, ..ProptestConfig::default() })]

    /// Token soup: no panic, a located error or a model.
    #[test]
    fn fuzz_token_soup(pieces in prop::collection::vec(0..PIECES.len(), 0..60)) {
        let text: String = pieces.iter().map(|&i| PIECES[i]).collect();
        check_outcome(&text);
    }

    /// A valid export with a random byte range replaced by random pieces.
    #[test]
    fn fuzz_mutated_export(a in 0..VALID.len(), len in 0usize..20, pieces in prop::collection::vec(0..PIECES.len(), 0..4)) {
        let start = (0..=a).rev().find(|&i| VALID.is_char_boundary(i)).unwrap();
        let mut end = (start + len).min(VALID.len());
        while !VALID.is_char_boundary(end) { end -= 1; }
        let ins: String = pieces.iter().map(|&i| PIECES[i]).collect();
        let text = format!("{}{}{}", &VALID[..start], ins, &VALID[end..]);
        check_outcome(&text);
    }
}

/// `%` subtrees: out of the solid, each its own set (transforms and
/// operators inside kept, nested `%` part of the outer one, unsupported nodes
/// dropped with a warning); `show` adds them as see-through solids.
#[test]
fn background_parts_are_sets_of_their_own() {
    let text = "difference() {\n cube(size = 4);\n %multmatrix([[1, 0, 0, 9], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) difference() { cube(size = 2); %sphere(r = 1, $fn = 8); square(1); }\n}\n%cube(size = 1);\n";
    let m = model(text);
    // The solid is the cube alone: the `%` subtrahend vanishes from it.
    assert_eq!(m.primitives.len(), 1);
    assert_eq!(m.expr.leaves().len(), 1);
    assert_eq!(m.background.len(), 2);
    let b = &m.background[0];
    assert_eq!(b.name, "background_multmatrix_L3");
    // cube − sphere, moved by the part's own multmatrix; the square dropped.
    assert_eq!(b.primitives.len(), 2);
    assert!(matches!(b.expr.nodes[b.expr.root as usize], Node::Diff(..)));
    assert!(b.primitives[0]
        .mesh
        .positions
        .iter()
        .all(|p| p.x >= 9.0 - 1e-9));
    assert!(m
        .warnings
        .iter()
        .any(|w| w.contains("`square`") && w.contains("2D shape among 3D")));
    assert_eq!(m.background[1].name, "background_cube_L5");
    // Names are unique over the solid and the parts.
    let mut names: Vec<&str> = m
        .primitives
        .iter()
        .chain(m.background.iter().flat_map(|b| &b.primitives))
        .map(|p| p.name.as_str())
        .collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), 4);

    let mut scene =
        crate::scene::load_str(text, Path::new("/m/t.csg"), &Default::default()).unwrap();
    assert_eq!(scene.solids.len(), 1);
    assert_eq!(scene.appearance.background.len(), 2);
    assert!(!scene.appearance.is_transparent());
    assert_eq!(
        scene
            .warnings
            .iter()
            .filter(|w| w.contains("is left out"))
            .count(),
        2
    );
    let (near, far) = (scene.camera.near, scene.camera.far);
    assert_eq!(super::background::show(&mut scene), 2);
    assert_eq!(scene.solids.len(), 3);
    assert_eq!(scene.primitives.len(), 4);
    // The parts' leaves index their own primitives after the model's.
    let leaves: Vec<u32> = scene.solids[1].expr.leaves();
    assert_eq!(leaves, vec![1, 2]);
    assert_eq!(scene.solids[2].expr.leaves(), vec![3]);
    let a = super::background::alpha();
    assert!((a - 128.0 / 255.0).abs() < 1e-6);
    assert_eq!(scene.appearance.alpha_of(0, 0), 1.0);
    assert_eq!(scene.appearance.alpha_of(1, 1), a);
    assert!(scene.appearance.is_transparent());
    assert!(scene.warnings.iter().all(|w| !w.contains("is left out")));
    assert!(scene.camera.near <= near && scene.camera.far >= far);
    // The far part (x = 9..11) is inside the depth range.
    for p in &scene.primitives[1].mesh.positions {
        let d = scene.camera.view_depth(*p);
        assert!(d > scene.camera.near && d < scene.camera.far, "{d}");
    }
    assert!(scene.appearance.background.is_empty());
    assert_eq!(super::background::show(&mut scene), 0);
}

// ---------------------------------------------------------------- 2D and extrusions

fn volume(m: &Model) -> f64 {
    m.primitives.iter().map(|p| signed_volume(&p.mesh)).sum()
}

fn warned(m: &Model, what: &str) -> bool {
    m.warnings.iter().any(|w| w.contains(what))
}

#[test]
fn linear_extrude_of_circle_square_polygon() {
    // circle(r = 10): min(360/12, 10·2π/2) → 30 fragments; one slice.
    let m = model("linear_extrude(height = 3, center = true, convexity = 1, scale = [1, 1], $fn = 0, $fa = 12, $fs = 2) circle($fn = 0, $fa = 12, $fs = 2, r = 10);");
    assert_eq!(m.primitives.len(), 1);
    let mesh = &m.primitives[0].mesh;
    closed_outward(mesh);
    assert_eq!(mesh.positions.len(), 60);
    let z: Vec<f64> = mesh.positions.iter().map(|p| p.z).collect();
    assert!(z.iter().all(|&z| z == -1.5 || z == 1.5));
    // square and d = diameter.
    let m = model("linear_extrude(height = 2) square(size = [3, 4], center = false);");
    assert!((volume(&m) - 24.0).abs() < 1e-9);
    let m = model("linear_extrude(height = 1) circle(d = 4, $fn = 4);");
    assert!((volume(&m) - 8.0).abs() < 1e-9);
    // A concave polygon (an L) and its area.
    let m = model("linear_extrude(height = 1) polygon(points = [[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], paths = undef, convexity = 1);");
    closed_outward(&m.primitives[0].mesh);
    assert!((volume(&m) - 3.0).abs() < 1e-6, "{}", volume(&m));
}

#[test]
fn polygon_paths_fill_by_the_even_odd_rule() {
    // Three nested squares: 36 − 16 + 4 by even-odd.
    let m = model("linear_extrude(height = 1) polygon(points = [[-3, -3], [3, -3], [3, 3], [-3, 3], [-2, -2], [2, -2], [2, 2], [-2, 2], [-1, -1], [1, -1], [1, 1], [-1, 1]], paths = [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11]]);");
    for p in &m.primitives {
        closed_outward(&p.mesh);
    }
    assert!((volume(&m) - 24.0).abs() < 1e-6, "{}", volume(&m));
    // A hole given in the same direction as the outline is still a hole.
    let m = model("linear_extrude(height = 2) polygon(points = [[0, 0], [4, 0], [4, 4], [0, 4], [1, 1], [3, 1], [3, 3], [1, 3]], paths = [[0, 1, 2, 3], [4, 5, 6, 7]]);");
    assert!((volume(&m) - 24.0).abs() < 1e-6);
    // A self-intersecting bow tie: two triangles of area 1 each.
    let m = model("linear_extrude(height = 1) polygon(points = [[0, 0], [2, 2], [2, 0], [0, 2]]);");
    closed_outward(&m.primitives[0].mesh);
    assert!((volume(&m) - 2.0).abs() < 1e-6, "{}", volume(&m));
}

#[test]
fn two_d_booleans_become_3d_booleans() {
    let m = model("linear_extrude(height = 2) difference() { square(size = [10, 10], center = true); circle(r = 2, $fn = 16); }\nmultmatrix([[1, 0, 0, 20], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) linear_extrude(height = 2) intersection() { square(size = 4, center = true); multmatrix([[1, 0, 0, 2], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) square(size = 4, center = true); }");
    assert_eq!(m.primitives.len(), 4);
    assert!(inside(&m, DVec3::new(4.0, 0.0, 1.0)));
    assert!(!inside(&m, DVec3::new(0.0, 0.0, 1.0)), "the hole");
    assert!(!inside(&m, DVec3::new(4.0, 0.0, 2.5)), "above");
    // The intersection moved by the outer multmatrix: x in [20, 22].
    assert!(inside(&m, DVec3::new(21.0, 0.0, 1.0)));
    assert!(!inside(&m, DVec3::new(19.0, 0.0, 1.0)));
    // A mirroring 2D transform keeps the solid outward.
    let m = model("linear_extrude(height = 1) multmatrix([[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) polygon(points = [[0, 0], [2, 0], [0, 2]]);");
    closed_outward(&m.primitives[0].mesh);
    assert!(m.primitives[0].mesh.positions.iter().all(|p| p.x <= 0.0));
}

#[test]
fn linear_extrude_slices_twist_and_scale() {
    // twist 30, height 10, square(10): 3 slices (4 rings of 4).
    let m = model("linear_extrude(height = 10, center = false, convexity = 1, twist = 30, scale = [1, 1], $fn = 0, $fa = 12, $fs = 2) square(size = [10, 10], center = false);");
    let mesh = &m.primitives[0].mesh;
    closed_outward(mesh);
    assert_eq!(mesh.positions.len(), 16);
    // A positive twist turns clockwise seen from +Z: (10, 0) goes below y = 0.
    let top: Vec<DVec3> = mesh
        .positions
        .iter()
        .filter(|p| p.z == 10.0)
        .copied()
        .collect();
    assert!(
        top.iter()
            .any(|p| (p.x - 8.660254).abs() < 1e-5 && (p.y + 5.0).abs() < 1e-5),
        "{top:?}"
    );
    // scale [2, 1]: ceil(sqrt(Δ² + h²) / $fs) = 8 slices for a 10-high square(10).
    let m = model("linear_extrude(height = 10, scale = [2, 1]) square(size = [10, 10]);");
    assert_eq!(m.primitives[0].mesh.positions.len(), 4 * 9);
    closed_outward(&m.primitives[0].mesh);
    // `slices` given.
    let m = model(
        "linear_extrude(height = 10, twist = 90, slices = 5) square(size = 1, center = true);",
    );
    assert_eq!(m.primitives[0].mesh.positions.len(), 4 * 6);
    // scale 0: a cone to one apex; volume h·A/3.
    let m = model("linear_extrude(height = 3, scale = 0) square(size = 2, center = true);");
    let mesh = &m.primitives[0].mesh;
    closed_outward(mesh);
    assert_eq!(mesh.positions.len(), 5);
    assert!((volume(&m) - 4.0).abs() < 1e-9);
    // scale 0 on one axis: a wedge, still closed; twisted to 0 as well.
    let m = model("linear_extrude(height = 3, scale = [1, 0]) square(size = 2, center = true);");
    closed_outward(&m.primitives[0].mesh);
    assert!((volume(&m) - 6.0).abs() < 1e-9);
    let m = model("linear_extrude(height = 3, twist = 90, scale = 0) circle(r = 1, $fn = 12);");
    closed_outward(&m.primitives[0].mesh);
    // A negative scale is taken as 0; a height ≤ 0 makes nothing.
    let m = model("linear_extrude(height = 3, scale = -2) square(size = 2);cube();");
    assert!(warned(&m, "negative `scale`"));
    let e = err("linear_extrude(height = -3) square(size = 2);");
    assert!(e.contains("no solid"), "{e}");
}

#[test]
fn rotate_extrude_fragments_and_angles() {
    // circle(1) at x = 3: fragments from x = 4 → 13.
    let m = model("rotate_extrude(angle = 360, convexity = 2, $fn = 0, $fa = 12, $fs = 2) multmatrix([[1, 0, 0, 3], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) circle($fn = 0, $fa = 12, $fs = 2, r = 1);");
    let mesh = &m.primitives[0].mesh;
    closed_outward(mesh);
    assert_eq!(mesh.positions.len(), 5 * 13);
    // The first ring on −X at 360°.
    assert!(mesh.positions[..5]
        .iter()
        .all(|p| p.x < 0.0 && p.y.abs() < 1e-12));
    // 90°: 13 · 90/360 truncated → 3 fragments, 4 rings, starting on +X.
    let m = model("rotate_extrude(angle = 90) multmatrix([[1, 0, 0, 3], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) circle(r = 1);");
    let mesh = &m.primitives[0].mesh;
    closed_outward(mesh);
    assert_eq!(mesh.positions.len(), 5 * 4);
    assert!(mesh.positions[..5]
        .iter()
        .all(|p| p.x > 0.0 && p.y.abs() < 1e-12));
    // A profile with a hole, revolved; a profile touching the axis.
    let m = model("rotate_extrude($fn = 8) polygon(points = [[1, 0], [3, 0], [3, 2], [1, 2], [1.5, 0.5], [2.5, 0.5], [2.5, 1.5], [1.5, 1.5]], paths = [[0, 1, 2, 3], [4, 5, 6, 7]]);");
    closed_outward(&m.primitives[0].mesh);
    let m =
        model("rotate_extrude(angle = -120, $fn = 9) polygon(points = [[0, 0], [2, 0], [0, 2]]);");
    closed_outward(&m.primitives[0].mesh);
    // Negative x profiles revolve too; a profile across the axis makes nothing.
    let m = model("rotate_extrude($fn = 8) multmatrix([[1, 0, 0, -3], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) square(size = 1);");
    closed_outward(&m.primitives[0].mesh);
    let m = model("cube();\nrotate_extrude() square(size = 2, center = true);");
    assert_eq!(m.primitives.len(), 1);
    assert!(warned(&m, "same sign of x"), "{:?}", m.warnings);
}

#[test]
fn mixed_dimensions_are_dropped_with_a_warning() {
    let m = model("group() {\n  cube();\n  square(size = 3);\n}\nlinear_extrude(height = 1) { circle(r = 1); sphere(r = 1); }");
    assert_eq!(m.primitives.len(), 2);
    assert!(
        warned(&m, ":3:3:") && warned(&m, "2D shape among 3D"),
        "{:?}",
        m.warnings
    );
    assert!(warned(&m, "3D object inside a 2D subtree"));
    // A 2D model alone is drawn as a plate (`tests2d`).
    let m = model("square(size = 3);");
    assert!(warned(&m, "plate 1 unit thick"));
}

#[test]
fn hostile_two_d_input_is_a_located_error_or_a_render() {
    // Infinite or NaN numbers are undef, as OpenSCAD reads them: a warning.
    for (src, at) in [
        ("linear_extrude(height = nan) square();", "nan"),
        ("linear_extrude(height = 1, twist = inf) square();", "inf"),
        ("linear_extrude(height = 1) circle(r = -inf);", "-inf"),
        (
            "linear_extrude(height = 1) square(size = [1, nan]);",
            "[1, nan]",
        ),
        (
            "linear_extrude(height = 1) polygon(points = [[0, 0], [1, nan], [0, 1]]);",
            "[[0, 0]",
        ),
    ] {
        let m = model(&format!("{src}\ncube();"));
        let at = format!("t.csg:1:{}:", src.find(at).unwrap() + 1);
        assert!(
            m.warnings
                .iter()
                .any(|w| w.starts_with(&at) && w.contains("infinite or NaN")),
            "{src}: {:?}",
            m.warnings
        );
    }
    for (src, at, want) in [
        ("linear_extrude(height = 1) polygon(points = [[0, 0], [1, 0], [0, 1]], paths = [[0, 1, 7]]);", "7]", "not a point index"),
        ("linear_extrude(height = 1) polygon(points = [[0, 0], [1e300, 0], [0, 1]]);", "[1e300", "beyond"),
        ("linear_extrude(height = 1) polygon(points = [[0, 0, 0, 0]]);", "[0, 0, 0, 0]", "must be [x, y]"),
        ("linear_extrude(height = 1) polygon();", "polygon", "needs `points ="),
        ("linear_extrude(height = 1) square(size = [1, 2, 3]);", "[1, 2, 3]", "[x, y]"),
        ("linear_extrude(height = 1, slices = 1e9) square();", "1e9", "at most"),
        ("linear_extrude(height = 1, twist = 1e300) square();", "linear", "slices"),
        ("rotate_extrude($fn = 1e9) square();", "rotate", "fragments"),
        ("linear_extrude(height = 1, scale = [1, 2, 3]) square();", "[1, 2, 3]", "[x, y]"),
        ("linear_extrude(height = 1) square() { cube(); }", "square", "no children"),
        ("linear_extrude(file = \"a.dxf\", height = 1);", "\"a.dxf", "imported file"),
    ] {
        let e = err(src);
        let at = format!("t.csg:1:{}:", src.find(at).unwrap() + 1);
        assert!(e.starts_with(&at) && e.contains(want), "{src}: {e}");
    }
    // Degenerate outlines and sizes are the empty set.
    for src in [
        "linear_extrude(height = 1) polygon(points = [[0, 0], [1, 1], [2, 2]]);",
        "linear_extrude(height = 1) polygon(points = [[0, 0], [1, 1]]);",
        "linear_extrude(height = 1) polygon(points = []);",
        "linear_extrude(height = 1) polygon(points = [[0, 0], [1, 0], [0, 1]], paths = []);",
        "linear_extrude(height = 1) square(size = [-1, 2]);",
        "linear_extrude(height = 1) circle(r = 0);",
        "linear_extrude(height = 1) polygon(points = [[0, 0], [1e-300, 0], [0, 1e-300]]);",
        "linear_extrude(height = 1) multmatrix([[0, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) square();",
        "rotate_extrude(angle = 0) square();",
        "linear_extrude(height = 1);",
    ] {
        let e = err(src);
        assert!(e.contains("no solid"), "{src}: {e}");
    }
    // 10^5 points: a star outline, in bounded time.
    let n = 100_000;
    let pts = star_points(n);
    let t = std::time::Instant::now();
    let m = model(&format!(
        "linear_extrude(height = 1) polygon(points = [{}]);",
        pts.join(", ")
    ));
    closed_outward(&m.primitives[0].mesh);
    assert!(t.elapsed().as_secs() < 60, "{:?}", t.elapsed());
    // The same points, scrambled into a self-crossing tangle: a render or an error, no panic.
    let tangled: Vec<String> = (0..2000).map(|i| pts[(i * 7919) % n].clone()).collect();
    let _ = model_from_str(
        &format!(
            "linear_extrude(height = 1, twist = 40) polygon(points = [{}]);",
            tangled.join(", ")
        ),
        Path::new("t.csg"),
        false,
    );
}

#[test]
fn concave_polyhedron_faces_are_ear_clipped() {
    // OpenSCAD's polyhedron-concave-test: a hexagon with a notch, 5 high. A
    // fan from the first point would fold triangles over the notch.
    let m = model("polyhedron(points = [[0, 0, 0], [2, 4, 0], [8, 4, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0], [0, 0, 5], [2, 4, 5], [8, 4, 5], [10, 0, 5], [10, 10, 5], [0, 10, 5]], faces = [[0, 1, 2, 3, 4, 5], [0, 6, 7], [0, 7, 1], [1, 7, 8], [1, 8, 2], [2, 8, 9], [2, 9, 3], [3, 9, 10], [3, 10, 4], [4, 10, 11], [4, 11, 5], [5, 11, 6], [5, 6, 0], [11, 10, 9, 8, 7, 6]], convexity = 2);");
    let mesh = &m.primitives[0].mesh;
    closed_outward(mesh);
    assert!((signed_volume(mesh) - 340.0).abs() < 1e-9);
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a);
        if a.z == b.z && b.z == c.z {
            // Bottom faces point down, top faces up: none folded.
            assert!(n.z * (a.z - 2.5) > 0.0, "{t:?}");
        }
    }
}
