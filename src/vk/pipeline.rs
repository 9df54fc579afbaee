//! Graphics pipelines: one per fragment program and attachment formats with the
//! depth, stencil and cull state dynamic, and variants of them with that state
//! baked in ([`RasterState`], `Pipelines::get_fixed`; `vk::exec::state` says
//! why). The scissor is dynamic in all of them: it changes at nearly every draw.

use std::collections::HashMap;
use std::io::Cursor;
use std::sync::Arc;

use ash::vk;

use super::conv::StencilFaceOps;
use super::cpu_clock::CpuInstant;
use super::error::{Check, VkError};
use super::instance::Shared;

/// The fragment program of a pipeline (the plan's `Fragment` without its operands,
/// plus the executor's internal depth copy).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FragmentKind {
    None,
    Shade,
    /// `Shade` drawn into an embedding host's colour and depth attachments
    /// (`vk::exec::record::host`): colour only, the depth attachment bound
    /// without its stencil aspect; a one-primitive product's depth-equal
    /// final-shade draw, which needs no check of the output depth.
    ShadeHost,
    /// `ShadeHost` for an `_SRGB` host colour format.
    ShadeHostSrgb,
    Paint,
    Background,
    Peel,
    PeelShade,
    /// Peel with a tolerance: behind the previous layer by more than eps (`color.x`).
    PeelTolerant,
    WriteDepth,
    DepthFromTexture,
    /// `DepthFromTexture` into an embedding host's depth attachment, its colour
    /// attachment bound but not written (`vk::exec::record::host`'s depth merge).
    DepthFromTextureHost,
    ShadeNearDepth,
    /// `ShadeNearDepth` drawn into an embedding host's colour and depth
    /// attachments (`vk::exec::record::host`): colour only, the visible depth
    /// written, the depth attachment bound without its stencil aspect.
    ShadeNearDepthHost,
    /// `ShadeNearDepthHost` for an `_SRGB` host colour format: decodes the
    /// colour (sRGB-encoded) so that the format's encoding stores it unchanged.
    ShadeNearDepthHostSrgb,
    NearerThan,
    /// `NearerThan`'s complement (`Fragment::BehindThan`): SCS's clip by back faces.
    BehindThan,
    /// The tie rule's compare as the depth test (`Fragment::TieDepth`): the
    /// fragment depth moved by the tolerance, no texture.
    TieDepth,
    /// SCS's clip and merge in one draw (`Fragment::MergeBehind`).
    MergeBehind,
    /// `MergeBehind` with an exact compare (eps 0): one texel fetch, no
    /// derivatives (`plan::tie_free`).
    MergeBehindExact,
    ShadeAtDepth,
    /// `ShadeAtDepth` drawn into an embedding host's colour and depth
    /// attachments, the texture being the output depth-stencil's depth
    /// (`vk::exec::record::host`): colour only, the raster depth written.
    ShadeAtDepthHost,
    /// `ShadeAtDepthHost` for an `_SRGB` host colour format.
    ShadeAtDepthHostSrgb,
    /// `ShadeAtDepthHost` with no depth merge before it: tested against the
    /// host's depth with equality (before the shader on lavapipe), its raster
    /// depth written where it is the visible face (`HOST_WRITE`).
    ShadeAtDepthHostWrite,
    /// `ShadeAtDepthHostWrite` for an `_SRGB` host colour format.
    ShadeAtDepthHostWriteSrgb,
    /// `ShadeAtDepth` without colour: depth only.
    DepthAtDepth,
    /// Samples the depth aspect of a depth-stencil image into a depth texture.
    CopyDepth,
    /// The edge map from the normal buffer (set 0) and a depth buffer (set 1).
    Edges,
    /// A peeled layer blended front to back into the accumulation target
    /// (colour: set 0, ids: set 2, opacities: set 3; Hable & Rossignac §6).
    Accumulate,
}

impl FragmentKind {
    /// Whether the program writes a colour output. One that does not runs in
    /// a block with colour attachments with every colour write masked
    /// (`vk::exec::record::ahead`).
    pub fn writes_color(self) -> bool {
        !matches!(
            self,
            FragmentKind::None
                | FragmentKind::DepthFromTexture
                | FragmentKind::DepthFromTextureHost
                | FragmentKind::NearerThan
                | FragmentKind::BehindThan
                | FragmentKind::TieDepth
                | FragmentKind::MergeBehind
                | FragmentKind::MergeBehindExact
                | FragmentKind::DepthAtDepth
        )
    }

