#version 450
// Flat headlight shading, two-sided: rgb * (0.25 + 0.75 |n . v|) (output::shade).
// With HOST: the embedding's depth-equal final-shade draw of a one-primitive
// product (vk::exec::record::host, plan::direct_shade), drawn into a host's
// attachments, colour only, tested depth-EQUAL against the merged depth before
// the shader; no face of such a product lies nearer than the output depth, so
// it needs no fetch of it. With HOST_SRGB too, for an _SRGB host colour format.
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
#ifdef HOST
layout(early_fragment_tests) in;
#endif
#include "light.glsl"
layout(location = 0) out vec4 o_color;
#ifndef HOST
layout(location = 1) out uint o_prim;
#endif
#ifdef HOST_SRGB
#include "srgb.glsl"
#endif
#ifdef NORMALS
#define NORMAL_LOCATION 2
#include "seen_normal.glsl"
#endif

void main() {
#ifdef HOST
    vec3 c = d_color.rgb * shade_factor();
#ifdef HOST_SRGB
    // An _SRGB host format would encode these (already sRGB-encoded) values
    // a second time (a variant, not a flag: see shade_near_depth.frag).
    c = srgb_to_linear(c);
#endif
    o_color = vec4(c, 1.0);
#else
    o_color = vec4(d_color.rgb * shade_factor(), 1.0);
    o_prim = d_prim;
#endif
#ifdef NORMALS
    o_normal = vec4(seen_normal(), 0.0);
#endif
}
