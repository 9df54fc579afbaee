#version 450
// merge_behind.frag where no face can tie (plan::tie_free; the plan's
// MergeBehind with eps 0): the same merge with a plain compare, so one texel
// fetch and no derivatives. The texture's depth `z` becomes the fragment depth
// where the back face lies strictly behind it and `z` is not far.
layout(push_constant) uniform Push {
    mat4 mvp;
    vec4 view;
    vec4 color;
    uint prim;
    // bit 0: reversed Z (near = 1, far = 0)
    uint flags;
} pc;
#include "draw.glsl"
#include "depth_tex.glsl"

void main() {
    float d = tex_fetch(ivec2(gl_FragCoord.xy));
    bool reversed = (d_flags & 1u) != 0u;
    bool empty = reversed ? d <= 0.0 : d >= 1.0;
    bool behind = reversed ? gl_FragCoord.z < d : gl_FragCoord.z > d;
    if (empty || !behind) {
        discard;
    }
    gl_FragDepth = d;
}
