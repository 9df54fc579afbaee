//! Evaluated 2D outlines (`offset`, 2D `hull`/`minkowski`), `text`, `import`
//! of 2D files and 2D models drawn as plates, checked against OpenSCAD
//! 2021.01's own outputs (vertices from its SVG export) and fuzzed.

use glam::DVec2;

use super::tests::{closed_outward, err, model, star_points};
use super::Model;

/// The top cap's vertices (z = 0.5) of a 2D model's plate, sorted.
fn plate_top(m: &Model) -> Vec<DVec2> {
    let mut v: Vec<DVec2> = m
        .primitives
        .iter()
        .flat_map(|p| p.mesh.positions.iter())
        .filter(|p| p.z > 0.0)
        .map(|p| p.truncate())
        .collect();
    v.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    v.dedup();
    v
}

/// The outline points of an OpenSCAD SVG export (`M x,y L x,y ...`, y down).
fn svg_points(d: &str) -> Vec<DVec2> {
    let mut v: Vec<DVec2> = d
        .split(['M', 'L', 'z'])
        .filter_map(|p| {
            let (x, y) = p.trim().split_once(',')?;
            Some(DVec2::new(
                x.trim().parse().ok()?,
                -y.trim().parse::<f64>().ok()?,
            ))
        })
        .collect();
    v.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    v
}

fn same_points(got: &[DVec2], want: &[DVec2], tol: f64) {
    assert_eq!(got.len(), want.len(), "got {got:?}\nwant {want:?}");
    for w in want {
        assert!(
            got.iter().any(|g| g.distance(*w) <= tol),
            "{w} missing from {got:?}"
        );
    }
}

#[test]
fn offsets_match_openscad_vertex_for_vertex() {
    let poly = "polygon(points = [[0, 0], [10, 0], [10, 10], [5, 4], [0, 10]], paths = undef, convexity = 1);";
    // `openscad -o x.svg` of the same offsets (OpenSCAD 2021.01).
    let cases = [
        ("offset(r = 1.5, $fn = 12, $fa = 12, $fs = 2)", "M 10.75,1.29904 L 11.299,0.75 L 11.5,-0 L 11.5,-10 L 11.299,-10.75 L 10.75,-11.299 L 10,-11.5 L 9.25,-11.299 L 8.84767,-10.9603 L 5,-6.34308 L 1.15233,-10.9603 L 0.517807,-11.4078 L -0.255463,-11.4781 L -0.960281,-11.1523 L -1.40779,-10.5178 L -1.5,-10 L -1.5,-0 L -1.29904,0.75 L -0.75,1.29904 L 0,1.5 L 10,1.5 z"),
        ("offset(r = -1, $fn = 12, $fa = 12, $fs = 2)", "M 9,-7.23796 L 5.76822,-3.35982 L 5.3452,-3.06148 L 4.8297,-3.0146 L 4.23178,-3.35982 L 1,-7.23796 L 1,-1 L 9,-1 z"),
        ("offset(delta = 1, chamfer = true, $fn = 0, $fa = 12, $fs = 2)", "M 11,0.414215 L 11,-10.7015 L 9.68085,-11.1791 L 5,-5.56204 L 0.319153,-11.1791 L -1,-10.7015 L -1,0.414215 L -0.414215,1 L 10.4142,1 z"),
    ];
    for (op, svg) in cases {
        let m = model(&format!("{op} {{\n\t{poly}\n}}\n"));
        assert!(m.warnings.iter().any(|w| w.contains("plate 1 unit thick")));
        for p in &m.primitives {
            closed_outward(&p.mesh);
        }
        same_points(&plate_top(&m), &svg_points(svg), 1e-4);
    }
}

