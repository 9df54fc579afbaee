//! Goldfeather, layered Goldfeather and Trickle on lavapipe against the exact
//! reference, on the shipped scenes at 128×128. Interior metrics (pixels away from
//! silhouettes and primitive boundaries, where one pixel centre decides) must agree.

use std::path::Path;

use peeltrim::plan::{self, Algo, Prepared};
use peeltrim::reference;
use peeltrim::render::{DepthSetup, GpuRenderer};
use peeltrim::scene::{self, Scene};
use peeltrim::vk::DeviceChoice;

const ALGOS: [Algo; 3] = [Algo::Goldfeather, Algo::GoldfeatherLayered, Algo::Trickle];

fn load(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    let opts = scene::load::LoadOptions {
        size: Some((128, 128)),
    };
    scene::load::load(&path, &opts).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Renders `scene` with each algorithm and compares with the reference; returns
/// one line per algorithm and panics (after printing all) on a failed bound.
fn check(name: &str, algos: &[Algo], max_interior_mismatch: f64) {
    let scene = load(name);
    let reference = reference::render(&scene, scene.render.width, scene.render.height);
    let prep = Prepared::new(&scene).expect("prepared");
    let mut gpu =
        GpuRenderer::new(&scene, DeviceChoice::Cpu, DepthSetup::D24S8, true).expect("lavapipe");
    let mut failures = Vec::new();
    for &algo in algos {
        let plan = plan::build(algo, &prep).expect("plan");
        let frame = gpu.frame(&plan).expect("frame");
        let r = reference::compare::compare(&reference, &frame.images).expect("compare");
        let s = &frame.stats;
        println!(
            "{name:16} {:20} cov_int {:6} ({:.4}%) prim_int {:5} depth_p99_int {:.2e} max_int {:.2e} | cov {} prim {} | draws {} tris {} fs {} loops {}",
            algo.name(),
            r.coverage_mismatch_interior,
            100.0 * r.coverage_mismatch_interior_frac,
            r.prim_mismatch_interior,
            r.depth_abs_err_p99_interior,
            r.depth_abs_err_max_interior,
            r.coverage_mismatch,
            r.prim_mismatch,
            s["draws"],
            s["triangles"],
            s["fullscreen_passes"],
            s["loop_iterations"],
        );
        let extra = (0..reference.depth.len())
            .filter(|&i| reference.prim[i] == 0 && frame.images.prim[i] != 0)
            .count();
        let missing = (0..reference.depth.len())
            .filter(|&i| reference.prim[i] != 0 && frame.images.prim[i] == 0)
            .count();
        println!("    extra {extra} missing {missing}");
        if std::env::var("CLASSIC_DUMP").is_ok() {
            let w = frame.images.width as usize;
            for y in (0..frame.images.height as usize).step_by(2) {
                let row: String = (0..w)
                    .map(|x| {
                        let i = y * w + x;
                        match (reference.prim[i] != 0, frame.images.prim[i] != 0) {
                            (true, true) => '#',
                            (false, false) => '.',
                            (true, false) => 'm',
                            (false, true) => 'x',
                        }
                    })
                    .collect();
                println!("{row}");
            }
        }
        if r.coverage_mismatch_interior_frac > max_interior_mismatch {
            failures.push(format!(
                "{name} {algo}: interior coverage mismatch {}",
                r.coverage_mismatch_interior_frac
            ));
        }
        // A few depth quanta of a 24-bit buffer over the scene's depth range.
        let range = scene.camera.far - scene.camera.near;
        if r.depth_abs_err_p99_interior > 1e-3 * range {
            failures.push(format!(
                "{name} {algo}: interior depth p99 {}",
                r.depth_abs_err_p99_interior
            ));
        }
    }
    let msgs = gpu.validation_messages();
    assert!(msgs.is_empty(), "validation: {msgs:?}");
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn classic_coincident() {
    check("coincident.toml", &ALGOS, 0.001);
}

#[test]
fn classic_drilled_block() {
    check("drilled_block.toml", &ALGOS, 0.001);
}

#[test]
fn classic_complex() {
    check("complex.toml", &ALGOS, 0.001);
}

#[test]
fn classic_nonconvex_obj() {
    check("nonconvex_obj.toml", &ALGOS, 0.001);
}

#[test]
fn classic_paper_example() {
    check("paper_example.toml", &ALGOS, 0.001);
}

#[test]
fn classic_speckle() {
    check("speckle.toml", &ALGOS, 0.001);
}

#[test]
fn classic_too_many_products_fail_fast() {
    // (A0 + B0)(A1 + B1)...: 2^40 products.
    let mut text = String::from("[camera]\neye = [0.0, 2.0, 6.0]\ntarget = [0.0, 0.0, 0.0]\n");
    let mut expr = Vec::new();
    for i in 0..40 {
        let s = 1.0 + 0.01 * i as f64;
        text +=
            &format!("[[primitive]]\nname = \"a{i}\"\nshape = \"box\"\nsize = [{s}, 1.0, 1.0]\n");
        text +=
            &format!("[[primitive]]\nname = \"b{i}\"\nshape = \"box\"\nsize = [1.0, {s}, 1.0]\n");
        expr.push(format!("(a{i} + b{i})"));
    }
    text += &format!("[csg]\nexpr = \"{}\"\n", expr.join(" "));
    let scene =
        scene::load::load_str(&text, Path::new("blowup.toml"), &Default::default()).expect("scene");
    let prep = Prepared::new(&scene).expect("prepared");
    for algo in ALGOS {
        let t = std::time::Instant::now();
        let err = plan::build(algo, &prep)
            .expect_err("too many products")
            .to_string();
        assert!(
            t.elapsed().as_secs_f64() < 1.0,
            "{algo} took {:?}",
            t.elapsed()
        );
        assert!(err.contains("cst-i") && err.contains("products"), "{err}");
    }
}
