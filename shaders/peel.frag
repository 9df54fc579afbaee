#version 450
// Depth peeling: keep fragments strictly behind the previous layer; record depth.
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
layout(location = 0) out float o_depth;

bool behind_prev() {
    float prev = tex_fetch(ivec2(gl_FragCoord.xy));
    return (d_flags & 1u) != 0u ? gl_FragCoord.z < prev : gl_FragCoord.z > prev;
}

void main() {
    if (!behind_prev()) {
        discard;
    }
    o_depth = gl_FragCoord.z;
}
