#version 450
// Embedding: writes peeltrim's CSG colour and depth into the host's attachments
// where the CSG covers the pixel (primitive id != 0); the host's depth test, set
// as dynamic state, decides against the host's own geometry.
layout(set = 0, binding = 0) uniform texture2D u_color;
layout(set = 0, binding = 1) uniform utexture2D u_prim;
layout(set = 0, binding = 2) uniform texture2D u_depth;
layout(set = 0, binding = 3) uniform sampler u_samp;
layout(location = 0) out vec4 o_color;

#ifdef HOST_SRGB
#include "srgb.glsl"
#endif

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    uint prim = texelFetch(usampler2D(u_prim, u_samp), p, 0).r;
    if (prim == 0u) {
        discard;
    }
    vec4 c = texelFetch(sampler2D(u_color, u_samp), p, 0);
#ifdef HOST_SRGB
    // The host's colour format is _SRGB, whose hardware encoding would encode
    // peeltrim's (already sRGB-encoded) values a second time. A shader variant,
    // not a flag: lavapipe would compute the decode for every pixel either way.
    c.rgb = srgb_to_linear(c.rgb);
#endif
    o_color = c;
    gl_FragDepth = texelFetch(sampler2D(u_depth, u_samp), p, 0).r;
}
