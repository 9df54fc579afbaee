//! Loader tests: every shipped scene loads, and each kind of user mistake gets an
//! error naming the file, the place, and the fix.

use super::load::{is_bounded, load, load_str, LoadOptions, SceneError};
use super::{Projection, Shape};
use crate::csg::{Expr, Node};
use std::path::{Path, PathBuf};

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

fn err(src: &str) -> String {
    match load_str(src, Path::new("/tmp/t/test.toml"), &LoadOptions::default()) {
        Ok(_) => panic!("expected an error for:\n{src}"),
        Err(e) => e.to_string(),
    }
}

const CAM: &str = "[camera]\neye = [3.0, 2.0, 4.0]\ntarget = [0.0, 0.0, 0.0]\n";
const BOX_A: &str = "[[primitive]]\nname = \"A\"\nshape = \"box\"\nsize = [1.0, 1.0, 1.0]\n";

fn with(extra: &str) -> String {
    format!("{CAM}{BOX_A}{extra}")
}

#[test]
fn every_shipped_scene_loads_and_is_framed() {
    let mut n = 0;
    for entry in std::fs::read_dir(scenes_dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("toml") {
            continue;
        }
        let before = std::fs::read(&path).unwrap();
        let s = load(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            std::fs::read(&path).unwrap(),
            before,
            "loading modified the file"
        );
        assert!(!s.solids.is_empty() || !s.surfaces.is_empty());
        assert!(
            s.warnings.is_empty(),
            "{}: {:?}",
            path.display(),
            s.warnings
        );
        let c = &s.camera;
        assert!(c.near > 0.0 && c.near < c.far, "{}", path.display());
        // Every drawn vertex lies between the planes and inside the view.
        let (w, h) = (s.render.width as f64, s.render.height as f64);
        let m = c.proj(w / h, Default::default()) * c.view();
        let drawn = s
            .primitives
            .iter()
            .filter(|p| p.used)
            .map(|p| &p.mesh)
            .chain(s.surfaces.iter().map(|s| &s.mesh));
        for mesh in drawn {
            for &p in &mesh.positions {
                let d = c.view_depth(p);
                assert!(d > c.near && d < c.far, "{}: depth {d}", path.display());
                let q = m * p.extend(1.0);
                let ndc = q.truncate() / q.w;
                assert!(ndc.x.abs() <= 1.0 + 1e-9 && ndc.y.abs() <= 1.0 + 1e-9);
            }
        }
        for p in s.primitives.iter().filter(|p| p.used) {
            assert!(
                p.mesh.signed_volume() > 0.0,
                "{}: {}",
                path.display(),
                p.name
            );
        }
        n += 1;
    }
    assert!(n >= 11, "only {n} scenes");
}

#[test]
fn shipped_scene_counts() {
    let count = |f: &str| {
        load(&scenes_dir().join(f), &LoadOptions::default())
            .unwrap()
            .primitives
            .len()
    };
    assert_eq!(count("complex.toml"), 20);
    assert_eq!(count("gear.toml"), 48);
    assert_eq!(count("many_50.toml"), 50);
    let s = load(&scenes_dir().join("assembly.toml"), &LoadOptions::default()).unwrap();
    assert_eq!(s.solids.len(), 2);
    let s = load(
        &scenes_dir().join("nonconvex_obj.toml"),
        &LoadOptions::default(),
    )
    .unwrap();
    assert!(matches!(s.primitives[0].shape, Shape::Mesh { .. }));
}

