//! One frame of one algorithm, start to finish: the reference ray caster, or a
//! plan built for the scene and executed on a Vulkan device. Shared by the command
//! line, the benchmark harness and the GPU tests so they measure the same thing.
#![deny(unsafe_code)]

use std::time::Instant;

use serde::Serialize;

use crate::output::Images;
use peeltrim::plan::{self, Algo, PlanError, Prepared};
use peeltrim::scene::camera::DepthConvention;
use peeltrim::scene::Scene;
use peeltrim::vk;
use peeltrim_reference::precision::DepthPrecision;

pub mod edges;
mod gpu_layers;
pub mod interference;
mod kirsch;
pub mod layers;
pub mod memory;
mod sequence;
pub mod shadow;
pub mod style;

/// Depth-buffer set-ups of the speed-against-error studies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DepthSetup {
    D24S8,
    D32S8,
    /// D32S8 with reversed depth (near = 1): floating-point precision where
    /// perspective needs it.
    D32S8Reversed,
}

impl DepthSetup {
    /// The default set-up: a float depth buffer with reversed Z, whose relative
    /// precision suits perspective at every distance (docs/precision.md).
    pub const DEFAULT: DepthSetup = DepthSetup::D32S8Reversed;
    /// What the default falls back to on a device without a usable D32S8.
    pub const FALLBACK: DepthSetup = DepthSetup::D24S8;
    pub const ALL: [DepthSetup; 3] = [
        DepthSetup::D24S8,
        DepthSetup::D32S8,
        DepthSetup::D32S8Reversed,
    ];
    pub fn name(self) -> &'static str {
        match self {
            DepthSetup::D24S8 => "d24s8",
            DepthSetup::D32S8 => "d32s8",
            DepthSetup::D32S8Reversed => "d32s8-reversed",
        }
    }
    /// The specification's depth bounds for this set-up on a device with
    /// `subpixel_bits` of subpixel precision.
    pub fn precision(self, subpixel_bits: u32) -> DepthPrecision {
        let (format, reversed) = self.exec_format();
        DepthPrecision {
            float: format == vk::DepthFormat::D32S8,
            convention: if reversed {
                DepthConvention::Reversed
            } else {
                DepthConvention::Standard
            },
            subpixel_bits,
        }
    }
    /// The set-up to use on a device that can use the depth formats `usable`
    /// says it can: `self`, or with `fallback` (the user named no
    /// `--depth-format`) [`DepthSetup::FALLBACK`] where `self`'s format is not
    /// usable, with the reason (stats.json's `depth_setup_fallback`). The one
    /// rule of `render`, `bench` and `view`; a set-up asked for by name is kept,
    /// and the executor then refuses it with the flag to change.
    pub fn resolve(
        self,
        fallback: bool,
        device: &str,
        usable: impl Fn(vk::DepthFormat) -> bool,
    ) -> (DepthSetup, Option<String>) {
        let format = self.exec_format().0;
        if !fallback || usable(format) {
            return (self, None);
        }
        (
            DepthSetup::FALLBACK,
            Some(format!(
                "{device} cannot use {format:?}: {} instead",
                DepthSetup::FALLBACK.name()
            )),
        )
    }

    /// [`DepthSetup::resolve`] on `ctx`'s device.
    pub fn resolve_on(self, ctx: &vk::Context, fallback: bool) -> (DepthSetup, Option<String>) {
        self.resolve(fallback, ctx.device_name(), |f| {
            ctx.depth_format_usable(f.vk())
        })
    }

    pub fn exec_format(self) -> (vk::DepthFormat, bool) {
        match self {
            DepthSetup::D24S8 => (vk::DepthFormat::D24S8, false),
            DepthSetup::D32S8 => (vk::DepthFormat::D32S8, false),
            DepthSetup::D32S8Reversed => (vk::DepthFormat::D32S8, true),
        }
    }
}

#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub algo: Algo,
    pub device: vk::DeviceChoice,
    pub depth: DepthSetup,
    /// Fall back to [`DepthSetup::FALLBACK`] when the device cannot use `depth`'s
    /// format (the default set-up does; an explicit `--depth-format` does not).
    pub depth_fallback: bool,
    pub validation: bool,
    pub build: plan::BuildOptions,
}

