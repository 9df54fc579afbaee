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

/// The sample-depth probe (`vk::sample_depth_probe`): whether a program run
/// once per sample reads its own sample's depth is measured, and the
/// profile and the sample counts the device accepts follow it (lavapipe
/// interpolates `gl_FragCoord.z` at the sample, SwiftShader gives every
/// sample sample 0's depth).
#[test]
fn multisampling_follows_the_measured_sample_depth() {
    let ctx = super::context();
    let Some(probe) = peeltrim::vk::sample_depth_probe::of(&ctx).expect("the probe draws") else {
        eprintln!("note: {} cannot multisample: not probed", ctx.device_name());
        assert!(!ctx.profile().sample_depth);
        assert_eq!(ctx.supported_samples(), vec![1]);
        return;
    };
    eprintln!(
        "{}: sample-depth probe at {} samples: {} of {} inner pixels pass on every sample",
        ctx.device_name(),
        probe.samples,
        probe.passed,
        probe.pixels
    );
    assert!(probe.pixels > 30, "{probe:?}");
    // Either every inner pixel passes, or (sample 0's depth everywhere) the
    // steep probe fails nearly all of them: never a mixture.
    assert!(
        probe.per_sample() || probe.passed * 10 < probe.pixels,
        "{probe:?}"
    );
    assert_eq!(ctx.profile().sample_depth, probe.per_sample());
    if !probe.per_sample() {
        assert_eq!(ctx.supported_samples(), vec![1]);
        let e = ctx.check_samples(probe.samples).unwrap_err().to_string();
        assert!(
            e.contains("gl_FragCoord.z") && e.contains("--samples 1"),
            "{e}"
        );
    }
    super::assert_clean(&ctx);
}
