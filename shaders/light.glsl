// The headlight of every shading program, two-sided:
// rgb * (0.25 + 0.75 |n . v|) (output::shade), included by build.rs. Not a
// shader of its own.
//
// mesh.vert hands over r (`v_ray`), the ray from the eye to the vertex
// (perspective; orthographic: the view direction), and n . r (`v_nr`) with n
// the face normal. On a planar face n . r is the same at every point, so it is
// a flat input, taken from the triangle's provoking vertex (the only corner
// that carries the normal: vk/exec/corners.rs); r is affine in the world
// position, so perspective-correct interpolation gives it exactly at the
// pixel, and |n . v| = |n . r| / |r| with one inverse square root: the
// reference's per-pixel factor. The normalizes of n and of the eye's ray, the
// camera's uniform read and the flat normal this replaces were 27% of a
// one-box frame's shader instructions on lavapipe (docs/perf/: the
// headlight per pixel); a factor per vertex (Gouraud) saves 7% more but is
// 3 levels off on one box.
layout(location = 2) in vec3 v_ray;
layout(location = 6) flat in float v_nr;

float shade_factor() {
    return 0.25 + 0.75 * abs(v_nr) * inversesqrt(dot(v_ray, v_ray));
}