#[test]
fn defaults_and_size_override() {
    let src = with("color = \"#102030\"\n[csg]\nexpr = \"A\"\n");
    let s = load_str(&src, Path::new("x.toml"), &LoadOptions::default()).unwrap();
    assert_eq!((s.render.width, s.render.height), (800, 800));
    assert_eq!(s.render.background, [0x20, 0x20, 0x20]);
    assert_eq!(s.primitives[0].color, [0x10, 0x20, 0x30]);
    assert_eq!(
        s.camera.projection,
        Projection::Perspective { fov_y_deg: 35.0 }
    );
    assert_eq!(s.camera.up, glam::DVec3::Y);
    assert_eq!(s.solids[0].name, "csg");
    // fit depends on the final aspect ratio
    let src = src.replace(
        "target = [0.0, 0.0, 0.0]\n",
        "target = [0.0, 0.0, 0.0]\nfit = true\n",
    );
    let a = load_str(&src, Path::new("x.toml"), &LoadOptions::default()).unwrap();
    let b = load_str(
        &src,
        Path::new("x.toml"),
        &LoadOptions {
            size: Some((400, 800)),
        },
    )
    .unwrap();
    assert_eq!((b.render.width, b.render.height), (400, 800));
    assert!(b.camera.eye.length() > a.camera.eye.length() * 1.5);
    // scale as a number or a vector, a mirror keeps the volume positive
    let src = with("scale = -2\n[[primitive]]\nname = \"B\"\nshape = \"sphere\"\nradius = 1\nscale = [1, 2, 3]\n[csg]\nexpr = \"A B\"\n");
    let s = load_str(&src, Path::new("x.toml"), &LoadOptions::default()).unwrap();
    assert!((s.primitives[0].mesh.signed_volume() - 8.0).abs() < 1e-9);
    assert!(matches!(
        s.primitives[1].shape,
        Shape::Sphere {
            segments: 48,
            rings: 24,
            ..
        }
    ));
}

#[test]
fn unused_primitive_warns() {
    let src = with(
        "[[primitive]]\nname = \"B\"\nshape = \"box\"\nsize = [1, 1, 1]\n[csg]\nexpr = \"A\"\n",
    );
    let s = load_str(&src, Path::new("x.toml"), &LoadOptions::default()).unwrap();
    assert!(!s.primitives[1].used && s.primitives[0].used);
    assert_eq!(s.warnings.len(), 1);
    assert!(
        s.warnings[0].contains("\"B\" is not named"),
        "{:?}",
        s.warnings
    );
}

#[test]
fn syntax_and_type_errors_have_line_and_column() {
    let e = err(&with("[csg]\nexpr = \"A\"\ncolour = 3\n"));
    assert!(
        e.starts_with("/tmp/t/test.toml:10:1: unknown field `colour`"),
        "{e}"
    );
    let e = err(&with("radius = \"big\"\n[csg]\nexpr = \"A\"\n"));
    assert!(
        e.starts_with("/tmp/t/test.toml:8:10:") && e.contains("invalid type"),
        "{e}"
    );
    let e = err(&with("[csg\n"));
    assert!(e.starts_with("/tmp/t/test.toml:8:"), "{e}");
    let e = err(&with("color = \"red\"\n[csg]\nexpr = \"A\"\n"));
    assert!(e.contains("#rrggbb"), "{e}");
    let e = err(&with("shape = \"box\"\n"));
    assert!(e.contains("duplicate key"), "{e}");
    let e = err(&format!(
        "{CAM}[[primitive]]\nname = \"A\"\nshape = \"cube\"\n[csg]\nexpr = \"A\"\n"
    ));
    assert!(
        e.contains("unknown variant `cube`") && e.contains("`box`"),
        "{e}"
    );
    let e = err(&format!(
        "{CAM}[[primitive]]\nshape = \"box\"\nsize = [1, 1, 1]\n[csg]\nexpr = \"A\"\n"
    ));
    assert!(e.contains("missing field `name`"), "{e}");
    let e = err(&with("scale = [1, 2]\n[csg]\nexpr = \"A\"\n"));
    assert!(e.contains("exactly 3 numbers"), "{e}");
}

