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
layout(set = 0, binding = 0) uniform texture2D u_tex;
layout(set = 0, binding = 1) uniform sampler u_samp;
layout(location = 0) out float o_depth;

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
    float prev = texelFetch(sampler2D(u_tex, u_samp), ivec2(gl_FragCoord.xy), 0).r;
    // Reversed Z: a float buffer with relative precision, so the tolerance scales
    // with the depth.
    float eps = (pc.flags & 1u) != 0u ? REVERSED_SCALE * pc.color.x * prev : pc.color.x;
    // The slope term only for a face parallel to the texture's (a coplanar face
    // snapped differently), not for one crossing it.
    if (same_slope(dz, prev, eps)) {
        eps += sign(pc.color.x) * tie_slope() * (abs(dz.x) + abs(dz.y));
    }
    bool behind = (pc.flags & 1u) != 0u ? gl_FragCoord.z + eps < prev : gl_FragCoord.z - eps > prev;
    if (!behind) {
        discard;
    }
    o_depth = gl_FragCoord.z;
}
