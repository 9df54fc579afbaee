//! Shadows of a scene with a `[light]` (Rossignac & Wu: the CSG solid's
//! depth buffer seen from the light, then a shadow test in the eye's shading).
//!
//! GPU algorithms render the plan twice on one device: from the eye (with the
//! normal buffer), and from the light's camera ([`Light::camera_for`]:
//! orthographic for a directional light, perspective for a point light) into a
//! square shadow map of [`SHADOW_MAP_SCALE`] times the eye image's larger side
//! (at least [`SHADOW_MAP_MIN`]) on an executor of its own. The shadow pass
//! (`vk::shadow`, `shaders/shadow.frag`) then reprojects each visible pixel's
//! point into the map on the GPU: shadowed when its light-view depth exceeds the
//! map's by more than the bias — the specification's depth error of both images
//! at their slopes, plus the map's depth change across half a texel, and the
//! receiver's own slope towards the light; a point on a closed primitive's face
//! turned away from the light is in its own shadow. This module forms the pass's
//! parameters and runs the frames. The reference casts exact shadow rays
//! ([`peeltrim_reference::shadow`]). Both darken shadowed pixels by [`SHADOW_KEEP`].
#![deny(unsafe_code)]

use std::time::Instant;

use serde::Serialize;

use super::{DepthSetup, Frame, GpuRenderer, RenderError, RenderOptions};
use glam::{DMat4, DVec3};
use peeltrim::plan::{Algo, Plan, Prepared};
use peeltrim::scene::camera::DepthConvention;
use peeltrim::scene::light::Light;
use peeltrim::scene::{Camera, Projection, Scene};
use peeltrim::vk::{self, shadow::ShadowParams};
use peeltrim_reference::precision::DepthPrecision;

/// The shadow map's side over the eye image's larger side.
pub const SHADOW_MAP_SCALE: u32 = 2;
/// Smallest shadow-map side: small images get a finer map (shadow edges are
/// then right to a fraction of a pixel).
pub const SHADOW_MAP_MIN: u32 = 1024;
/// Largest shadow-map side.
pub const SHADOW_MAP_MAX: u32 = 8192;
pub use peeltrim::vk::shadow::SHADOW_KEEP;

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
    /// GPU: the shadow pass (GPU time).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shadow_pass_gpu_ms: Option<f64>,
    /// GPU: queue submissions of the shadowed frame (map, eye, pass; 1 when
    /// both frames replay, see `GpuShadows::frame`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shadow_submits: Option<u64>,
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

/// The shadow pass's uniform block for an eye camera `eye` on a `width ×
/// height` image and the light's camera `map` on a `size × size` map, with the
/// set-up's depth bounds `precision` and `closed` closed primitives (mesh ids
/// above are open surfaces). Formed in f64 relative to the map camera's target
/// (the drawn geometry's centre) and rounded once.
pub fn pass_params(
    eye: &Camera,
    (width, height): (u32, u32),
    map: &Camera,
    size: u32,
    precision: &DepthPrecision,
    closed: usize,
) -> ShadowParams {
    let origin = map.target;
    let reversed = precision.convention == DepthConvention::Reversed;
    let f32s = |v: &[f64]| -> Vec<f32> { v.iter().map(|&x| x as f32).collect() };
    let vec4 = |v: DVec3, w: f64| -> [f32; 4] { [v.x as f32, v.y as f32, v.z as f32, w as f32] };
    let ortho = |c: &Camera| matches!(c.projection, Projection::Orthographic { .. });
    let cam = |c: &Camera| {
        [
            c.near as f32,
            c.far as f32,
            ortho(c) as u32 as f32,
            reversed as u32 as f32,
        ]
    };
    // (nx·d, ny·d, d, 1) or (nx, ny, d, 1) → world: Camera::ray's point at view
    // depth d (NDC y downward, view y upward).
    let aspect = width as f64 / height as f64;
    let (sx, sy) = match eye.projection {
        Projection::Perspective { fov_y_deg } => {
            let th = (fov_y_deg.to_radians() * 0.5).tan();
            (th * aspect, th)
        }
        Projection::Orthographic { height } => (height * aspect * 0.5, height * 0.5),
    };
    let inv_view = eye.view().inverse();
    let col = |v: DVec3| inv_view.transform_vector3(v).extend(0.0);
    let unproject = DMat4::from_cols(
        col(DVec3::new(sx, 0.0, 0.0)),
        col(DVec3::new(0.0, -sy, 0.0)),
        col(DVec3::NEG_Z),
        (eye.eye - origin).extend(1.0),
    );
    let light_clip =
        map.proj(1.0, DepthConvention::Standard) * map.view() * DMat4::from_translation(origin);
    // A texel's world size: fixed (orthographic) or per unit of view depth.
    let texel = match map.projection {
        Projection::Orthographic { height } => height / size as f64,
        Projection::Perspective { fov_y_deg } => {
            2.0 * (fov_y_deg.to_radians() * 0.5).tan() / size as f64
        }
    };
    ShadowParams {
        eye_unproject: f32s(&unproject.to_cols_array()).try_into().expect("16"),
        light_clip: f32s(&light_clip.to_cols_array()).try_into().expect("16"),
        eye_cam: cam(eye),
        map_cam: cam(map),
        eye_pos: vec4(eye.eye - origin, !ortho(eye) as u32 as f64),
        eye_fwd: vec4(eye.forward(), 0.0),
        light_pos: vec4(map.eye - origin, !ortho(map) as u32 as f64),
        light_fwd: vec4(map.forward(), texel),
        sizes: [width as f32, height as f32, size as f32, size as f32],
        prec: [
            precision.float as u32 as f32,
            0.5f32.powi(precision.subpixel_bits as i32 + 1),
            closed as f32,
            0.0,
        ],
    }
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

/// What the shadow pass's parameters need of the light's side: the map's
/// camera and side, the closed primitives' count and the depth bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightView {
    pub map_camera: Camera,
    pub size: u32,
    pub closed: usize,
    pub precision: DepthPrecision,
}

