//! OpenSCAD extrusions on the GPU: the shipped models made of `linear_extrude`
//! (a profile with a hole, a twisted and tapered star) and `rotate_extrude` (a
//! lathe profile), loaded from `scenes/openscad/`, rendered with cst-i under
//! validation and compared with the exact reference (interior coverage ≤ 0.1%,
//! depth p99 within the depth tolerance). Each 2D primitive is its own extruded
//! solid, so the extruded caps of a 2D difference are coplanar by construction:
//! the test also checks that they draw without holes or speckle.

use peeltrim::plan::Algo;
use peeltrim::scene::{self, LoadOptions};
use peeltrim_cli::render::DepthSetup;

use super::algorithms::{depth_tolerance, run_gpu};

const SIZE: (u32, u32) = (96, 96);

/// Renders `scenes/openscad/NAME` with cst-i against the reference; the
/// comparison, after asserting the bar (also used by `openscad_3d`).
pub fn check(name: &str, min_prims: usize) -> peeltrim_reference::compare::CompareReport {
    let path = crate::setup::scenes_dir().join("openscad").join(name);
    let scene =
        scene::load(&path, &LoadOptions { size: Some(SIZE) }).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        scene.primitives.len() >= min_prims,
        "{name}: {} primitives",
        scene.primitives.len()
    );
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    let tol = depth_tolerance(&scene);
    let (r, _, depth_ok) =
        run_gpu(&scene, Algo::CstI, DepthSetup::D32S8, &reference, tol).expect("a solid");
    eprintln!(
        "cst-i {name}: coverage {:.4}% depth p99 {:.2e} (tol {:.2e})",
        r.coverage_mismatch_interior_frac * 100.0,
        r.depth_abs_err_p99_interior,
        tol
    );
    assert!(
        r.coverage_mismatch_interior_frac <= 0.001 && depth_ok,
        "{name}: {r:?}"
    );
    r
}

#[test]
fn twisted_extrusion_cst_i_matches_reference() {
    let _ = check("twisted_vase.csg", 3);
}

#[test]
fn extruded_profile_with_hole_cst_i_matches_reference() {
    let _ = check("extruded_profile.csg", 10);
}

#[test]
fn rotate_extrude_cst_i_matches_reference() {
    let _ = check("lathe_knob.csg", 10);
}

#[test]
fn imported_dxf_and_svg_outlines_cst_i_match_reference() {
    // A DXF flange (two layers) and an SVG drop, each one extruded primitive.
    check("import_outline.csg", 3);
}
