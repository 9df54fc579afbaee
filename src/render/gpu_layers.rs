//! The layers of the solid on the GPU with CST (seed 000 §6): per solid, the
//! entry stream (odd layers) and the exit stream (even layers) are peeled layer
//! by layer, each layer a CST plan of the solid initialized at the previous
//! layer's depth ([`crate::plan::cst::layers`]), each stream stopped by an
//! occlusion query; the streams are then merged front to back per pixel into
//! the layers of the image, so an assembly's layers are the union of its solids'
//! boundaries, each solid counted on its own.
#![deny(unsafe_code)]

use super::layers::SolidLayer;
use super::{GpuRenderer, RenderError};
use crate::output::Images;
use crate::plan::cst::layers::{coverage_plan, layer_plan, Side};
use crate::plan::cst::Variant;
use crate::plan::Prepared;
use crate::scene::Scene;
use crate::vk::ExecStats;

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
    /// The image's layers, front to back.
    pub layers: Vec<SolidLayer>,
    /// Solid (0-based) of each layer's crossing per pixel, parallel to `layers`
    /// (`u32::MAX` where there is none): the opacity of a point may be its solid's.
    pub solid: Vec<Vec<u32>>,
    /// Figures of every plan run, summed.
    pub stats: ExecStats,
    /// Layer plans run (entry and exit streams of every solid).
    pub stream_layers: u32,
    /// CSTs run: the leaves peeled and trimmed by each layer plan, summed (the
    /// paper's "CSTs" column, seed 000 §8).
    pub csts: u64,
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

/// Peels every solid's streams on `gpu` (the scene uploaded) and merges them.
pub fn render(
    gpu: &mut GpuRenderer,
    scene: &Scene,
    variant: Variant,
    limit: StreamLimit,
) -> Result<GpuLayers, RenderError> {
    let mut stats = ExecStats::default();
    let mut peeled = Vec::new();
    let (mut stream_layers, mut csts) = (0, 0);
    let coverage = coverage_plan();
    for i in 0..scene.solids.len() {
        let sub = solid_scene(scene, i);
        let prep = Prepared::new(&sub)?;
        if !prep.has_solid() || prep.positive.literals().is_empty() {
            continue;
        }
        // One solid seen from outside: its crossings alternate entry, exit, entry…
        // so layer 2k − 1 is the entry stream's k-th and 2k the exit stream's, and a
        // stream may stop where its layer covers fewer pixels than the threshold.
        // Otherwise (an assembly, the eye or the near plane inside a primitive) the
        // merge decides the order, and each stream may hold any of the first N.
        let alternating = scene.solids.len() == 1
            && !prep.eye_inside.iter().any(|&b| b)
            && !prep.near_cut.iter().any(|&b| b);
        let bound = prep.mesh_triangles.iter().sum::<usize>() as u32 + 1;
        for side in [Side::Entry, Side::Exit] {
            let cap = match (limit.max, alternating, side) {
                (None, _, _) => bound,
                (Some(n), false, _) => n,
                (Some(n), true, Side::Entry) => n.div_ceil(2),
                (Some(n), true, Side::Exit) => n / 2,
            };
            for k in 0..cap {
                let lp = layer_plan(&prep, variant, side, k == 0)?;
                let st = gpu.execute(&lp.plan)?;
                stats.accumulate(&st.exec);
                stream_layers += 1;
                csts += lp.csts as u64;
                let counted = gpu.execute(&coverage)?;
                stats.accumulate(&counted.exec);
                let covered = counted.exec.counts.samples_counted;
                if covered == 0 {
                    break;
                }
                // Every peeled layer stays on the host until the merge.
                super::FrameMemory {
                    gpu: true,
                    normals: gpu.normals(),
                    layers: peeled.len() as u64 + 1,
                    shadow_map: None,
                }
                .check(scene.render.width, scene.render.height)?;
                peeled.push(Peeled {
                    solid: i as u32,
                    images: gpu.read_back()?,
                    normal: gpu.read_normals()?,
                });
                if alternating && covered < limit.threshold {
                    break;
                }
            }
        }
    }
    let (w, h) = (scene.render.width, scene.render.height);
    let (layers, solid) = merge(&peeled, w, h, scene.render.background, limit);
    Ok(GpuLayers {
        layers,
        solid,
        stats,
        stream_layers,
        csts,
    })
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
