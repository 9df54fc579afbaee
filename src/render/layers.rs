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
use crate::reference::{render_layers, LayerLimit};
use crate::scene::Scene;

/// What the command line asks of layers and transparency.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LayerOptions {
    /// `--layers N`: peel at most N layers.
    pub max_layers: Option<u32>,
    /// `--layer-threshold N`: stop at the first layer covering fewer than N pixels.
    pub threshold: u64,
    /// `--layers-out`: write `layers/01/`, `layers/02/`, … next to the images.
    pub write_layers: bool,
}

impl LayerOptions {
    /// Whether the frame needs layers: asked for, or the scene is see-through.
    pub fn wanted(&self, scene: &Scene) -> bool {
        self.write_layers || self.max_layers.is_some() || scene.appearance.is_transparent()
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
    if opts.algo != Algo::Reference {
        return Err(RenderError::Unsupported {
            algo: opts.algo.name().to_string(),
            what: "layers and transparency (--layers, --layers-out, --alpha, alpha keys)",
        });
    }
    let transparent = scene.appearance.is_transparent();
    let t = Instant::now();
    let (w, h) = (scene.render.width, scene.render.height);
    let stack = render_layers(scene, w, h, lopts.limit());
    let mut frame = if transparent {
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
    let layer_stats = LayerStats {
        layers: stack.layers.len() as u32,
        layer_pixels: stack
            .layers
            .iter()
            .map(|l| l.prim.iter().filter(|&&p| p != 0).count() as u64)
            .collect(),
        transparent,
    };
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
