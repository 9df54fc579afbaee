//! The embedding's composite pass (`vk::embed`), the fallback of the direct
//! final shade (`vk::exec::record::host`; `vk::embed::HostPath` says when it is
//! used): one full-screen draw, inside the host's own dynamic rendering of its
//! colour and depth attachments, that writes peeltrim's colour and depth where
//! the CSG covers the pixel, under the host's depth test. Also the host formats
//! both paths support ([`COLOR_FORMATS`], [`DEPTH_FORMATS`]) and the typed error
//! for the others.

use ash::vk;

use super::error::{Check, VkError};
use super::instance::Shared;
use super::pipeline::{graphics_pipeline, Graphics};
use super::sync;
use super::HostTargets;
use crate::plan::usage::Usage;

const FRAG: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/composite.frag.spv"));
/// The variant for an `_SRGB` host colour format (decodes before writing).
const FRAG_SRGB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/composite.frag.host_srgb.spv"));

/// Host colour formats peeltrim writes into (directly or by the composite).
/// peeltrim's colour is sRGB-encoded; it is written as those values into UNORM
/// and float formats, and decoded to linear for the `_SRGB` formats (whose
/// hardware encoding then stores the same bytes). Other formats (integer, fewer than three
/// channels, compressed) give [`VkError::HostFormat`].
pub const COLOR_FORMATS: &[vk::Format] = &[
    vk::Format::R8G8B8A8_UNORM,
    vk::Format::R8G8B8A8_SRGB,
    vk::Format::B8G8R8A8_UNORM,
    vk::Format::B8G8R8A8_SRGB,
    vk::Format::A8B8G8R8_UNORM_PACK32,
    vk::Format::A8B8G8R8_SRGB_PACK32,
    vk::Format::A2B10G10R10_UNORM_PACK32,
    vk::Format::A2R10G10B10_UNORM_PACK32,
    vk::Format::R16G16B16A16_UNORM,
    vk::Format::R16G16B16A16_SFLOAT,
    vk::Format::R32G32B32A32_SFLOAT,
    vk::Format::B10G11R11_UFLOAT_PACK32,
];

/// Host depth formats peeltrim writes into (their depth aspect; a stencil
/// aspect is left untouched). peeltrim's depth is 32-bit float; a UNORM host
/// buffer stores it rounded to its precision, as it does the host's own depths.
pub const DEPTH_FORMATS: &[vk::Format] = &[
    vk::Format::D16_UNORM,
    vk::Format::X8_D24_UNORM_PACK32,
    vk::Format::D32_SFLOAT,
    vk::Format::D16_UNORM_S8_UINT,
    vk::Format::D24_UNORM_S8_UINT,
    vk::Format::D32_SFLOAT_S8_UINT,
];

/// Whether a colour format stores sRGB-encoded values (the composite decodes).
pub fn is_srgb(format: vk::Format) -> bool {
    matches!(
        format,
        vk::Format::R8G8B8A8_SRGB | vk::Format::B8G8R8A8_SRGB | vk::Format::A8B8G8R8_SRGB_PACK32
    )
}