impl LightView {
    /// The pass's uniform block for an eye camera on a `width × height` image.
    pub fn params(&self, eye: &Camera, extent: (u32, u32)) -> ShadowParams {
        pass_params(
            eye,
            extent,
            &self.map_camera,
            self.size,
            &self.precision,
            self.closed,
        )
    }
}

/// The light's side of a GPU renderer: the light's depth map on an executor of
/// its own (same device, map size) and the shadow pass. The map of a
/// world-fixed light depends only on the plan, so it is rendered once per plan
/// ([`GpuShadows::ensure_map`]); each eye frame then costs one shadow pass.
pub struct GpuShadows {
    pass: vk::shadow::ShadowPass,
    map: vk::Executor,
    map_plan: Plan,
    /// Whether the map holds a frame of `map_plan`.
    map_done: bool,
    light: Light,
    view: LightView,
}

/// One shadowed eye frame's extra costs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShadowCost {
    /// The light map's frame, when this frame rendered it.
    pub map: Option<vk::ExecStats>,
    /// The shadow pass.
    pub pass: vk::shadow::ShadowRun,
    /// Queue submissions of the whole shadowed frame (map, eye and pass): 1
    /// when both frames replay ([`GpuShadows::frame`]).
    pub submits: u64,
}

impl GpuShadows {
    /// Shadows of `light` over `width × height` eye frames on `ctx`'s device
    /// with depth set-up `depth` (bounds `precision`), the map rendered by
    /// `algo` with `build`'s options. The eye's executor must write normals.
    pub fn new(
        ctx: &vk::Context,
        (depth, precision): (DepthSetup, DepthPrecision),
        scene: &Scene,
        light: &Light,
        algo: Algo,
        build: &peeltrim::plan::BuildOptions,
    ) -> Result<GpuShadows, RenderError> {
        let (width, height) = (scene.render.width, scene.render.height);
        let size = shadow_map_size(width, height);
        let ls = light_scene(scene, light, size);
        let prep = Prepared::new(&ls)?;
        let map_plan = peeltrim::plan::build_with(algo, &prep, build)?;
        peeltrim::budget::current().check(
            || format!("a {size}x{size} shadow map"),
            size as u64 * size as u64 * super::GPU_HOST_BYTES_PER_PIXEL,
            "use a smaller --size (the map is 2x the image's larger side)",
        )?;
        ctx.check_frame_size(size, size, super::DEVICE_BYTES_PER_PIXEL)?;
        let (depth_format, reversed_z) = depth.exec_format();
        let mut map = vk::Executor::new(
            ctx,
            &vk::ExecDesc {
                width: size,
                height: size,
                depth_format,
                reversed_z,
                samples: 1,
            },
        )?;
        map.upload(&ls)?;
        let pass = vk::shadow::ShadowPass::new(ctx, width, height)?;
        Ok(GpuShadows {
            pass,
            map,
            map_plan,
            map_done: false,
            light: *light,
            view: LightView {
                map_camera: ls.camera,
                size,
                closed: scene.primitives.len(),
                precision,
            },
        })
    }

    /// Shadows for `gpu`'s frames (which from now on write normals).
    pub fn for_renderer(
        gpu: &mut GpuRenderer,
        scene: &Scene,
        light: &Light,
        algo: Algo,
        build: &peeltrim::plan::BuildOptions,
    ) -> Result<GpuShadows, RenderError> {
        gpu.set_normals(true)?;
        let setup = (gpu.depth_setup(), gpu.precision());
        Self::new(gpu.context(), setup, scene, light, algo, build)
    }

