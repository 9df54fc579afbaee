//! The plan executor: records a plan's steps into command buffers (one submission
//! per straight run of steps, one per loop head and tail), with dynamic depth,
//! stencil and cull state per draw, timestamp and occlusion queries.
//!
//! Synchronization is deliberately simple: every image stays in `GENERAL` layout;
//! consecutive draws with the same attachments share one dynamic-rendering block
//! (rasterization order makes one draw's depth/stencil writes visible to the next);
//! a full memory barrier separates blocks, clears and copies.

use std::sync::Arc;
use std::time::Instant;

use ash::vk;
use glam::{DMat4, DVec3};
use gpu_allocator::MemoryLocation;
use serde::Serialize;

use super::conv;
use super::error::{Check, VkError};
use super::image::{range, Image, ImageDesc};
use super::instance::{Context, Shared};
use super::memory::Buffer;
use super::pipeline::{pipeline_flags, FragmentKind, PipelineDesc, Pipelines, PushConstants};
use super::readback::{decode, Raw};
use super::scissor::{bounds_rect, Rect};
use crate::output::Images;
use crate::plan::{Clear, Draw, Fragment, Geometry, Plan, Scissor, Step, Tex};
use crate::scene::camera::DepthConvention;
use crate::scene::{Aabb, Camera, Projection, Scene};

/// Depth-stencil format of the plan's depth-stencil images (`--depth-format`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize)]
pub enum DepthFormat {
    #[default]
    D24S8,
    D32S8,
}

impl DepthFormat {
    pub fn vk(self) -> vk::Format {
        match self {
            DepthFormat::D24S8 => vk::Format::D24_UNORM_S8_UINT,
            DepthFormat::D32S8 => vk::Format::D32_SFLOAT_S8_UINT,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExecDesc {
    pub width: u32,
    pub height: u32,
    pub depth_format: DepthFormat,
    /// Reversed depth (near 1, far 0); meant for `D32S8`.
    pub reversed_z: bool,
}

/// GPU time and draw count of all `Step::Pass` groups of one name.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PassStats {
    pub name: String,
    pub gpu_ms: f64,
    pub draws: u64,
}

/// Timings (vary) and counts (deterministic: equal for two runs of one plan).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ExecStats {
    pub gpu_ms: f64,
    pub cpu_ms: f64,
    pub per_pass: Vec<PassStats>,
    /// `Step::Draw`s executed (loop bodies once per iteration).
    pub draws: u64,
    /// Draws of mesh geometry (`Mesh` or `Meshes`).
    pub mesh_draws: u64,
    /// Full-screen draws, including internal depth copies.
    pub fullscreen_passes: u64,
    /// Mesh triangles submitted for rasterization (full-screen quads not counted).
    pub triangles: u64,
    /// Sum of the scissor areas of full-screen draws.
    pub fullscreen_pixels: u64,
    /// Head executions of each loop, in execution order.
    pub loop_iterations: Vec<u32>,
    /// Samples passed by all `count_samples` draws.
    pub samples_counted: u64,
}

/// A frame's images and statistics.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    pub images: Images,
    pub stats: ExecStats,
}

/// The uploaded scene.
struct SceneData {
    vertices: Buffer,
    /// `(first vertex, vertex count)` per mesh.
    ranges: Vec<(u32, u32)>,
    colors: Vec<[u8; 3]>,
    bounds: Vec<Aabb>,
    background: [u8; 3],
    camera: Camera,
    /// World point subtracted from every vertex before rounding to f32 (the eye
    /// at upload), folded back into `mvp` in f64: vertex rounding is relative to
    /// the distance from the eye wherever the scene lies in the world.
    origin: DVec3,
    view: DMat4,
    proj: DMat4,
    mvp: [f32; 16],
    /// Eye (w = 1) or view direction (w = 0) for shading.
    view_vec: [f32; 4],
    /// First vertex of the full-screen quad (6 vertices).
    quad_first: u32,
}

/// The plan's images and their descriptor sets.
struct Resources {
    shared: Arc<Shared>,
    pool: vk::DescriptorPool,
    tex_sets: Vec<vk::DescriptorSet>,
    ds_sets: Vec<vk::DescriptorSet>,
    color: Image,
    prim: Image,
    ds: Vec<Image>,
    tex: Vec<Image>,
}

impl Drop for Resources {
    fn drop(&mut self) {
        // SAFETY: the executor waited for the GPU; destroying the pool frees its sets.
        unsafe { self.shared.device.destroy_descriptor_pool(self.pool, None) };
    }
}

/// Attachments of a rendering block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    Color,
    Prim,
    Tex(Tex),
}

#[derive(Clone, Debug, PartialEq, Eq)]
struct BlockKey {
    colors: Vec<Target>,
    ds: Option<u8>,
}

/// Runs plans on one device at one image size.
pub struct Executor {
    shared: Arc<Shared>,
    desc: ExecDesc,
    pipelines: Pipelines,
    command_pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    occlusion: vk::QueryPool,
    occlusion_cap: u32,
    timestamps: vk::QueryPool,
    timestamps_cap: u32,
    resources: Option<Resources>,
    /// Images created since the last submission still need their layout set.
    fresh_images: bool,
    scene: Option<SceneData>,
    readback: Option<Buffer>,
    /// Vertex snapping of a coarser device, emulated (tests); `None`: off.
    rounding: Option<super::RoundingEmulation>,
}

/// State of one command buffer being recorded.
struct Rec {
    cmd: vk::CommandBuffer,
    block: Option<BlockKey>,
    bound: Option<vk::Pipeline>,
    occlusion_used: u32,
    /// `(timestamp index, pass name)` at each boundary.
    marks: Vec<(u32, String)>,
}

/// Executor-wide state during one `execute`.
struct Run {
    stats: ExecStats,
    pass: String,
}

fn full_memory_barrier(device: &ash::Device, cmd: vk::CommandBuffer) {
    memory_barrier(
        device,
        cmd,
        vk::AccessFlags::MEMORY_WRITE,
        vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE,
        vk::PipelineStageFlags::ALL_COMMANDS,
    );
}

/// A global memory barrier from every earlier command to `dst_stage`.
fn memory_barrier(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    src: vk::AccessFlags,
    dst: vk::AccessFlags,
    dst_stage: vk::PipelineStageFlags,
) {
    let barrier = [vk::MemoryBarrier::default()
        .src_access_mask(src)
        .dst_access_mask(dst)];
    // SAFETY: recording state; outside a rendering block (callers end it first).
    unsafe {
        device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::ALL_COMMANDS,
            dst_stage,
            vk::DependencyFlags::empty(),
            &barrier,
            &[],
            &[],
        )
    };
}

/// Layout transitions of whole images, with full execution and memory dependencies.
fn transition(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    images: &[(&Image, vk::ImageLayout, vk::ImageLayout)],
) {
    let barriers: Vec<_> = images
        .iter()
        .map(|(img, old, new)| {
            vk::ImageMemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::MEMORY_WRITE)
                .dst_access_mask(vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE)
                .old_layout(*old)
                .new_layout(*new)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(img.raw)
                .subresource_range(range(img.desc.aspect()))
        })
        .collect();
    // SAFETY: recording, outside rendering; the images are live and in `old`.
    unsafe {
        device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &barriers,
        )
    };
}

