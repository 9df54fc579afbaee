//! Every GPU algorithm on every shipped scene, against the exact reference:
//! interior coverage and depth asserted, primitive mismatches asserted or
//! reported (per algorithm), zero validation messages.

use std::path::{Path, PathBuf};

use peeltrim::plan::{self, Algo, Prepared};
use peeltrim::scene::{self, LoadOptions, Scene};
use peeltrim_cli::output::Images;
use peeltrim_cli::render::{DepthSetup, GpuRenderer};
use peeltrim_reference::compare::{compare, CompareReport};

pub const SIZE: (u32, u32) = (128, 128);

pub fn shipped_scenes() -> Vec<PathBuf> {
    let dir = crate::setup::scenes_dir();
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("scenes/ exists")
        .map(|e| e.expect("readable dir entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    v.sort();
    assert!(
        v.len() >= 8,
        "expected the shipped scenes in {}",
        dir.display()
    );
    v
}

pub fn load(path: &Path) -> Scene {
    scene::load(path, &LoadOptions { size: Some(SIZE) }).unwrap_or_else(|e| panic!("{e}"))
}

/// The shipped scene `scenes/NAME.toml` (`setup::scenes_dir`) at [`SIZE`].
pub fn shipped(name: &str) -> Scene {
    load(&crate::setup::scenes_dir().join(format!("{name}.toml")))
}

/// [`shipped`] scene `name`, prepared, and its reference image at [`SIZE`].
pub fn shipped_with_reference(name: &str) -> (Scene, Prepared, Images) {
    let scene = shipped(name);
    let prep = Prepared::new(&scene).expect("prepared");
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    (scene, prep, reference)
}

/// The scene file text `text`, named `name` (its meshes resolve against no
/// folder), at [`SIZE`].
pub fn load_text(text: &str, name: &str) -> Scene {
    scene::load_str(text, Path::new(name), &LoadOptions { size: Some(SIZE) })
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The error a correct rasterizing algorithm may make, in view units: eight
/// quanta of a 24-bit depth buffer at the far plane, plus the rounding of f32
/// vertex positions and transforms (a few ulps of the far distance).
pub fn depth_tolerance(scene: &Scene) -> f64 {
    let (n, f) = (scene.camera.near, scene.camera.far);
    let quanta = match scene.camera.projection {
        scene::Projection::Perspective { .. } => 8.0 * 2f64.powi(-24) * f * (f - n) / n,
        scene::Projection::Orthographic { .. } => 8.0 * 2f64.powi(-24) * (f - n),
    };
    quanta + 2f64.powi(-19) * f
}

/// Renders `scene` with `algo` (validation on) and compares it with `reference`;
/// the flag: whether the depth passes with `strict_tol` (`setup::depth_passes`).
pub fn run_gpu(
    scene: &Scene,
    algo: Algo,
    depth: DepthSetup,
    reference: &Images,
    strict_tol: f64,
) -> Option<(CompareReport, peeltrim_cli::render::FrameStats, bool)> {
    let prep = match Prepared::new(scene) {
        Ok(p) => p,
        Err(plan::PlanError::NoSolid) => return None,
        Err(e) => panic!("{e}"),
    };
    let plan = match plan::build(algo, &prep) {
        Ok(p) => p,
        // A scene of surfaces only: the algorithm draws no surface.
        Err(plan::PlanError::SurfacesNeedCst(_)) => return None,
        Err(e) => panic!("{algo}: {e}"),
    };
    let mut gpu = GpuRenderer::new(scene, crate::setup::device(), depth, true)
        .expect("a Vulkan device (lavapipe)");
    let frame = gpu.frame(&plan).unwrap_or_else(|e| panic!("{algo}: {e}"));
    let msgs = gpu.validation_messages();
    assert!(
        msgs.is_empty(),
        "{algo} {}: validation messages: {msgs:#?}",
        depth.name()
    );
    let r = compare(reference, &frame.images).expect("same size");
    let depth_ok = crate::setup::depth_passes(
        r.depth_abs_err_p99_interior <= strict_tol,
        &gpu,
        scene,
        reference,
        &frame.images,
    );
    Some((r, frame.stats, depth_ok))
}

/// Renders `scene` with `algo` in every depth set-up and asserts the bars:
/// interior coverage mismatches ≤ `cov`, interior primitive mismatches ≤
/// `prim`, depth within [`depth_tolerance`]. Returns the loop iterations of
/// the last frame.
pub fn assert_scene(scene: &Scene, algo: Algo, cov: f64, prim: f64) -> Vec<u32> {
    let reference = peeltrim_reference::render(scene, SIZE.0, SIZE.1);
    let tol = depth_tolerance(scene);
    let mut iterations = Vec::new();
    for depth in crate::setup::usable_setups() {
        let (r, stats, depth_ok) = run_gpu(scene, algo, depth, &reference, tol).expect("a solid");
        let loops = &stats.exec.counts.loop_iterations;
        eprintln!("{algo} {}: {r:?} loops {loops:?}", depth.name());
        let at = format!("{algo} {}: {r:?}", depth.name());
        assert!(r.coverage_mismatch_interior_frac <= cov, "{at}");
        assert!(r.prim_mismatch_interior_frac <= prim, "{at}");
        assert!(depth_ok, "depth, {at}");
        iterations = loops.clone();
    }
    iterations
}

/// The bars: interior coverage mismatches ≤ `cov`, interior primitive
/// mismatches ≤ `prim`, depth p99 within a few quanta.
pub fn check_algo(algo: Algo, depths: &[DepthSetup], cov: f64, prim: f64) {
    let mut failures = Vec::new();
    for path in shipped_scenes() {
        let scene = load(&path);
        let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
        let tol = depth_tolerance(&scene);
        for &depth in depths {
            let Some((r, stats, depth_ok)) = run_gpu(&scene, algo, depth, &reference, tol) else {
                eprintln!("{algo}: {} has no solid; skipped", path.display());
                continue;
            };
            let name = path.file_stem().unwrap().to_string_lossy();
            eprintln!(
                "{algo} {name} {}: coverage {:.4}% prim {:.4}% depth p99 {:.2e} (tol {:.2e}) draws {} gpu {:.1} ms",
                depth.name(),
                r.coverage_mismatch_interior_frac * 100.0,
                r.prim_mismatch_interior_frac * 100.0,
                r.depth_abs_err_p99_interior,
                tol,
                stats.exec.counts.draws,
                stats.exec.gpu_ms
            );
            if r.coverage_mismatch_interior_frac > cov
                || r.prim_mismatch_interior_frac > prim
                || !depth_ok
            {
                failures.push(format!("{name} {}: {r:?}", depth.name()));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{algo} misses the bars on:\n{}",
        failures.join("\n")
    );
}

/// A test of `algo` against the reference on every shipped scene in every
/// depth set-up, with the bars of [`check_algo`].
macro_rules! on_shipped_scenes {
    ($(#[$doc:meta])* $name:ident: $algo:expr, cov $cov:expr, prim $prim:expr) => {
        $(#[$doc])*
        #[test]
        fn $name() {
            check_algo($algo, &crate::setup::usable_setups(), $cov, $prim);
        }
    };
}

/// CST's bars (0.05% interior coverage, 0.01% primitive mismatches).
pub const CST_COV: f64 = 0.0005;
/// See [`CST_COV`].
pub const CST_PRIM: f64 = 0.0001;

/// `images` match `reference` within CST's bars ([`CST_COV`], [`CST_PRIM`]).
pub fn assert_within_cst_bars(reference: &Images, images: &Images, what: &str) {
    let r = compare(reference, images).expect("same size");
    assert!(
        r.coverage_mismatch_interior_frac <= CST_COV,
        "{what}: {r:?}"
    );
    assert!(r.prim_mismatch_interior_frac <= CST_PRIM, "{what}: {r:?}");
}

on_shipped_scenes!(blister_matches_reference_on_shipped_scenes: Algo::Blister, cov 0.001, prim 0.01);

/// Plans are deterministic: two runs give identical counts and images.
#[test]
fn blister_counts_are_deterministic() {
    let scene = load(&crate::setup::scenes_dir().join("gear.toml"));
    let prep = Prepared::new(&scene).unwrap();
    let plan = plan::build(Algo::Blister, &prep).unwrap();
    let mut gpu =
        GpuRenderer::new(&scene, crate::setup::device(), DepthSetup::D32S8, true).unwrap();
    let a = gpu.frame(&plan).unwrap();
    let b = gpu.frame(&plan).unwrap();
    // The first frame learns the loop counts one submission at a time; the second
    // replays them in one: every other count is equal (but the state commands:
    // each submission's command buffer starts with none set; the timestamps,
    // written around each submission; and the pipelines, created by the first).
    assert!(a.stats.exec.counts.submits > 1);
    assert_eq!(b.stats.exec.counts.submits, 1);
    let strip = |c: &peeltrim::vk::Counts| peeltrim::vk::Counts {
        submits: 0,
        state_commands: 0,
        timestamps: 0,
        pipelines_created: 0,
        ..c.clone()
    };
    assert_eq!(strip(&a.stats.exec.counts), strip(&b.stats.exec.counts));
    assert_eq!(a.images, b.images);
    assert!(gpu.validation_messages().is_empty());
}

on_shipped_scenes!(cst_z_matches_reference_on_shipped_scenes: Algo::CstZ, cov CST_COV, prim CST_PRIM);
on_shipped_scenes!(cst_i_matches_reference_on_shipped_scenes: Algo::CstI, cov CST_COV, prim CST_PRIM);
on_shipped_scenes!(cst_g_matches_reference_on_shipped_scenes: Algo::CstG, cov CST_COV, prim CST_PRIM);
on_shipped_scenes!(
    /// SCS on every shipped scene (its products of convex primitives by SCS, the
    /// others by Goldfeather's steps), with CST's bars.
    scs_matches_reference_on_shipped_scenes: Algo::Scs, cov CST_COV, prim CST_PRIM
);

/// The paper's Blister (depth-test parity, colour and id from the peel) on every
/// shipped scene: its speckles are counted and reported, not hidden, next to the
/// tolerant `blister`, which must never be worse.
#[test]
fn blister_paper_speckles_are_counted() {
    let mut total = (0u64, 0u64);
    for path in shipped_scenes() {
        let scene = load(&path);
        let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
        let depth = crate::setup::usable(DepthSetup::D24S8);
        let (Some((paper, _, _)), Some((tolerant, _, _))) = (
            run_gpu(&scene, Algo::BlisterPaper, depth, &reference, 0.0),
            run_gpu(&scene, Algo::Blister, depth, &reference, 0.0),
        ) else {
            continue;
        };
        let name = path.file_stem().unwrap().to_string_lossy();
        eprintln!(
            "blister-paper {name}: speckles (interior prim mismatches) {} = {:.3}%, coverage {:.3}%; blister: {} / {:.3}%",
            paper.prim_mismatch_interior,
            paper.prim_mismatch_interior_frac * 100.0,
            paper.coverage_mismatch_interior_frac * 100.0,
            tolerant.prim_mismatch_interior,
            tolerant.coverage_mismatch_interior_frac * 100.0
        );
        total.0 += paper.prim_mismatch_interior;
        total.1 += tolerant.prim_mismatch_interior;
        assert!(
            paper.coverage_mismatch_interior_frac <= 0.005,
            "{name}: {paper:?}"
        );
        assert!(
            tolerant.prim_mismatch_interior <= paper.prim_mismatch_interior,
            "{name}"
        );
        assert!(
            tolerant.coverage_mismatch_interior <= paper.coverage_mismatch_interior,
            "{name}"
        );
    }
    eprintln!(
        "speckles over all shipped scenes: blister-paper {}, blister {}",
        total.0, total.1
    );
}

/// Asserts `algo`'s interior coverage and primitive mismatches on `scene`
/// against `reference` within `cov` and `prim`, with D32S8 forward and
/// reversed (depth not checked); `what` names the case in the log.
fn assert_d32(scene: &Scene, reference: &Images, what: &str, algo: Algo, cov: f64, prim: f64) {
    for depth in [DepthSetup::D32S8, DepthSetup::D32S8Reversed] {
        let (r, _, _) = run_gpu(scene, algo, depth, reference, 0.0).expect("a solid");
        eprintln!("{what}, {algo} {}: {r:?}", depth.name());
        let at = format!("{algo} {}: {r:?}", depth.name());
        assert!(r.coverage_mismatch_interior_frac <= cov, "{at}");
        assert!(r.prim_mismatch_interior_frac <= prim, "{at}");
    }
}

/// The eye inside a primitive (a room minus a pillar, seen from inside): parity
/// counted from the near plane is inverted for the room, which Blister and CST
/// correct; the visible points are where rays enter the solid, as the reference
/// says (the pillar's far side), not the room's walls.
#[test]
fn eye_inside_a_primitive() {
    let text = r##"
primitive = [
  { name = "Room", shape = "box", size = [4.0, 3.0, 8.0] },
  { name = "Pillar", shape = "cylinder", radius = 0.4, height = 3.5, translate = [0.5, 0.0, -2.0], color = "#a04040" },
]
camera = { eye = [0.0, 0.0, 0.5], target = [0.0, 0.0, -3.0], fov_y_deg = 60 }
csg = { expr = "Room - Pillar" }
"##;
    let scene = load_text(text, "eye_inside.toml");
    let prep = Prepared::new(&scene).unwrap();
    assert_eq!(prep.eye_inside[..2], [true, false]);
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    assert!(reference.prim.contains(&2), "the pillar shows");
    let algos = Algo::ALL
        .into_iter()
        .filter(|&a| a != Algo::Reference && a != Algo::BlisterPaper);
    for algo in algos {
        // The bars: Blister and CST 0.05%, Goldfeather 0.1%.
        let cov = match algo {
            Algo::Goldfeather
            | Algo::GoldfeatherLayered
            | Algo::Trickle
            | Algo::Kirsch
            | Algo::Scs => 0.001,
            _ => 0.0005,
        };
        assert_d32(&scene, &reference, "eye inside", algo, cov, 0.0001);
    }
}

/// An orthographic eye plane cutting a primitive (a ball minus a pin, cut by the
/// eye plane; a block wholly in front): some pixels' rays start inside the ball,
/// others outside, so no per-primitive parity flip is right. The visible points are
/// where rays enter the solid beyond the near plane, as the reference says.
#[test]
fn orthographic_eye_plane_cuts_a_primitive() {
    let text = r##"
primitive = [
  { name = "Ball", shape = "sphere", radius = 1.2, translate = [-0.4, 0.0, -0.6] },
  { name = "Pin", shape = "cylinder", radius = 0.3, height = 2.0, rotate_deg = [90.0, 0.0, 0.0], translate = [-0.2, 0.2, 0.0], color = "#a04040" },
  { name = "Block", shape = "box", size = [1.0, 1.0, 1.0], translate = [1.3, -0.5, -1.5], color = "#4040a0" },
]
camera = { eye = [0.0, 0.0, 0.5], target = [0.0, 0.0, -3.0], projection = "orthographic", ortho_height = 4.0, near = 0.0 }
csg = { expr = "(Ball - Pin) + Block" }
"##;
    let scene = load_text(text, "ortho_cut.toml");
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    for p in 1..=3u16 {
        assert!(reference.prim.contains(&p), "primitive {p} shows");
    }
    let prep = Prepared::new(&scene).unwrap();
    assert_eq!(prep.near_cut[..3], [true, true, false]);
    for algo in Algo::ALL.into_iter().filter(|&a| a != Algo::Reference) {
        assert_d32(&scene, &reference, "ortho eye plane", algo, 0.0005, 0.0005);
    }
}
