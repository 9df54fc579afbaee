//! The shader stages of the executor's graphics pipelines: a vertex and a
//! fragment module, each entered at `main` (the SPIR-V of `shaders/`).

use ash::vk;

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