/// Checks the host's formats against the lists above and the device's optimal
/// tiling features (colour attachment, depth-stencil attachment).
pub(crate) fn check_host_formats(
    shared: &Shared,
    color: vk::Format,
    depth: vk::Format,
) -> Result<(), VkError> {
    let names = |l: &[vk::Format]| {
        l.iter()
            .map(|f| format!("{f:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let checks = [
        (
            "colour",
            color,
            COLOR_FORMATS,
            vk::FormatFeatureFlags::COLOR_ATTACHMENT,
        ),
        (
            "depth",
            depth,
            DEPTH_FORMATS,
            vk::FormatFeatureFlags::DEPTH_STENCIL_ATTACHMENT,
        ),
    ];
    for (attachment, format, list, feature) in checks {
        let problem = if !list.contains(&format) {
            format!(
                "not a {attachment} format peeltrim writes: use one of {}",
                names(list)
            )
        } else {
            // SAFETY: physical device of this instance; plain query.
            let fp = unsafe {
                shared
                    .instance
                    .get_physical_device_format_properties(shared.physical, format)
            };
            if fp.optimal_tiling_features.contains(feature) {
                continue;
            }
            format!("the device cannot render to it with optimal tiling ({feature:?}): use another of {}", names(list))
        };
        return Err(VkError::HostFormat {
            attachment,
            format,
            problem,
        });
    }
    Ok(())
}

/// A descriptor pool with room for one set of `layout` (three sampled images
/// and a sampler, as [`write_output_set`] writes them), and that set.
pub(crate) fn output_set(
    device: &ash::Device,
    layout: vk::DescriptorSetLayout,
) -> Result<(vk::DescriptorPool, vk::DescriptorSet), VkError> {
    let sizes = [
        vk::DescriptorPoolSize {
            ty: vk::DescriptorType::SAMPLED_IMAGE,
            descriptor_count: 3,
        },
        vk::DescriptorPoolSize {
            ty: vk::DescriptorType::SAMPLER,
            descriptor_count: 1,
        },
    ];
    let pci = vk::DescriptorPoolCreateInfo::default()
        .max_sets(1)
        .pool_sizes(&sizes);
    // SAFETY: valid create info on a live device.
    let pool =
        unsafe { device.create_descriptor_pool(&pci, None) }.check("vkCreateDescriptorPool")?;
    let layouts = [layout];
    let ai = vk::DescriptorSetAllocateInfo::default()
        .descriptor_pool(pool)
        .set_layouts(&layouts);
    // SAFETY: the pool has room for this one set of a live layout.
    match unsafe { device.allocate_descriptor_sets(&ai) }.check("vkAllocateDescriptorSets") {
        Ok(sets) => Ok((pool, sets[0])),
        Err(e) => {
            // SAFETY: the pool holds no set and nothing uses it.
            unsafe { device.destroy_descriptor_pool(pool, None) };
            Err(e)
        }
    }
}

/// Inside a rendering block of `extent`: binds a full-screen pass's pipeline
/// and its one descriptor set (set 0 of `layout`), whose images the caller has
/// made readable, and sets the viewport to the whole extent and the scissor
/// (within it). Shared by the composite and the shadow pass (`vk::shadow`).
/// Points `set` at three sampled images — colour, ids, depth, bindings 0–2,
/// in the sampled layout — and `sampler` (binding 3): the layout of the
/// composite and resolve passes.
///
/// # Safety
/// `set`, the views and the sampler are live, and no pending command buffer
/// uses `set`.
pub(crate) unsafe fn write_output_set(
    device: &ash::Device,
    set: vk::DescriptorSet,
    views: [vk::ImageView; 3],
    sampler: vk::Sampler,
) {
    let sampled = sync::access(Usage::Sampled).layout;
    let info = |view| {
        [vk::DescriptorImageInfo {
            sampler: vk::Sampler::null(),
            image_view: view,
            image_layout: sampled,
        }]
    };
    let (ci, pi, di) = (info(views[0]), info(views[1]), info(views[2]));
    let si = [vk::DescriptorImageInfo {
        sampler,
        image_view: vk::ImageView::null(),
        image_layout: vk::ImageLayout::UNDEFINED,
    }];
    let infos: [(vk::DescriptorType, &[vk::DescriptorImageInfo]); 4] = [
        (vk::DescriptorType::SAMPLED_IMAGE, &ci),
        (vk::DescriptorType::SAMPLED_IMAGE, &pi),
        (vk::DescriptorType::SAMPLED_IMAGE, &di),
        (vk::DescriptorType::SAMPLER, &si),
    ];
    let writes: Vec<vk::WriteDescriptorSet<'_>> = infos
        .iter()
        .enumerate()
        .map(|(b, (ty, i))| {
            vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(b as u32)
                .descriptor_type(*ty)
                .image_info(i)
        })
        .collect();
    // SAFETY: the caller's: the set, views and sampler are live and the set
    // is not in use.
    unsafe { device.update_descriptor_sets(&writes, &[]) };
}

pub(crate) fn bind_fullscreen(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    (pipeline, layout, set): (vk::Pipeline, vk::PipelineLayout, vk::DescriptorSet),
    extent: vk::Extent2D,
    scissor: vk::Rect2D,
) {
    let viewport = vk::Viewport {
        x: 0.0,
        y: 0.0,
        width: extent.width as f32,
        height: extent.height as f32,
        min_depth: 0.0,
        max_depth: 1.0,
    };
    // SAFETY: inside a rendering block whose formats the pipeline was made for.
    unsafe { device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline) };
    // SAFETY: the set matches set 0 of `layout`; its images are readable (the
    // caller's barriers).
    unsafe {
        device.cmd_bind_descriptor_sets(
            cmd,
            vk::PipelineBindPoint::GRAPHICS,
            layout,
            0,
            &[set],
            &[],
        )
    };
    // SAFETY: dynamic state of the bound pipeline.
    unsafe { device.cmd_set_viewport(cmd, 0, &[viewport]) };
    // SAFETY: as above; the rectangle lies within the attachments.
    unsafe { device.cmd_set_scissor(cmd, 0, &[scissor]) };
}

/// The composite pass's objects, made for one pair of host formats.
pub(super) struct Composite {
    pub(super) formats: (vk::Format, vk::Format),
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    pipeline: vk::Pipeline,
    /// The output views the set points at (colour, ids, depth): rewritten only
    /// when they change, which needs a new plan, when no frame is pending.
    pub(super) views: Option<[vk::ImageView; 3]>,
}

impl Composite {
    pub(super) fn new(
        shared: &Shared,
        formats: (vk::Format, vk::Format),
    ) -> Result<Composite, VkError> {
        let device = &shared.device;
        let binding = super::pipeline::fragment_binding;
        let bindings = [
            binding(0, vk::DescriptorType::SAMPLED_IMAGE),
            binding(1, vk::DescriptorType::SAMPLED_IMAGE),
            binding(2, vk::DescriptorType::SAMPLED_IMAGE),
            binding(3, vk::DescriptorType::SAMPLER),
        ];
        let mut c = Composite {
            formats,
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            pipeline: vk::Pipeline::null(),
            views: None,
        };
        let dci = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid create info on a live device. (Each object made below is
        // destroyed by `Composite::destroy` even when a later step fails.)
        c.set_layout = unsafe { device.create_descriptor_set_layout(&dci, None) }
            .check("vkCreateDescriptorSetLayout")
            .inspect_err(|_| c.destroy(device))?;
        let set_layouts = [c.set_layout];
        let lci = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        // SAFETY: valid create info; the set layout is live.
        c.layout = unsafe { device.create_pipeline_layout(&lci, None) }
            .check("vkCreatePipelineLayout")
            .inspect_err(|_| c.destroy(device))?;
        (c.pool, c.set) = output_set(device, c.set_layout).inspect_err(|_| c.destroy(device))?;
        c.pipeline = c.make_pipeline(shared).inspect_err(|_| c.destroy(device))?;
        Ok(c)
    }

    fn make_pipeline(&self, shared: &Shared) -> Result<vk::Pipeline, VkError> {
        let frag = if is_srgb(self.formats.0) {
            FRAG_SRGB
        } else {
            FRAG
        };
        let depth_stencil = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true);
        super::stages::fullscreen_pipeline(shared, frag, |stages| {
            graphics_pipeline(
                &shared.device,
                &Graphics {
                    stages,
                    vertex_input: &vk::PipelineVertexInputStateCreateInfo::default(),
                    cull: vk::CullModeFlags::NONE,
                    depth_stencil: &depth_stencil,
                    dynamic_states: &[
                        vk::DynamicState::VIEWPORT,
                        vk::DynamicState::SCISSOR,
                        vk::DynamicState::DEPTH_COMPARE_OP,
                    ],
                    color_formats: &[self.formats.0],
                    depth_format: self.formats.1,
                    // Only the depth aspect is written: no stencil attachment.
                    stencil_format: vk::Format::UNDEFINED,
                    layout: self.layout,
                    samples: 1,
                    sample_shading: false,
                    blend: None,
                },
            )
        })
    }

    /// Points the set at the executor's current output images.
    pub(super) fn write_set(
        &self,
        shared: &Shared,
        out: &super::exec::Output,
        sampler: vk::Sampler,
    ) {
        let views = [out.color.1, out.prim.1, out.depth.1];
        // SAFETY: set, views and sampler are live; the set is not in use by a
        // pending command buffer (it changes only with the executor's images,
        // which change only when no frame is pending).
        unsafe { write_output_set(&shared.device, self.set, views, sampler) };
    }

    /// Draws into the host's attachments (the caller has made peeltrim's output
    /// images sampled and the host's attachment writes available).
    pub(super) fn draw(
        &self,
        device: &ash::Device,
        cmd: vk::CommandBuffer,
        t: &HostTargets,
        scissor: vk::Rect2D,
        depth_compare: vk::CompareOp,
    ) {
        let extent = vk::Extent2D {
            width: t.extent[0],
            height: t.extent[1],
        };
        let color = [vk::RenderingAttachmentInfo::default()
            .image_view(t.color_view)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::LOAD)
            .store_op(vk::AttachmentStoreOp::STORE)];
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(t.depth_view)
            .image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::LOAD)
            .store_op(vk::AttachmentStoreOp::STORE);
        let ri = vk::RenderingInfo::default()
            .render_area(extent.into())
            .layer_count(1)
            .color_attachments(&color)
            .depth_attachment(&depth);
        // SAFETY: outside rendering (the caller's contract); the views are the
        // host's attachments in the layouts the contract names.
        unsafe { device.cmd_begin_rendering(cmd, &ri) };
        // The pipeline was made for these formats; the set's images are in
        // `SHADER_READ_ONLY_OPTIMAL` (barrier above).
        bind_fullscreen(
            device,
            cmd,
            (self.pipeline, self.layout, self.set),
            extent,
            scissor,
        );
        // SAFETY: dynamic state of the bound pipeline.
        unsafe { device.cmd_set_depth_compare_op(cmd, depth_compare) };
        // SAFETY: pipeline, set and state bound; the vertex shader needs no buffer.
        unsafe { device.cmd_draw(cmd, 3, 1, 0, 0) };
        // SAFETY: closes the block begun above.
        unsafe { device.cmd_end_rendering(cmd) };
    }

    pub(super) fn destroy(&self, device: &ash::Device) {
        // SAFETY (each call): no pending command buffer uses these objects (the
        // embedder is dropped or remade only when the host has no frame of it
        // pending); null handles are ignored.
        unsafe { device.destroy_pipeline(self.pipeline, None) };
        // SAFETY: as above.
        unsafe { device.destroy_descriptor_pool(self.pool, None) };
        // SAFETY: as above.
        unsafe { device.destroy_pipeline_layout(self.layout, None) };
        // SAFETY: as above.
        unsafe { device.destroy_descriptor_set_layout(self.set_layout, None) };
    }
}
