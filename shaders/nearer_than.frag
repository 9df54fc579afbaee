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

// plan::tie: the slope part of a tolerance is TIE_SLOPES steps of the device's
// vertex snapping (2^-bits pixel, bits in flags 8..16) times fwidth(z); with
// reversed Z the eps part is REVERSED_SCALE * eps * z (2 to 4 float ulps).
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
// needs one side per axis to agree (the other may cross an edge). The same
// function is in shade_near_depth.frag, nearer_than.frag, peel_tolerant.frag.
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

void main() {
    // Derivatives before any discard (they need the whole quad).
    vec2 dz = vec2(dFdx(gl_FragCoord.z), dFdy(gl_FragCoord.z));
    float d = texelFetch(sampler2D(u_tex, u_samp), ivec2(gl_FragCoord.xy), 0).r;
    bool reversed = (pc.flags & 1u) != 0u;
    // Reversed Z: a float buffer with relative precision, so the tolerance scales
    // with the depth.
    float eps = reversed ? REVERSED_SCALE * pc.color.a * d : pc.color.a;
    // The slope term only for a face parallel to the texture's (a coplanar face
    // snapped differently), not for one crossing it.
    if (same_slope(dz, d, eps)) {
        eps += sign(pc.color.a) * tie_slope() * (abs(dz.x) + abs(dz.y));
    }
    bool nearer = reversed ? gl_FragCoord.z >= d - eps : gl_FragCoord.z <= d + eps;
    if (!nearer) {
        discard;
    }
}
