#version 450
// Hable & Rossignac §6's transparency on the GPU: one peeled layer blended front to
// back into the accumulation target (vk/exec/transparency.rs). Where the layer has a
// point (primitive id p != 0) the output is its colour premultiplied by the
// opacity a = table[p] and the coverage a; the pipeline blends
// dst += (1 - dst.a) * src, i.e. C += (1 - A) a c and A += (1 - A) a.
layout(set = 0, binding = 0) uniform texture2D u_color;
layout(set = 0, binding = 1) uniform sampler u_samp;
layout(set = 2, binding = 0) uniform utexture2D u_prim;
layout(set = 2, binding = 1) uniform sampler u_samp_prim;
// ALPHA_TABLE_SIDE x ALPHA_TABLE_SIDE opacities: id p at (p % side, p / side).
layout(set = 3, binding = 0) uniform texture2D u_alpha;
layout(set = 3, binding = 1) uniform sampler u_samp_alpha;
layout(location = 0) out vec4 o_accum;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    uint prim = texelFetch(usampler2D(u_prim, u_samp_prim), px, 0).r;
    if (prim == 0u) {
        discard;
    }
    int side = textureSize(sampler2D(u_alpha, u_samp_alpha), 0).x;
    ivec2 at = ivec2(int(prim) % side, int(prim) / side);
    float a = texelFetch(sampler2D(u_alpha, u_samp_alpha), at, 0).r;
    vec3 c = texelFetch(sampler2D(u_color, u_samp), px, 0).rgb;
    o_accum = vec4(a * c, a);
}
