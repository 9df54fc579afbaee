//! Interference of an assembly on the GPU (Hable & Rossignac §6, Fig. 1c). §6 renders
//! `(A−B')+(B−A')` with primed copies in the interference colour: the primed
//! faces on that solid's boundary are exactly the boundary of `A·B`, and the
//! nearest of them along a pixel's line is where the line first enters `A·B`. So
//! each pair of solids is rendered as the one solid `A·B` by the chosen CST
//! variant, every primitive coloured [`INTERFERENCE_RGB`]: its coverage is the
//! pair's pixels, and the nearest pair's visible point is the opaque
//! interference. The reference ([`peeltrim_reference::interference`]) computes the
//! same sets exactly. The solids' layers in front of it are the GPU's layers of
//! the solid (Hable & Rossignac §6, `render::gpu_layers`), blended semi-transparent.
#![deny(unsafe_code)]

use super::edges::edge_map;
use super::gpu_layers::{self, GpuLayers, StreamLimit};
use super::layers::{GpuLayerFigures, InterferenceFigures, LayerOptions, LayerStats, LayeredFrame};
use super::sequence::{self, Counted, Layer, Stop, Stream};
use super::{Frame, FrameStats, GpuRenderer, RenderError, RenderOptions};
use crate::output::Images;
use peeltrim::plan::cst::Variant;
use peeltrim::plan::{Algo, Prepared};
use peeltrim::scene::{Appearance, Scene, Solid};
use peeltrim_reference::interference::SOLID_ALPHA;
use peeltrim_reference::interference::{InterferingPair, INTERFERENCE_RGB};
use peeltrim_reference::layers::blend_colors;

/// The GPU's interference of a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuInterference {
    /// Per pixel: the nearest pair intersection's shaded colour, where there is one.
    pub color: Vec<Option<[u8; 4]>>,
    /// Per pixel: that intersection's view depth (`+inf` where there is none).
    pub depth: Vec<f32>,
    /// Pairs with at least one pixel, in solid order.
    pub pairs: Vec<InterferingPair>,
    /// GPU time of all pair frames.
    pub gpu_ms: f64,
    /// Queue submissions of the pair frames (one, after the first frame).
    pub submits: u64,
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
    let mut gpu = renderer(scene, opts)?;
    let out = pairs_on(&mut gpu, scene, opts)?;
    let msgs = gpu.validation_messages();
    if !msgs.is_empty() {
        return Err(RenderError::Validation(msgs));
    }
    Ok(out)
}

/// One renderer for every pair frame and the layers (one device, not one each).
fn renderer(scene: &Scene, opts: &RenderOptions) -> Result<GpuRenderer, RenderError> {
    check_supported(opts.algo)?;
    GpuRenderer::for_options(scene, opts)
}

/// [`supported`] as an error.
fn check_supported(algo: Algo) -> Result<(), RenderError> {
    if !supported(algo) {
        return Err(RenderError::Unsupported {
            algo: algo.name().to_string(),
            what: "interference (--interference; cst-z, cst-i and cst-g can)",
        });
    }
    Ok(())
}

