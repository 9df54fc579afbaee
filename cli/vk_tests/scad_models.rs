//! Generated OpenSCAD models shared by the GPU and command-line tests.

/// A plate with 2,000 cylindrical holes, as OpenSCAD exports a `for` loop of
/// `translate() cylinder()`: one `multmatrix` per hole.
pub fn plate_with_holes() -> String {
    let mut s =
        String::from("difference() {\n\tcube(size = [102, 42, 2], center = false);\n\tgroup() {\n");
    for i in 0..2000 {
        s.push_str(&format!(
            "\t\tmultmatrix([[1, 0, 0, {}], [0, 1, 0, {}], [0, 0, 1, -1], [0, 0, 0, 1]]) {{\n\t\t\tcylinder($fn = 12, $fa = 12, $fs = 2, h = 4, r1 = 0.4, r2 = 0.4, center = false);\n\t\t}}\n",
            1 + i % 100,
            1 + i / 100 * 2
        ));
    }
    s.push_str("\t}\n}\n");
    s
}