    /// The variant writing the normal buffer, for those that have one.
    fn spirv_normals(self) -> Option<&'static [u8]> {
        macro_rules! spv {
            ($f:literal) => {
                Some(include_bytes!(concat!(
                    env!("OUT_DIR"),
                    "/",
                    $f,
                    ".normals.spv"
                )))
            };
        }
        match self {
            FragmentKind::Shade => spv!("shade.frag"),
            FragmentKind::Paint => spv!("paint.frag"),
            FragmentKind::Background => spv!("background.frag"),
            FragmentKind::PeelShade => spv!("peel_shade.frag"),
            FragmentKind::ShadeNearDepth => spv!("shade_near_depth.frag"),
            FragmentKind::ShadeAtDepth => spv!("shade_at_depth.frag"),
            _ => None,
        }
    }

    /// The multisampled variant (`MS`, `shaders/depth_tex.glsl`) of the
    /// programs that sample a depth texture: each fetch reads the
    /// invocation's own sample. `None` for those that sample none.
    fn spirv_ms(self) -> Option<&'static [u8]> {
        macro_rules! spv {
            ($f:literal) => {
                Some(include_bytes!(concat!(env!("OUT_DIR"), "/", $f, ".ms.spv")))
            };
        }
        // The host variants' multisampled twins (`host_ms`, ...).
        macro_rules! host {
            ($f:literal) => {
                Some(include_bytes!(concat!(env!("OUT_DIR"), "/", $f, "_ms.spv")))
            };
        }
        match self {
            FragmentKind::Peel => spv!("peel.frag"),
            FragmentKind::PeelShade => spv!("peel_shade.frag"),
            FragmentKind::PeelTolerant => spv!("peel_tolerant.frag"),
            FragmentKind::DepthFromTexture => spv!("depth_from_texture.frag"),
            FragmentKind::ShadeNearDepth => spv!("shade_near_depth.frag"),
            FragmentKind::NearerThan => spv!("nearer_than.frag"),
            FragmentKind::BehindThan => spv!("behind_than.frag"),
            FragmentKind::MergeBehind => spv!("merge_behind.frag"),
            FragmentKind::MergeBehindExact => spv!("merge_behind_exact.frag"),
            FragmentKind::ShadeAtDepth => spv!("shade_at_depth.frag"),
            FragmentKind::DepthAtDepth => spv!("depth_at_depth.frag"),
            FragmentKind::CopyDepth => spv!("copy_depth.frag"),
            FragmentKind::DepthFromTextureHost => host!("depth_from_texture.frag.host"),
            FragmentKind::ShadeNearDepthHost => host!("shade_near_depth.frag.host"),
            FragmentKind::ShadeNearDepthHostSrgb => host!("shade_near_depth.frag.host_srgb"),
            FragmentKind::ShadeAtDepthHost => host!("shade_at_depth.frag.host"),
            FragmentKind::ShadeAtDepthHostSrgb => host!("shade_at_depth.frag.host_srgb"),
            FragmentKind::ShadeAtDepthHostWrite => host!("shade_at_depth.frag.host_write"),
            FragmentKind::ShadeAtDepthHostWriteSrgb => {
                host!("shade_at_depth.frag.host_write_srgb")
            }
            _ => None,
        }
    }

    /// Whether a multisampled pipeline of the program runs once per sample
    /// (`sampleShadingEnable`, `minSampleShading` 1): every program whose
    /// output depends on the fragment's own depth or position — it samples a
    /// depth texture, writes depth, writes a depth into a texture, or
    /// discards by depth. The shading programs that only write colour and ids
    /// run once per pixel; the depth and stencil tests decide per sample
    /// which samples they reach.
    pub fn per_sample(self) -> bool {
        !matches!(
            self,
            FragmentKind::None
                | FragmentKind::Shade
                | FragmentKind::ShadeHost
                | FragmentKind::ShadeHostSrgb
                | FragmentKind::Paint
                | FragmentKind::Background
        )
    }

    /// The push-constant fields the program reads beyond `flags`, directly or
    /// as `shaders/draw.glsl`'s flat copies from `mesh.vert` (the table the
    /// recorder skips pushes by; `tests::reads_match_the_shader_sources`
    /// checks it against `shaders/`).
    pub fn reads(self) -> Reads {
        let (color, prim, view) = match self {
            FragmentKind::Shade
            | FragmentKind::ShadeHost
            | FragmentKind::ShadeHostSrgb
            | FragmentKind::Paint
            | FragmentKind::PeelShade
            | FragmentKind::ShadeNearDepth
            | FragmentKind::ShadeNearDepthHost
            | FragmentKind::ShadeNearDepthHostSrgb
            | FragmentKind::ShadeAtDepth
            | FragmentKind::ShadeAtDepthHost
            | FragmentKind::ShadeAtDepthHostSrgb
            | FragmentKind::ShadeAtDepthHostWrite
            | FragmentKind::ShadeAtDepthHostWriteSrgb => (true, true, false),
            FragmentKind::Background
            | FragmentKind::PeelTolerant
            | FragmentKind::NearerThan
            | FragmentKind::BehindThan
            | FragmentKind::TieDepth
            | FragmentKind::MergeBehind => (true, false, false),
            FragmentKind::Edges => (true, false, true),
            FragmentKind::None
            | FragmentKind::Peel
            | FragmentKind::WriteDepth
            | FragmentKind::DepthFromTexture
            | FragmentKind::MergeBehindExact
            | FragmentKind::DepthFromTextureHost
            | FragmentKind::DepthAtDepth
            | FragmentKind::CopyDepth
            | FragmentKind::Accumulate => (false, false, false),
        };
        Reads {
            mvp: false,
            view,
            color,
            prim,
        }
    }

    /// Whether the program reads `shaders/mesh.vert`'s interpolated outputs
    /// (world position, normal, headlight ray). One that does not runs with
    /// the vertex shader's `FLAT` variant, which computes the same position
    /// and stores only the flat copies of the push constants (llvmpipe stores
    /// every output of every vertex on its queue thread, read or not): the
    /// shading programs, which are those that read `prim`
    /// (`tests::interpolated_matches_the_shader_sources` checks this).
    pub fn interpolated(self) -> bool {
        // The shading programs: the ones that write the primitive id.
        self.reads().prim
    }

    fn spirv(self, normals: bool, ms: bool) -> &'static [u8] {
        if ms {
            if let Some(code) = self.spirv_ms() {
                return code;
            }
        }
        if normals {
            return self
                .spirv_normals()
                .unwrap_or_else(|| panic!("{self:?} writes no colour, so no normals"));
        }
        macro_rules! spv {
            ($f:literal) => {
                include_bytes!(concat!(env!("OUT_DIR"), "/", $f, ".spv"))
            };
        }
        match self {
            FragmentKind::None => spv!("none.frag"),
            FragmentKind::Shade => spv!("shade.frag"),
            FragmentKind::ShadeHost => spv!("shade.frag.host"),
            FragmentKind::ShadeHostSrgb => spv!("shade.frag.host_srgb"),
            FragmentKind::Paint => spv!("paint.frag"),
            FragmentKind::Background => spv!("background.frag"),
            FragmentKind::Peel => spv!("peel.frag"),
            FragmentKind::PeelShade => spv!("peel_shade.frag"),
            FragmentKind::PeelTolerant => spv!("peel_tolerant.frag"),
            FragmentKind::WriteDepth => spv!("write_depth.frag"),
            FragmentKind::DepthFromTexture => spv!("depth_from_texture.frag"),
            FragmentKind::DepthFromTextureHost => spv!("depth_from_texture.frag.host"),
            FragmentKind::ShadeNearDepth => spv!("shade_near_depth.frag"),
            FragmentKind::ShadeNearDepthHost => spv!("shade_near_depth.frag.host"),
            FragmentKind::ShadeNearDepthHostSrgb => spv!("shade_near_depth.frag.host_srgb"),
            FragmentKind::NearerThan => spv!("nearer_than.frag"),
            FragmentKind::BehindThan => spv!("behind_than.frag"),
            FragmentKind::TieDepth => spv!("tie_depth.frag"),
            FragmentKind::MergeBehind => spv!("merge_behind.frag"),
            FragmentKind::MergeBehindExact => spv!("merge_behind_exact.frag"),
            FragmentKind::CopyDepth => spv!("copy_depth.frag"),
            FragmentKind::ShadeAtDepth => spv!("shade_at_depth.frag"),
            FragmentKind::ShadeAtDepthHost => spv!("shade_at_depth.frag.host"),
            FragmentKind::ShadeAtDepthHostSrgb => spv!("shade_at_depth.frag.host_srgb"),
            FragmentKind::ShadeAtDepthHostWrite => spv!("shade_at_depth.frag.host_write"),
            FragmentKind::ShadeAtDepthHostWriteSrgb => {
                spv!("shade_at_depth.frag.host_write_srgb")
            }
            FragmentKind::DepthAtDepth => spv!("depth_at_depth.frag"),
            FragmentKind::Edges => spv!("edges.frag"),
            FragmentKind::Accumulate => spv!("accumulate.frag"),
        }
    }
}

