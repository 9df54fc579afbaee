//! `render --layers-out / --layers / --layer-threshold / --alpha` as a user runs
//! them: the layer directories, layer 1 against the opaque images, the composite,
//! stats.json, and the errors.

use super::{assert_error, run, scene, stderr, tmp};

pub(super) fn render(name: &str, out: &std::path::Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "render",
        name,
        "--size",
        "64x48",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    // The reference unless the case names its algorithm.
    if !extra.contains(&"--algo") {
        args.extend(["--algo", "reference"]);
    }
    run(&args)
}

fn images(dir: &std::path::Path) -> peeltrim_cli::output::Images {
    peeltrim_cli::output::read_images(dir).unwrap_or_else(|e| panic!("{e}"))
}

pub(super) fn stats(dir: &std::path::Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("stats.json")).unwrap()).unwrap()
}

#[test]
fn layers_out_writes_every_layer_and_layer_one_is_the_image() {
    let out = tmp("layers");
    let o = render(&scene("drilled_block.toml"), &out, &["--layers-out"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let st = stats(&out);
    let n = st["layers"].as_u64().unwrap() as usize;
    assert!(n >= 4, "{st}");
    let pixels: Vec<u64> = st["layer_pixels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    assert_eq!(pixels.len(), n);
    assert!(
        pixels.windows(2).all(|w| w[0] >= w[1]) && pixels[n - 1] > 0,
        "{pixels:?}"
    );
    assert_eq!(st["transparent"], false);
    assert!(!out.join("layers").join(format!("{:02}", n + 1)).exists());

    // Opaque: the output files are the opaque image, and layer 1 is that image.
    let main = images(&out);
    let first = images(&out.join("layers/01"));
    assert_eq!(first, main);
    let mut prev = first;
    for k in 2..=n {
        let layer = images(&out.join(format!("layers/{k:02}")));
        let covered = layer.prim.iter().filter(|&&p| p != 0).count() as u64;
        assert_eq!(covered, pixels[k - 1], "layer {k}");
        for i in 0..layer.depth.len() {
            if layer.prim[i] != 0 {
                assert!(
                    prev.prim[i] != 0,
                    "layer {k} pixel {i} without layer {}",
                    k - 1
                );
                assert!(
                    layer.depth[i] >= prev.depth[i],
                    "layer {k} pixel {i} in front"
                );
            } else {
                assert_eq!(layer.depth[i], f32::INFINITY);
            }
        }
        prev = layer;
    }

    // --layers 2 and a threshold above the last layer's pixels cut the stack.
    let cut = tmp("layers-cut");
    let o = render(
        &scene("drilled_block.toml"),
        &cut,
        &["--layers-out", "--layers", "2"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(cut.join("layers/02/depth.npy").exists() && !cut.join("layers/03").exists());
    let t = (pixels[n - 1] + 1).to_string();
    let o = render(
        &scene("drilled_block.toml"),
        &cut,
        &["--layers-out", "--layer-threshold", &t],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let kept = pixels.iter().take_while(|&&p| p > pixels[n - 1]).count();
    assert!(kept < n);
    assert_eq!(stats(&cut)["layers"].as_u64().unwrap() as usize, kept);
}

#[test]
fn alpha_composites_and_keeps_layer_one() {
    let opaque = tmp("alpha-opaque");
    let o = render(&scene("paper_example.toml"), &opaque, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let see = tmp("alpha");
    let o = render(&scene("paper_example.toml"), &see, &["--alpha", "0.4"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (a, b) = (images(&opaque), images(&see));
    assert_eq!(
        (a.depth.clone(), a.prim.clone()),
        (b.depth.clone(), b.prim.clone())
    );
    let changed = (0..a.color.len())
        .filter(|&i| a.prim[i] != 0 && a.color[i] != b.color[i])
        .count();
    let covered = a.prim.iter().filter(|&&p| p != 0).count();
    assert!(
        changed * 2 > covered,
        "{changed} of {covered} covered pixels changed"
    );
    let bg: Vec<usize> = (0..a.color.len()).filter(|&i| a.prim[i] == 0).collect();
    assert!(
        bg.iter().all(|&i| a.color[i] == b.color[i]),
        "background changed"
    );
    assert_eq!(stats(&see)["transparent"], true);
}

#[test]
fn layer_flags_reject_bad_values_and_non_cst_algorithms_say_they_cannot() {
    let out = tmp("layers-bad");
    let s = scene("paper_example.toml");
    assert_error(
        &render(&s, &out, &["--alpha", "1.5"]),
        &["--alpha", "(0, 1]"],
    );
    assert_error(&render(&s, &out, &["--alpha", "half"]), &["opacity"]);
    assert_error(&render(&s, &out, &["--layers", "0"]), &["--layers"]);
    for algo in ["goldfeather", "blister"] {
        let o = render(&s, &out, &["--algo", algo, "--layers-out"]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert_error(&o, &[algo, "cannot render", "--algo reference", "cst-z"]);
    }
}

#[test]
fn cst_writes_its_layers() {
    let out = tmp("layers-cst");
    let s = scene("paper_example.toml");
    let o = render(
        &s,
        &out,
        &["--algo", "cst-g", "--layers-out", "--alpha", "0.4"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let st = stats(&out);
    let n = st["layers"].as_u64().unwrap() as usize;
    assert!(
        n >= 4 && st["transparent"] == true && st["csts"].as_u64() > Some(0),
        "{st}"
    );
    assert!(st["stream_layers"].as_u64() >= Some(n as u64), "{st}");
    let first = images(&out.join("layers/01"));
    let main = images(&out);
    assert_eq!((first.depth, first.prim), (main.depth, main.prim));
    assert!(out.join(format!("layers/{n:02}/prim.png")).exists());
}

#[test]
fn highlight_marks_trimmed_faces_visible_and_hidden() {
    let out = tmp("highlight");
    let s = scene("drilled_block.toml");
    let o = render(&s, &out, &["--layers-out", "--highlight", "H00,H01"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let plain = tmp("highlight-plain");
    let o = render(&s, &plain, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (lit, base) = (images(&out), images(&plain));
    assert_eq!((&lit.depth, &lit.prim), (&base.depth, &base.prim));
    let st = stats(&out);
    let n = st["layers"].as_u64().unwrap() as usize;
    let layers: Vec<_> = (1..=n)
        .map(|k| images(&out.join(format!("layers/{k:02}"))))
        .collect();
    // H00 and H01 are primitives 2 and 3 (1-based) of drilled_block.
    let (mut shown, mut hidden) = (0u64, 0u64);
    for i in 0..lit.prim.len() {
        match layers.iter().position(|l| matches!(l.prim[i], 2 | 3)) {
            Some(0) => {
                shown += 1;
                // The highlight colour, shaded: rgb * k with one k for all channels.
                let [r, g, b] = peeltrim_reference::highlight::HIGHLIGHT_RGB.map(f64::from);
                let c = lit.color[i].map(f64::from);
                let k = c[0] / r;
                assert!(
                    (0.24..=1.0).contains(&k)
                        && (c[1] - g * k).abs() <= 1.0
                        && (c[2] - b * k).abs() <= 1.0,
                    "pixel {i}: {:?}",
                    lit.color[i]
                );
            }
            Some(_) => {
                hidden += 1;
                assert_ne!(lit.color[i], base.color[i], "pixel {i}");
            }
            None => assert_eq!(lit.color[i], base.color[i], "pixel {i}"),
        }
    }
    assert!(shown > 0 && hidden > 0, "{shown} {hidden}");
    assert_eq!(st["highlighted_pixels"].as_u64(), Some(shown));
    assert_eq!(st["highlighted_hidden_pixels"].as_u64(), Some(hidden));

    assert_error(
        &render(&s, &out, &["--highlight", "H00,Nope"]),
        &["--highlight", "'Nope'", "Block, H00"],
    );
}

#[test]
fn interference_lists_the_intersecting_pair() {
    let dir = tmp("interference");
    let path = dir.join("clash.toml");
    std::fs::write(
        &path,
        "[camera]\neye = [3.0, 2.0, 4.0]\nfit = true\n[render]\ninterference = true\n\
         [[primitive]]\nname = \"P\"\nshape = \"box\"\nsize = [2, 2, 2]\n\
         [[primitive]]\nname = \"Q\"\nshape = \"sphere\"\nradius = 0.8\ntranslate = [1, 0, 0]\n\
         [[primitive]]\nname = \"R\"\nshape = \"box\"\nsize = [0.5, 0.5, 0.5]\ntranslate = [-3, 0, 0]\n\
         [[solid]]\nname = \"p\"\nexpr = \"P\"\n[[solid]]\nname = \"q\"\nexpr = \"Q\"\n\
         [[solid]]\nname = \"r\"\nexpr = \"R\"\n",
    )
    .unwrap();
    let s = path.to_str().unwrap();
    let out = dir.join("out");
    let o = render(s, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let st = stats(&out);
    let pairs = st["interference"].as_array().unwrap();
    assert_eq!(pairs.len(), 1, "{st}");
    assert_eq!(pairs[0]["solids"], serde_json::json!(["p", "q"]));
    let n = pairs[0]["pixels"].as_u64().unwrap();
    assert!(
        n > 50 && st["interference_pixels"].as_u64() == Some(n),
        "{st}"
    );
    // On the GPU (a CST variant): the same pair and nearly the same pixels;
    // other GPU algorithms say they cannot.
    let gpu = dir.join("gpu");
    let o = render(s, &gpu, &["--algo", "cst-i"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let g = stats(&gpu);
    assert_eq!(
        g["interference"][0]["solids"],
        serde_json::json!(["p", "q"])
    );
    let m = g["interference"][0]["pixels"].as_u64().unwrap();
    assert!(m.abs_diff(n) <= n / 50 + 2, "{m} vs {n}");
    let o = render(s, &out, &["--algo", "blister"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_error(&o, &["interference", "cst-i"]);
}

/// `--algo kirsch` writes its layers like the reference does with
/// `--layer-reading products`, and refuses what it cannot render.
#[test]
fn kirsch_layers_out_and_its_errors() {
    let s = scene("paper_example.toml");
    let (gpu, cpu) = (tmp("kirsch-layers"), tmp("kirsch-layers-ref"));
    let o = render(
        &s,
        &gpu,
        &["--algo", "kirsch", "--layers-out", "--layers", "3"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = render(
        &s,
        &cpu,
        &[
            "--layers-out",
            "--layers",
            "3",
            "--layer-reading",
            "products",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let (sg, sc) = (stats(&gpu), stats(&cpu));
    assert_eq!(sg["algo"], "kirsch");
    assert_eq!(sg["layers"], sc["layers"], "{sg} {sc}");
    let n = sg["layers"].as_u64().unwrap();
    assert!(n >= 2, "{sg}");
    for k in 1..=n {
        let dir = format!("layers/{k:02}");
        let r = peeltrim_reference::compare::compare(
            &images(&cpu.join(&dir)),
            &images(&gpu.join(&dir)),
        )
        .unwrap();
        assert!(
            r.coverage_mismatch_interior_frac <= 0.001 && r.prim_mismatch_interior_frac <= 0.001,
            "layer {k}: {r:?}"
        );
    }
    // Layer 1 is the opaque image.
    assert_eq!(images(&gpu.join("layers/01")), images(&gpu));
    // The occlusion query's threshold (§6): stop at the first layer counting fewer.
    let fewest = (0..n as usize)
        .map(|k| sg["layer_pixels"][k].as_u64().unwrap())
        .min()
        .unwrap();
    let cut = tmp("kirsch-threshold");
    let t = (fewest + 1).to_string();
    let o = render(
        &s,
        &cut,
        &["--algo", "kirsch", "--layers-out", "--layer-threshold", &t],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let want = (0..n as usize)
        .take_while(|&k| sg["layer_pixels"][k].as_u64().unwrap() > fewest)
        .count();
    assert!(want >= 1, "{sg}");
    assert_eq!(stats(&cut)["layers"], want, "{}", stats(&cut));
    assert!(!cut.join(format!("layers/{:02}", want + 1)).exists());

    let out = tmp("kirsch-bad");
    let o = render(&s, &out, &["--algo", "kirsch", "--layer-reading", "solid"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_error(&o, &["kirsch", "--layer-reading products"]);
    let o = render(&s, &out, &["--algo", "kirsch", "--highlight", "A"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_error(&o, &["kirsch", "cannot render", "--algo reference"]);
    assert_error(
        &render(&s, &out, &["--layer-reading", "volume"]),
        &["--layer-reading", "solid or products"],
    );
}

/// `bench --modes` times every layered mode of CST and kirsch: a row per mode
/// and algorithm, with the layers each peeled (kirsch refuses highlight, which
/// is skipped with a warning, not a failed run).
#[test]
fn bench_modes_time_every_style() {
    let out = tmp("bench-modes");
    let o = run(&[
        "bench",
        &scene("drilled_block.toml"),
        "--algos",
        "cst-i,kirsch",
        "--size",
        "64x48",
        "--frames",
        "1",
        "--modes",
        "--no-images",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("modes.csv")).expect("modes.csv");
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let row = |algo: &str, mode: &str| {
        rows.iter()
            .find(|r| r[1] == algo && r[2] == mode)
            .unwrap_or_else(|| panic!("no {algo} {mode} row in\n{csv}"))
    };
    for mode in [
        "opaque",
        "transparent",
        "blueprint",
        "wireframe",
        "blueprint-transparent",
    ] {
        for algo in ["cst-i", "kirsch"] {
            let r = row(algo, mode);
            let layers: u32 = r[4].parse().unwrap();
            assert_eq!(layers, if mode == "opaque" { 1 } else { 4 }, "{r:?}");
            assert!(r[8].parse::<f64>().unwrap() > 0.0, "{r:?}");
        }
    }
    // cst-i composites drilled_block's layers on the GPU: it reads back layer 1
    // (colour, ids, depth) and the f32 composite, not the four layers.
    let bytes = |mode: &str| row("cst-i", mode)[7].parse::<u64>().unwrap();
    assert_eq!(bytes("transparent"), (12 + 16) * 64 * 48);
    assert_eq!(bytes("opaque"), 12 * 64 * 48);
    assert!(row("cst-i", "highlight")[6].parse::<u64>().unwrap() > 0);
    assert!(!rows.iter().any(|r| r[1] == "kirsch" && r[2] == "highlight"));
    assert!(stderr(&o).contains("kirsch highlight"), "{}", stderr(&o));
}
