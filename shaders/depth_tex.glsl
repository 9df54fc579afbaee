// The depth texture a program samples (set 0: `u_tex`, `u_samp`), included by
// build.rs in place of declaring them; not a shader of its own. With MS
// (build.rs's `ms` variant, for multisampled executors) the texture is
// multisampled and every fetch reads this invocation's own sample: using
// `gl_SampleID` makes the program run once per sample (sample-rate shading,
// Vulkan specification §"Sample Shading"), so a peel, parity or tie test
// compares each sample's depth with the same sample's depth.
#ifdef MS
layout(set = 0, binding = 0) uniform texture2DMS u_tex;
#else
layout(set = 0, binding = 0) uniform texture2D u_tex;
#endif
layout(set = 0, binding = 1) uniform sampler u_samp;

// The texel of pixel `p` (this invocation's sample with MS).
float tex_fetch(ivec2 p) {
#ifdef MS
    return texelFetch(sampler2DMS(u_tex, u_samp), p, int(gl_SampleID)).r;
#else
    return texelFetch(sampler2D(u_tex, u_samp), p, 0).r;
#endif
}

// The texture's size in pixels.
ivec2 tex_size() {
#ifdef MS
    return textureSize(sampler2DMS(u_tex, u_samp));
#else
    return textureSize(sampler2D(u_tex, u_samp), 0);
#endif
}
