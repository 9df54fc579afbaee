//! The tie-free fast path (`plan::tie_free`): on a scene without coincident or
//! nearly coincident faces every tolerant parity and peel draw runs as a plain
//! depth test, the images match the reference and the tie-rule frame; on one
//! with coincident faces the tied meshes keep the tie rule.

use std::path::Path;

use peeltrim::plan::step::{Fragment, Step};
use peeltrim::plan::{self, Algo, Prepared};
use peeltrim::reference::compare::compare;
use peeltrim::render::{DepthSetup, FrameStats, GpuRenderer};

use crate::algorithms::{load, SIZE};

/// The GPU algorithms with tolerant parity or peel draws (all but the
/// reference and the paper's depth-test Blister).
fn tolerant() -> impl Iterator<Item = Algo> {
    Algo::ALL
        .into_iter()
        .filter(|a| !matches!(a, Algo::Reference | Algo::BlisterPaper))
}

/// One frame of `algo` on the shipped scene `name`, with the fast path on or off.
fn frame(
    name: &str,
    algo: Algo,
    tie_free: bool,
) -> (peeltrim::output::Images, FrameStats, peeltrim::scene::Scene) {
    let path = crate::setup::scenes_dir().join(format!("{name}.toml"));
    let scene = load(Path::new(&path));
    let prep = Prepared::new(&scene).expect("prepared");
    let plan = plan::build(algo, &prep).unwrap_or_else(|e| panic!("{algo}: {e}"));
    let mut gpu = GpuRenderer::new(&scene, crate::setup::device(), DepthSetup::DEFAULT, true)
        .expect("a Vulkan device (lavapipe)");
    gpu.set_tie_free(tie_free);
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
        let (fast, stats, scene) = frame(name, algo, true);
        let c = &stats.exec.counts;
        assert!(c.tie_free_draws > 0, "{algo}: no tie-free draw: {c:?}");
        assert_eq!(c.tie_rule_draws, 0, "{algo}: a draw kept the tie rule");
        let reference =
            reference.get_or_insert_with(|| peeltrim::reference::render(&scene, SIZE.0, SIZE.1));
        let r = compare(reference, &fast).expect("same size");
        // The bars of the shipped-scene tests.
        if r.coverage_mismatch_interior_frac > 0.001 || r.prim_mismatch_interior_frac > 0.01 {
            failures.push(format!("{algo} against the reference: {r:?}"));
        }
        // The tie-rule frame: no draw taken as tie-free, the same pixels.
        let (slow, slow_stats, _) = frame(name, algo, false);
        assert_eq!(slow_stats.exec.counts.tie_free_draws, 0);
        assert_eq!(
            slow_stats.exec.counts.tie_rule_draws, c.tie_free_draws,
            "{algo}: every tolerant draw of the tie-rule frame is tie-free in the other"
        );
        let d = compare(&slow, &fast).expect("same size");
        if d.coverage_mismatch_interior > 0 || d.prim_mismatch_interior > 0 {
            failures.push(format!("{algo} against its tie-rule frame: {d:?}"));
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
    // Every primitive of `coincident` shares a face plane with another one.
    for algo in tolerant() {
        let (_, stats, _) = frame("coincident", algo, true);
        let c = &stats.exec.counts;
        assert_eq!(c.tie_free_draws, 0, "{algo}: {c:?}");
        assert!(c.tie_rule_draws > 0, "{algo}: {c:?}");
    }
}

#[test]
fn scs_subtracts_drilled_block_with_plain_depth_tests() {
    // SCS's exits move `z` in the depth-stencil image as in the texture, so its
    // tie-free parity draws test the image: each hole's subtraction and the
    // block's clip run without the tie-rule shader (`plan::scs`).
    let (fast, stats, scene) = frame("drilled_block", Algo::Scs, true);
    let prep = Prepared::new(&scene).expect("prepared");
    let built = plan::build(Algo::Scs, &prep).expect("scs plan");
    let mut parity: Vec<(&str, u64)> = Vec::new();
    let mut pass = "";
    for s in &built.steps {
        match s {
            Step::Pass(p) => pass = p,
            Step::Draw(d) if matches!(d.fragment, Fragment::NearerThan { .. }) => {
                match parity.last_mut() {
                    Some((p, n)) if *p == pass => *n += 1,
                    _ => parity.push((pass, 1)),
                }
            }
            Step::Loop(_) => panic!("the holes are disjoint: no rounds"),
            _ => {}
        }
    }
    // One parity draw per hole, then the block's clip.
    assert_eq!(parity, vec![("subtract", 12), ("clip", 1)]);
    let c = &stats.exec.counts;
    assert_eq!((c.tie_free_draws, c.tie_rule_draws), (13, 0), "{c:?}");
    let reference = peeltrim::reference::render(&scene, SIZE.0, SIZE.1);
    let r = compare(&reference, &fast).expect("same size");
    // `vk_tests::algorithms`' SCS bars.
    assert!(
        r.coverage_mismatch_interior_frac <= 0.0005 && r.prim_mismatch_interior_frac <= 0.0001,
        "against the reference: {r:?}"
    );
    let (slow, slow_stats, _) = frame("drilled_block", Algo::Scs, false);
    assert_eq!(slow_stats.exec.counts.tie_rule_draws, 13);
    let d = compare(&slow, &fast).expect("same size");
    assert_eq!(
        (d.coverage_mismatch_interior, d.prim_mismatch_interior),
        (0, 0),
        "against the tie-rule frame: {d:?}"
    );
}
