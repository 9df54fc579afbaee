#version 450
// SCS's clip and merge of a product with one positive primitive in one draw of
// that primitive's back faces (plan::scs): the texture's depth `z` becomes the
// fragment depth where the back face lies behind `z` beyond the tie tolerance
// (color.a), i.e. `z` is still inside the primitive; where the back face is at
// or in front of `z` (`z` left it through a cutter) or `z` is far (no product
// at this pixel) the fragment is discarded.
layout(push_constant) uniform Push {
    mat4 mvp;
    vec4 view;
    // a: the tie tolerance of the parity tests (normalized depth)
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
    TieTexel t = tie_texel();
    bool empty = (d_flags & 1u) != 0u ? t.d <= 0.0 : t.d >= 1.0;
    if (empty || tie_nearer(dz, t)) {
        discard;
    }
    gl_FragDepth = t.d;
}