    /// The shadow map's side.
    pub fn map_size(&self) -> u32 {
        self.view.size
    }

    /// Renders the light's map unless it holds this plan's already (a
    /// world-fixed light's map does not change with the eye's camera).
    pub fn ensure_map(&mut self) -> Result<Option<vk::ExecStats>, RenderError> {
        if self.map_done {
            return Ok(None);
        }
        let st = self.map.execute(&self.map_plan)?;
        self.map_done = true;
        Ok(Some(st))
    }

    /// Darkens the shadowed pixels of `gpu`'s last frame (seen by `eye`), the
    /// map rendered first if it needs to be.
    pub fn shade(&mut self, gpu: &GpuRenderer, eye: &Camera) -> Result<ShadowCost, RenderError> {
        let map = self.ensure_map()?;
        let exec = gpu.executor();
        let d = exec.desc();
        let params = self.view.params(eye, (d.width, d.height));
        let pass = self
            .pass
            .run(exec, &self.map, &params, exec.output_rect())?;
        let submits = map.as_ref().map_or(0, |m| m.counts.submits) + 1;
        Ok(ShadowCost { map, pass, submits })
    }

    /// One shadowed frame of `plan` on `gpu`, seen by `eye`: the light's map
    /// (again when `new_map`, as the bench times it; otherwise only when it
    /// does not hold this plan's), the eye's frame and the shadow pass. When
    /// both frames replay their recordings (their loop counts are known) they
    /// and the pass go in one submission with one wait; a frame
    /// whose counts then fail the GPU's check runs again loop by loop and the
    /// pass after it. Otherwise (a plan's first frame) frame by frame.
    pub fn frame(
        &mut self,
        gpu: &mut GpuRenderer,
        plan: &Plan,
        eye: &Camera,
        new_map: bool,
    ) -> Result<(crate::render::FrameStats, ShadowCost), RenderError> {
        if new_map {
            self.map_done = false;
        }
        let batched = gpu.executor().knows_loops(plan)
            && (self.map_done || self.map.knows_loops(&self.map_plan));
        if !batched {
            let stats = gpu.execute(plan)?;
            let mut cost = self.shade(gpu, eye)?;
            cost.submits += stats.exec.counts.submits;
            return Ok((stats, cost));
        }
        let map_frame = match self.map_done {
            true => None,
            false => Some(self.map.prepare(&self.map_plan)?.expect("counts known")),
        };
        let eye_frame = gpu.executor_mut().prepare(plan)?.expect("counts known");
        let exec = gpu.executor();
        let d = exec.desc();
        let params = self.view.params(eye, (d.width, d.height));
        let scissor = exec.output_rect();
        self.pass.record_own(exec, &self.map, &params, scissor)?;
        let frames: Vec<_> = map_frame
            .iter()
            .map(|f| f.cmd)
            .chain([eye_frame.cmd])
            .collect();
        self.pass.submit_after(&frames)?;
        let map = match map_frame {
            Some(f) => Some(self.map.complete(&self.map_plan, f)?),
            None => None,
        };
        self.map_done = true;
        let exec = gpu.executor_mut().complete(plan, eye_frame)?;
        // Frames run again loop by loop: their images are new, so is the pass.
        let rerun: Vec<u64> = map
            .iter()
            .chain([&exec])
            .filter(|s| s.recorded == vk::Recorded::Stepwise)
            .map(|s| s.counts.submits)
            .collect();
        let pass = match rerun.is_empty() {
            true => self.pass.result(scissor)?,
            false => self.pass.run(gpu.executor(), &self.map, &params, scissor)?,
        };
        let submits = 1 + rerun.iter().sum::<u64>() + u64::from(!rerun.is_empty());
        let stats = gpu.frame_stats(plan, exec);
        Ok((stats, ShadowCost { map, pass, submits }))
    }

    /// The map rendered, and the pass, handed to an embedder
    /// (`vk::Embedder::set_shadow`) for frames seen by `eye`; the light's view
    /// gives the parameters of later cameras.
    pub fn into_embedded(
        mut self,
        eye: &Camera,
    ) -> Result<(vk::shadow::EmbeddedShadow, LightView), RenderError> {
        self.ensure_map()?;
        let extent = self.pass.extent();
        let params = self.view.params(eye, (extent[0], extent[1]));
        Ok((
            vk::shadow::EmbeddedShadow {
                pass: self.pass,
                map: self.map,
                params,
            },
            self.view,
        ))
    }

    /// The last pass's shadowed pixels.
    pub fn mask(&mut self) -> Result<Vec<bool>, RenderError> {
        Ok(self.pass.read_mask()?)
    }

