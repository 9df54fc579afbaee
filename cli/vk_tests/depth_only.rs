//! Depth-only images for plans that use no stencil (`plan::formats`,
//! `DepthFormat::vk_for`): such a plan gets `D32_SFLOAT` and renders the
//! `D32_SFLOAT_S8_UINT` images bit for bit with fewer bytes cleared; a plan
//! that counts parity in the stencil keeps `D32_SFLOAT_S8_UINT` and renders
//! right; plans of both kinds alternating on one executor each get their
//! format back. Validation on throughout.

use ash::vk;
use peeltrim::plan::formats::needs_stencil;
use peeltrim::plan::{build, Algo, Plan, Prepared};
use peeltrim::scene::Scene;
use peeltrim::vk::{DepthFormat, ExecDesc, Executor, Frame};
use peeltrim_cli::output::Images;
use peeltrim_reference::compare::compare;

use crate::algorithms::load_text;
// A block minus a bore (the subtraction counts parity in the stencil), and
// the camera of both scenes.
use crate::direct_shade::{CAMERA, HOUSING};
use crate::{assert_clean, context};

/// One box: every product algorithm draws it directly, no stencil.
const ONE_BOX: &str = r##"
[[primitive]]
name = "Block"
shape = "box"
size = [2.0, 1.5, 1.0]
[[solid]]
name = "b"
expr = "Block"
"##;

/// An executor of `scene` on D32S8; without `depth_only`, on the profile of
/// a device that cannot use D32 (`DeviceProfile::depth_formats`).
fn executor(ctx: &peeltrim::vk::Context, scene: &Scene, depth_only: bool) -> Executor {
    let desc = ExecDesc {
        width: scene.render.width,
        height: scene.render.height,
        depth_format: DepthFormat::D32S8,
        reversed_z: true,
        samples: 1,
    };
    let mut profile = *ctx.profile();
    profile.depth_formats.d32 &= depth_only;
    let mut e = Executor::new(&ctx.with_profile(profile), &desc).expect("executor");
    e.upload(scene).expect("upload");
    e
}

fn frame(e: &mut Executor, plan: &Plan, what: &str) -> (Frame, vk::Format) {
    let f = e.frame(plan).unwrap_or_else(|err| panic!("{what}: {err}"));
    let format = e.depth_images_format().expect("a frame made its images");
    (f, format)
}

/// No interior coverage or id mismatch against the reference.
fn matches_reference(reference: &Images, img: &Images, what: &str) {
    let d = compare(reference, img).expect("same size");
    assert!(
        d.coverage_mismatch_interior == 0 && d.prim_mismatch_interior == 0,
        "{what} against the reference: {d:?}"
    );
}

#[test]
fn a_stencil_free_plan_gets_d32_and_renders_d32s8s_images_bit_for_bit() {
    let ctx = context();
    let scene = load_text(&format!("{CAMERA}{ONE_BOX}"), "one box");
    let prep = Prepared::new(&scene).expect("prepared");
    let reference = peeltrim_reference::render(&scene, scene.render.width, scene.render.height);
    for algo in [Algo::Scs, Algo::Goldfeather, Algo::CstI] {
        let plan = build(algo, &prep).expect("plan");
        assert!(!needs_stencil(&plan), "{algo}: {:?}", plan.steps);
        let (only, f_only) = frame(&mut executor(&ctx, &scene, true), &plan, "d32");
        let (both, f_both) = frame(&mut executor(&ctx, &scene, false), &plan, "d32s8");
        assert_eq!(f_only, vk::Format::D32_SFLOAT, "{algo}");
        assert_eq!(f_both, vk::Format::D32_SFLOAT_S8_UINT, "{algo}");
        assert!(
            only.images == both.images,
            "{algo}: D32 and D32S8 images differ: {:?}",
            compare(&both.images, &only.images)
        );
        matches_reference(&reference, &only.images, &format!("{algo} d32"));
        let (a, b) = (&only.stats.counts, &both.stats.counts);
        assert_eq!(a.cleared_pixels, b.cleared_pixels, "{algo}");
        assert!(
            a.cleared_bytes < b.cleared_bytes,
            "{algo}: {} bytes cleared with D32, {} with D32S8",
            a.cleared_bytes,
            b.cleared_bytes
        );
    }
    assert_clean(&ctx);
}

#[test]
fn a_plan_that_counts_in_the_stencil_keeps_d32s8_and_renders_right() {
    let ctx = context();
    let scene = load_text(&format!("{CAMERA}{HOUSING}"), "housing");
    let prep = Prepared::new(&scene).expect("prepared");
    let reference = peeltrim_reference::render(&scene, scene.render.width, scene.render.height);
    for algo in [Algo::Scs, Algo::Goldfeather] {
        let plan = build(algo, &prep).expect("plan");
        assert!(needs_stencil(&plan), "{algo}");
        let (f, format) = frame(&mut executor(&ctx, &scene, true), &plan, "housing");
        assert_eq!(format, vk::Format::D32_SFLOAT_S8_UINT, "{algo}");
        matches_reference(&reference, &f.images, &format!("{algo}"));
    }
    assert_clean(&ctx);
}

/// One executor, plans alternating between the kinds: once a plan needed
/// stencil its images stay (a stencil-free plan runs on them too), and each
/// frame is the one a fresh executor gives.
#[test]
fn plans_of_both_kinds_alternate_on_one_executor() {
    let ctx = context();
    let scene = load_text(&format!("{CAMERA}{HOUSING}"), "housing");
    let prep = Prepared::new(&scene).expect("prepared");
    // The housing's subtraction (stencil), and the block alone (mesh 0 of
    // both scenes) drawn directly.
    let with = build(Algo::Scs, &prep).expect("plan");
    let one = Prepared::new(&load_text(&format!("{CAMERA}{ONE_BOX}"), "one box")).unwrap();
    let without = build(Algo::Scs, &one).expect("plan");
    assert!(needs_stencil(&with) && !needs_stencil(&without));
    let fresh = |p: &Plan| {
        frame(&mut executor(&ctx, &scene, true), p, "fresh")
            .0
            .images
    };
    let (want_with, want_without) = (fresh(&with), fresh(&without));
    let mut e = executor(&ctx, &scene, true);
    for (i, p) in [&without, &with, &without, &with].into_iter().enumerate() {
        let (f, format) = frame(&mut e, p, "alternating");
        let (want, want_format) = match (needs_stencil(p), i) {
            (true, _) => (&want_with, vk::Format::D32_SFLOAT_S8_UINT),
            (false, 0) => (&want_without, vk::Format::D32_SFLOAT),
            (false, _) => (&want_without, vk::Format::D32_SFLOAT_S8_UINT),
        };
        assert_eq!(format, want_format, "frame {i}");
        assert!(
            f.images == *want,
            "frame {i}: {:?}",
            compare(want, &f.images)
        );
    }
    assert_clean(&ctx);
}