#[test]
fn value_errors_name_the_key_and_fix() {
    let cases: &[(&str, &str)] = &[
        (
            "[[primitive]]\nname = \"A\"\nshape = \"box\"\nsize = [1, 1, 1]\n[csg]\nexpr = \"A\"\n",
            "primitive[2] \"A\": name: \"A\" is already the name of primitive[1]",
        ),
        (
            "[[primitive]]\nname = \"2x\"\nshape = \"box\"\nsize = [1, 1, 1]\n[csg]\nexpr = \"A\"\n",
            "not a valid name",
        ),
        (
            "[[primitive]]\nname = \"B\"\nshape = \"sphere\"\nradius = 0.0\n[csg]\nexpr = \"A\"\n",
            "primitive[2] \"B\": radius: 0 must be a positive finite number",
        ),
        (
            "[[primitive]]\nname = \"B\"\nshape = \"sphere\"\nradius = nan\n[csg]\nexpr = \"A\"\n",
            "must be a positive finite number",
        ),
        (
            "[[primitive]]\nname = \"B\"\nshape = \"cylinder\"\nradius = 1.0\n[csg]\nexpr = \"A\"\n",
            "primitive[2] \"B\": height: missing: a cylinder needs `height`",
        ),
        (
            "[[primitive]]\nname = \"B\"\nshape = \"box\"\nradius = 1.0\nsize = [1, 1, 1]\n[csg]\nexpr = \"A\"\n",
            "`radius` does not apply to shape \"box\"",
        ),
        (
            "[[primitive]]\nname = \"B\"\nshape = \"box\"\nsize = [1, 0, 1]\n[csg]\nexpr = \"A\"\n",
            "every extent must be positive",
        ),
        (
            "[[primitive]]\nname = \"B\"\nshape = \"sphere\"\nradius = 1\nsegments = 2\n[csg]\nexpr = \"A\"\n",
            "segments: 2 is out of range: use 3 to",
        ),
        (
            "[[primitive]]\nname = \"B\"\nshape = \"torus\"\nradius = 1\nminor_radius = 0.2\nrings = 2\n[csg]\nexpr = \"A\"\n",
            "rings: 2 is out of range: a torus needs 3 to",
        ),
        (
            "[[primitive]]\nname = \"B\"\nshape = \"torus\"\nradius = 1\nminor_radius = 1.5\n[csg]\nexpr = \"A\"\n",
            "must be less than radius",
        ),
        (
            "[[primitive]]\nname = \"B\"\nshape = \"box\"\nsize = [1, 1, 1]\nscale = [1, 0, 1]\n[csg]\nexpr = \"A\"\n",
            "scale: [1, 0, 1] has a zero component",
        ),
        (
            "[[primitive]]\nname = \"B\"\nshape = \"box\"\nsize = [1, 1, 1]\ntrim = \"A\"\n[csg]\nexpr = \"A\"\n",
            "`trim` applies only to a [[surface]]",
        ),
        ("[csg]\nexpr = \"A + Q\"\n", "csg: expr: unknown primitive 'Q'"),
        ("[csg]\nexpr = \"!A\"\n", "is unbounded"),
        ("[csg]\nexpr = \"A\"\n[[solid]]\nname = \"s\"\nexpr = \"A\"\n", "cannot be used together"),
        ("", "nothing to draw"),
        (
            "[[solid]]\nname = \"s\"\nexpr = \"A\"\n[[solid]]\nname = \"s\"\nexpr = \"A\"\n",
            "solid[2] \"s\": name",
        ),
        (
            "[[primitive]]\nname = \"M\"\nshape = \"mesh\"\npath = \"nope.obj\"\n[csg]\nexpr = \"M\"\n",
            "primitive[2] \"M\": path: cannot read /tmp/t/nope.obj",
        ),
        (
            "[[surface]]\nname = \"S\"\nshape = \"sphere\"\nradius = 1\n",
            "surface[1] \"S\": trim: missing `trim`",
        ),
        ("[render]\nwidth = 0\n[csg]\nexpr = \"A\"\n", "render: width: 0 is out of range"),
    ];
    for (extra, want) in cases {
        let e = err(&with(extra));
        assert!(e.starts_with("/tmp/t/test.toml"), "{e}");
        assert!(e.contains(want), "want {want:?} in:\n{e}");
    }
    // the expression error shows the caret under the column
    let e = err(&with("[csg]\nexpr = \"A + Q\"\n"));
    assert!(e.contains("    A + Q\n        ^\n"), "{e}");
    assert!(e.contains("hint: define it with [[primitive]]"), "{e}");
}

