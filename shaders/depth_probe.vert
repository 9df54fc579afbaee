#version 450
// The depth probe's triangle (src/vk/depth_probe.rs): three clip-space
// positions from push constants, no vertex buffer, no fragment shader.
layout(push_constant) uniform Probe {
    vec4 pos[3];
} probe;

void main() {
    gl_Position = probe.pos[gl_VertexIndex];
}
