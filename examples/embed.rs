//! A windowless host engine embedding peeltrim (docs/embedding.md).
//!
//! It creates its own Vulkan instance (with the validation layer) and device,
//! draws its own floor into its own colour and depth images, records peeltrim's
//! CSG into the same command buffer and depth buffer, submits, reads the image
//! back, and checks occlusion both ways against the reference composite: the CPU
//! reference image of the CSG plus the analytically ray-cast floor.
//!
//! `cargo run --example embed` runs it with standard and reversed depth and exits
//! non-zero on a mismatch or a validation message; `vk_tests/embed.rs` runs the
//! same code under `cargo test`.
#![allow(clippy::missing_safety_doc)]

use std::ffi::{c_void, CStr};
use std::sync::Mutex;

use ash::vk;
use glam::{DVec3, Mat4};
use peeltrim::embed::{CsgExpr, CsgScene, EmbedDesc, LoopCounts, MeshInput};
use peeltrim::scene::shapes::{make_box, make_sphere};
use peeltrim::scene::{Camera, Mesh, Projection};
use peeltrim::vk::embed::HostPath;
use peeltrim::vk::{Context, DepthFormat, HostTargets};
use peeltrim::Algo;

const FLOOR_VERT: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/host_floor.vert.spv"));
const FLOOR_FRAG: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/host_floor.frag.spv"));
const BG: [u8; 3] = [10, 20, 30];
const FLOOR_RGB: [u8; 3] = [230, 230, 40];
/// The floor: the square |x|, |z| <= FLOOR_HALF at height FLOOR_Y, cutting the CSG.
const FLOOR_Y: f32 = -0.3;
const FLOOR_HALF: f32 = 3.0;

/// What one host frame showed, against the reference composite.
#[derive(Debug, Default)]
pub struct Report {
    pub pixels: u64,
    /// Pixels not within one pixel of a change of class in the reference.
    pub interior: u64,
    pub mismatched_interior: u64,
    /// Reference pixels where the floor is in front of the CSG (and the host shows the floor).
    pub floor_hides_csg: u64,
    pub floor_hides_csg_ok: u64,
    /// Reference pixels where the CSG is in front of the floor (and the host shows the CSG).
    pub csg_hides_floor: u64,
    pub csg_hides_floor_ok: u64,
    /// Loop counts of the first and the last frame's recordings.
    pub first_counts: Vec<u32>,
    pub last_counts: Vec<u32>,
    /// How each frame's final shading reached the host's targets.
    pub host_paths: Vec<Option<HostPath>>,
    /// The last frame's direct shade draws at the output depth (no face can
    /// tie) and with the tie rule.
    pub shade_fixed_draws: u64,
    pub shade_rule_draws: u64,
    /// The last frame's depth-equal draws of one-primitive products, which
    /// skip the check of the output depth (`plan::direct_shade`).
    pub direct_shade_draws: u64,
    /// The last frame's depth-equal draws that wrote their own depth, with
    /// no depth merge before them.
    pub shade_written_draws: u64,
    /// The last frame's depth-equal pieces drawn without the check of the
    /// output depth outside their mesh's cutters (`plan::cut_away`).
    pub shade_uncut_draws: u64,
    /// The last frame's pieces drawn after the solid's faces, strictly
    /// tested: the insides of its cavities (`record::host::insides_last`).
    pub shade_insides_last: u64,
    /// The last frame's pixels cut from the cavities' insides where they
    /// cannot be seen through an opening (`record::host::cut_insides`).
    pub shade_insides_cut_pixels: u64,
    /// Multisampled frames: pixels whose samples show both the floor and
    /// the CSG in the reference composite (the edges against the floor),
    /// those whose resolved colour is within 1/8 of a sample's contrast of
    /// the reference's mean, and those blended (no sample's pure colour).
    pub floor_edges: u64,
    pub floor_edges_ok: u64,
    pub floor_edges_blended: u64,
    /// Why the set-up did not run on this device (`None`: it ran).
    pub skipped: Option<String>,
    /// The last frame's colour image, RGBA, row by row.
    pub image: Image,
    pub validation: Vec<String>,
}

/// An image's pixels, printed as their count (a report's `Debug` stays short).
#[derive(Default, PartialEq, Eq)]
pub struct Image(pub Vec<[u8; 4]>);

impl std::fmt::Debug for Image {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Image({} pixels)", self.0.len())
    }
}

impl Report {
    pub fn interior_match(&self) -> f64 {
        1.0 - self.mismatched_interior as f64 / self.interior.max(1) as f64
    }

    /// A multisampled frame's edges against the floor: 99% of them within
    /// 1/8 of the reference's resolved colour, most of them blended.
    pub fn floor_edges_antialiased(&self) -> bool {
        self.floor_edges > 0
            && self.floor_edges_ok as f64 >= 0.99 * self.floor_edges as f64
            && 2 * self.floor_edges_blended >= self.floor_edges
    }
}

static MESSAGES: Mutex<Vec<String>> = Mutex::new(Vec::new());

unsafe extern "system" fn on_message(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _ty: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    _user: *mut c_void,
) -> vk::Bool32 {
    // SAFETY: the layer passes a valid callback data struct with a C string.
    let text = unsafe { CStr::from_ptr((*data).p_message) }
        .to_string_lossy()
        .into_owned();
    if severity.intersects(
        vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
            | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
    ) {
        MESSAGES.lock().expect("messages").push(text);
    }
    vk::FALSE
}

/// The host's device: everything peeltrim does not own.
struct Host {
    entry: ash::Entry,
    instance: ash::Instance,
    debug: (ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT),
    physical: vk::PhysicalDevice,
    device: ash::Device,
    family: u32,
    queue: vk::Queue,
}

