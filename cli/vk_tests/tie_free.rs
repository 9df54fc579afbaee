//! The tie-free fast path (`plan::tie_free`): on a scene without coincident or
//! nearly coincident faces every tolerant parity and peel draw runs as a plain
//! depth test and the images match the reference; on one with coincident
//! faces the draws that can meet a tie keep the tie rule.

use peeltrim::plan::step::{Fragment, Step};
use peeltrim::plan::{self, Algo, Prepared};
use peeltrim::vk::Recorded;
use peeltrim_cli::render::{DepthSetup, FrameStats, GpuRenderer};
use peeltrim_reference::compare::compare;
use peeltrim_reference::precision::spec_depth_check;

use crate::algorithms::{load, shipped, shipped_with_reference, SIZE};

/// The GPU algorithms with tolerant parity or peel draws (all but the
/// reference and the paper's depth-test Blister).
fn tolerant() -> impl Iterator<Item = Algo> {
    Algo::ALL
        .into_iter()
        .filter(|a| !matches!(a, Algo::Reference | Algo::BlisterPaper))
}

/// One frame of `algo` on the shipped scene `name`.
fn frame(
    name: &str,
    algo: Algo,
) -> (
    peeltrim_cli::output::Images,
    FrameStats,
    peeltrim::scene::Scene,
) {
    let scene = shipped(name);
    let prep = Prepared::new(&scene).expect("prepared");
    let plan = plan::build(algo, &prep).unwrap_or_else(|e| panic!("{algo}: {e}"));
    let mut gpu = GpuRenderer::new(&scene, crate::setup::device(), DepthSetup::DEFAULT, true)
        .expect("a Vulkan device (lavapipe)");
    let f = gpu.frame(&plan).unwrap_or_else(|e| panic!("{algo}: {e}"));
    let msgs = gpu.validation_messages();
    assert!(msgs.is_empty(), "{algo}: validation messages: {msgs:#?}");
    (f.images, f.stats, scene)
}

