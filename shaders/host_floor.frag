#version 450
// The example host's floor colour (examples/embed.rs).
layout(push_constant) uniform Push {
    mat4 mvp;
    vec4 floor_;
    vec4 color;
} pc;
layout(location = 0) out vec4 o_color;

void main() {
    o_color = vec4(pc.color.rgb, 1.0);
}
