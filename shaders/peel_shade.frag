#version 450
// Depth peeling with shading: as peel.frag, plus colour and primitive id.
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
#include "light.glsl"
layout(location = 0) out vec4 o_color;
layout(location = 1) out uint o_prim;
layout(location = 2) out float o_depth;
#ifdef NORMALS
#define NORMAL_LOCATION 3
#include "seen_normal.glsl"
#endif

bool behind_prev() {
    float prev = tex_fetch(ivec2(gl_FragCoord.xy));
    return (d_flags & 1u) != 0u ? gl_FragCoord.z < prev : gl_FragCoord.z > prev;
}

void main() {
    if (!behind_prev()) {
        discard;
    }
    o_color = vec4(d_color.rgb * shade_factor(), 1.0);
    o_prim = d_prim;
    o_depth = gl_FragCoord.z;
#ifdef NORMALS
    o_normal = vec4(seen_normal(), 0.0);
#endif
}
