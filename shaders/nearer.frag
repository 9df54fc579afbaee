#version 450
// Depth-stencil only: the fragment's depth moved eps (color.w) nearer, so that depth
// tests against an image count faces up to eps behind what it holds.
layout(push_constant) uniform Push {
    mat4 mvp;
    // xyz: the eye (w = 1, perspective) or the unit view direction (w = 0, orthographic)
    vec4 view;
    // w: eps (normalized depth)
    vec4 color;
    // primitive id written to the id target (mesh index + 1)
    uint prim;
    // bit 0: reversed Z (near = 1, far = 0)
    uint flags;
} pc;

void main() {
    float eps = pc.color.w;
    gl_FragDepth = (pc.flags & 1u) != 0u ? gl_FragCoord.z + eps : gl_FragCoord.z - eps;
}
