#version 450
// Resets rejected pixels: background colour, primitive id 0.
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
layout(location = 0) out vec4 o_color;
layout(location = 1) out uint o_prim;
#ifdef NORMALS
// No face: a zero normal (Kirsch, Nienhaus & Döllner §5.2's normal buffer).
layout(location = 2) out vec4 o_normal;
#endif

void main() {
    o_color = vec4(d_color.rgb, 1.0);
    o_prim = 0u;
#ifdef NORMALS
    o_normal = vec4(0.0);
#endif
}
