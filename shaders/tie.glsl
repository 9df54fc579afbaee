// The tie tolerance of every tolerant shader (plan::tie), included by build.rs
// (`#include "tie.glsl"`) after the including shader declares `pc` (with
// `flags`), `u_tex` and `u_samp`. Not a shader of its own.

// plan::tie: the slope part of a tolerance is TIE_SLOPES steps of the device's
// vertex snapping (2^-bits pixel, bits in flags 8..16) times fwidth(z); with
// reversed Z the eps part is REVERSED_SCALE * eps * z (1 to 2 float ulps).
const float TIE_SLOPES = 1.0;
const float REVERSED_SCALE = 0.125;
// A tie's depth gradient agrees with the texture's within this fraction.
const float SLOPE_AGREEMENT = 0.03125;
float tie_slope() {
    return TIE_SLOPES * exp2(-float((pc.flags >> 8) & 0xffu));
}

// Coplanar faces (true ties) share the depth gradient; a face crossing the
// texture's at a shallow angle, inside the slope band near the crossing, does
// not. The texture face's gradient comes from one-sided texel differences: a tie
// needs one side per axis to agree (the other may cross an edge).
bool same_slope(vec2 dz, float d, float eps) {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 hi = textureSize(sampler2D(u_tex, u_samp), 0) - 1;
    float l = texelFetch(sampler2D(u_tex, u_samp), clamp(p - ivec2(1, 0), ivec2(0), hi), 0).r;
    float r = texelFetch(sampler2D(u_tex, u_samp), clamp(p + ivec2(1, 0), ivec2(0), hi), 0).r;
    float u = texelFetch(sampler2D(u_tex, u_samp), clamp(p - ivec2(0, 1), ivec2(0), hi), 0).r;
    float w = texelFetch(sampler2D(u_tex, u_samp), clamp(p + ivec2(0, 1), ivec2(0), hi), 0).r;
    float tol = SLOPE_AGREEMENT * (abs(dz.x) + abs(dz.y)) + 2.0 * abs(eps);
    bool x = abs(d - l - dz.x) <= tol || abs(r - d - dz.x) <= tol;
    bool y = abs(d - u - dz.y) <= tol || abs(w - d - dz.y) <= tol;
    return x && y;
}
