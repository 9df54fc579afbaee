//! OpenSCAD models (`scenes/openscad/*.csg`, loaded as they are) on the GPU:
//! cst-i and Blister against the exact reference (interior coverage ≤ 0.1%,
//! depth p99 within the depth tolerance), and a model of 2,000 cylinders with
//! cst-i. Validation messages fail (checked in `run_gpu`).

use std::path::PathBuf;

use peeltrim::plan::Algo;
use peeltrim::scene::{self, LoadOptions, Scene};
use peeltrim_cli::render::DepthSetup;

use super::algorithms::{depth_tolerance, run_gpu};
use super::scad_models::plate_with_holes;

const SIZE: (u32, u32) = (96, 96);

fn models() -> Vec<PathBuf> {
    let dir = crate::setup::scenes_dir().join("openscad");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("scenes/openscad exists")
        .map(|e| e.expect("readable dir entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "csg"))
        .collect();
    v.sort();
    assert!(
        v.len() >= 5,
        "expected the shipped models in {}",
        dir.display()
    );
    v
}

fn check(scene: &Scene, name: &str, algo: Algo) -> Option<String> {
    let reference = peeltrim_reference::render(scene, SIZE.0, SIZE.1);
    let tol = depth_tolerance(scene);
    let (r, stats, depth_ok) =
        run_gpu(scene, algo, DepthSetup::D32S8, &reference, tol).expect("a solid");
    eprintln!(
        "{algo} {name}: coverage {:.4}% prim {:.4}% depth p99 {:.2e} (tol {:.2e}) draws {}",
        r.coverage_mismatch_interior_frac * 100.0,
        r.prim_mismatch_interior_frac * 100.0,
        r.depth_abs_err_p99_interior,
        tol,
        stats.exec.counts.draws
    );
    (r.coverage_mismatch_interior_frac > 0.001 || !depth_ok).then(|| format!("{name}: {r:?}"))
}

fn check_models(algo: Algo) {
    let failures: Vec<String> = models()
        .iter()
        .filter_map(|path| {
            let scene = scene::load(path, &LoadOptions { size: Some(SIZE) })
                .unwrap_or_else(|e| panic!("{e}"));
            check(&scene, &path.file_stem().unwrap().to_string_lossy(), algo)
        })
        .collect();
    assert!(
        failures.is_empty(),
        "{algo} misses the bars on:\n{}",
        failures.join("\n")
    );
}

#[test]
fn openscad_models_cst_i_match_reference() {
    check_models(Algo::CstI);
}

#[test]
fn openscad_models_blister_match_reference() {
    check_models(Algo::Blister);
}

#[test]
fn two_thousand_cylinders_render_with_cst_i() {
    let dir = std::env::temp_dir().join(format!("peeltrim-scad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("holes.csg");
    std::fs::write(&path, plate_with_holes()).unwrap();
    let t = std::time::Instant::now();
    let scene =
        scene::load(&path, &LoadOptions { size: Some(SIZE) }).unwrap_or_else(|e| panic!("{e}"));
    eprintln!("2000 holes: loaded in {:?} (test profile)", t.elapsed());
    assert_eq!(scene.primitives.len(), 2001);
    let fail = check(&scene, "holes", Algo::CstI);
    assert!(fail.is_none(), "{fail:?}");
}
