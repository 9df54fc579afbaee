// The normal buffer of Kirsch, Nienhaus & Döllner §5.2 (compiled in with NORMALS,
// when the executor asks for normals): the face's unit normal turned towards the eye,
// in world orientation (the CPU rotates it into view space; angles between normals,
// all the edge rule needs, are the same in both). After light.glsl, whose
// `v_nr` is n . r, r pointing away from the eye.
layout(location = 1) flat in vec3 v_normal;
layout(location = NORMAL_LOCATION) out vec4 o_normal;

vec3 seen_normal() {
    vec3 n = normalize(v_normal);
    return v_nr > 0.0 ? -n : n;
}