const VERTEX_SPIRV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/mesh.vert.spv"));
/// `mesh.vert` without the interpolated outputs (`FragmentKind::interpolated`).
const VERTEX_FLAT_SPIRV: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/mesh.vert.flat.spv"));

/// Everything that selects a pipeline; plain data, hashable.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct PipelineDesc {
    pub fragment: FragmentKind,
    pub color_formats: Vec<vk::Format>,
    /// The depth-stencil attachment's format; `None` when none is bound.
    pub depth_stencil_format: Option<vk::Format>,
    /// The program's variant that also writes the normal buffer (its last colour
    /// attachment).
    pub normals: bool,
    /// Samples per pixel of the attachments (1, 2, 4 or 8).
    pub samples: u32,
}

/// The depth, stencil and cull state of a draw, in Vulkan's terms: baked into
/// a pipeline variant (`Pipelines::get_fixed`) or recorded as dynamic state
/// (`vk::exec::state`, which maps a plan draw to it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct RasterState {
    pub cull: vk::CullModeFlags,
    pub depth_test: bool,
    pub depth_write: bool,
    pub depth_compare: vk::CompareOp,
    pub stencil_test: bool,
    pub front: StencilFaceOps,
    pub back: StencilFaceOps,
    pub compare_mask: u32,
    pub write_mask: u32,
    pub reference: u32,
}

impl RasterState {
    fn depth_stencil(&self) -> vk::PipelineDepthStencilStateCreateInfo<'static> {
        let face = |o: &StencilFaceOps| vk::StencilOpState {
            fail_op: o.fail,
            pass_op: o.pass,
            depth_fail_op: o.depth_fail,
            compare_op: o.compare,
            compare_mask: self.compare_mask,
            write_mask: self.write_mask,
            reference: self.reference,
        };
        vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(self.depth_test)
            .depth_write_enable(self.depth_write)
            .depth_compare_op(self.depth_compare)
            .stencil_test_enable(self.stencil_test)
            .front(face(&self.front))
            .back(face(&self.back))
            .depth_bounds_test_enable(false)
            .min_depth_bounds(0.0)
            .max_depth_bounds(1.0)
    }
}

/// Most pipeline variants with baked state an executor creates; past them a
/// draw takes the pipeline with dynamic state. The shipped scenes' plans use
/// 5–21 states each; each variant costs a pipeline creation (about 3 ms of CPU
/// on lavapipe) and, there, a vertex-shader compile at its first draw.
pub const MAX_FIXED_PIPELINES: usize = 96;