#[test]
fn camera_errors() {
    let body = format!("{BOX_A}[csg]\nexpr = \"A\"\n");
    let cases: &[(&str, &str)] = &[
        (
            "eye = [1, 1, 1]\ntarget = [1, 1, 1]\n",
            "camera: eye: eye and target are the same point",
        ),
        (
            "eye = [0, 3, 0]\n",
            "camera: up: up = [0, 1, 0] is parallel",
        ),
        ("eye = [0, 0, 3]\nfov_y_deg = 180\n", "camera: fov_y_deg"),
        (
            "eye = [0, 0, 3]\nprojection = \"orthographic\"\n",
            "camera: ortho_height: missing",
        ),
        (
            "eye = [0, 0, 3]\nnear = 0.0\n",
            "camera: near: 0 must be a positive finite number",
        ),
        (
            "eye = [0, 0, 3]\nnear = 5.0\nfar = 1.0\n",
            "near = 5 must be less than far = 1",
        ),
        ("target = [0, 0, 0]\n", "camera: eye: missing"),
    ];
    for (cam, want) in cases {
        let e = err(&format!("[camera]\n{cam}{body}"));
        assert!(e.contains(want), "want {want:?} in:\n{e}");
    }
    // no [camera]: framed from a default direction
    let s = load_str(&body, Path::new("x.toml"), &LoadOptions::default()).unwrap();
    assert!(s.camera.target.length() < 1e-12 && s.camera.near > 0.0);
    // explicit near/far are kept
    let s = load_str(
        &format!("[camera]\neye = [0, 0, 5]\nnear = 0.5\nfar = 50\n{body}"),
        Path::new("x.toml"),
        &LoadOptions::default(),
    )
    .unwrap();
    assert_eq!((s.camera.near, s.camera.far), (0.5, 50.0));
}

fn tmp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("peeltrim_scene_{tag}_{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn mesh_errors_name_the_edge() {
    let d = tmp_dir("mesh");
    let cube = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
    let faces = [
        "f 1 4 3 2",
        "f 5 6 7 8",
        "f 1 2 6 5",
        "f 3 4 8 7",
        "f 2 3 7 6",
        "f 1 5 8 4",
    ];
    let write = |name: &str, faces: &[&str]| {
        std::fs::write(d.join(name), format!("{cube}{}\n", faces.join("\n"))).unwrap();
    };
    write("good.obj", &faces);
    write("open.obj", &faces[..5]);
    let mut flipped = faces.to_vec();
    flipped[0] = "f 1 2 3 4";
    write("flipped.obj", &flipped);
    let inside: Vec<String> = faces
        .iter()
        .map(|f| {
            let mut v: Vec<&str> = f.split(' ').collect();
            v[1..].reverse();
            v.join(" ")
        })
        .collect();
    write(
        "inside.obj",
        &inside.iter().map(|s| s.as_str()).collect::<Vec<_>>(),
    );
    std::fs::write(d.join("empty.obj"), cube).unwrap();
    let scene = |obj: &str| {
        format!("{CAM}[[primitive]]\nname = \"M\"\nshape = \"mesh\"\npath = \"{obj}\"\n[csg]\nexpr = \"M\"\n")
    };
    let run = |obj: &str| load_str(&scene(obj), &d.join("s.toml"), &LoadOptions::default());
    let s = run("good.obj").unwrap();
    assert!((s.primitives[0].mesh.signed_volume() - 1.0).abs() < 1e-12);
    let e = run("open.obj").unwrap_err().to_string();
    assert!(
        e.contains("primitive[1] \"M\": path")
            && e.contains("edge v")
            && e.contains("reverse by none"),
        "{e}"
    );
    let e = run("flipped.obj").unwrap_err().to_string();
    assert!(e.contains("same direction"), "{e}");
    let e = run("inside.obj").unwrap_err().to_string();
    assert!(e.contains("inside out"), "{e}");
    let e = run("empty.obj").unwrap_err().to_string();
    assert!(e.contains("no faces"), "{e}");
    // an open mesh is fine as a surface, or when no expression uses it
    let src = format!("{CAM}{BOX_A}[[surface]]\nname = \"S\"\nshape = \"mesh\"\npath = \"open.obj\"\ntrim = \"A\"\n");
    assert!(load_str(&src, &d.join("s.toml"), &LoadOptions::default()).is_ok());
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn read_error_names_the_file() {
    let e = load(
        Path::new("/nonexistent/scene.toml"),
        &LoadOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, SceneError::Read { .. }));
    assert!(e
        .to_string()
        .starts_with("/nonexistent/scene.toml: cannot read"));
}

