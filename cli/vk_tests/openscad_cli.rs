//! OpenSCAD `.csg` models through the command line: every subcommand accepts
//! one, a TOML scene may name one, and every bad model (unsupported node, bad
//! syntax, open polyhedron) exits non-zero with `file:line:col`.

use std::path::PathBuf;

use super::scad_models::plate_with_holes;
use super::{assert_error, run, stderr, tmp};

fn model(name: &str) -> String {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
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
        "group() {\n  projection() { cube(size = 1); }\n  sphere(r = 1);\n}\n",
    );
    let strict = write(&d, "strict.toml", "[csg]\nopenscad = \"hull.csg\"\n");
    assert_error(
        &run(&["blist", &strict]),
        &[
            "hull.csg:2:3:",
            "`projection` (it needs the 3D boundary) is not supported",
        ],
    );
    let skip = write(
        &d,
        "skip.toml",
        "[csg]\nopenscad = \"hull.csg\"\nskip_unsupported = true\n",
    );
    let o = run(&["blist", &skip]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "hull.csg:2:3: `projection` (it needs the 3D boundary) is not supported and was dropped"
        ),
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
        ("hull() { difference() { cube(size = 1); sphere(r = 1); } }", &["x.csg:2:12:", "`difference` inside `hull` (line 2)", "not supported", "--skip-unsupported"]),
        ("minkowski() { intersection() { cube(size = 1); sphere(r = 1); } }", &["x.csg:2:17:", "`intersection` inside `minkowski`"]),
        ("linear_extrude(height = 1) import(file = \"a.txt\");", &["x.csg:2:", "DXF or SVG"]),
        ("projection() { cube(size = 1); }", &["x.csg:2:3:", "`projection`"]),
        ("cube(size = [1, 2 3]);", &["x.csg:2:21:", "expected `,` or `]`"]),
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
        "group() {\n  projection() { cube(size = 1); }\n  cube(size = 1);\n}\n",
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
        stderr(&o).contains(
            "skip.csg:2:3: `projection` (it needs the 3D boundary) is not supported and was dropped"
        ),
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

/// `%` parts: see-through grey solids of their own with the algorithms that
/// composite layers (the reference and CST agree on the composite), left out
/// with a warning by the others.
#[test]
fn background_parts_are_drawn_see_through_where_layers_are() {
    let d = tmp("scad-background");
    let m = write(
        &d,
        "bg.csg",
        "sphere($fn = 24, r = 10);\n\
         %multmatrix([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 8], [0, 0, 0, 1]]) cube(size = [30, 4, 4], center = true);\n",
    );
    let render = |algo: &str| {
        let out = d.join(algo);
        let o = run(&[
            "render",
            &m,
            "--algo",
            algo,
            "--size",
            "64x64",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{algo}: {}", stderr(&o));
        let images = peeltrim_cli::output::read_images(&out).unwrap_or_else(|e| panic!("{e}"));
        (images.prim, images.color, stderr(&o))
    };
    // Opaque algorithm: the part is left out, and the warning says who draws it.
    let (prim_o, color_o, err) = render("blister");
    assert!(prim_o.iter().all(|&p| p <= 1), "only the sphere");
    assert!(
        err.contains("bg.csg:2:2: `%multmatrix` (background) is left out") && err.contains("cst-i"),
        "{err}"
    );
    let (prim_r, color_r, err) = render("reference");
    assert!(!err.contains("left out"), "{err}");
    // The bar is in front of the sphere's top and reaches past it on both sides.
    let bar = (0..prim_r.len())
        .filter(|&i| prim_r[i] == 2)
        .collect::<Vec<_>>();
    let over_sphere = bar.iter().filter(|&&i| prim_o[i] == 1).count();
    let over_background = bar.iter().filter(|&&i| prim_o[i] == 0).count();
    assert!(
        over_sphere > 20 && over_background > 20,
        "{over_sphere} {over_background}"
    );
    // See-through: where the bar is, the colour is neither what lies behind it
    // nor an opaque grey; over the background it is a blend with #ffffe5.
    for &i in &bar {
        assert_ne!(
            color_r[i], color_o[i],
            "pixel {i}: the bar changes the colour"
        );
    }
    for &i in bar.iter().filter(|&&i| prim_o[i] == 0) {
        let c = color_r[i];
        // Grey (r = g = b) blended at 128/255 over #ffffe5: blue below red.
        assert!(c[0] > c[2] && c[0] >= 0x80, "pixel {i}: {c:?}");
    }
    // CST composites the same layers as the reference.
    let (prim_c, color_c, _) = render("cst-i");
    let n = prim_r.len();
    let off = (0..n)
        .filter(|&i| (0..3).any(|k| color_c[i][k].abs_diff(color_r[i][k]) > 2))
        .count();
    let prim_off = (0..n).filter(|&i| prim_c[i] != prim_r[i]).count();
    assert!(
        off * 100 <= 2 * n,
        "{off} of {n} pixels differ by more than 2/255"
    );
    assert!(
        prim_off * 100 <= 2 * n,
        "{prim_off} of {n} pixels name another primitive"
    );
}

/// Every unsupported node of a model is reported at once, in file order with
/// its line; with --skip-unsupported the warnings come in file order too.
#[test]
fn every_unsupported_node_is_reported_in_file_order() {
    let d = tmp("scad-unsupported-all");
    let f = write(
        &d,
        "many.csg",
        "group() {\n  projection() { cube(size = 1); }\n  group() {\n    projection() { sphere(r = 1); }\n  }\n  hull() { difference() { cube(size = 1); sphere(r = 1); } }\n  cube(size = 1);\n}\n",
    );
    let out = d.join("o");
    let o = run(&[
        "render",
        &f,
        "--size",
        "8x8",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_error(
        &o,
        &[
            "many.csg:2:3:",
            "3 nodes are not supported: `projection` (it needs the 3D boundary) (line 2), `projection` (it needs the 3D boundary) (line 4), `difference` inside `hull` (line 6)",
            "--skip-unsupported",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    let o = run(&[
        "render",
        &f,
        "--skip-unsupported",
        "--size",
        "8x8",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    let at = |s: &str| e.find(s).unwrap_or_else(|| panic!("{s} in {e}"));
    assert!(
        at("many.csg:2:3: `projection`") < at("many.csg:4:5: `projection`"),
        "{e}"
    );
    assert!(
        at("many.csg:4:5: `projection`") < at("many.csg:6:12: `difference`"),
        "{e}"
    );
}

/// The fitted camera frames a model's `%` (background) parts too: a part far
/// from the solid is in the picture of an algorithm that draws it.
#[test]
fn the_fitted_camera_holds_background_parts() {
    let d = tmp("scad-background-fit");
    let f = write(
        &d,
        "far.csg",
        "group() {\n  cube(size = 2);\n  %multmatrix([[1, 0, 0, 30], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) cube(size = 2);\n}\n",
    );
    let out = d.join("o");
    let o = run(&[
        "render",
        &f,
        "--algo",
        "reference",
        "--size",
        "64x64",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let images = peeltrim_cli::output::read_images(&out).unwrap_or_else(|e| panic!("{e}"));
    // Primitive 1 is the solid's cube, 2 the background part's.
    assert!(images.prim.iter().any(|&p| p == 1), "the solid is in view");
    assert!(images.prim.iter().any(|&p| p == 2), "the % part is in view");
}
