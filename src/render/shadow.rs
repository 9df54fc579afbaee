//! Shadows of a scene with a `[light]` (seed 003, Rossignac & Wu: the CSG solid's
//! depth buffer seen from the light, then a shadow test in the eye's shading).
//!
//! GPU algorithms render the plan twice: from the eye, and from the light's camera
//! ([`Light::camera_for`]: orthographic for a directional light, perspective for
//! a point light) into a square shadow map of [`SHADOW_MAP_SCALE`] times the eye
//! image's larger side (at least [`SHADOW_MAP_MIN`]). Both are the same
//! algorithm's depth images. The shadow test then reprojects each visible pixel's point into the map: shadowed when its
//! light-view depth exceeds the map's by more than the bias [`shadow_bias`] (the
//! specification's depth error of both images at their slopes, plus the map's
//! depth change across half a texel, and the receiver's own slope towards the
//! light); a point on a face turned away from the light is in its own shadow.
//! The shadow test runs on the CPU over the two read-back depth images (the
//! visible triangle's normal looked up in its mesh); it is not a GPU pass yet.
//! The reference casts exact shadow rays
//! ([`crate::reference::shadow`]). Both darken shadowed pixels by [`SHADOW_KEEP`].
#![deny(unsafe_code)]

use std::time::Instant;

use serde::Serialize;

use super::{Frame, RenderError, RenderOptions};
use crate::geom::bvh::{Line, SceneBvh, WorldCrossing};
use crate::output::Images;
use crate::plan::Algo;
use crate::reference::precision::{slopes, DepthPrecision};
use crate::scene::light::Light;
use crate::scene::{Camera, Projection, Scene};
use glam::DVec3;

/// The shadow map's side over the eye image's larger side.
pub const SHADOW_MAP_SCALE: u32 = 2;
/// Smallest shadow-map side: small images get a finer map (shadow edges are
/// then right to a fraction of a pixel).
pub const SHADOW_MAP_MIN: u32 = 1024;
/// Largest shadow-map side.
pub const SHADOW_MAP_MAX: u32 = 8192;
/// Fraction of a shadowed pixel's colour kept (the lit shading is the contract's).
pub const SHADOW_KEEP: f64 = 0.5;

/// The shadow figures of `stats.json` (extension).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ShadowStats {
    /// The light, e.g. `directional [0.0000, -1.0000, 0.0000]`.
    pub light: String,
    /// Visible pixels the light reaches.
    pub lit_pixels: u64,
    /// Visible pixels in shadow.
    pub shadowed_pixels: u64,
    /// GPU: the shadow map's side in pixels.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shadow_map_size: Option<u32>,
    /// GPU: the shadow map's frame (GPU time).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shadow_map_gpu_ms: Option<f64>,
}

/// The shadow map's side for a `width × height` eye image.
pub fn shadow_map_size(width: u32, height: u32) -> u32 {
    (width.max(height) * SHADOW_MAP_SCALE).clamp(SHADOW_MAP_MIN, SHADOW_MAP_MAX)
}

/// `scene` seen from `light` at `size × size`.
pub fn light_scene(scene: &Scene, light: &Light, size: u32) -> Scene {
    let mut s = scene.clone();
    s.camera = light.camera_for(scene);
    s.render.width = size;
    s.render.height = size;
    s
}

/// One depth image with what its error bound needs.
pub struct DepthView<'a> {
    pub images: &'a Images,
    pub camera: &'a Camera,
    pub precision: DepthPrecision,
}

/// The shadow test's bias at a map texel of depth `m` and slope `slope_m` (view
/// depth per texel, `|∂x| + |∂y|`), for an eye point of view depth `d`, slope
/// `slope_e` and ray cosine `cos` (ray direction · view direction): the
/// specification's error of the map's depth and of the eye's (the latter along
/// the eye ray, so divided by `cos`), plus `slope_m` for the point lying up to
/// half a texel from the texel centre on each axis (0.5 · slope), doubled because
/// the slope is a one-sided estimate.
pub fn shadow_bias(
    map: &DepthView,
    m: f64,
    slope_m: f64,
    eye: &DepthView,
    d: f64,
    slope_e: f64,
    cos: f64,
) -> f64 {
    map.precision.allowed(map.camera, m, slope_m)
        + slope_m
        + eye.precision.allowed(eye.camera, d, slope_e) / cos.max(1e-6)
}

