#version 450
// Keeps fragments behind the texture's depth by more than a tolerance (color.a,
// normalized depth): the complement of nearer_than.frag, ties decided by the
// same rule; writes nothing but depth/stencil side effects. SCS's clip by back
// faces (plan::scs): a positive primitive's back face passes where the
// candidate depth is still inside it.
layout(push_constant) uniform Push {
    mat4 mvp;
    vec4 view;
    // a: the tolerance of the parity tests (normalized depth)
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
    if (tie_nearer(dz, tie_texel())) {
        discard;
    }
}
