// The tie tolerance of every tolerant shader (plan::tie), included by build.rs
// (`#include "tie.glsl"`) after the including shader includes `draw.glsl`
// and `depth_tex.glsl`. Not a shader of its own.

#include "tie_band.glsl"

// A tie's depth gradient agrees with the texture's within this fraction.
const float SLOPE_AGREEMENT = 0.03125;

// The texture at `p`, clamped to the image: a helper invocation past the edge
// (the other half of a quad) reads the edge texel.
float tie_fetch(ivec2 p) {
    ivec2 hi = tex_size() - 1;
    return tex_fetch(clamp(p, ivec2(0), hi));
}

// The texture's depth at this pixel and its one-sided texel differences: `d`,
// then (x, y) the side inside this pixel's quad, (z, w) the side outside it.
// Called in uniform control flow (derivatives). The inside side is a fine
// derivative, exactly the difference of the two texels (r - d in an even
// column, d - l in an odd one; likewise rows), so only the outside side costs a
// fetch: three fetches per fragment where four neighbours and the centre took
// five (the cost of the tie rule on lavapipe, docs/perf/).
struct TieTexel {
    float d;
    vec4 diff;
};
TieTexel tie_texel() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    float d = tie_fetch(p);
    bvec2 odd = equal(p & 1, ivec2(1));
    float qx = tie_fetch(p + ivec2(odd.x ? 1 : -1, 0));
    float qy = tie_fetch(p + ivec2(0, odd.y ? 1 : -1));
    vec4 diff = vec4(dFdxFine(d), dFdyFine(d), odd.x ? qx - d : d - qx, odd.y ? qy - d : d - qy);
    return TieTexel(d, diff);
}

// Coplanar faces (true ties) share the depth gradient; a face crossing the
// texture's at a shallow angle, inside the slope band near the crossing, does
// not. The texture face's gradient comes from one-sided texel differences: a tie
// needs one side per axis to agree (the other may cross an edge).
bool same_slope(vec2 dz, TieTexel t, float eps) {
    float tol = SLOPE_AGREEMENT * (abs(dz.x) + abs(dz.y)) + 2.0 * abs(eps);
    bool x = abs(t.diff.x - dz.x) <= tol || abs(t.diff.z - dz.x) <= tol;
    bool y = abs(t.diff.y - dz.y) <= tol || abs(t.diff.w - dz.y) <= tol;
    return x && y;
}

// Whether this fragment is at or in front of the texture's depth plus the
// signed tolerance `d_color.a` (normalized depth), ties decided by the slope
// test: the classification of every tolerant parity test. `dz` are the
// fragment depth's derivatives and `t` the texel, both taken in uniform
// control flow.
bool tie_nearer(vec2 dz, TieTexel t) {
    float d = t.d;
    bool reversed = (d_flags & 1u) != 0u;
    // Reversed Z: a float buffer with relative precision, so the tolerance scales
    // with the depth.
    float eps = reversed ? REVERSED_SCALE * d_color.a * d : d_color.a;
    // The slope term only for a face parallel to the texture's (a coplanar face
    // snapped differently), not for one crossing it. It moves the bound by
    // `slope` (the sign of the tolerance); the slope test decides only
    // the fragments inside that thin band.
    float slope = sign(d_color.a) * tie_slope() * (abs(dz.x) + abs(dz.y));
    bool nearer = reversed ? gl_FragCoord.z >= d - eps : gl_FragCoord.z <= d + eps;
    bool widened = reversed ? gl_FragCoord.z >= d - (eps + slope)
                            : gl_FragCoord.z <= d + (eps + slope);
    if (nearer != widened && same_slope(dz, t, eps)) {
        nearer = widened;
    }
    return nearer;
}