impl Host {
    fn new() -> Result<Host, String> {
        // SAFETY: loading the system Vulkan loader.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| e.to_string())?;
        let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
        let layers = [c"VK_LAYER_KHRONOS_validation".as_ptr()];
        let exts = [ash::ext::debug_utils::NAME.as_ptr()];
        let ci = vk::InstanceCreateInfo::default()
            .application_info(&app)
            .enabled_layer_names(&layers)
            .enabled_extension_names(&exts);
        // SAFETY: the create info outlives the call.
        let instance = unsafe { entry.create_instance(&ci, None) }
            .map_err(|e| format!("vkCreateInstance with the validation layer: {e}"))?;
        let du = ash::ext::debug_utils::Instance::new(&entry, &instance);
        let dci = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                    | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(on_message));
        // SAFETY: valid create info; the callback is a plain function.
        let messenger =
            unsafe { du.create_debug_utils_messenger(&dci, None) }.map_err(|e| e.to_string())?;
        // SAFETY: plain enumeration.
        let physical = *unsafe { instance.enumerate_physical_devices() }
            .map_err(|e| e.to_string())?
            .first()
            .ok_or("no Vulkan device")?;
        // SAFETY: `physical` belongs to `instance`.
        let family = unsafe { instance.get_physical_device_queue_family_properties(physical) }
            .iter()
            .position(|f| f.queue_flags.contains(vk::QueueFlags::GRAPHICS))
            .ok_or("no graphics queue")? as u32;
        let prio = [1.0f32];
        let qci = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(family)
            .queue_priorities(&prio)];
        // What `Context::from_raw` requires.
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
            .dynamic_rendering(true)
            .maintenance4(true);
        // And `sampleRateShading` where the device has it (multisampled
        // embedding runs peeltrim's depth tests once per sample).
        // SAFETY: `physical` belongs to `instance`; a plain query.
        let supported = unsafe { instance.get_physical_device_features(physical) };
        let features = vk::PhysicalDeviceFeatures::default()
            .sample_rate_shading(supported.sample_rate_shading == vk::TRUE);
        let dci = vk::DeviceCreateInfo::default()
            .queue_create_infos(&qci)
            .enabled_features(&features)
            .push_next(&mut f13);
        // SAFETY: valid create info for a device of this instance.
        let device = unsafe { instance.create_device(physical, &dci, None) }
            .map_err(|e| format!("vkCreateDevice: {e}"))?;
        // SAFETY: queue 0 of the family requested above.
        let queue = unsafe { device.get_device_queue(family, 0) };
        Ok(Host {
            entry,
            instance,
            debug: (du, messenger),
            physical,
            device,
            family,
            queue,
        })
    }

    /// Destroys the device, messenger and instance; the validation messages
    /// reported until then, if any, are the error.
    ///
    /// # Safety
    ///
    /// Nothing made from the device is alive or pending.
    unsafe fn finish(&self) -> Result<(), String> {
        // SAFETY: the caller's; children before their parents.
        unsafe {
            self.device.device_wait_idle().ok();
            self.device.destroy_device(None);
            self.debug
                .0
                .destroy_debug_utils_messenger(self.debug.1, None);
            self.instance.destroy_instance(None);
        }
        let msgs = MESSAGES.lock().expect("messages").clone();
        match msgs.is_empty() {
            true => Ok(()),
            false => Err(format!("validation: {}", msgs.join("\n"))),
        }
    }

    /// peeltrim's context on this device.
    ///
    /// # Safety
    ///
    /// The device outlives the context and everything made from it.
    unsafe fn context(&self) -> Result<Context, String> {
        // SAFETY: the caller's; the device enables what `from_raw` needs.
        unsafe {
            Context::from_raw(
                self.entry.clone(),
                self.instance.clone(),
                self.physical,
                self.device.clone(),
                self.family,
                self.queue,
            )
        }
        .map_err(|e| e.to_string())
    }

    /// `want` if the device can render to it as a depth attachment with
    /// optimal tiling, else the first of D32S8, D24S8 and D32 it can (a host
    /// picks the formats its device supports: SwiftShader and AMD GPUs have
    /// no D24S8), said on stderr.
    fn depth_format(&self, want: vk::Format) -> vk::Format {
        let ok = |f: vk::Format| {
            // SAFETY: `physical` belongs to `instance`; a plain query.
            let fp = unsafe {
                self.instance
                    .get_physical_device_format_properties(self.physical, f)
            };
            fp.optimal_tiling_features
                .contains(vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT)
        };
        let fallbacks = [
            vk::Format::D32_SFLOAT_S8_UINT,
            vk::Format::D24_UNORM_S8_UINT,
            vk::Format::D32_SFLOAT,
        ];
        match std::iter::once(want).chain(fallbacks).find(|&f| ok(f)) {
            Some(f) if f != want => {
                eprintln!("note: the device lacks host depth format {want:?}: {f:?} instead");
                f
            }
            _ => want,
        }
    }

    fn memory(
        &self,
        req: vk::MemoryRequirements,
        flags: vk::MemoryPropertyFlags,
    ) -> vk::DeviceMemory {
        // SAFETY: `physical` belongs to `instance`.
        let props = unsafe {
            self.instance
                .get_physical_device_memory_properties(self.physical)
        };
        let ty = (0..props.memory_type_count)
            .find(|&i| {
                req.memory_type_bits & (1 << i) != 0
                    && props.memory_types[i as usize]
                        .property_flags
                        .contains(flags)
            })
            .expect("a memory type for the host's images and buffers");
        let ai = vk::MemoryAllocateInfo::default()
            .allocation_size(req.size)
            .memory_type_index(ty);
        // SAFETY: valid allocate info.
        unsafe { self.device.allocate_memory(&ai, None) }.expect("host memory")
    }

    fn image(
        &self,
        format: vk::Format,
        usage: vk::ImageUsageFlags,
        aspect: vk::ImageAspectFlags,
        [w, h]: [u32; 2],
        samples: u32,
    ) -> (vk::Image, vk::DeviceMemory, vk::ImageView) {
        let ci = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: w,
                height: h,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::from_raw(samples))
            .usage(usage);
        let d = &self.device;
        // SAFETY: valid create info.
        let image = unsafe { d.create_image(&ci, None) }.expect("host image");
        // SAFETY: `image` is live.
        let mem = self.memory(
            unsafe { d.get_image_memory_requirements(image) },
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
        );
        // SAFETY: fresh memory of the required size and type.
        unsafe { d.bind_image_memory(image, mem, 0) }.expect("bind");
        let vci = vk::ImageViewCreateInfo::default()
            .image(image)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(range(aspect));
        // SAFETY: valid view of a bound image.
        let view = unsafe { d.create_image_view(&vci, None) }.expect("view");
        (image, mem, view)
    }

    fn pipeline(
        &self,
        color: vk::Format,
        depth: vk::Format,
        samples: u32,
    ) -> (vk::Pipeline, vk::PipelineLayout) {
        let d = &self.device;
        let module = |bytes: &[u8]| {
            let words = ash::util::read_spv(&mut std::io::Cursor::new(bytes)).expect("SPIR-V");
            // SAFETY: SPIR-V compiled by build.rs.
            unsafe {
                d.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&words), None)
            }
            .expect("module")
        };
        let (vs, fs) = (module(FLOOR_VERT), module(FLOOR_FRAG));
        // Only the vertex shader reads them (it passes the colour on flat).
        let ranges = [vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::VERTEX,
            offset: 0,
            size: 96,
        }];
        // SAFETY: valid create info.
        let layout = unsafe {
            d.create_pipeline_layout(
                &vk::PipelineLayoutCreateInfo::default().push_constant_ranges(&ranges),
                None,
            )
        }
        .expect("layout");
        let stages = [
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::VERTEX)
                .module(vs)
                .name(c"main"),
            vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::FRAGMENT)
                .module(fs)
                .name(c"main"),
        ];
        let vi = vk::PipelineVertexInputStateCreateInfo::default();
        let ia = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let vp = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        let rs = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .line_width(1.0);
        let ms = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::from_raw(samples));
        let ds = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true);
        let att = [vk::PipelineColorBlendAttachmentState::default()
            .color_write_mask(vk::ColorComponentFlags::RGBA)];
        let cb = vk::PipelineColorBlendStateCreateInfo::default().attachments(&att);
        let dy = [
            vk::DynamicState::VIEWPORT,
            vk::DynamicState::SCISSOR,
            vk::DynamicState::DEPTH_COMPARE_OP,
        ];
        let dyn_ = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dy);
        let formats = [color];
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(&formats)
            .depth_attachment_format(depth);
        let ci = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vi)
            .input_assembly_state(&ia)
            .viewport_state(&vp)
            .rasterization_state(&rs)
            .multisample_state(&ms)
            .depth_stencil_state(&ds)
            .color_blend_state(&cb)
            .dynamic_state(&dyn_)
            .layout(layout)
            .push_next(&mut rendering);
        // SAFETY: everything the create info points to lives across the call.
        let p = unsafe { d.create_graphics_pipelines(vk::PipelineCache::null(), &[ci], None) }
            .map_err(|(_, e)| e)
            .expect("floor pipeline")[0];
        // SAFETY: modules are only needed during creation.
        unsafe {
            d.destroy_shader_module(vs, None);
            d.destroy_shader_module(fs, None);
        }
        (p, layout)
    }
}

