#version 450
// The shadow test of a `[light]` in one full-screen pass (src/vk/shadow.rs;
// Rossignac & Wu's shadow buffer): each visible eye pixel's point is rebuilt from the
// eye's depth, reprojected into the light's depth map and shadowed when its depth
// from the light exceeds the map texel's by more than the bias of
// src/render/shadow.rs (docs/shadows.md). Shadowed fragments pass: the blend
// (src ONE, dst CONSTANT_COLOR = SHADOW_KEEP) darkens the colour target and
// sets the mask target to 1; lit and background fragments are discarded.
layout(set = 0, binding = 0) uniform texture2D u_eye_depth;
layout(set = 0, binding = 1) uniform utexture2D u_eye_prim;
layout(set = 0, binding = 2) uniform texture2D u_eye_normal;
layout(set = 0, binding = 3) uniform texture2D u_map_depth;
layout(set = 0, binding = 4) uniform utexture2D u_map_prim;
layout(set = 0, binding = 5) uniform sampler u_samp;
layout(set = 0, binding = 6) uniform Shadow {
    // (nx·d, ny·d, d, 1) (perspective) or (nx, ny, d, 1) (orthographic) of an
    // eye pixel at NDC (nx, ny) and view depth d → world, relative to the
    // common origin (the light's target).
    mat4 eye_unproject;
    // World (relative to the origin) → the light's clip space (standard depth).
    mat4 light_clip;
    // x: near, y: far, z: 1 orthographic, w: 1 reversed depth
    vec4 eye_cam;
    vec4 map_cam;
    // xyz: the eye (relative to the origin); w: 1 perspective
    vec4 eye_pos;
    // xyz: the eye's unit view direction
    vec4 eye_fwd;
    // xyz: the light's eye (relative to the origin); w: 1 point light
    vec4 light_pos;
    // xyz: the light's unit view direction; w: a texel's world size (orthographic),
    // or per unit of light view depth (perspective)
    vec4 light_fwd;
    // xy: eye image size; zw: map size
    vec4 sizes;
    // x: 1 float depth (D32), 0 D24; y: 2^-(subpixel bits + 1); z: number of
    // closed primitives (ids above are open surfaces)
    vec4 prec;
} u;
layout(location = 0) out vec4 o_color;
layout(location = 1) out vec4 o_mask;

// Resolvable depth steps and f32 transform error of reference/precision.rs.
const float STEPS = 4.0;
const float TRANSFORM_REL = 1.0 / 1048576.0;

// Camera::view_depth_from_ndc for camera `c`.
float view_depth(vec4 c, float z) {
    float n = c.x;
    float f = c.y;
    bool reversed = c.w > 0.5;
    if (c.z > 0.5) {
        return reversed ? f - z * (f - n) : n + z * (f - n);
    }
    return reversed ? n * f / (n + z * (f - n)) : n * f / (f - z * (f - n));
}

// DepthPrecision::allowed at stored depth `z` (view depth `d`, slope `s`).
float allowed(vec4 c, float z, float d, float s) {
    float res = 1.0 / 16777216.0;
    if (u.prec.x > 0.5) {
        float a = max(abs(z), 1.17549435e-38);
        res = uintBitsToFloat(floatBitsToUint(a) + 1u) - a;
    }
    float n = c.x;
    float f = c.y;
    float per_window = c.z > 0.5 ? f - n : d * d * (f - n) / (f * n);
    return u.prec.y * s + STEPS * res * per_window + TRANSFORM_REL * abs(d);
}

// Stored depth, view depth and primitive id of a texel (id 0: background).
struct Texel {
    float z;
    float d;
    uint prim;
};

Texel eye_texel(ivec2 p) {
    float z = texelFetch(sampler2D(u_eye_depth, u_samp), p, 0).r;
    uint id = texelFetch(usampler2D(u_eye_prim, u_samp), p, 0).r;
    return Texel(z, view_depth(u.eye_cam, z), id);
}

Texel map_texel(ivec2 p) {
    float z = texelFetch(sampler2D(u_map_depth, u_samp), p, 0).r;
    uint id = texelFetch(usampler2D(u_map_prim, u_samp), p, 0).r;
    return Texel(z, view_depth(u.map_cam, z), id);
}