/// Every pair's `A·B` on `gpu` (which it leaves holding the last pair's meshes).
fn pairs_on(
    gpu: &mut GpuRenderer,
    scene: &Scene,
    opts: &RenderOptions,
) -> Result<GpuInterference, RenderError> {
    let n = scene.render.width as usize * scene.render.height as usize;
    let mut out = GpuInterference {
        color: vec![None; n],
        depth: vec![f32::INFINITY; n],
        pairs: Vec::new(),
        gpu_ms: 0.0,
        submits: 0,
    };
    // Every pair's scene has the same meshes (all primitives in the
    // interference colour, no surfaces): one upload, and all pairs' frames in
    // one submission (`sequence`), each pair's images copied out.
    let mut pairs = Vec::new();
    for (i, a) in scene.solids.iter().enumerate() {
        for b in &scene.solids[i + 1..] {
            let pair = pair_scene(scene, a, b);
            let plan = peeltrim::plan::build_with(opts.algo, &Prepared::new(&pair)?, &opts.build)?;
            pairs.push((a, b, pair, plan));
        }
    }
    let Some(first) = pairs.first() else {
        return Ok(out);
    };
    gpu.upload(&first.2)?;
    let mut streams: Vec<Stream<'_>> = pairs
        .iter()
        .map(|p| Stream {
            cap: 1,
            layer: Box::new(|_| {
                Ok(Layer {
                    plans: vec![p.3.clone()],
                    counted: Counted::Samples,
                    accumulate: None,
                    keep: true,
                })
            }),
            stop: Box::new(|_, _| Stop::Go),
        })
        .collect();
    let run = sequence::frame(gpu, "interference-pairs", &mut streams, None, &|_| Ok(()))?;
    drop(streams);
    out.gpu_ms = run.stats.gpu_ms;
    out.submits = run.stats.counts.submits;
    for ((a, b, _, _), layers) in pairs.iter().zip(run.streams) {
        let images = layers
            .into_iter()
            .next()
            .and_then(|l| l.images)
            .expect("every pair's frame is kept")
            .0;
        let mut pixels = 0;
        for (k, (&p, &d)) in images.prim.iter().zip(&images.depth).enumerate() {
            if p == 0 {
                continue;
            }
            pixels += 1;
            if d < out.depth[k] {
                out.depth[k] = d;
                out.color[k] = Some(images.color[k]);
            }
        }
        if pixels > 0 {
            out.pairs.push(InterferingPair {
                solids: [a.name.clone(), b.name.clone()],
                pixels,
            });
        }
    }
    Ok(out)
}

/// The interference view of a GPU algorithm, as the reference draws it
/// (Hable & Rossignac §6): each pixel's nearest interference opaque in the
/// interference colour, the solids' layers in front of it semi-transparent (their
/// `alpha` where below 1, else [`SOLID_ALPHA`]); where there is none, every layer
/// semi-transparent over the background. The layers are the GPU's
/// (`render::gpu_layers`); depth and primitive are layer 1's.
pub fn render_interference(
    scene: &Scene,
    opts: &RenderOptions,
) -> Result<(Frame, GpuInterference, GpuLayers), RenderError> {
    let mut gpu = renderer(scene, opts)?;
    render_interference_with(&mut gpu, scene, opts, false)
}

/// [`render_interference`]; with `normals`, the layers have their normals
/// (for their edge maps).
fn render_interference_with(
    gpu: &mut GpuRenderer,
    scene: &Scene,
    opts: &RenderOptions,
    normals: bool,
) -> Result<(Frame, GpuInterference, GpuLayers), RenderError> {
    let t = std::time::Instant::now();
    gpu.set_normals(normals)?;
    let inter = pairs_on(gpu, scene, opts)?;
    gpu.upload(scene)?;
    let variant = match opts.algo {
        Algo::CstZ => Variant::Z,
        Algo::CstI => Variant::I,
        _ => Variant::G,
    };
    let every = StreamLimit {
        max: None,
        threshold: 0,
    };
    let peeled = gpu_layers::render(gpu, "interference", scene, variant, every, None)?;
    let msgs = gpu.validation_messages();
    if !msgs.is_empty() {
        return Err(RenderError::Validation(msgs));
    }
    let (w, h) = (scene.render.width, scene.render.height);
    let n = w as usize * h as usize;
    let bg = scene.render.background;
    let color = (0..n)
        .map(|i| {
            let (back, limit) = match inter.color[i] {
                // A layer within the GPU's depth error of the interference is
                // its own entry point, not in front of it.
                Some(c) => ([c[0], c[1], c[2]], inter.depth[i] * (1.0 - 1e-4)),
                None => (bg, f32::INFINITY),
            };
            let front = peeled.layers.iter().zip(&peeled.solid).map_while(|(l, s)| {
                let prim = l.images.prim[i];
                (prim != 0 && l.images.depth[i] < limit).then(|| {
                    let a = scene.appearance.alpha_of(prim as u32 - 1, s[i]);
                    (if a < 1.0 { a } else { SOLID_ALPHA }, l.images.color[i])
                })
            });
            blend_colors(front, back)
        })
        .collect();
    let first = peeled.layers.first();
    let mut exec = peeled.stats.clone();
    exec.gpu_ms += inter.gpu_ms;
    exec.counts.submits += inter.submits;
    exec.cpu_ms = t.elapsed().as_secs_f64() * 1e3;
    let frame = Frame {
        coverage: None,
        images: Images {
            width: w,
            height: h,
            color,
            depth: first.map_or_else(|| vec![f32::INFINITY; n], |l| l.images.depth.clone()),
            prim: first.map_or_else(|| vec![0; n], |l| l.images.prim.clone()),
        },
        stats: FrameStats {
            algo: opts.algo.name().to_string(),
            width: w,
            height: h,
            samples: 1,
            device: gpu.device_name(),
            depth_setup: Some(gpu.depth_setup().name()),
            exec,
            ..Default::default()
        },
    };
    Ok((frame, inter, peeled))
}

