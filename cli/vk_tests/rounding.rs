//! Device-independence without a hardware GPU: every GPU algorithm on every
//! shipped scene, on the default depth set-up, with another device's vertex
//! snapping emulated (`vk::RoundingEmulation`): 8 subpixel bits with depth
//! interpolated from the snapped vertices, as the NVIDIA H200 of the log does
//! (lavapipe reports 8 but interpolates from the unsnapped floats), and 4 bits, the
//! coarsest a conformant device may use. A fix that only holds with lavapipe's
//! exact rounding fails here. Bars: depth within the specification's bound at 99%
//! of interior pixels (`reference::precision`); interior coverage and primitive
//! mismatches ≤ 0.05% at 8 bits. At 4 bits faces closer than
//! 1/8 pixel's worth of depth slope are ties by construction (`plan::tie`), so
//! near-tangent crossings of two surfaces may take the lower index over a band
//! wider than the one-pixel boundary margin: primitive mismatches ≤ 0.5% there.

use peeltrim::plan::{self, Algo, Prepared};
use peeltrim::scene::Scene;
use peeltrim::vk::RoundingEmulation;
use peeltrim_cli::output::Images;
use peeltrim_cli::render::{DepthSetup, GpuRenderer};
use peeltrim_reference::compare::{compare, CompareReport};
use peeltrim_reference::precision::{spec_depth_check, SpecDepthReport};

use crate::algorithms::{load, shipped_scenes};

/// The bar on interior coverage and primitive mismatches.
pub const BAR: f64 = 0.0005;

/// Renders `scene` with `algo` on `depth`, rounding emulated if asked; `None` when
/// the algorithm does not draw this scene (no solid, or a refusal with its error).
pub fn run(
    scene: &Scene,
    algo: Algo,
    depth: DepthSetup,
    rounding: Option<RoundingEmulation>,
    reference: &Images,
) -> Option<(CompareReport, SpecDepthReport)> {
    let prep = Prepared::new(scene).ok()?;
    let plan = match plan::build(algo, &prep) {
        Ok(p) => p,
        Err(plan::PlanError::SurfacesNeedCst(_) | plan::PlanError::NoSolid) => return None,
        Err(e) => {
            eprintln!("{algo}: refused: {e}");
            return None;
        }
    };
    let mut gpu = GpuRenderer::emulating(scene, crate::setup::device(), depth, true, rounding)
        .expect("a Vulkan device");
    // The bound of the device emulated, or of the device itself.
    let precision = match rounding {
        Some(r) => depth.precision(r.subpixel_bits),
        None => gpu.precision(),
    };
    let frame = gpu.frame(&plan).unwrap_or_else(|e| panic!("{algo}: {e}"));
    let msgs = gpu.validation_messages();
    assert!(msgs.is_empty(), "{algo}: validation messages: {msgs:#?}");
    let r = compare(reference, &frame.images).expect("same size");
    let d = spec_depth_check(reference, &frame.images, &scene.camera, &precision);
    Some((r, d))
}

/// The primitive-mismatch bar at the 4-bit minimum (module doc).
const BAR_4_BITS: f64 = 0.005;

/// 8 bits on the default set-up and on D24S8 (where the log's classic tests
/// ran; D32S8 on a device without it), 4 bits on the default set-up. With the code before this suite, the 8-bit
/// D24S8 run reproduces the H200 log's counts exactly (e.g. `gear`: 298 interior
/// primitive mismatches, 1.8188%, for every algorithm).
fn check(algo: Algo) {
    // D32S8 (standard Z) where the device lacks D24S8 (SwiftShader).
    for depth in [DepthSetup::DEFAULT, crate::setup::usable(DepthSetup::D24S8)] {
        check_with(algo, RoundingEmulation::EIGHT_BITS, BAR, depth);
    }
    check_with(
        algo,
        RoundingEmulation::SPEC_MINIMUM,
        BAR_4_BITS,
        DepthSetup::DEFAULT,
    );
}

