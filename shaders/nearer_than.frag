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
#include "draw.glsl"
#include "depth_tex.glsl"

#include "tie.glsl"

void main() {
    // Derivatives before any discard (they need the whole quad).
    vec2 dz = vec2(dFdx(gl_FragCoord.z), dFdy(gl_FragCoord.z));
    if (!tie_nearer(dz, tie_texel())) {
        discard;
    }
}
