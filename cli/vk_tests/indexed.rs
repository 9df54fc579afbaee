//! Indexed draws (`GpuScene`'s and `corners`'s docs): every mesh draw is
//! indexed, from the mesh's shared corners where the program reads no
//! interpolated output and from its lit corners (each triangle's own provoking
//! vertex carries its face normal) where it does, with or without the emulated
//! vertex snapping, and the frames match the reference. Validation on
//! throughout.

use peeltrim::plan::{self, Algo, Prepared};
use peeltrim::vk::RoundingEmulation;
use peeltrim_cli::render::{DepthSetup, FrameStats, GpuRenderer};
use peeltrim_reference::compare::compare;

use crate::algorithms::{shipped, shipped_with_reference};

/// One frame of `algo` on `scene`.
fn frame(
    scene: &peeltrim::scene::Scene,
    prep: &Prepared,
    algo: Algo,
    rounding: Option<RoundingEmulation>,
) -> (peeltrim_cli::output::Images, FrameStats) {
    let plan = plan::build(algo, prep).unwrap_or_else(|e| panic!("{algo}: {e}"));
    let mut gpu = GpuRenderer::emulating(
        scene,
        crate::setup::device(),
        DepthSetup::DEFAULT,
        true,
        rounding,
    )
    .expect("a Vulkan device (lavapipe)");
    let f = gpu.frame(&plan).unwrap_or_else(|e| panic!("{algo}: {e}"));
    let msgs = gpu.validation_messages();
    assert!(msgs.is_empty(), "{algo}: validation messages: {msgs:#?}");
    (f.images, f.stats)
}

/// `algo` on the shipped scene `name`: it drew every call indexed.
fn all_indexed(name: &str, algo: Algo, rounding: Option<RoundingEmulation>) {
    let scene = shipped(name);
    let prep = Prepared::new(&scene).expect("prepared");
    let (_, s_on) = frame(&scene, &prep, algo, rounding);
    let a = &s_on.exec.counts;
    let what = format!("{name} {algo} {rounding:?}");
    assert!(a.draw_calls > 0, "{what}: no mesh draw: {a:?}");
    assert_eq!(
        a.indexed_draw_calls, a.draw_calls,
        "{what}: a mesh draw was not indexed"
    );
}

#[test]
fn every_draw_is_indexed_on_the_subtraction_scenes() {
    for name in ["drilled_block", "complex", "nonconvex_obj"] {
        for algo in [
            Algo::Scs,
            Algo::Goldfeather,
            Algo::CstI,
            Algo::Blister,
            Algo::Trickle,
        ] {
            all_indexed(name, algo, None);
        }
    }
}

#[test]
fn every_draw_is_indexed_on_coincident_faces_and_snapped_vertices() {
    for algo in [Algo::Scs, Algo::Goldfeather, Algo::CstZ] {
        all_indexed("coincident", algo, None);
        all_indexed("coincident", algo, Some(RoundingEmulation::EIGHT_BITS));
        all_indexed("many_50", algo, Some(RoundingEmulation::EIGHT_BITS));
    }
}

#[test]
fn indexed_frames_match_the_reference() {
    let (scene, prep, reference) = shipped_with_reference("many_50");
    for algo in [Algo::Scs, Algo::Goldfeather] {
        let (img, stats) = frame(&scene, &prep, algo, None);
        assert!(stats.exec.counts.indexed_draw_calls > 0, "{algo}");
        let r = compare(&reference, &img).expect("same size");
        assert!(
            r.coverage_mismatch_interior == 0 && r.prim_mismatch_interior == 0,
            "{algo} against the reference: {r:?}"
        );
    }
}