fn range(aspect: vk::ImageAspectFlags) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: aspect,
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

fn barrier(
    image: vk::Image,
    aspect: vk::ImageAspectFlags,
    from: (vk::ImageLayout, vk::AccessFlags),
    to: (vk::ImageLayout, vk::AccessFlags),
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .old_layout(from.0)
        .src_access_mask(from.1)
        .new_layout(to.0)
        .dst_access_mask(to.1)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(range(aspect))
}

/// Begins `cmd` and brings the host's targets (contents discarded) into the
/// attachment layouts peeltrim's contract expects, after the attachment writes
/// and the read-back copy of the frames before (they share the images).
unsafe fn begin_frame(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    color: vk::Image,
    depth: (vk::Image, vk::ImageAspectFlags),
) {
    let undefined = |access| (vk::ImageLayout::UNDEFINED, access);
    // SAFETY: the caller's: `cmd` is not pending, the images are live.
    unsafe {
        d.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default())
            .expect("begin");
        d.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
                | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS
                | vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
                | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &[
                barrier(
                    color,
                    vk::ImageAspectFlags::COLOR,
                    undefined(vk::AccessFlags::COLOR_ATTACHMENT_WRITE),
                    (
                        vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                        vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
                    ),
                ),
                barrier(
                    depth.0,
                    depth.1,
                    undefined(vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE),
                    (
                        vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
                        vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
                    ),
                ),
            ],
        )
    };
}

/// The host's CSG scene on `ctx`: [`host_meshes`] combined as `m0 - m1`,
/// with `ball` as `m0 - m1 + m2`, and with `bites` the box's three other top
/// corners bitten too (three more balls, numbered on, subtracted before the
/// ball is added).
fn host_csg(ctx: &Context, desc: &EmbedDesc, ball: bool, bites: bool) -> Result<CsgScene, String> {
    let mut meshes = host_meshes();
    let mut expr = String::from("m0 - m1");
    if !bites {
        meshes.truncate(3);
    }
    if !ball {
        meshes.remove(2);
    }
    if bites {
        let first = 2 + usize::from(ball);
        for m in first..first + 3 {
            expr += &format!(" - m{m}");
        }
    }
    // Last: the ball stays a product of one primitive.
    if ball {
        expr += " + m2";
    }
    scene_of(ctx, &meshes, &expr, desc)
}

/// The CSG scene of `meshes` (positions, indices, transform, colour) under
/// `expr`, seen from [`camera`].
fn scene_of(
    ctx: &Context,
    meshes: &[HostMesh],
    expr: &str,
    desc: &EmbedDesc,
) -> Result<CsgScene, String> {
    let inputs: Vec<MeshInput<'_>> = meshes
        .iter()
        .map(|(p, i, t, c)| MeshInput {
            positions: p,
            indices: i,
            transform: *t,
            color: *c,
        })
        .collect();
    CsgScene::new(ctx, &inputs, CsgExpr::Text(expr), &camera(), desc).map_err(|e| e.to_string())
}

/// The drilled box on `ctx` ([`drilled_meshes`], `m0 - m1 - m2 - m3 - m4`).
fn drilled_csg(ctx: &Context, desc: &EmbedDesc) -> Result<CsgScene, String> {
    let meshes = drilled_meshes();
    let expr = (1..meshes.len()).fold(String::from("m0"), |e, m| format!("{e} - m{m}"));
    scene_of(ctx, &meshes, &expr, desc)
}

/// The box of [`host_meshes`] and four small balls centred on its faces
/// towards the eye (two on the top, one on the front, one on the right): a
/// pit each, small on screen, so that most of the box's rectangle lies
/// outside every cutter's.
fn drilled_meshes() -> Vec<HostMesh> {
    let f32s = |m: &Mesh| {
        m.positions
            .iter()
            .map(|p| [p.x as f32, p.y as f32, p.z as f32])
            .collect()
    };
    let cube = make_box(DVec3::splat(2.0));
    let ball = make_sphere(1.0, 24, 12);
    let mut meshes = vec![(
        f32s(&cube),
        cube.triangles.clone(),
        Mat4::IDENTITY,
        [70, 130, 220],
    )];
    for (at, color) in [
        ([0.4, 1.0, -0.4], [220, 90, 60]),
        ([-0.5, 1.0, 0.4], [220, 180, 60]),
        ([-0.3, 0.4, 1.0], [90, 200, 110]),
        ([1.0, 0.4, -0.4], [200, 80, 200]),
    ] {
        meshes.push((
            f32s(&ball),
            ball.triangles.clone(),
            Mat4::from_translation(at.into()) * Mat4::from_scale(glam::Vec3::splat(0.3)),
            color,
        ));
    }
    meshes
}

/// A host mesh: positions, triangles, model matrix, colour.
type HostMesh = (Vec<[f32; 3]>, Vec<[u32; 3]>, Mat4, [u8; 3]);

/// The host's CSG: a box with a spherical bite, as plain f32 meshes, and a
/// ball beside the box, half below the floor (a product of one primitive,
/// which the standalone frame shades in its direct draw, `plan::direct_shade`).
fn host_meshes() -> Vec<HostMesh> {
    let f32s = |m: &Mesh| {
        m.positions
            .iter()
            .map(|p| [p.x as f32, p.y as f32, p.z as f32])
            .collect()
    };
    let cube = make_box(DVec3::splat(2.0));
    let ball = make_sphere(1.2, 32, 16);
    vec![
        (
            f32s(&cube),
            cube.triangles.clone(),
            Mat4::IDENTITY,
            [70, 130, 220],
        ),
        (
            f32s(&ball),
            ball.triangles.clone(),
            Mat4::from_translation([0.6, 0.7, 0.6].into()),
            [220, 90, 60],
        ),
        (
            f32s(&ball),
            ball.triangles.clone(),
            Mat4::from_translation([-1.9, FLOOR_Y, 1.2].into())
                * Mat4::from_scale(glam::Vec3::splat(0.5)),
            [90, 200, 110],
        ),
        (
            f32s(&ball),
            ball.triangles.clone(),
            Mat4::from_translation([-0.7, 0.8, 0.7].into())
                * Mat4::from_scale(glam::Vec3::splat(0.7)),
            [220, 180, 60],
        ),
        (
            f32s(&ball),
            ball.triangles.clone(),
            Mat4::from_translation([0.7, 0.8, -0.7].into())
                * Mat4::from_scale(glam::Vec3::splat(0.7)),
            [200, 80, 200],
        ),
        (
            f32s(&ball),
            ball.triangles.clone(),
            Mat4::from_translation([-0.7, 0.8, -0.7].into())
                * Mat4::from_scale(glam::Vec3::splat(0.7)),
            [60, 200, 220],
        ),
    ]
}

pub fn camera() -> Camera {
    Camera {
        eye: DVec3::new(3.2, 2.4, 4.2),
        target: DVec3::new(0.0, -0.2, 0.0),
        up: DVec3::Y,
        projection: Projection::Perspective { fov_y_deg: 40.0 },
        near: 1.0,
        far: 20.0,
    }
}

