//! `render --style`, `--edge-depth`, `--edge-angle` and the layer directories'
//! `normal.npy` / `edges.png` (Kirsch, Nienhaus & Döllner §5) as a user runs them.

use super::layers_cli::{render, stats};
use super::{assert_error, scene, stderr, tmp};

/// `normal.npy`: `(H, W, 3)` little-endian f32.
fn read_normals(path: &std::path::Path) -> (String, Vec<[f32; 3]>) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..6], b"\x93NUMPY");
    let hlen = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let header = String::from_utf8(bytes[10..10 + hlen].to_vec()).unwrap();
    let data: Vec<f32> = bytes[10 + hlen..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    (
        header,
        data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    )
}

#[test]
fn layers_out_writes_normals_and_edges_by_the_rule() {
    let out = tmp("bp-layers");
    let o = render(&scene("drilled_block.toml"), &out, &["--layers-out"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let st = stats(&out);
    let n = st["layers"].as_u64().unwrap() as usize;
    let edge_pixels = st["edge_pixels"].as_array().unwrap();
    assert_eq!(edge_pixels.len(), n);
    for k in 1..=n {
        let dir = out.join(format!("layers/{k:02}"));
        let img = peeltrim_cli::output::read_images(&dir).unwrap();
        let (header, normals) = read_normals(&dir.join("normal.npy"));
        assert!(header.contains("'shape': (48, 64, 3)"), "{header}");
        assert_eq!(normals.len(), 64 * 48);
        for (i, v) in normals.iter().enumerate() {
            let len = v.iter().map(|c| c * c).sum::<f32>().sqrt();
            if img.prim[i] == 0 {
                assert_eq!(len, 0.0);
            } else {
                assert!((len - 1.0).abs() < 1e-5, "layer {k} pixel {i}: {v:?}");
            }
        }
        // edges.png is the rule applied to this layer's own files.
        let (w, h, edges) = peeltrim_cli::output::read_edges(&dir).unwrap();
        assert_eq!((w, h), (64, 48));
        let want = peeltrim_cli::render::edges::edge_map(
            &img.depth,
            &normals,
            64,
            48,
            &Default::default(),
        );
        assert_eq!(edges, want, "layer {k}");
        let count = edges.iter().filter(|&&e| e).count() as u64;
        assert_eq!(edge_pixels[k - 1].as_u64(), Some(count));
        assert!(k > 2 || count > 50, "layer {k}: {count} edge pixels");
    }
    // A looser crease angle finds fewer edges on layer 1 (the block's corners
    // are 90°, so 95° drops them; silhouettes stay).
    let loose = tmp("bp-loose");
    let o = render(
        &scene("drilled_block.toml"),
        &loose,
        &["--layers-out", "--edge-angle", "95"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let a = stats(&out)["edge_pixels"][0].as_u64().unwrap();
    let b = stats(&loose)["edge_pixels"][0].as_u64().unwrap();
    assert!(b < a && b > 0, "{a} {b}");
    // compare reports the edge maps' agreement of two layer folders: the looser
    // map is a subset, so it strays nowhere (at 64×48 every dropped crease pixel
    // still lies within a pixel of a kept edge).
    let o = super::run(&[
        "compare",
        out.join("layers/01").to_str().unwrap(),
        loose.join("layers/01").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let e = &j["edges"];
    assert_eq!(e["reference_edges"].as_u64(), Some(a), "{j}");
    assert_eq!(e["our_edges"].as_u64(), Some(b), "{j}");
    assert_eq!(e["ours_stray"].as_u64(), Some(0), "{j}");
    assert_eq!(j["prim_mismatch"].as_u64(), Some(0), "{j}");
    // Folders without edges.png: no `edges` key.
    let o = super::run(&["compare", out.to_str().unwrap(), loose.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(j.get("edges").is_none(), "{j}");
}

#[test]
fn styles_compose_color_png_and_keep_layer_one() {
    let base = tmp("bp-opaque");
    let o = render(&scene("paper_example.toml"), &base, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let opaque = peeltrim_cli::output::read_images(&base).unwrap();
    let mut seen = Vec::new();
    for style in [
        "transparent",
        "blueprint",
        "wireframe",
        "blueprint-transparent",
    ] {
        let out = tmp(&format!("bp-{style}"));
        let o = render(&scene("paper_example.toml"), &out, &["--style", style]);
        assert!(o.status.success(), "{style}: {}", stderr(&o));
        let img = peeltrim_cli::output::read_images(&out).unwrap();
        assert_eq!(img.depth, opaque.depth, "{style}");
        assert_eq!(img.prim, opaque.prim, "{style}");
        assert_ne!(img.color, opaque.color, "{style}");
        assert_eq!(stats(&out)["style"], style);
        seen.push(img.color);
    }
    for i in 0..seen.len() {
        for j in i + 1..seen.len() {
            assert_ne!(seen[i], seen[j], "styles {i} and {j} look the same");
        }
    }
    // Wireframe: background wherever no layer has an edge.
    let out = tmp("bp-wire");
    render(
        &scene("paper_example.toml"),
        &out,
        &["--style", "wireframe", "--layers-out"],
    );
    let img = peeltrim_cli::output::read_images(&out).unwrap();
    let n = stats(&out)["layers"].as_u64().unwrap() as usize;
    let maps: Vec<Vec<bool>> = (1..=n)
        .map(|k| {
            peeltrim_cli::output::read_edges(out.join(format!("layers/{k:02}")))
                .unwrap()
                .2
        })
        .collect();
    for (i, c) in img.color.iter().enumerate() {
        let any = maps.iter().any(|m| m[i]);
        assert_eq!(*c != [32, 32, 32, 255], any, "pixel {i}: {c:?}");
        if maps[0][i] {
            assert_eq!(*c, [255, 255, 255, 255], "pixel {i}: a visible edge");
        }
    }
}

#[test]
fn style_errors_and_gpu_refusal() {
    let out = tmp("bp-err");
    let o = render(&scene("gear.toml"), &out, &["--style", "sketch"]);
    assert_error(&o, &["sketch", "blueprint-transparent"]);
    let o = render(
        &scene("gear.toml"),
        &out,
        &["--style", "blueprint", "--edge-angle", "0"],
    );
    assert_error(&o, &["--edge-angle", "between 0 and 180"]);
    let o = render(
        &scene("gear.toml"),
        &out,
        &["--edge-depth=-1", "--style", "wireframe"],
    );
    assert_error(&o, &["--edge-depth", "positive"]);
    // A GPU algorithm without layers refuses with exit code 2.
    let o = render(
        &scene("gear.toml"),
        &out,
        &["--style", "blueprint", "--algo", "goldfeather"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("goldfeather"), "{}", stderr(&o));
    // [render] style in a scene file, and a bad one named with its place.
    let dir = tmp("bp-scene");
    let src = std::fs::read_to_string(scene("gear.toml")).unwrap();
    let with = |style: &str| {
        let text = if src.contains("[render]") {
            src.replace("[render]", &format!("[render]\nstyle = \"{style}\""))
        } else {
            format!("{src}\n[render]\nstyle = \"{style}\"\n")
        };
        let p = dir.join(format!("{style}.toml"));
        std::fs::write(&p, text).unwrap();
        p
    };
    let o = render(with("wireframe").to_str().unwrap(), &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stats(&out)["style"], "wireframe");
    let o = render(with("sketchy").to_str().unwrap(), &out, &[]);
    assert_error(&o, &["sketchy.toml:", "render: style", "unknown style"]);
}