#[test]
fn boundedness() {
    let leaf = |p| Node::Leaf { prim: p };
    let cases = [
        (vec![leaf(0), Node::Not(0)], 1, false),
        (
            vec![leaf(0), Node::Not(0), leaf(1), Node::Union(1, 2)],
            3,
            false,
        ),
        (
            vec![leaf(0), Node::Not(0), leaf(1), Node::Inter(1, 2)],
            3,
            true,
        ),
        (vec![leaf(0), leaf(1), Node::Diff(0, 1)], 2, true),
        (
            vec![leaf(0), Node::Not(0), leaf(1), Node::Diff(1, 2)],
            3,
            false,
        ),
        (vec![leaf(0), Node::Not(0), Node::Not(1)], 2, true),
        // !(!A + !B) = A B
        (
            vec![
                leaf(0),
                Node::Not(0),
                leaf(1),
                Node::Not(2),
                Node::Union(1, 3),
                Node::Not(4),
            ],
            5,
            true,
        ),
    ];
    for (nodes, root, want) in cases {
        let e = Expr { nodes, root };
        assert_eq!(is_bounded(&e), want, "{e:?}");
    }
}

/// Messages a user meets often: each names the place (file, line, key) and the fix.
#[test]
fn common_mistakes_name_the_place_and_the_fix() {
    for (extra, needles) in [
        (
            "[[primitive]]\nname = \"B\"\nshape = \"sphere\"\nradius = 0.0\n[csg]\nexpr = \"A\"\n",
            &[
                "test.toml:8: primitive[2] \"B\": radius",
                "must be a positive finite number",
            ][..],
        ),
        (
            "[csg]\nexpr = \"A + Q\"\n",
            &["test.toml:8: csg: expr", "Q"][..],
        ),
        (
            "[csg]\nexpr = \"A\"\ncolour = 3\n",
            &["test.toml:10:1", "unknown field `colour`", "expr"][..],
        ),
        (
            "[csg]\nexpr = \"!A + A\"\n",
            &["test.toml:8: csg: expr", "unbounded", "e.g. `B !A`"][..],
        ),
    ] {
        let e = err(&with(extra));
        for n in needles {
            assert!(e.contains(n), "missing {n:?} in:\n{e}");
        }
    }
}

const BAD_VECTORS: [(&str, &str); 8] = [
    (
        "[1.0, 1.0, 1.0, 4.0]",
        "has 4 elements: write exactly 3 numbers",
    ),
    ("[1.0, 1.0]", "has 2 elements: write exactly 3 numbers"),
    ("[]", "has 0 elements"),
    ("[1.0, 1.0, 1.0, \"x\"]", "has 4 elements"),
    (
        "[0.5, \"x\", 1.0]",
        "element 2 is the string \"x\", not a number",
    ),
    (
        "[0.5, 1.0, true]",
        "element 3 is the boolean true, not a number",
    ),
    (
        "\"1 2 3\"",
        "found the string \"1 2 3\": write an array of 3 numbers",
    ),
    ("{ x = 1.0 }", "found a table"),
];

/// Every fixed-length vector of a primitive or surface rejects a wrong length or
/// element type, naming the file, the line of the key, the key path and the fix.
#[test]
fn shape_vectors_reject_wrong_length_and_type() {
    for key in ["size", "rotate_deg", "translate", "scale"] {
        for (value, needle) in BAD_VECTORS {
            for table in ["primitive", "surface"] {
                let src = format!(
                    "{CAM}[[{table}]]\nname = \"A\"\nshape = \"box\"\n{}{key} = {value}\ntrim = \"A\"\n",
                    if key == "size" { "" } else { "size = [1.0, 1.0, 1.0]\n" }
                );
                let (src, shift) = if table == "primitive" {
                    (src.replace("trim = \"A\"\n", "[csg]\nexpr = \"A\"\n"), 0)
                } else {
                    let p =
                        "[[primitive]]\nname = \"P\"\nshape = \"box\"\nsize = [1.0, 1.0, 1.0]\n";
                    (
                        src.replacen("[[surface]]", &format!("{p}[[surface]]"), 1)
                            .replace("trim = \"A\"", "trim = \"P\""),
                        4,
                    )
                };
                let line = shift + if key == "size" { 7 } else { 8 };
                let e = err(&src);
                let want = format!("test.toml:{line}: {table}[1] \"A\": {key}: ");
                assert!(
                    e.starts_with("/tmp/t/") && e.contains(&want),
                    "{key} = {value}: {e}"
                );
                if key == "scale" && !value.starts_with('[') {
                    assert!(e.contains("a number or an array of 3 numbers"), "{e}");
                } else {
                    assert!(e.contains(needle), "{key} = {value}: {e}");
                }
                assert!(e.contains("e.g."), "{e}");
            }
        }
    }
}