const GENERAL: vk::ImageLayout = vk::ImageLayout::GENERAL;
const SRC: vk::ImageLayout = vk::ImageLayout::TRANSFER_SRC_OPTIMAL;
const DST: vk::ImageLayout = vk::ImageLayout::TRANSFER_DST_OPTIMAL;

/// Occlusion and timestamp queries one submission of `steps` needs.
fn count_queries(steps: &[&Step]) -> (u32, u32) {
    let mut occlusion = 0;
    let mut passes = 0;
    for s in steps {
        match *s {
            Step::Draw(d) if d.count_samples => occlusion += 1,
            Step::Pass(_) => passes += 1,
            _ => {}
        }
    }
    (occlusion, passes + 2)
}

impl Executor {
    pub fn new(ctx: &Context, desc: &ExecDesc) -> Result<Executor, VkError> {
        if desc.width == 0 || desc.height == 0 {
            return Err(VkError::Plan("image size must be at least 1x1".into()));
        }
        let shared = ctx.shared.clone();
        let device = &shared.device;
        if !ctx.depth_format_usable(desc.depth_format.vk()) {
            return Err(VkError::Unsupported(format!(
                "{:?} as a sampled, copyable depth-stencil attachment (try the other --depth-format)",
                desc.depth_format
            )));
        }
        let pipelines = Pipelines::new(&shared)?;
        let pci = vk::CommandPoolCreateInfo::default()
            .queue_family_index(shared.queue_family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid create info on a live device.
        let command_pool =
            unsafe { device.create_command_pool(&pci, None) }.check("vkCreateCommandPool")?;
        let mut exec = Executor {
            shared: shared.clone(),
            desc: *desc,
            pipelines,
            command_pool,
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            occlusion: vk::QueryPool::null(),
            occlusion_cap: 0,
            timestamps: vk::QueryPool::null(),
            timestamps_cap: 0,
            resources: None,
            fresh_images: false,
            scene: None,
            readback: None,
            rounding: None,
        };
        let ai = vk::CommandBufferAllocateInfo::default()
            .command_pool(command_pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool is live.
        exec.cmd =
            unsafe { device.allocate_command_buffers(&ai) }.check("vkAllocateCommandBuffers")?[0];
        // SAFETY: valid create info.
        exec.fence = unsafe { device.create_fence(&vk::FenceCreateInfo::default(), None) }
            .check("vkCreateFence")?;
        exec.ensure_queries(64, 64)?;
        Ok(exec)
    }

    pub fn desc(&self) -> &ExecDesc {
        &self.desc
    }

    /// The push constants' flags: reversed Z, and the subpixel precision the tie
    /// tolerance assumes (the device's, or the emulated device's).
    fn flags(&self) -> u32 {
        let bits = match self.rounding {
            Some(r) => r.subpixel_bits,
            None => self.shared.limits.sub_pixel_precision_bits,
        };
        pipeline_flags(self.desc.reversed_z, bits)
    }

    /// Emulates a coarser device's vertex snapping in every later mesh draw.
    pub fn set_rounding_emulation(&mut self, rounding: Option<super::RoundingEmulation>) {
        self.rounding = rounding;
    }

    fn convention(&self) -> DepthConvention {
        if self.desc.reversed_z {
            DepthConvention::Reversed
        } else {
            DepthConvention::Standard
        }
    }

    fn ensure_queries(&mut self, occlusion: u32, timestamps: u32) -> Result<(), VkError> {
        let device = &self.shared.device;
        grow_pool(
            device,
            &mut self.occlusion,
            &mut self.occlusion_cap,
            vk::QueryType::OCCLUSION,
            occlusion,
        )?;
        grow_pool(
            device,
            &mut self.timestamps,
            &mut self.timestamps_cap,
            vk::QueryType::TIMESTAMP,
            timestamps,
        )
    }

    /// Uploads all meshes of `scene` (primitives in file order, then surfaces) and
    /// its camera.
    pub fn upload(&mut self, scene: &Scene) -> Result<(), VkError> {
        let meshes: Vec<(&crate::scene::Mesh, [u8; 3])> = scene
            .primitives
            .iter()
            .map(|p| (&p.mesh, p.color))
            .chain(scene.surfaces.iter().map(|s| (&s.mesh, s.color)))
            .collect();
        // Camera-relative vertices: f32 rounding then scales with the distance
        // from the eye, i.e. with the view depth (uniform relative precision),
        // wherever the scene lies in the world.
        let origin = if scene.camera.eye.is_finite() {
            scene.camera.eye
        } else {
            DVec3::ZERO
        };
        let mut floats: Vec<f32> = Vec::new();
        let mut ranges = Vec::new();
        let mut colors = Vec::new();
        let mut bounds = Vec::new();
        for (mesh, color) in &meshes {
            let first = (floats.len() / 6) as u32;
            for t in &mesh.triangles {
                let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
                let n = (b - a).cross(c - a).normalize_or_zero();
                for p in [a - origin, b - origin, c - origin] {
                    floats.extend([p.x as f32, p.y as f32, p.z as f32]);
                    floats.extend([n.x as f32, n.y as f32, n.z as f32]);
                }
            }
            ranges.push((first, (floats.len() / 6) as u32 - first));
            colors.push(*color);
            let mut lo = DVec3::splat(f64::INFINITY);
            let mut hi = DVec3::splat(f64::NEG_INFINITY);
            for p in &mesh.positions {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
            bounds.push(Aabb { min: lo, max: hi });
        }
        let quad_first = (floats.len() / 6) as u32;
        for (x, y) in [
            (-1.0f32, -1.0f32),
            (1.0, -1.0),
            (1.0, 1.0),
            (-1.0, -1.0),
            (1.0, 1.0),
            (-1.0, 1.0),
        ] {
            floats.extend([x, y, 0.0, 0.0, 0.0, 1.0]);
        }
        let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_ne_bytes()).collect();
        let mut vertices = Buffer::new(
            &self.shared,
            "vertices",
            bytes.len() as u64,
            vk::BufferUsageFlags::VERTEX_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        vertices.mapped_mut()?.copy_from_slice(&bytes);

        let camera = scene.camera;
        let CameraState {
            view,
            proj,
            mvp,
            view_vec,
        } = self.camera_state(&camera, origin);
        self.scene = Some(SceneData {
            vertices,
            ranges,
            colors,
            bounds,
            background: scene.render.background,
            camera,
            origin,
            view,
            proj,
            mvp,
            view_vec,
            quad_first,
        });
        Ok(())
    }

    /// Moves the camera of the uploaded scene without uploading its meshes again
    /// (an interactive viewer orbiting). Vertices stay relative to the eye at
    /// upload, so the images equal a fresh upload's up to f32 rounding.
    pub fn set_camera(&mut self, camera: &crate::scene::Camera) -> Result<(), VkError> {
        let origin = self
            .scene
            .as_ref()
            .ok_or_else(|| VkError::Plan("set_camera before upload".into()))?
            .origin;
        let st = self.camera_state(camera, origin);
        let scene = self.scene.as_mut().expect("checked above");
        scene.camera = *camera;
        scene.view = st.view;
        scene.proj = st.proj;
        scene.mvp = st.mvp;
        scene.view_vec = st.view_vec;
        Ok(())
    }

    /// What the shaders and scissors derive from the camera. The matrix product
    /// is formed in f64 and rounded once.
    fn camera_state(&self, camera: &crate::scene::Camera, origin: DVec3) -> CameraState {
        let aspect = self.desc.width as f64 / self.desc.height as f64;
        let view = camera.view();
        let proj = camera.proj(aspect, self.convention());
        let mvp = (proj * view * DMat4::from_translation(origin))
            .to_cols_array()
            .map(|v| v as f32);
        // Shading sees vertices relative to `origin`, so the eye is too.
        let eye = camera.eye - origin;
        let view_vec = match camera.projection {
            Projection::Perspective { .. } => [eye.x as f32, eye.y as f32, eye.z as f32, 1.0],
            Projection::Orthographic { .. } => {
                let f = camera.forward();
                [f.x as f32, f.y as f32, f.z as f32, 0.0]
            }
        };
        CameraState {
            view,
            proj,
            mvp,
            view_vec,
        }
    }

    fn ensure_resources(&mut self, plan: &Plan) -> Result<(), VkError> {
        let n_ds = plan.depth_stencils.max(1) as usize;
        let n_tex = plan.textures as usize;
        if let Some(r) = &self.resources {
            if r.ds.len() >= n_ds && r.tex.len() >= n_tex {
                return Ok(());
            }
        }
        self.resources = None;
        let (w, h) = (self.desc.width, self.desc.height);
        let sh = &self.shared;
        let color_usage = vk::ImageUsageFlags::COLOR_ATTACHMENT
            | vk::ImageUsageFlags::TRANSFER_SRC
            | vk::ImageUsageFlags::TRANSFER_DST;
        let color = Image::new(
            sh,
            "color",
            ImageDesc::new_2d(vk::Format::R8G8B8A8_UNORM, [w, h]).usage(color_usage),
        )?;
        let prim = Image::new(
            sh,
            "prim",
            ImageDesc::new_2d(vk::Format::R32_UINT, [w, h]).usage(color_usage),
        )?;
        let mut ds = Vec::new();
        for i in 0..n_ds {
            ds.push(Image::new(
                sh,
                &format!("ds{i}"),
                ImageDesc::new_2d(self.desc.depth_format.vk(), [w, h]).usage(
                    vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
                        | vk::ImageUsageFlags::SAMPLED
                        | vk::ImageUsageFlags::TRANSFER_SRC
                        | vk::ImageUsageFlags::TRANSFER_DST,
                ),
            )?);
        }
        let mut tex = Vec::new();
        for i in 0..n_tex {
            tex.push(Image::new(
                sh,
                &format!("tex{i}"),
                ImageDesc::new_2d(vk::Format::R32_SFLOAT, [w, h])
                    .usage(color_usage | vk::ImageUsageFlags::SAMPLED),
            )?);
        }
        let n_sets = (n_ds + n_tex) as u32;
        let sizes = [
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::SAMPLED_IMAGE,
                descriptor_count: n_sets,
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::SAMPLER,
                descriptor_count: n_sets,
            },
        ];
        let pci = vk::DescriptorPoolCreateInfo::default()
            .max_sets(n_sets)
            .pool_sizes(&sizes);
        // SAFETY: valid create info.
        let pool = unsafe { sh.device.create_descriptor_pool(&pci, None) }
            .check("vkCreateDescriptorPool")?;
        let mut res = Resources {
            shared: sh.clone(),
            pool,
            tex_sets: Vec::new(),
            ds_sets: Vec::new(),
            color,
            prim,
            ds,
            tex,
        };
        let layouts = vec![self.pipelines.set_layout; n_sets as usize];
        let ai = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(pool)
            .set_layouts(&layouts);
        // SAFETY: the pool has room for exactly these sets.
        let sets =
            unsafe { sh.device.allocate_descriptor_sets(&ai) }.check("vkAllocateDescriptorSets")?;
        let views: Vec<vk::ImageView> = res
            .ds
            .iter()
            .map(|i| i.depth_view)
            .chain(res.tex.iter().map(|i| i.view))
            .collect();
        for (set, view) in sets.iter().zip(&views) {
            let image_info = [vk::DescriptorImageInfo {
                sampler: vk::Sampler::null(),
                image_view: *view,
                image_layout: vk::ImageLayout::GENERAL,
            }];
            let sampler_info = [vk::DescriptorImageInfo {
                sampler: self.pipelines.sampler,
                image_view: vk::ImageView::null(),
                image_layout: vk::ImageLayout::UNDEFINED,
            }];
            let writes = [
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(0)
                    .descriptor_type(vk::DescriptorType::SAMPLED_IMAGE)
                    .image_info(&image_info),
                vk::WriteDescriptorSet::default()
                    .dst_set(*set)
                    .dst_binding(1)
                    .descriptor_type(vk::DescriptorType::SAMPLER)
                    .image_info(&sampler_info),
            ];
            // SAFETY: sets, views and sampler are live; no set is in use.
            unsafe { sh.device.update_descriptor_sets(&writes, &[]) };
        }
        res.ds_sets = sets[..n_ds].to_vec();
        res.tex_sets = sets[n_ds..].to_vec();
        self.resources = Some(res);
        self.fresh_images = true;
        Ok(())
    }

    /// Executes `plan` on the uploaded scene and reads the images back.
    /// Ends `cmd`, submits it and waits for it: every submission of the executor
    /// is synchronous, so the next one may read what this one wrote.
    fn submit_and_wait(&self, cmd: vk::CommandBuffer) -> Result<(), VkError> {
        let device = &self.shared.device;
        // SAFETY: recording state, no open rendering block or query.
        unsafe { device.end_command_buffer(cmd) }.check("vkEndCommandBuffer")?;
        let cmds = [cmd];
        let si = [vk::SubmitInfo::default().command_buffers(&cmds)];
        {
            let _queue = self.shared.queue_lock.lock();
            // SAFETY: the command buffer is executable; the fence is unsignaled; the
            // lock serializes our submissions (an embedding host synchronizes its own,
            // see Context::from_raw).
            unsafe { device.queue_submit(self.shared.queue, &si, self.fence) }
                .check("vkQueueSubmit")?;
        }
        // SAFETY: the fence was just submitted.
        unsafe { device.wait_for_fences(&[self.fence], true, u64::MAX) }
            .check("vkWaitForFences")?;
        // SAFETY: the fence is signaled and not in use.
        unsafe { device.reset_fences(&[self.fence]) }.check("vkResetFences")?;
        Ok(())
    }

    pub fn execute(&mut self, plan: &Plan) -> Result<Frame, VkError> {
        let start = Instant::now();
        if self.scene.is_none() {
            return Err(VkError::Plan("execute before upload: no scene".into()));
        }
        self.validate(plan)?;
        self.ensure_resources(plan)?;
        let mut run = Run {
            stats: ExecStats::default(),
            pass: String::new(),
        };
        let mut pending: Vec<&Step> = Vec::new();
        for step in &plan.steps {
            if let Step::Loop(l) = step {
                if !pending.is_empty() {
                    self.submit(&pending, &mut run)?;
                    pending.clear();
                }
                let head: Vec<&Step> = l.head.iter().collect();
                let tail: Vec<&Step> = l.tail.iter().collect();
                let mut iterations = 0;
                while iterations < l.max_iterations {
                    iterations += 1;
                    let samples = self.submit(&head, &mut run)?;
                    if samples == 0 || iterations >= l.max_iterations {
                        break;
                    }
                    self.submit(&tail, &mut run)?;
                }
                run.stats.loop_iterations.push(iterations);
            } else {
                pending.push(step);
            }
        }
        if !pending.is_empty() {
            self.submit(&pending, &mut run)?;
        }
        let images = self.read_back(plan.output_ds)?;
        run.stats.cpu_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(Frame {
            images,
            stats: run.stats,
        })
    }

    fn validate(&self, plan: &Plan) -> Result<(), VkError> {
        let n_mesh = self.scene.as_ref().map(|s| s.ranges.len()).unwrap_or(0) as u32;
        let n_ds = plan.depth_stencils.max(1);
        let check_tex = |t: Tex| {
            if t >= plan.textures {
                Err(VkError::Plan(format!(
                    "texture {t} of {} used",
                    plan.textures
                )))
            } else {
                Ok(())
            }
        };
        let check_ds = |d: u8| {
            if d >= n_ds {
                Err(VkError::Plan(format!("depth-stencil {d} of {n_ds} used")))
            } else {
                Ok(())
            }
        };
        let check_mesh = |m: u32| {
            if m >= n_mesh {
                Err(VkError::Plan(format!("mesh {m} of {n_mesh} used")))
            } else {
                Ok(())
            }
        };
        check_ds(plan.output_ds)?;
        fn walk(
            steps: &[Step],
            nested: bool,
            f: &mut dyn FnMut(&Step) -> Result<(), VkError>,
        ) -> Result<(), VkError> {
            for s in steps {
                if let Step::Loop(l) = s {
                    if nested {
                        return Err(VkError::Plan("nested loops are not supported".into()));
                    }
                    walk(&l.head, true, f)?;
                    walk(&l.tail, true, f)?;
                } else {
                    f(s)?;
                }
            }
            Ok(())
        }
        walk(&plan.steps, false, &mut |s| {
            match s {
                Step::Draw(d) => {
                    check_ds(d.ds)?;
                    match &d.geometry {
                        Geometry::Mesh(m) => check_mesh(*m)?,
                        Geometry::Meshes(ms) => ms.iter().try_for_each(|m| check_mesh(*m))?,
                        Geometry::FullScreen { .. } => {}
                    }
                    if let Scissor::BoundsOf(ms) = &d.scissor {
                        ms.iter().try_for_each(|m| check_mesh(*m))?;
                    }
                    match d.fragment {
                        Fragment::Peel { prev, out, .. } => {
                            check_tex(prev)?;
                            check_tex(out)?;
                            if prev == out {
                                return Err(VkError::Plan(
                                    "Peel reads and writes the same texture".into(),
                                ));
                            }
                        }
                        Fragment::WriteDepth { out } => check_tex(out)?,
                        Fragment::DepthFromTexture { src } => check_tex(src)?,
                        Fragment::PeelTolerant {
                            prev: a, out: b, ..
                        }
                        | Fragment::CopyTexel { src: a, out: b } => {
                            check_tex(a)?;
                            check_tex(b)?;
                            if a == b {
                                return Err(VkError::Plan(
                                    "a fragment reads and writes the same texture".into(),
                                ));
                            }
                        }
                        Fragment::ShadeNearDepth { tex, .. }
                        | Fragment::NearerThan { tex, .. }
                        | Fragment::ShadeAtDepth { tex } => check_tex(tex)?,
                        _ => {}
                    }
                }
                Step::Clear(Clear::DepthStencil { ds, .. }) => check_ds(*ds)?,
                Step::Clear(Clear::Texture { tex, .. }) => check_tex(*tex)?,
                Step::CopyTexture { src, dst } => {
                    check_tex(*src)?;
                    check_tex(*dst)?;
                }
                Step::CopyDepthToTexture { ds, dst } => {
                    check_ds(*ds)?;
                    check_tex(*dst)?;
                }
                _ => {}
            }
            Ok(())
        })
    }

    /// Records `steps` into one command buffer, submits and waits. Returns the
    /// samples passed by its counted draws.
    fn submit(&mut self, steps: &[&Step], run: &mut Run) -> Result<u64, VkError> {
        let (n_occ, n_ts) = count_queries(steps);
        self.ensure_queries(n_occ.max(1), n_ts)?;
        let device = self.shared.device.clone();
        let cmd = self.cmd;
        // SAFETY: the previous submission was waited on, so the buffer is not pending.
        unsafe { device.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()) }
            .check("vkResetCommandBuffer")?;
        let bi = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: the buffer is in the initial state.
        unsafe { device.begin_command_buffer(cmd, &bi) }.check("vkBeginCommandBuffer")?;
        // SAFETY: recording; outside rendering; ranges within the pools.
        unsafe { device.cmd_reset_query_pool(cmd, self.occlusion, 0, self.occlusion_cap) };
        // SAFETY: as above.
        unsafe { device.cmd_reset_query_pool(cmd, self.timestamps, 0, self.timestamps_cap) };
        if self.fresh_images {
            self.init_layouts(cmd);
            self.fresh_images = false;
        }
        full_memory_barrier(&device, cmd);
        let mut rec = Rec {
            cmd,
            block: None,
            bound: None,
            occlusion_used: 0,
            marks: Vec::new(),
        };
        self.timestamp(&mut rec, run.pass.clone());
        for step in steps {
            self.record(&mut rec, run, step)?;
        }
        self.end_block(&mut rec);
        self.timestamp(&mut rec, String::new());
        self.submit_and_wait(cmd)?;

        let mut samples = 0u64;
        if rec.occlusion_used > 0 {
            samples = query_results(&device, self.occlusion, rec.occlusion_used as usize)?
                .iter()
                .sum();
        }
        run.stats.samples_counted += samples;
        if self.shared.timestamp_valid_bits > 0 && rec.marks.len() >= 2 {
            let ts = query_results(&device, self.timestamps, rec.marks.len())?;
            let period = self.shared.limits.timestamp_period as f64;
            for i in 0..rec.marks.len() - 1 {
                let ms = ts[i + 1].saturating_sub(ts[i]) as f64 * period * 1e-6;
                run.stats.gpu_ms += ms;
                if let Some(p) = pass_entry(&mut run.stats, &rec.marks[i].1) {
                    p.gpu_ms += ms;
                }
            }
        }
        Ok(samples)
    }

    fn init_layouts(&self, cmd: vk::CommandBuffer) {
        let Some(res) = &self.resources else { return };
        let barriers: Vec<_> = [&res.color, &res.prim]
            .into_iter()
            .chain(res.ds.iter())
            .chain(res.tex.iter())
            .map(|img| {
                vk::ImageMemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::empty())
                    .dst_access_mask(vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE)
                    .old_layout(vk::ImageLayout::UNDEFINED)
                    .new_layout(vk::ImageLayout::GENERAL)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .image(img.raw)
                    .subresource_range(range(img.desc.aspect()))
            })
            .collect();
        // SAFETY: recording, outside rendering; every image is live and unused.
        unsafe {
            self.shared.device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                vk::PipelineStageFlags::ALL_COMMANDS,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &barriers,
            )
        };
    }

    fn timestamp(&self, rec: &mut Rec, pass: String) {
        if self.shared.timestamp_valid_bits == 0 {
            return;
        }
        let idx = rec.marks.len() as u32;
        // SAFETY: recording, outside rendering; the query was reset in this buffer.
        unsafe {
            self.shared.device.cmd_write_timestamp(
                rec.cmd,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                self.timestamps,
                idx,
            )
        };
        rec.marks.push((idx, pass));
    }

    fn end_block(&self, rec: &mut Rec) {
        if rec.block.take().is_some() {
            // SAFETY: a rendering block is open in this command buffer.
            unsafe { self.shared.device.cmd_end_rendering(rec.cmd) };
            full_memory_barrier(&self.shared.device, rec.cmd);
        }
    }

    fn res(&self) -> &Resources {
        self.resources
            .as_ref()
            .expect("resources exist during execute")
    }

    fn target_image(&self, t: Target) -> &Image {
        let r = self.res();
        match t {
            Target::Color => &r.color,
            Target::Prim => &r.prim,
            Target::Tex(i) => &r.tex[i as usize],
        }
    }

    fn begin_block(&self, rec: &mut Rec, key: BlockKey) {
        if rec.block.as_ref() == Some(&key) {
            return;
        }
        self.end_block(rec);
        let colors: Vec<_> = key
            .colors
            .iter()
            .map(|t| {
                vk::RenderingAttachmentInfo::default()
                    .image_view(self.target_image(*t).view)
                    .image_layout(vk::ImageLayout::GENERAL)
                    .load_op(vk::AttachmentLoadOp::LOAD)
                    .store_op(vk::AttachmentStoreOp::STORE)
            })
            .collect();
        let ds_att = key.ds.map(|d| {
            vk::RenderingAttachmentInfo::default()
                .image_view(self.res().ds[d as usize].view)
                .image_layout(vk::ImageLayout::GENERAL)
                .load_op(vk::AttachmentLoadOp::LOAD)
                .store_op(vk::AttachmentStoreOp::STORE)
        });
        let mut ri = vk::RenderingInfo::default()
            .render_area(vk::Rect2D {
                offset: vk::Offset2D { x: 0, y: 0 },
                extent: vk::Extent2D {
                    width: self.desc.width,
                    height: self.desc.height,
                },
            })
            .layer_count(1)
            .color_attachments(&colors);
        if let Some(a) = ds_att.as_ref() {
            ri = ri.depth_attachment(a).stencil_attachment(a);
        }
        // SAFETY: recording outside rendering; all views are live and in GENERAL.
        unsafe { self.shared.device.cmd_begin_rendering(rec.cmd, &ri) };
        rec.block = Some(key);
        rec.bound = None;
    }

    fn target_format(t: Target) -> vk::Format {
        match t {
            Target::Color => vk::Format::R8G8B8A8_UNORM,
            Target::Prim => vk::Format::R32_UINT,
            Target::Tex(_) => vk::Format::R32_SFLOAT,
        }
    }

    fn record(&mut self, rec: &mut Rec, run: &mut Run, step: &Step) -> Result<(), VkError> {
        let device = self.shared.device.clone();
        let cmd = rec.cmd;
        let reversed = self.desc.reversed_z;
        match step {
            Step::Pass(name) => {
                self.end_block(rec);
                run.pass = name.clone();
                pass_entry(&mut run.stats, name);
                self.timestamp(rec, name.clone());
            }
            Step::Clear(clear) => {
                self.end_block(rec);
                let res = self.res();
                match *clear {
                    Clear::DepthStencil { ds, depth, stencil } => {
                        let img = &res.ds[ds as usize];
                        let v = vk::ClearDepthStencilValue {
                            depth: conv::depth_value(depth, reversed),
                            stencil: stencil as u32,
                        };
                        // SAFETY: outside rendering; the image allows transfer dst.
                        unsafe {
                            device.cmd_clear_depth_stencil_image(
                                cmd,
                                img.raw,
                                vk::ImageLayout::GENERAL,
                                &v,
                                &[range(img.desc.aspect())],
                            )
                        };
                    }
                    Clear::Texture { tex, depth } => {
                        let img = &res.tex[tex as usize];
                        let v = vk::ClearColorValue {
                            float32: [conv::depth_value(depth, reversed), 0.0, 0.0, 0.0],
                        };
                        // SAFETY: as above.
                        unsafe {
                            device.cmd_clear_color_image(
                                cmd,
                                img.raw,
                                vk::ImageLayout::GENERAL,
                                &v,
                                &[range(vk::ImageAspectFlags::COLOR)],
                            )
                        };
                    }
                    Clear::Color => {
                        let bg = self
                            .scene
                            .as_ref()
                            .map(|s| s.background)
                            .unwrap_or_default();
                        let v = vk::ClearColorValue {
                            float32: [
                                bg[0] as f32 / 255.0,
                                bg[1] as f32 / 255.0,
                                bg[2] as f32 / 255.0,
                                1.0,
                            ],
                        };
                        // SAFETY: as above.
                        unsafe {
                            device.cmd_clear_color_image(
                                cmd,
                                res.color.raw,
                                vk::ImageLayout::GENERAL,
                                &v,
                                &[range(vk::ImageAspectFlags::COLOR)],
                            )
                        };
                        let z = vk::ClearColorValue { uint32: [0; 4] };
                        // SAFETY: as above.
                        unsafe {
                            device.cmd_clear_color_image(
                                cmd,
                                res.prim.raw,
                                vk::ImageLayout::GENERAL,
                                &z,
                                &[range(vk::ImageAspectFlags::COLOR)],
                            )
                        };
                    }
                }
                full_memory_barrier(&device, cmd);
            }
            Step::CopyTexture { src, dst } => {
                self.end_block(rec);
                let res = self.res();
                let layers = vk::ImageSubresourceLayers {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    mip_level: 0,
                    base_array_layer: 0,
                    layer_count: 1,
                };
                let region = vk::ImageCopy {
                    src_subresource: layers,
                    src_offset: vk::Offset3D::default(),
                    dst_subresource: layers,
                    dst_offset: vk::Offset3D::default(),
                    extent: vk::Extent3D {
                        width: self.desc.width,
                        height: self.desc.height,
                        depth: 1,
                    },
                };
                let (s_img, d_img) = (&res.tex[*src as usize], &res.tex[*dst as usize]);
                if src == dst {
                    return Ok(());
                }
                transition(
                    &device,
                    cmd,
                    &[(s_img, GENERAL, SRC), (d_img, GENERAL, DST)],
                );
                // SAFETY: outside rendering; both images allow transfer, same format,
                // in the layouts given.
                unsafe { device.cmd_copy_image(cmd, s_img.raw, SRC, d_img.raw, DST, &[region]) };
                transition(
                    &device,
                    cmd,
                    &[(s_img, SRC, GENERAL), (d_img, DST, GENERAL)],
                );
            }
            Step::CopyDepthToTexture { ds, dst } => {
                let key = BlockKey {
                    colors: vec![Target::Tex(*dst)],
                    ds: None,
                };
                let set = self.res().ds_sets[*ds as usize];
                self.fullscreen_internal(rec, run, key, FragmentKind::CopyDepth, set)?;
            }
            Step::Draw(draw) => self.draw(rec, run, draw)?,
            Step::Loop(_) => {
                return Err(VkError::Plan("nested loops are not supported".into()));
            }
        }
        Ok(())
    }

    fn pipeline_for(
        &mut self,
        key: &BlockKey,
        kind: FragmentKind,
    ) -> Result<vk::Pipeline, VkError> {
        let desc = PipelineDesc {
            fragment: kind,
            color_formats: key.colors.iter().map(|t| Self::target_format(*t)).collect(),
            depth_stencil_format: key.ds.map(|_| self.desc.depth_format.vk()),
        };
        self.pipelines.get(&desc)
    }

    fn bind(&self, rec: &mut Rec, pipeline: vk::Pipeline, set: Option<vk::DescriptorSet>) {
        let device = &self.shared.device;
        if rec.bound != Some(pipeline) {
            // SAFETY: recording inside a block whose formats match the pipeline.
            unsafe { device.cmd_bind_pipeline(rec.cmd, vk::PipelineBindPoint::GRAPHICS, pipeline) };
            rec.bound = Some(pipeline);
            let scene = self.scene.as_ref().expect("scene uploaded");
            // SAFETY: the vertex buffer is live until the submission completes.
            unsafe { device.cmd_bind_vertex_buffers(rec.cmd, 0, &[scene.vertices.raw], &[0]) };
        }
        if let Some(set) = set {
            // SAFETY: the set matches the pipeline layout's set 0.
            unsafe {
                device.cmd_bind_descriptor_sets(
                    rec.cmd,
                    vk::PipelineBindPoint::GRAPHICS,
                    self.pipelines.layout,
                    0,
                    &[set],
                    &[],
                )
            };
        }
    }

    /// Sets every dynamic state of the pipelines (all of it, every draw).
    fn set_state(&self, rec: &Rec, draw: Option<&Draw>, scissor: Rect) {
        let d = &self.shared.device;
        let cmd = rec.cmd;
        let reversed = self.desc.reversed_z;
        let vp = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: self.desc.width as f32,
            height: self.desc.height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        let sc = vk::Rect2D {
            offset: vk::Offset2D {
                x: scissor.x0 as i32,
                y: scissor.y0 as i32,
            },
            extent: vk::Extent2D {
                width: scissor.width(),
                height: scissor.height(),
            },
        };
        let cull = draw
            .map(|d| conv::cull_mode(d.cull))
            .unwrap_or(vk::CullModeFlags::NONE);
        let (depth_test, depth_write, depth_cmp) = match draw {
            Some(dr) => (
                true,
                dr.depth.write,
                conv::compare_op(dr.depth.compare, reversed),
            ),
            None => (false, false, vk::CompareOp::ALWAYS),
        };
        let stencil = draw.and_then(|d| d.stencil);
        let keep = conv::StencilFaceOps {
            fail: vk::StencilOp::KEEP,
            pass: vk::StencilOp::KEEP,
            depth_fail: vk::StencilOp::KEEP,
            compare: vk::CompareOp::ALWAYS,
        };
        let (front, back, cmask, wmask, reference) = match &stencil {
            Some(s) => (
                conv::stencil_face(&s.front),
                conv::stencil_face(&s.back),
                s.compare_mask as u32,
                s.write_mask as u32,
                s.reference as u32,
            ),
            None => (keep, keep, 0, 0, 0),
        };
        // SAFETY (all calls below): recording inside a rendering block with a bound
        // pipeline that declares these states dynamic; Vulkan 1.3 core commands.
        unsafe { d.cmd_set_viewport(cmd, 0, &[vp]) };
        // SAFETY: see above.
        unsafe { d.cmd_set_scissor(cmd, 0, &[sc]) };
        // SAFETY: see above.
        unsafe { d.cmd_set_cull_mode(cmd, cull) };
        // SAFETY: see above.
        unsafe { d.cmd_set_front_face(cmd, conv::FRONT_FACE) };
        // SAFETY: see above.
        unsafe { d.cmd_set_depth_test_enable(cmd, depth_test) };
        // SAFETY: see above.
        unsafe { d.cmd_set_depth_write_enable(cmd, depth_write) };
        // SAFETY: see above.
        unsafe { d.cmd_set_depth_compare_op(cmd, depth_cmp) };
        // SAFETY: see above.
        unsafe { d.cmd_set_stencil_test_enable(cmd, stencil.is_some()) };
        for (face, ops) in [
            (vk::StencilFaceFlags::FRONT, front),
            (vk::StencilFaceFlags::BACK, back),
        ] {
            // SAFETY: see above.
            unsafe {
                d.cmd_set_stencil_op(cmd, face, ops.fail, ops.pass, ops.depth_fail, ops.compare)
            };
        }
        let both = vk::StencilFaceFlags::FRONT_AND_BACK;
        // SAFETY: see above.
        unsafe { d.cmd_set_stencil_compare_mask(cmd, both, cmask) };
        // SAFETY: see above.
        unsafe { d.cmd_set_stencil_write_mask(cmd, both, wmask) };
        // SAFETY: see above.
        unsafe { d.cmd_set_stencil_reference(cmd, both, reference) };
    }

    fn push(&self, rec: &Rec, pc: &PushConstants) {
        // SAFETY: recording; the range matches the layout's single push range.
        unsafe {
            self.shared.device.cmd_push_constants(
                rec.cmd,
                self.pipelines.layout,
                vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
                0,
                &pc.bytes(),
            )
        };
    }

    fn fullscreen_matrix(depth: f32) -> [f32; 16] {
        let mut m = glam::Mat4::IDENTITY.to_cols_array();
        m[10] = 0.0;
        m[14] = depth;
        m
    }

    /// A full-screen draw that is not a plan `Draw` (depth copies).
    fn fullscreen_internal(
        &mut self,
        rec: &mut Rec,
        run: &mut Run,
        key: BlockKey,
        kind: FragmentKind,
        set: vk::DescriptorSet,
    ) -> Result<(), VkError> {
        let pipeline = self.pipeline_for(&key, kind)?;
        self.begin_block(rec, key);
        self.bind(rec, pipeline, Some(set));
        let full = Rect::full(self.desc.width, self.desc.height);
        self.set_state(rec, None, full);
        let scene = self.scene.as_ref().expect("scene uploaded");
        let pc = PushConstants {
            mvp: Self::fullscreen_matrix(0.0),
            flags: self.flags(),
            ..Default::default()
        };
        self.push(rec, &pc);
        // SAFETY: inside a block with a bound pipeline and vertex buffer.
        unsafe {
            self.shared
                .device
                .cmd_draw(rec.cmd, 6, 1, scene.quad_first, 0)
        };
        run.stats.fullscreen_passes += 1;
        run.stats.fullscreen_pixels += full.area();
        Ok(())
    }

    fn draw(&mut self, rec: &mut Rec, run: &mut Run, draw: &Draw) -> Result<(), VkError> {
        let (kind, colors, set) = {
            let res = self.res();
            match draw.fragment {
                Fragment::None => (FragmentKind::None, vec![], None),
                Fragment::Shade => (FragmentKind::Shade, vec![Target::Color, Target::Prim], None),
                Fragment::Paint { .. } => {
                    (FragmentKind::Paint, vec![Target::Color, Target::Prim], None)
                }
                Fragment::Background => (
                    FragmentKind::Background,
                    vec![Target::Color, Target::Prim],
                    None,
                ),
                Fragment::Peel { prev, out, shade } => {
                    let set = Some(res.tex_sets[prev as usize]);
                    if shade {
                        (
                            FragmentKind::PeelShade,
                            vec![Target::Color, Target::Prim, Target::Tex(out)],
                            set,
                        )
                    } else {
                        (FragmentKind::Peel, vec![Target::Tex(out)], set)
                    }
                }
                Fragment::WriteDepth { out } => {
                    (FragmentKind::WriteDepth, vec![Target::Tex(out)], None)
                }
                Fragment::ShadeAtDepth { tex } => (
                    FragmentKind::ShadeAtDepth,
                    vec![Target::Color, Target::Prim],
                    Some(res.tex_sets[tex as usize]),
                ),
                Fragment::DepthFromTexture { src } => (
                    FragmentKind::DepthFromTexture,
                    vec![],
                    Some(res.tex_sets[src as usize]),
                ),
                Fragment::PeelTolerant { prev, out, .. } => (
                    FragmentKind::PeelTolerant,
                    vec![Target::Tex(out)],
                    Some(res.tex_sets[prev as usize]),
                ),
                // The texel copy is the depth-copy shader reading a depth texture.
                Fragment::CopyTexel { src, out } => (
                    FragmentKind::CopyDepth,
                    vec![Target::Tex(out)],
                    Some(res.tex_sets[src as usize]),
                ),
                Fragment::NearerThan { tex, .. } => (
                    FragmentKind::NearerThan,
                    vec![],
                    Some(res.tex_sets[tex as usize]),
                ),
                Fragment::ShadeNearDepth { tex, .. } => (
                    FragmentKind::ShadeNearDepth,
                    vec![Target::Color, Target::Prim],
                    Some(res.tex_sets[tex as usize]),
                ),
            }
        };
        let key = BlockKey {
            colors,
            ds: Some(draw.ds),
        };
        let pipeline = self.pipeline_for(&key, kind)?;
        self.begin_block(rec, key);
        self.bind(rec, pipeline, set);
        let scene = self.scene.as_ref().expect("scene uploaded");
        let (w, h) = (self.desc.width, self.desc.height);
        let scissor = match &draw.scissor {
            Scissor::Full => Rect::full(w, h),
            Scissor::BoundsOf(ms) => {
                let boxes: Vec<Aabb> = ms.iter().map(|m| scene.bounds[*m as usize]).collect();
                bounds_rect(scene.view, scene.proj, scene.camera.near, &boxes, w, h)
            }
        };
        self.set_state(rec, Some(draw), scissor);
        let flags = self.flags();
        let rgb = |c: [u8; 3]| {
            [
                c[0] as f32 / 255.0,
                c[1] as f32 / 255.0,
                c[2] as f32 / 255.0,
                1.0,
            ]
        };
        let device = &self.shared.device;
        let query = if draw.count_samples {
            let q = rec.occlusion_used;
            rec.occlusion_used += 1;
            // SAFETY: inside a block; the query was reset in this buffer and is not active.
            unsafe {
                device.cmd_begin_query(rec.cmd, self.occlusion, q, vk::QueryControlFlags::empty())
            };
            Some(q)
        } else {
            None
        };
        run.stats.draws += 1;
        if let Some(p) = pass_entry(&mut run.stats, &run.pass) {
            p.draws += 1;
        }
        match &draw.geometry {
            Geometry::FullScreen { depth } => {
                let color = match draw.fragment {
                    Fragment::Paint { rgb: c } => rgb(c),
                    _ => rgb(scene.background),
                };
                let pc = PushConstants {
                    mvp: Self::fullscreen_matrix(conv::depth_value(*depth, self.desc.reversed_z)),
                    view: scene.view_vec,
                    color,
                    prim: 0,
                    flags,
                    // Full-screen rectangles stay unsnapped.
                    snap: [0.0; 2],
                };
                self.push(rec, &pc);
                // SAFETY: inside a block with a bound pipeline and vertex buffer.
                unsafe { device.cmd_draw(rec.cmd, 6, 1, scene.quad_first, 0) };
                run.stats.fullscreen_passes += 1;
                run.stats.fullscreen_pixels += scissor.area();
            }
            Geometry::Mesh(_) | Geometry::Meshes(_) => {
                let ids: &[u32] = match &draw.geometry {
                    Geometry::Mesh(m) => std::slice::from_ref(m),
                    Geometry::Meshes(ms) => ms,
                    Geometry::FullScreen { .. } => &[],
                };
                run.stats.mesh_draws += 1;
                for &m in ids {
                    let (first, count) = scene.ranges[m as usize];
                    let color = match draw.fragment {
                        Fragment::Paint { rgb: c } => rgb(c),
                        Fragment::Background => rgb(scene.background),
                        Fragment::PeelTolerant { eps, .. } => [eps, 0.0, 0.0, 0.0],
                        // The tolerance travels in the colour's alpha.
                        Fragment::ShadeNearDepth { eps, .. } | Fragment::NearerThan { eps, .. } => {
                            let [r, g, b, _] = rgb(scene.colors[m as usize]);
                            [r, g, b, eps]
                        }
                        _ => rgb(scene.colors[m as usize]),
                    };
                    let pc = PushConstants {
                        mvp: scene.mvp,
                        view: scene.view_vec,
                        color,
                        prim: m + 1,
                        flags,
                        snap: self
                            .rounding
                            .map(|r| r.ndc_step(self.desc.width, self.desc.height))
                            .unwrap_or_default(),
                    };
                    self.push(rec, &pc);
                    if count > 0 {
                        // SAFETY: inside a block; the range lies in the vertex buffer.
                        unsafe { device.cmd_draw(rec.cmd, count, 1, first, 0) };
                    }
                    run.stats.triangles += count as u64 / 3;
                }
            }
        }
        if let Some(q) = query {
            // SAFETY: the query was begun in this block.
            unsafe { device.cmd_end_query(rec.cmd, self.occlusion, q) };
        }
        Ok(())
    }

    fn read_back(&mut self, output_ds: u8) -> Result<Images, VkError> {
        let (w, h) = (self.desc.width, self.desc.height);
        let plane = w as u64 * h as u64 * 4;
        if self.readback.as_ref().map(|b| b.size) != Some(plane * 3) {
            self.readback = None;
            self.readback = Some(Buffer::new(
                &self.shared,
                "readback",
                plane * 3,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?);
        }
        let device = self.shared.device.clone();
        let cmd = self.cmd;
        let buffer = self.readback.as_ref().map(|b| b.raw).unwrap_or_default();
        // SAFETY: the previous submission was waited on.
        unsafe { device.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty()) }
            .check("vkResetCommandBuffer")?;
        let bi = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: the buffer is in the initial state.
        unsafe { device.begin_command_buffer(cmd, &bi) }.check("vkBeginCommandBuffer")?;
        if self.fresh_images {
            self.init_layouts(cmd);
            self.fresh_images = false;
        }
        full_memory_barrier(&device, cmd);
        let res = self.res();
        let copies = [
            (&res.color, vk::ImageAspectFlags::COLOR, 0),
            (&res.prim, vk::ImageAspectFlags::COLOR, plane),
            (
                &res.ds[output_ds as usize],
                vk::ImageAspectFlags::DEPTH,
                plane * 2,
            ),
        ];
        let imgs: Vec<_> = copies.iter().map(|c| (c.0, GENERAL, SRC)).collect();
        transition(&device, cmd, &imgs);
        for (img, aspect, offset) in copies {
            let region = vk::BufferImageCopy {
                buffer_offset: offset,
                buffer_row_length: 0,
                buffer_image_height: 0,
                image_subresource: vk::ImageSubresourceLayers {
                    aspect_mask: aspect,
                    mip_level: 0,
                    base_array_layer: 0,
                    layer_count: 1,
                },
                image_offset: vk::Offset3D::default(),
                image_extent: vk::Extent3D {
                    width: w,
                    height: h,
                    depth: 1,
                },
            };
            // SAFETY: outside rendering; the image allows transfer src; the region fits.
            unsafe { device.cmd_copy_image_to_buffer(cmd, img.raw, SRC, buffer, &[region]) };
        }
        let back: Vec<_> = copies.iter().map(|c| (c.0, SRC, GENERAL)).collect();
        transition(&device, cmd, &back);
        memory_barrier(
            &device,
            cmd,
            vk::AccessFlags::TRANSFER_WRITE,
            vk::AccessFlags::HOST_READ,
            vk::PipelineStageFlags::HOST,
        );
        self.submit_and_wait(cmd)?;

        let bytes = self
            .readback
            .as_ref()
            .map(|b| b.mapped())
            .transpose()?
            .unwrap_or(&[]);
        let scene = self.scene.as_ref().expect("scene uploaded");
        let plane = plane as usize;
        Ok(decode(
            Raw {
                width: w,
                height: h,
                color: &bytes[..plane],
                prim: &bytes[plane..2 * plane],
                depth: &bytes[2 * plane..3 * plane],
            },
            self.desc.depth_format,
            &scene.camera,
            self.convention(),
            scene.background,
        ))
    }
}

