//! The reference's layers of the solid and their transparent composite
//! (Hable & Rossignac §5–§6; the oracle for the GPU's depth-peeled layers).
//!
//! Layer k of a pixel is the k-th point, front to back, where its line crosses the
//! boundary of the regularized solid, each point once: the crossings of the line
//! are swept in event groups exactly as in [`super::raycast`] (crossings closer than
//! the grouping tolerance apply together), and a group is a boundary crossing of a
//! solid exactly when it changes the solid's classification. So faces inside the
//! solid, coincident faces and zero-thickness sheets give no layer (the overlap
//! rule), and a point where several primitives' faces coincide is one layer whose
//! primitive is the lowest-index one among those the solid names.
//!
//! An assembly's layers are those of the union of its solids' boundaries, each
//! solid's boundary counted on its own: two solids touching at a face give two
//! layers at that depth (lower primitive index first). Crossings whose view depth
//! lies outside `[near, far]` are clipped, like on the GPU; so with the eye inside
//! the solid layer 1 is a back face. Surfaces are not part of the solid's layers.
//!
//! The composite blends the shaded layers front to back, each with the opacity of
//! its primitive (else its solid, else the render; [`peeltrim::scene::Appearance`]),
//! over the background.
#![deny(unsafe_code)]

use rayon::prelude::*;

use super::bvh::{Crossing, Line, WorldCrossing};
use super::products_reading::{product_scene, LayerReading};
use super::raycast::Prepared;
use peeltrim::csg::products::ProductError;
use peeltrim::images::{shade, Images};
use peeltrim::scene::Scene;

/// One boundary crossing of one solid along a pixel's line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayerHit {
    /// View depth.
    pub depth: f64,
    /// 0-based primitive index (lowest among coincident faces the solid names).
    pub prim: u32,
    /// 0-based solid index.
    pub solid: u32,
    /// The line enters the solid here (a front face); else it leaves it.
    pub entering: bool,
    /// `|cos|` between the face's geometric normal and the line, for shading.
    pub cos: f64,
    /// The crossed face's unit normal in view space (x right, y up, z towards
    /// the viewer: the camera looks down −z), oriented as seen: turned towards
    /// the eye (`dot(normal, ray) ≤ 0`), whichever side of the solid it bounds.
    /// Kirsch, Nienhaus & Döllner §5.2's normal buffer.
    pub normal: [f64; 3],
}

/// Every layer of an image, and the transparent composite.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerStack {
    /// Layer k (0-based here, `layers/{k+1:02}/` on disk): the shaded colour of
    /// that crossing (background where none), its depth (`+inf`) and 1-based
    /// primitive (0).
    pub layers: Vec<Images>,
    /// Layer k's view-space normals ([`LayerHit::normal`]; zero where none).
    pub normals: Vec<Vec<[f32; 3]>>,
    /// The layers composited front to back with the scene's opacities.
    pub composite: Vec<[u8; 4]>,
    /// Each pixel's crossings, front to back, row-major.
    pub hits: Vec<Vec<LayerHit>>,
}

#[derive(Default)]
pub(super) struct Scratch {
    tmp: Vec<Crossing>,
    events: Vec<WorldCrossing>,
    count: Vec<i32>,
    vals: Vec<bool>,
    inside: Vec<bool>,
    group: Vec<LayerHit>,
    pair_inside: Vec<bool>,
    /// After a cast: the nearest entry into the intersection of two solids
    /// (`solid` is the pair's index in [`Layers::pairs`]), within `[near, far]`.
    pub(super) clash: Option<LayerHit>,
    /// After a cast: which pairs of solids the line meets in both, within `[near, far]`.
    pub(super) pairs_hit: Vec<bool>,
}

