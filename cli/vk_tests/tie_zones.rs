//! The final shade's tie rule only inside on-screen tie zones
//! (`plan::tie_zones`): a frame whose shade runs the rule only there, and the
//! depth-equal shade over the rest of each mesh, gives the reference's
//! pixels. Where the device profile allows no depth-equal shade
//! (`DeviceProfile::depth_equal_shades`) every shade draw keeps the rule.

use peeltrim::plan::{self, Algo};
use peeltrim_cli::render::{DepthSetup, GpuRenderer};
use peeltrim_reference::compare::compare;

use crate::algorithms::shipped_with_reference;

#[test]
fn zone_scissored_shading_matches_the_reference() {
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
                let zoned = gpu.frame(&plan).unwrap_or_else(|e| panic!("{algo}: {e}"));
                let msgs = gpu.validation_messages();
                assert!(msgs.is_empty(), "{algo}: validation messages: {msgs:#?}");
                let at = format!("{name} {algo} {depth:?}");
                let z = &zoned.stats.exec.counts;
                let shades = gpu
                    .context()
                    .profile()
                    .depth_equal_shades(depth.exec_format().0);
                // Both scenes have meshes flush with others: rule pieces where
                // they meet, depth-equal pieces elsewhere.
                match shades {
                    true => assert!(
                        z.shade_rule_draws > 0 && z.shade_fixed_draws > 0,
                        "{at}: {z:?}"
                    ),
                    false => assert_eq!(z.shade_fixed_draws, 0, "{at}: {z:?}"),
                }
                let c = compare(&reference, &zoned.images).expect("same size");
                // Within 0.05%.
                if c.coverage_mismatch_interior_frac > 0.0005
                    || c.prim_mismatch_interior_frac > 0.0005
                {
                    failures.push(format!("{at} against the reference: {c:?}"));
                }
                eprintln!(
                    "{at}: rule {} draws {} px (+{} depth-equal); \
                     against the reference {} coverage, {} prim (interior)",
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
