//! Kirsch's depth-peeled layers on the GPU (Kirsch, Nienhaus & Döllner §4, §4.5, §6):
//! layer k is the output of [`plan::build_kirsch_layer`], executed and read back
//! layer by layer on one device; peeling stops at the first layer whose occlusion
//! query (the plan's final counted pass, the executor's `final_samples`) counts no
//! pixel or fewer than `--layer-threshold`. The transparent `color.png` blends the
//! read-back colour layer maps back to front with their opacities (§4.5's depth
//! sprites, composed on the host). With `--layers-out` or a style (Kirsch,
//! Nienhaus & Döllner §5) the executor's normal buffer is on: each layer's view-space
//! normals are read right after its plan, its edge map is the reference's rule on
//! them ([`super::edges`]), and the style composes `color.png` as the reference's
//! does ([`super::style::compose_scene`]).
//!
//! Each layer's plan peels all layers before it again (the executor keeps no
//! texture from one frame to the next), so N layers cost N(N+1)/2 layer passes.
//! `stats.json` sums `gpu_ms`, `frame_ms` and `record_ms` over these plans (and the
//! one that finds no further layer); its counts are the last layer's plan's.
#![deny(unsafe_code)]

use std::time::Instant;

use super::edges::{count, edge_map};
use super::layers::{LayerOptions, LayerStats, LayeredFrame, SolidLayer};
use super::sequence::{self, Counted, Layer, Stop, Stream};
use super::style::compose_scene;
use super::{Frame, RenderError, RenderOptions};
use crate::output::Images;
use peeltrim::plan::{self, Prepared};
use peeltrim::scene::Scene;

/// The layers of `scene` by Kirsch's depth peeling, products each on their own
/// (§7a).
pub(super) fn render_layered(
    session: &mut super::layers::LayeredSession,
    scene: &Scene,
    opts: &RenderOptions,
    lopts: &LayerOptions,
) -> Result<LayeredFrame, RenderError> {
    let t = Instant::now();
    let prep = Prepared::new(scene)?;
    let gpu = session.gpu(scene, opts)?;
    // No layer beyond the total face count: a bound, not a limit reached in practice.
    let bound = prep.triangles_in(&prep.solid_meshes).max(1) as u32;
    let max = lopts.max_layers.unwrap_or(bound).min(bound);
    // Normals (and the edge maps from them) only where something reads them.
    let style = scene.appearance.style;
    let want_normals = lopts.write_layers || style.layered();
    gpu.set_normals(want_normals)?;
    let threshold = lopts.threshold;
    let mut streams = [Stream {
        cap: max,
        layer: Box::new(|k| {
            Ok(Layer {
                plans: vec![plan::build_kirsch_layer(&prep, &opts.build, k + 1)?],
                counted: Counted::Final,
                accumulate: None,
                keep: true,
            })
        }),
        stop: Box::new(|_, covered| {
            if covered == 0 || covered < threshold {
                Stop::Before
            } else {
                Stop::Go
            }
        }),
    }];
    let run = sequence::frame(gpu, "kirsch", &mut streams, None, &|_| Ok(()))?;
    drop(streams);
    let mut layers: Vec<Images> = Vec::new();
    let mut normals: Vec<Vec<[f32; 3]>> = Vec::new();
    let mut layer_pixels = Vec::new();
    for l in run.streams.into_iter().flatten() {
        let (images, normal) = l.images.expect("every Kirsch layer is kept");
        layers.push(images);
        normals.extend(normal);
        layer_pixels.push(l.covered);
    }
    let msgs = gpu.validation_messages();
    if !msgs.is_empty() {
        return Err(RenderError::Validation(msgs));
    }
    let mut stats = gpu.frame_stats(&plan::build_kirsch_layer(&prep, &opts.build, 1)?, run.stats);
    stats.exec.cpu_ms = t.elapsed().as_secs_f64() * 1e3;
    let transparent = scene.appearance.is_transparent();
    let mut images = match layers.first() {
        Some(first) => first.clone(),
        // Nothing covers a pixel: the (empty) first layer, the frame's last plan.
        None => gpu.read_back()?,
    };
    let solid_of = solid_of(scene);
    let (w, h) = (scene.render.width, scene.render.height);
    let edges: Vec<Vec<bool>> = if style.edges() || lopts.write_layers {
        layers
            .iter()
            .zip(&normals)
            .map(|(l, n)| edge_map(&l.depth, n, w, h, &lopts.edge_rule))
            .collect()
    } else {
        vec![]
    };
    if style.layered() {
        let refs: Vec<&Images> = layers.iter().collect();
        images.color = compose_scene(scene, &refs, &edges, |k, i| {
            let prim = (layers[k].prim[i] as u32).checked_sub(1)?;
            Some((prim, solid_of[prim as usize]))
        });
    } else if transparent {
        images.color = composite(scene, &layers, &images, &solid_of);
    }
    let layer_stats = LayerStats {
        layers: layers.len() as u32,
        layer_pixels,
        transparent,
        style: style.name(),
        edge_pixels: (!edges.is_empty()).then(|| edges.iter().map(|e| count(e)).collect()),
        ..Default::default()
    };
    stats.layers = Some(layer_stats.clone());
    let mut normals = normals.into_iter().map(Some);
    Ok(LayeredFrame {
        frame: Frame {
            images,
            stats,
            coverage: None,
        },
        layers: layers
            .into_iter()
            .map(|images| SolidLayer {
                images,
                normal: normals.next().flatten(),
            })
            .collect(),
        edges,
        layer_stats,
    })
}