/// The per-pass entry of `name`; none for work before the first `Step::Pass`.
fn pass_entry<'a>(stats: &'a mut ExecStats, name: &str) -> Option<&'a mut PassStats> {
    if name.is_empty() {
        return None;
    }
    let i = match stats.per_pass.iter().position(|p| p.name == name) {
        Some(i) => i,
        None => {
            stats.per_pass.push(PassStats {
                name: name.to_string(),
                ..Default::default()
            });
            stats.per_pass.len() - 1
        }
    };
    Some(&mut stats.per_pass[i])
}

impl Drop for Executor {
    fn drop(&mut self) {
        let d = &self.shared.device;
        // Every submission is waited on before `submit`/`read_back` return, so the
        // GPU uses none of our objects now (no device-wide wait: an embedding host may
        // be using its queues).
        self.readback = None;
        self.resources = None;
        self.scene = None;
        // SAFETY: no submission is pending; each handle is destroyed once; null is ignored.
        unsafe { d.destroy_query_pool(self.timestamps, None) };
        // SAFETY: as above.
        unsafe { d.destroy_query_pool(self.occlusion, None) };
        // SAFETY: as above.
        unsafe { d.destroy_fence(self.fence, None) };
        // SAFETY: as above; destroying the pool frees its command buffer.
        unsafe { d.destroy_command_pool(self.command_pool, None) };
        // `pipelines` drops after this body, then the Arc<Shared>.
    }
}

