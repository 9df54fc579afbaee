#version 450
// The read-back of a multisampled frame (vk::resolve), one full-screen pass
// into single-sample images: colour the mean of the pixel's samples (the
// 8-bit sRGB-encoded values averaged, as a UNORM resolve does), alpha the
// pixel's coverage (the fraction of its samples with a primitive), primitive
// id and depth those of sample 0, the sample docs/executor.md defines for
// `prim.png` and `depth.npy`.
// The frame's samples per pixel (naga's GLSL has no textureSamples).
layout(push_constant) uniform Push {
    int samples;
} pc;
layout(set = 0, binding = 0) uniform texture2DMS u_color;
layout(set = 0, binding = 1) uniform utexture2DMS u_prim;
layout(set = 0, binding = 2) uniform texture2DMS u_depth;
layout(set = 0, binding = 3) uniform sampler u_samp;
layout(location = 0) out vec4 o_color;
layout(location = 1) out uint o_prim;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    int n = pc.samples;
    vec3 sum = vec3(0.0);
    float covered = 0.0;
    for (int i = 0; i < n; i++) {
        sum += texelFetch(sampler2DMS(u_color, u_samp), p, i).rgb;
        covered += texelFetch(usampler2DMS(u_prim, u_samp), p, i).r != 0u ? 1.0 : 0.0;
    }
    o_color = vec4(sum, covered) / float(n);
    o_prim = texelFetch(usampler2DMS(u_prim, u_samp), p, 0).r;
    gl_FragDepth = texelFetch(sampler2DMS(u_depth, u_samp), p, 0).r;
}