/// The `stats.json` of one frame: typed until `output.rs` writes it.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct FrameStats {
    pub algo: String,
    /// With `--algo auto`: what was picked and why.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto: Option<crate::auto::AutoPick>,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel (`--samples`): colour averaged over them, depth and
    /// primitive ids of sample 0.
    pub samples: u32,
    pub device: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub depth_setup: Option<&'static str>,
    /// Why the requested depth set-up was replaced, if it was.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub depth_setup_fallback: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stencil_bits: Option<u8>,
    /// The reference's rendering passes (none: it ray casts).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub passes: Option<u64>,
    /// The reference's rays.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rays: Option<u64>,
    /// Timings and counts of the executor (the reference: its CPU time only).
    #[serde(flatten)]
    pub exec: vk::ExecStats,
    /// Layers and transparency (extension; only when asked for).
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub layers: Option<layers::LayerStats>,
    /// Shadows of the `[light]` (extension; only with one).
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub shadow: Option<shadow::ShadowStats>,
}

/// Images and the `stats.json` of one frame.
#[derive(Clone, Debug)]
pub struct Frame {
    pub images: Images,
    pub stats: FrameStats,
    /// With samples above 1: each pixel's covered samples ×255 over the
    /// samples (`coverage.png`; `vk::Executor::coverage`).
    pub coverage: Option<Vec<u8>>,
}

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Plan(#[from] PlanError),
    #[error(transparent)]
    Vk(#[from] vk::VkError),
    #[error("algorithm '{algo}' cannot render {what} yet: use --algo reference")]
    Unsupported { algo: String, what: &'static str },
    #[error(
        "{0} with --samples above 1: not supported, they compose single-sample layers \
         and masks; use --samples 1"
    )]
    Multisampled(&'static str),
    #[error("Vulkan validation reported {} message(s); first: {}", .0.len(), .0.first().map(String::as_str).unwrap_or(""))]
    Validation(Vec<String>),
    #[error(transparent)]
    OverBudget(#[from] peeltrim::budget::OverBudget),
}

pub use memory::{
    FrameMemory, DEVICE_BYTES_PER_PIXEL, GPU_HOST_BYTES_PER_PIXEL, REFERENCE_BYTES_PER_PIXEL,
};

/// Refuses a frame whose images would exceed the memory budget, before any is
/// allocated (its extras: [`FrameMemory`]).
pub fn check_frame_budget(
    width: u32,
    height: u32,
    gpu: bool,
) -> Result<(), peeltrim::budget::OverBudget> {
    FrameMemory {
        gpu,
        ..Default::default()
    }
    .check(width, height)
}

/// The CPU reference: exact ray casting.
pub fn render_reference(scene: &Scene) -> Frame {
    let t = Instant::now();
    let (images, _, coverage) =
        peeltrim_reference::render_samples(scene, scene.render.width, scene.render.height);
    let coverage = (scene.render.samples > 1).then_some(coverage);
    let mut stats = reference_stats(&images, t.elapsed().as_secs_f64() * 1e3);
    stats.samples = scene.render.samples;
    stats.rays = stats.rays.map(|r| r * scene.render.samples as u64);
    Frame {
        images,
        stats,
        coverage,
    }
}

/// The reference's `stats.json` for `images` cast in `cpu_ms`.
fn reference_stats(images: &Images, cpu_ms: f64) -> FrameStats {
    FrameStats {
        algo: "reference".into(),
        width: images.width,
        height: images.height,
        samples: 1,
        device: format!(
            "cpu: exact f64 ray casting on {} threads",
            rayon::current_num_threads()
        ),
        passes: Some(0),
        rays: Some(images.width as u64 * images.height as u64),
        exec: vk::ExecStats {
            cpu_ms,
            ..Default::default()
        },
        ..Default::default()
    }
}

/// A Vulkan device with the scene uploaded, ready to run plans repeatedly.
pub struct GpuRenderer {
    // Field order is drop order: the executor's objects go before the context.
    exec: vk::Executor,
    ctx: vk::Context,
    depth: DepthSetup,
    /// Why the requested set-up was replaced, if it was.
    fallback: Option<String>,
    /// What its layered frames needed (`sequence`: one submission each).
    layered: sequence::Sequencer,
}

impl GpuRenderer {
    pub fn new(
        scene: &Scene,
        device: vk::DeviceChoice,
        depth: DepthSetup,
        validation: bool,
    ) -> Result<Self, RenderError> {
        Self::with_fallback(scene, device, depth, false, validation)
    }

    /// As [`GpuRenderer::new`]; with `fallback`, a device that cannot use
    /// `depth`'s format gets [`DepthSetup::FALLBACK`] instead (said in stats.json).
    pub fn with_fallback(
        scene: &Scene,
        device: vk::DeviceChoice,
        depth: DepthSetup,
        fallback: bool,
        validation: bool,
    ) -> Result<Self, RenderError> {
        Self::build(scene, device, depth, fallback, validation, None)
    }

    /// As [`GpuRenderer::new`], with `emulation`'s vertex snapping on the
    /// device's hardware profile ([`vk::DeviceProfile::emulating`]): a test of a
    /// coarser device. `None`: the device's own profile.
    pub fn emulating(
        scene: &Scene,
        device: vk::DeviceChoice,
        depth: DepthSetup,
        validation: bool,
        emulation: Option<vk::RoundingEmulation>,
    ) -> Result<Self, RenderError> {
        Self::build(scene, device, depth, false, validation, emulation)
    }

    fn build(
        scene: &Scene,
        device: vk::DeviceChoice,
        depth: DepthSetup,
        fallback: bool,
        validation: bool,
        emulation: Option<vk::RoundingEmulation>,
    ) -> Result<Self, RenderError> {
        check_frame_budget(scene.render.width, scene.render.height, true)?;
        let mut ctx = vk::Context::new(&vk::ContextDesc { device, validation })?;
        if let Some(e) = emulation {
            ctx = ctx.with_profile(ctx.profile().emulating(e));
        }
        ctx.check_frame_size(
            scene.render.width,
            scene.render.height,
            DEVICE_BYTES_PER_PIXEL,
        )?;
        let (depth, why) = depth.resolve_on(&ctx, fallback);
        let (depth_format, reversed_z) = depth.exec_format();
        let desc = vk::ExecDesc {
            width: scene.render.width,
            height: scene.render.height,
            depth_format,
            reversed_z,
            samples: scene.render.samples,
        };
        let mut exec = vk::Executor::new(&ctx, &desc)?;
        exec.upload(scene)?;
        Ok(GpuRenderer {
            exec,
            ctx,
            depth,
            fallback: why,
            layered: Default::default(),
        })
    }

    /// Gives the executor the cutter sets of `algo` on `prep` under `scene`'s
    /// camera (`plan::cut_away::CutAway::of`, `vk::Executor::set_cut_away`):
    /// SCS's subtractions are cut to the openings they can act in. For the
    /// uploaded scene only; a new upload drops them.
    pub fn set_cut_away(&mut self, algo: Algo, prep: &Prepared, scene: &Scene) {
        self.exec
            .set_cut_away(peeltrim::plan::cut_away::CutAway::of(algo, prep, scene));
    }

    /// Uploads `scene`'s meshes and camera again (e.g. with other colours).
    pub fn upload(&mut self, scene: &Scene) -> Result<(), RenderError> {
        Ok(self.exec.upload(scene)?)
    }

    /// The renderer `opts` asks for (device, depth set-up and its fallback,
    /// validation).
    pub fn for_options(scene: &Scene, opts: &RenderOptions) -> Result<Self, RenderError> {
        Self::with_fallback(
            scene,
            opts.device,
            opts.depth,
            opts.depth_fallback,
            opts.validation,
        )
    }

    /// The depth set-up in use (after any fallback).
    pub fn depth_setup(&self) -> DepthSetup {
        self.depth
    }

    /// Why the requested depth set-up was replaced, if it was.
    pub fn depth_setup_fallback(&self) -> Option<String> {
        self.fallback.clone()
    }

    /// The specification's depth bounds for this device and set-up.
    pub fn precision(&self) -> DepthPrecision {
        self.depth.precision(self.ctx.subpixel_bits())
    }

    pub fn device_name(&self) -> String {
        self.ctx.device_name().to_string()
    }

    /// The executor of the frames (the shadow pass samples its images).
    pub(crate) fn executor(&self) -> &vk::Executor {
        &self.exec
    }

    /// The device's context (the bench's embedded path runs on it too).
    pub fn context(&self) -> &vk::Context {
        &self.ctx
    }

    /// Validation messages collected so far (empty when validation is off).
    pub fn validation_messages(&self) -> Vec<String> {
        self.ctx.validation_messages()
    }

    /// Executes a plan once; the images stay on the GPU (see [`Self::read_back`]).
    pub fn execute(&mut self, plan: &plan::Plan) -> Result<FrameStats, RenderError> {
        let exec = self.exec.execute(plan)?;
        Ok(self.frame_stats(plan, exec))
    }

    /// The executor of the frames, for a frame submitted with others
    /// (`vk::Executor::prepare`, see [`shadow::GpuShadows::frame`]).
    pub(crate) fn executor_mut(&mut self) -> &mut vk::Executor {
        &mut self.exec
    }

    /// The statistics of a frame of `plan` whose executor's figures are `exec`.
    pub(crate) fn frame_stats(&self, plan: &plan::Plan, exec: vk::ExecStats) -> FrameStats {
        let d = self.exec.desc();
        FrameStats {
            algo: plan.algo.clone(),
            width: d.width,
            height: d.height,
            samples: d.samples,
            device: self.ctx.device_name().to_string(),
            depth_setup: Some(self.depth.name()),
            depth_setup_fallback: self.fallback.clone(),
            stencil_bits: Some(plan.stencil_bits),
            passes: None,
            rays: None,
            exec,
            layers: None,
            shadow: None,
            auto: None,
        }
    }

    /// Whether later frames also write the normal buffer (Kirsch, Nienhaus & Döllner
    /// §5.2), read with [`Self::read_normals`]; refused when the buffer would not fit
    /// the memory budget or the device.
    pub fn set_normals(&mut self, on: bool) -> Result<(), RenderError> {
        if on {
            let d = self.exec.desc();
            let m = FrameMemory {
                gpu: true,
                normals: true,
                ..Default::default()
            };
            m.check(d.width, d.height)?;
            self.ctx
                .check_frame_size(d.width, d.height, m.device_bytes_per_pixel())?;
        }
        self.exec.set_normals(on);
        Ok(())
    }

    /// Whether frames write the normal buffer ([`Self::set_normals`]).
    pub fn normals(&self) -> bool {
        self.exec.normals()
    }

    /// The last frame's view-space normals (see [`vk::Executor::read_normals`]).
    pub fn read_normals(&mut self) -> Result<Option<Vec<[f32; 3]>>, RenderError> {
        Ok(self.exec.read_normals()?)
    }

    /// Whether later frames keep the GPU composite's images; `false` when the
    /// device cannot (see [`vk::Executor::set_transparency`]).
    /// Refused when its float target would not fit the memory budget or the
    /// device.
    pub fn set_transparency(&mut self, on: bool) -> Result<bool, RenderError> {
        if on {
            let d = self.exec.desc();
            let m = FrameMemory {
                gpu: true,
                normals: self.exec.normals(),
                accumulate: true,
                ..Default::default()
            };
            m.check(d.width, d.height)?;
            self.ctx
                .check_frame_size(d.width, d.height, m.device_bytes_per_pixel())?;
        }
        Ok(self.exec.set_transparency(on)?)
    }

    /// Blends the last frame's layer into the GPU composite (see
    /// [`vk::Executor::accumulate`]).
    pub fn accumulate(&mut self, alpha: Option<&[f32]>) -> Result<(), RenderError> {
        Ok(self.exec.accumulate(alpha)?)
    }

    /// The GPU composite so far: premultiplied colour and coverage per pixel.
    pub fn read_accumulation(&mut self) -> Result<Vec<[f32; 4]>, RenderError> {
        Ok(self.exec.read_accumulation()?)
    }

    /// The last frame's edge map computed on the GPU (`shaders/edges.frag`) by
    /// `rule`; `None` unless normals were on for that frame.
    pub fn edge_map(&mut self, rule: &edges::EdgeRule) -> Result<Option<Vec<bool>>, RenderError> {
        Ok(self.exec.edge_map(rule.depth_rel, rule.angle_deg)?)
    }

    /// Moves the camera (no upload; the next frame replays its recording when the
    /// scissors allow, see `vk::Recorded`).
    pub fn set_camera(&mut self, camera: &peeltrim::scene::Camera) -> Result<(), RenderError> {
        Ok(self.exec.set_camera(camera)?)
    }

    /// The next frame records its command buffer again instead of replaying it.
    pub fn forget_recording(&mut self) {
        self.exec.forget_recording();
    }

    /// What the host allocator of the executor's command buffers served so
    /// far ([`vk::Executor::command_arena`]).
    pub fn command_arena(&self) -> vk::cmd_arena::ArenaCounts {
        self.exec.command_arena()
    }

    /// CPU ms of each of `reps` recordings of `plan`'s kept frame, made anew
    /// without submitting (see [`vk::Executor::time_recording`]); `None` until a
    /// frame of `plan` has replayed.
    pub fn time_recording(
        &mut self,
        plan: &plan::Plan,
        reps: u32,
    ) -> Result<Option<Vec<f64>>, RenderError> {
        Ok(self.exec.time_recording(plan, reps)?)
    }

    /// [`Self::time_recording`] with the executor's cached decisions (see
    /// [`vk::Executor::time_recording_cached`]).
    pub fn time_recording_cached(
        &mut self,
        plan: &plan::Plan,
        reps: u32,
    ) -> Result<Option<Vec<f64>>, RenderError> {
        Ok(self.exec.time_recording_cached(plan, reps)?)
    }

    /// The images of the last executed frame.
    pub fn read_back(&mut self) -> Result<Images, RenderError> {
        Ok(self.exec.read_back()?)
    }

    /// Executes a plan once and reads its images back.
    pub fn frame(&mut self, plan: &plan::Plan) -> Result<Frame, RenderError> {
        let stats = self.execute(plan)?;
        let images = self.read_back()?;
        let coverage = self.exec.coverage().map(<[u8]>::to_vec);
        Ok(Frame {
            images,
            stats,
            coverage,
        })
    }
}

/// Renders one frame with the chosen algorithm: with the scene's `[light]`, its
/// shadows too ([`shadow`]).
pub fn render(scene: &Scene, opts: &RenderOptions) -> Result<Frame, RenderError> {
    match &scene.appearance.light {
        Some(_) if scene.render.samples > 1 => Err(RenderError::Multisampled("shadows ([light])")),
        Some(light) => shadow::render_shadowed(scene, opts, light),
        None => render_opaque(scene, opts),
    }
}

/// The plain opaque frame (any `[light]` ignored).
pub fn render_opaque(scene: &Scene, opts: &RenderOptions) -> Result<Frame, RenderError> {
    if opts.algo == Algo::Reference {
        check_frame_budget(scene.render.width, scene.render.height, false)?;
        return Ok(render_reference(scene));
    }
    Ok(render_gpu(scene, opts)?.0)
}

/// One frame of a GPU algorithm, with the depth bounds of the set-up it used.
fn render_gpu(scene: &Scene, opts: &RenderOptions) -> Result<(Frame, DepthPrecision), RenderError> {
    let prep = Prepared::new(scene)?;
    let plan = plan::build_with(opts.algo, &prep, &opts.build)?;
    let mut gpu = GpuRenderer::for_options(scene, opts)?;
    gpu.set_cut_away(opts.algo, &prep, scene);
    let frame = gpu.frame(&plan)?;
    let msgs = gpu.validation_messages();
    if !msgs.is_empty() {
        return Err(RenderError::Validation(msgs));
    }
    Ok((frame, gpu.precision()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one fallback rule of `render`, `bench` and `view`.
    #[test]
    fn depth_setup_falls_back_only_by_default_and_only_without_d32s8() {
        let no_d32 = |f: vk::DepthFormat| f != vk::DepthFormat::D32S8;
        let all = |_: vk::DepthFormat| true;
        // The default on a device without D32S8: D24S8, with the reason.
        let (d, why) = DepthSetup::DEFAULT.resolve(true, "dev", no_d32);
        assert_eq!(d, DepthSetup::D24S8);
        assert_eq!(why.as_deref(), Some("dev cannot use D32S8: d24s8 instead"));
        let (d, why) = DepthSetup::D32S8.resolve(true, "dev", no_d32);
        assert_eq!((d, why.is_some()), (DepthSetup::D24S8, true));
        // Asked for by name (no fallback): kept, for the executor to refuse.
        let (d, why) = DepthSetup::D32S8Reversed.resolve(false, "dev", no_d32);
        assert_eq!((d, why), (DepthSetup::D32S8Reversed, None));
        // A device with D32S8, or D24S8 asked for: nothing changes.
        for s in DepthSetup::ALL {
            assert_eq!(s.resolve(true, "dev", all), (s, None));
        }
        assert_eq!(
            DepthSetup::D24S8.resolve(true, "dev", no_d32),
            (DepthSetup::D24S8, None)
        );
    }
}
