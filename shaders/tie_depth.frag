#version 450
// The tie rule's compare as the depth test (plan::tie_free, `Fragment::TieDepth`):
// the fragment depth moved nearer by the tie tolerance (color.a, signed, and
// the slope term of tie_band.glsl in its direction), tested against a
// depth-stencil image that holds the texture's depth exactly (D32). Tested
// `LessOrEqual` it keeps what nearer_than.frag keeps on a coplanar face;
// `Greater`, what behind_than.frag keeps. It reads no texture, so the draw
// needs no barrier after the writes of that depth (docs/precision.md). It always
// widens by the slope term, where the texture shaders widen only for a face whose
// gradient agrees with the texture's: the two differ only where a face crosses the
// visible one within 2^-bits pixel's slope.
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
#include "tie_band.glsl"

void main() {
    float z = gl_FragCoord.z;
    float a = d_color.a;
    float slope = sign(a) * tie_slope() * (abs(dFdx(z)) + abs(dFdy(z)));
    bool reversed = (d_flags & 1u) != 0u;
    // Standard Z: z <= d + a + slope. Reversed Z, where the eps part scales
    // with the texture's depth d: z >= d - REVERSED_SCALE * a * d - slope.
    gl_FragDepth = reversed ? (z + slope) / (1.0 - REVERSED_SCALE * a) : z - (a + slope);
}
