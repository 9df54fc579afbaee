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
