//! The shader stages of the executor's graphics pipelines: a vertex and a
//! fragment module, each entered at `main` (the SPIR-V of `shaders/`); and the
//! full-screen pipelines outside the executor (the embedding's composite, the
//! shadow pass), whose vertex shader is `shaders/fullscreen.vert`.

use ash::vk;

use super::error::VkError;
use super::instance::Shared;
use super::pipeline::shader_module;

/// One triangle covering the viewport, from the vertex index alone.
const FULLSCREEN_VERT: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/fullscreen.vert.spv"));

/// The stages of a pipeline of vertex module `vert` and fragment module `frag`.
pub(crate) fn vert_frag(
    vert: vk::ShaderModule,
    frag: vk::ShaderModule,
) -> [vk::PipelineShaderStageCreateInfo<'static>; 2] {
    [
        (vk::ShaderStageFlags::VERTEX, vert),
        (vk::ShaderStageFlags::FRAGMENT, frag),
    ]
    .map(|(stage, module)| {
        vk::PipelineShaderStageCreateInfo::default()
            .stage(stage)
            .module(module)
            .name(c"main")
    })
}

/// The pipeline `make` creates from the stages of `shaders/fullscreen.vert`
/// and fragment program `frag` (SPIR-V); the shader modules live only while
/// it runs.
pub(crate) fn fullscreen_pipeline(
    shared: &Shared,
    frag: &[u8],
    make: impl FnOnce(&[vk::PipelineShaderStageCreateInfo<'static>]) -> Result<vk::Pipeline, VkError>,
) -> Result<vk::Pipeline, VkError> {
    let device = &shared.device;
    let vert = shader_module(shared, FULLSCREEN_VERT)?;
    let made = shader_module(shared, frag).and_then(|frag| {
        let made = make(&vert_frag(vert, frag));
        // SAFETY: modules are only needed while creating the pipeline.
        unsafe { device.destroy_shader_module(frag, None) };
        made
    });
    // SAFETY: as above.
    unsafe { device.destroy_shader_module(vert, None) };
    made
}
