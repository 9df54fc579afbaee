//! Layers of the solid and transparent rendering, start to finish (seed 000 §6):
//! the options (`--layers`, `--layer-threshold`, `--layers-out`, `--alpha`), the
//! frame they produce, and writing `layers/NN/`. The reference computes them
//! exactly ([`crate::reference::layers`]), kirsch by CSG depth peeling
//! ([`super::kirsch`]); the other GPU algorithms say they cannot yet.
//! Each layer also has view-space normals and, when asked for, an edge map
//! ([`super::edges`]), from which the styles compose `color.png` ([`super::style`]).
#![deny(unsafe_code)]

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use super::edges::{edge_map, EdgeRule};
use super::style::{compose, StyleLayer, DEFAULT_ALPHA};
use super::{Frame, FrameStats, RenderError, RenderOptions};
use crate::output::{write_edges, write_images, write_normals, Images, OutputError};
use crate::plan::Algo;
use crate::plan::PlanError;
use crate::reference::highlight::{highlight_pixel, Highlighted};
use crate::reference::interference::{render_interference, InterferingPair};
use crate::reference::{render_layers_read, LayerLimit, LayerReading};
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
    /// `--layer-reading`: how a union of products is layered (seed 001 §7); `None`:
    /// the algorithm's own (the reference: the solid, kirsch: the products).
    pub reading: Option<LayerReading>,
    /// `--edge-depth`, `--edge-angle`: the edge rule's thresholds.
    pub edge_rule: EdgeRule,
}

impl LayerOptions {
    /// Whether the frame needs layers: asked for, or the scene is see-through.
    pub fn wanted(&self, scene: &Scene) -> bool {
        self.write_layers
            || scene.appearance.interference
            || self.max_layers.is_some()
            || self.reading.is_some()
            || !self.highlight.is_empty()
            || scene.appearance.is_transparent()
            || scene.appearance.style.layered()
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
    /// The style of `color.png` (`--style`, `[render] style`).
    pub style: &'static str,
    /// With edge maps: edge pixels of each layer, layer 1 first.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub edge_pixels: Option<Vec<u64>>,
}

/// A frame with its layers: `images` as the contract's files (the composite in
/// `color.png` when transparent; depth and primitive of layer 1 then), and each
/// layer's own images.
#[derive(Clone, Debug)]
pub struct LayeredFrame {
    pub frame: Frame,
    pub layers: Vec<Images>,
    /// Each layer's view-space normals ([`crate::reference::layers::LayerHit::normal`]).
    pub normals: Vec<Vec<[f32; 3]>>,
    /// Each layer's edge map, when the style or `--layers-out` needs them (else empty).
    pub edges: Vec<Vec<bool>>,
    pub layer_stats: LayerStats,
}

/// Renders `scene` with its layers. The reference can, and kirsch (products each
/// on their own, without highlight or interference); other algorithms get
/// [`RenderError::Unsupported`].
pub fn render_layered(
    scene: &Scene,
    opts: &RenderOptions,
    lopts: &LayerOptions,
) -> Result<LayeredFrame, RenderError> {
    if opts.algo != Algo::Reference && super::interference::interference_only(scene, lopts) {
        return super::interference::layered_frame(scene, opts);
    }
    let extras = !lopts.highlight.is_empty() || scene.appearance.interference;
    if opts.algo == Algo::Kirsch && lopts.reading == Some(LayerReading::Solid) {
        return Err(RenderError::Unsupported {
            algo: opts.algo.name().to_string(),
            what: "the solid's layers as one volume (--layer-reading solid; kirsch peels each \
                   product on its own: --layer-reading products)",
        });
    }
    // Styles and edge maps need each layer's normals, which kirsch does not read back yet.
    let styled = scene.appearance.style.layered() || lopts.write_layers;
    if opts.algo == Algo::Kirsch && !extras && !styled {
        return super::kirsch::render_layered(scene, opts, lopts);
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
    let reading = lopts.reading.unwrap_or_default();
    let stack = render_layers_read(
        scene,
        w,
        h,
        lopts.limit(),
        reading,
        opts.build.products.limit,
    )
    .map_err(|e| PlanError::Products(e.to_string()))?;
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
        style: scene.appearance.style.name(),
        ..Default::default()
    };
    if interference {
        let img = render_interference(scene, w, h);
        frame.images.color = img.color;
        layer_stats.interference_pixels = Some(img.mask.iter().filter(|&&m| m).count() as u64);
        layer_stats.interference = Some(img.pairs);
    }
    let style = scene.appearance.style;
    let edges: Vec<Vec<bool>> = if style.edges() || lopts.write_layers {
        stack
            .layers
            .iter()
            .zip(&stack.normals)
            .map(|(l, n)| edge_map(&l.depth, n, w, h, &lopts.edge_rule))
            .collect()
    } else {
        vec![]
    };
    if !edges.is_empty() {
        layer_stats.edge_pixels = Some(edges.iter().map(|e| super::edges::count(e)).collect());
    }
    if style.layered() {
        let opacity = |hit: &crate::reference::layers::LayerHit| {
            if transparent {
                scene.appearance.alpha_of(hit.prim, hit.solid)
            } else {
                DEFAULT_ALPHA
            }
        };
        let styled: Vec<StyleLayer> = stack
            .layers
            .iter()
            .enumerate()
            .map(|(k, l)| StyleLayer {
                color: &l.color,
                covered: l.depth.iter().map(|d| d.is_finite()).collect(),
                edges: edges.get(k).map_or(&[][..], |e| &e[..]),
                alpha: stack
                    .hits
                    .iter()
                    .map(|v| v.get(k).map_or(1.0, |hit| opacity(hit)))
                    .collect(),
            })
            .collect();
        let n = w as usize * h as usize;
        frame.images.color = compose(style, &styled, scene.render.background, n);
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
        normals: stack.normals,
        edges,
        layer_stats,
    })
}

/// Writes layer k (0-based) into `dir/layers/{k+1:02}/` (`color.png`, `depth.npy`,
/// `prim.png`, and `normal.npy` and `edges.png` where the frame has them).
pub fn write_layers(dir: &Path, frame: &LayeredFrame) -> Result<(), OutputError> {
    for (k, img) in frame.layers.iter().enumerate() {
        let sub = dir.join("layers").join(format!("{:02}", k + 1));
        write_images(&sub, img)?;
        if let Some(n) = frame.normals.get(k) {
            write_normals(&sub, img.width, img.height, n)?;
        }
        if let Some(e) = frame.edges.get(k) {
            write_edges(&sub, img.width, img.height, e)?;
        }
    }
    Ok(())
}
