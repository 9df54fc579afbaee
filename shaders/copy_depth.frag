#version 450
// Full-screen: copies the sampled depth aspect of a depth-stencil image into a
// depth texture.
#include "depth_tex.glsl"
layout(location = 0) out float o_depth;

void main() {
    o_depth = tex_fetch(ivec2(gl_FragCoord.xy));
}
