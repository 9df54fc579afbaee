#version 450
// Full-screen, before the shade pass's mesh draws (plan::tie::shade_near_depth):
// copies the visible depth into the shade's depth output (o_depth) and writes as
// fragment depth the farthest raster depth a face shade_near_depth.frag accepts
// can have here, so that their LessOrEqual depth test culls hidden fragments
// before the shader runs. Conservative by construction: a rejected fragment is
// one the shader would discard. Where nothing is visible, the near value: the
// shader accepts nothing there.
layout(push_constant) uniform Push {
    mat4 mvp;
    // xyz: the eye (w = 1, perspective) or the unit view direction (w = 0, orthographic)
    vec4 view;
    // a: the shade pass's eps (normalized depth)
    vec4 color;
    uint prim;
    // bit 0: reversed Z (near = 1, far = 0); bits 8..16: subpixel precision bits
    uint flags;
} pc;
layout(set = 0, binding = 0) uniform texture2D u_tex;
layout(set = 0, binding = 1) uniform sampler u_samp;
layout(location = 0) out float o_depth;

#include "tie.glsl"

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    float d = tie_fetch(p);
    o_depth = d;
    bool reversed = (pc.flags & 1u) != 0u;
    if (reversed ? d <= 0.0 : d >= 1.0) {
        gl_FragDepth = reversed ? 1.0 : 0.0;
        return;
    }
    // The shader accepts a face (raster depth r, slope s = |dz/dx| + |dz/dy|)
    // within eps of d, or whose plane depth at the pixel centre is within
    // eps + s/2 · 2^-bits of d with a gradient agreeing with one one-sided
    // texel difference per axis (same_slope): then s ≤ (S + 4 eps) /
    // (1 − 2 · SLOPE_AGREEMENT), S the sum of the larger differences per axis.
    // The plane depth is r moved by at most half a snapping step, s/2 · 2^-bits;
    // twice that is allowed here. So an accepted r is nearer than d + eps +
    // 1.5 · 2^-bits · s; the bound doubles that and adds 4 D24 quanta (standard
    // Z) or 2^-21 d (reversed: 4 float ulps) for the depth buffer's rounding.
    float sx = max(abs(tie_fetch(p + ivec2(1, 0)) - d), abs(d - tie_fetch(p - ivec2(1, 0))));
    float sy = max(abs(tie_fetch(p + ivec2(0, 1)) - d), abs(d - tie_fetch(p - ivec2(0, 1))));
    float eps = reversed ? REVERSED_SCALE * pc.color.a * d : pc.color.a;
    float slope = (sx + sy + 4.0 * eps) / (1.0 - 2.0 * SLOPE_AGREEMENT);
    float snap = tie_slope() / TIE_SLOPES;
    float tol = 2.0 * (eps + 1.5 * snap * slope) + (reversed ? d / 2097152.0 : 1.0 / 4194304.0);
    gl_FragDepth = clamp(reversed ? d - tol : d + tol, 0.0, 1.0);
}