/// Push constants shared by every shader (`shaders/*`: `Push`). Nothing in them
/// depends on the camera (that is in the uniform buffer of `shaders/camera.glsl`),
/// so recordings survive camera moves; `view` is unused, kept for the layout.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PushConstants {
    pub mvp: [f32; 16],
    pub view: [f32; 4],
    pub color: [f32; 4],
    pub prim: u32,
    pub flags: u32,
    /// NDC step of the emulated vertex-snapping grid (x, y); zeros: off
    /// ([`super::RoundingEmulation`]).
    pub snap: [f32; 2],
}

/// Which [`PushConstants`] fields a draw's shaders read beyond `flags` and
/// `snap` (the same for every draw of a frame): the others may hold anything.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Reads {
    /// The full-screen quad's matrix (meshes take the camera's).
    pub mvp: bool,
    pub view: bool,
    pub color: bool,
    pub prim: bool,
}

impl Reads {
    pub const ALL: Reads = Reads {
        mvp: true,
        view: true,
        color: true,
        prim: true,
    };
}

pub const PUSH_SIZE: u32 = std::mem::size_of::<PushConstants>() as u32;
/// `PushConstants::flags` bit: depths are reversed (near 1, far 0).
pub const FLAG_REVERSED_Z: u32 = 1;
/// `PushConstants::flags` bit: the final shade's tie-rule draws write their
/// raster depth, not the plane depth at the pixel centre
/// (`shaders/shade_near_depth.frag`): set where the shade's depth-equal draws
/// run (a device that does not snap, where the two agree to f32 rounding), so
/// that a pixel gets the same depth whichever of the two shaded it
/// (`plan::tie_zones`).
pub const FLAG_RASTER_DEPTH: u32 = 2;
/// The `firstInstance` of a draw of the full-screen quad, which
/// `shaders/mesh.vert` transforms by the push constants' `mvp` and leaves
/// unsnapped; meshes are drawn with instance 0 and the camera's matrix. Told
/// by the instance rather than a push-constant flag so that alternating mesh
/// and full-screen draws (a CST trim) can share one push.
pub const QUAD_INSTANCE: u32 = 1;
/// `PushConstants::flags` bits 8..16: the device's subpixel precision bits, from
/// which the shaders' tie tolerance derives its slope term (`plan::tie`).
pub const FLAG_SUBPIXEL_SHIFT: u32 = 8;

/// The flags word: reversed Z and the subpixel precision (clamped to 4..=16:
/// 4 is the specification's minimum).
pub fn pipeline_flags(reversed_z: bool, subpixel_bits: u32) -> u32 {
    let reversed = if reversed_z { FLAG_REVERSED_Z } else { 0 };
    reversed | subpixel_bits.clamp(4, 16) << FLAG_SUBPIXEL_SHIFT
}

impl PushConstants {
    pub fn bytes(&self) -> [u8; PUSH_SIZE as usize] {
        // Field by field in declaration order (`repr(C)`, all 4-byte words):
        // recorded at most once per draw, so no iterator chain.
        let mut out = [0u8; PUSH_SIZE as usize];
        let mut at = 0;
        let mut put = |w: u32| {
            out[at..at + 4].copy_from_slice(&w.to_ne_bytes());
            at += 4;
        };
        for f in self.mvp.iter().chain(&self.view).chain(&self.color) {
            put(f.to_bits());
        }
        put(self.prim);
        put(self.flags);
        put(self.snap[0].to_bits());
        put(self.snap[1].to_bits());
        out
    }
}

/// Vertex layout: position then flat face normal, both `vec3` (non-indexed).
pub const VERTEX_STRIDE: u32 = 24;

/// Shader modules, the shared layouts, a sampler and the pipeline cache.
pub struct Pipelines {
    shared: Arc<Shared>,
    vertex: vk::ShaderModule,
    /// `mesh.vert`'s `FLAT` variant, for programs that read no interpolated output.
    vertex_flat: vk::ShaderModule,
    /// By program, normals variant and multisampled variant.
    fragments: HashMap<(FragmentKind, bool, bool), vk::ShaderModule>,
    pub(crate) sampler: vk::Sampler,
    pub(crate) set_layout: vk::DescriptorSetLayout,
    /// Set 1: the camera's uniform buffer.
    pub(crate) camera_set_layout: vk::DescriptorSetLayout,
    pub(crate) layout: vk::PipelineLayout,
    cache: HashMap<PipelineDesc, vk::Pipeline>,
    /// Variants with baked state (at most [`MAX_FIXED_PIPELINES`]).
    fixed: HashMap<(PipelineDesc, RasterState), vk::Pipeline>,
    /// Pipelines created so far, and the calling thread's CPU time creating them
    /// (drivers compile the shaders then: lavapipe runs LLVM, milliseconds each).
    pub(crate) created: u32,
    pub(crate) create_ms: f64,
}

/// One descriptor of type `ty` at `binding`, read by the fragment shader (the
/// full-screen passes' textures, sampler and uniforms).
pub(crate) fn fragment_binding(
    binding: u32,
    ty: vk::DescriptorType,
) -> vk::DescriptorSetLayoutBinding<'static> {
    vk::DescriptorSetLayoutBinding::default()
        .binding(binding)
        .descriptor_type(ty)
        .descriptor_count(1)
        .stage_flags(vk::ShaderStageFlags::FRAGMENT)
}

