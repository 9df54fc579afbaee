//! Hardening from the user's side: messages for common mistakes, the memory
//! budget refusing at once (with the estimate, the budget and the way out)
//! instead of aborting, large expressions rendered or refused in bounded time,
//! and the bench finishing (table and plots) without any installed font.

use std::path::Path;
use std::time::{Duration, Instant};

use super::{assert_error, run, scene, stderr, tmp};

const AB: &str = "[[primitive]]\nname = \"A\"\nshape = \"box\"\nsize = [1.0, 1.0, 1.0]\n\
                  [[primitive]]\nname = \"B\"\nshape = \"sphere\"\nradius = 0.6\nsegments = 16\n";

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn out_naming_a_file_says_a_folder_is_needed() {
    let dir = tmp("outfile");
    let file = write(&dir, "taken", "not a folder");
    let gear = scene("gear.toml");
    for cmd in [
        super::render_args(&gear, "8x8", &[], &file),
        vec![
            "bench",
            &gear[..],
            "--algos",
            "reference",
            "--size",
            "8x8",
            "--out",
            &file,
        ],
    ] {
        let o = run(&cmd);
        assert_error(
            &o,
            &["taken is a file, not a folder", "--out needs a folder"],
        );
        assert_eq!(o.status.code(), Some(1));
    }
    // A folder below a file: the file is named.
    let below = format!("{file}/sub");
    assert_error(
        &run(&super::render_args(&gear, "8x8", &[], &below)),
        &["taken is a file, not a folder"],
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "not a folder");
}

#[test]
fn openscad_and_other_files_say_what_a_scene_is() {
    let dir = tmp("scad");
    let scad = write(
        &dir,
        "model.scad",
        "difference() {\n  cube(2, center=true);\n  sphere(1.3);\n}\n",
    );
    // Without openscad: how to install it, or to export the .csg.
    let o = super::bin()
        .args(["render", &scad])
        .env("PEELTRIM_OPENSCAD", "/nonexistent/openscad")
        .env("PEELTRIM_CACHE_DIR", dir.join("cache"))
        .output()
        .unwrap();
    assert_error(
        &o,
        &[
            "model.scad",
            "OpenSCAD source file",
            "apt-get install openscad",
            "Export as CSG",
        ],
    );
    assert_eq!(o.status.code(), Some(1));
    let other = write(&dir, "model.txt", "difference() {\n  cube(2);\n}\n");
    assert_error(
        &run(&["plan", &other, "--algo", "cst-i"]),
        &[
            "model.txt:1:",
            "not named .toml and is not valid TOML",
            "OpenSCAD's CSG export",
        ],
    );
    // A .toml file keeps the plain TOML message.
    let toml = write(&dir, "broken.toml", "difference() {\n");
    let o = run(&["plan", &toml]);
    assert_error(&o, &["broken.toml:1:"]);
    assert!(!stderr(&o).contains("not named .toml"));
}

#[test]
fn a_huge_sphere_is_refused_against_the_budget() {
    let dir = tmp("sphere");
    let p = write(
        &dir,
        "sphere.toml",
        "[[primitive]]\nname = \"S\"\nshape = \"sphere\"\nradius = 1.0\nsegments = 4096\n[csg]\nexpr = \"S\"\n",
    );
    let t = Instant::now();
    let o = run(&["render", &p, "--size", "32x32", "--memory-budget", "1G"]);
    assert_error(
        &o,
        &[
            "sphere.toml:1: primitive[1] \"S\": segments",
            "4096 segments × 2048 rings",
            "over the budget of 1.0 GiB",
            "lower `segments`",
            "--memory-budget",
        ],
    );
    assert!(t.elapsed() < Duration::from_secs(5), "{:?}", t.elapsed());
    assert_error(
        &run(&["render", &p, "--memory-budget", "lots"]),
        &["'lots' is not a memory size", "e.g. 2G"],
    );
}

/// `n` leaves over A and B joined by `op` (" " or " + ").
fn chain(n: usize, op: &str) -> String {
    (0..n)
        .map(|i| if i % 2 == 0 { "A" } else { "B" })
        .collect::<Vec<_>>()
        .join(op)
}

fn expr_scene(dir: &Path, name: &str, expr: &str) -> String {
    write(dir, name, &format!("{AB}[csg]\nexpr = \"{expr}\"\n"))
}

