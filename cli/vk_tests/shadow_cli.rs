//! `render` of a scene with `[light]` as a user runs it: stats.json's shadow
//! figures agree between the reference and a GPU algorithm, and a bad light is
//! a located error.

use super::{assert_error, run, scene, stderr, tmp};

fn stats(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("stats.json")).unwrap()).unwrap()
}

#[test]
fn shadow_counts_agree_and_bad_lights_are_errors() {
    let dir = tmp("shadow");
    let mut counts = Vec::new();
    for algo in ["reference", "cst-i"] {
        let out = dir.join(algo);
        let o = run(&[
            "render",
            &scene("shadow_block.toml"),
            "--algo",
            algo,
            "--size",
            "96x72",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let st = stats(&out);
        let (lit, dark) = (
            st["lit_pixels"].as_u64().unwrap(),
            st["shadowed_pixels"].as_u64().unwrap(),
        );
        assert!(
            st["light"].as_str().unwrap().starts_with("directional"),
            "{st}"
        );
        assert!(dark > 50 && lit > 500, "{st}");
        assert_eq!(st["shadow_map_size"].is_u64(), algo != "reference", "{st}");
        counts.push((lit, dark));
    }
    let (r, g) = (counts[0], counts[1]);
    assert!(r.1.abs_diff(g.1) <= r.1 / 20 + 3, "{counts:?}");

    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "[[primitive]]\nname = \"A\"\nshape = \"box\"\nsize = [1, 1, 1]\n[csg]\nexpr = \"A\"\n\
         [light]\ndirection = [0, 0, 0]\n",
    )
    .unwrap();
    let o = run(&[
        "render",
        bad.to_str().unwrap(),
        "--out",
        dir.join("o").to_str().unwrap(),
    ]);
    assert_error(&o, &["bad.toml", "light: direction", "zero vector"]);
}

/// `bench` of a scene with `[light]` times the light map and reports the same
/// lit/shadowed counts as `render` of the same algorithm and size; a scene with
/// `interference = true` reports its pairs × frames and the interfering pairs
/// (those `render --interference` lists in stats.json).
#[test]
fn bench_times_shadows_and_interference() {
    let dir = tmp("shadow-bench");
    let o = run(&[
        "render",
        &scene("shadow_block.toml"),
        "--algo",
        "cst-i",
        "--size",
        "96x72",
        "--out",
        dir.join("r").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let st = stats(&dir.join("r"));
    let b = dir.join("b");
    let o = run(&[
        "bench",
        &scene("shadow_block.toml"),
        &scene("interference.toml"),
        "--algos",
        "cst-i",
        "--size",
        "96x72",
        "--frames",
        "2",
        "--no-images",
        "--out",
        b.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let res: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(b.join("results.json")).unwrap()).unwrap();
    let rows = res.as_array().unwrap();
    let sh = &rows.iter().find(|r| r["scene"] == "shadow_block").unwrap()["shadow"];
    assert_eq!(sh["lit_pixels"], st["lit_pixels"], "{sh} vs {st}");
    assert_eq!(sh["shadowed_pixels"], st["shadowed_pixels"], "{sh} vs {st}");
    assert_eq!(sh["map_size"], st["shadow_map_size"], "{sh}");
    assert!(
        sh["light_map_gpu_ms_median"].as_f64().unwrap() > 0.0,
        "{sh}"
    );
    // One frame is the map, the eye and the shadow pass, in one submission.
    assert_eq!(sh["submits_max"], 1, "{sh}");
    let ms = |k: &str| sh[k].as_f64().unwrap_or_else(|| panic!("{k}: {sh}"));
    assert!(ms("shadow_pass_gpu_ms_median") > 0.0, "{sh}");
    assert!(ms("frame_ms_median") > 0.0, "{sh}");
    assert!(
        ms("frame_gpu_ms_median") >= ms("light_map_gpu_ms_median").max(ms("eye_gpu_ms_median")),
        "{sh}"
    );
    let inter = &rows.iter().find(|r| r["scene"] == "interference").unwrap()["interference"];
    assert_eq!(inter["frames_per_pair"], 2, "{inter}");
    let o = run(&[
        "render",
        &scene("interference.toml"),
        "--algo",
        "cst-i",
        "--size",
        "96x72",
        "--out",
        dir.join("i").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let ist = stats(&dir.join("i"));
    let listed = ist["interference"].as_array().unwrap().len();
    assert_eq!(inter["interfering_pairs"], listed, "{inter} vs {ist}");
    assert!(inter["pairs"].as_u64().unwrap() >= listed as u64, "{inter}");
    let summary = std::fs::read_to_string(b.join("summary.md")).unwrap();
    assert!(
        summary.contains("## Shadows") && summary.contains("## Interference"),
        "{summary}"
    );
}