/// One host set-up: its formats, depth convention, frames in flight, and how
/// many frames it records (the last is read back and compared).
#[derive(Clone, Debug)]
pub struct Setup {
    pub extent: [u32; 2],
    pub reversed_z: bool,
    /// A 4-byte colour format (RGBA or BGRA order, UNORM or SRGB).
    pub color_format: vk::Format,
    pub depth_format: vk::Format,
    /// Command buffers in flight: the host waits for a frame's fence only when it
    /// reuses that frame's command buffer.
    pub frames_in_flight: u32,
    pub frames: u32,
    pub loop_counts: LoopCounts,
    pub algo: Algo,
    /// peeltrim's own depth-stencil images (D24S8 keeps the tie rule).
    pub internal_depth: DepthFormat,
    /// Adds the ball beside the box (`m0 - m1 + m2`, [`host_meshes`]).
    pub ball: bool,
    /// Bites the box's three other top corners too ([`host_csg`]).
    pub bites: bool,
    /// Instead of the bitten box: the box with four small pits in its faces
    /// towards the eye (`m0 - m1 - … - m4`, [`drilled_meshes`]), whose
    /// screen rectangles leave most of the box free of cutters
    /// (`plan::cut_away`).
    pub drilled: bool,
    /// Whether the final shade's pieces may skip the check of the output
    /// depth outside their mesh's cutters (`plan::cut_away`; `false`: every
    /// piece checks, for comparing the two images).
    pub uncut: bool,
    /// Samples per pixel of the host's colour and depth (and of peeltrim's
    /// images); above 1 the host resolves its colour before reading it back.
    pub samples: u32,
}

impl Setup {
    /// One frame in flight, RGBA8 UNORM colour and D32 depth, estimated counts.
    pub fn new(extent: [u32; 2], reversed_z: bool) -> Setup {
        Setup {
            extent,
            reversed_z,
            color_format: vk::Format::R8G8B8A8_UNORM,
            depth_format: vk::Format::D32_SFLOAT,
            frames_in_flight: 1,
            frames: 1,
            loop_counts: LoopCounts::Estimate,
            algo: Algo::Goldfeather,
            internal_depth: DepthFormat::D32S8,
            ball: false,
            bites: false,
            drilled: false,
            uncut: true,
            samples: 1,
        }
    }
}

/// The host's frames of `setup`: floor, then peeltrim, then (last frame) a
/// read-back; compared with the reference composite.
pub fn run(setup: &Setup) -> Result<Report, String> {
    MESSAGES.lock().expect("messages").clear();
    let host = Host::new()?;
    let report = frame(&host, setup);
    // SAFETY: every object of the frame was destroyed (or the device idles).
    unsafe {
        host.device.device_wait_idle().ok();
        host.device.destroy_device(None);
        host.debug
            .0
            .destroy_debug_utils_messenger(host.debug.1, None);
        host.instance.destroy_instance(None);
    }
    let mut report = report?;
    report.validation = MESSAGES.lock().expect("messages").clone();
    Ok(report)
}

/// The aspects of a depth format's image (barriers name all of them).
fn depth_aspects(format: vk::Format) -> vk::ImageAspectFlags {
    match format {
        vk::Format::D16_UNORM | vk::Format::X8_D24_UNORM_PACK32 | vk::Format::D32_SFLOAT => {
            vk::ImageAspectFlags::DEPTH
        }
        _ => vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL,
    }
}

fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn frame(host: &Host, setup: &Setup) -> Result<Report, String> {
    let d = &host.device;
    let extent = setup.extent;
    // SAFETY: the device outlives the context (dropped before the device).
    let ctx = unsafe { host.context() }?;
    let inflight = setup.frames_in_flight.max(1);
    let desc = EmbedDesc {
        extent,
        reversed_z: setup.reversed_z,
        frames_in_flight: inflight,
        loop_counts: setup.loop_counts,
        algo: setup.algo,
        // peeltrim's own depth: D32S8 where the device lacks the one asked for.
        internal_depth: match ctx.depth_format_usable(setup.internal_depth.vk()) {
            true => setup.internal_depth,
            false => {
                eprintln!(
                    "note: the device lacks {:?}: D32S8 for peeltrim's depth",
                    setup.internal_depth
                );
                DepthFormat::D32S8
            }
        },
        samples: setup.samples,
    };
    if let Err(e) = ctx.check_samples(setup.samples) {
        return Ok(Report {
            skipped: Some(e.to_string()),
            ..Report::default()
        });
    }
    let mut csg = match setup.drilled {
        true => drilled_csg(&ctx, &desc)?,
        false => host_csg(&ctx, &desc, setup.ball, setup.bites)?,
    };
    if !setup.uncut {
        // Until the next plan: the camera does not move here.
        csg.recorder()
            .set_cut_away(peeltrim::plan::cut_away::CutAway::none());
    }

    let (color_format, depth_format) = (setup.color_format, host.depth_format(setup.depth_format));
    let srgb = matches!(
        color_format,
        vk::Format::R8G8B8A8_SRGB | vk::Format::B8G8R8A8_SRGB
    );
    let bgra = matches!(
        color_format,
        vk::Format::B8G8R8A8_UNORM | vk::Format::B8G8R8A8_SRGB
    );
    // The host's colours as it writes them: linear for an sRGB target.
    let shade = |c: [u8; 3]| {
        c.map(|v| {
            if srgb {
                srgb_to_linear(v)
            } else {
                v as f32 / 255.0
            }
        })
    };
    let depth_aspect = depth_aspects(depth_format);
    let samples = setup.samples;
    let (color_img, color_mem, color_view) = host.image(
        color_format,
        vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC,
        vk::ImageAspectFlags::COLOR,
        extent,
        samples,
    );
    let (depth_img, depth_mem, depth_view) = host.image(
        depth_format,
        vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
        depth_aspect,
        extent,
        samples,
    );
    // A multisampled host resolves its colour into a single-sample image.
    let resolved = (samples > 1).then(|| {
        host.image(
            color_format,
            vk::ImageUsageFlags::COLOR_ATTACHMENT
                | vk::ImageUsageFlags::TRANSFER_DST
                | vk::ImageUsageFlags::TRANSFER_SRC,
            vk::ImageAspectFlags::COLOR,
            extent,
            1,
        )
    });
    let (pipeline, layout) = host.pipeline(color_format, depth_format, samples);
    let bytes = extent[0] as u64 * extent[1] as u64 * 4;
    // SAFETY: valid create info.
    let buffer = unsafe {
        d.create_buffer(
            &vk::BufferCreateInfo::default()
                .size(bytes)
                .usage(vk::BufferUsageFlags::TRANSFER_DST),
            None,
        )
    }
    .expect("buffer");
    let visible = vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
    // SAFETY: `buffer` is live.
    let buf_mem = host.memory(unsafe { d.get_buffer_memory_requirements(buffer) }, visible);
    // SAFETY: fresh memory of the required size.
    unsafe { d.bind_buffer_memory(buffer, buf_mem, 0) }.expect("bind");
    let pci = vk::CommandPoolCreateInfo::default()
        .queue_family_index(host.family)
        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
    // SAFETY: valid create info.
    let pool = unsafe { d.create_command_pool(&pci, None) }.expect("pool");
    let ai = vk::CommandBufferAllocateInfo::default()
        .command_pool(pool)
        .command_buffer_count(inflight);
    // SAFETY: the pool is live.
    let cmds = unsafe { d.allocate_command_buffers(&ai) }.expect("cmd");
    let signaled = vk::FenceCreateInfo::default().flags(vk::FenceCreateFlags::SIGNALED);
    let fences: Vec<vk::Fence> = (0..inflight)
        // SAFETY: valid create info.
        .map(|_| unsafe { d.create_fence(&signaled, None) }.expect("fence"))
        .collect();

    let ext = vk::Extent2D {
        width: extent[0],
        height: extent[1],
    };
    let far = if setup.reversed_z { 0.0 } else { 1.0 };
    let nearer = if setup.reversed_z {
        vk::CompareOp::GREATER
    } else {
        vk::CompareOp::LESS
    };
    let mvp = csg.view_proj().as_mat4();
    let mut push = Vec::with_capacity(96);
    for f in mvp
        .to_cols_array()
        .iter()
        .chain(&[FLOOR_Y, FLOOR_HALF, 0.0, 0.0])
        .chain(&shade(FLOOR_RGB))
        .chain(&[1.0])
    {
        push.extend(f.to_ne_bytes());
    }
    let targets = HostTargets {
        color_view,
        color_format,
        depth_view,
        depth_format,
        extent,
    };
    let attach = (
        vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
        vk::AccessFlags::COLOR_ATTACHMENT_WRITE,
    );
    let depth_attach = (
        vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL,
        vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
    );
    let mut counts = Vec::new();
    let mut paths = Vec::new();
    let mut shade_draws = (0, 0, 0, 0, 0, 0, 0);
    for k in 0..setup.frames.max(1) {
        let slot = (k % inflight) as usize;
        let (cmd, fence) = (cmds[slot], fences[slot]);
        let last = k + 1 == setup.frames.max(1);
        // SAFETY: the fence guards this command buffer's previous submission.
        unsafe {
            d.wait_for_fences(&[fence], true, u64::MAX).expect("wait");
            d.reset_fences(&[fence]).expect("reset");
        }
        // SAFETY: every call below records into `cmd`, which this function owns and
        // which is not pending (its fence was waited for); the images, views,
        // pipeline and buffer are live until after the final wait.
        unsafe {
            begin_frame(d, cmd, color_img, (depth_img, depth_aspect));
            let bg = shade(BG);
            let color_att = [vk::RenderingAttachmentInfo::default()
                .image_view(color_view)
                .image_layout(attach.0)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue {
                    color: vk::ClearColorValue {
                        float32: [bg[0], bg[1], bg[2], 1.0],
                    },
                })];
            let depth_att = vk::RenderingAttachmentInfo::default()
                .image_view(depth_view)
                .image_layout(depth_attach.0)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue {
                    depth_stencil: vk::ClearDepthStencilValue {
                        depth: far,
                        stencil: 0,
                    },
                });
            d.cmd_begin_rendering(
                cmd,
                &vk::RenderingInfo::default()
                    .render_area(ext.into())
                    .layer_count(1)
                    .color_attachments(&color_att)
                    .depth_attachment(&depth_att),
            );
            d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
            d.cmd_set_viewport(
                cmd,
                0,
                &[vk::Viewport {
                    x: 0.0,
                    y: 0.0,
                    width: ext.width as f32,
                    height: ext.height as f32,
                    min_depth: 0.0,
                    max_depth: 1.0,
                }],
            );
            d.cmd_set_scissor(cmd, 0, &[ext.into()]);
            d.cmd_set_depth_compare_op(cmd, nearer);
            d.cmd_push_constants(cmd, layout, vk::ShaderStageFlags::VERTEX, 0, &push);
            d.cmd_draw(cmd, 6, 1, 0, 0);
            d.cmd_end_rendering(cmd);
        }
        // SAFETY: `cmd` is recording outside rendering on the context's queue
        // family; the targets are in the attachment layouts; at most `inflight`
        // frames are pending (the fence wait above), submitted in recording order.
        let stats = unsafe { csg.recorder().record(cmd, &targets) }.map_err(|e| e.to_string())?;
        counts.push(stats.counts.loop_iterations.clone());
        paths.push(stats.host_path);
        shade_draws = (
            stats.counts.shade_fixed_draws,
            stats.counts.shade_rule_draws,
            stats.counts.direct_shade_draws,
            stats.counts.shade_written_draws,
            stats.counts.shade_uncut_draws,
            stats.counts.shade_insides_last,
            stats.counts.shade_insides_cut_pixels,
        );
        // SAFETY: as above.
        unsafe {
            if last {
                read_back_color(
                    d,
                    cmd,
                    (color_img, resolved.map(|r| r.0)),
                    attach,
                    buffer,
                    ext,
                );
            }
            d.end_command_buffer(cmd).expect("end");
            let cmds = [cmd];
            d.queue_submit(
                host.queue,
                &[vk::SubmitInfo::default().command_buffers(&cmds)],
                fence,
            )
            .expect("submit");
        }
    }
    // SAFETY: waits for every frame (the last holds the read-back).
    unsafe { d.wait_for_fences(&fences, true, u64::MAX) }.expect("wait");
    // SAFETY: coherent host-visible memory written by the completed copy.
    let mut pixels: Vec<[u8; 4]> = unsafe {
        let p = d
            .map_memory(buf_mem, 0, bytes, vk::MemoryMapFlags::empty())
            .expect("map") as *const [u8; 4];
        let v = std::slice::from_raw_parts(p, (extent[0] * extent[1]) as usize).to_vec();
        d.unmap_memory(buf_mem);
        v
    };
    if bgra {
        for p in &mut pixels {
            p.swap(0, 2);
        }
    }
    let mut report = match samples {
        1 => compare(&csg, extent, &pixels),
        n => compare_samples(&csg, extent, &pixels, n),
    };
    report.image = Image(pixels);
    report.first_counts = counts.first().cloned().unwrap_or_default();
    report.last_counts = counts.last().cloned().unwrap_or_default();
    report.host_paths = paths;
    (
        report.shade_fixed_draws,
        report.shade_rule_draws,
        report.direct_shade_draws,
        report.shade_written_draws,
        report.shade_uncut_draws,
        report.shade_insides_last,
        report.shade_insides_cut_pixels,
    ) = shade_draws;
    drop(csg);
    drop(ctx);
    // SAFETY: every frame completed; nothing uses these objects any more.
    unsafe {
        for f in fences {
            d.destroy_fence(f, None);
        }
        d.destroy_command_pool(pool, None);
        d.destroy_buffer(buffer, None);
        d.free_memory(buf_mem, None);
        d.destroy_pipeline(pipeline, None);
        d.destroy_pipeline_layout(layout, None);
        for (img, mem, view) in [
            (color_img, color_mem, color_view),
            (depth_img, depth_mem, depth_view),
        ]
        .into_iter()
        .chain(resolved)
        {
            d.destroy_image_view(view, None);
            d.destroy_image(img, None);
            d.free_memory(mem, None);
        }
    }
    Ok(report)
}

