//! Layers of the solid and transparent rendering, start to finish (seed 000 §6):
//! the options (`--layers`, `--layer-threshold`, `--layers-out`, `--alpha`), the
//! frame they produce, and writing `layers/NN/`. The reference computes them
//! exactly ([`crate::reference::layers`]); the GPU algorithms say they cannot yet.
#![deny(unsafe_code)]

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use super::{Frame, FrameStats, RenderError, RenderOptions};
use crate::output::{write_images, Images, OutputError};
use crate::plan::Algo;
use crate::reference::highlight::{highlight_pixel, Highlighted};
use crate::reference::interference::{render_interference, InterferingPair};
use crate::reference::{render_layers, LayerLimit};
use crate::scene::Scene;

/// What the command line asks of layers and transparency.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LayerOptions {
    /// `--layers N`: peel at most N layers.
    pub max_layers: Option<u32>,
    /// `--layer-threshold N`: stop at the first layer covering fewer than N pixels.
    pub threshold: u64,
    /// `--layers-out`: write `layers/01/`, `layers/02/`, … next to the images.
    pub write_layers: bool,
    /// `--highlight NAME,...`: 0-based indices of the primitives to highlight.
    pub highlight: Vec<u32>,
}

impl LayerOptions {
    /// Whether the frame needs layers: asked for, or the scene is see-through.
    pub fn wanted(&self, scene: &Scene) -> bool {
        self.write_layers
            || scene.appearance.interference
            || self.max_layers.is_some()
            || !self.highlight.is_empty()
            || scene.appearance.is_transparent()
    }

    fn limit(&self) -> LayerLimit {
        LayerLimit {
            max: self.max_layers.map(|n| n as usize),
            threshold: self.threshold,
        }
    }
}

/// The layer figures of `stats.json`.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LayerStats {
    /// Layers peeled (the last one covers at least the threshold's pixels).
    pub layers: u32,
    /// Pixels each layer covers, layer 1 first.
    pub layer_pixels: Vec<u64>,
    /// `color.png` is the alpha composite of the layers.
    pub transparent: bool,
    /// With `--highlight`: pixels where a highlighted face is the first layer.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub highlighted_pixels: Option<u64>,
    /// With `--highlight`: pixels where one lies hidden behind other faces.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub highlighted_hidden_pixels: Option<u64>,
    /// With interference: the pairs of solids that intersect, with the pixels
    /// whose ray meets their intersection.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interference: Option<Vec<InterferingPair>>,
    /// With interference: pixels showing an interference.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interference_pixels: Option<u64>,
}

/// A frame with its layers: `images` as the contract's files (the composite in
/// `color.png` when transparent; depth and primitive of layer 1 then), and each
/// layer's own images.
#[derive(Clone, Debug)]
pub struct LayeredFrame {
    pub frame: Frame,
    pub layers: Vec<Images>,
    pub layer_stats: LayerStats,
}

/// Renders `scene` with its layers. Only the reference can yet; other algorithms
/// get [`RenderError::Unsupported`].
pub fn render_layered(
    scene: &Scene,
    opts: &RenderOptions,
    lopts: &LayerOptions,
) -> Result<LayeredFrame, RenderError> {
    if opts.algo != Algo::Reference && super::interference::interference_only(scene, lopts) {
        return super::interference::layered_frame(scene, opts);
    }
    if opts.algo != Algo::Reference {
        return Err(RenderError::Unsupported {
            algo: opts.algo.name().to_string(),
            what: "layers, transparency, highlight and interference (--layers, --layers-out, --alpha, alpha keys, --highlight, --interference)",
        });
    }
    let transparent = scene.appearance.is_transparent();
    let interference = scene.appearance.interference;
    let t = Instant::now();
    let (w, h) = (scene.render.width, scene.render.height);
    let stack = render_layers(scene, w, h, lopts.limit());
    let mut frame = if transparent || interference {
        let first = stack.layers.first();
        let n = w as usize * h as usize;
        Frame {
            images: Images {
                width: w,
                height: h,
                color: stack.composite.clone(),
                depth: first.map_or_else(|| vec![f32::INFINITY; n], |l| l.depth.clone()),
                prim: first.map_or_else(|| vec![0; n], |l| l.prim.clone()),
            },
            stats: FrameStats::default(),
        }
    } else {
        super::render_reference(scene)
    };
    frame.stats = super::reference_stats(&frame.images, t.elapsed().as_secs_f64() * 1e3);
    let mut layer_stats = LayerStats {
        layers: stack.layers.len() as u32,
        layer_pixels: stack
            .layers
            .iter()
            .map(|l| l.prim.iter().filter(|&&p| p != 0).count() as u64)
            .collect(),
        transparent,
        ..Default::default()
    };
    if interference {
        let img = render_interference(scene, w, h);
        frame.images.color = img.color;
        layer_stats.interference_pixels = Some(img.mask.iter().filter(|&&m| m).count() as u64);
        layer_stats.interference = Some(img.pairs);
    }
    if !lopts.highlight.is_empty() {
        let mut chosen = vec![false; scene.primitives.len()];
        for &p in &lopts.highlight {
            chosen[p as usize] = true;
        }
        let (mut shown, mut hidden) = (0, 0);
        for (c, hits) in frame.images.color.iter_mut().zip(&stack.hits) {
            let (out, h) = highlight_pixel(hits, *c, &chosen);
            *c = out;
            match h {
                Highlighted::Visible => shown += 1,
                Highlighted::Hidden => hidden += 1,
                Highlighted::No => {}
            }
        }
        layer_stats.highlighted_pixels = Some(shown);
        layer_stats.highlighted_hidden_pixels = Some(hidden);
    }
    frame.stats.layers = Some(layer_stats.clone());
    Ok(LayeredFrame {
        frame,
        layers: stack.layers,
        layer_stats,
    })
}

/// Writes layer k (0-based) into `dir/layers/{k+1:02}/` (`color.png`, `depth.npy`,
/// `prim.png`).
pub fn write_layers(dir: &Path, layers: &[Images]) -> Result<(), OutputError> {
    for (k, img) in layers.iter().enumerate() {
        write_images(dir.join("layers").join(format!("{:02}", k + 1)), img)?;
    }
    Ok(())
}
