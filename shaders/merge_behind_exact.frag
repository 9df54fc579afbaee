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
layout(set = 0, binding = 0) uniform texture2D u_tex;
layout(set = 0, binding = 1) uniform sampler u_samp;

void main() {
    float d = texelFetch(sampler2D(u_tex, u_samp), ivec2(gl_FragCoord.xy), 0).r;
    bool reversed = (d_flags & 1u) != 0u;
    bool empty = reversed ? d <= 0.0 : d >= 1.0;
    bool behind = reversed ? gl_FragCoord.z < d : gl_FragCoord.z > d;
    if (empty || !behind) {
        discard;
    }
    gl_FragDepth = d;
}
