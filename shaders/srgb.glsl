// sRGB-encoded values in 0..1 to linear ones, for hosts whose colour format is
// _SRGB (its hardware encoding would otherwise encode peeltrim's sRGB-encoded
// colours a second time). Included by build.rs; not a shader of its own.
vec3 srgb_to_linear(vec3 c) {
    vec3 lo = c / 12.92;
    vec3 hi = pow((c + 0.055) / 1.055, vec3(2.4));
    return mix(lo, hi, step(vec3(0.04045), c));
}