/// Large expressions: CST refuses the quadratic ones at once, with the
/// way out; unions of repeated leaves render.
#[test]
fn large_expressions_render_or_are_refused_at_once() {
    let dir = tmp("large");
    let out = dir.join("o");
    let out = out.to_str().unwrap();
    let mut deep = String::new();
    for _ in 0..10_000 {
        deep.push_str("(A - ");
    }
    deep.push('B');
    deep.push_str(&")".repeat(10_000));
    let cases = [
        ("inter1e4.toml", chain(10_000, " ")),
        ("deep1e4.toml", deep),
        ("inter1e5.toml", chain(100_000, " ")),
    ];
    for (name, expr) in &cases {
        let p = expr_scene(&dir, name, expr);
        for args in [
            vec!["plan", &p[..], "--algo", "cst-i"],
            super::render_args(&p, "16x16", &["--algo", "cst-i"], out),
        ] {
            let t = Instant::now();
            let o = run(&args);
            let took = t.elapsed();
            assert_error(
                &o,
                &["cst-i trims each of the", "active zone", "--algo blister"],
            );
            // Debug builds are slower; release takes well under a second.
            assert!(
                took < Duration::from_secs(10),
                "{name} {}: {took:?}",
                args[0]
            );
            eprintln!("{name} {}: refused in {took:?}", args[0]);
        }
    }
    // 10^5 unions: every zone is the universe; duplicate leaves draw nothing new.
    let p = expr_scene(&dir, "union1e5.toml", &chain(100_000, " + "));
    let t = Instant::now();
    let o = run(&["plan", &p, "--algo", "cst-i"]);
    assert!(o.status.success(), "{}", stderr(&o));
    eprintln!("union1e5 plan: {:?}", t.elapsed());
    let out = dir.join("u");
    let o = run(&super::render_args(
        &p,
        "32x32",
        &["--algo", "cst-i"],
        out.to_str().unwrap(),
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    let refp = dir.join("uref");
    let small = expr_scene(&dir, "union2.toml", "A + B");
    let o = run(&super::render_args(
        &small,
        "32x32",
        &["--algo", "reference"],
        refp.to_str().unwrap(),
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["compare", refp.to_str().unwrap(), out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["coverage_mismatch_interior"], 0, "{report}");
    assert_eq!(report["prim_mismatch_interior"], 0, "{report}");
}

#[test]
fn huge_images_are_refused_clearly_by_every_algorithm() {
    let algos = [
        "reference",
        "goldfeather",
        "goldfeather-layered",
        "trickle",
        "blister",
        "cst-z",
        "cst-i",
        "cst-g",
        "blister-paper",
    ];
    for algo in algos {
        let o = run(&[
            "render",
            &scene("gear.toml"),
            "--algo",
            algo,
            "--size",
            "16384x16384",
            "--memory-budget",
            "1G",
            "--out",
            "/nonexistent-never-written",
        ]);
        assert_error(
            &o,
            &[
                "16384x16384 frame would need about",
                "over the budget of 1.0 GiB",
                "smaller --size",
            ],
        );
        assert_eq!(o.status.code(), Some(1), "{algo}");
    }
}

/// Plots are an optional extra drawn with the embedded font: the bench finishes
/// with its table whatever fonts the machine has, and a plot that cannot be
/// written is one warning, not a failed run.
#[test]
fn bench_finishes_with_its_table_without_system_fonts() {
    let dir = tmp("bench-font");
    let bench = |out: &std::path::Path| {
        run(&[
            "bench",
            &scene("gear.toml"),
            "--algos",
            "reference",
            "--size",
            "16x16",
            "--frames",
            "1",
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let out = dir.join("out");
    let o = bench(&out);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("no plots"), "{}", stderr(&o));
    assert!(std::fs::read_to_string(out.join("summary.md"))
        .unwrap()
        .contains("reference"));
    // Where `plots` cannot be created, the run still succeeds.
    let out2 = dir.join("out2");
    std::fs::create_dir_all(&out2).unwrap();
    std::fs::write(out2.join("plots"), "a file in the way").unwrap();
    let o = bench(&out2);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("warning: no plots"), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("reference"));
    assert!(out2.join("summary.md").exists() && out2.join("results.json").exists());
}

/// A device without D32S8 (emulated with `PEELTRIM_EMULATE_NO_D32S8=1`): `render`
/// and `bench` take D24S8 by the one rule and say why; a set-up asked for by name
/// is not replaced but refused with the flag to change.
#[test]
fn without_d32s8_render_and_bench_fall_back_to_d24s8() {
    if !super::require(super::caps().d24s8, "D24S8") {
        return;
    }
    let dir = tmp("nod32");
    let s = scene("gear.toml");
    let no_d32 = |args: &[&str]| {
        super::bin()
            .env("PEELTRIM_EMULATE_NO_D32S8", "1")
            .args(args)
            .output()
            .unwrap()
    };
    let out = dir.join("render");
    let o = no_d32(&super::render_args(
        &s,
        "24x24",
        &["--algo", "cst-i"],
        out.to_str().unwrap(),
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    let stats = super::layers_cli::stats(&out);
    assert_eq!(stats["depth_setup"], "d24s8");
    let why = stats["depth_setup_fallback"].as_str().unwrap_or_default();
    assert!(why.contains("cannot use D32S8: d24s8 instead"), "{stats}");

    let out = dir.join("bench");
    let o = no_d32(&[
        "bench",
        &s,
        "--algos",
        "cst-i,blister",
        "--size",
        "24x24",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--no-images",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let results: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("results.json")).unwrap()).unwrap();
    let gpu: Vec<&serde_json::Value> = results
        .as_array()
        .expect("results.json is a list of runs")
        .iter()
        .filter(|r| r["algo"] != "reference")
        .collect();
    assert_eq!(gpu.len(), 2, "{results}");
    for r in gpu {
        assert!(r["failure"].is_null(), "{r}");
        assert_eq!(r["depth_setup"], "d24s8", "{r}");
        let why = r["depth_setup_fallback"].as_str().unwrap_or_default();
        assert!(why.contains("cannot use D32S8"), "{r}");
        // The image is still right: the error against the reference is small.
        let mismatch = r["error"]["coverage_mismatch_interior_frac"].as_f64();
        assert!(mismatch.is_some_and(|m| m < 0.01), "{r}");
    }

    // Asked for by name: not replaced; the run says which flag to change.
    let named = dir.join("named");
    let o = no_d32(&super::render_args(
        &s,
        "24x24",
        &["--algo", "cst-i", "--depth-format", "d32s8"],
        named.to_str().unwrap(),
    ));
    assert_error(&o, &["D32S8", "--depth-format"]);
}

/// `PEELTRIM_DEVICE_PROFILE` with a value it does not accept: `render` stops
/// with an error that names the variable and the accepted values (no panic);
/// `hardware` renders.
#[test]
fn an_unknown_device_profile_is_a_clear_error() {
    let dir = tmp("profile");
    let s = scene("gear.toml");
    let run = |profile: &str, out: &str| {
        super::bin()
            .env("PEELTRIM_DEVICE_PROFILE", profile)
            .args(super::render_args(&s, "24x24", &["--algo", "scs"], out))
            .output()
            .unwrap()
    };
    let out = dir.join("bad");
    let o = run("gpu", out.to_str().unwrap());
    assert!(!o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("PEELTRIM_DEVICE_PROFILE='gpu'")
            && e.contains("'device'")
            && e.contains("'hardware'"),
        "{e}"
    );
    assert!(!e.contains("panicked"), "{e}");
    let out = dir.join("hardware");
    let o = run("hardware", out.to_str().unwrap());
    assert!(o.status.success(), "{}", stderr(&o));
}

/// One voice for every error: `peeltrim: error: …` on stderr; exit 2 for a
/// usage error (a bad flag or value, clap's included), 1 for input and
/// runtime errors; `--help` and `--version` succeed.
#[test]
fn errors_speak_one_voice_with_usage_2_and_input_1() {
    let gear = scene("gear.toml");
    let usage: [&[&str]; 6] = [
        &["render", &gear, "--no-such-flag"],
        &["render", &gear, "--algo", "zbuffer"],
        &["render"],
        &["bench", &gear, "--frames", "0"],
        &["render", &gear, "--depth-format", "d24s8", "--reversed-z"],
        &["frobnicate"],
    ];
    for args in usage {
        let o = run(args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(e.starts_with("peeltrim: error: "), "{args:?}: {e}");
        assert!(!e.contains("\nerror:"), "{args:?}: {e}");
    }
    let input: [&[&str]; 2] = [
        &["render", "/nonexistent/scene.toml"],
        &["plan", "/nonexistent/scene.toml", "--algo", "cst-i"],
    ];
    for args in input {
        let o = run(args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert!(e.starts_with("peeltrim: error: "), "{args:?}: {e}");
    }
    for args in [&["--help"][..], &["--version"], &["render", "--help"]] {
        let o = run(args);
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
        assert!(!o.stdout.is_empty());
    }
}

/// The messages of common mistakes, each saying what is accepted in words.
#[test]
fn common_mistakes_get_plain_messages() {
    let gear = scene("gear.toml");
    let o = run(&["render", &gear, "--layers", "0"]);
    assert_error(&o, &["'0' is not a number of layers", "at least 1"]);
    assert!(!stderr(&o).contains("4294967295"), "{}", stderr(&o));
    // A negative size is read as the value it was meant as, and refused.
    let o = run(&["render", &gear, "--size", "-200x200"]);
    assert_error(&o, &["size '-200x200' is not WxH with positive integers"]);
    let o = run(&["bench", &gear, "--frames", "0"]);
    assert_error(&o, &["'0' is not a number of frames", "at least 1"]);
    // The missing file is named once.
    let dir = tmp("mistakes");
    let o = run(&[
        "bench",
        "/tmp/none-peeltrim.toml",
        "--out",
        dir.join("b").to_str().unwrap(),
    ]);
    assert_error(&o, &["/tmp/none-peeltrim.toml"]);
    assert_eq!(
        stderr(&o).matches("/tmp/none-peeltrim.toml").count(),
        1,
        "{}",
        stderr(&o)
    );
    // Help describes SCENE and says what files are accepted, on its own.
    for cmd in ["render", "view", "plan"] {
        let o = run(&[cmd, "--help"]);
        let h = String::from_utf8_lossy(&o.stdout);
        assert!(
            h.contains("<SCENE>  The scene: a .toml scene file"),
            "{cmd}: {h}"
        );
        assert!(h.contains(".csg"), "{cmd}: {h}");
        assert!(h.contains("[default: auto]"), "{cmd}: {h}");
        assert!(!h.contains("docs/") && !h.contains('§'), "{cmd}: {h}");
    }
}

/// `view` without a display says so in one line and what to do instead.
#[cfg(feature = "viewer")]
#[test]
fn view_without_a_display_says_so() {
    let o = super::bin()
        .args(["view", &scene("gear.toml")])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    assert_error(&o, &["no display", "peeltrim render", "xvfb-run"]);
    assert_eq!(stderr(&o).trim_end().lines().count(), 1, "{}", stderr(&o));
    assert!(!stderr(&o).contains(".rs:"), "{}", stderr(&o));
}

/// A camera looking away from the scene renders an empty image with a warning.
#[test]
fn a_camera_that_sees_nothing_warns() {
    let dir = tmp("away");
    let p = write(
        &dir,
        "away.toml",
        &format!("{AB}[csg]\nexpr = \"A - B\"\n[camera]\neye = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 10.0]\n"),
    );
    let out = dir.join("o");
    let o = run(&super::render_args(
        &p,
        "16x16",
        &["--algo", "reference"],
        out.to_str().unwrap(),
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o)
            .contains("peeltrim: warning: the image is empty: nothing of the scene is in view"),
        "{}",
        stderr(&o)
    );
    let o = run(&super::render_args(
        &scene("gear.toml"),
        "16x16",
        &["--algo", "reference"],
        out.to_str().unwrap(),
    ));
    assert!(!stderr(&o).contains("image is empty"), "{}", stderr(&o));
}

/// The zones' memory estimate reads as a sentence.
#[test]
fn the_zones_budget_message_is_a_sentence() {
    let dir = tmp("zones");
    let p = expr_scene(&dir, "inter.toml", &chain(300, " "));
    let o = run(&["plan", &p, "--algo", "cst-i", "--memory-budget", "64K"]);
    assert_error(
        &o,
        &["the zones, about", "literals in all", "), would need about"],
    );
}

/// `--algo auto` (the default) picks a speckle-free algorithm per scene and
/// says which and why in stats.json.
#[test]
fn auto_is_the_default_and_says_why() {
    let dir = tmp("auto");
    for name in ["gear.toml", "drilled_block.toml", "trimmed_surface.toml"] {
        let out = dir.join(name);
        let o = run(&super::render_args(
            &scene(name),
            "32x32",
            &[],
            out.to_str().unwrap(),
        ));
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let st: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("stats.json")).unwrap()).unwrap();
        let algo = st["algo"].as_str().unwrap();
        assert_eq!(st["auto"]["picked"], algo, "{st}");
        assert!(
            !["scs", "trickle", "blister-paper", "reference"].contains(&algo),
            "{name}: {algo}"
        );
        assert!(
            st["auto"]["reason"].as_str().unwrap().contains("estimated"),
            "{st}"
        );
        assert!(st["auto"]["estimates"]["cst-i"].as_f64().is_some(), "{st}");
        assert!(st["auto"]["estimates"].get("scs").is_none(), "{st}");
        if name == "trimmed_surface.toml" {
            assert!(algo.starts_with("cst-"), "{name}: {algo}");
        }
    }
    let o = run(&["plan", &scene("gear.toml")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("peeltrim: auto: "), "{}", stderr(&o));
}
