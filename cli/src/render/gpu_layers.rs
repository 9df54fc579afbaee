//! The layers of the solid on the GPU with CST (Hable & Rossignac §6): per solid, the
//! entry stream (odd layers) and the exit stream (even layers) are peeled layer
//! by layer, each layer a CST plan of the solid initialized at the previous
//! layer's depth ([`peeltrim::plan::cst::layers`]), each stream stopped by an
//! occlusion query; the streams are then merged front to back per pixel into
//! the layers of the image, so an assembly's layers are the union of its solids'
//! boundaries, each solid counted on its own ([`render`]).
//!
//! One solid seen from outside needs no merge: its crossings alternate entry,
//! exit, entry…, so peeling the two streams in turn (each with its own floor
//! texture) produces the image's layers in order, and each is blended into the
//! GPU's accumulation target as it is produced ([`composite`]): a transparent
//! frame then reads back one image instead of every layer. An assembly's
//! streams interleave differently at every pixel, so its layers are merged and
//! composited on the CPU (docs/transparency-and-blueprints.md).
#![deny(unsafe_code)]

use std::cell::Cell;

use super::layers::SolidLayer;
use super::sequence::{self, Counted, Layer, Stop, Stop::Go, Stream};
use super::{GpuRenderer, RenderError};
use crate::output::Images;
use peeltrim::plan::cst::layers::{coverage_plan, layer_plan, Side, EXIT_FLOOR, FLOOR};
use peeltrim::plan::cst::Variant;
use peeltrim::plan::Prepared;
use peeltrim::scene::Scene;
use peeltrim::vk::ExecStats;

/// Where the streams stop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StreamLimit {
    /// At most this many layers of the image (`None`: every layer).
    pub max: Option<u32>,
    /// Stop at the first layer covering fewer pixels (0: none).
    pub threshold: u64,
}

/// The GPU's layers of a scene and what they cost.
pub struct GpuLayers {
    /// The image's layers, front to back (empty when [`composite`] was not
    /// asked for them).
    pub layers: Vec<SolidLayer>,
    /// Pixels each layer covers, layer 1 first.
    pub pixels: Vec<u64>,
    /// Solid (0-based) of each layer's crossing per pixel, parallel to `layers`
    /// (`u32::MAX` where there is none): the opacity of a point may be its solid's.
    pub solid: Vec<Vec<u32>>,
    /// Figures of every plan run, summed.
    pub stats: ExecStats,
    /// Layer plans run (entry and exit streams of every solid).
    pub stream_layers: u32,
    /// CSTs run: the leaves peeled and trimmed by each layer plan, summed (the
    /// paper's "CSTs" column, Hable & Rossignac §8).
    pub csts: u64,
    /// Bytes copied from the GPU: layer images (colour, id, depth; normals
    /// when on) and the composite.
    pub readback_bytes: u64,
    /// The images of the plan [`render`] was asked to run after the layers.
    pub after: Option<Images>,
}

/// Bytes a pixel of one layer's read-back takes: colour, id and depth (4 each),
/// and the normal buffer's 16 when it is on.
fn layer_bytes(normal: &Option<Vec<[f32; 3]>>) -> u64 {
    12 + if normal.is_some() { 16 } else { 0 }
}

/// One peeled layer of one stream.
struct Peeled {
    solid: u32,
    images: Images,
    /// View-space normals, when the renderer writes its normal buffer.
    normal: Option<Vec<[f32; 3]>>,
}

/// The scene restricted to solid `i` without surfaces (surfaces are no part of
/// the solid's layers).
fn solid_scene(scene: &Scene, i: usize) -> Scene {
    let mut s = scene.clone();
    s.solids = vec![scene.solids[i].clone()];
    s.surfaces.clear();
    s
}

