//! Interference of an assembly on the GPU (seed 000 §6, Fig. 1c). §6 renders
//! `(A−B')+(B−A')` with primed copies in the interference colour: the primed
//! faces on that solid's boundary are exactly the boundary of `A·B`, and the
//! nearest of them along a pixel's line is where the line first enters `A·B`. So
//! each pair of solids is rendered as the one solid `A·B` by the chosen CST
//! variant, every primitive coloured [`INTERFERENCE_RGB`]: its coverage is the
//! pair's pixels, and the nearest pair's visible point is the opaque
//! interference. The reference ([`crate::reference::interference`]) computes the
//! same sets exactly.
//!
//! Not yet on the GPU: the solids' semi-transparent layers in front (the GPU
//! layers are another issue's); `color.png` shows the interference opaque over
//! the solids' opaque image meanwhile.
#![deny(unsafe_code)]

use super::layers::{LayerOptions, LayerStats, LayeredFrame, SolidLayer};
use super::{Frame, RenderError, RenderOptions};
use crate::plan::Algo;
use crate::reference::interference::{InterferingPair, INTERFERENCE_RGB};
use crate::scene::{Appearance, Scene, Solid};

/// The GPU's interference of a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuInterference {
    /// Per pixel: the nearest pair intersection's shaded colour, where there is one.
    pub color: Vec<Option<[u8; 4]>>,
    /// Pairs with at least one pixel, in solid order.
    pub pairs: Vec<InterferingPair>,
    /// GPU time of all pair frames.
    pub gpu_ms: f64,
}

impl GpuInterference {
    /// Pixels showing an interference.
    pub fn mask(&self) -> Vec<bool> {
        self.color.iter().map(Option::is_some).collect()
    }
}

/// The algorithms that can: the CST variants.
pub fn supported(algo: Algo) -> bool {
    matches!(algo, Algo::CstZ | Algo::CstI | Algo::CstG)
}

/// `scene` reduced to the one solid `a · b`, drawn in the interference colour.
pub fn pair_scene(scene: &Scene, a: &Solid, b: &Solid) -> Scene {
    let mut s = scene.clone();
    s.solids = vec![Solid {
        name: format!("{}*{}", a.name, b.name),
        expr: a.expr.inter(&b.expr),
    }];
    s.surfaces.clear();
    for p in &mut s.primitives {
        p.color = INTERFERENCE_RGB;
    }
    s.appearance = Appearance::default();
    s
}

/// Renders every pair's intersection with `opts.algo` (a CST variant).
pub fn gpu_interference(
    scene: &Scene,
    opts: &RenderOptions,
) -> Result<GpuInterference, RenderError> {
    if !supported(opts.algo) {
        return Err(RenderError::Unsupported {
            algo: opts.algo.name().to_string(),
            what: "interference (--interference; cst-z, cst-i and cst-g can)",
        });
    }
    let n = scene.render.width as usize * scene.render.height as usize;
    let mut nearest = vec![f32::INFINITY; n];
    let mut out = GpuInterference {
        color: vec![None; n],
        pairs: Vec::new(),
        gpu_ms: 0.0,
    };
    for (i, a) in scene.solids.iter().enumerate() {
        for b in &scene.solids[i + 1..] {
            let f = super::render_opaque(&pair_scene(scene, a, b), opts)?;
            out.gpu_ms += f.stats.exec.gpu_ms;
            let mut pixels = 0;
            for (k, (&p, &d)) in f.images.prim.iter().zip(&f.images.depth).enumerate() {
                if p == 0 {
                    continue;
                }
                pixels += 1;
                if d < nearest[k] {
                    nearest[k] = d;
                    out.color[k] = Some(f.images.color[k]);
                }
            }
            if pixels > 0 {
                out.pairs.push(InterferingPair {
                    solids: [a.name.clone(), b.name.clone()],
                    pixels,
                });
            }
        }
    }
    Ok(out)
}

/// The interference view of a GPU algorithm: the opaque frame of the scene, the
/// interference drawn over it.
pub fn render_interference(
    scene: &Scene,
    opts: &RenderOptions,
) -> Result<(Frame, GpuInterference), RenderError> {
    let t = std::time::Instant::now();
    let inter = gpu_interference(scene, opts)?;
    let mut frame = super::render_opaque(scene, opts)?;
    for (c, i) in frame.images.color.iter_mut().zip(&inter.color) {
        if let Some(i) = i {
            *c = *i;
        }
    }
    frame.stats.exec.gpu_ms += inter.gpu_ms;
    frame.stats.exec.cpu_ms = t.elapsed().as_secs_f64() * 1e3;
    Ok((frame, inter))
}

/// Whether `--interference` is all the layered features asked for (the part the
/// GPU does without layers).
pub fn interference_only(scene: &Scene, lopts: &LayerOptions) -> bool {
    scene.appearance.interference
        && !scene.appearance.is_transparent()
        && lopts.max_layers.is_none()
        && !lopts.write_layers
        && lopts.highlight.is_empty()
        && !scene.appearance.style.layered()
}

/// [`render_interference`] as the layered renderer's answer: layer 1 is the
/// opaque frame; `stats.json` gets the pairs and the interference's pixels.
pub fn layered_frame(scene: &Scene, opts: &RenderOptions) -> Result<LayeredFrame, RenderError> {
    let (mut frame, inter) = render_interference(scene, opts)?;
    let layer_stats = LayerStats {
        layers: 1,
        layer_pixels: vec![frame.images.prim.iter().filter(|&&p| p != 0).count() as u64],
        transparent: false,
        interference_pixels: Some(inter.color.iter().filter(|c| c.is_some()).count() as u64),
        interference: Some(inter.pairs),
        style: scene.appearance.style.name(),
        ..Default::default()
    };
    frame.stats.layers = Some(layer_stats.clone());
    Ok(LayeredFrame {
        layers: vec![SolidLayer::new(frame.images.clone())],
        // The GPU's interference frame has no normal buffer, so no edge maps.
        edges: vec![],
        frame,
        layer_stats,
    })
}
