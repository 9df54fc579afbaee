//! OpenSCAD's 3D node kinds on the GPU: an imported STL part subtracted from a
//! block (`import`), a rounded box with a hull-cut slot and a resized ball
//! (`minkowski`, `hull`, `resize`), and a height map with a bore (`surface`),
//! each shipped in `scenes/openscad/`, rendered with cst-i under validation
//! against the exact reference.

use super::openscad_extrude::check;

#[test]
fn imported_stl_subtracted_from_a_block_has_no_interior_mismatch() {
    let r = check("stl_cutout.csg", 2);
    assert_eq!(r.coverage_mismatch_interior, 0, "{r:?}");
}

#[test]
fn minkowski_hull_and_resize_cst_i_match_reference() {
    let _ = check("rounded_box.csg", 3);
}

#[test]
fn surface_cst_i_matches_reference() {
    let _ = check("terrain.csg", 2);
}