/// Per primitive, the solid whose opacity it takes: the first solid naming it.
fn solid_of(scene: &Scene) -> Vec<u32> {
    let mut solid_of = vec![0u32; scene.primitives.len()];
    for (si, s) in scene.solids.iter().enumerate().rev() {
        for p in s.expr.leaves() {
            solid_of[p as usize] = si as u32;
        }
    }
    solid_of
}

/// The colour layer maps blended back to front over the background (§4.5), each
/// pixel with its primitive's opacity (else its solid's: the first solid naming
/// the primitive; else the render's).
fn composite(scene: &Scene, layers: &[Images], first: &Images, solid_of: &[u32]) -> Vec<[u8; 4]> {
    let bg = scene.render.background;
    (0..first.color.len())
        .map(|i| {
            let mut acc = [bg[0] as f64, bg[1] as f64, bg[2] as f64];
            for l in layers.iter().rev() {
                let Some(prim) = (l.prim[i] as u32).checked_sub(1) else {
                    continue;
                };
                let a = scene.appearance.alpha_of(prim, solid_of[prim as usize]);
                for (x, c) in acc.iter_mut().zip(l.color[i]) {
                    *x = a * c as f64 + (1.0 - a) * *x;
                }
            }
            let px = |k: usize| acc[k].round().clamp(0.0, 255.0) as u8;
            [px(0), px(1), px(2), 255]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn back_to_front_equals_the_references_front_to_back_blend() {
        let mut scene = peeltrim::scene::fixtures::block_minus_spheres(1);
        scene.render.background = [10, 20, 30];
        scene.appearance.alpha = Some(0.4);
        scene.appearance.primitive_alpha = vec![None, Some(0.7)];
        let img = |c: [u8; 4], p: u16| Images {
            width: 1,
            height: 1,
            color: vec![c],
            depth: vec![1.0],
            prim: vec![p],
        };
        let (l1, l2) = (img([200, 100, 0, 255], 1), img([0, 50, 250, 255], 2));
        let got = composite(&scene, &[l1.clone(), l2], &l1, &solid_of(&scene))[0];
        // Front to back: C = a1 c1 + (1 − a1)(a2 c2 + (1 − a2) bg).
        let want =
            |c1: f64, c2: f64, bg: f64| (0.4 * c1 + 0.6 * (0.7 * c2 + 0.3 * bg)).round() as u8;
        assert_eq!(
            got,
            [
                want(200.0, 0.0, 10.0),
                want(100.0, 50.0, 20.0),
                want(0.0, 250.0, 30.0),
                255
            ]
        );
    }
}