/// Replaces `pool` by one of at least `need` queries of type `ty` when it is
/// smaller (capacities grow in powers of two, so plans of one size reuse it).
fn grow_pool(
    device: &ash::Device,
    pool: &mut vk::QueryPool,
    cap: &mut u32,
    ty: vk::QueryType,
    need: u32,
) -> Result<(), VkError> {
    if need <= *cap {
        return Ok(());
    }
    let new_cap = need.next_power_of_two();
    // SAFETY: the pool is idle (the executor waits after every submission); null is ignored.
    unsafe { device.destroy_query_pool(*pool, None) };
    *pool = vk::QueryPool::null();
    *cap = 0;
    let ci = vk::QueryPoolCreateInfo::default()
        .query_type(ty)
        .query_count(new_cap);
    // SAFETY: valid create info.
    *pool = unsafe { device.create_query_pool(&ci, None) }.check("vkCreateQueryPool")?;
    *cap = new_cap;
    Ok(())
}

/// The camera-derived part of [`SceneData`].
struct CameraState {
    view: glam::DMat4,
    proj: glam::DMat4,
    mvp: [f32; 16],
    view_vec: [f32; 4],
}

/// The first `n` results of `pool`, written by a submission that has completed.
fn query_results(device: &ash::Device, pool: vk::QueryPool, n: usize) -> Result<Vec<u64>, VkError> {
    let mut out = vec![0u64; n];
    // SAFETY: the first `n` queries were written by the completed submission.
    unsafe {
        device.get_query_pool_results(
            pool,
            0,
            &mut out,
            vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
        )
    }
    .check("vkGetQueryPoolResults")?;
    Ok(out)
}