/// The reference prepared for layers: the ray caster's scene plus, per solid,
/// which primitives it names.
pub struct Layers<'a> {
    pub(super) prep: Prepared<'a>,
    /// World → view rotation, for the view-space normals.
    view: glam::DMat4,
    named: Vec<Vec<bool>>,
    /// Every pair `(a, b)`, `a < b`, of solids (for interference).
    pub(super) pairs: Vec<(u32, u32)>,
    /// Crossings of several solids within one event group are one layer (the
    /// products reading: a depth peel cannot separate equal depths).
    one_per_group: bool,
}

impl<'a> Layers<'a> {
    pub fn new(scene: &'a Scene) -> Layers<'a> {
        let named = named(scene);
        let k = scene.solids.len() as u32;
        Layers {
            view: scene.camera.view(),
            prep: Prepared::new(scene),
            named,
            pairs: (0..k)
                .flat_map(|a| (a + 1..k).map(move |b| (a, b)))
                .collect(),
            one_per_group: false,
        }
    }

    /// The products reading (Kirsch, Nienhaus & Döllner §7a): `products` is
    /// `original` with one solid per product, product `i` from solid `origin[i]`. A
    /// crossing's primitive is the lowest index crossing there that its original
    /// solid names (the GPU's depth-equal shading), and coincident crossings of
    /// several products are one layer.
    pub fn for_products(products: &'a Scene, original: &Scene, origin: &[u32]) -> Layers<'a> {
        let mut l = Layers::new(products);
        let named_by_solid = named(original);
        l.named = origin
            .iter()
            .map(|&s| named_by_solid[s as usize].clone())
            .collect();
        l.one_per_group = true;
        l
    }

    /// The first `max` boundary crossings (all when `None`) along the line through
    /// pixel centre `(px, py)` of a `w × h` image, front to back.
    pub fn cast_pixel(
        &self,
        px: f64,
        py: f64,
        w: u32,
        h: u32,
        max: Option<usize>,
    ) -> Vec<LayerHit> {
        let mut s = Scratch::default();
        let mut out = Vec::new();
        self.cast_with(&mut s, px, py, w, h, max.unwrap_or(usize::MAX), &mut out);
        out
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn cast_with(
        &self,
        s: &mut Scratch,
        px: f64,
        py: f64,
        w: u32,
        h: u32,
        max: usize,
        out: &mut Vec<LayerHit>,
    ) {
        out.clear();
        let p = &self.prep;
        let cam = &p.scene.camera;
        let line = Line::from_ray(&cam.ray(px, py, w, h));
        let fwd = cam.forward();
        let depth_of = |t: f64| (line.at(t) - cam.eye).dot(fwd);
        let hit_of = |e: &WorldCrossing, solid: usize, entering: bool| {
            let n = p.prims.shapes[e.shape as usize].normal(e.crossing.tri);
            let d = n.dot(line.dir);
            let seen = if d > 0.0 { -n } else { n };
            LayerHit {
                depth: depth_of(e.crossing.t),
                prim: e.shape,
                solid: solid as u32,
                entering,
                cos: d.abs(),
                normal: self.view.transform_vector3(seen).to_array(),
            }
        };

        s.events.clear();
        p.prims
            .cast(&line, |i| p.needed[i], &mut s.tmp, &mut s.events);
        s.events
            .sort_unstable_by(|a, b| a.crossing.t.total_cmp(&b.crossing.t));
        s.count.clear();
        s.count.resize(p.prims.shapes.len(), 0);
        s.inside.clear();
        for sol in &p.solids {
            let v = sol.eval(&s.count, &mut s.vals);
            s.inside.push(v);
        }
        s.clash = None;
        s.pair_inside.clear();
        s.pair_inside.resize(self.pairs.len(), false);
        s.pairs_hit.clear();
        s.pairs_hit.resize(self.pairs.len(), false);

        let mut i = 0;
        while i < s.events.len() && out.len() < max {
            let mut j = i;
            while j < s.events.len()
                && (j == i || s.events[j].crossing.t - s.events[j - 1].crossing.t <= p.tol)
            {
                let e = s.events[j];
                s.count[e.shape as usize] += if e.crossing.entering { 1 } else { -1 };
                j += 1;
            }
            let group = &s.events[i..j];
            s.group.clear();
            for (si, sol) in p.solids.iter().enumerate() {
                let now = sol.eval(&s.count, &mut s.vals);
                if now == s.inside[si] {
                    continue;
                }
                s.inside[si] = now;
                // The group changed this solid, so one of its primitives crossed.
                let best = group
                    .iter()
                    .filter(|e| self.named[si][e.shape as usize])
                    .min_by_key(|e| e.shape)
                    .expect(
                        "a solid's classification changed with none of its primitives crossing",
                    );
                s.group.push(hit_of(best, si, now));
            }
            for (pi, &(a, b)) in self.pairs.iter().enumerate() {
                let both = s.inside[a as usize] && s.inside[b as usize];
                if both && !s.pair_inside[pi] {
                    let best = group
                        .iter()
                        .filter(|e| {
                            self.named[a as usize][e.shape as usize]
                                || self.named[b as usize][e.shape as usize]
                        })
                        .min_by_key(|e| e.shape)
                        .expect("entering two solids with none of their primitives crossing");
                    let hit = hit_of(best, pi, true);
                    if (cam.near..=cam.far).contains(&hit.depth) {
                        s.pairs_hit[pi] = true;
                        s.clash.get_or_insert(hit);
                    }
                }
                s.pair_inside[pi] = both;
            }
            s.group.sort_by_key(|hit| hit.prim);
            if self.one_per_group {
                s.group.truncate(1);
            }
            for hit in &s.group {
                if hit.depth > cam.far {
                    return;
                }
                if hit.depth >= cam.near && out.len() < max {
                    out.push(*hit);
                }
            }
            i = j;
        }
    }
}

/// Per solid, which primitives it names.
fn named(scene: &Scene) -> Vec<Vec<bool>> {
    let n = scene.primitives.len();
    scene
        .solids
        .iter()
        .map(|s| {
            let mut v = vec![false; n];
            for p in s.expr.leaves() {
                v[p as usize] = true;
            }
            v
        })
        .collect()
}

/// The colour of a crossing: the standard shading of its primitive's colour.
pub fn layer_color(scene: &Scene, hit: &LayerHit) -> [u8; 4] {
    shade(scene.primitives[hit.prim as usize].color, hit.cos)
}

/// Blends `hits` (front to back) over `background` with the scene's opacities:
/// `C = Σ_k T_k a_k c_k + T_n bg`, `T_{k+1} = T_k (1 − a_k)`.
pub fn composite(scene: &Scene, hits: &[LayerHit], background: [u8; 3]) -> [u8; 4] {
    blend(
        scene,
        hits,
        |h| scene.appearance.alpha_of(h.prim, h.solid),
        background,
    )
}

/// [`composite`] with the opacity of each crossing given by `alpha`.
pub fn blend(
    scene: &Scene,
    hits: &[LayerHit],
    alpha: impl Fn(&LayerHit) -> f64,
    background: [u8; 3],
) -> [u8; 4] {
    blend_colors(
        hits.iter().map(|h| (alpha(h), layer_color(scene, h))),
        background,
    )
}

/// Blends `(opacity, colour)` layers, front to back, over `background`:
/// `C = Σ_k T_k a_k c_k + T_n bg`, `T_{k+1} = T_k (1 − a_k)` (shared by the
/// reference and the GPU's layers, which composite the same 8-bit colours).
pub fn blend_colors(
    layers: impl IntoIterator<Item = (f64, [u8; 4])>,
    background: [u8; 3],
) -> [u8; 4] {
    let mut acc = [0.0f64; 3];
    let mut t = 1.0;
    for (a, c) in layers {
        for (x, v) in acc.iter_mut().zip(c) {
            *x += t * a * v as f64;
        }
        t *= 1.0 - a;
    }
    let px = |k: usize| {
        (acc[k] + t * background[k] as f64)
            .round()
            .clamp(0.0, 255.0) as u8
    };
    [px(0), px(1), px(2), 255]
}

/// Where peeling stops: after `max` layers, or at the first layer covering fewer
/// than `threshold` pixels (the GPU's occlusion-query test; 0 keeps every layer).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LayerLimit {
    pub max: Option<usize>,
    pub threshold: u64,
}

/// Casts every pixel of a `width × height` image for its layers up to `limit`.
pub fn render_layers(scene: &Scene, width: u32, height: u32, limit: LayerLimit) -> LayerStack {
    let hits = cast_all(&Layers::new(scene), width, height, limit);
    stack(scene, hits, width, height, limit)
}

/// [`render_layers`] in either reading of a union of products (Kirsch,
/// Nienhaus & Döllner §7); the products reading fails when the sum of products
/// exceeds `product_limit`.
pub fn render_layers_read(
    scene: &Scene,
    width: u32,
    height: u32,
    limit: LayerLimit,
    reading: LayerReading,
    product_limit: usize,
) -> Result<LayerStack, ProductError> {
    if reading == LayerReading::Solid {
        return Ok(render_layers(scene, width, height, limit));
    }
    let (products, origin) = product_scene(scene, product_limit)?;
    let layers = Layers::for_products(&products, scene, &origin);
    let mut hits = cast_all(&layers, width, height, limit);
    // Opacities are the original solids'.
    for h in hits.iter_mut().flatten() {
        h.solid = origin[h.solid as usize];
    }
    Ok(stack(scene, hits, width, height, limit))
}

/// Every pixel's crossings, up to `limit.max` each.
fn cast_all(layers: &Layers<'_>, width: u32, height: u32, limit: LayerLimit) -> Vec<Vec<LayerHit>> {
    let max = limit.max.unwrap_or(usize::MAX);
    (0..height)
        .into_par_iter()
        .map_init(Scratch::default, |s, y| {
            (0..width)
                .map(|x| {
                    let mut out = Vec::new();
                    let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                    layers.cast_with(s, px, py, width, height, max, &mut out);
                    out
                })
                .collect::<Vec<_>>()
        })
        .flatten()
        .collect()
}

/// The layers of `hits` up to the threshold of `limit`, and their composite.
fn stack(
    scene: &Scene,
    mut hits: Vec<Vec<LayerHit>>,
    width: u32,
    height: u32,
    limit: LayerLimit,
) -> LayerStack {
    // Layer k exists only where layer k − 1 does, so pixel counts never grow with k.
    let covering = |k: usize| hits.iter().filter(|v| v.len() > k).count() as u64;
    let n = (0..)
        .find(|&k| {
            let c = covering(k);
            c == 0 || c < limit.threshold
        })
        .expect("layer counts are finite");
    hits.iter_mut().for_each(|v| v.truncate(n));
    let bg = scene.render.background;
    let layers = (0..n)
        .map(|k| Images {
            width,
            height,
            color: hits
                .iter()
                .map(|v| {
                    v.get(k)
                        .map_or([bg[0], bg[1], bg[2], 255], |h| layer_color(scene, h))
                })
                .collect(),
            depth: hits
                .iter()
                .map(|v| v.get(k).map_or(f32::INFINITY, |h| h.depth as f32))
                .collect(),
            prim: hits
                .iter()
                .map(|v| {
                    v.get(k)
                        .map_or(0, |h| (h.prim + 1).min(u16::MAX as u32) as u16)
                })
                .collect(),
        })
        .collect();
    let normals = (0..n)
        .map(|k| {
            hits.iter()
                .map(|v| v.get(k).map_or([0.0; 3], |h| h.normal.map(|c| c as f32)))
                .collect()
        })
        .collect();
    let composite = hits.iter().map(|v| composite(scene, v, bg)).collect();
    LayerStack {
        layers,
        normals,
        composite,
        hits,
    }
}

#[cfg(test)]
#[path = "layers_tests.rs"]
mod tests;
