// The tie tolerance's constants and slope term (plan::tie), shared by the
// tolerant shaders that read the texture (`tie.glsl`) and by `tie_depth.frag`,
// which reads none. Included by build.rs after the including shader includes
// `draw.glsl`; not a shader of its own.

// plan::tie: the slope part of a tolerance is TIE_SLOPES steps of the device's
// vertex snapping (2^-bits pixel, bits in flags 8..16) times fwidth(z); with
// reversed Z the eps part is REVERSED_SCALE * eps * z (1 to 2 float ulps).
const float TIE_SLOPES = 1.0;
const float REVERSED_SCALE = 0.125;
float tie_slope() {
    // 2^-bits built from its float bits (bits is 4..16): exact, and no exp2
    // per fragment (lavapipe evaluates it as a polynomial).
    return TIE_SLOPES * uintBitsToFloat((127u - ((d_flags >> 8) & 0xffu)) << 23);
}
