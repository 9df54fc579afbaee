//! Where the GPU tests run: the device (`PEELTRIM_TEST_DEVICE=cpu|auto|gpu`,
//! default `cpu`, i.e. lavapipe) and the scenes (`PEELTRIM_TEST_SCENES`, default
//! the crate's `scenes/`), so that the same test binary runs on a hardware GPU
//! (`tools/gpu-run.sh`). On lavapipe the depth bars are the strict figures
//! measured there; elsewhere they are the specification's (`precision`).

use std::path::PathBuf;

use peeltrim::plan::Algo;
use peeltrim::scene::Scene;
use peeltrim::vk::{DeviceChoice, DeviceProfile};
use peeltrim_cli::output::Images;
use peeltrim_cli::render::{DepthSetup, GpuRenderer, RenderOptions};
use peeltrim_reference::precision::spec_depth_check;

/// The device of every GPU test. A malformed value is a test failure, not a
/// silent fallback.
pub fn device() -> DeviceChoice {
    match std::env::var("PEELTRIM_TEST_DEVICE").as_deref() {
        Err(_) | Ok("") | Ok("cpu") => DeviceChoice::Cpu,
        Ok("auto") => DeviceChoice::Auto,
        Ok("gpu") => DeviceChoice::Gpu,
        Ok(other) => panic!("PEELTRIM_TEST_DEVICE='{other}': use cpu, auto or gpu"),
    }
}

/// `algo` on the test device with the default depth set-up (and its fallback),
/// validation on: the options of the layer, kirsch and shadow tests.
pub fn options(algo: Algo) -> RenderOptions {
    RenderOptions {
        algo,
        device: device(),
        depth: DepthSetup::DEFAULT,
        depth_fallback: true,
        validation: true,
        build: Default::default(),
    }
}

/// Whether the strict, lavapipe-measured depth figures apply: only where the
/// device profile interpolates depth from unsnapped vertices (a CPU
/// rasterizer's own profile); a profile that snaps (hardware, or hardware's
/// snapping emulated) gets the specification's bounds.
pub fn strict(profile: &DeviceProfile) -> bool {
    profile.unsnapped_depth
}

/// The profile of the test device (`PEELTRIM_DEVICE_PROFILE` applied), from
/// one context made for it.
pub fn profile() -> DeviceProfile {
    static PROFILE: std::sync::OnceLock<DeviceProfile> = std::sync::OnceLock::new();
    *PROFILE.get_or_init(|| {
        let ctx = peeltrim::vk::Context::new(&peeltrim::vk::ContextDesc {
            device: device(),
            validation: false,
        })
        .expect("a Vulkan device");
        *ctx.profile()
    })
}

/// Whether final shades on the test device run depth-equal draws on D32S8
/// (`DeviceProfile::depth_equal_shades`): the counts of the shade's pieces
/// depend on it.
pub fn depth_equal_shades() -> bool {
    profile().depth_equal_shades(peeltrim::vk::DepthFormat::D32S8)
}

/// The shipped scenes' directory.
pub fn scenes_dir() -> PathBuf {
    match std::env::var_os("PEELTRIM_TEST_SCENES") {
        Some(p) if !p.is_empty() => PathBuf::from(p),
        _ => PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/..")).join("scenes"),
    }
}

/// Whether a render's depth passes: `strict_ok` (the lavapipe figure) on
/// lavapipe; elsewhere that or the specification's bound at 99% of interior
/// pixels.
pub fn depth_passes(
    strict_ok: bool,
    gpu: &GpuRenderer,
    scene: &Scene,
    reference: &Images,
    images: &Images,
) -> bool {
    strict_ok
        || (!strict(gpu.context().profile())
            && spec_depth_check(reference, images, &scene.camera, &gpu.precision()).ratio_p99
                <= 1.0)
}

/// A layer's edge map against the reference's (the bar: at least 99% of
/// the reference's edge pixels matched within a pixel, at most 1% of ours
/// stray); `label` names the algorithm and scene, `layer` is 0-based.
pub fn assert_layer_edges(
    label: &str,
    layer: usize,
    reference: &[bool],
    ours: &[bool],
    (w, h): (u32, u32),
) {
    let a = peeltrim_reference::edge_compare::compare_edges(reference, ours, w, h);
    eprintln!(
        "{label} layer {}: edges ref {} ours {} matched {:.2}% stray {:.2}%",
        layer + 1,
        a.reference_edges,
        a.our_edges,
        a.matched_frac * 100.0,
        a.stray_frac * 100.0
    );
    assert!(
        a.reference_edges > 0,
        "{label} layer {}: the reference finds no edge",
        layer + 1
    );
    assert!(
        a.matched_frac >= 0.99 && a.stray_frac <= 0.01,
        "{label} layer {}: {a:?}",
        layer + 1
    );
}

/// Whether the test device can use `setup`'s depth format
/// (`DeviceProfile::depth_formats`; SwiftShader and AMD GPUs have no D24S8).
pub fn has_depth(setup: DepthSetup) -> bool {
    profile().depth_formats.usable(setup.exec_format().0.vk())
}

/// `want`, or D32S8 where the device lacks `want`'s format (D24S8 on
/// SwiftShader), said on stderr: a test that renders on D24S8 for its
/// quantized depth checks the same images against the reference on D32S8.
pub fn usable(want: DepthSetup) -> DepthSetup {
    match has_depth(want) {
        true => want,
        false => {
            eprintln!(
                "note: the device lacks {}: {} instead",
                want.name(),
                DepthSetup::D32S8.name()
            );
            DepthSetup::D32S8
        }
    }
}

/// `DepthSetup::ALL` without the set-ups whose format the device lacks, each
/// left out with a note.
pub fn usable_setups() -> Vec<DepthSetup> {
    DepthSetup::ALL
        .into_iter()
        .filter(|&d| {
            let ok = has_depth(d);
            if !ok {
                eprintln!("note: the device lacks {}: not run", d.name());
            }
            ok
        })
        .collect()
}