pub(crate) fn shader_module(shared: &Shared, bytes: &[u8]) -> Result<vk::ShaderModule, VkError> {
    let words = ash::util::read_spv(&mut Cursor::new(bytes))
        .map_err(|e| VkError::Plan(format!("embedded SPIR-V unreadable: {e}")))?;
    let ci = vk::ShaderModuleCreateInfo::default().code(&words);
    // SAFETY: the words are SPIR-V produced and validated by naga in build.rs.
    unsafe { shared.device.create_shader_module(&ci, None) }.check("vkCreateShaderModule")
}

impl Pipelines {
    pub(crate) fn new(shared: &Arc<Shared>) -> Result<Pipelines, VkError> {
        let mut p = Pipelines {
            shared: shared.clone(),
            vertex: vk::ShaderModule::null(),
            vertex_flat: vk::ShaderModule::null(),
            fragments: HashMap::new(),
            sampler: vk::Sampler::null(),
            set_layout: vk::DescriptorSetLayout::null(),
            camera_set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            cache: HashMap::new(),
            fixed: HashMap::new(),
            created: 0,
            create_ms: 0.0,
        };
        p.vertex = shader_module(shared, VERTEX_SPIRV)?;
        p.vertex_flat = shader_module(shared, VERTEX_FLAT_SPIRV)?;
        let sci = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE);
        // SAFETY: valid create info on a live device.
        p.sampler = unsafe { shared.device.create_sampler(&sci, None) }.check("vkCreateSampler")?;
        let bindings = [
            fragment_binding(0, vk::DescriptorType::SAMPLED_IMAGE),
            fragment_binding(1, vk::DescriptorType::SAMPLER),
        ];
        let dci = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
        // SAFETY: valid create info on a live device.
        p.set_layout = unsafe { shared.device.create_descriptor_set_layout(&dci, None) }
            .check("vkCreateDescriptorSetLayout")?;
        let ranges = [vk::PushConstantRange {
            stage_flags: vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT,
            offset: 0,
            size: PUSH_SIZE,
        }];
        let camera = [vk::DescriptorSetLayoutBinding::default()
            .binding(0)
            .descriptor_type(vk::DescriptorType::UNIFORM_BUFFER)
            .descriptor_count(1)
            .stage_flags(vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT)];
        let cci = vk::DescriptorSetLayoutCreateInfo::default().bindings(&camera);
        // SAFETY: valid create info on a live device.
        p.camera_set_layout = unsafe { shared.device.create_descriptor_set_layout(&cci, None) }
            .check("vkCreateDescriptorSetLayout")?;
        // Set 0: the image a program samples; set 1: the camera; sets 2 and 3
        // (the same layout as set 0): the edge and accumulate passes' other
        // images.
        let set_layouts = [
            p.set_layout,
            p.camera_set_layout,
            p.set_layout,
            p.set_layout,
        ];
        let lci = vk::PipelineLayoutCreateInfo::default()
            .set_layouts(&set_layouts)
            .push_constant_ranges(&ranges);
        // SAFETY: valid create info; the set layout is live.
        p.layout = unsafe { shared.device.create_pipeline_layout(&lci, None) }
            .check("vkCreatePipelineLayout")?;
        Ok(p)
    }

    /// The pipeline for `desc` with dynamic depth, stencil and cull state,
    /// created on first use.
    pub(crate) fn get(&mut self, desc: &PipelineDesc) -> Result<vk::Pipeline, VkError> {
        if let Some(&p) = self.cache.get(desc) {
            return Ok(p);
        }
        let pipeline = self.create_timed(desc, None)?;
        self.cache.insert(desc.clone(), pipeline);
        Ok(pipeline)
    }

    /// The variant of `desc` with `state` baked in, created on first use;
    /// `None` once [`MAX_FIXED_PIPELINES`] exist and this one does not (the
    /// caller then uses [`Self::get`] and sets the state dynamically).
    pub(crate) fn get_fixed(
        &mut self,
        desc: &PipelineDesc,
        state: &RasterState,
    ) -> Result<Option<vk::Pipeline>, VkError> {
        let key = (desc.clone(), *state);
        if let Some(&p) = self.fixed.get(&key) {
            return Ok(Some(p));
        }
        if self.fixed.len() >= MAX_FIXED_PIPELINES {
            return Ok(None);
        }
        let pipeline = self.create_timed(desc, Some(state))?;
        self.fixed.insert(key, pipeline);
        Ok(Some(pipeline))
    }

    /// Creates the pipeline of `desc` (with `state` baked in, or dynamic),
    /// counting it and its CPU time.
    fn create_timed(
        &mut self,
        desc: &PipelineDesc,
        state: Option<&RasterState>,
    ) -> Result<vk::Pipeline, VkError> {
        let t = CpuInstant::now();
        let ms = desc.samples > 1;
        let key = (desc.fragment, desc.normals, ms);
        let fragment = match self.fragments.get(&key) {
            Some(&m) => m,
            None => {
                let m = shader_module(&self.shared, desc.fragment.spirv(desc.normals, ms))?;
                self.fragments.insert(key, m);
                m
            }
        };
        let pipeline = self.create(desc, fragment, state)?;
        self.created += 1;
        self.create_ms += t.elapsed_ms();
        Ok(pipeline)
    }

    fn create(
        &self,
        desc: &PipelineDesc,
        fragment: vk::ShaderModule,
        state: Option<&RasterState>,
    ) -> Result<vk::Pipeline, VkError> {
        let vertex = match desc.fragment.interpolated() {
            true => self.vertex,
            false => self.vertex_flat,
        };
        let stages = super::stages::vert_frag(vertex, fragment);
        let vb = [vk::VertexInputBindingDescription {
            binding: 0,
            stride: VERTEX_STRIDE,
            input_rate: vk::VertexInputRate::VERTEX,
        }];
        let va = [
            vk::VertexInputAttributeDescription {
                location: 0,
                binding: 0,
                format: vk::Format::R32G32B32_SFLOAT,
                offset: 0,
            },
            vk::VertexInputAttributeDescription {
                location: 1,
                binding: 0,
                format: vk::Format::R32G32B32_SFLOAT,
                offset: 12,
            },
        ];
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(&vb)
            .vertex_attribute_descriptions(&va);
        let depth_stencil = state.map_or_else(
            || {
                vk::PipelineDepthStencilStateCreateInfo::default()
                    .depth_bounds_test_enable(false)
                    .min_depth_bounds(0.0)
                    .max_depth_bounds(1.0)
            },
            RasterState::depth_stencil,
        );
        // Viewport, scissor and front face are dynamic in every pipeline, so
        // binding a variant never invalidates them.
        let mut dynamic_states = vec![
            vk::DynamicState::VIEWPORT,
            vk::DynamicState::SCISSOR,
            vk::DynamicState::FRONT_FACE,
        ];
        if state.is_none() {
            dynamic_states.extend([
                vk::DynamicState::CULL_MODE,
                vk::DynamicState::DEPTH_TEST_ENABLE,
                vk::DynamicState::DEPTH_WRITE_ENABLE,
                vk::DynamicState::DEPTH_COMPARE_OP,
                vk::DynamicState::STENCIL_TEST_ENABLE,
                vk::DynamicState::STENCIL_OP,
                vk::DynamicState::STENCIL_COMPARE_MASK,
                vk::DynamicState::STENCIL_WRITE_MASK,
                vk::DynamicState::STENCIL_REFERENCE,
            ]);
        }
        let ds_format = desc.depth_stencil_format.unwrap_or(vk::Format::UNDEFINED);
        // A host's depth attachment is bound without its stencil (untouched);
        // a depth-only format has none.
        let stencil_format = match desc.fragment {
            FragmentKind::ShadeHost
            | FragmentKind::ShadeHostSrgb
            | FragmentKind::ShadeNearDepthHost
            | FragmentKind::ShadeNearDepthHostSrgb
            | FragmentKind::ShadeAtDepthHost
            | FragmentKind::ShadeAtDepthHostSrgb
            | FragmentKind::ShadeAtDepthHostWrite
            | FragmentKind::ShadeAtDepthHostWriteSrgb
            | FragmentKind::DepthFromTextureHost => vk::Format::UNDEFINED,
            _ if !super::conv::has_stencil(ds_format) => vk::Format::UNDEFINED,
            _ => ds_format,
        };
        graphics_pipeline(
            &self.shared.device,
            &Graphics {
                stages: &stages,
                vertex_input: &vertex_input,
                cull: state.map_or(vk::CullModeFlags::NONE, |s| s.cull),
                depth_stencil: &depth_stencil,
                dynamic_states: &dynamic_states,
                color_formats: &desc.color_formats,
                depth_format: ds_format,
                stencil_format,
                layout: self.layout,
                samples: desc.samples,
                sample_shading: desc.fragment.per_sample(),
                blend: match desc.fragment {
                    FragmentKind::Accumulate => Some(under_blend()),
                    // Depth and stencil only, in a block with colour
                    // attachments (`Recorder::block_for`, the host's depth
                    // merge): they keep their values.
                    k if !k.writes_color() => Some(no_color_writes()),
                    _ => None,
                },
            },
        )
    }
}