#[test]
fn text_matches_openscad() {
    // `text("H", size = 10)` and "Ho" centred, as OpenSCAD 2021.01 draws them
    // with Liberation Sans (its SVG export).
    let m = model("text(text = \"H\", size = 10, spacing = 1, font = \"\", direction = \"ltr\", language = \"en\", script = \"Latn\", halign = \"left\", valign = \"baseline\", $fn = 0, $fa = 12, $fs = 2);");
    let h = "M 2.43449,-4.42819 L 7.60179,-4.42819 L 7.60179,-0 L 8.89699,-0 L 8.89699,-9.55479 L 7.60179,-9.55479 L 7.60179,-5.5132 L 2.43449,-5.5132 L 2.43449,-9.55479 L 1.1393,-9.55479 L 1.1393,-0 L 2.43449,-0 z";
    same_points(&plate_top(&m), &svg_points(h), 1e-3);
    let m = model("linear_extrude(height = 2) text(text = \"Ho\", size = 10, halign = \"center\", valign = \"center\");");
    let top: Vec<DVec2> = plate_top(&m);
    let min_x = top.iter().map(|p| p.x).fold(f64::MAX, f64::min);
    let max_y = top.iter().map(|p| p.y).fold(f64::MIN, f64::max);
    // OpenSCAD: H's stem at x = −7.52983, its top at y = 4.95792.
    assert!((min_x + 7.52983).abs() < 1e-3, "{min_x}");
    assert!((max_y - 4.95792).abs() < 5e-3, "{max_y}");
    for p in &m.primitives {
        closed_outward(&p.mesh);
    }
    // Bitstream Vera Sans: DejaVu Sans, as fontconfig maps it on Debian
    // (OpenSCAD's SVG export of the same text; FreeType's hinting of DejaVu's
    // instructions moves OpenSCAD's points by up to 0.003).
    let m = model("text(text = \"H\", size = 10, font = \"Bitstream Vera Sans\");");
    let h = "M 2.73279,-4.8192 L 7.7103,-4.8192 L 7.7103,-0 L 9.08009,-0 L 9.08009,-10.1248 L 7.7103,-10.1248 L 7.7103,-5.97119 L 2.73279,-5.97119 L 2.73279,-10.1248 L 1.36299,-10.1248 L 1.36299,-0 L 2.73279,-0 z";
    same_points(&plate_top(&m), &svg_points(h), 4e-3);
    assert!(
        !m.warnings.iter().any(|w| w.contains("Vera")),
        "{:?}",
        m.warnings
    );
    // An unknown font: a warning, Liberation Sans.
    let m = model(
        "linear_extrude(height = 1) text(text = \"a\", font = \"Comic Sans MS:style=Bold\");",
    );
    assert!(
        m.warnings
            .iter()
            .any(|w| w.contains("Comic Sans MS") && w.contains("Liberation Sans")),
        "{:?}",
        m.warnings
    );
}

#[test]
fn hull_and_minkowski_in_an_extrusion() {
    let m = model("linear_extrude(height = 2) hull() { square(size = 2); multmatrix([[1, 0, 0, 10], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) square(size = 2); }");
    assert_eq!(m.primitives.len(), 1);
    assert!((crate::scene::validate::signed_volume(&m.primitives[0].mesh) - 48.0).abs() < 1e-9);
    // A non-convex outline ⊕ a square: an L of two 2 × 6 bars grown by 1.
    let m = model("linear_extrude(height = 1) minkowski() { polygon(points = [[0, 0], [6, 0], [6, 2], [2, 2], [2, 6], [0, 6]]); square(size = 2, center = true); }");
    let v = crate::scene::validate::signed_volume(&m.primitives[0].mesh);
    assert!((v - (64.0 - 16.0)).abs() < 1e-6, "{v}");
    // The offset of a transformed child is taken in the offset's own frame.
    let m = model("linear_extrude(height = 1) multmatrix([[2, 0, 0, 0], [0, 2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]) offset(delta = 1) square(size = 1);");
    let v = crate::scene::validate::signed_volume(&m.primitives[0].mesh);
    assert!((v - 36.0).abs() < 1e-6, "{v}");
    // Hull and minkowski of 3D children are 3D: a cube's hull is the cube.
    let m = model("hull() { cube(size = 1); }");
    let v = crate::scene::validate::signed_volume(&m.primitives[0].mesh);
    assert!((v - 1.0).abs() < 1e-12, "{v}");
}

