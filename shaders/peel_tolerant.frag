#version 450
// Tolerant depth peeling: keep fragments behind the previous layer (texture) by
// more than eps, record their depth. eps (normalized depth) arrives in color.x.
layout(push_constant) uniform Push {
    mat4 mvp;
    // xyz: the eye (w = 1, perspective) or the unit view direction (w = 0, orthographic)
    vec4 view;
    // x: eps (this shader only)
    vec4 color;
    // primitive id written to the id target (mesh index + 1)
    uint prim;
    // bit 0: reversed Z (near = 1, far = 0)
    uint flags;
} pc;
#include "draw.glsl"
#include "depth_tex.glsl"
layout(location = 0) out float o_depth;

#include "tie.glsl"

void main() {
    // Derivatives before any discard (they need the whole quad).
    vec2 dz = vec2(dFdx(gl_FragCoord.z), dFdy(gl_FragCoord.z));
    TieTexel t = tie_texel();
    float prev = t.d;
    // Reversed Z: a float buffer with relative precision, so the tolerance scales
    // with the depth.
    float eps = (d_flags & 1u) != 0u ? REVERSED_SCALE * d_color.x * prev : d_color.x;
    // The slope term only for a face parallel to the texture's (a coplanar face
    // snapped differently), not for one crossing it. It moves the bound by
    // `slope`; the slope test decides only the
    // fragments inside that thin band.
    float slope = sign(d_color.x) * tie_slope() * (abs(dz.x) + abs(dz.y));
    bool reversed = (d_flags & 1u) != 0u;
    bool behind = reversed ? gl_FragCoord.z + eps < prev : gl_FragCoord.z - eps > prev;
    bool widened = reversed ? gl_FragCoord.z + (eps + slope) < prev
                            : gl_FragCoord.z - (eps + slope) > prev;
    if (behind != widened && same_slope(dz, t, eps)) {
        behind = widened;
    }
    if (!behind) {
        discard;
    }
    o_depth = gl_FragCoord.z;
}