/// The unit normal of the boundary seen at eye pixels, pointing out of the solid
/// (towards the eye), and whether it bounds a closed primitive. The GPU frame has
/// no normal image, so the triangle is looked up on the CPU: the crossing of the
/// pixel's line with the visible primitive's mesh nearest the visible point.
struct Normals {
    bvh: SceneBvh,
    closed: usize,
}

impl Normals {
    fn new(scene: &Scene) -> Normals {
        Normals {
            bvh: SceneBvh::new(
                scene
                    .primitives
                    .iter()
                    .map(|p| &p.mesh)
                    .chain(scene.surfaces.iter().map(|s| &s.mesh)),
            ),
            closed: scene.primitives.len(),
        }
    }

    /// At 1-based mesh index `prim`, on `line` at parameter `t`.
    fn at(
        &self,
        prim: u16,
        line: &Line,
        t: f64,
        tmp: &mut Vec<WorldCrossing>,
    ) -> Option<(DVec3, bool)> {
        let idx = prim as usize - 1;
        tmp.clear();
        self.bvh.cast(line, |s| s == idx, &mut Vec::new(), tmp);
        let c = tmp.iter().min_by(|a, b| {
            (a.crossing.t - t)
                .abs()
                .total_cmp(&(b.crossing.t - t).abs())
        })?;
        let n = self.bvh.shapes[idx].normal(c.crossing.tri);
        let n = if n.dot(line.dir) > 0.0 { -n } else { n };
        Some((n, idx < self.closed))
    }
}

/// Per eye pixel: `None` on background, `Some(true)` in shadow, by the shadow map
/// `map`. A point on a closed primitive's face turned away from the light is in
/// its own shadow; otherwise the map decides, with [`shadow_bias`] plus the
/// receiver's own depth change across the texel (its face's slope seen from the
/// light: a texel's width times `tan` of the angle to the light), which a face
/// the light grazes needs because the map may not show it at all.
pub fn shadow_test(scene: &Scene, eye: &DepthView, map: &DepthView) -> Vec<Option<bool>> {
    let (w, h) = (eye.images.width, eye.images.height);
    let (mw, mh) = (map.images.width, map.images.height);
    let eye_slopes = slopes(eye.images);
    let map_slopes = slopes(map.images);
    let normals = Normals::new(scene);
    let fwd = eye.camera.forward();
    let lfwd = map.camera.forward();
    let mut tmp = Vec::new();
    let mut out = Vec::with_capacity(eye.images.depth.len());
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let d = eye.images.depth[i] as f64;
            if !d.is_finite() || eye.images.prim[i] == 0 {
                out.push(None);
                continue;
            }
            let ray = eye.camera.ray(x as f64 + 0.5, y as f64 + 0.5, w, h);
            let cos = ray.dir.dot(fwd);
            let p = ray.origin + ray.dir * (d / cos);
            let dl = map.camera.view_depth(p);
            let (to_light, texel) = match map.camera.projection {
                Projection::Orthographic { height } => (-lfwd, height / mh as f64),
                Projection::Perspective { fov_y_deg } => (
                    (map.camera.eye - p).normalize(),
                    2.0 * dl * (fov_y_deg.to_radians() * 0.5).tan() / mh as f64,
                ),
            };
            let line = Line::from_ray(&ray);
            let facing = normals
                .at(eye.images.prim[i], &line, d / cos, &mut tmp)
                .map(|(n, closed)| (n.dot(to_light), closed));
            if let Some((f, true)) = facing {
                if f <= 0.0 {
                    out.push(Some(true));
                    continue;
                }
            }
            let (lx, ly) = map.camera.pixel_of(p, mw, mh);
            let (tx, ty) = (lx.floor(), ly.floor());
            if tx < 0.0 || ty < 0.0 || tx >= mw as f64 || ty >= mh as f64 {
                out.push(Some(false));
                continue;
            }
            let t = ty as usize * mw as usize + tx as usize;
            let m = map.images.depth[t] as f64;
            let shadowed = m.is_finite() && {
                let f = facing.map_or(1.0, |(f, _)| f.abs()).clamp(1e-3, 1.0);
                let receiver = texel * (1.0 - f * f).sqrt() / f;
                let bias = shadow_bias(map, m, map_slopes[t], eye, d, eye_slopes[i], cos);
                dl > m + bias + receiver
            };
            out.push(Some(shadowed));
        }
    }
    out
}

