#version 450
// Kirsch, Nienhaus & Döllner §5.1's edge map in one full-screen pass: the rule of
// src/render/edges.rs on the normal buffer (set 0: xyz the seen face's unit normal,
// zero where nothing was drawn) and the depth buffer (set 2; set 1 is the camera).
// Both pixels of a 4-neighbour pair are edges when coverage differs, when their view
// depths differ by more than color.x of the nearer one, or when their normals' dot
// product is below color.y; the image border is never an edge. Writes 1 on edges, 0
// elsewhere. Colour and flags are draw.glsl's flat copies; `view` is still read from
// the push constants (mesh.vert passes no flat copy of it; this pass runs once a
// frame, only when an edge map is asked for).
layout(push_constant) uniform Push {
    mat4 mvp;
    // x: near, y: far, z: 1 for orthographic (view depth is affine in depth)
    vec4 view;
    // x: relative depth threshold, y: cosine of the crease angle
    vec4 color;
    uint prim;
    // bit 0: reversed Z (near = 1, far = 0)
    uint flags;
} pc;
#include "draw.glsl"
layout(set = 0, binding = 0) uniform texture2D u_normal;
layout(set = 0, binding = 1) uniform sampler u_samp;
layout(set = 2, binding = 0) uniform texture2D u_depth;
layout(set = 2, binding = 1) uniform sampler u_samp_depth;
layout(location = 0) out vec4 o_edge;

// Camera::view_depth_from_ndc.
float view_depth(float z) {
    float n = pc.view.x;
    float f = pc.view.y;
    bool reversed = (d_flags & 1u) != 0u;
    if (pc.view.z > 0.5) {
        return reversed ? f - z * (f - n) : n + z * (f - n);
    }
    return reversed ? n * f / (n + z * (f - n)) : n * f / (f - z * (f - n));
}

vec3 normal_at(ivec2 p) {
    return texelFetch(sampler2D(u_normal, u_samp), p, 0).xyz;
}

float depth_at(ivec2 p) {
    return view_depth(texelFetch(sampler2D(u_depth, u_samp_depth), p, 0).r);
}

bool discontinuous(ivec2 a, ivec2 b) {
    vec3 na = normal_at(a);
    vec3 nb = normal_at(b);
    bool ca = dot(na, na) > 0.5;
    bool cb = dot(nb, nb) > 0.5;
    if (ca != cb) {
        return true;
    }
    if (!ca) {
        return false;
    }
    float da = depth_at(a);
    float db = depth_at(b);
    if (abs(da - db) > d_color.x * min(abs(da), abs(db))) {
        return true;
    }
    return dot(na, nb) < d_color.y;
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 size = textureSize(sampler2D(u_normal, u_samp), 0);
    bool edge = false;
    if (p.x > 0 && p.y > 0 && p.x < size.x - 1 && p.y < size.y - 1) {
        edge = discontinuous(p, p + ivec2(1, 0)) || discontinuous(p, p - ivec2(1, 0))
            || discontinuous(p, p + ivec2(0, 1)) || discontinuous(p, p - ivec2(0, 1));
    }
    o_edge = vec4(edge ? 1.0 : 0.0);
}
