#version 450
// shade_at_depth.frag without colour: keeps only fragments whose depth equals
// the texture's bit-exactly (a CST peel's kept points, Hable & Rossignac §4
// Render(S)), for a solid's merge, whose colour and id the final shading writes
// (plan::cst::peel, Merge::at_depth). Exact because gl_Position is invariant.
layout(set = 0, binding = 0) uniform texture2D u_tex;
layout(set = 0, binding = 1) uniform sampler u_samp;

void main() {
    float kept = texelFetch(sampler2D(u_tex, u_samp), ivec2(gl_FragCoord.xy), 0).r;
    if (gl_FragCoord.z != kept) {
        discard;
    }
}
