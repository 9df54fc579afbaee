// The camera (set 1, binding 0; vk/exec/camera.rs): a uniform buffer, so a
// recorded frame replays under a moved camera.
layout(set = 1, binding = 0) uniform Camera {
    // World (relative to the upload origin) to clip space.
    mat4 mvp;
    // xyz: the eye (w = 1, perspective) or the unit view direction (w = 0, orthographic)
    vec4 view;
} cam;

