#version 450
// The example host's own geometry (examples/embed.rs, not the library): a square
// floor at height floor_.x with half size floor_.y, from the vertex index alone.
layout(push_constant) uniform Push {
    mat4 mvp;
    vec4 floor_;
    vec4 color;
} pc;
// The floor colour for host_floor.frag, per vertex rather than a push constant
// read per fragment (shaders/draw.glsl).
layout(location = 0) flat out vec4 d_color;

void main() {
    d_color = pc.color;
    int i = int(gl_VertexIndex);
    float x = (i == 1 || i == 2 || i == 4) ? 1.0 : -1.0;
    float z = (i == 2 || i == 4 || i == 5) ? 1.0 : -1.0;
    gl_Position = pc.mvp * vec4(x * pc.floor_.y, pc.floor_.x, z * pc.floor_.y, 1.0);
}
