#version 450
// shade_at_depth.frag without colour: keeps only fragments whose depth equals
// the texture's bit-exactly (a CST peel's kept points, Hable & Rossignac §4
// Render(S)), for a solid's merge, whose colour and id the final shading writes
// (plan::cst::peel, Merge::at_depth). Exact because gl_Position is invariant.
#include "depth_tex.glsl"

void main() {
    float kept = tex_fetch(ivec2(gl_FragCoord.xy));
    if (gl_FragCoord.z != kept) {
        discard;
    }
}
