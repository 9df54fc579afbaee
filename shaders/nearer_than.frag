#version 450
// Keeps fragments at or in front of the texture's depth plus a tolerance
// (color.a, normalized depth); writes nothing but depth/stencil side effects.
// Used for parity counting that is robust to coincident faces.
layout(push_constant) uniform Push {
    mat4 mvp;
    vec4 view;
    // a: the tolerance (signed: negative keeps only fragments more than -a in front)
    vec4 color;
    uint prim;
    // bit 0: reversed Z (near = 1, far = 0)
    uint flags;
} pc;
layout(set = 0, binding = 0) uniform texture2D u_tex;
layout(set = 0, binding = 1) uniform sampler u_samp;

#include "tie.glsl"

void main() {
    // Derivatives before any discard (they need the whole quad).
    vec2 dz = vec2(dFdx(gl_FragCoord.z), dFdy(gl_FragCoord.z));
    TieTexel t = tie_texel();
    float d = t.d;
    bool reversed = (pc.flags & 1u) != 0u;
    // Reversed Z: a float buffer with relative precision, so the tolerance scales
    // with the depth.
    float eps = reversed ? REVERSED_SCALE * pc.color.a * d : pc.color.a;
    // The slope term only for a face parallel to the texture's (a coplanar face
    // snapped differently), not for one crossing it. It moves the bound by
    // `slope` (the sign of the tolerance); the slope test decides only
    // the fragments inside that thin band.
    float slope = sign(pc.color.a) * tie_slope() * (abs(dz.x) + abs(dz.y));
    bool nearer = reversed ? gl_FragCoord.z >= d - eps : gl_FragCoord.z <= d + eps;
    bool widened = reversed ? gl_FragCoord.z >= d - (eps + slope)
                            : gl_FragCoord.z <= d + (eps + slope);
    if (nearer != widened && same_slope(dz, t, eps)) {
        nearer = widened;
    }
    if (!nearer) {
        discard;
    }
}
