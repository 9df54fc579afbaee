//! `hull`, `minkowski`, `resize`, `import` and `surface` in `.csg` models:
//! the pieces they become, their colours and names, and their errors.

use glam::DVec3;
use std::path::{Path, PathBuf};

use super::{model_from_str, Model};
use crate::scene::validate::{check_closed, signed_volume};

fn model_at(text: &str, path: &Path) -> Result<Model, String> {
    model_from_str(text, path, false).map_err(|e| e.to_string())
}

fn model(text: &str) -> Model {
    model_at(text, Path::new("t.csg")).unwrap_or_else(|e| panic!("{e}"))
}

fn err(text: &str) -> String {
    model_at(text, Path::new("t.csg")).err().expect("an error")
}

fn volume(m: &Model) -> f64 {
    m.primitives
        .iter()
        .map(|p| {
            check_closed(&p.mesh).unwrap();
            signed_volume(&p.mesh)
        })
        .sum()
}

fn bounds(m: &Model) -> (DVec3, DVec3) {
    m.primitives
        .iter()
        .map(|p| p.mesh.aabb().unwrap())
        .map(|b| (b.min, b.max))
        .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
        .unwrap()
}

const T5: &str = "multmatrix([[1, 0, 0, 5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])";

#[test]
fn hull_of_transformed_primitives_is_one_primitive() {
    let m = model(&format!(
        "multmatrix([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 10], [0, 0, 0, 1]]) hull() {{\n  cube(size = [1, 1, 1]);\n  {T5} group() {{ cube(size = [1, 1, 1]); }}\n}}"
    ));
    assert_eq!(m.primitives.len(), 1);
    assert_eq!(m.primitives[0].name, "hull_L1");
    assert!((volume(&m) - 6.0).abs() < 1e-12);
    assert_eq!(
        bounds(&m),
        (DVec3::new(0.0, 0.0, 10.0), DVec3::new(6.0, 1.0, 11.0))
    );
    // A hull among other parts takes part in their Booleans.
    let m = model(&format!(
        "difference() {{ cube(size = [20, 20, 20], center = true); hull() {{ sphere(r = 1); {T5} sphere(r = 1); }} }}"
    ));
    assert_eq!(m.primitives.len(), 2);
    assert!(matches!(
        m.expr.nodes[m.expr.root as usize],
        crate::csg::Node::Diff(..)
    ));
    // Flat children have no 3D hull: the empty set.
    let e = err(
        "hull() { multmatrix([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]) cube(); }",
    );
    assert!(e.contains("no solid"), "{e}");
}

#[test]
fn booleans_below_hull_minkowski_resize_are_refused_by_name() {
    for (op, inner) in [
        ("hull", "difference"),
        ("minkowski", "intersection"),
        ("resize(newsize = [1, 1, 1])", "difference"),
    ] {
        let name = op.split('(').next().unwrap();
        let src = format!(
            "cube();\n{}{} {{ cube(); {inner}() {{ cube(); sphere(); }} }}",
            op,
            if op.contains('(') { "" } else { "()" }
        );
        let e = err(&src);
        assert!(
            e.starts_with("t.csg:2:") && e.contains(&format!("`{inner}` inside `{name}` (line 2)")),
            "{e}"
        );
        assert!(e.contains("mesh Boolean"), "{e}");
    }
}

#[test]
fn minkowski_of_convex_parts() {
    // A rounded box: cube ⊕ sphere, as one convex piece.
    let m =
        model("minkowski() { cube(size = [10, 10, 2], center = true); sphere($fn = 8, r = 1); }");
    assert_eq!(m.primitives.len(), 1);
    assert_eq!(m.primitives[0].name, "minkowski_L1");
    let (lo, hi) = bounds(&m);
    // The sphere's rings stop short of its radius (OpenSCAD's tessellation).
    assert!(
        hi.x > 5.9 && hi.x <= 6.0 && lo.z < -1.9 && lo.z >= -2.0,
        "{lo} {hi}"
    );
    // A union of two cubes sums part by part.
    let m = model(&format!(
        "minkowski() {{ union() {{ cube(); {T5} cube(); }} cube(size = [1, 1, 1], center = true); }}"
    ));
    assert_eq!(m.primitives.len(), 2);
    assert!((volume(&m) - 16.0).abs() < 1e-12);
    // Under a transform, the translation applies once.
    let m = model(&format!("{T5} minkowski() {{ cube(); cube(); }}"));
    assert_eq!(
        bounds(&m),
        (DVec3::new(5.0, 0.0, 0.0), DVec3::new(7.0, 2.0, 2.0))
    );
    // A non-convex child is named.
    let l = "polyhedron(points = [[0, 0, 0], [2, 0, 0], [2, 1, 0], [1, 1, 0], [1, 2, 0], [0, 2, 0], [0, 0, 1], [2, 0, 1], [2, 1, 1], [1, 1, 1], [1, 2, 1], [0, 2, 1]], faces = [[0, 1, 2, 3, 4, 5], [11, 10, 9, 8, 7, 6], [6, 7, 1, 0], [7, 8, 2, 1], [8, 9, 3, 2], [9, 10, 4, 3], [10, 11, 5, 4], [11, 6, 0, 5]]);";
    let m = model(l);
    assert!((volume(&m) - 3.0).abs() < 1e-12, "the L is a valid solid");
    let e = err(&format!("minkowski() {{\n {l}\n cube();\n}}"));
    assert!(
        e.starts_with("t.csg:1:1:") && e.contains("`polyhedron` (line 2) is not convex"),
        "{e}"
    );
}

