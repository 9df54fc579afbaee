#version 450
// The sample-depth probe's shade (src/vk/sample_depth_probe.rs): run once per
// sample (the pipeline's sample shading), it replaces the fragment's depth
// with gl_FragCoord.z and passes a depth-EQUAL test against the raster depth
// of the same triangle only where gl_FragCoord.z is the sample's own depth.
layout(location = 0) out vec4 o_color;

void main() {
    o_color = vec4(1.0);
    gl_FragDepth = gl_FragCoord.z;
}
