#version 450
// Records the fragment depth into a depth texture.
layout(location = 0) out float o_depth;

void main() {
    o_depth = gl_FragCoord.z;
}
