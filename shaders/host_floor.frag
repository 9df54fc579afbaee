#version 450
// The example host's floor colour (examples/embed.rs), a flat input that
// host_floor.vert copies from the push constants: llvmpipe reads a push
// constant lane by lane in a fragment shader (shaders/draw.glsl says why).
layout(location = 0) flat in vec4 d_color;
layout(location = 0) out vec4 o_color;

void main() {
    o_color = vec4(d_color.rgb, 1.0);
}