/// Solid `i` of `scene` prepared for peeling (`None`: it has no solid), whether
/// its crossings alternate entry, exit, entry… (one solid seen from outside:
/// layer 2k − 1 is the entry stream's k-th and 2k the exit stream's, and a
/// stream may stop where its layer covers fewer pixels than the threshold;
/// otherwise — an assembly, the eye or the near plane inside a primitive — the
/// merge decides the order, and each stream may hold any of the first N), and
/// a bound on any stream's layers.
fn peelable(scene: &Scene, i: usize) -> Result<Option<(Prepared, bool, u32)>, RenderError> {
    let sub = solid_scene(scene, i);
    let prep = Prepared::new(&sub)?;
    if !prep.has_solid() || prep.positive.literals().is_empty() {
        return Ok(None);
    }
    let alternating = scene.solids.len() == 1
        && !prep.eye_inside.iter().any(|&b| b)
        && !prep.near_cut.iter().any(|&b| b);
    let bound = prep.mesh_triangles.iter().sum::<usize>() as u32 + 1;
    Ok(Some((prep, alternating, bound)))
}

/// Peels every solid's streams on `gpu` (the scene uploaded) and merges them;
/// `kind` names the frame among the renderer's layered frames (`sequence`).
/// `after`: a plan run in the same submission after the layers (the opaque
/// image of a layered frame), its images in [`GpuLayers::after`].
pub fn render(
    gpu: &mut GpuRenderer,
    kind: &'static str,
    scene: &Scene,
    variant: Variant,
    limit: StreamLimit,
    after: Option<&peeltrim::plan::Plan>,
) -> Result<GpuLayers, RenderError> {
    let (w, h) = (scene.render.width, scene.render.height);
    let pixels = w as u64 * h as u64;
    let coverage = coverage_plan();
    let mut solids = Vec::new();
    for i in 0..scene.solids.len() {
        if let Some(p) = peelable(scene, i)? {
            solids.push((i as u32, p));
        }
    }
    // Per stream: its solid and the CSTs of each of its layer plans.
    let csts: Vec<(u32, Cell<usize>)> = solids
        .iter()
        .flat_map(|(i, _)| [(*i, Cell::new(0)), (*i, Cell::new(0))])
        .collect();
    let mut streams = Vec::new();
    for ((_, (prep, alternating, bound)), cells) in solids.iter().zip(csts.chunks(2)) {
        for (side, cell) in [Side::Entry, Side::Exit].into_iter().zip(cells) {
            let cap = match (limit.max, *alternating, side) {
                (None, _, _) => *bound,
                (Some(n), false, _) => n,
                (Some(n), true, Side::Entry) => n.div_ceil(2),
                (Some(n), true, Side::Exit) => n / 2,
            };
            let coverage = &coverage;
            let alternating = *alternating;
            streams.push(Stream {
                cap,
                layer: Box::new(move |k| {
                    let lp = layer_plan(prep, variant, side, k == 0, FLOOR)?;
                    cell.1.set(lp.csts);
                    Ok(Layer {
                        plans: vec![lp.plan, coverage.clone()],
                        counted: Counted::Samples,
                        accumulate: None,
                        keep: true,
                    })
                }),
                stop: Box::new(move |_, covered| {
                    if covered == 0 {
                        Stop::Before
                    } else if alternating && covered < limit.threshold {
                        Stop::After
                    } else {
                        Go
                    }
                }),
            });
        }
    }
    streams.extend(after.map(|p| Stream {
        cap: 1,
        layer: Box::new(move |_| {
            Ok(Layer {
                plans: vec![p.clone()],
                counted: Counted::Samples,
                accumulate: None,
                keep: true,
            })
        }),
        stop: Box::new(|_, _| Go),
    }));
    let normals = gpu.normals();
    // Every peeled layer stays on the host until the merge.
    let check = |n: u64| {
        super::FrameMemory {
            gpu: true,
            normals,
            layers: n,
            shadow_map: None,
            accumulate: false,
        }
        .check(w, h)
        .map_err(RenderError::from)
    };
    let mut out = sequence::frame(gpu, kind, &mut streams, None, &check)?;
    drop(streams);
    let after = after.map(|_| {
        let last = out.streams.pop().and_then(|mut s| s.pop());
        last.and_then(|l| l.images)
            .expect("the plan after the layers is kept")
            .0
    });
    let mut peeled = Vec::new();
    let mut readback_bytes = 0;
    for ((solid, _), layers) in csts.iter().zip(out.streams) {
        for l in layers {
            let (images, normal) = l.images.expect("every layer of a stream is kept");
            readback_bytes += pixels * layer_bytes(&normal);
            peeled.push(Peeled {
                solid: *solid,
                images,
                normal,
            });
        }
    }
    let (layers, solid) = merge(&peeled, w, h, scene.render.background, limit);
    Ok(GpuLayers {
        pixels: layers.iter().map(SolidLayer::covered).collect(),
        layers,
        solid,
        stats: out.stats,
        stream_layers: out.peeled.iter().sum(),
        csts: out
            .peeled
            .iter()
            .zip(&csts)
            .map(|(&n, c)| n as u64 * c.1.get() as u64)
            .sum(),
        readback_bytes,
        after,
    })
}