#[test]
fn a_scene_without_coincident_faces_draws_tie_free_and_matches_the_reference() {
    // Twelve holes through a block, every cylinder longer than the block: no
    // two faces of different primitives are parallel within reach.
    let name = "drilled_block";
    let mut failures = Vec::new();
    let mut reference = None;
    for algo in tolerant() {
        let (fast, stats, scene) = frame(name, algo);
        let c = &stats.exec.counts;
        assert!(c.tie_free_draws > 0, "{algo}: no tie-free draw: {c:?}");
        assert_eq!(c.tie_rule_draws, 0, "{algo}: a draw kept the tie rule");
        let reference =
            reference.get_or_insert_with(|| peeltrim_reference::render(&scene, SIZE.0, SIZE.1));
        let r = compare(reference, &fast).expect("same size");
        // The bars of the shipped-scene tests.
        if r.coverage_mismatch_interior_frac > 0.001 || r.prim_mismatch_interior_frac > 0.01 {
            failures.push(format!("{algo} against the reference: {r:?}"));
        }
        eprintln!(
            "{algo}: {} tie-free draws; coverage {:.4}% prim {:.4}% against the reference",
            c.tie_free_draws,
            r.coverage_mismatch_interior_frac * 100.0,
            r.prim_mismatch_interior_frac * 100.0
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn coincident_faces_keep_the_tie_rule() {
    // Every primitive of `coincident` shares a face plane with another one:
    // the draws reading an image that may hold a partner's faces keep the
    // rule; the others (`plan::tie_context`) may go plain.
    for algo in tolerant() {
        let (_, stats, _) = frame("coincident", algo);
        let c = &stats.exec.counts;
        // SCS's keep it as the depth test (`Fragment::TieDepth`).
        assert!(c.tie_rule_draws + c.tie_depth_draws > 0, "{algo}: {c:?}");
    }
}

#[test]
fn a_depth_equal_final_shade_matches_the_reference() {
    // Every plan's depth-stencil image must hold the visible faces' raster
    // depths bit-exactly for the depth-equal shade to find them: on every
    // depth set-up, and with an 8-bit device's vertex snapping emulated,
    // where the shade keeps the tie rule (its depth output carries the
    // snapping error; `DeviceProfile::depth_equal_shades`), as it does on
    // D24S8.
    let name = "drilled_block";
    let (scene, prep, reference) = shipped_with_reference(name);
    let setups = crate::setup::usable_setups()
        .into_iter()
        .map(|d| (d, None))
        .chain([(
            DepthSetup::DEFAULT,
            Some(peeltrim::vk::RoundingEmulation::EIGHT_BITS),
        )]);
    let mut failures = Vec::new();
    for (depth, rounding) in setups {
        for algo in tolerant() {
            let plan = plan::build(algo, &prep).unwrap_or_else(|e| panic!("{algo}: {e}"));
            let mut gpu =
                GpuRenderer::emulating(&scene, crate::setup::device(), depth, true, rounding)
                    .expect("a Vulkan device (lavapipe)");
            let fixed = gpu.frame(&plan).unwrap_or_else(|e| panic!("{algo}: {e}"));
            let msgs = gpu.validation_messages();
            assert!(msgs.is_empty(), "{algo}: validation messages: {msgs:#?}");
            let at = format!("{algo} on {depth:?}, rounding {rounding:?}");
            let f = &fixed.stats.exec.counts;
            let shades = gpu
                .context()
                .profile()
                .depth_equal_shades(depth.exec_format().0);
            if !shades {
                assert_eq!(f.shade_fixed_draws, 0, "{at}: snapping, or D24");
            } else {
                assert_eq!(f.shade_rule_draws, 0, "{at}");
                assert!(f.shade_fixed_draws > 0, "{at}: no shade draw: {f:?}");
            }
            let c = compare(&reference, &fixed.images).expect("same size");
            let s = spec_depth_check(&reference, &fixed.images, &scene.camera, &gpu.precision());
            if c.coverage_mismatch_interior_frac > 0.001
                || c.prim_mismatch_interior_frac > 0.01
                || s.ratio_p99 > 1.0
            {
                failures.push(format!("{at} against the reference: {c:?} {s:?}"));
            }
            eprintln!("{at}: {} depth-equal shade draws", f.shade_fixed_draws);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn coincident_faces_keep_the_tie_rule_in_the_final_shade() {
    // Visible coincident faces: C's flush with A's where B removed A
    // (speckle), the flange's with the block's (assembly). `coincident`'s
    // are never visible (`vk_tests/visible_ties.rs`).
    for name in ["speckle", "assembly"] {
        for algo in tolerant() {
            let (_, stats, _) = frame(name, algo);
            let c = &stats.exec.counts;
            assert!(c.shade_rule_draws > 0, "{name} {algo}: {c:?}");
        }
    }
}

#[test]
fn a_camera_change_that_changes_the_shade_decisions_records_again() {
    // Two boxes, B's bottom face 4e-3 above A's top face: tie-free with a
    // tight depth range, within the tie band with a near plane 300 times
    // closer (standard Z: the band grows with far/near). The screen
    // rectangles stay the same, so only the decisions can make it record.
    let toml = r##"
name = "gap"
[camera]
eye = [1.0, 3.0, 4.0]
target = [0.0, 0.5, 0.0]
near = 3.0
far = 7.0
[[primitive]]
name = "A"
shape = "box"
size = [1.0, 1.0, 1.0]
[[primitive]]
name = "B"
shape = "box"
size = [1.0, 1.0, 1.0]
translate = [0.3, 1.004, 0.2]
[csg]
expr = "A + B"
"##;
    let path = std::env::temp_dir().join(format!("peeltrim-gap-{}.toml", std::process::id()));
    std::fs::write(&path, toml).expect("temp scene");
    let scene = load(&path);
    std::fs::remove_file(&path).ok();
    let plan = plan::build(Algo::Goldfeather, &Prepared::new(&scene).unwrap()).unwrap();
    let mut gpu = GpuRenderer::new(&scene, crate::setup::device(), DepthSetup::D32S8, true)
        .expect("a Vulkan device (lavapipe)");
    if !gpu
        .context()
        .profile()
        .depth_equal_shades(DepthSetup::D32S8.exec_format().0)
    {
        // Every final shade keeps the rule on this profile: no camera
        // changes the shade's decisions.
        return;
    }
    // Both boxes are one-primitive products: tie-free, each shades in its
    // direct draw (`plan::direct_shade`) and the final shade draws neither;
    // within the band both keep the old path.
    let counts = |gpu: &mut GpuRenderer| {
        let s = gpu.execute(&plan).unwrap().exec;
        let c = &s.counts;
        let depth_equal = c.shade_fixed_draws + c.direct_shade_draws;
        (s.recorded, depth_equal, c.shade_rule_draws)
    };
    counts(&mut gpu);
    assert_eq!(counts(&mut gpu), (Recorded::New, 2, 0));
    assert_eq!(counts(&mut gpu), (Recorded::Replayed, 2, 0));
    let direct = |gpu: &mut GpuRenderer| gpu.execute(&plan).unwrap().exec.counts.direct_shade_draws;
    assert_eq!(direct(&mut gpu), 2);
    let near = peeltrim::scene::Camera {
        near: 0.01,
        ..scene.camera
    };
    // A moved camera records with grown scissors, and with exact ones once it
    // stays (`vk_tests/replay.rs`); then it replays.
    gpu.set_camera(&near).unwrap();
    // Within the band the boxes tie only where B's bottom face meets A's top
    // face: one tie-rule draw there, A's, the lower index (`plan::tie_zones`),
    // depth-equal pieces around it; B, whose one partner has the lower
    // index, draws depth-equal everywhere, in its direct draw.
    for want in [Recorded::Camera, Recorded::Camera, Recorded::Replayed] {
        let (kind, fixed, rule) = counts(&mut gpu);
        assert_eq!((kind, rule), (want, 1));
        assert!(fixed > 0, "{kind:?}");
    }
    assert_eq!(direct(&mut gpu), 1);
    gpu.set_camera(&scene.camera).unwrap();
    assert_eq!(counts(&mut gpu), (Recorded::Camera, 2, 0));
    let msgs = gpu.validation_messages();
    assert!(msgs.is_empty(), "validation messages: {msgs:#?}");
}

#[test]
fn scs_subtracts_drilled_block_with_plain_depth_tests() {
    // SCS's exits move `z` in the depth-stencil image as in the texture, so its
    // tie-free parity draws test the image: each hole's subtraction runs
    // without the tie-rule shader, and so does the block's clip by its back
    // faces (`plan::scs`, `Fragment::BehindThan`; the one product is drawn in
    // the output, no merge).
    let (fast, stats, scene) = frame("drilled_block", Algo::Scs);
    let prep = Prepared::new(&scene).expect("prepared");
    let built = plan::build(Algo::Scs, &prep).expect("scs plan");
    let mut parity: Vec<(&str, u64)> = Vec::new();
    let mut pass = "";
    for s in &built.steps {
        match s {
            Step::Pass(p) => pass = p,
            Step::Draw(d)
                if matches!(
                    d.fragment,
                    Fragment::NearerThan { .. } | Fragment::ParityBeforeExit { .. }
                ) =>
            {
                match parity.last_mut() {
                    Some((p, n)) if *p == pass => *n += 1,
                    _ => parity.push((pass, 1)),
                }
            }
            Step::Loop(_) => panic!("the holes are disjoint: no rounds"),
            _ => {}
        }
    }
    // One parity draw per hole; the tie-free frame draws its front faces only
    // (`Fragment::ParityBeforeExit`).
    assert_eq!(parity, vec![("subtract", 12)]);
    let c = &stats.exec.counts;
    assert_eq!((c.tie_free_draws, c.tie_rule_draws), (13, 0), "{c:?}");
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    let r = compare(&reference, &fast).expect("same size");
    // `vk_tests::algorithms`' SCS bars.
    assert!(
        r.coverage_mismatch_interior_frac <= 0.0005 && r.prim_mismatch_interior_frac <= 0.0001,
        "against the reference: {r:?}"
    );
}

#[test]
fn scs_runs_its_tie_rule_as_the_depth_test() {
    // complex: the slot's caps flush with the base's top face, so SCS's base
    // product keeps the rule on its parity draws. As the depth test
    // (`Fragment::TieDepth`) they read no texture: the same interior pixels
    // as the reference. On every depth set-up, and with an 8-bit device's
    // vertex snapping emulated; D24S8 keeps the texture's rule (its depth
    // image rounds the depth).
    let name = "complex";
    let (scene, prep, reference) = shipped_with_reference(name);
    let plan = plan::build(Algo::Scs, &prep).expect("scs");
    let setups = crate::setup::usable_setups()
        .into_iter()
        .map(|d| (d, None))
        .chain([(
            DepthSetup::DEFAULT,
            Some(peeltrim::vk::RoundingEmulation::EIGHT_BITS),
        )]);
    let mut failures = Vec::new();
    for (depth, rounding) in setups {
        let mut gpu = GpuRenderer::emulating(&scene, crate::setup::device(), depth, true, rounding)
            .expect("a Vulkan device (lavapipe)");
        let test = gpu.frame(&plan).expect("a frame");
        let msgs = gpu.validation_messages();
        assert!(msgs.is_empty(), "validation messages: {msgs:#?}");
        let at = format!("{depth:?}, rounding {rounding:?}");
        let t = &test.stats.exec.counts;
        if depth == DepthSetup::D24S8 {
            assert_eq!(t.tie_depth_draws, 0, "{at}: D24 keeps the rule: {t:?}");
            continue;
        }
        assert!(t.tie_depth_draws > 0, "{at}: {t:?}");
        let c = compare(&reference, &test.images).expect("same size");
        if (c.coverage_mismatch_interior, c.prim_mismatch_interior) != (0, 0) {
            failures.push(format!("{at}: against the reference: {c:?}"));
        }
        eprintln!(
            "{at}: {} depth-test rule draws, barriers {}",
            t.tie_depth_draws, t.barriers
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
