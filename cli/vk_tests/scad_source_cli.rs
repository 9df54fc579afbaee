//! OpenSCAD source files (`.scad`) on the command line: exported by
//! `openscad` into a cache keyed by content (a second run does not run
//! openscad), relative imports kept, a clear error naming the install when
//! openscad is missing, and `view --watch` reloading on save in a virtual X
//! server (a broken save keeps the last picture, a good one is drawn).

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use super::{assert_error, bin, stderr, tmp};

fn has_openscad() -> bool {
    Command::new("openscad")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

#[test]
fn scad_files_are_exported_once_into_the_cache() {
    if !super::require(has_openscad(), "openscad (tools/setup.sh --openscad)") {
        return;
    }
    let d = tmp("scad-source");
    let cache = d.join("cache");
    let model = d.join("m.scad");
    std::fs::copy(
        super::scene("openscad/knob_part.stl"),
        d.join("knob_part.stl"),
    )
    .unwrap();
    std::fs::write(
        &model,
        "difference() { cube(16, center = true); import(\"knob_part.stl\"); }\n",
    )
    .unwrap();
    let out = d.join("out");
    let args = [
        "render",
        model.to_str().unwrap(),
        "--size",
        "32x32",
        "--algo",
        "reference",
        "--out",
        out.to_str().unwrap(),
    ];
    let o = bin()
        .args(args)
        .env("PEELTRIM_CACHE_DIR", &cache)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let cached: Vec<_> = std::fs::read_dir(cache.join("scad"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(cached.len(), 1, "{cached:?}");
    let text = std::fs::read_to_string(&cached[0]).unwrap();
    assert!(
        text.contains(&d.join("knob_part.stl").display().to_string()),
        "{text}"
    );
    // Unchanged: read from the cache, openscad not run.
    let o = bin()
        .args(args)
        .env("PEELTRIM_CACHE_DIR", &cache)
        .env("PEELTRIM_OPENSCAD", "/nonexistent/openscad")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    // Changed, and openscad missing: how to install it, or export the .csg.
    std::fs::write(&model, "cube(3);\n").unwrap();
    let o = bin()
        .args(args)
        .env("PEELTRIM_CACHE_DIR", &cache)
        .env("PEELTRIM_OPENSCAD", "/nonexistent/openscad")
        .output()
        .unwrap();
    assert_error(&o, &["m.scad", "apt-get install openscad", "Export as CSG"]);
    // A model openscad rejects: its message, and the way out.
    std::fs::write(&model, "cube(3)\n").unwrap();
    let o = bin()
        .args(args)
        .env("PEELTRIM_CACHE_DIR", &cache)
        .output()
        .unwrap();
    assert_error(&o, &["m.scad", "openscad could not export"]);
}

/// Waits for a stderr line containing `want`, for at most `secs`.
fn wait_for(
    lines: &std::sync::mpsc::Receiver<String>,
    want: &str,
    secs: u64,
    log: &mut String,
) -> bool {
    let end = Instant::now() + Duration::from_secs(secs);
    while let Some(left) = end.checked_duration_since(Instant::now()) {
        match lines.recv_timeout(left) {
            Ok(l) => {
                log.push_str(&l);
                log.push('\n');
                if l.contains(want) {
                    return true;
                }
            }
            Err(_) => return false,
        }
    }
    false
}

#[cfg(feature = "viewer")]
#[test]
fn view_watch_reloads_on_save_and_keeps_the_last_good_picture() {
    if !super::require(
        super::caps().xlib_surface,
        "X11 surfaces (VK_KHR_xlib_surface)",
    ) {
        return;
    }
    let d = tmp("scad-watch");
    let model = d.join("m.csg");
    std::fs::write(&model, "cube(size = [2, 2, 2], center = true);\n").unwrap();
    let mut child = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 320x240x24"])
        .arg(env!("CARGO_BIN_EXE_peeltrim"))
        .args([
            "view",
            model.to_str().unwrap(),
            "--size",
            "64x64",
            "--algo",
            "cst-i",
            "--watch",
        ])
        .env("PEELTRIM_VALIDATION", "1")
        .env("PEELTRIM_VIEW_RELOADS", "2")
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("xvfb-run is installed (tools/setup.sh installs xvfb)");
    let err = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for l in BufReader::new(err).lines().map_while(Result::ok) {
            let _ = tx.send(l);
        }
    });
    let mut log = String::new();
    let started = wait_for(&rx, "peeltrim view:", 120, &mut log);
    if !started {
        let _ = child.kill();
    }
    assert!(started, "{log}");
    std::thread::sleep(Duration::from_millis(1500));
    std::fs::write(
        &model,
        "cube(size = [2, 2, 2], center = true);\nsphere(r = ;\n",
    )
    .unwrap();
    let failed = wait_for(&rx, "reload failed", 60, &mut log);
    std::fs::write(&model, "sphere(r = 1.5, $fn = 16);\n").unwrap();
    let reloaded = wait_for(&rx, "ms from save to new frame", 60, &mut log);
    if !(failed && reloaded) {
        let _ = child.kill();
    }
    let status = child.wait().unwrap();
    while let Ok(l) = rx.try_recv() {
        log.push_str(&l);
        log.push('\n');
    }
    assert!(failed && reloaded, "{log}");
    assert!(log.contains("m.csg:2:"), "the error is located: {log}");
    assert!(status.success(), "{log}");
    assert!(!log.contains("vulkan validation"), "{log}");
}
