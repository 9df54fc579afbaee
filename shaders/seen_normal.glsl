// The normal buffer of seed 001 §5.2 (compiled in with NORMALS, when the executor
// asks for normals): the face's unit normal turned towards the eye, in world
// orientation (the CPU rotates it into view space; angles between normals, all
// the edge rule needs, are the same in both).
layout(location = NORMAL_LOCATION) out vec4 o_normal;

vec3 seen_normal() {
    vec3 n = normalize(v_normal);
    vec3 v = view_dir(v_world);
    return dot(n, v) > 0.0 ? -n : n;
}
