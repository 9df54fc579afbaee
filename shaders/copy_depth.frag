#version 450
// Full-screen: copies the sampled depth aspect of a depth-stencil image into a
// depth texture.
layout(set = 0, binding = 0) uniform texture2D u_tex;
layout(set = 0, binding = 1) uniform sampler u_samp;
layout(location = 0) out float o_depth;

void main() {
    o_depth = texelFetch(sampler2D(u_tex, u_samp), ivec2(gl_FragCoord.xy), 0).r;
}
