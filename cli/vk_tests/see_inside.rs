//! Transparency and interference on the GPU (Hable & Rossignac §6),
//! validation on: the GPU composite (each peeled layer blended into the accumulation
//! target as it is peeled) against the CPU blend of the same layers and the
//! exact reference, with per-primitive opacities; and interference combined
//! with opacities and `--layers` on an assembly made for this test.

use peeltrim::plan::Algo;
use peeltrim::scene::{self, LoadOptions};
use peeltrim_cli::output::Images;
use peeltrim_cli::render::interference::gpu_interference;
use peeltrim_cli::render::layers::LayerOptions;
use peeltrim_reference::compare::{boundary_mask, compare};
use peeltrim_reference::layers::blend_colors;

use crate::gpu_layers::layered;
use crate::setup::options;

const CST: [Algo; 3] = [Algo::CstZ, Algo::CstI, Algo::CstG];

/// Pixels not within a pixel of a coverage or primitive change of any layer,
/// nor of a change of `mask` (when given).
fn interior(layers: &[&Images], mask: Option<&[bool]>) -> Vec<bool> {
    let (w, h) = (layers[0].width as usize, layers[0].height as usize);
    let mut keep = vec![true; w * h];
    for l in layers {
        for (k, b) in keep.iter_mut().zip(boundary_mask(l)) {
            *k &= !b;
        }
    }
    if let Some(m) = mask {
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let differs = (y.saturating_sub(1)..(y + 2).min(h))
                    .flat_map(|ny| (x.saturating_sub(1)..(x + 2).min(w)).map(move |nx| ny * w + nx))
                    .any(|j| m[j] != m[i]);
                keep[i] &= !differs;
            }
        }
    }
    keep
}

/// Interior pixels (of `inside`) where `a` and `b` differ by more than 2/255,
/// and how many interior pixels there are.
fn colour_off(a: &[[u8; 4]], b: &[[u8; 4]], inside: &[bool]) -> (usize, usize) {
    let n = inside.iter().filter(|&&k| k).count();
    let off = (0..a.len())
        .filter(|&i| inside[i] && (0..3).any(|c| a[i][c].abs_diff(b[i][c]) > 2))
        .count();
    (off, n)
}

