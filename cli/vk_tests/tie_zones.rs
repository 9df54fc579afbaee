//! The final shade's tie rule only inside on-screen tie zones
//! (`plan::tie_zones`): a frame whose shade runs the rule only there, and the
//! depth-equal shade over the rest of each mesh, gives the pixels of the frame
//! whose shade runs the rule on every draw, and the reference's.

use peeltrim::plan::{self, Algo};
use peeltrim_reference::compare::compare;
use peeltrim_cli::render::{DepthSetup, GpuRenderer};

use crate::algorithms::shipped_with_reference;

#[test]
fn zone_scissored_shading_gives_the_all_rule_frames_pixels() {
    let mut failures = Vec::new();
    for name in ["speckle", "assembly"] {
        let (scene, prep, reference) = shipped_with_reference(name);
        for depth in [DepthSetup::DEFAULT, DepthSetup::D32S8] {
            for algo in Algo::ALL
                .into_iter()
                .filter(|a| !matches!(a, Algo::Reference | Algo::BlisterPaper))
            {
                let plan = plan::build(algo, &prep).unwrap_or_else(|e| panic!("{algo}: {e}"));
                let mut gpu = GpuRenderer::new(&scene, crate::setup::device(), depth, true)
                    .expect("a Vulkan device (lavapipe)");
                let mut run = |zoned: bool| {
                    gpu.set_fixed_shade(zoned);
                    gpu.frame(&plan).unwrap_or_else(|e| panic!("{algo}: {e}"))
                };
                let (rule, zoned) = (run(false), run(true));
                let msgs = gpu.validation_messages();
                assert!(msgs.is_empty(), "{algo}: validation messages: {msgs:#?}");
                let at = format!("{name} {algo} {depth:?}");
                let (r, z) = (&rule.stats.exec.counts, &zoned.stats.exec.counts);
                assert_eq!(r.shade_fixed_draws, 0, "{at}");
                // Both scenes have meshes flush with others: rule pieces where
                // they meet, depth-equal pieces elsewhere, and fewer pixels
                // under the rule.
                assert!(
                    z.shade_rule_draws > 0 && z.shade_fixed_draws > 0,
                    "{at}: {z:?}"
                );
                assert!(
                    z.shade_rule_pixels < r.shade_rule_pixels,
                    "{at}: {} rule pixels, {} without zones",
                    z.shade_rule_pixels,
                    r.shade_rule_pixels
                );
                let d = compare(&rule.images, &zoned.images).expect("same size");
                // Depth: the rule's plane depth against the raster depth, equal
                // up to f32 rounding (view units, scenes a few units away).
                if d.coverage_mismatch > 0
                    || d.prim_mismatch > 0
                    || d.depth_abs_err_max_interior > 2e-5
                {
                    failures.push(format!("{at} against the all-rule frame: {d:?}"));
                }
                let c = compare(&reference, &zoned.images).expect("same size");
                let cr = compare(&reference, &rule.images).expect("same size");
                // No worse than the all-rule frame, and within 0.05%.
                if c.coverage_mismatch_interior > cr.coverage_mismatch_interior
                    || c.prim_mismatch_interior > cr.prim_mismatch_interior
                    || c.coverage_mismatch_interior_frac > 0.0005
                    || c.prim_mismatch_interior_frac > 0.0005
                {
                    failures.push(format!("{at} against the reference: {c:?}"));
                }
                eprintln!(
                    "{at}: rule {} draws {} px -> {} draws {} px (+{} depth-equal); \
                     against the reference {} coverage, {} prim (interior)",
                    r.shade_rule_draws,
                    r.shade_rule_pixels,
                    z.shade_rule_draws,
                    z.shade_rule_pixels,
                    z.shade_fixed_draws,
                    c.coverage_mismatch_interior,
                    c.prim_mismatch_interior
                );
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
