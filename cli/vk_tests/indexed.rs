//! Indexed draws (`GpuScene`'s and `corners`'s docs, docs/executor.md):
//! every mesh draw is indexed, from the mesh's shared corners where the program
//! reads no interpolated output and from its lit corners (each triangle's own
//! provoking vertex carries its face normal) where it does. The frame must be
//! the non-indexed frame bit for bit (colour, ids and depth: the same
//! triangles from the same f32 positions, so the depth-equal tests between
//! draws from different sets still pass), with or without the emulated vertex
//! snapping, and the same draws and triangles must be recorded. Validation on
//! throughout.

use peeltrim::plan::{self, Algo, Prepared};
use peeltrim_reference::compare::compare;
use peeltrim_cli::render::{DepthSetup, FrameStats, GpuRenderer};
use peeltrim::vk::RoundingEmulation;

use crate::algorithms::{shipped, shipped_with_reference};

/// One frame of `algo` on `scene`, indexed or not.
fn frame(
    scene: &peeltrim::scene::Scene,
    prep: &Prepared,
    algo: Algo,
    indexed: bool,
    rounding: Option<RoundingEmulation>,
) -> (peeltrim_cli::output::Images, FrameStats) {
    let plan = plan::build(algo, prep).unwrap_or_else(|e| panic!("{algo}: {e}"));
    let mut gpu = GpuRenderer::new(scene, crate::setup::device(), DepthSetup::DEFAULT, true)
        .expect("a Vulkan device (lavapipe)");
    gpu.set_indexed(indexed).expect("the soup");
    gpu.set_rounding_emulation(rounding);
    let f = gpu.frame(&plan).unwrap_or_else(|e| panic!("{algo}: {e}"));
    let msgs = gpu.validation_messages();
    assert!(msgs.is_empty(), "{algo}: validation messages: {msgs:#?}");
    (f.images, f.stats)
}

/// `algo` on the shipped scene `name`: the indexed frame is the non-indexed
/// one, bit for bit; it drew every call indexed, the other none.
fn same_frames(name: &str, algo: Algo, rounding: Option<RoundingEmulation>) {
    let scene = shipped(name);
    let prep = Prepared::new(&scene).expect("prepared");
    let (on, s_on) = frame(&scene, &prep, algo, true, rounding);
    let (off, s_off) = frame(&scene, &prep, algo, false, rounding);
    let (a, b) = (&s_on.exec.counts, &s_off.exec.counts);
    let what = format!("{name} {algo} {rounding:?}");
    assert!(a.draw_calls > 0, "{what}: no mesh draw: {a:?}");
    assert_eq!(
        a.indexed_draw_calls, a.draw_calls,
        "{what}: a mesh draw was not indexed"
    );
    assert_eq!(b.indexed_draw_calls, 0, "{what}: switched off, yet indexed");
    assert_eq!(a.draw_calls, b.draw_calls, "{what}");
    assert_eq!(a.triangles, b.triangles, "{what}");
    assert!(
        on.color == off.color && on.prim == off.prim,
        "{what}: colour or ids differ: {:?}",
        compare(&off, &on)
    );
    let bits = |d: &[f32]| d.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert!(bits(&on.depth) == bits(&off.depth), "{what}: depths differ");
}

#[test]
fn indexed_draws_match_non_indexed_on_the_subtraction_scenes() {
    for name in ["drilled_block", "complex", "nonconvex_obj"] {
        for algo in [
            Algo::Scs,
            Algo::Goldfeather,
            Algo::CstI,
            Algo::Blister,
            Algo::Trickle,
        ] {
            same_frames(name, algo, None);
        }
    }
}

#[test]
fn indexed_draws_match_non_indexed_on_coincident_faces_and_snapped_vertices() {
    // Coincident faces: the tie rule's depth-equal comparisons between an
    // indexed depth pass and a non-indexed shade are where a difference in the
    // positions would show; the snapping (8 bits, the H200's) moves both alike.
    for algo in [Algo::Scs, Algo::Goldfeather, Algo::CstZ] {
        same_frames("coincident", algo, None);
        same_frames("coincident", algo, Some(RoundingEmulation::EIGHT_BITS));
        same_frames("many_50", algo, Some(RoundingEmulation::EIGHT_BITS));
    }
}

#[test]
fn indexed_frames_match_the_reference() {
    let (scene, prep, reference) = shipped_with_reference("many_50");
    for algo in [Algo::Scs, Algo::Goldfeather] {
        let (img, stats) = frame(&scene, &prep, algo, true, None);
        assert!(stats.exec.counts.indexed_draw_calls > 0, "{algo}");
        let r = compare(&reference, &img).expect("same size");
        assert!(
            r.coverage_mismatch_interior == 0 && r.prim_mismatch_interior == 0,
            "{algo} against the reference: {r:?}"
        );
    }
}
