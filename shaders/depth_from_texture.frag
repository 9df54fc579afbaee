#version 450
// Full-screen: the depth texture becomes the fragment depth; far (empty) pixels are
// discarded. With HOST: the embedding's depth merge into a host's depth
// (vk::exec::record::host), whose strict test never passes a far depth, so it
// keeps no discard (lavapipe runs a full-screen draw with one measurably slower).
layout(push_constant) uniform Push {
    mat4 mvp;
    // xyz: the eye (w = 1, perspective) or the unit view direction (w = 0, orthographic)
    vec4 view;
    // rgb: mesh, paint or background colour in 0..1
    vec4 color;
    // primitive id written to the id target (mesh index + 1)
    uint prim;
    // bit 0: reversed Z (near = 1, far = 0)
    uint flags;
} pc;
#include "draw.glsl"
#include "depth_tex.glsl"

void main() {
    float d = tex_fetch(ivec2(gl_FragCoord.xy));
#ifdef HOST
    // A far depth fails the host's strict test by itself.
#else
    bool empty = (d_flags & 1u) != 0u ? d <= 0.0 : d >= 1.0;
    if (empty) {
        discard;
    }
#endif
    gl_FragDepth = d;
}