/// Records the copy of the colour image into `buffer`, visible to the host;
/// a multisampled one (with its single-sample `resolved` image) resolved
/// first, the samples averaged (`vkCmdResolveImage`).
unsafe fn read_back_color(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    (color_img, resolved): (vk::Image, Option<vk::Image>),
    attach: (vk::ImageLayout, vk::AccessFlags),
    buffer: vk::Buffer,
    ext: vk::Extent2D,
) {
    let src = (
        vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
        vk::AccessFlags::TRANSFER_READ,
    );
    let dst = (
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        vk::AccessFlags::TRANSFER_WRITE,
    );
    let color = vk::ImageAspectFlags::COLOR;
    let layers = vk::ImageSubresourceLayers {
        aspect_mask: color,
        mip_level: 0,
        base_array_layer: 0,
        layer_count: 1,
    };
    let extent = vk::Extent3D {
        width: ext.width,
        height: ext.height,
        depth: 1,
    };
    // SAFETY: the caller's: `cmd` is recording outside rendering, the images
    // are live, the colour image in `attach`'s layout, the resolved one
    // unused.
    let color_img = match resolved {
        None => color_img,
        Some(r) => unsafe {
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[
                    barrier(color_img, color, attach, src),
                    barrier(
                        r,
                        color,
                        (vk::ImageLayout::UNDEFINED, vk::AccessFlags::empty()),
                        dst,
                    ),
                ],
            );
            let region = vk::ImageResolve::default()
                .src_subresource(layers)
                .dst_subresource(layers)
                .extent(extent);
            d.cmd_resolve_image(cmd, color_img, src.0, r, dst.0, &[region]);
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[barrier(r, color, dst, src)],
            );
            r
        },
    };
    // SAFETY: as above; a resolved image is in TRANSFER_SRC_OPTIMAL.
    unsafe {
        if resolved.is_none() {
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT,
                vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &[],
                &[],
                &[barrier(color_img, color, attach, src)],
            );
        }
        let region = vk::BufferImageCopy::default()
            .image_subresource(layers)
            .image_extent(extent);
        d.cmd_copy_image_to_buffer(
            cmd,
            color_img,
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            buffer,
            &[region],
        );
        let to_host = vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::HOST_READ);
        d.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::HOST,
            vk::DependencyFlags::empty(),
            &[to_host],
            &[],
            &[],
        );
    }
}

/// Per pixel: 0 background, 1 floor, 2 CSG (within one step per channel: an
/// sRGB target stores the host's colours through float).
fn classify(c: [u8; 4]) -> u8 {
    let near = |k: [u8; 3]| (0..3).all(|i| c[i].abs_diff(k[i]) <= 1);
    if near(BG) {
        0
    } else if near(FLOOR_RGB) {
        1
    } else {
        2
    }
}

/// The host image against the reference composite: the CPU reference of the CSG
/// (exact ray casting) and the floor ray-cast analytically, nearer view depth wins.
fn compare(csg: &CsgScene, [w, h]: [u32; 2], pixels: &[[u8; 4]]) -> Report {
    let reference = peeltrim_reference::render(csg.scene(), w, h);
    let cam = csg.camera();
    let mut expected = vec![0u8; (w * h) as usize];
    let mut r = Report {
        pixels: (w * h) as u64,
        ..Report::default()
    };
    let mut kinds = vec![None; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let ray = cam.ray(x as f64 + 0.5, y as f64 + 0.5, w, h);
            let t = (FLOOR_Y as f64 - ray.origin.y) / ray.dir.y;
            let p = ray.origin + ray.dir * t;
            let floor =
                (t > 0.0 && p.x.abs() <= FLOOR_HALF as f64 && p.z.abs() <= FLOOR_HALF as f64)
                    .then(|| cam.view_depth(p));
            let solid = reference.depth[i]
                .is_finite()
                .then_some(reference.depth[i] as f64);
            expected[i] = match (floor, solid) {
                (Some(f), Some(s)) => {
                    kinds[i] = Some(f < s);
                    if f < s {
                        1
                    } else {
                        2
                    }
                }
                (Some(_), None) => 1,
                (None, Some(_)) => 2,
                (None, None) => 0,
            };
        }
    }
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let got = classify(pixels[i]);
            let interior = (-1i32..=1).all(|dy| {
                (-1i32..=1).all(|dx| {
                    let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                    nx < 0
                        || ny < 0
                        || nx >= w as i32
                        || ny >= h as i32
                        || expected[(ny as u32 * w + nx as u32) as usize] == expected[i]
                })
            });
            if interior {
                r.interior += 1;
                if got != expected[i] {
                    r.mismatched_interior += 1;
                }
                match kinds[i] {
                    Some(true) => {
                        r.floor_hides_csg += 1;
                        r.floor_hides_csg_ok += (got == 1) as u64;
                    }
                    Some(false) => {
                        r.csg_hides_floor += 1;
                        r.csg_hides_floor_ok += (got == 2) as u64;
                    }
                    None => {}
                }
            }
        }
    }
    r
}

/// A multisampled host image (resolved, `samples` per pixel) against the
/// reference composite cast per sample at Vulkan's standard sample locations
/// (`peeltrim_reference::sample_positions`): each sample is background, the
/// floor or the CSG's shaded point, whichever is nearest. Pixels whose
/// samples agree, with neighbours that agree too, are the interior (as in
/// [`compare`], the floor hiding the CSG or the CSG the floor at every
/// sample); pixels whose samples show both the floor and the CSG are the
/// edges against the floor, whose resolved colour must be the samples'
/// mean (a UNORM resolve) within 1/8 of their contrast.
fn compare_samples(csg: &CsgScene, [w, h]: [u32; 2], pixels: &[[u8; 4]], samples: u32) -> Report {
    let scene = csg.scene();
    let cast = peeltrim_reference::Prepared::new(scene);
    let cam = csg.camera();
    let positions = peeltrim_reference::sample_positions(samples);
    let mut r = Report {
        pixels: (w * h) as u64,
        ..Report::default()
    };
    // Per pixel: each sample's class (0 background, 1 floor, 2 CSG) and
    // whether the floor is in front of the CSG there (both present).
    let mut classes = vec![Vec::new(); (w * h) as usize];
    let mut colors = vec![Vec::new(); (w * h) as usize];
    let mut fronts = vec![Vec::new(); (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            for &(sx, sy) in positions {
                let (px, py) = (x as f64 + sx, y as f64 + sy);
                let ray = cam.ray(px, py, w, h);
                let t = (FLOOR_Y as f64 - ray.origin.y) / ray.dir.y;
                let p = ray.origin + ray.dir * t;
                let floor =
                    (t > 0.0 && p.x.abs() <= FLOOR_HALF as f64 && p.z.abs() <= FLOOR_HALF as f64)
                        .then(|| cam.view_depth(p));
                let hit = cast.cast_pixel(px, py, w, h);
                let (class, color) = match (floor, hit) {
                    (Some(f), Some(s)) if f < s.depth => (1, FLOOR_RGB),
                    (_, Some(s)) => {
                        let c = peeltrim::images::shade(s.rgb, s.normal.dot(s.dir));
                        (2, [c[0], c[1], c[2]])
                    }
                    (Some(_), None) => (1, FLOOR_RGB),
                    (None, None) => (0, BG),
                };
                if let (Some(f), Some(s)) = (floor, hit) {
                    fronts[i].push(f < s.depth);
                }
                classes[i].push(class);
                colors[i].push(color);
            }
        }
    }
    let pure = |i: usize| classes[i].iter().all(|&c| c == classes[i][0]);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let got = pixels[i];
            let interior = (-1i32..=1).all(|dy| {
                (-1i32..=1).all(|dx| {
                    let (nx, ny) = (x as i32 + dx, y as i32 + dy);
                    let j = (ny.max(0) as u32 * w + nx.max(0) as u32) as usize;
                    nx < 0
                        || ny < 0
                        || nx >= w as i32
                        || ny >= h as i32
                        || (pure(j) && classes[j][0] == classes[i][0])
                })
            });
            if interior {
                r.interior += 1;
                let want = classes[i][0];
                r.mismatched_interior += (classify(got) != want) as u64;
                if fronts[i].len() == classes[i].len() {
                    if fronts[i].iter().all(|&f| f) {
                        r.floor_hides_csg += 1;
                        r.floor_hides_csg_ok += (classify(got) == 1) as u64;
                    } else if fronts[i].iter().all(|&f| !f) {
                        r.csg_hides_floor += 1;
                        r.csg_hides_floor_ok += (classify(got) == 2) as u64;
                    }
                }
                continue;
            }
            if !(classes[i].contains(&1) && classes[i].contains(&2)) {
                continue;
            }
            r.floor_edges += 1;
            let n = colors[i].len() as f64;
            let channel = |k: usize| colors[i].iter().map(|c| c[k] as f64).sum::<f64>() / n;
            let contrast = |k: usize| {
                let (lo, hi) = colors[i]
                    .iter()
                    .fold((255u8, 0u8), |(lo, hi), c| (lo.min(c[k]), hi.max(c[k])));
                (hi - lo) as f64
            };
            let ok = (0..3).all(|k| (got[k] as f64 - channel(k)).abs() <= contrast(k) / 8.0 + 2.0);
            r.floor_edges_ok += ok as u64;
            let blended = colors[i]
                .iter()
                .all(|c| (0..3).any(|k| got[k].abs_diff(c[k]) > 2));
            r.floor_edges_blended += blended as u64;
        }
    }
    r
}

