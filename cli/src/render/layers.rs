//! Layers of the solid and transparent rendering, start to finish (Hable & Rossignac
//! §6): the options (`--layers`, `--layer-threshold`, `--layers-out`, `--alpha`), the
//! frame they produce, and writing `layers/NN/`. The reference computes them
//! exactly ([`peeltrim_reference::layers`]); CST-Z/I/G peel them on the GPU
//! (`render::gpu_layers`), kirsch by CSG depth peeling (`render::kirsch`); the
//! other GPU algorithms say they cannot. The reference's layers also have
//! view-space normals and edge maps ([`super::edges`]), from which the styles
//! compose `color.png` ([`super::style`]).
#![deny(unsafe_code)]

use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use super::edges::{edge_map, EdgeRule};
use super::gpu_layers::{self, GpuLayers, StreamLimit};
use super::style::compose_scene;
use super::{Frame, FrameStats, GpuRenderer, RenderError, RenderOptions};
use crate::output::{write_edges, write_images, write_normals, Images, OutputError};
use peeltrim::plan::cst::Variant;
use peeltrim::plan::{Algo, PlanError, Prepared};
use peeltrim::scene::Scene;
use peeltrim::vk::ExecStats;
use peeltrim_reference::highlight::{highlight_at, highlight_pixel, Highlighted, HIGHLIGHT_RGB};
use peeltrim_reference::interference::{render_interference, InterferingPair};
use peeltrim_reference::layers::blend_colors;
use peeltrim_reference::{render_layers_read, LayerLimit, LayerReading};

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
    /// `--layer-reading`: how a union of products is layered (Kirsch,
    /// Nienhaus & Döllner §7); `None`: the algorithm's own (the reference: the solid,
    /// kirsch: the products).
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

/// `--highlight`'s figures (keys `highlighted_pixels`, `highlighted_hidden_pixels`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct HighlightFigures {
    /// Pixels where a highlighted face is the first layer.
    #[serde(rename = "highlighted_pixels")]
    pub shown: u64,
    /// Pixels where one lies hidden behind other faces.
    #[serde(rename = "highlighted_hidden_pixels")]
    pub hidden: u64,
}

/// Interference's figures (keys `interference`, `interference_pixels`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct InterferenceFigures {
    /// The pairs of solids that intersect, with the pixels whose ray meets
    /// their intersection.
    #[serde(rename = "interference")]
    pub pairs: Vec<InterferingPair>,
    /// Pixels showing an interference.
    #[serde(rename = "interference_pixels")]
    pub pixels: u64,
}

/// The GPU's layer figures.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct GpuLayerFigures {
    /// Layer plans run (the entry and exit streams of every solid, Hable & Rossignac
    /// §6).
    pub stream_layers: u32,
    /// CSTs run over all layers (the paper's "CSTs", Hable & Rossignac §8).
    pub csts: u64,
    /// Bytes read back for the layers and the composite (deterministic; what
    /// the GPU composite saves, docs/executor.md).
    pub readback_bytes: u64,
}

