#version 450
// The one vertex shader of every pass. gl_Position is invariant so that depth-equal
// tests between passes compare bit-identical depths.
layout(push_constant) uniform Push {
    mat4 mvp;
    // xyz: the eye (w = 1, perspective) or the unit view direction (w = 0, orthographic)
    vec4 view;
    // rgb: mesh, paint or background colour in 0..1
    vec4 color;
    // primitive id written to the id target (mesh index + 1)
    uint prim;
    // bit 0: reversed Z (near = 1, far = 0)
    uint flags;
    // Rounding emulation (tests only; 0 = off): the NDC step of a coarse subpixel
    // grid to which vertices are snapped, as a device with few subPixelPrecisionBits
    // snaps them before interpolating depth (vk::RoundingEmulation).
    vec2 snap;
} pc;
#include "camera.glsl"

layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;

#ifdef FLAT
// The variant for programs that read no interpolated output (build.rs's
// `mesh.vert.flat.spv`; `FragmentKind::interpolated`): the depth-only and
// parity passes. llvmpipe runs the vertex shader on the queue thread and
// stores every output per vertex whether or not a fragment program reads it
// (all outputs but the position: ~60 of a vertex's ~190 instructions; docs/bench.md).
// The position is computed by the same code in both variants, so depth-equal tests
// still match.
#else
layout(location = 0) out vec3 v_world;
// Flat: the provoking vertex's, i.e. the triangle's own lit corner, which
// alone carries the face normal (vk/exec/corners.rs).
layout(location = 1) flat out vec3 v_normal;
// The headlight's ray, and the normal's component along it (light.glsl): the
// same at every point of the planar face, so flat, from the vertex that
// carries the normal.
layout(location = 2) out vec3 v_ray;
layout(location = 6) flat out float v_nr;
#endif
// The push constants fragment programs read, per vertex (draw.glsl: llvmpipe
// reads a push constant lane by lane in a fragment shader).
layout(location = 3) flat out vec4 d_color;
layout(location = 4) flat out uint d_prim;
layout(location = 5) flat out uint d_flags;

invariant gl_Position;

void main() {
    d_color = pc.color;
    d_prim = pc.prim;
    d_flags = pc.flags;
#ifdef FLAT
#else
    v_world = a_pos;
    v_normal = a_normal;
    // Perspective (w = 1): from the eye to the vertex; orthographic (w = 0):
    // the view direction, the same at every vertex.
    vec3 ray = mix(cam.view.xyz, a_pos - cam.view.xyz, cam.view.w);
    v_ray = ray;
    v_nr = dot(a_normal, ray);
#endif
    // The full-screen quad is drawn as instance 1 (vk::pipeline::QUAD_INSTANCE)
    // with its own matrix and stays unsnapped; meshes use the camera's matrix.
    // Not a push-constant flag: alternating mesh and quad draws share one push.
    bool quad = gl_InstanceIndex != 0;
    mat4 m = quad ? pc.mvp : cam.mvp;
    vec4 p = m * vec4(a_pos, 1.0);
    if (!quad && pc.snap.x > 0.0 && p.w > 0.0) {
        // Window position in grid steps from the viewport corner, rounded, back
        // to clip space with the same w (the point stays on its eye ray up to
        // the snap). Far-off vertices are left alone (the clipper takes them).
        vec2 g = (p.xy / p.w + 1.0) / pc.snap;
        if (all(lessThan(abs(g), vec2(16777216.0)))) {
            p.xy = (round(g) * pc.snap - 1.0) * p.w;
        }
    }
    gl_Position = p;
}
