//! The depth probe (`vk::depth_probe`): the device's depth interpolation is
//! measured, and the profile follows the measurement, never the device type
//! (lavapipe and SwiftShader are both CPU devices; only lavapipe interpolates
//! depth from unsnapped vertices).

use peeltrim::vk::depth_probe;
use peeltrim::vk::profile::{ProfileChoice, PROFILE_ENV};

#[test]
fn the_profile_follows_the_measured_depth_interpolation() {
    let ctx = super::context();
    let probe = depth_probe::of(&ctx)
        .expect("the probe draws")
        .expect("a D32 format (every device has D32 or D32S8 here)");
    eprintln!(
        "{}: depth probe over {} pixel centres: {:.2e} from the unsnapped plane, {:.2e} from the plane snapped to 2^-{} pixel: {}",
        ctx.device_name(),
        probe.pixels,
        probe.unsnapped_error,
        probe.snapped_error,
        probe.subpixel_bits,
        if probe.unsnapped() { "unsnapped" } else { "snapped" }
    );
    assert!(probe.pixels > 30, "{probe:?}");
    let choice = ProfileChoice::from_env().expect(PROFILE_ENV);
    let profile = ctx.profile();
    match choice {
        ProfileChoice::Device => assert_eq!(profile.unsnapped_depth, probe.unsnapped()),
        ProfileChoice::Hardware => assert!(!profile.unsnapped_depth),
    }
    super::assert_clean(&ctx);
}
