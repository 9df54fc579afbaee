//! `peeltrim view` as the second embedding host (docs/embedding.md), in a
//! virtual X server (`xvfb-run`, installed by tools/setup.sh): every frame
//! records the CSG into a swapchain image through `Embedder::record`, two frames
//! in flight, orbiting between frames (the camera moves without an upload), with
//! the validation layer on. The run must exit 0 with no validation message.

use std::process::Command;

use super::scene;

fn view(scene_file: &str, algo: &str, frames: u32) -> std::process::Output {
    view_with(scene_file, algo, frames, &[])
}

fn view_with(
    scene_file: &str,
    algo: &str,
    frames: u32,
    env: &[(&str, &str)],
) -> std::process::Output {
    Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 320x240x24"])
        .arg(env!("CARGO_BIN_EXE_peeltrim"))
        .args(["view", scene_file, "--size", "96x80", "--algo", algo])
        .env("PEELTRIM_VALIDATION", "1")
        .env("PEELTRIM_VIEW_FRAMES", frames.to_string())
        .envs(env.iter().copied())
        .output()
        .expect("xvfb-run is installed (tools/setup.sh installs xvfb)")
}

/// On a device without D32S8 (emulated), the viewer takes D24S8 as `render`
/// does, says so, and draws its frames without a validation message.
#[test]
fn the_viewer_falls_back_to_d24s8_without_d32s8() {
    if !super::require(super::caps().d24s8, "D24S8")
        || !super::require(
            super::caps().xlib_surface,
            "X11 surfaces (VK_KHR_xlib_surface)",
        )
    {
        return;
    }
    let out = view_with(
        &scene("gear.toml"),
        "cst-i",
        2,
        &[("PEELTRIM_EMULATE_NO_D32S8", "1")],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("cannot use D32S8: d24s8 instead"), "{err}");
    assert!(!err.contains("vulkan validation"), "{err}");
    let frames = err
        .lines()
        .filter(|l| l.contains("peeltrim view: frame:"))
        .count();
    assert_eq!(frames, 2, "{err}");
}

#[test]
fn the_viewer_records_the_csg_into_its_swapchain_frames() {
    if !super::require(
        super::caps().xlib_surface,
        "X11 surfaces (VK_KHR_xlib_surface)",
    ) {
        return;
    }
    // shadow_block has a `[light]`: the light's map once, the shadow pass
    // recorded into every frame.
    for (file, algo) in [
        ("gear.toml", "cst-i"),
        ("paper_example.toml", "blister"),
        ("shadow_block.toml", "cst-z"),
    ] {
        let out = view(&scene(file), algo, 6);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{file} {algo}: {err}");
        assert!(!err.contains("vulkan validation"), "{file} {algo}: {err}");
        // Six frames, each with its draw count in the title line.
        let frames = err
            .lines()
            .filter(|l| l.contains("peeltrim view: frame:"))
            .count();
        assert_eq!(frames, 6, "{err}");
        assert!(err.contains(" draws |"), "{err}");
    }
}

/// The viewer draws 4 samples per pixel where the device has them (its
/// swapchain frames resolved from a multisampled colour and depth), 1 with
/// `--samples 1`; an algorithm whose plan is composited (blister-paper) is
/// refused at 4 with a warning and the window keeps running.
#[test]
fn the_viewer_antialiases_where_the_device_can() {
    if !super::require(
        super::caps().xlib_surface,
        "X11 surfaces (VK_KHR_xlib_surface)",
    ) {
        return;
    }
    let four = super::caps().four_samples;
    let run = |algo: &str, extra: &[&str]| {
        let out = Command::new("xvfb-run")
            .args(["-a", "-s", "-screen 0 320x240x24"])
            .arg(env!("CARGO_BIN_EXE_peeltrim"))
            .args([
                "view",
                &scene("gear.toml"),
                "--size",
                "96x80",
                "--algo",
                algo,
            ])
            .args(extra)
            .env("PEELTRIM_VALIDATION", "1")
            .env("PEELTRIM_VIEW_FRAMES", "3")
            .output()
            .expect("xvfb-run is installed (tools/setup.sh installs xvfb)");
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{algo} {extra:?}: {err}");
        assert!(
            !err.contains("vulkan validation"),
            "{algo} {extra:?}: {err}"
        );
        err
    };
    let n = if four { 4 } else { 1 };
    let err = run("cst-i", &[]);
    assert!(err.contains(&format!("{n} sample(s) per pixel")), "{err}");
    let err = run("cst-i", &["--samples", "1"]);
    assert!(err.contains("1 sample(s) per pixel"), "{err}");
    if four {
        let err = run("blister-paper", &[]);
        assert!(err.contains("cannot draw this scene"), "{err}");
        assert!(err.contains("--samples 1"), "{err}");
    }
}
