//! What the meshes of a scene cost in memory over a whole run, estimated from
//! their vertex and triangle counts before they are tessellated or read, so that
//! an over-large `segments`/`rings` or OBJ is refused against the memory budget
//! ([`crate::budget`]) instead of aborting in an allocation.
//!
//! Per vertex and per triangle the run holds: the local and the world mesh
//! (`f64` positions, `u32` indices), the `f32` copies uploaded to the device, and
//! the reference ray caster's BVH over world triangles (the largest part). The
//! constants fit measured peaks: spheres of 1024 and 2048 segments (1.05 M and
//! 4.2 M triangles) rendered at 32×32 peak at 285 MiB and 1.10 GiB with the
//! reference (1.02 GiB with cst-i), about 280 B per added triangle; the estimate
//! gives 288 MiB and 1.13 GiB.

/// Bytes held per vertex over a run.
pub const BYTES_PER_VERTEX: u64 = 64;
/// Bytes held per triangle over a run.
pub const BYTES_PER_TRIANGLE: u64 = 256;
/// Triangles per byte of an OBJ file are at most about one per 8 bytes
/// (`f 1 2 3\n`), vertices one per 12 (`v 0 0 0\n`).
pub const OBJ_BYTES_PER_TRIANGLE: u64 = 8;

/// Estimated bytes of a mesh of `vertices` and `triangles` over a run.
pub fn mesh_bytes(vertices: u64, triangles: u64) -> u64 {
    vertices
        .saturating_mul(BYTES_PER_VERTEX)
        .saturating_add(triangles.saturating_mul(BYTES_PER_TRIANGLE))
}

/// `(vertices, triangles)` of a sphere of `n` segments and `m` rings (two poles).
pub fn sphere(n: u32, m: u32) -> (u64, u64) {
    let side = n as u64 * (m as u64).saturating_sub(1);
    (side + 2, 2 * side)
}

/// `(vertices, triangles)` of a torus of `n` segments and `m` rings.
pub fn torus(n: u32, m: u32) -> (u64, u64) {
    let g = n as u64 * m as u64;
    (g, 2 * g)
}

/// An upper bound of the bytes of an OBJ file of `file_len` bytes over a run.
pub fn obj_bytes(file_len: u64) -> u64 {
    mesh_bytes(0, file_len / OBJ_BYTES_PER_TRIANGLE)
}
