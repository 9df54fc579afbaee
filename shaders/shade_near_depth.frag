#version 450
// Depth-equal shading with a tolerance: colour and primitive id where the
// fragment depth is within color.a (normalized depth) plus TIE_SLOPE pixels' worth
// of this face's depth slope of the texture; writes the face's depth at the pixel
// centre, independent of how the device snapped the vertices (plan::tie,
// docs/precision.md). With HOST: the embedding's final pass drawn straight into a
// host's attachments (vk::exec::record::host), colour only; with HOST_SRGB too,
// for an _SRGB host colour format.
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
#include "camera.glsl"
#include "depth_tex.glsl"
#ifdef MS
// Interpolated at this invocation's sample, where gl_FragCoord is
// (plane_depth steps from where v_world projects to gl_FragCoord.xy).
layout(location = 0) sample in vec3 v_world;
#else
layout(location = 0) in vec3 v_world;
#endif
#include "light.glsl"
layout(location = 0) out vec4 o_color;
#ifndef HOST
layout(location = 1) out uint o_prim;
#endif
#ifdef NORMALS
#define NORMAL_LOCATION 2
#include "seen_normal.glsl"
#endif


#include "tie.glsl"
#ifdef HOST_SRGB
#include "srgb.glsl"
#endif

// Whether this fragment's face passes through the visible point: its own raster
// depth within eps of the visible depth (the visible face itself, and coplanar
// faces rasterized alike), or its plane depth `z` (unsnapped) within eps plus
// the visible depth's snapping (half the two-sided slope term) with the visible
// face's gradient (a coplanar face snapped differently).
bool near_depth(float z, TieTexel t, vec2 dz) {
    float d = t.d;
    // Reversed Z: a float buffer with relative precision, so the tolerance scales
    // with the depth.
    float eps = (d_flags & 1u) != 0u ? REVERSED_SCALE * d_color.a * d : d_color.a;
    if (abs(gl_FragCoord.z - d) <= eps) {
        return true;
    }
    float slope = abs(dz.x) + abs(dz.y);
    return abs(z - d) <= eps + 0.5 * tie_slope() * slope && same_slope(dz, t, eps);
}

// The depth of this face's plane at the pixel centre. The device interpolates
// with the barycentrics of the pixel centre in its snapped triangle; v_world,
// interpolated with the same (perspective-corrected) weights, is a point of the
// exact face plane that projects to `at`, where the exact plane's depth is the
// same weighted sum of vertex depths: gl_FragCoord.z. Window depth is affine in
// window x, y on a plane, so one step along the slope moves it from `at` to the
// pixel centre. On a device that interpolates unsnapped positions `at` is the
// pixel centre and this is gl_FragCoord.z.
float plane_depth(vec2 dz) {
    vec2 size = vec2(tex_size());
    vec4 clip = cam.mvp * vec4(v_world, 1.0);
    vec2 at = (clip.xy / clip.w * 0.5 + 0.5) * size;
    return clamp(gl_FragCoord.z + dot(dz, gl_FragCoord.xy - at), 0.0, 1.0);
}

void main() {
    // Derivatives before any discard (they need the whole quad).
    vec2 dz = vec2(dFdx(gl_FragCoord.z), dFdy(gl_FragCoord.z));
    TieTexel t = tie_texel();
    float z = plane_depth(dz);
    if (!near_depth(z, t, dz)) {
        discard;
    }
#ifdef HOST
    // Nothing visible here (the far clear value); this also stands in for a
    // stencil test of the plan's, which the host's depth attachment cannot
    // hold: Blister's unlocked pixels are pushed back to far.
    if (t.d == ((d_flags & 1u) != 0u ? 0.0 : 1.0)) {
        discard;
    }
    // Every face drawn here writes the same depth, the visible one, so that the
    // host's strict depth test keeps the first writer: the lowest index, drawn
    // first (the host's geometry wins exact ties).
    gl_FragDepth = t.d;
    vec3 c = d_color.rgb * shade_factor();
#ifdef HOST_SRGB
    // An _SRGB host format, whose hardware encoding would encode these
    // (already sRGB-encoded) values a second time. A shader variant, not a
    // flag: lavapipe would compute the decode for every fragment either way.
    c = srgb_to_linear(c);
#endif
    o_color = vec4(c, 1.0);
#else
    // Bit 1: the raster depth, where the shade's depth-equal draws leave it
    // (a device that does not snap; vk::pipeline::FLAG_RASTER_DEPTH), so
    // that the tie rule and those draws agree bit for bit where both can run.
    gl_FragDepth = (d_flags & 2u) != 0u ? gl_FragCoord.z : z;
    o_color = vec4(d_color.rgb * shade_factor(), 1.0);
    o_prim = d_prim;
#endif
#ifdef NORMALS
    o_normal = vec4(seen_normal(), 0.0);
#endif
}
