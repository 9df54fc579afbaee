#version 450
// Embedding: writes peeltrim's CSG colour and depth into the host's attachments
// where the CSG covers the pixel (primitive id != 0); the host's depth test, set
// as dynamic state, decides against the host's own geometry.
layout(set = 0, binding = 0) uniform texture2D u_color;
layout(set = 0, binding = 1) uniform utexture2D u_prim;
layout(set = 0, binding = 2) uniform texture2D u_depth;
layout(set = 0, binding = 3) uniform sampler u_samp;
layout(location = 0) out vec4 o_color;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    uint prim = texelFetch(usampler2D(u_prim, u_samp), p, 0).r;
    if (prim == 0u) {
        discard;
    }
    o_color = texelFetch(sampler2D(u_color, u_samp), p, 0);
    gl_FragDepth = texelFetch(sampler2D(u_depth, u_samp), p, 0).r;
}