#[test]
fn resize_scales_from_the_leaves_bounding_box() {
    let m = model(
        "resize(newsize = [10,30,0], auto = [0,0,1], convexity = 0) {\n\tcube(size = [2, 4, 8], center = false);\n}",
    );
    assert_eq!(bounds(&m), (DVec3::ZERO, DVec3::new(10.0, 30.0, 60.0)));
    assert_eq!(m.primitives[0].name, "cube_L2");
    let m = model(&format!(
        "resize(newsize = [6,0,0], auto = [0,0,0]) {{ multmatrix([[1, 0, 0, 1], [0, 1, 0, 1], [0, 0, 1, 1], [0, 0, 0, 1]]) cube(size = [2, 4, 8]); {T5} sphere(r = 0.5); }}"
    ));
    assert_eq!(m.primitives.len(), 2);
    let (lo, hi) = bounds(&m);
    assert!((hi.x - lo.x - 6.0).abs() < 1e-12, "{lo} {hi}");
    let m = model("resize(newsize = [0, 0, 5]) multmatrix([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]) cube(); cube();");
    assert!(
        m.warnings.iter().any(|w| w.contains("flat along z")),
        "{:?}",
        m.warnings
    );
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("peeltrim-scad3d-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// An ASCII STL of the cube from `lo` to `hi` on every axis.
pub(super) fn cube_stl(lo: f32, hi: f32) -> String {
    let p = |i: usize| {
        [
            if i & 1 != 0 { hi } else { lo },
            if i & 2 != 0 { hi } else { lo },
            if i & 4 != 0 { hi } else { lo },
        ]
    };
    // CCW from outside.
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let mut s = String::from("solid cube\n");
    for q in quads {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            s += "facet normal 0 0 0\nouter loop\n";
            for i in t {
                let v = p(i);
                s += &format!("vertex {} {} {}\n", v[0], v[1], v[2]);
            }
            s += "endloop\nendfacet\n";
        }
    }
    s + "endsolid cube\n"
}

#[test]
fn import_stl_and_off_relative_to_the_csg_file() {
    let d = temp_dir("import");
    std::fs::write(d.join("part.stl"), cube_stl(-1.0, 1.0)).unwrap();
    std::fs::write(
        d.join("part.off"),
        "OFF\n8 6 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n",
    )
    .unwrap();
    let csg = d.join("m.csg");
    let m = model_at(
        "difference() {\n cube(size = [4, 4, 4], center = true);\n import(file = \"part.stl\", layer = \"\", origin = [0, 0], scale = 1, convexity = 1, $fn = 0, $fa = 12, $fs = 2, timestamp = 0);\n}\nmultmatrix([[1, 0, 0, 5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) import(\"part.off\");",
        &csg,
    )
    .unwrap();
    assert_eq!(m.primitives.len(), 3);
    assert_eq!(m.primitives[1].name, "import_L3");
    assert!((signed_volume(&m.primitives[1].mesh) - 8.0).abs() < 1e-9);
    assert_eq!(
        m.primitives[2].mesh.aabb().unwrap().min,
        DVec3::new(5.0, 0.0, 0.0)
    );
    // An open mesh: the file named and the fix.
    // The first facet's seven lines removed.
    let full = cube_stl(0.0, 1.0);
    let mut lines: Vec<&str> = full.lines().collect();
    lines.drain(1..8);
    std::fs::write(d.join("open.stl"), lines.join("\n")).unwrap();
    let e = model_at("import(file = \"open.stl\");", &csg).unwrap_err();
    assert!(
        e.contains("m.csg:1:1:") && e.contains("open.stl") && e.contains("not a closed"),
        "{e}"
    );
    // A missing file: OpenSCAD's warning, and the rest renders.
    let m = model_at("import(file = \"missing.stl\");\ncube();", &csg).unwrap();
    assert_eq!(m.primitives.len(), 1);
    assert!(
        m.warnings
            .iter()
            .any(|w| w.contains("missing.stl") && w.contains("relative to the .csg")),
        "{:?}",
        m.warnings
    );
    std::fs::write(d.join("a.3mf"), "x").unwrap();
    let e = model_at("import(file = \"a.3mf\");", &csg).unwrap_err();
    assert!(e.contains("STL"), "{e}");
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn surface_of_a_dat_file() {
    let d = temp_dir("surface");
    std::fs::write(d.join("h.dat"), "# heights\n1 2 3\n4 5 6.5\n").unwrap();
    let csg = d.join("m.csg");
    let m = model_at(
        "surface(file = \"h.dat\", center = true, invert = false, timestamp = 0);",
        &csg,
    )
    .unwrap();
    let (lo, hi) = bounds(&m);
    assert_eq!(
        (lo, hi),
        (DVec3::new(-1.0, -0.5, 0.0), DVec3::new(1.0, 0.5, 6.5))
    );
    assert!(volume(&m) > 0.0);
    std::fs::remove_dir_all(&d).ok();
}