/// Median `frame_ms` (submission to completion) of `frames` frames of `path`'s
/// solids, standalone (`Executor::execute`) and embedded (recorded into a host
/// command buffer that the host submits and waits for), plus the embedded
/// frames' median CPU recording time.
pub fn bench(path: &std::path::Path, frames: usize) -> Result<[f64; 3], String> {
    use peeltrim::plan::{self, Algo, Prepared};
    use std::time::Instant;
    let scene = peeltrim::scene::load(path, &Default::default()).map_err(|e| e.to_string())?;
    if !scene.surfaces.is_empty() {
        return Err(format!(
            "{}: trimmed surfaces are not part of the mesh-level API",
            path.display()
        ));
    }
    let host = Host::new()?;
    let d = &host.device;
    // SAFETY: the device outlives the context (dropped before the device).
    let ctx = unsafe { host.context() }?;
    let extent = [scene.render.width, scene.render.height];
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    // Embedded: the same plan recorded into the host's command buffer.
    let f32s = |m: &Mesh| -> Vec<[f32; 3]> {
        m.positions
            .iter()
            .map(|p| [p.x as f32, p.y as f32, p.z as f32])
            .collect()
    };
    let pos: Vec<Vec<[f32; 3]>> = scene.primitives.iter().map(|p| f32s(&p.mesh)).collect();
    let inputs: Vec<MeshInput<'_>> = scene
        .primitives
        .iter()
        .zip(&pos)
        .map(|(p, v)| MeshInput {
            positions: v,
            indices: &p.mesh.triangles,
            transform: Mat4::IDENTITY,
            color: p.color,
        })
        .collect();
    let expr = plan::union_of_solids(&scene).ok_or("no solid")?;
    let desc = EmbedDesc {
        extent,
        frames_in_flight: 1,
        // The standalone path learns its counts; so does this one, for equal work.
        loop_counts: LoopCounts::Learn,
        ..EmbedDesc::default()
    };
    let mut csg = CsgScene::new(&ctx, &inputs, CsgExpr::Built(expr), &scene.camera, &desc)
        .map_err(|e| e.to_string())?;
    // Standalone: the executor's own submission, on the very scene the mesh-level
    // API built (the host's f32 meshes), so both paths run the same plan.
    let plan = plan::build(
        Algo::Goldfeather,
        &Prepared::new(csg.scene()).map_err(|e| e.to_string())?,
    )
    .map_err(|e| e.to_string())?;
    let mut exec = peeltrim::vk::Executor::new(
        &ctx,
        &peeltrim::vk::ExecDesc {
            width: extent[0],
            height: extent[1],
            depth_format: peeltrim::vk::DepthFormat::D32S8,
            reversed_z: false,
            samples: 1,
        },
    )
    .map_err(|e| e.to_string())?;
    exec.upload(csg.scene()).map_err(|e| e.to_string())?;
    let mut standalone = Vec::new();
    let (color_format, depth_format) = (vk::Format::R8G8B8A8_UNORM, vk::Format::D32_SFLOAT);
    let color = host.image(
        color_format,
        vk::ImageUsageFlags::COLOR_ATTACHMENT,
        vk::ImageAspectFlags::COLOR,
        extent,
        1,
    );
    let depth = host.image(
        depth_format,
        vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
        vk::ImageAspectFlags::DEPTH,
        extent,
        1,
    );
    let targets = HostTargets {
        color_view: color.2,
        color_format,
        depth_view: depth.2,
        depth_format,
        extent,
    };
    let pci = vk::CommandPoolCreateInfo::default()
        .queue_family_index(host.family)
        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
    // SAFETY: valid create info.
    let pool = unsafe { d.create_command_pool(&pci, None) }.expect("pool");
    // SAFETY: the pool is live.
    let cmd = unsafe {
        d.allocate_command_buffers(
            &vk::CommandBufferAllocateInfo::default()
                .command_pool(pool)
                .command_buffer_count(1),
        )
    }
    .expect("cmd")[0];
    // SAFETY: valid create info.
    let fence = unsafe { d.create_fence(&vk::FenceCreateInfo::default(), None) }.expect("fence");
    let (mut embedded, mut record) = (Vec::new(), Vec::new());
    // Interleaved, so that load on the machine hits both alike.
    for _ in 0..frames {
        let st = exec.execute(&plan).map_err(|e| e.to_string())?;
        standalone.push(st.frame_ms);
        if std::env::var_os("EMBED_BENCH_COUNTS").is_some() {
            eprintln!("standalone {:?}", st.counts);
        }
        let t = Instant::now();
        // SAFETY: `cmd` is not pending (waited below); the images are live.
        unsafe { begin_frame(d, cmd, color.0, (depth.0, vk::ImageAspectFlags::DEPTH)) };
        // SAFETY: as above; one frame in flight.
        let et = unsafe { csg.recorder().record(cmd, &targets) }.map_err(|e| e.to_string())?;
        if std::env::var_os("EMBED_BENCH_COUNTS").is_some() {
            eprintln!("embedded   {:?}", et.counts);
        }
        // SAFETY: as above.
        unsafe { d.end_command_buffer(cmd) }.expect("end");
        record.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        let cmds = [cmd];
        // SAFETY: `cmd` is complete; the fence is unsignalled.
        unsafe {
            d.queue_submit(
                host.queue,
                &[vk::SubmitInfo::default().command_buffers(&cmds)],
                fence,
            )
            .expect("submit");
            d.wait_for_fences(&[fence], true, u64::MAX).expect("wait");
            d.reset_fences(&[fence]).expect("reset");
        }
        embedded.push(t.elapsed().as_secs_f64() * 1e3);
    }
    drop(exec);
    drop(csg);
    drop(ctx);
    // SAFETY: idle; nothing uses these objects.
    unsafe {
        d.destroy_fence(fence, None);
        d.destroy_command_pool(pool, None);
        for (img, mem, view) in [color, depth] {
            d.destroy_image_view(view, None);
            d.destroy_image(img, None);
            d.free_memory(mem, None);
        }
    }
    // SAFETY: idle; every object made from the device was destroyed above.
    unsafe { host.finish() }?;
    Ok([median(standalone), median(embedded), median(record)])
}