#[test]
fn hostile_outlines_are_a_located_error_or_a_render() {
    for (src, at, want) in [
        (
            "linear_extrude(height = 1) offset(r = 1, $fn = 1e9) square();",
            "offset",
            "fragments",
        ),
        (
            "linear_extrude(height = 1) offset(r = 1e300) square();",
            "offset",
            "beyond",
        ),
        (
            "linear_extrude(height = 1) offset(delta = 1e300) square();",
            "offset",
            "beyond",
        ),
        (
            "linear_extrude(height = 1) text(text = \"a\", size = 1e300);",
            "text",
            "beyond",
        ),
        (
            "linear_extrude(height = 1) text(text = \"ab\", spacing = 1e300);",
            "text",
            "beyond",
        ),
        (
            "linear_extrude(height = 1) text(text = 3);",
            "3",
            "must be a string",
        ),
        (
            "linear_extrude(height = 1) text(text = \"a\", font = 7);",
            "7",
            "must be a string",
        ),
        ("text(text = \"a\", $fn = 1e9);", "text", "fragments"),
    ] {
        let e = err(src);
        let at = format!("t.csg:1:{}:", src.find(at).unwrap() + 1);
        assert!(e.starts_with(&at) && e.contains(want), "{src}: {e}");
    }
    // `nan` and `inf` are undef to OpenSCAD: `offset` takes its default, a
    // round offset by 1 (a unit square grows to about 1 + 4 + π).
    for src in [
        "linear_extrude(height = 1) offset(r = nan) square();",
        "linear_extrude(height = 1) offset(delta = inf) square();",
    ] {
        let m = model(src);
        let plain = model("linear_extrude(height = 1) offset(r = 1) square();");
        let v = crate::scene::validate::signed_volume(&m.primitives[0].mesh);
        let w = crate::scene::validate::signed_volume(&plain.primitives[0].mesh);
        assert!((v - w).abs() < 1e-9 && v > 5.0, "{src}: {v} against {w}");
    }
    // So does `text`'s `size`: 10.
    let m = model("linear_extrude(height = 1) text(text = \"a\", size = nan);");
    let plain = model("linear_extrude(height = 1) text(text = \"a\", size = 10);");
    assert_eq!(
        m.primitives[0].mesh.positions,
        plain.primitives[0].mesh.positions
    );
    // Degenerate outlines are the empty set.
    for src in [
        "linear_extrude(height = 1) offset(r = -6) square(size = 10);",
        "linear_extrude(height = 1) offset(delta = 1) polygon(points = [[0, 0], [1, 1], [2, 2]]);",
        "linear_extrude(height = 1) hull() { polygon(points = [[0, 0], [1, 1], [2, 2]]); }",
        "linear_extrude(height = 1) hull();",
        "linear_extrude(height = 1) minkowski() { circle(r = 0); square(); }",
        "linear_extrude(height = 1) text(text = \"\");",
        "linear_extrude(height = 1) text(text = \"   \");",
        "linear_extrude(height = 1) text(text = \"a\", size = 1e-300);",
        "linear_extrude(height = 1) text(text = \"a\", size = -1);",
    ] {
        let e = err(src);
        assert!(e.contains("no solid"), "{src}: {e}");
    }
    // 10^5 points: hull and offset of a star, in bounded time; a tangle of
    // them offset (self-crossing); too many Minkowski pairs refused.
    let n = 100_000;
    let pts = star_points(n);
    let star = format!("polygon(points = [{}]);", pts.join(", "));
    let t = std::time::Instant::now();
    for op in ["hull()", "offset(delta = 0.001)"] {
        let m = model(&format!("linear_extrude(height = 1) {op} {{ {star} }}"));
        closed_outward(&m.primitives[0].mesh);
    }
    assert!(t.elapsed().as_secs() < 120, "{:?}", t.elapsed());
    // An offset far wider than the edges would cross itself 10^10 times.
    let e = err(&format!(
        "linear_extrude(height = 1) offset(r = 5) {{ {star} }}"
    ));
    assert!(
        e.contains("crossings") && e.starts_with("t.csg:1:28:"),
        "{e}"
    );
    // (Crossings grow with the square of a tangle's size: 300 points.)
    let tangled: Vec<String> = (0..300).map(|i| pts[(i * 7919) % n].clone()).collect();
    let tangle = format!("polygon(points = [{}]);", tangled.join(", "));
    for op in [
        "offset(r = 0.3)",
        "offset(delta = -0.3, chamfer = true)",
        "hull()",
    ] {
        super::tests::check_outcome(&format!("linear_extrude(height = 1) {op} {{ {tangle} }}"));
    }
    let big: Vec<String> = (0..2000).map(|i| pts[(i * 7919) % n].clone()).collect();
    let big = format!("polygon(points = [{}]);", big.join(", "));
    let e = err(&format!(
        "linear_extrude(height = 1) minkowski() {{ {big} {big} }}"
    ));
    assert!(e.contains("at most 1000000"), "{e}");
    // A long text is refused before any glyph is drawn.
    let e = err(&format!(
        "linear_extrude(height = 1) text(text = \"{}\");",
        "x".repeat(100_000)
    ));
    assert!(e.contains("at most 10000"), "{e}");
}

