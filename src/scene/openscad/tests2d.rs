//! Evaluated 2D outlines (`offset`, 2D `hull`/`minkowski`), `text`, `import`
//! of 2D files and 2D models drawn as plates, checked against OpenSCAD
//! 2021.01's own outputs (vertices from its SVG export) and fuzzed.

use glam::DVec2;

use super::tests::{closed_outward, err, model};
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
    // Hull and minkowski of 3D children stay refused.
    assert!(err("hull() { cube(size = 1); }").contains("`hull` of 3D children"));
}
