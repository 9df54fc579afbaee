#version 450
// Paint: shaded like shade.frag, in the paint colour (CST painting, Hable & Rossignac
// §6).
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
#include "light.glsl"
layout(location = 0) out vec4 o_color;
layout(location = 1) out uint o_prim;
#ifdef NORMALS
#define NORMAL_LOCATION 2
#include "seen_normal.glsl"
#endif

void main() {
    o_color = vec4(d_color.rgb * shade_factor(), 1.0);
    o_prim = d_prim;
#ifdef NORMALS
    o_normal = vec4(seen_normal(), 0.0);
#endif
}