/// What differs between peeltrim's graphics pipelines (the executor's and the
/// embedding's composite); [`graphics_pipeline`] fills in the fixed rest:
/// triangle lists, one dynamic viewport and scissor, filled polygons, no
/// blending unless `blend` says, dynamic rendering.
pub(crate) struct Graphics<'a> {
    pub stages: &'a [vk::PipelineShaderStageCreateInfo<'a>],
    pub vertex_input: &'a vk::PipelineVertexInputStateCreateInfo<'a>,
    /// Static cull mode (ignored where `CULL_MODE` is dynamic).
    pub cull: vk::CullModeFlags,
    pub depth_stencil: &'a vk::PipelineDepthStencilStateCreateInfo<'a>,
    pub dynamic_states: &'a [vk::DynamicState],
    pub color_formats: &'a [vk::Format],
    pub depth_format: vk::Format,
    pub stencil_format: vk::Format,
    pub layout: vk::PipelineLayout,
    /// Samples per pixel of the attachments.
    pub samples: u32,
    /// With `samples` > 1: the fragment program runs once per sample.
    pub sample_shading: bool,
    /// Blending of every colour attachment and the blend constants (`None`:
    /// no blending, all channels written).
    pub blend: Option<(vk::PipelineColorBlendAttachmentState, [f32; 4])>,
}

