// The draw's constants a fragment program reads per fragment, as flat inputs
// that mesh.vert copies from the push constants (included by build.rs right
// after the including shader declares `pc`; not a shader of its own).
//
// Why not `pc.color` etc.: llvmpipe (Mesa 22.3) cannot assume the first lane
// of a fragment shader is active, so it loads each push-constant component
// lane by lane, with a bounds check (about 25 instructions per component per
// 8 pixels: half a shaded onebox pixel's JIT code); a flat input is the same
// for every lane, read once per triangle and block. See docs/bench.md, the
// per-pixel floor against OpenCSG.
layout(location = 3) flat in vec4 d_color;
layout(location = 4) flat in uint d_prim;
layout(location = 5) flat in uint d_flags;