#[test]
fn camera_vectors_reject_wrong_length_and_type() {
    for key in ["eye", "target", "up"] {
        for (value, needle) in BAD_VECTORS {
            let mut cam = vec![
                ("eye", "[3.0, 2.0, 4.0]"),
                ("target", "[0.0, 0.0, 0.0]"),
                ("up", "[0.0, 1.0, 0.0]"),
            ];
            cam.iter_mut().find(|(k, _)| *k == key).unwrap().1 = value;
            let cam: String = cam.iter().map(|(k, v)| format!("{k} = {v}\n")).collect();
            let src = format!("[camera]\n{cam}{BOX_A}[csg]\nexpr = \"A\"\n");
            let line = 2 + ["eye", "target", "up"]
                .iter()
                .position(|k| *k == key)
                .unwrap();
            let e = err(&src);
            let want = format!("test.toml:{line}: camera: {key}: ");
            assert!(e.contains(&want), "{key} = {value}: {e}");
            assert!(e.contains(needle), "{key} = {value}: {e}");
        }
    }
}

/// Integers are numbers; `scale` may be one number.
#[test]
fn vectors_accept_integers_and_a_scalar_scale() {
    let src = "[camera]\neye = [3, 2, 4]\nup = [0, 1, 0]\n[[primitive]]\nname = \"A\"\nshape = \"box\"\n\
               size = [1, 2, 1]\nscale = 2\nrotate_deg = [0, 90, 0]\ntranslate = [1, 0, 0]\n[csg]\nexpr = \"A\"\n";
    let s = load_str(src, Path::new("/tmp/t/test.toml"), &LoadOptions::default()).unwrap();
    assert_eq!(s.camera.eye, glam::DVec3::new(3.0, 2.0, 4.0));
    assert_eq!(
        s.primitives[0].shape,
        Shape::Box {
            size: glam::DVec3::new(1.0, 2.0, 1.0)
        }
    );
    let b = s.primitives[0].mesh.aabb().unwrap();
    // 1 x 2 x 1 scaled by 2, turned 90° about y, moved +1 in x.
    assert!(
        (b.max - glam::DVec3::new(2.0, 2.0, 1.0)).length() < 1e-9,
        "{b:?}"
    );
}

/// Colours are `"#rrggbb"` strings: a wrong type or form is located and explained.
#[test]
fn colours_reject_wrong_form_and_type() {
    for (key, table_src) in [
        ("color", format!("{CAM}{BOX_A}color = VALUE\n[csg]\nexpr = \"A\"\n")),
        (
            "background",
            format!("{CAM}{BOX_A}[render]\nbackground = VALUE\n[csg]\nexpr = \"A\"\n"),
        ),
        (
            "paint_color",
            format!("{CAM}[[surface]]\nname = \"A\"\nshape = \"box\"\nsize = [1.0, 1.0, 1.0]\ntrim = \"A\"\nkeep = \"paint\"\npaint_color = VALUE\n"),
        ),
    ] {
        for (value, needle) in [
            ("\"#12345\"", "six hexadecimal digits"),
            ("\"d0a040\"", "six hexadecimal digits"),
            ("\"#gg0000\"", "six hexadecimal digits"),
            ("[208, 160, 64]", "expected a string"),
            ("5", "expected a string"),
        ] {
            let e = err(&table_src.replace("VALUE", value));
            assert!(e.contains("test.toml:") && e.contains(needle), "{key} = {value}: {e}");
            assert!(e.contains(&format!("{key} = {value}")), "snippet shows the key: {e}");
        }
    }
}
