//! OpenSCAD `.csg` models through the command line: every subcommand accepts
//! one, a TOML scene may name one, and every bad model (unsupported node, bad
//! syntax, inf/nan, open polyhedron) exits non-zero with `file:line:col`.

use std::path::PathBuf;

use super::scad_models::plate_with_holes;
use super::{assert_error, run, stderr, tmp};

fn model(name: &str) -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/openscad")
        .join(name)
        .display()
        .to_string()
}

fn write(dir: &std::path::Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

#[test]
fn render_plan_blist_accept_a_csg() {
    let out = tmp("scad-render");
    let o = run(&[
        "render",
        &model("spur_gear.csg"),
        "--size",
        "48x48",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for f in ["color.png", "depth.npy", "prim.png", "stats.json"] {
        assert!(out.join(f).is_file(), "{f}");
    }
    // prim.png indexes the model's primitives in order of appearance.
    let prim = image::open(out.join("prim.png")).unwrap().into_luma16();
    let max = prim.pixels().map(|p| p.0[0]).max().unwrap();
    assert!(max >= 1, "the gear is visible");
    let o = run(&["plan", &model("bracket.csg"), "--algo", "cst-i"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["blist", &model("modifiers.csg")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    // sphere − 2 cylinders, and the blue cube ∩ sphere; the `%` table is left out.
    assert_eq!(j["leaves"], 5);
    assert!(stderr(&o).contains("background"), "{}", stderr(&o));
}

#[test]
fn toml_scene_names_a_csg() {
    let d = tmp("scad-toml");
    std::fs::copy(model("spur_gear.csg"), d.join("spur_gear.csg")).unwrap();
    let scene = write(
        &d,
        "s.toml",
        "[camera]\neye = [0.0, -80.0, 60.0]\nup = [0.0, 0.0, 1.0]\nfit = true\n[render]\nwidth = 32\nheight = 32\n[csg]\nopenscad = \"spur_gear.csg\"\n",
    );
    let out = d.join("out");
    let o = run(&["render", &scene, "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bad = write(
        &d,
        "bad.toml",
        "[csg]\nopenscad = \"spur_gear.csg\"\nexpr = \"A\"\n",
    );
    assert_error(
        &run(&["render", &bad]),
        &["bad.toml:1", "csg: openscad", "remove `expr`"],
    );
    let missing = write(&d, "missing.toml", "[csg]\nopenscad = \"nope.csg\"\n");
    assert_error(
        &run(&["render", &missing]),
        &["nope.csg", "relative to the scene file"],
    );
    // `skip_unsupported = true` in the table, as --skip-unsupported.
    write(
        &d,
        "hull.csg",
        "group() {\n  hull() { cube(size = 1); }\n  sphere(r = 1);\n}\n",
    );
    let strict = write(&d, "strict.toml", "[csg]\nopenscad = \"hull.csg\"\n");
    assert_error(
        &run(&["blist", &strict]),
        &["hull.csg:2:3:", "`hull` is not supported"],
    );
    let skip = write(
        &d,
        "skip.toml",
        "[csg]\nopenscad = \"hull.csg\"\nskip_unsupported = true\n",
    );
    let o = run(&["blist", &skip]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("hull.csg:2:3: `hull` is not supported and was dropped"),
        "{}",
        stderr(&o)
    );
    let misplaced = write(&d, "misplaced.toml", "[[primitive]]\nname = \"A\"\nshape = \"box\"\nsize = [1.0, 1.0, 1.0]\n[csg]\nexpr = \"A\"\nskip_unsupported = true\n");
    assert_error(
        &run(&["blist", &misplaced]),
        &["csg: skip_unsupported", "only with `openscad"],
    );
}

#[test]
fn bad_models_are_located_errors() {
    let d = tmp("scad-bad");
    let cases: &[(&str, &[&str])] = &[
        ("hull() { cube(size = 1); }", &["x.csg:2:3:", "`hull`", "not supported", "--skip-unsupported"]),
        ("minkowski() { cube(size = 1); }", &["x.csg:2:3:", "`minkowski`"]),
        ("linear_extrude(height = 1) { square(size = 1); }", &["x.csg:2:3:", "`linear_extrude`"]),
        ("rotate_extrude() { square(size = 1); }", &["x.csg:2:3:", "`rotate_extrude`"]),
        ("import(file = \"a.stl\");", &["x.csg:2:3:", "`import`"]),
        ("surface(file = \"a.dat\");", &["x.csg:2:3:", "`surface`"]),
        ("text(text = \"a\");", &["x.csg:2:3:", "`text`"]),
        ("projection() { cube(size = 1); }", &["x.csg:2:3:", "`projection`"]),
        ("circle(r = 1);", &["x.csg:2:3:", "`circle`", "2D"]),
        ("cube(size = [1, 2 3]);", &["x.csg:2:21:", "expected `,` or `]`"]),
        ("sphere(r = inf);", &["x.csg:2:14:", "infinite or NaN"]),
        ("cube(size = [1, nan, 1]);", &["x.csg:2:19:", "infinite or NaN"]),
        (
            "polyhedron(points = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], faces = [[0, 1, 2], [0, 3, 1], [1, 3, 2]]);",
            &["x.csg:2:3:", "not a closed solid", "edge points["],
        ),
    ];
    for (i, (node, want)) in cases.iter().enumerate() {
        let sub = d.join(i.to_string());
        std::fs::create_dir_all(&sub).unwrap();
        let f = write(
            &sub,
            "x.csg",
            &format!("group() {{\n  {node}\n  cube(size = 1);\n}}\n"),
        );
        assert_error(
            &run(&[
                "render",
                &f,
                "--size",
                "8x8",
                "--out",
                d.join("o").to_str().unwrap(),
            ]),
            want,
        );
    }
    // --skip-unsupported drops the node with a warning naming it.
    let f = write(
        &d,
        "skip.csg",
        "group() {\n  hull() { cube(size = 1); }\n  cube(size = 1);\n}\n",
    );
    let o = run(&[
        "render",
        &f,
        "--skip-unsupported",
        "--size",
        "8x8",
        "--out",
        d.join("o").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("skip.csg:2:3: `hull` is not supported and was dropped"),
        "{}",
        stderr(&o)
    );
}

/// 2,000 cylinders. A plate minus 2,000 holes is one product of 2,001
/// literals: every algorithm plans it. Two crossing unions of 1,000 cylinders
/// intersected have 10^6 products: cst-i plans it, the sum-of-products
/// algorithms refuse with their clear error.
#[test]
fn two_thousand_cylinders_plan_with_cst_i() {
    let d = tmp("scad-holes");
    let holes = write(&d, "holes.csg", &plate_with_holes());
    for algo in ["cst-i", "goldfeather", "trickle"] {
        let o = run(&["plan", &holes, "--algo", algo]);
        assert!(o.status.success(), "{algo}: {}", stderr(&o));
    }
    let crossing = write(&d, "crossing.csg", &crossing_unions());
    let o = run(&["plan", &crossing, "--algo", "cst-i"]);
    assert!(o.status.success(), "{}", stderr(&o));
    for algo in ["goldfeather", "goldfeather-layered", "trickle"] {
        assert_error(
            &run(&["plan", &crossing, "--algo", algo]),
            &["sum-of-products form grows to at least"],
        );
    }
}

/// Rods along x intersected with rods along y (1,000 each).
fn crossing_unions() -> String {
    let rod = |axis: &str, k: usize| {
        let (dx, dy) = ((k % 40) as f64, (k / 40) as f64);
        match axis {
            "x" => format!("\t\tmultmatrix([[0, 0, 1, 0], [0, 1, 0, {dx}], [-1, 0, 0, {dy}], [0, 0, 0, 1]]) cylinder($fn = 8, h = 40, r1 = 0.3, r2 = 0.3);\n"),
            _ => format!("\t\tmultmatrix([[1, 0, 0, {dx}], [0, 0, 1, 0], [0, -1, 0, {dy}], [0, 0, 0, 1]]) cylinder($fn = 8, h = 40, r1 = 0.3, r2 = 0.3);\n"),
        }
    };
    let mut s = String::from("intersection() {\n\tunion() {\n");
    s.extend((0..1000).map(|k| rod("x", k)));
    s.push_str("\t}\n\tunion() {\n");
    s.extend((0..1000).map(|k| rod("y", k)));
    s.push_str("\t}\n}\n");
    s
}