    /// Lit/shadowed counts over the covered pixels of `prim` by the last pass.
    pub fn stats(&mut self, prim: &[u16]) -> Result<ShadowStats, RenderError> {
        let mask = self.mask()?;
        let mut st = ShadowStats {
            light: self.light.describe(),
            shadow_map_size: Some(self.view.size),
            ..Default::default()
        };
        for (&p, &m) in prim.iter().zip(&mask) {
            match (p != 0, m) {
                (true, true) => st.shadowed_pixels += 1,
                (true, false) => st.lit_pixels += 1,
                (false, _) => {}
            }
        }
        Ok(st)
    }
}

/// Shadows of `light` in every later frame `embedder` records (its images of
/// `scene`'s render size, depth set-up `depth`, on `ctx`'s device): the eye
/// writes normals, the light's map is rendered now by `algo` (a world-fixed
/// light's map does not follow the camera), and the shadow pass is recorded
/// after each frame. Returns what later cameras' parameters need (set them in
/// `embedder.shadow_mut()`). Only while no frame of `embedder` is pending.
pub fn embed_shadows(
    embedder: &mut vk::Embedder,
    ctx: &vk::Context,
    depth: DepthSetup,
    scene: &Scene,
    light: &Light,
    algo: Algo,
) -> Result<LightView, RenderError> {
    embedder.set_shadow(None);
    embedder.set_normals(true);
    let setup = (depth, depth.precision(ctx.subpixel_bits()));
    let build = peeltrim::plan::BuildOptions::default();
    let shadows = GpuShadows::new(ctx, setup, scene, light, algo, &build)?;
    let (embedded, view) = shadows.into_embedded(&scene.camera)?;
    embedder.set_shadow(Some(embedded));
    Ok(view)
}

/// Per eye pixel: `None` on background, `Some(true)` in shadow, from a shadow
/// pass's `mask` and the frame's ids `prim`.
pub fn classify(prim: &[u16], mask: &[bool]) -> Vec<Option<bool>> {
    prim.iter()
        .zip(mask)
        .map(|(&p, &m)| (p != 0).then_some(m))
        .collect()
}

/// A GPU algorithm's frame of `scene` with the shadows of `light`, and its
/// shadow mask (tests compare it with the shadow rays).
pub fn gpu_shadowed(
    scene: &Scene,
    opts: &RenderOptions,
    light: &Light,
) -> Result<(Frame, Vec<Option<bool>>), RenderError> {
    let t = Instant::now();
    // The eye's frame is held while the light's map renders.
    super::FrameMemory {
        gpu: true,
        shadow_map: Some(shadow_map_size(scene.render.width, scene.render.height)),
        ..Default::default()
    }
    .check(scene.render.width, scene.render.height)?;
    let prep = Prepared::new(scene)?;
    let plan = peeltrim::plan::build_with(opts.algo, &prep, &opts.build)?;
    let mut gpu = GpuRenderer::for_options(scene, opts)?;
    let mut shadows = GpuShadows::for_renderer(&mut gpu, scene, light, opts.algo, &opts.build)?;
    let (mut stats, cost) = shadows.frame(&mut gpu, &plan, &scene.camera, false)?;
    let images = gpu.read_back()?;
    let mask = shadows.mask()?;
    let mut st = shadows.stats(&images.prim)?;
    st.shadow_map_gpu_ms = cost.map.map(|m| m.gpu_ms);
    st.shadow_pass_gpu_ms = Some(cost.pass.gpu_ms);
    st.shadow_submits = Some(cost.submits);
    stats.exec.cpu_ms = t.elapsed().as_secs_f64() * 1e3;
    stats.shadow = Some(st);
    drop(shadows);
    let msgs = gpu.validation_messages();
    if !msgs.is_empty() {
        return Err(RenderError::Validation(msgs));
    }
    let classes = classify(&images.prim, &mask);
    Ok((
        Frame {
            images,
            stats,
            coverage: None,
        },
        classes,
    ))
}

/// One frame of `scene` lit by `light`, shadows included: the reference casts
/// shadow rays, GPU algorithms run the shadow pass.
pub fn render_shadowed(
    scene: &Scene,
    opts: &RenderOptions,
    light: &Light,
) -> Result<Frame, RenderError> {
    if opts.algo != Algo::Reference {
        return Ok(gpu_shadowed(scene, opts, light)?.0);
    }
    let t = Instant::now();
    let mut frame = super::render_opaque(scene, opts)?;
    let mask = peeltrim_reference::shadow::shadow_rays(
        scene,
        light,
        scene.render.width,
        scene.render.height,
    );
    let st = apply(&mut frame.images.color, &mask, light);
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