/// Whether the GPU's interference view answers the layered request:
/// `--interference` alone or with transparency (`alpha` keys, `--alpha`),
/// `--layers`, `--layer-threshold` and `--layers-out`. Highlight and styles
/// together with interference are the reference's.
pub fn handles(scene: &Scene, lopts: &LayerOptions) -> bool {
    scene.appearance.interference && lopts.highlight.is_empty() && !scene.appearance.style.layered()
}

/// [`render_interference`] as the layered renderer's answer: the composite of
/// every layer in front of the interference (as the reference's, whatever
/// `--layers` says), the GPU's layers cut as `lopts` asks (`--layers`,
/// `--layer-threshold`; with `--layers-out` their normals and edge maps), and
/// in `stats.json` the pairs and the interference's pixels.
pub fn layered_frame(
    session: &mut super::layers::LayeredSession,
    scene: &Scene,
    opts: &RenderOptions,
    lopts: &LayerOptions,
) -> Result<LayeredFrame, RenderError> {
    check_supported(opts.algo)?;
    let gpu = session.gpu(scene, opts)?;
    let (mut frame, inter, mut peeled) =
        render_interference_with(gpu, scene, opts, lopts.write_layers)?;
    // The reference's cut: at most N layers, stopping before the first that
    // covers fewer pixels than the threshold.
    let count = peeled
        .pixels
        .iter()
        .take_while(|&&p| p >= lopts.threshold.max(1))
        .count()
        .min(lopts.max_layers.map_or(usize::MAX, |m| m as usize));
    peeled.layers.truncate(count);
    peeled.pixels.truncate(count);
    let (w, h) = (scene.render.width, scene.render.height);
    let edges: Vec<Vec<bool>> = peeled
        .layers
        .iter()
        .filter_map(|l| {
            let n = l.normal.as_ref()?;
            Some(edge_map(&l.images.depth, n, w, h, &lopts.edge_rule))
        })
        .collect();
    let layer_stats = LayerStats {
        layers: count as u32,
        gpu: Some(GpuLayerFigures::of(&peeled)),
        layer_pixels: peeled.pixels,
        transparent: scene.appearance.is_transparent(),
        interference: Some(InterferenceFigures {
            pixels: inter.color.iter().filter(|c| c.is_some()).count() as u64,
            pairs: inter.pairs,
        }),
        style: scene.appearance.style.name(),
        edge_pixels: (!edges.is_empty())
            .then(|| edges.iter().map(|e| super::edges::count(e)).collect()),
        ..Default::default()
    };
    frame.stats.layers = Some(layer_stats.clone());
    Ok(LayeredFrame {
        layers: peeled.layers,
        edges,
        frame,
        layer_stats,
    })
}
