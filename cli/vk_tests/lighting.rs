//! The headlight (`shaders/light.glsl`) against the reference's per-pixel
//! `output::shade` (validation on): a slab seen up close at a grazing angle,
//! where |n . v| changes by half its range across each face. A factor taken per
//! vertex and interpolated (Gouraud) or per face is tens of levels off there;
//! the GPU's factor must be the reference's to one level of rounding at every
//! interior pixel, in every algorithm's shading program (the depth-equal
//! `Shade`, the tie rule's `ShadeNearDepth`, CST's `ShadeAtDepth`, the peels'
//! `PeelShade`), perspective and orthographic.

use peeltrim::plan::{self, Algo, Prepared};
use peeltrim::scene::Scene;
use peeltrim_cli::output::Images;
use peeltrim_cli::render::{DepthSetup, GpuRenderer};

use crate::algorithms::{load_text, SIZE};

/// A wide slab with its top at y = 0, a step whose top is coplanar with it
/// (the tie rule's case), minus a cylinder; seen from 1.2 above the top.
fn slab(camera: &str) -> Scene {
    let text = format!(
        r##"
primitive = [
  {{ name = "Slab", shape = "box", size = [8.0, 0.5, 8.0], translate = [0.0, -0.25, -2.0], color = "#e0c080" }},
  {{ name = "Step", shape = "box", size = [2.0, 0.5, 2.0], translate = [1.2, -0.25, -0.5], color = "#80a0e0" }},
  {{ name = "Hole", shape = "cylinder", radius = 0.5, height = 2.0, translate = [-1.0, 0.0, -1.0], color = "#c06060" }},
]
camera = {camera}
csg = {{ expr = "(Slab + Step) - Hole" }}
"##
    );
    load_text(&text, "lighting.toml")
}

const PERSPECTIVE: &str = r#"{ eye = [0.0, 1.2, 2.0], target = [0.0, -0.4, -2.0] }"#;
const ORTHOGRAPHIC: &str = r#"{ eye = [0.3, 1.0, 2.0], target = [0.0, 0.0, -1.0], projection = "orthographic", ortho_height = 5.0 }"#;

/// Pixels whose 3×3 neighbourhood shows one primitive in both images.
fn interior(a: &Images, b: &Images) -> Vec<usize> {
    let (w, h) = (a.width as usize, a.height as usize);
    let mut v = Vec::new();
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let p = a.prim[y * w + x];
            let same = (0..9).all(|k| {
                let j = (y + k / 3 - 1) * w + x + k % 3 - 1;
                a.prim[j] == p && b.prim[j] == p
            });
            if p != 0 && same {
                v.push(y * w + x);
            }
        }
    }
    v
}

/// The spread of the reference's red channel over primitive `prim`'s pixels.
fn spread(images: &Images, prim: u16) -> u8 {
    let reds = images
        .prim
        .iter()
        .zip(&images.color)
        .filter(|(&p, _)| p == prim)
        .map(|(_, c)| c[0]);
    let (lo, hi) = reds.fold((255, 0), |(lo, hi), r| (r.min(lo), r.max(hi)));
    hi.saturating_sub(lo)
}

/// Every algorithm's colours against the reference's; the slab's shades span
/// at least `min_spread` levels in the reference.
fn check(scene: &Scene, what: &str, min_spread: u8) {
    let reference = peeltrim_reference::render(scene, SIZE.0, SIZE.1);
    let s = spread(&reference, 1);
    assert!(
        s >= min_spread,
        "{what}: the slab's shades span only {s} levels"
    );
    let prep = Prepared::new(scene).unwrap_or_else(|e| panic!("{e}"));
    for algo in [
        Algo::Scs,
        Algo::Goldfeather,
        Algo::Blister,
        Algo::CstI,
        Algo::CstZ,
        Algo::Kirsch,
    ] {
        let plan = plan::build(algo, &prep).unwrap_or_else(|e| panic!("{algo}: {e}"));
        let mut gpu = GpuRenderer::new(scene, crate::setup::device(), DepthSetup::DEFAULT, true)
            .expect("a Vulkan device (lavapipe)");
        let frame = gpu.frame(&plan).unwrap_or_else(|e| panic!("{algo}: {e}"));
        let msgs = gpu.validation_messages();
        assert!(msgs.is_empty(), "{what} {algo}: validation: {msgs:#?}");
        let got = &frame.images;
        let inside = interior(&reference, got);
        assert!(
            inside.len() > 4000,
            "{what} {algo}: {} pixels",
            inside.len()
        );
        let off: Vec<usize> = inside
            .iter()
            .copied()
            .filter(|&i| (0..3).any(|c| got.color[i][c].abs_diff(reference.color[i][c]) > 1))
            .collect();
        if let Some(&i) = off.first() {
            eprintln!(
                "{what} {algo}: pixel {i} gpu {:?} reference {:?}",
                got.color[i], reference.color[i]
            );
        }
        assert!(
            off.is_empty(),
            "{what} {algo}: {} of {} interior colours differ from the reference by more than 1",
            off.len(),
            inside.len()
        );
    }
}

#[test]
fn a_grazing_slab_is_lit_per_pixel_in_perspective() {
    // The top changes shade a lot across the image: a per-vertex or per-face
    // factor could not follow it.
    check(&slab(PERSPECTIVE), "perspective", 40);
}

#[test]
fn a_grazing_slab_is_lit_per_pixel_in_orthographic() {
    // Orthographic: one factor per face, from the view direction (the ray's
    // other branch in mesh.vert).
    check(&slab(ORTHOGRAPHIC), "orthographic", 0);
}
