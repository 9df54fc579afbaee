//! The command line as a user runs it: output files of `render`, `blist` JSON
//! walked against the tree, `compare`, and clear errors (non-zero exit, the place
//! named, never a panic) on bad scenes, expressions, OBJ files and flags.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use rand::{Rng, SeedableRng};

mod blueprint_cli;
mod layers_cli;
/// OpenSCAD `.csg` models through the command line.
mod openscad_cli;
mod scad_models;
mod scad_source_cli;
mod shadow_cli;
/// `peeltrim view` (the second embedding host) in a virtual X server.
#[cfg(feature = "viewer")]
mod viewer_cli;

fn bin() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_peeltrim"));
    c.env("PEELTRIM_VALIDATION", "1");
    c
}

fn run(args: &[&str]) -> Output {
    bin().args(args).output().expect("runs the binary")
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("peeltrim-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn scene(name: &str) -> String {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
        .join("scenes")
        .join(name)
        .display()
        .to_string()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The arguments `render SCENE --size SIZE FLAGS… --out OUT`.
fn render_args<'a>(scene: &'a str, size: &'a str, flags: &[&'a str], out: &'a str) -> Vec<&'a str> {
    let mut args = vec!["render", scene, "--size", size];
    args.extend_from_slice(flags);
    args.extend(["--out", out]);
    args
}

/// A failing run: non-zero exit, no panic, and the message contains `want`.
fn assert_error(o: &Output, want: &[&str]) {
    let e = stderr(o);
    assert!(
        !o.status.success(),
        "expected failure, got success; stderr:\n{e}"
    );
    assert!(!e.contains("panicked"), "panic:\n{e}");
    for w in want {
        assert!(e.contains(w), "want {w:?} in:\n{e}");
    }
}

#[test]
fn render_reference_writes_contract_files() {
    let out = tmp("ref");
    let o = run(&[
        "render",
        &scene("paper_example.toml"),
        "--algo",
        "reference",
        "--size",
        "64x48",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let npy = std::fs::read(out.join("depth.npy")).unwrap();
    assert_eq!(&npy[..6], b"\x93NUMPY");
    let header =
        String::from_utf8_lossy(&npy[10..10 + u16::from_le_bytes([npy[8], npy[9]]) as usize])
            .into_owned();
    assert!(
        header.contains("'descr': '<f4'") && header.contains("'shape': (48, 64)"),
        "{header}"
    );
    let prim = image::open(out.join("prim.png")).unwrap();
    assert!(
        matches!(prim, image::DynamicImage::ImageLuma16(_)),
        "prim.png must be 16-bit grey"
    );
    let color = image::open(out.join("color.png")).unwrap().to_rgba8();
    assert_eq!(color.dimensions(), (64, 48));
    assert!(
        color.pixels().all(|p| p.0[3] == 255),
        "colour must be opaque"
    );
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("stats.json")).unwrap()).unwrap();
    for k in [
        "algo", "width", "height", "device", "gpu_ms", "cpu_ms", "passes",
    ] {
        assert!(stats.get(k).is_some(), "stats.json lacks {k}: {stats}");
    }
    // compare against itself: all zero
    let c = run(&["compare", out.to_str().unwrap(), out.to_str().unwrap()]);
    let r: serde_json::Value = serde_json::from_slice(&c.stdout).unwrap();
    assert_eq!(r["pixels"], 64 * 48);
    assert_eq!(r["coverage_mismatch"], 0);
    assert_eq!(r["prim_mismatch"], 0);
    assert_eq!(r["depth_abs_err_max"], 0.0);
}

#[test]
fn render_blister_agrees_with_reference_and_counts_repeat() {
    let (a, b, r) = (tmp("bl-a"), tmp("bl-b"), tmp("bl-ref"));
    let s = scene("speckle.toml");
    for (dir, algo) in [(&r, "reference"), (&a, "blister"), (&b, "blister")] {
        let o = run(&[
            "render",
            &s,
            "--algo",
            algo,
            "--size",
            "96x96",
            "--out",
            dir.to_str().unwrap(),
            "--device",
            "cpu",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let read = |d: &Path| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(d.join("stats.json")).unwrap()).unwrap()
    };
    let (sa, sb) = (read(&a), read(&b));
    assert!(sa["gpu_ms"].as_f64().unwrap() > 0.0);
    for k in [
        "draws",
        "mesh_draws",
        "fullscreen_passes",
        "triangles",
        "fullscreen_pixels",
        "loop_iterations",
    ] {
        assert!(sa.get(k).is_some(), "stats.json lacks {k}");
        assert_eq!(sa[k], sb[k], "{k} differs between runs");
    }
    let c = run(&["compare", r.to_str().unwrap(), a.to_str().unwrap()]);
    let rep: serde_json::Value = serde_json::from_slice(&c.stdout).unwrap();
    assert!(
        rep["coverage_mismatch_interior_frac"].as_f64().unwrap() <= 0.001,
        "{rep}"
    );
    assert!(
        rep["prim_mismatch_interior_frac"].as_f64().unwrap() <= 0.01,
        "{rep}"
    );
}

/// A random expression string over `names`, with complements, parentheses and
/// juxtaposition.
fn random_expr(rng: &mut impl Rng, depth: u32, names: &[&str]) -> String {
    if depth == 0 || rng.gen_bool(0.25) {
        let n = names[rng.gen_range(0..names.len())];
        return if rng.gen_bool(0.2) {
            format!("!{n}")
        } else {
            n.to_string()
        };
    }
    let a = random_expr(rng, depth - 1, names);
    let b = random_expr(rng, depth - 1, names);
    match rng.gen_range(0..4) {
        0 => format!("({a} + {b})"),
        1 => format!("({a} - {b})"),
        2 => format!("({a} * {b})"),
        _ => format!("({a} {b})"),
    }
}

/// Walks the `blist` JSON for one point.
fn walk(json: &serde_json::Value, inside: &HashMap<String, bool>) -> bool {
    let entries = json["entries"].as_array().unwrap();
    let mut cur = entries[0]["label"].clone();
    for e in entries {
        if e["label"] != cur {
            continue;
        }
        let v = inside[e["prim"].as_str().unwrap()] != e["negated"].as_bool().unwrap();
        cur = if v {
            e["if_true"].clone()
        } else {
            e["if_false"].clone()
        };
        if cur == "T" || cur == "F" {
            break;
        }
    }
    cur == "T"
}

#[test]
fn blist_walk_equals_the_tree() {
    let names = ["A", "B", "C", "D", "E", "F"];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    for _ in 0..25 {
        let src = random_expr(&mut rng, 5, &names);
        let o = run(&["blist", &src]);
        assert!(o.status.success(), "{src}: {}", stderr(&o));
        let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert!(json["stencil_bits"].as_u64().unwrap() <= 8);
        // The tree, evaluated independently of the Blist.
        let mut ids: Vec<String> = Vec::new();
        let expr = peeltrim::csg::parse(&src, &mut |n: &str| {
            Some(ids.iter().position(|x| x == n).unwrap_or_else(|| {
                ids.push(n.to_string());
                ids.len() - 1
            }) as u32)
        })
        .unwrap();
        assert_eq!(
            json["leaves"].as_u64().unwrap() as usize,
            expr.leaves().len()
        );
        for bits in 0..(1u32 << ids.len()) {
            let inside: HashMap<String, bool> = ids
                .iter()
                .enumerate()
                .map(|(i, n)| (n.clone(), bits >> i & 1 == 1))
                .collect();
            let tree = expr.eval(|_, p| bits >> p & 1 == 1);
            assert_eq!(walk(&json, &inside), tree, "{src} at {inside:?}");
        }
    }
}

#[test]
fn blist_of_a_scene_file_and_a_million_leaves() {
    let o = run(&["blist", &scene("gear.toml")]);
    assert!(o.status.success(), "{}", stderr(&o));
    // 10^6 leaves through a scene file: labels within the bound, <= 8 bits.
    let dir = tmp("million");
    let n = 1_000_000usize;
    let mut s = String::from("[[primitive]]\nname = \"A\"\nshape = \"box\"\nsize = [1.0, 1.0, 1.0]\n[[primitive]]\nname = \"B\"\nshape = \"box\"\nsize = [0.5, 0.5, 0.5]\n[csg]\nexpr = \"");
    for i in 0..n {
        if i > 0 {
            s.push_str(if i % 3 == 0 {
                " + "
            } else if i % 3 == 1 {
                " - "
            } else {
                " "
            });
        }
        s.push(if i % 2 == 0 { 'A' } else { 'B' });
    }
    s.push_str("\"\n");
    let p = dir.join("big.toml");
    std::fs::write(&p, s).unwrap();
    let t = std::time::Instant::now();
    let o = run(&["blist", p.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(json["leaves"], n as u64);
    let bound = ((2.0 * n as f64 / 3.0 + 2.0).log2().ceil() + 1.0) as u64;
    assert!(
        json["labels"].as_u64().unwrap() <= bound,
        "{} labels > {bound}",
        json["labels"]
    );
    assert!(json["stencil_bits"].as_u64().unwrap() <= 8);
    eprintln!(
        "blist of 10^6 leaves: {:?}, {} labels",
        t.elapsed(),
        json["labels"]
    );
}

#[test]
fn bad_input_is_a_clear_error() {
    let dir = tmp("bad");
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_string()
    };
    let base = "[camera]\neye = [3.0, 2.0, 4.0]\n[[primitive]]\nname = \"A\"\nshape = \"box\"\nsize = [1.0, 1.0, 1.0]\n";
    // unknown key, with the file and line
    let p = write(
        "unknown.toml",
        &format!("{base}colour = \"#ff0000\"\n[csg]\nexpr = \"A\"\n"),
    );
    assert_error(&run(&["render", &p]), &["unknown.toml", ":7", "colour"]);
    // expression syntax: caret under the column
    let p = write("syntax.toml", &format!("{base}[csg]\nexpr = \"A + (A\"\n"));
    assert_error(&run(&["render", &p]), &["syntax.toml", "A + (A", "^"]);
    // unknown primitive
    let p = write(
        "unknown_prim.toml",
        &format!("{base}[csg]\nexpr = \"A - Q\"\n"),
    );
    assert_error(&run(&["render", &p]), &["'Q'", "[[primitive]]"]);
    // unbounded solid
    let p = write("unbounded.toml", &format!("{base}[csg]\nexpr = \"!A\"\n"));
    assert_error(&run(&["render", &p]), &["unbounded"]);
    // missing OBJ
    let p = write(
        "missing.toml",
        "[[primitive]]\nname = \"M\"\nshape = \"mesh\"\npath = \"nope.obj\"\n[csg]\nexpr = \"M\"\n",
    );
    assert_error(&run(&["render", &p]), &["nope.obj"]);
    // open OBJ mesh used in CSG: the primitive and an edge are named
    write(
        "open.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\n",
    );
    let p = write(
        "open.toml",
        "[[primitive]]\nname = \"M\"\nshape = \"mesh\"\npath = \"open.obj\"\n[csg]\nexpr = \"M\"\n",
    );
    assert_error(&run(&["render", &p]), &["\"M\"", "edge"]);
    // eye == target
    let p = write("eye.toml", "[camera]\neye = [0.0, 0.0, 0.0]\n[[primitive]]\nname = \"A\"\nshape = \"box\"\nsize = [1.0, 1.0, 1.0]\n[csg]\nexpr = \"A\"\n");
    assert_error(&run(&["render", &p]), &["eye"]);
    // zero size
    let p = write("zero.toml", "[[primitive]]\nname = \"A\"\nshape = \"box\"\nsize = [1.0, 0.0, 1.0]\n[csg]\nexpr = \"A\"\n");
    assert_error(&run(&["render", &p]), &["size"]);
    // flags
    let ok = scene("speckle.toml");
    assert_error(&run(&["render", &ok, "--size", "0x10"]), &["size"]);
    assert_error(
        &run(&["render", &ok, "--algo", "zbuffer"]),
        &["zbuffer", "blister"],
    );
    assert_error(&run(&["render", &ok, "--depth-format", "d16"]), &["d16"]);
    assert_error(
        &run(&[
            "render",
            &ok,
            "--depth-format",
            "d24s8",
            "--reversed-z",
            "--algo",
            "blister",
        ]),
        &["d32s8"],
    );
    assert_error(
        &run(&["render", "/nonexistent/scene.toml"]),
        &["/nonexistent/scene.toml"],
    );
    assert_error(&run(&["blist", "A + * B"]), &["^"]);
    assert_error(
        &run(&["compare", "/nonexistent/a", "/nonexistent/b"]),
        &["/nonexistent/a"],
    );
    // the input files are untouched
    assert_eq!(
        std::fs::read_to_string(dir.join("open.obj")).unwrap(),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\n"
    );
}

/// `bench SCENE --algos reference --baseline opencsg --opencsg-bench PROGRAM`.
fn bench_opencsg(scene_file: &str, size: &str, program: &str, out: &Path) -> Output {
    run(&[
        "bench",
        &scene(scene_file),
        "--algos",
        "reference",
        "--size",
        size,
        "--frames",
        "1",
        "--baseline",
        "opencsg",
        "--opencsg-bench",
        program,
        "--out",
        out.to_str().unwrap(),
    ])
}

/// `bench --baseline opencsg` without the program: the bench succeeds and its
/// summary says how to build it.
#[test]
fn bench_baseline_opencsg_missing_says_how_to_build() {
    let out = tmp("opencsg-missing");
    let o = bench_opencsg(
        "paper_example.toml",
        "32x32",
        "/nonexistent/opencsg-bench",
        &out,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(
        summary.contains("not run") && summary.contains("tools/opencsg-bench/build.sh"),
        "{summary}"
    );
    let o = run(&[
        "bench",
        &scene("paper_example.toml"),
        "--baseline",
        "povray",
    ]);
    assert_error(&o, &["povray"]);
}

/// With the program built (tools/opencsg-bench/build.sh), OpenCSG's images of a
/// scene of convex primitives match the reference: the exchange file's matrices,
/// the depth conversion and the row order are right. Skipped (with a note) when
/// the program is not built.
#[test]
fn bench_baseline_opencsg_matches_reference_when_built() {
    let program = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
        .join("tools/opencsg-bench/opencsg-bench");
    if !program.is_file() {
        eprintln!("skipped: {} is not built", program.display());
        return;
    }
    let out = tmp("opencsg");
    let o = bench_opencsg("complex.toml", "96x80", program.to_str().unwrap(), &out);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let rows: Vec<&serde_json::Value> = json
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| r["algo"].as_str().unwrap().starts_with("opencsg-"))
        .collect();
    assert_eq!(rows.len(), 3, "{json:#}");
    for r in rows {
        assert!(r["failure"].is_null(), "{r:#}");
        assert!(r["gpu_ms_median"].as_f64().unwrap() > 0.0);
        let e = &r["error"];
        assert_eq!(e["coverage_mismatch_interior"].as_u64(), Some(0), "{r:#}");
        assert!(
            e["depth_abs_err_p99_interior"].as_f64().unwrap() < 1e-3,
            "{r:#}"
        );
    }
}

/// The default depth set-up is D32 float with reversed Z; the flags select the
/// others, and an impossible combination is a clear error.
#[test]
fn depth_setup_defaults_to_reversed_d32() {
    let s = scene("speckle.toml");
    let cases: [(&[&str], &str); 3] = [
        (&[], "d32s8-reversed"),
        (&["--standard-z"], "d32s8"),
        (&["--depth-format", "d24s8"], "d24s8"),
    ];
    for (i, (flags, want)) in cases.iter().enumerate() {
        if *want == "d24s8" && !require(caps().d24s8, "D24S8") {
            continue;
        }
        let dir = tmp(&format!("depth-setup-{i}"));
        let mut args = vec![
            "render",
            &s,
            "--algo",
            "cst-i",
            "--size",
            "32x32",
            "--device",
            "cpu",
            "--out",
            dir.to_str().unwrap(),
        ];
        args.extend_from_slice(flags);
        let o = run(&args);
        assert!(o.status.success(), "{flags:?}: {}", stderr(&o));
        let stats: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join("stats.json")).unwrap()).unwrap();
        assert_eq!(stats["depth_setup"], *want, "{flags:?}");
        assert!(
            stats.get("depth_setup_fallback").is_none(),
            "lavapipe has d32s8"
        );
    }
    let o = run(&[
        "render",
        &s,
        "--depth-format",
        "d24s8",
        "--reversed-z",
        "--device",
        "cpu",
    ]);
    assert_error(&o, &["--reversed-z", "d32s8"]);
    let o = run(&[
        "render",
        &s,
        "--standard-z",
        "--reversed-z",
        "--device",
        "cpu",
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("--standard-z"),
        "{}",
        stderr(&o)
    );
}

mod cli_hardening;

/// A reader that stops early (`peeltrim plan … | head -1`) ends the command
/// quietly: exit 0, no panic message.
#[test]
fn closed_stdout_is_not_a_panic() {
    use std::process::Stdio;
    let gear = scene("gear.toml");
    for args in [
        vec!["plan", gear.as_str(), "--algo", "cst-z"],
        vec!["blist", gear.as_str()],
    ] {
        let mut child = bin()
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn peeltrim");
        // Close our end of the pipe before the child writes: its writes fail
        // with EPIPE (Rust ignores SIGPIPE), as behind `| head`.
        drop(child.stdout.take());
        let out = child.wait_with_output().expect("wait for peeltrim");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(out.status.success(), "{args:?}: {:?} {err}", out.status);
    }
}

/// `bench` times a scene's algorithms round-robin and says so per run; on the
/// gear CST-G plans exactly CST-I's steps (equal digests) and the summary's CST
/// ordering line says so.
#[test]
fn bench_interleaves_frames_and_states_the_cst_ordering() {
    let out = tmp("bench-interleaved");
    let o = run(&[
        "bench",
        &scene("gear.toml"),
        "--algos",
        "cst-g,cst-i,cst-z,blister",
        "--size",
        "48x48",
        "--frames",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let rows = json.as_array().unwrap();
    assert_eq!(rows.len(), 4, "{json:#}");
    for r in rows {
        assert!(r["failure"].is_null(), "{r:#}");
        assert_eq!(r["timing"]["interleaved"]["runs"], 4, "{r:#}");
        assert_eq!(r["frames"], 2, "{r:#}");
        assert_eq!(r["overhead"]["replayed_frames"], 2, "{r:#}");
    }
    let digest = |a: &str| {
        rows.iter().find(|r| r["algo"] == a).unwrap()["plan_digest"]
            .as_str()
            .unwrap()
            .to_string()
    };
    assert_eq!(digest("cst-g"), digest("cst-i"));
    assert_ne!(digest("cst-i"), digest("cst-z"));
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(
        summary.contains("4 of 4 runs had their timed frames interleaved")
            && summary.contains("≡ cst-i")
            && summary.contains("CST-G = CST-I plan"),
        "{summary}"
    );
    // Every run against the rasterization floor: one z-buffered draw of the
    // gear's triangles, which no CSG frame undercuts.
    for r in rows {
        let (floor, cpu) = (
            r["floor"]["frame_cpu_ms"].as_f64(),
            r["frame_cpu_ms_median"].as_f64(),
        );
        assert!(floor.is_some_and(|f| f > 0.0), "{r:#}");
        assert!(cpu.unwrap() > floor.unwrap(), "{r:#}");
    }
    assert!(
        summary.contains("## Against the rasterization floor")
            && summary.contains("| gear | 48×48 |"),
        "{summary}"
    );
    assert!(out.join("plots/floor.png").is_file());
}

/// `plan --device-profile`: the plan passes' result. Under the CPU rasterizer
/// profile (unsnapped depth) the final shade's tie-free draws are depth-equal
/// draws; under the hardware profile none is, and the plan before the passes
/// is the same; an unknown profile is a usage error.
#[test]
fn plan_prints_the_passes_result_under_each_profile() {
    let gear = scene("gear.toml");
    let plan = |profile: &str| {
        let o = run(&[
            "plan",
            &gear,
            "--algo",
            "goldfeather",
            "--device-profile",
            profile,
        ]);
        assert!(o.status.success(), "{profile}: {}", stderr(&o));
        String::from_utf8(o.stdout).unwrap()
    };
    let (cpu, hw) = (plan("cpu"), plan("hardware"));
    let split = |t: &str| {
        let (before, after) = t
            .split_once("# After the plan passes")
            .expect("the passes' section");
        (before.to_string(), after.to_string())
    };
    let ((cpu_plan, cpu_passes), (hw_plan, hw_passes)) = (split(&cpu), split(&hw));
    assert_eq!(
        cpu_plan, hw_plan,
        "the algorithm's plan does not depend on the profile"
    );
    assert!(cpu_passes.contains("CpuRasterizer") && hw_passes.contains("Hardware"));
    let equal = |t: &str| t.matches("depth-equal").count();
    assert!(equal(&cpu_passes) > 0, "{cpu_passes}");
    assert_eq!(
        equal(&hw_passes),
        1,
        "only the heading's 'depth-equal shades off': {hw_passes}"
    );
    assert_eq!(
        cpu_passes.matches("  draw ").count(),
        hw_passes.matches("  draw ").count()
    );
    let o = run(&["plan", &gear, "--device-profile", "gpu"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("use device, cpu or hardware"),
        "{}",
        stderr(&o)
    );
}

/// What the test device offers that some CLI tests need (the device the
/// binary will pick with `--device cpu`), asked once.
struct Caps {
    d24s8: bool,
    /// The instance can make X11 surfaces (the viewer's window under xvfb).
    xlib_surface: bool,
    /// The device runs frames at 4 samples per pixel.
    four_samples: bool,
}

fn caps() -> &'static Caps {
    static CAPS: std::sync::OnceLock<Caps> = std::sync::OnceLock::new();
    CAPS.get_or_init(|| {
        let ctx = peeltrim::vk::Context::new(&peeltrim::vk::ContextDesc {
            device: peeltrim::vk::DeviceChoice::Cpu,
            validation: false,
        })
        .expect("a Vulkan device");
        // SAFETY: loading the system's Vulkan loader; only queried here.
        let entry = unsafe { ash::Entry::load() }.expect("the Vulkan loader");
        // SAFETY: a plain query of the loader.
        let exts =
            unsafe { entry.enumerate_instance_extension_properties(None) }.unwrap_or_default();
        let xlib_surface = exts.iter().any(|e| {
            e.extension_name_as_c_str()
                .is_ok_and(|n| n.to_bytes() == b"VK_KHR_xlib_surface")
        });
        Caps {
            d24s8: ctx.profile().depth_formats.d24s8,
            xlib_surface,
            four_samples: ctx.supported_samples().contains(&4),
        }
    })
}

/// Whether the test device has `what` (`has`); prints the skip line when not.
fn require(has: bool, what: &str) -> bool {
    if !has {
        eprintln!("skipped: the device lacks {what}");
    }
    has
}