impl GpuLayerFigures {
    /// The figures of `peeled`.
    pub fn of(peeled: &GpuLayers) -> Self {
        GpuLayerFigures {
            stream_layers: peeled.stream_layers,
            csts: peeled.csts,
            readback_bytes: peeled.readback_bytes,
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
    /// GPU, transparent: whether the layers were blended on the GPU as they
    /// were peeled (one solid seen from outside) rather than merged and
    /// composited on the CPU.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub composited_on_gpu: Option<bool>,
    /// With `--highlight`: where the highlighted faces show.
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub highlight: Option<HighlightFigures>,
    /// With interference: the intersecting pairs and the pixels showing them.
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub interference: Option<InterferenceFigures>,
    /// GPU: the work of the layer plans.
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub gpu: Option<GpuLayerFigures>,
    /// The style of `color.png` (`--style`, `[render] style`).
    pub style: &'static str,
    /// With edge maps: edge pixels of each layer, layer 1 first.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub edge_pixels: Option<Vec<u64>>,
}

/// One layer of the solid: the k-th boundary crossing of every pixel's ray. The
/// one type every producer of layers (the reference, CST peeling, Kirsch's
/// peeling) fills and every consumer (transparency, highlight, `layers/NN/`,
/// blueprint edge maps) reads.
#[derive(Clone, Debug, PartialEq)]
pub struct SolidLayer {
    /// The output images of this crossing: its shaded colour (background
    /// where the ray has fewer crossings), view depth (`+inf`) and 1-based
    /// primitive (0).
    pub images: Images,
    /// Per pixel, row-major: the unit view-space normal of the crossing's face
    /// (x right, y up, z towards the viewer), turned towards the eye (`[0, 0, 0]` where there is none); `None` when the
    /// producer does not compute normals.
    pub normal: Option<Vec<[f32; 3]>>,
}

impl SolidLayer {
    /// A layer without normals.
    pub fn new(images: Images) -> SolidLayer {
        SolidLayer {
            images,
            normal: None,
        }
    }

    /// Pixels this layer covers.
    pub fn covered(&self) -> u64 {
        self.images.prim.iter().filter(|&&p| p != 0).count() as u64
    }
}

/// A frame with its layers: `images` as the output files (the composite in
/// `color.png` when transparent; depth and primitive of layer 1 then), and each
/// layer, front to back.
#[derive(Clone, Debug)]
pub struct LayeredFrame {
    pub frame: Frame,
    pub layers: Vec<SolidLayer>,
    /// Each layer's edge map, when the style or `--layers-out` needs them and the
    /// layers have normals (else empty).
    pub edges: Vec<Vec<bool>>,
    pub layer_stats: LayerStats,
}

/// Whether `algo` renders layers and composites them (transparency, styles; an
/// OpenSCAD model's `%` parts): the reference, kirsch and the CST variants.
pub fn draws_transparency(algo: Algo) -> bool {
    matches!(
        algo,
        Algo::Reference | Algo::Kirsch | Algo::CstZ | Algo::CstI | Algo::CstG
    )
}

/// A GPU renderer kept from one layered frame to the next of one scene and
/// one set of options ([`render_layered_in`]): from the second frame on, a
/// frame is one submission, replayed without recording while the camera stays
/// (`render::sequence`).
#[derive(Default)]
pub struct LayeredSession {
    gpu: Option<GpuRenderer>,
}

impl LayeredSession {
    /// The session's renderer, made for `scene` and `opts` on first use.
    pub(super) fn gpu(
        &mut self,
        scene: &Scene,
        opts: &RenderOptions,
    ) -> Result<&mut GpuRenderer, RenderError> {
        if self.gpu.is_none() {
            self.gpu = Some(GpuRenderer::for_options(scene, opts)?);
        }
        Ok(self.gpu.as_mut().expect("made above"))
    }
}

/// Renders `scene` with its layers: exactly with the reference (every style),
/// by CST depth peeling with `cst-z`, `cst-i` and `cst-g` (layers, transparency,
/// highlight), by Kirsch's CSG depth peeling with `kirsch` (layers and
/// transparency, products each on their own); other algorithms and the
/// combinations not listed get
/// [`RenderError::Unsupported`].
pub fn render_layered(
    scene: &Scene,
    opts: &RenderOptions,
    lopts: &LayerOptions,
) -> Result<LayeredFrame, RenderError> {
    render_layered_in(&mut LayeredSession::default(), scene, opts, lopts)
}

/// [`render_layered`] on `session`'s renderer (made on first use): every
/// frame of a session must have the same scene, options and layer options.
pub fn render_layered_in(
    session: &mut LayeredSession,
    scene: &Scene,
    opts: &RenderOptions,
    lopts: &LayerOptions,
) -> Result<LayeredFrame, RenderError> {
    if scene.render.samples > 1 {
        return Err(RenderError::Multisampled(
            "layers, transparency, highlight, interference and styles",
        ));
    }
    if opts.algo != Algo::Reference && super::interference::handles(scene, lopts) {
        return super::interference::layered_frame(session, scene, opts, lopts);
    }
    let gpu_refuses = |what: &'static str| {
        Err(RenderError::Unsupported {
            algo: opts.algo.name().to_string(),
            what,
        })
    };
    let styled_algo = draws_transparency(opts.algo);
    if !styled_algo && scene.appearance.style.layered() {
        // Styles need each layer's normals and edges: the reference's, and the
        // GPU's layer peelers'.
        return gpu_refuses(
            "styles other than opaque (--style, [render] style; reference, cst-z, cst-i, cst-g and kirsch render them)",
        );
    }
    let variant = match opts.algo {
        Algo::Reference => return render_layered_reference(scene, opts, lopts),
        Algo::Kirsch => {
            if lopts.reading == Some(LayerReading::Solid) {
                return gpu_refuses(
                    "the solid's layers as one volume (--layer-reading solid; kirsch peels each \
                     product on its own: --layer-reading products)",
                );
            }
            if !lopts.highlight.is_empty() || scene.appearance.interference {
                return gpu_refuses("highlight and interference together with layers (cst-z, cst-i and cst-g render highlight)");
            }
            return super::kirsch::render_layered(session, scene, opts, lopts);
        }
        Algo::CstZ => Variant::Z,
        Algo::CstI => Variant::I,
        Algo::CstG => Variant::G,
        _ => {
            return gpu_refuses("layers, transparency and highlight (--layers, --layers-out, --alpha, alpha keys, --highlight); cst-z, cst-i, cst-g and kirsch render them")
        }
    };
    if lopts.reading == Some(LayerReading::Products) {
        return gpu_refuses("the products reading (--layer-reading products: kirsch; cst-z, cst-i and cst-g peel the solid)");
    }
    if scene.appearance.interference {
        return Err(RenderError::Unsupported {
            algo: opts.algo.name().to_string(),
            what: "interference together with highlight or styles (--interference with --highlight or --style)",
        });
    }
    render_layered_gpu(session, scene, opts, lopts, variant)
}

/// The GPU's layered frame (see [`super::gpu_layers`]): the opaque image as
/// `render` makes it, or the composite of the layers when something is
/// see-through; highlight over either.
fn render_layered_gpu(
    session: &mut LayeredSession,
    scene: &Scene,
    opts: &RenderOptions,
    lopts: &LayerOptions,
    variant: Variant,
) -> Result<LayeredFrame, RenderError> {
    let t = Instant::now();
    let transparent = scene.appearance.is_transparent();
    let gpu = session.gpu(scene, opts)?;
    let style = scene.appearance.style;
    // Edge maps (styles, `--layers-out`) need each layer's normals.
    let want_edges = style.edges() || lopts.write_layers;
    gpu.set_normals(want_edges || style.layered())?;
    let limit = StreamLimit {
        max: lopts.max_layers,
        threshold: lopts.threshold,
    };
    // Every layer's images: for `--layers-out`, the styles and highlight.
    let keep = want_edges || style.layered() || !lopts.highlight.is_empty();
    let composited = if transparent {
        let alpha = |p: u32| scene.appearance.alpha_of(p, 0);
        gpu_layers::composite(gpu, scene, variant, limit, keep, alpha)?
    } else {
        None
    };
    let on_gpu = composited.is_some();
    let (peeled, mut frame) = match composited {
        Some(c) => {
            let images = Images {
                color: c.color,
                ..c.first
            };
            let stats = FrameStats::default();
            (
                c.layers,
                Frame {
                    images,
                    stats,
                    coverage: None,
                },
            )
        }
        None => cpu_composite(gpu, scene, opts, variant, limit)?,
    };
    let mut exec = peeled.stats.clone();
    if !transparent {
        exec.accumulate(&frame.stats.exec);
    }
    exec.cpu_ms = t.elapsed().as_secs_f64() * 1e3;
    frame.stats = FrameStats {
        algo: opts.algo.name().to_string(),
        width: scene.render.width,
        height: scene.render.height,
        samples: scene.render.samples,
        device: gpu.device_name(),
        depth_setup: Some(gpu.depth_setup().name()),
        stencil_bits: frame.stats.stencil_bits,
        exec,
        ..Default::default()
    };
    let mut layer_stats = LayerStats {
        layers: peeled.pixels.len() as u32,
        layer_pixels: peeled.pixels.clone(),
        transparent,
        composited_on_gpu: transparent.then_some(on_gpu),
        gpu: Some(GpuLayerFigures::of(&peeled)),
        style: scene.appearance.style.name(),
        ..Default::default()
    };
    let (w, h) = (scene.render.width, scene.render.height);
    let edges: Vec<Vec<bool>> = if want_edges {
        peeled
            .layers
            .iter()
            .filter_map(|l| {
                Some(edge_map(
                    &l.images.depth,
                    l.normal.as_ref()?,
                    w,
                    h,
                    &lopts.edge_rule,
                ))
            })
            .collect()
    } else {
        vec![]
    };
    let images: Vec<&Images> = peeled.layers.iter().map(|l| &l.images).collect();
    let hit = |k: usize, i: usize| {
        let prim = (images[k].prim[i] as u32).checked_sub(1)?;
        Some((prim, peeled.solid[k][i]))
    };
    styled(scene, &mut frame, &mut layer_stats, &images, &edges, hit);
    if !lopts.highlight.is_empty() {
        highlight_gpu(
            gpu,
            &mut frame,
            &peeled,
            scene,
            variant,
            lopts,
            &mut layer_stats,
        )?;
    }
    let msgs = gpu.validation_messages();
    if !msgs.is_empty() {
        return Err(RenderError::Validation(msgs));
    }
    frame.stats.layers = Some(layer_stats.clone());
    Ok(LayeredFrame {
        frame,
        layers: peeled.layers,
        edges,
        layer_stats,
    })
}

/// The layers peeled stream by stream and merged on the CPU
/// ([`gpu_layers::render`]), and the frame: the layers composited on the CPU
/// when the scene is see-through (an assembly, the eye inside, or a device
/// that cannot blend the GPU's accumulation target), else the opaque image
/// `render` makes, unchanged (its stats in the frame's).
fn cpu_composite(
    gpu: &mut GpuRenderer,
    scene: &Scene,
    opts: &RenderOptions,
    variant: Variant,
    limit: StreamLimit,
) -> Result<(GpuLayers, Frame), RenderError> {
    let opaque = if scene.appearance.is_transparent() {
        None
    } else {
        let prep = Prepared::new(scene)?;
        Some(peeltrim::plan::build_with(opts.algo, &prep, &opts.build)?)
    };
    let mut peeled = gpu_layers::render(gpu, "layers", scene, variant, limit, opaque.as_ref())?;
    let frame = if let (Some(plan), Some(images)) = (&opaque, peeled.after.take()) {
        // Opaque: the image `render` makes, unchanged, in the layers' submission.
        let stats = gpu.frame_stats(plan, ExecStats::default());
        Frame {
            images,
            stats,
            coverage: None,
        }
    } else {
        let n = scene.render.width as usize * scene.render.height as usize;
        let bg = scene.render.background;
        let color = (0..n)
            .map(|i| {
                let hits = peeled.layers.iter().zip(&peeled.solid).map_while(|(l, s)| {
                    let prim = l.images.prim[i];
                    (prim != 0).then(|| {
                        let alpha = scene.appearance.alpha_of(prim as u32 - 1, s[i]);
                        (alpha, l.images.color[i])
                    })
                });
                blend_colors(hits, bg)
            })
            .collect();
        let first = peeled.layers.first();
        Frame {
            coverage: None,
            images: Images {
                width: scene.render.width,
                height: scene.render.height,
                color,
                depth: first.map_or_else(|| vec![f32::INFINITY; n], |l| l.images.depth.clone()),
                prim: first.map_or_else(|| vec![0; n], |l| l.images.prim.clone()),
            },
            stats: FrameStats::default(),
        }
    };
    Ok((peeled, frame))
}

/// The reference's layered frame (exact).
fn render_layered_reference(
    scene: &Scene,
    opts: &RenderOptions,
    lopts: &LayerOptions,
) -> Result<LayeredFrame, RenderError> {
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
            coverage: None,
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
        layer_stats.interference = Some(InterferenceFigures {
            pixels: img.mask.iter().filter(|&&m| m).count() as u64,
            pairs: img.pairs,
        });
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
    let images: Vec<&Images> = stack.layers.iter().collect();
    let hit = |k: usize, i: usize| stack.hits[i].get(k).map(|h| (h.prim, h.solid));
    styled(scene, &mut frame, &mut layer_stats, &images, &edges, hit);
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
        layer_stats.highlight = Some(HighlightFigures { shown, hidden });
    }
    frame.stats.layers = Some(layer_stats.clone());
    Ok(LayeredFrame {
        frame,
        layers: stack
            .layers
            .into_iter()
            .zip(stack.normals)
            .map(|(images, n)| SolidLayer {
                images,
                normal: Some(n),
            })
            .collect(),
        edges,
        layer_stats,
    })
}