/// Front-to-back blending ("under", the accumulate pass): `dst += (1 −
/// dst.a)·src` for colour (premultiplied by the shader) and coverage alike.
pub(crate) fn under_blend() -> (vk::PipelineColorBlendAttachmentState, [f32; 4]) {
    let a = vk::PipelineColorBlendAttachmentState::default()
        .blend_enable(true)
        .color_write_mask(vk::ColorComponentFlags::RGBA)
        .src_color_blend_factor(vk::BlendFactor::ONE_MINUS_DST_ALPHA)
        .dst_color_blend_factor(vk::BlendFactor::ONE)
        .color_blend_op(vk::BlendOp::ADD)
        .src_alpha_blend_factor(vk::BlendFactor::ONE_MINUS_DST_ALPHA)
        .dst_alpha_blend_factor(vk::BlendFactor::ONE)
        .alpha_blend_op(vk::BlendOp::ADD);
    (a, [0.0; 4])
}

/// No colour attachment written (a depth-stencil-only program in a block
/// with colour attachments).
pub(crate) fn no_color_writes() -> (vk::PipelineColorBlendAttachmentState, [f32; 4]) {
    let a = vk::PipelineColorBlendAttachmentState::default()
        .blend_enable(false)
        .color_write_mask(vk::ColorComponentFlags::empty());
    (a, [0.0; 4])
}

/// Creates the graphics pipeline `g` describes (see [`Graphics`]).
pub(crate) fn graphics_pipeline(
    device: &ash::Device,
    g: &Graphics<'_>,
) -> Result<vk::Pipeline, VkError> {
    let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
        .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
    let viewport = vk::PipelineViewportStateCreateInfo::default()
        .viewport_count(1)
        .scissor_count(1);
    let raster = vk::PipelineRasterizationStateCreateInfo::default()
        .polygon_mode(vk::PolygonMode::FILL)
        .cull_mode(g.cull)
        .line_width(1.0);
    let multisample = vk::PipelineMultisampleStateCreateInfo::default()
        .rasterization_samples(super::samples::flag(g.samples))
        .sample_shading_enable(g.samples > 1 && g.sample_shading)
        .min_sample_shading(1.0);
    let (each, constants) = g.blend.unwrap_or((
        vk::PipelineColorBlendAttachmentState::default()
            .blend_enable(false)
            .color_write_mask(vk::ColorComponentFlags::RGBA),
        [0.0; 4],
    ));
    let blend_attachments = vec![each; g.color_formats.len()];
    let blend = vk::PipelineColorBlendStateCreateInfo::default()
        .attachments(&blend_attachments)
        .blend_constants(constants);
    let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(g.dynamic_states);
    let mut rendering = vk::PipelineRenderingCreateInfo::default()
        .color_attachment_formats(g.color_formats)
        .depth_attachment_format(g.depth_format)
        .stencil_attachment_format(g.stencil_format);
    let ci = vk::GraphicsPipelineCreateInfo::default()
        .stages(g.stages)
        .vertex_input_state(g.vertex_input)
        .input_assembly_state(&assembly)
        .viewport_state(&viewport)
        .rasterization_state(&raster)
        .multisample_state(&multisample)
        .depth_stencil_state(g.depth_stencil)
        .color_blend_state(&blend)
        .dynamic_state(&dynamic)
        .layout(g.layout)
        .push_next(&mut rendering);
    // SAFETY: all state structs above and in `g` live across the call; its
    // modules and layout are live (the caller's).
    let pipelines =
        unsafe { device.create_graphics_pipelines(vk::PipelineCache::null(), &[ci], None) }
            .map_err(|(_, e)| VkError::Call {
                call: "vkCreateGraphicsPipelines",
                result: e,
            })?;
    Ok(pipelines[0])
}