// reference::precision::slopes: per axis the larger one-sided difference to a
// neighbour of the same primitive, summed over the axes.
float eye_slope(ivec2 p, Texel t) {
    ivec2 size = ivec2(u.sizes.xy);
    float sx = 0.0;
    float sy = 0.0;
    for (int k = 0; k < 4; k++) {
        ivec2 o = k == 0 ? ivec2(-1, 0) : k == 1 ? ivec2(1, 0) : k == 2 ? ivec2(0, -1) : ivec2(0, 1);
        ivec2 q = p + o;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) {
            continue;
        }
        Texel n = eye_texel(q);
        if (n.prim != t.prim) {
            continue;
        }
        float diff = abs(n.d - t.d);
        if (k < 2) {
            sx = max(sx, diff);
        } else {
            sy = max(sy, diff);
        }
    }
    return sx + sy;
}

float map_slope(ivec2 p, Texel t) {
    ivec2 size = ivec2(u.sizes.zw);
    float sx = 0.0;
    float sy = 0.0;
    for (int k = 0; k < 4; k++) {
        ivec2 o = k == 0 ? ivec2(-1, 0) : k == 1 ? ivec2(1, 0) : k == 2 ? ivec2(0, -1) : ivec2(0, 1);
        ivec2 q = p + o;
        if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) {
            continue;
        }
        Texel n = map_texel(q);
        if (n.prim != t.prim) {
            continue;
        }
        float diff = abs(n.d - t.d);
        if (k < 2) {
            sx = max(sx, diff);
        } else {
            sy = max(sy, diff);
        }
    }
    return sx + sy;
}

void shadowed() {
    o_color = vec4(0.0);
    o_mask = vec4(1.0);
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    Texel e = eye_texel(p);
    if (e.prim == 0u) {
        discard;
    }
    // The pixel centre's point at the eye's view depth.
    vec2 ndc = (vec2(p) + 0.5) / u.sizes.xy * 2.0 - 1.0;
    vec4 q = u.eye_pos.w > 0.5 ? vec4(ndc * e.d, e.d, 1.0) : vec4(ndc, e.d, 1.0);
    vec3 world = (u.eye_unproject * q).xyz;
    float cos_e = u.eye_pos.w > 0.5 ? e.d / max(length(world - u.eye_pos.xyz), 1e-30) : 1.0;
    float dl = dot(world - u.light_pos.xyz, u.light_fwd.xyz);
    bool point = u.light_pos.w > 0.5;
    vec3 to_light = point ? normalize(u.light_pos.xyz - world) : -u.light_fwd.xyz;
    float texel = point ? u.light_fwd.w * dl : u.light_fwd.w;
    // The seen face's normal (turned towards the eye; zero if none was written).
    vec3 n = texelFetch(sampler2D(u_eye_normal, u_samp), p, 0).xyz;
    bool has_normal = dot(n, n) > 0.5;
    float facing = has_normal ? dot(normalize(n), to_light) : 1.0;
    // A closed primitive's face turned away from the light is in its own shadow.
    if (has_normal && float(e.prim) <= u.prec.z && facing <= 0.0) {
        shadowed();
        return;
    }
    vec4 c = u.light_clip * vec4(world, 1.0);
    vec2 lp = (c.xy / c.w + 1.0) * 0.5 * u.sizes.zw;
    vec2 t = floor(lp);
    if (any(lessThan(t, vec2(0.0))) || any(greaterThanEqual(t, u.sizes.zw))) {
        discard;
    }
    ivec2 ti = ivec2(t);
    Texel m = map_texel(ti);
    if (m.prim == 0u) {
        discard;
    }
    float f = clamp(abs(facing), 1e-3, 1.0);
    float receiver = texel * sqrt(1.0 - f * f) / f;
    float slope_m = map_slope(ti, m);
    float bias = allowed(u.map_cam, m.z, m.d, slope_m) + slope_m
        + allowed(u.eye_cam, e.z, e.d, eye_slope(p, e)) / max(cos_e, 1e-6);
    if (dl > m.d + bias + receiver) {
        shadowed();
        return;
    }
    discard;
}