/// Darkens the shadowed pixels of `color` and counts lit and shadowed ones.
pub fn apply(color: &mut [[u8; 4]], mask: &[Option<bool>], light: &Light) -> ShadowStats {
    let mut st = ShadowStats {
        light: light.describe(),
        ..Default::default()
    };
    for (c, m) in color.iter_mut().zip(mask) {
        match m {
            Some(true) => {
                st.shadowed_pixels += 1;
                for v in &mut c[..3] {
                    *v = (*v as f64 * SHADOW_KEEP).round() as u8;
                }
            }
            Some(false) => st.lit_pixels += 1,
            None => {}
        }
    }
    st
}

/// A GPU frame of the eye and of the light, with their depth set-ups.
pub struct ShadowFrames {
    pub eye: Frame,
    pub eye_precision: DepthPrecision,
    pub map: Frame,
    pub map_camera: Camera,
    pub map_precision: DepthPrecision,
}

/// Renders the eye's frame and the shadow map with a GPU algorithm.
pub fn gpu_frames(
    scene: &Scene,
    opts: &RenderOptions,
    light: &Light,
) -> Result<ShadowFrames, RenderError> {
    let size = shadow_map_size(scene.render.width, scene.render.height);
    // The eye's frame is held while the light's map renders.
    super::FrameMemory {
        gpu: true,
        shadow_map: Some(size),
        ..Default::default()
    }
    .check(scene.render.width, scene.render.height)?;
    let (eye, eye_precision) = super::render_gpu(scene, opts)?;
    let ls = light_scene(scene, light, size);
    let (map, map_precision) = super::render_gpu(&ls, opts)?;
    Ok(ShadowFrames {
        eye,
        eye_precision,
        map,
        map_camera: ls.camera,
        map_precision,
    })
}

/// The lit/shadowed mask of a GPU algorithm's frames.
pub fn gpu_mask(scene: &Scene, f: &ShadowFrames) -> Vec<Option<bool>> {
    shadow_test(
        scene,
        &DepthView {
            images: &f.eye.images,
            camera: &scene.camera,
            precision: f.eye_precision,
        },
        &DepthView {
            images: &f.map.images,
            camera: &f.map_camera,
            precision: f.map_precision,
        },
    )
}

/// One frame of `scene` lit by `light`, shadows included.
pub fn render_shadowed(
    scene: &Scene,
    opts: &RenderOptions,
    light: &Light,
) -> Result<Frame, RenderError> {
    let t = Instant::now();
    if opts.algo == Algo::Reference {
        let mut frame = super::render_opaque(scene, opts)?;
        let mask = crate::reference::shadow::shadow_rays(
            scene,
            light,
            scene.render.width,
            scene.render.height,
        );
        let st = apply(&mut frame.images.color, &mask, light);
        frame.stats.exec.cpu_ms = t.elapsed().as_secs_f64() * 1e3;
        frame.stats.shadow = Some(st);
        return Ok(frame);
    }
    let f = gpu_frames(scene, opts, light)?;
    let mask = gpu_mask(scene, &f);
    let mut frame = f.eye;
    let mut st = apply(&mut frame.images.color, &mask, light);
    st.shadow_map_size = Some(f.map.images.width);
    st.shadow_map_gpu_ms = Some(f.map.stats.exec.gpu_ms);
    frame.stats.exec.cpu_ms = t.elapsed().as_secs_f64() * 1e3;
    frame.stats.shadow = Some(st);
    Ok(frame)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn apply_darkens_only_shadowed_pixels() {
        let mut c = vec![[200, 100, 51, 255]; 3];
        let light = Light::Directional {
            direction: glam::DVec3::NEG_Y,
        };
        let st = apply(&mut c, &[None, Some(true), Some(false)], &light);
        assert_eq!(c[0], [200, 100, 51, 255]);
        assert_eq!(c[1], [100, 50, 26, 255]);
        assert_eq!(c[2], [200, 100, 51, 255]);
        assert_eq!((st.lit_pixels, st.shadowed_pixels), (1, 1));
    }

    #[test]
    fn map_size_scales_and_caps() {
        assert_eq!(shadow_map_size(400, 300), SHADOW_MAP_MIN);
        assert_eq!(shadow_map_size(1000, 300), 2000);
        assert_eq!(shadow_map_size(16384, 10), SHADOW_MAP_MAX);
    }
}
