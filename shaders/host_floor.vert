#version 450
// The example host's own geometry (examples/embed.rs, not the library): a square
// floor at height floor_.x with half size floor_.y, from the vertex index alone.
layout(push_constant) uniform Push {
    mat4 mvp;
    vec4 floor_;
    vec4 color;
} pc;

void main() {
    int i = int(gl_VertexIndex);
    float x = (i == 1 || i == 2 || i == 4) ? 1.0 : -1.0;
    float z = (i == 2 || i == 4 || i == 5) ? 1.0 : -1.0;
    gl_Position = pc.mvp * vec4(x * pc.floor_.y, pc.floor_.x, z * pc.floor_.y, 1.0);
}
