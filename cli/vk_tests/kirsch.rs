//! Kirsch's CSG depth peeling (Kirsch, Nienhaus & Döllner §4) on every shipped scene,
//! validation on: its first layer is the opaque render (against the reference like
//! every algorithm), its layers 1–4 match the reference's layers of the same reading
//! (products each on their own, §7a), and its transparent composite matches the
//! reference's; its layers' edge maps (from the executor's normal buffer) match
//! the reference's, and so does a style composed from them.

use peeltrim::plan::Algo;
use peeltrim::scene::style::Style;
use peeltrim::scene::Scene;
use peeltrim_cli::output::Images;
use peeltrim_cli::render::edges::edge_map;
use peeltrim_cli::render::layers::{render_layered, LayerOptions, LayeredFrame};
use peeltrim_reference::compare::compare;
use peeltrim_reference::{render_layers_read, LayerLimit, LayerReading, LayerStack};

use crate::algorithms::{check_algo, load, shipped_scenes, SIZE};
use crate::setup::options;

/// The bar on the first layer: 0.05% interior mismatches.
#[test]
fn kirsch_matches_reference_on_shipped_scenes() {
    check_algo(Algo::Kirsch, &crate::setup::usable_setups(), 0.0005, 0.0005);
}

fn kirsch_layers(scene: &Scene, max: u32) -> Option<LayeredFrame> {
    let lopts = LayerOptions {
        max_layers: Some(max),
        ..Default::default()
    };
    kirsch_layered(scene, &lopts)
}

