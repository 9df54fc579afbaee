#version 450
// Full-screen: the depth texture becomes the fragment depth everywhere, far
// values included. The shade pass's resolve (plan::tie::shade_near_depth): its
// depth output, held in a texture while its bound stood in the depth buffer.
layout(set = 0, binding = 0) uniform texture2D u_tex;
layout(set = 0, binding = 1) uniform sampler u_samp;

void main() {
    gl_FragDepth = texelFetch(sampler2D(u_tex, u_samp), ivec2(gl_FragCoord.xy), 0).r;
}