/// The transparent image of a scene composited on the GPU, and its layers.
pub struct Composited {
    /// `color.png`: the layers blended front to back over the background.
    pub color: Vec<[u8; 4]>,
    /// Layer 1's images (`depth.npy`, `prim.png`): background where none.
    pub first: Images,
    /// The layers (their images only when asked for) and what they cost.
    pub layers: GpuLayers,
}

/// The layers of a one-solid scene seen from outside, peeled in order (entry
/// and exit streams in turn, each from its own floor) and each blended into
/// the GPU's accumulation target right after it is peeled, at the opacity
/// `alpha(p)` of its primitive `p` (0-based); only layer 1 is read back, and
/// every layer when `images` (`--layers-out`, styles, highlight). `None` when
/// the scene's crossings do not alternate (an assembly, the eye or the near
/// plane inside a primitive: [`render`] merges those) or the device cannot
/// blend the accumulation target; the caller then composites on the CPU.
pub fn composite(
    gpu: &mut GpuRenderer,
    scene: &Scene,
    variant: Variant,
    limit: StreamLimit,
    images: bool,
    alpha: impl Fn(u32) -> f64,
) -> Result<Option<Composited>, RenderError> {
    if scene.solids.len() != 1 {
        return Ok(None);
    }
    let Some((prep, true, bound)) = peelable(scene, 0)? else {
        return Ok(None);
    };
    if !gpu.set_transparency(true)? {
        return Ok(None);
    }
    // Opacity by primitive id (1-based; 0 is no primitive).
    let table: Vec<f32> = std::iter::once(0.0)
        .chain((0..scene.primitives.len() as u32).map(|p| alpha(p) as f32))
        .collect();
    let (w, h) = (scene.render.width, scene.render.height);
    let pixels = w as u64 * h as u64;
    let coverage = coverage_plan();
    let csts = Cell::new(0);
    let mut streams = [Stream {
        cap: limit.max.unwrap_or(2 * bound),
        layer: Box::new(|m| {
            // Layer m + 1: the entry stream's (m / 2 + 1)-th, or the exit stream's.
            let (side, floor) = match m % 2 {
                0 => (Side::Entry, FLOOR),
                _ => (Side::Exit, EXIT_FLOOR),
            };
            let lp = layer_plan(&prep, variant, side, m < 2, floor)?;
            csts.set(lp.csts);
            Ok(Layer {
                plans: vec![lp.plan, coverage.clone()],
                counted: Counted::Samples,
                accumulate: Some(m == 0),
                keep: images || m == 0,
            })
        }),
        stop: Box::new(|_, covered| {
            if covered == 0 || covered < limit.threshold {
                Stop::Before
            } else {
                Go
            }
        }),
    }];
    let run = sequence::frame(gpu, "composite", &mut streams, Some(&table), &|_| Ok(()))?;
    drop(streams);
    let mut out = GpuLayers {
        layers: Vec::new(),
        pixels: Vec::new(),
        solid: Vec::new(),
        stats: run.stats,
        stream_layers: run.peeled[0],
        csts: run.peeled[0] as u64 * csts.get() as u64,
        readback_bytes: 0,
        after: None,
    };
    let mut first = None;
    for (m, l) in run.streams.into_iter().flatten().enumerate() {
        out.pixels.push(l.covered);
        let Some((images_m, normal)) = l.images else {
            continue;
        };
        out.readback_bytes += pixels * layer_bytes(&normal);
        if m == 0 {
            first = Some(images_m.clone());
        }
        if images {
            out.solid.push(
                images_m
                    .prim
                    .iter()
                    .map(|&p| if p == 0 { u32::MAX } else { 0 })
                    .collect(),
            );
            out.layers.push(SolidLayer {
                images: images_m,
                normal,
            });
        }
    }
    let bg = scene.render.background;
    let n = w as usize * h as usize;
    let color = if first.is_some() {
        out.readback_bytes += pixels * 16;
        gpu.read_accumulation()?
            .iter()
            .map(|p| resolve(*p, bg))
            .collect()
    } else {
        vec![[bg[0], bg[1], bg[2], 255]; n]
    };
    let first = first.unwrap_or_else(|| Images {
        width: w,
        height: h,
        color: vec![[bg[0], bg[1], bg[2], 255]; n],
        depth: vec![f32::INFINITY; n],
        prim: vec![0; n],
    });
    Ok(Some(Composited {
        color,
        first,
        layers: out,
    }))
}