/// Mutations of a valid 2D export: a model or a located error, never a panic.
const VALID_2D: &str = "linear_extrude(height = 2, center = false, convexity = 1, scale = [1, 1], $fn = 0, $fa = 12, $fs = 2) {\n\toffset(r = 1, $fn = 0, $fa = 12, $fs = 2) {\n\t\thull() {\n\t\t\tsquare(size = [4, 2], center = false);\n\t\t\tcircle($fn = 8, r = 1);\n\t\t}\n\t}\n\tminkowski() {\n\t\ttext(text = \"Ab\", size = 3, halign = \"center\");\n\t\tcircle($fn = 4, r = 0.2);\n\t}\n\toffset(delta = -0.5, chamfer = true) polygon(points = [[0, 0], [9, 0], [0, 9], [9, 9]]);\n}\n";

const PIECES_2D: &[&str] = &[
    "offset(",
    "hull()",
    "minkowski()",
    "text(",
    "square(",
    "circle(",
    "polygon(",
    "r = ",
    "delta = ",
    "chamfer = true",
    "size = ",
    "\"x\"",
    "1e300",
    "-1e300",
    "nan",
    "inf",
    "0",
    "-1",
    "1e-300",
    "[",
    "]",
    "(",
    ")",
    "{",
    "}",
    ";",
    ",",
    "$fn = ",
    "1e9",
    "points = ",
    "[[0, 0], [1, 0], [0, 1]]",
];

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 300, failure_persistence: None, ..proptest::prelude::ProptestConfig::default() })]

    #[test]
    fn fuzz_mutated_2d_export(a in 0..VALID_2D.len(), len in 0usize..20, pieces in proptest::collection::vec(0..PIECES_2D.len(), 0..4)) {
        let mut end = (a + len).min(VALID_2D.len());
        while !VALID_2D.is_char_boundary(end) { end -= 1; }
        let ins: String = pieces.iter().map(|&i| PIECES_2D[i]).collect();
        super::tests::check_outcome(&format!("{}{}{}", &VALID_2D[..a], ins, &VALID_2D[end..]));
    }
}

#[test]
fn holes_touching_the_outline_at_a_vertex_extrude() {
    // A triangular hole whose corner lies on the square's left edge (given
    // as a vertex of both, and as an evaluated outline).
    for (src, area) in [
        ("polygon(points = [[0, 0], [10, 0], [10, 10], [0, 10], [0, 5], [3, 7], [3, 3]], paths = [[0, 1, 2, 3, 4], [4, 5, 6]]);", 94.0),
        ("offset(delta = 0) difference() { square(size = 10); polygon(points = [[0, 2], [3, 5], [0, 8]]); }", 91.0),
    ] {
        let m = model(&format!("linear_extrude(height = 2) {src}"));
        let v: f64 = m
            .primitives
            .iter()
            .map(|p| {
                closed_outward(&p.mesh);
                crate::scene::validate::signed_volume(&p.mesh)
            })
            .sum();
        assert!((v - 2.0 * area).abs() < 1e-9, "{src}: {v}");
    }
}