/// The edge pixels of `edges` (when any are drawn) into `stats`, and with a
/// layered style `frame`'s colour composed from the layers' `images` and
/// `edges` (`hit`: the primitive and solid of layer k at pixel i).
fn styled(
    scene: &Scene,
    frame: &mut Frame,
    stats: &mut LayerStats,
    images: &[&Images],
    edges: &[Vec<bool>],
    hit: impl Fn(usize, usize) -> Option<(u32, u32)>,
) {
    if !edges.is_empty() {
        stats.edge_pixels = Some(edges.iter().map(|e| super::edges::count(e)).collect());
    }
    if scene.appearance.style.layered() {
        frame.images.color = compose_scene(scene, images, edges, hit);
    }
}

/// `--highlight` on the GPU's layers: the layers peeled again with the chosen
/// primitives in the highlight colour (same geometry, so the same layers in the
/// same order), whose colour at each pixel's first chosen layer is the
/// highlighted face shaded like any face; drawn over `frame`'s colour.
fn highlight_gpu(
    gpu: &mut GpuRenderer,
    frame: &mut Frame,
    peeled: &GpuLayers,
    scene: &Scene,
    variant: Variant,
    lopts: &LayerOptions,
    stats: &mut LayerStats,
) -> Result<(), RenderError> {
    let mut painted = scene.clone();
    for &p in &lopts.highlight {
        painted.primitives[p as usize].color = HIGHLIGHT_RGB;
    }
    gpu.upload(&painted)?;
    let limit = StreamLimit {
        max: Some(peeled.layers.len() as u32),
        threshold: 0,
    };
    let again = gpu_layers::render(gpu, "highlight", &painted, variant, limit, None)?;
    // The renderer's next frame (a bench repeating it) draws the scene's colours.
    gpu.upload(scene)?;
    frame.stats.exec.accumulate(&again.stats);
    let chosen: Vec<u16> = lopts.highlight.iter().map(|&p| p as u16 + 1).collect();
    let (mut shown, mut hidden) = (0, 0);
    for (i, c) in frame.images.color.iter_mut().enumerate() {
        let first = peeled
            .layers
            .iter()
            .position(|l| chosen.contains(&l.images.prim[i]));
        let Some(k) = first else { continue };
        let Some(lit) = again.layers.get(k) else {
            continue;
        };
        let (out, h) = highlight_at(k, lit.images.color[i], *c);
        *c = out;
        match h {
            Highlighted::Visible => shown += 1,
            Highlighted::Hidden => hidden += 1,
            Highlighted::No => {}
        }
    }
    stats.highlight = Some(HighlightFigures { shown, hidden });
    if let Some(g) = &mut stats.gpu {
        g.readback_bytes += again.readback_bytes;
    }
    Ok(())
}

/// Writes layer k (0-based) into `dir/layers/{k+1:02}/` (`color.png`, `depth.npy`,
/// `prim.png`, and `normal.npy` and `edges.png` where the frame has them).
pub fn write_layers(dir: &Path, frame: &LayeredFrame) -> Result<(), OutputError> {
    for (k, l) in frame.layers.iter().enumerate() {
        let sub = dir.join("layers").join(format!("{:02}", k + 1));
        let img = &l.images;
        write_images(&sub, img)?;
        if let Some(n) = &l.normal {
            write_normals(&sub, img.width, img.height, n)?;
        }
        if let Some(e) = frame.edges.get(k) {
            write_edges(&sub, img.width, img.height, e)?;
        }
    }
    Ok(())
}