/// One pixel of the composite: the accumulated premultiplied colour `C` (0..1)
/// and coverage `A` over the background, `C + (1 − A)·bg`, in bytes as the
/// reference rounds them.
fn resolve(p: [f32; 4], bg: [u8; 3]) -> [u8; 4] {
    let t = (1.0 - p[3] as f64).max(0.0);
    let px = |k: usize| {
        (255.0 * p[k] as f64 + t * bg[k] as f64)
            .round()
            .clamp(0.0, 255.0) as u8
    };
    [px(0), px(1), px(2), 255]
}

/// Two depths the merge treats as one point (relative; GPU depths of faces that
/// coincide in the scene differ by a few ulps): ordered by primitive index.
const SAME_DEPTH: f32 = 1e-6;

/// Merges the streams' layers per pixel, front to back (coincident points by
/// primitive index, as the reference orders them), into the image's layers,
/// cut at `limit`.
fn merge(
    peeled: &[Peeled],
    w: u32,
    h: u32,
    background: [u8; 3],
    limit: StreamLimit,
) -> (Vec<SolidLayer>, Vec<Vec<u32>>) {
    let n = w as usize * h as usize;
    // Per pixel: (depth, prim, solid, colour, normal) of every stream layer
    // covering it.
    type Hit = (f32, u16, u32, [u8; 4], [f32; 3]);
    let mut hits: Vec<Vec<Hit>> = vec![Vec::new(); n];
    for p in peeled {
        for (i, v) in hits.iter_mut().enumerate() {
            let prim = p.images.prim[i];
            if prim != 0 {
                let normal = p.normal.as_ref().map_or([0.0; 3], |nm| nm[i]);
                v.push((p.images.depth[i], prim, p.solid, p.images.color[i], normal));
            }
        }
    }
    let normals = !peeled.is_empty() && peeled.iter().all(|p| p.normal.is_some());
    for v in &mut hits {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Insertion pass: neighbours at the same depth go by primitive index.
        for j in 1..v.len() {
            let mut k = j;
            while k > 0
                && (v[k].0 - v[k - 1].0).abs() <= SAME_DEPTH * v[k].0.abs().max(1.0)
                && v[k].1 < v[k - 1].1
            {
                v.swap(k, k - 1);
                k -= 1;
            }
        }
    }
    let covering = |k: usize| hits.iter().filter(|v| v.len() > k).count() as u64;
    let max = limit.max.map_or(usize::MAX, |m| m as usize);
    let count = (0..max)
        .find(|&k| {
            let c = covering(k);
            c == 0 || c < limit.threshold
        })
        .unwrap_or(max);
    let bg = [background[0], background[1], background[2], 255];
    let layers = (0..count)
        .map(|k| SolidLayer {
            images: Images {
                width: w,
                height: h,
                color: hits.iter().map(|v| v.get(k).map_or(bg, |x| x.3)).collect(),
                depth: hits
                    .iter()
                    .map(|v| v.get(k).map_or(f32::INFINITY, |x| x.0))
                    .collect(),
                prim: hits.iter().map(|v| v.get(k).map_or(0, |x| x.1)).collect(),
            },
            normal: normals.then(|| {
                hits.iter()
                    .map(|v| v.get(k).map_or([0.0; 3], |x| x.4))
                    .collect()
            }),
        })
        .collect();
    let solid = (0..count)
        .map(|k| {
            hits.iter()
                .map(|v| v.get(k).map_or(u32::MAX, |x| x.2))
                .collect()
        })
        .collect();
    (layers, solid)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stream(solid: u32, depth: [f32; 2], prim: [u16; 2]) -> Peeled {
        Peeled {
            solid,
            images: Images {
                width: 2,
                height: 1,
                color: vec![[prim[0] as u8, 0, 0, 255], [prim[1] as u8, 0, 0, 255]],
                depth: depth.to_vec(),
                prim: prim.to_vec(),
            },
            normal: None,
        }
    }

    #[test]
    fn resolve_blends_the_rest_of_the_background() {
        // Nothing accumulated: the background.
        assert_eq!(resolve([0.0; 4], [10, 20, 30]), [10, 20, 30, 255]);
        // Two layers at 0.5, colours 1.0 then 0.0 (C = 0.5, A = 0.75) over 200:
        // 127.5 + 50 = 177.5, rounded as the reference rounds (half away).
        assert_eq!(resolve([0.5, 0.5, 0.5, 0.75], [200; 3])[0], 178);
        // Opaque: the background is gone.
        assert_eq!(resolve([0.2, 0.4, 0.6, 1.0], [255; 3]), [51, 102, 153, 255]);
    }

    #[test]
    fn merge_orders_by_depth_then_primitive_and_cuts() {
        let inf = f32::INFINITY;
        let peeled = [
            stream(0, [2.0, 1.0], [1, 1]),
            stream(1, [1.0 + 1e-7, inf], [3, 0]),
            stream(1, [1.0, 3.0], [2, 2]),
        ];
        let all = StreamLimit {
            max: None,
            threshold: 0,
        };
        let (layers, solid) = merge(&peeled, 2, 1, [9, 9, 9], all);
        assert_eq!(layers.len(), 3);
        // Pixel 0: 1.0 (prim 2) and 1.0 + 1e-7 (prim 3) are one depth: index order.
        assert_eq!(
            layers.iter().map(|l| l.images.prim[0]).collect::<Vec<_>>(),
            [2, 3, 1]
        );
        assert_eq!(
            layers.iter().map(|l| l.images.prim[1]).collect::<Vec<_>>(),
            [1, 2, 0]
        );
        assert_eq!(layers[2].images.depth[1], inf);
        assert_eq!(layers[2].images.color[1], [9, 9, 9, 255]);
        assert_eq!(solid[0], [1, 0]);
        // A threshold of two pixels stops before the layer covering one.
        let two = StreamLimit {
            max: None,
            threshold: 2,
        };
        assert_eq!(merge(&peeled, 2, 1, [0; 3], two).0.len(), 2);
        let one = StreamLimit {
            max: Some(1),
            threshold: 0,
        };
        assert_eq!(merge(&peeled, 2, 1, [0; 3], one).0.len(), 1);
    }
}