/// The host set-ups the example (and its test) runs: colour and depth formats,
/// both depth conventions, one to three frames in flight; the bitten box and
/// the drilled one.
pub fn setups() -> Vec<(String, Setup)> {
    use vk::Format as F;
    // The last field: the box bitten at four corners, whose depth-equal
    // pieces follow the depth merge (the others write their own depth).
    let cases = [
        (F::R8G8B8A8_UNORM, F::D32_SFLOAT, false, 1, 1, false),
        (F::R8G8B8A8_UNORM, F::D32_SFLOAT, true, 1, 1, false),
        (F::B8G8R8A8_UNORM, F::D24_UNORM_S8_UINT, false, 2, 4, true),
        (F::B8G8R8A8_SRGB, F::D32_SFLOAT_S8_UINT, true, 3, 5, false),
        (F::R8G8B8A8_SRGB, F::D24_UNORM_S8_UINT, true, 2, 3, true),
        (F::B8G8R8A8_UNORM, F::D32_SFLOAT_S8_UINT, false, 2, 3, false),
    ];
    cases
        .into_iter()
        .map(|(color, depth, reversed_z, inflight, frames, bites)| {
            let name = format!(
                "{color:?}+{depth:?} {} z, {inflight} in flight{}",
                if reversed_z { "reversed" } else { "standard" },
                if bites { ", four bites" } else { "" }
            );
            let setup = Setup {
                color_format: color,
                depth_format: depth,
                frames_in_flight: inflight,
                frames,
                bites,
                ..Setup::new([160, 120], reversed_z)
            };
            (name, setup)
        })
        // The drilled box, whose pieces outside its pits skip the check of
        // the output depth (`plan::cut_away`), both depth conventions.
        .chain([false, true].map(|reversed_z| {
            let name = format!(
                "R8G8B8A8_UNORM+D32_SFLOAT {} z, 1 in flight, drilled",
                if reversed_z { "reversed" } else { "standard" }
            );
            // Large enough that a free piece pays for its draw.
            let setup = Setup {
                drilled: true,
                ..Setup::new([480, 360], reversed_z)
            };
            (name, setup)
        }))
        // A 4× multisampled host (colour, depth and peeltrim's images), the
        // host resolving its colour: the floor cutting through the CSG hides
        // it per sample, and the edges against it are antialiased.
        .chain(
            [(false, Algo::Goldfeather), (true, Algo::CstI)].map(|(reversed_z, algo)| {
                let name = format!(
                    "R8G8B8A8_UNORM+D32_SFLOAT {} z, 4 samples, {algo}",
                    if reversed_z { "reversed" } else { "standard" }
                );
                let setup = Setup {
                    samples: 4,
                    algo,
                    frames: 2,
                    ..Setup::new([160, 120], reversed_z)
                };
                (name, setup)
            }),
        )
        .collect()
}

/// What `Embedder::record` answers for host formats `color` and `depth`:
/// `Some(message)` for `VkError::HostFormat`, returned before anything is
/// recorded (the views, null here, are never touched), `None` if accepted.
pub fn record_with_formats(color: vk::Format, depth: vk::Format) -> Result<Option<String>, String> {
    MESSAGES.lock().expect("messages").clear();
    let host = Host::new()?;
    let d = &host.device;
    let result = (|| {
        // SAFETY: the device outlives the context (dropped in this closure).
        let ctx = unsafe { host.context() }?;
        let desc = EmbedDesc {
            extent: [32, 32],
            ..EmbedDesc::default()
        };
        let mut csg = host_csg(&ctx, &desc, false, false)?;
        let targets = HostTargets {
            color_view: vk::ImageView::null(),
            color_format: color,
            depth_view: vk::ImageView::null(),
            depth_format: depth,
            extent: [32, 32],
        };
        let pci = vk::CommandPoolCreateInfo::default().queue_family_index(host.family);
        // SAFETY: valid create info.
        let pool = unsafe { d.create_command_pool(&pci, None) }.expect("pool");
        let ai = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .command_buffer_count(1);
        // SAFETY: the pool is live.
        let cmd = unsafe { d.allocate_command_buffers(&ai) }.expect("cmd")[0];
        // SAFETY: a fresh command buffer.
        unsafe { d.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default()) }
            .expect("begin");
        // SAFETY: `cmd` records outside rendering; a format error returns before
        // any command (the null views are never used then), and the buffer is
        // never submitted.
        let answer = match unsafe { csg.recorder().record(cmd, &targets) } {
            Ok(_) => Err("accepted (with null views)".to_string()),
            Err(e @ peeltrim::vk::VkError::HostFormat { .. }) => Ok(Some(e.to_string())),
            Err(e) => Err(format!("not a format error: {e}")),
        };
        // SAFETY: never submitted; freeing the pool frees the buffer.
        unsafe { d.destroy_command_pool(pool, None) };
        answer
    })();
    // SAFETY: nothing was submitted; every object of the closure is dropped.
    unsafe { host.finish() }?;
    result
}

#[allow(dead_code)]
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--bench") {
        println!("scene,standalone_frame_ms,embedded_frame_ms,ratio,embedded_record_ms");
        for path in &args[1..] {
            match bench(std::path::Path::new(path), 15) {
                Ok([s, e, r]) => println!("{path},{s:.3},{e:.3},{:.3},{r:.3}", e / s),
                Err(e) => println!("{path},not run: {e}"),
            }
        }
        return;
    }
    let mut failed = false;
    for (name, setup) in setups() {
        match run(&setup) {
            Ok(Report {
                skipped: Some(why), ..
            }) => println!("{name}: not run: {why}"),
            Ok(r) => {
                let ok = r.validation.is_empty()
                    && r.interior_match() >= 0.9995
                    && r.floor_hides_csg > 0
                    && r.csg_hides_floor > 0
                    && (setup.samples == 1 || r.floor_edges_antialiased());
                println!(
                    "{name}: {:.4}% of {} interior pixels match the reference composite; floor hides CSG {}/{}, CSG hides floor {}/{}; loop counts {:?} -> {:?}; depth-equal draws {} ({} writing their depth, {} outside their cutters with no check of the output depth); {} validation messages",
                    r.interior_match() * 100.0, r.interior, r.floor_hides_csg_ok, r.floor_hides_csg, r.csg_hides_floor_ok, r.csg_hides_floor, r.first_counts, r.last_counts, r.shade_fixed_draws, r.shade_written_draws, r.shade_uncut_draws, r.validation.len()
                );
                if setup.samples > 1 {
                    println!(
                        "  edges against the floor: {} of {} within 1/8 of the reference's resolved colour, {} blended",
                        r.floor_edges_ok, r.floor_edges, r.floor_edges_blended
                    );
                }
                for m in &r.validation {
                    println!("  validation: {m}");
                }
                failed |= !ok;
            }
            Err(e) => {
                eprintln!("embed example: {name}: {e}");
                failed = true;
            }
        }
    }
    if failed {
        std::process::exit(1);
    }
}