impl Drop for Pipelines {
    fn drop(&mut self) {
        let _layer = self.shared.layer_use();
        let d = &self.shared.device;
        for p in self
            .cache
            .drain()
            .map(|e| e.1)
            .chain(self.fixed.drain().map(|e| e.1))
        {
            // SAFETY: the executor waited for the GPU before dropping its pipelines.
            unsafe { d.destroy_pipeline(p, None) };
        }
        // SAFETY: no pipeline uses the layouts any more; null handles are ignored.
        unsafe { d.destroy_pipeline_layout(self.layout, None) };
        // SAFETY: as above.
        unsafe { d.destroy_descriptor_set_layout(self.set_layout, None) };
        // SAFETY: as above.
        unsafe { d.destroy_descriptor_set_layout(self.camera_set_layout, None) };
        // SAFETY: as above.
        unsafe { d.destroy_sampler(self.sampler, None) };
        for (_, m) in self.fragments.drain() {
            // SAFETY: modules are only needed while creating pipelines.
            unsafe { d.destroy_shader_module(m, None) };
        }
        for m in [self.vertex, self.vertex_flat] {
            // SAFETY: as above.
            unsafe { d.destroy_shader_module(m, None) };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each program's source under `shaders/` (the host variant is the same
    /// source built with `HOST`).
    const SOURCES: [(FragmentKind, &str); 25] = [
        (FragmentKind::None, "none.frag"),
        (FragmentKind::Shade, "shade.frag"),
        (FragmentKind::ShadeHost, "shade.frag"),
        (FragmentKind::Paint, "paint.frag"),
        (FragmentKind::Background, "background.frag"),
        (FragmentKind::Peel, "peel.frag"),
        (FragmentKind::PeelShade, "peel_shade.frag"),
        (FragmentKind::PeelTolerant, "peel_tolerant.frag"),
        (FragmentKind::WriteDepth, "write_depth.frag"),
        (FragmentKind::DepthFromTexture, "depth_from_texture.frag"),
        (
            FragmentKind::DepthFromTextureHost,
            "depth_from_texture.frag",
        ),
        (FragmentKind::ShadeNearDepth, "shade_near_depth.frag"),
        (FragmentKind::ShadeNearDepthHost, "shade_near_depth.frag"),
        (FragmentKind::NearerThan, "nearer_than.frag"),
        (FragmentKind::BehindThan, "behind_than.frag"),
        (FragmentKind::TieDepth, "tie_depth.frag"),
        (FragmentKind::MergeBehind, "merge_behind.frag"),
        (FragmentKind::MergeBehindExact, "merge_behind_exact.frag"),
        (FragmentKind::ShadeAtDepth, "shade_at_depth.frag"),
        (FragmentKind::ShadeAtDepthHost, "shade_at_depth.frag"),
        (FragmentKind::ShadeAtDepthHostWrite, "shade_at_depth.frag"),
        (FragmentKind::DepthAtDepth, "depth_at_depth.frag"),
        (FragmentKind::CopyDepth, "copy_depth.frag"),
        (FragmentKind::Edges, "edges.frag"),
        (FragmentKind::Accumulate, "accumulate.frag"),
    ];

    /// The text of `shaders/{file}` followed by its includes but `skip`, and
    /// theirs in turn (as `build.rs` includes them).
    fn source(file: &str, skip: Option<&str>) -> String {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
        let mut text = std::fs::read_to_string(dir.join(file)).expect("shader source");
        for line in text.clone().lines() {
            if let Some(inc) = line.strip_prefix("#include \"") {
                let inc = inc.trim_end_matches('"');
                if Some(inc) != skip {
                    text += &source(inc, skip);
                }
            }
        }
        text
    }

    /// The push-constant elision trusts `FragmentKind::reads`: a field a
    /// program reads but the table omits would keep another draw's value.
    #[test]
    fn reads_match_the_shader_sources() {
        for (kind, file) in SOURCES {
            // The includes a program pulls in read push constants too, but
            // draw.glsl declares the flat copies: a program's use of one is
            // what reads the field.
            let text = source(file, Some("draw.glsl"));
            let r = kind.reads();
            for (field, read) in [("color", r.color), ("prim", r.prim), ("view", r.view)] {
                let used = |name: String| text.contains(&name);
                assert_eq!(
                    used(format!("pc.{field}")) || used(format!("d_{field}")),
                    read,
                    "{kind:?} ({file}) and its `reads` disagree on `{field}`"
                );
            }
            assert!(!r.mvp, "only the quad's vertex shader reads mvp");
        }
    }

    /// A program that reads an interpolated output the `FLAT` vertex shader
    /// does not write would read undefined values (and fail validation); one
    /// that reads none but is listed only costs the outputs' stores.
    #[test]
    fn interpolated_matches_the_shader_sources() {
        for (kind, file) in SOURCES {
            let text = source(file, None);
            let declared = ["v_world", "v_normal", "v_ray", "v_nr"].iter().any(|v| {
                ["float", "vec3", "vec4"]
                    .iter()
                    .any(|t| text.contains(&format!(" in {t} {v};")))
            });
            assert_eq!(
                declared,
                kind.interpolated(),
                "{kind:?} ({file}) and `interpolated` disagree"
            );
        }
    }

    /// A program that writes colour but claimed not to would run with its
    /// writes masked; one that does not but claimed to would leave undefined
    /// values in a joined block's colour attachments.
    #[test]
    fn writes_color_matches_the_shader_sources() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
        for (kind, file) in SOURCES {
            let text = std::fs::read_to_string(dir.join(file)).expect("shader source");
            let outputs = text
                .lines()
                .any(|l| l.starts_with("layout(location") && l.contains(") out "));
            assert_eq!(
                outputs,
                kind.writes_color(),
                "{kind:?} ({file}) and `writes_color` disagree"
            );
        }
    }

    #[test]
    fn a_baked_state_goes_into_the_depth_stencil_info() {
        let face = StencilFaceOps {
            fail: vk::StencilOp::KEEP,
            pass: vk::StencilOp::INVERT,
            depth_fail: vk::StencilOp::ZERO,
            compare: vk::CompareOp::EQUAL,
        };
        let s = RasterState {
            cull: vk::CullModeFlags::BACK,
            depth_test: true,
            depth_write: false,
            depth_compare: vk::CompareOp::GREATER,
            stencil_test: true,
            front: face,
            back: face,
            compare_mask: 6,
            write_mask: 1,
            reference: 2,
        };
        let ci = s.depth_stencil();
        assert_eq!(ci.depth_test_enable, vk::TRUE);
        assert_eq!(ci.depth_write_enable, vk::FALSE);
        assert_eq!(ci.depth_compare_op, vk::CompareOp::GREATER);
        assert_eq!(ci.stencil_test_enable, vk::TRUE);
        assert_eq!(ci.front.pass_op, vk::StencilOp::INVERT);
        assert_eq!(ci.back.depth_fail_op, vk::StencilOp::ZERO);
        assert_eq!(
            (
                ci.front.compare_mask,
                ci.front.write_mask,
                ci.front.reference
            ),
            (6, 1, 2)
        );
    }
}