/// The reference's layers 1..=max, products each on their own (§7a).
fn products_reading(scene: &Scene, name: &str, max: u32) -> LayerStack {
    let limit = LayerLimit {
        max: Some(max as usize),
        threshold: 0,
    };
    render_layers_read(scene, SIZE.0, SIZE.1, limit, LayerReading::Products, 4096)
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn kirsch_layered(scene: &Scene, lopts: &LayerOptions) -> Option<LayeredFrame> {
    match render_layered(scene, &options(Algo::Kirsch), lopts) {
        Ok(f) => Some(f),
        // A scene of surfaces only has no layers of a solid.
        Err(peeltrim_cli::render::RenderError::Plan(peeltrim::plan::PlanError::NoSolid)) => None,
        Err(e) => panic!("{e}"),
    }
}

/// Layers k ≤ 4 against the reference's §7a layers: ≤ 0.1% interior coverage and
/// primitive mismatches each; a layer only one side has covers ≤ 0.1% of the pixels.
#[test]
fn kirsch_layers_match_the_products_reading() {
    const MAX: u32 = 4;
    let mut failures = Vec::new();
    let mut checked = 0;
    for path in shipped_scenes() {
        let mut scene = load(&path);
        // Layers only: kirsch does not draw interference (scenes/interference.toml).
        scene.appearance.interference = false;
        if scene.solids.is_empty() {
            continue;
        }
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let reference = products_reading(&scene, &name, MAX);
        let Some(gpu) = kirsch_layers(&scene, MAX) else {
            continue;
        };
        // A layer only one side has must be a sliver (≤ 0.1% of the pixels).
        let gpu_images: Vec<&Images> = gpu.layers.iter().map(|l| &l.images).collect();
        let ref_images: Vec<&Images> = reference.layers.iter().collect();
        let (gn, rn) = (gpu_images.len(), ref_images.len());
        let longer = if gn > rn { &gpu_images } else { &ref_images };
        for (k, l) in longer.iter().enumerate().skip(gn.min(rn)) {
            let covered = l.prim.iter().filter(|&&p| p != 0).count();
            eprintln!("kirsch {name} layer {}: {covered} pixels on one side only ({gn} layers, the reference {rn})", k + 1);
            if covered * 1000 > l.prim.len() {
                failures.push(format!("{name}: {gn} layers, the reference {rn}"));
            }
        }
        for (k, (r, g)) in ref_images.iter().zip(&gpu_images).enumerate() {
            let c = compare(r, g).expect("same size");
            eprintln!(
                "kirsch {name} layer {}: coverage {:.4}% prim {:.4}% depth p99 {:.2e}",
                k + 1,
                c.coverage_mismatch_interior_frac * 100.0,
                c.prim_mismatch_interior_frac * 100.0,
                c.depth_abs_err_p99_interior
            );
            checked += 1;
            if c.coverage_mismatch_interior_frac > 0.001 || c.prim_mismatch_interior_frac > 0.001 {
                failures.push(format!("{name} layer {}: {c:?}", k + 1));
            }
        }
        // The counted pixels are the read-back layers' coverage.
        for (k, g) in gpu_images.iter().enumerate() {
            let covered = g.prim.iter().filter(|&&p| p != 0).count() as u64;
            assert_eq!(gpu.layer_stats.layer_pixels[k], covered, "{name} layer {k}");
        }
    }
    assert!(checked >= 16, "only {checked} layers compared");
    assert!(
        failures.is_empty(),
        "kirsch's layers miss the bar on:\n{}",
        failures.join("\n")
    );
}

/// `--alpha 0.4`: the back-to-front composite of kirsch's layers against the
/// reference's front-to-back blend of the same layers: ≤ 1% of interior pixels off
/// by more than 4 levels.
#[test]
fn kirsch_transparency_matches_the_reference() {
    for name in ["drilled_block.toml", "gear.toml"] {
        let mut scene = load(&crate::setup::scenes_dir().join(name));
        scene.appearance.alpha = Some(0.4);
        let reference = render_layers_read(
            &scene,
            SIZE.0,
            SIZE.1,
            LayerLimit::default(),
            LayerReading::Products,
            4096,
        )
        .unwrap();
        let gpu = kirsch_layers(&scene, u32::MAX).expect("a solid");
        assert!(gpu.layer_stats.transparent);
        let prim = &reference.layers[0].prim;
        let (w, h) = (SIZE.0 as usize, SIZE.1 as usize);
        // Interior: the 3×3 neighbourhood has one primitive in every reference layer.
        let interior = |i: usize| {
            let (x, y) = (i % w, i / w);
            x > 0
                && y > 0
                && x + 1 < w
                && y + 1 < h
                && reference.layers.iter().all(|l| {
                    (0..9).all(|d| l.prim[(y + d / 3 - 1) * w + x + d % 3 - 1] == l.prim[i])
                })
        };
        let (mut n, mut off) = (0, 0);
        for i in 0..prim.len() {
            if !interior(i) {
                continue;
            }
            n += 1;
            let (a, b) = (reference.composite[i], gpu.frame.images.color[i]);
            if (0..3).any(|c| (a[c] as i32 - b[c] as i32).abs() > 4) {
                off += 1;
            }
        }
        eprintln!("kirsch {name} alpha 0.4: {off} of {n} interior pixels off");
        assert!(n > 1000 && off * 100 <= n, "{name}: {off} of {n}");
    }
}

/// `--layers-out` with layers k ≤ 3: each kirsch layer has normals and an edge map,
/// and the edge map finds the reference's (the edge rule on the products reading's
/// depth and normals): ≥ 99% of the reference's edge pixels within one pixel of
/// ours, ≤ 1% of ours farther. `stats.json`'s `edge_pixels` counts the maps.
#[test]
fn kirsch_edge_maps_match_the_products_reading() {
    const MAX: u32 = 3;
    let mut checked = 0;
    for name in ["drilled_block.toml", "gear.toml", "complex.toml"] {
        let scene = load(&crate::setup::scenes_dir().join(name));
        let lopts = LayerOptions {
            max_layers: Some(MAX),
            write_layers: true,
            ..Default::default()
        };
        let reference = products_reading(&scene, &name, MAX);
        let gpu = kirsch_layered(&scene, &lopts).expect("a solid");
        assert_eq!(
            gpu.edges.len(),
            gpu.layers.len(),
            "{name}: an edge map a layer"
        );
        let counts: Vec<u64> = gpu
            .edges
            .iter()
            .map(|e| e.iter().filter(|&&b| b).count() as u64)
            .collect();
        assert_eq!(
            gpu.layer_stats.edge_pixels.as_ref(),
            Some(&counts),
            "{name}"
        );
        for (k, (l, ours)) in gpu.layers.iter().zip(&gpu.edges).enumerate() {
            let normals = l
                .normal
                .as_ref()
                .unwrap_or_else(|| panic!("{name} layer {}: no normals", k + 1));
            assert_eq!(normals.len(), l.images.depth.len());
            let Some(r) = reference.layers.get(k) else {
                continue;
            };
            let ref_edges = edge_map(
                &r.depth,
                &reference.normals[k],
                SIZE.0,
                SIZE.1,
                &lopts.edge_rule,
            );
            crate::setup::assert_layer_edges(&format!("kirsch {name}"), k, &ref_edges, ours, SIZE);
            checked += 1;
        }
    }
    assert!(checked >= 6, "only {checked} layers compared");
}

/// A style on kirsch's layers (blueprint, wireframe) against the reference's, both
/// reading the products: ≤ 1% of the pixels off by more than 4 levels (the edge
/// maps may differ by a pixel where a threshold is met within rounding).
#[test]
fn kirsch_styles_match_the_reference() {
    for style in [Style::Blueprint, Style::Wireframe] {
        for name in ["drilled_block.toml", "gear.toml"] {
            let mut scene = load(&crate::setup::scenes_dir().join(name));
            scene.appearance.style = style;
            let lopts = LayerOptions {
                max_layers: Some(4),
                reading: Some(LayerReading::Products),
                ..Default::default()
            };
            let reference = render_layered(&scene, &options(Algo::Reference), &lopts).unwrap();
            let gpu = kirsch_layered(&scene, &lopts).expect("a solid");
            assert_eq!(gpu.layer_stats.style, style.name());
            let (a, b) = (&reference.frame.images.color, &gpu.frame.images.color);
            let off = a
                .iter()
                .zip(b)
                .filter(|(a, b)| (0..3).any(|c| (a[c] as i32 - b[c] as i32).abs() > 4))
                .count();
            let background = b
                .iter()
                .filter(|c| c[..3] == scene.render.background)
                .count();
            eprintln!(
                "kirsch {name} {}: {off} of {} pixels off",
                style.name(),
                a.len()
            );
            assert!(background < a.len(), "{name}: the style drew nothing");
            assert!(
                off * 100 <= a.len(),
                "{name} {}: {off} of {} pixels off",
                style.name(),
                a.len()
            );
        }
    }
}
