#version 450
// Shades only where the fragment depth equals the texture's depth bit-exactly: the
// points a CST peel recorded and kept (Hable & Rossignac §4, Render(S)). Exact
// because the vertex shader's gl_Position is invariant, so the same mesh reproduces
// its depths. With HOST: the embedding's depth-equal final pass
// (vk::exec::record::host), drawn into a host's attachments with the output
// depth-stencil's depth bound as the texture, colour only, after the depth merge put
// that depth into the host's wherever it is nearer; with HOST_WRITE, with no merge,
// the visible face's raster depth written; with HOST_SRGB too, for an _SRGB host
// colour format.
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
#ifdef HOST_WRITE
// The host draw with no merge before it: it tests the host's depth with
// equality and writes its raster depth. No early_fragment_tests (they would
// write the depth of the faces discarded below), but a shader that discards and
// writes no gl_FragDepth still gets the depth test before it on lavapipe (the
// write comes after), so the fragments behind the host's geometry run nothing.
#else
// The host draw tests depth-EQUAL against the merged depth and writes none: the
// test runs before the shader, so only the fragments at the visible depth (or
// at a host depth they equal, which the fetch below turns away) run it.
layout(early_fragment_tests) in;
#endif
#endif
#include "depth_tex.glsl"
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
    float kept = tex_fetch(ivec2(gl_FragCoord.xy));
    if (gl_FragCoord.z != kept) {
        discard;
    }
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