#[test]
fn gpu_composite_blends_each_layer_as_peeled() {
    let path = crate::setup::scenes_dir().join("drilled_block.toml");
    let mut s = scene::load(
        &path,
        &LoadOptions {
            size: Some((96, 72)),
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    // Opacities that differ by primitive, so the table lookup matters.
    s.appearance.alpha = Some(0.45);
    s.appearance.primitive_alpha = (0..s.primitives.len())
        .map(|p| (p % 3 == 1).then_some(0.8))
        .collect();
    let kept = LayerOptions {
        write_layers: true,
        ..Default::default()
    };
    let reference = layered(&s, Algo::Reference, &LayerOptions::default());
    for algo in CST {
        let with_layers = layered(&s, algo, &kept);
        let alone = layered(&s, algo, &LayerOptions::default());
        let st = &alone.layer_stats;
        assert_eq!(st.composited_on_gpu, Some(true), "{}", algo.name());
        // Nothing but the composite was read back: no layers kept.
        assert!(alone.layers.is_empty());
        assert_eq!(st.layer_pixels, with_layers.layer_stats.layer_pixels);
        assert_eq!(st.layers as usize, with_layers.layers.len());
        // Reading the layers back changes nothing on the GPU.
        assert_eq!(alone.frame.images, with_layers.frame.images);
        // The accumulate pass against the CPU blend of the same 8-bit layers
        // (f32 against f64): within 1/255 everywhere.
        for i in 0..alone.frame.images.color.len() {
            let hits = with_layers.layers.iter().map_while(|l| {
                let p = l.images.prim[i];
                (p != 0).then(|| (s.appearance.alpha_of(p as u32 - 1, 0), l.images.color[i]))
            });
            let cpu = blend_colors(hits, s.render.background);
            let gpu = alone.frame.images.color[i];
            assert!(
                (0..3).all(|c| cpu[c].abs_diff(gpu[c]) <= 1),
                "{} pixel {i}: {gpu:?} vs {cpu:?}",
                algo.name()
            );
        }
        // And against the exact reference.
        let images: Vec<&Images> = reference.layers.iter().map(|l| &l.images).collect();
        let inside = interior(&images, None);
        let (off, n) = colour_off(
            &alone.frame.images.color,
            &reference.frame.images.color,
            &inside,
        );
        eprintln!(
            "{}: composite off by > 2/255 at {off} of {n} interior pixels",
            algo.name()
        );
        assert!(n > 1000 && off as f64 <= 1e-3 * n as f64, "{off} of {n}");
        // depth.npy and prim.png are layer 1's.
        let c = compare(&reference.layers[0].images, &alone.frame.images).unwrap();
        assert!(c.prim_mismatch_interior_frac <= 1e-3, "{c:?}");
    }
}

/// An assembly none of the shipped scenes has: a plate, a peg through it, and a
/// ball overlapping the peg above the plate, each solid with its own opacity;
/// plate and ball do not meet.
const ASSEMBLY: &str = r##"
name = "see-inside-assembly"
[camera]
eye = [2.2, 3.0, 3.4]
target = [0.0, 0.2, 0.0]
fit = true
[render]
interference = true
alpha = 0.5
[[primitive]]
name = "Plate"
shape = "box"
size = [2.4, 0.4, 1.6]
color = "#b0b0c8"
[[primitive]]
name = "Slot"
shape = "box"
size = [0.5, 1.0, 0.5]
translate = [-0.7, 0.0, 0.0]
color = "#707090"
[[primitive]]
name = "Peg"
shape = "cylinder"
radius = 0.3
height = 1.8
translate = [0.3, 0.4, 0.0]
color = "#c08040"
[[primitive]]
name = "Ball"
shape = "sphere"
radius = 0.45
translate = [0.3, 1.2, 0.3]
color = "#40a0c0"
[[solid]]
name = "plate"
expr = "Plate - Slot"
alpha = 0.35
[[solid]]
name = "peg"
expr = "Peg"
[[solid]]
name = "ball"
expr = "Ball"
alpha = 0.6
"##;

#[test]
fn interference_with_opacities_and_layers_matches_the_reference() {
    let dir = std::env::temp_dir().join(format!("peeltrim-see-inside-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("assembly.toml");
    std::fs::write(&path, ASSEMBLY).unwrap();
    let s = scene::load(
        &path,
        &LoadOptions {
            size: Some((96, 72)),
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let (w, h) = (s.render.width, s.render.height);
    let lopts = LayerOptions {
        max_layers: Some(3),
        write_layers: true,
        ..Default::default()
    };
    let reference = layered(&s, Algo::Reference, &lopts);
    let want = peeltrim_reference::interference::render_interference(&s, w, h);
    let names = |p: &[peeltrim_reference::interference::InterferingPair]| {
        p.iter().map(|p| p.solids.clone()).collect::<Vec<_>>()
    };
    assert_eq!(
        names(&want.pairs),
        [["plate", "peg"], ["peg", "ball"]].map(|p| p.map(String::from))
    );
    let images: Vec<&Images> = reference.layers.iter().map(|l| &l.images).collect();
    let inside = interior(&images, Some(&want.mask));
    for algo in CST {
        let got = layered(&s, algo, &lopts);
        let st = &got.layer_stats;
        let what = format!("{}: {st:?}", algo.name());
        // The pairs and their pixels (within 2%).
        let pairs = &st.interference.as_ref().expect("pairs").pairs;
        assert_eq!(names(pairs), names(&want.pairs), "{what}");
        for (g, r) in pairs.iter().zip(&want.pairs) {
            assert!(g.pixels.abs_diff(r.pixels) * 50 <= r.pixels, "{what}");
        }
        // The interference's pixel set, interior: ≤ 0.1% differ.
        let mask = gpu_interference(&s, &options(algo)).unwrap().mask();
        let n = inside.iter().filter(|&&k| k).count();
        let wrong = (0..mask.len())
            .filter(|&i| inside[i] && mask[i] != want.mask[i])
            .count();
        assert!(
            wrong as f64 <= 1e-3 * n as f64,
            "{what}: mask {wrong} of {n}"
        );
        // The view: within 2/255 at ≥ 99.9% of the interior pixels.
        let (off, n) = colour_off(&got.frame.images.color, &want.color, &inside);
        eprintln!(
            "{}: interference view off by > 2/255 at {off} of {n} interior pixels",
            algo.name()
        );
        assert!(
            n > 1000 && off as f64 <= 1e-3 * n as f64,
            "{what}: {off} of {n}"
        );
        // `--layers 3`: the first three layers, as the reference's.
        assert_eq!(st.layers, 3, "{what}");
        assert_eq!(got.layers.len(), reference.layers.len(), "{what}");
        assert_eq!(got.edges.len(), 3, "{what}: --layers-out has edge maps");
        for (k, (r, g)) in reference.layers.iter().zip(&got.layers).enumerate() {
            let c = compare(&r.images, &g.images).unwrap();
            assert!(
                c.coverage_mismatch_interior_frac <= 1e-3 && c.prim_mismatch_interior_frac <= 1e-3,
                "{what} layer {}: {c:?}",
                k + 1
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