fn check_with(algo: Algo, rounding: RoundingEmulation, prim_bar: f64, depth: DepthSetup) {
    let mut failures = Vec::new();
    for path in shipped_scenes() {
        let scene = load(&path);
        let reference = peeltrim_reference::render(&scene, scene.render.width, scene.render.height);
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let Some((r, d)) = run(&scene, algo, depth, Some(rounding), &reference) else {
            continue;
        };
        eprintln!(
            "{algo:20} {name:16} {} snapped 2^-{}: coverage {:.4}% prim {:.4}% depth p99 {:.2} of the bound ({:.1e} relative)",
            depth.name(),
            rounding.subpixel_bits,
            r.coverage_mismatch_interior_frac * 100.0,
            r.prim_mismatch_interior_frac * 100.0,
            d.ratio_p99,
            d.relative_p99,
        );
        if r.coverage_mismatch_interior_frac > BAR
            || r.prim_mismatch_interior_frac > prim_bar
            || d.ratio_p99 > 1.0
        {
            failures.push(format!(
                "{name} {} 2^-{}: {r:?} {d:?}",
                depth.name(),
                rounding.subpixel_bits
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{algo} with a coarse device's rounding misses the bars on:\n{}",
        failures.join("\n")
    );
}

#[test]
fn goldfeather_with_coarse_rounding() {
    check(Algo::Goldfeather);
}

#[test]
fn goldfeather_layered_with_coarse_rounding() {
    check(Algo::GoldfeatherLayered);
}

#[test]
fn kirsch_with_coarse_rounding() {
    check(Algo::Kirsch);
}

#[test]
fn scs_with_coarse_rounding() {
    check(Algo::Scs);
}

#[test]
fn trickle_with_coarse_rounding() {
    check(Algo::Trickle);
}

#[test]
fn blister_with_coarse_rounding() {
    check(Algo::Blister);
}

#[test]
fn cst_z_with_coarse_rounding() {
    check(Algo::CstZ);
}

#[test]
fn cst_i_with_coarse_rounding() {
    check(Algo::CstI);
}

#[test]
fn cst_g_with_coarse_rounding() {
    check(Algo::CstG);
}

/// The emulation has teeth: blister-paper writes rasterized depth with no
/// plane re-evaluation, so snapping moves its depths beyond lavapipe's strict
/// figure — yet within the specification's bound for a 4-bit device; the output
/// pass of `blister` removes most of that error.
#[test]
fn emulated_snapping_moves_raw_depth_within_the_spec_bound() {
    let scene = load(&crate::setup::scenes_dir().join("complex.toml"));
    let reference = peeltrim_reference::render(&scene, scene.render.width, scene.render.height);
    let depth = DepthSetup::DEFAULT;
    let run_with = |algo, rounding| run(&scene, algo, depth, rounding, &reference).expect("drawn");
    let (plain, _) = run_with(Algo::BlisterPaper, None);
    let (snapped, spec) = run_with(Algo::BlisterPaper, Some(RoundingEmulation::SPEC_MINIMUM));
    let (corrected, _) = run_with(Algo::Blister, Some(RoundingEmulation::SPEC_MINIMUM));
    eprintln!(
        "complex, depth p99 (interior): lavapipe {:.2e}, snapped raw {:.2e} ({:.2} of the bound), snapped re-evaluated {:.2e}",
        plain.depth_abs_err_p99_interior,
        snapped.depth_abs_err_p99_interior,
        spec.ratio_p99,
        corrected.depth_abs_err_p99_interior
    );
    assert!(
        snapped.depth_abs_err_p99_interior > 4.0 * plain.depth_abs_err_p99_interior,
        "snapping should move raw depths well beyond lavapipe's"
    );
    assert!(
        spec.ratio_p99 <= 1.0,
        "the bound must hold for the emulated device"
    );
    assert!(
        corrected.depth_abs_err_p99_interior < 0.5 * snapped.depth_abs_err_p99_interior,
        "the output pass should remove most of the snapping error"
    );
}
