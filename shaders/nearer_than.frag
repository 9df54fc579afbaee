#version 450
// Keeps fragments at or in front of the texture's depth plus a tolerance
// (color.a, normalized depth); writes nothing but depth/stencil side effects.
// Used for parity counting that is robust to coincident faces.
layout(push_constant) uniform Push {
    mat4 mvp;
    vec4 view;
    // a: the tolerance (signed: negative keeps only fragments more than -a in front)
    vec4 color;
    uint prim;
    // bit 0: reversed Z (near = 1, far = 0)
    uint flags;
} pc;
layout(set = 0, binding = 0) uniform texture2D u_tex;
layout(set = 0, binding = 1) uniform sampler u_samp;

// plan::tie: the slope part of a tolerance is TIE_SLOPES steps of the device's
// vertex snapping (2^-bits pixel, bits in flags 8..16) times fwidth(z); with
// reversed Z the eps part is REVERSED_SCALE * eps * z (2 to 4 float ulps).
const float TIE_SLOPES = 1.0;
const float REVERSED_SCALE = 0.125;
float tie_slope() {
    return TIE_SLOPES * exp2(-float((pc.flags >> 8) & 0xffu));
}

void main() {
    float slope = fwidth(gl_FragCoord.z);
    float d = texelFetch(sampler2D(u_tex, u_samp), ivec2(gl_FragCoord.xy), 0).r;
    bool reversed = (pc.flags & 1u) != 0u;
    // Reversed Z: a float buffer with relative precision, so the tolerance scales
    // with the depth.
    float eps = (reversed ? REVERSED_SCALE * pc.color.a * d : pc.color.a) + sign(pc.color.a) * tie_slope() * slope;
    bool nearer = reversed ? gl_FragCoord.z >= d - eps : gl_FragCoord.z <= d + eps;
    if (!nearer) {
        discard;
    }
}
