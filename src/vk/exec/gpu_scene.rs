//! The uploaded scene: one vertex buffer (a full-screen quad, then each mesh's
//! shared corners, then each mesh's lit corners; meshes are primitives in file
//! order, then surfaces), an index buffer, per-mesh colours, bounds, and the
//! camera-derived matrices the push constants and scissors use.
//!
//! A mesh is drawn one of two ways, both drawing its triangles with the same
//! corners in the same order (`corners::layout`), from the same f32 positions
//! (one rounding of `p - origin`), so the rasterizer sees bit-identical
//! triangles and depth-equal tests between them hold:
//! - indexed from its shared corners: the programs that read no interpolated
//!   output (`FragmentKind::interpolated`), the depth-only, parity, peel and
//!   clip passes;
//! - indexed from its lit corners: the shading programs (each triangle's own
//!   provoking vertex carries its face normal).
//!
//! A mesh's triangles are a range of *corners* (`ranges`: three a triangle,
//! numbered over all meshes): the index buffer holds corner `k`'s shared
//! vertex at `k` and its lit vertex at `lit_offset + k`, so one range names
//! the same triangles both ways. Why indexed: `corners`'s doc (llvmpipe
//! shades each index once per segment, on lavapipe's serial queue thread).
//! The buffers hold about 60 bytes a triangle of a tessellated sphere (24 a
//! shared corner, 24 a lit one, 24 of indices).

use std::sync::Arc;

use ash::vk;
use glam::{DMat4, DVec3};
use gpu_allocator::MemoryLocation;

use super::corners::{self, Layout};
use super::ExecDesc;
use crate::geom::ties::TieGaps;
use crate::plan::passes::SceneTies;
use crate::scene::camera::DepthConvention;
use crate::scene::{Aabb, Camera, Projection, Scene};
use crate::vk::error::VkError;
use crate::vk::instance::Shared;
use crate::vk::memory::Buffer;

pub(super) struct GpuScene {
    /// The quad, the shared corners, the lit corners (module doc).
    pub vertices: Buffer,
    /// Two u32 indices per corner: its shared vertex, then at `lit_offset`
    /// further its lit vertex (module doc).
    pub indices: Buffer,
    /// Where the lit corners' indices start in `indices`: the corner count.
    pub lit_offset: u32,
    /// `(first corner, corner count)` per mesh; consecutive meshes are
    /// contiguous.
    pub ranges: Vec<(u32, u32)>,
    /// `(first vertex, vertex count)` of each mesh's shared and lit corners:
    /// the slots a moved mesh's corners may fill (`rewrite`).
    pub corner_slots: Vec<[(u32, u32); 2]>,
    pub colors: Vec<[u8; 3]>,
    pub bounds: Vec<Aabb>,
    pub background: [u8; 3],
    pub camera: Camera,
    /// World point subtracted from every vertex before rounding to f32 (the eye
    /// at upload), folded back into `mvp` in f64: vertex rounding is relative to
    /// the distance from the eye wherever the scene lies in the world.
    pub origin: DVec3,
    pub cam: CameraState,
    /// First vertex of the full-screen quad (6 vertices), in both vertex
    /// buffers.
    pub quad_first: u32,
    /// Which meshes' faces could meet the tie rule, and those the final
    /// shade can see (`plan::passes::SceneTies`); unknown (every mesh
    /// possibly tied) once a mesh was moved.
    pub ties: SceneTies,
}

/// What the shaders and scissors derive from the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct CameraState {
    pub view: DMat4,
    pub proj: DMat4,
    pub mvp: [f32; 16],
    /// Eye (w = 1) or view direction (w = 0) for shading.
    pub view_vec: [f32; 4],
}

pub(super) fn convention(desc: &ExecDesc) -> DepthConvention {
    if desc.reversed_z {
        DepthConvention::Reversed
    } else {
        DepthConvention::Standard
    }
}

/// The matrix product is formed in f64 and rounded once.
pub(super) fn camera_state(camera: &Camera, desc: &ExecDesc, origin: DVec3) -> CameraState {
    let aspect = desc.width as f64 / desc.height as f64;
    let view = camera.view();
    let proj = camera.proj(aspect, convention(desc));
    let mvp = (proj * view * DMat4::from_translation(origin))
        .to_cols_array()
        .map(|v| v as f32);
    // Shading sees vertices relative to `origin`, so the eye is too.
    let eye = camera.eye - origin;
    let view_vec = match camera.projection {
        Projection::Perspective { .. } => [eye.x as f32, eye.y as f32, eye.z as f32, 1.0],
        Projection::Orthographic { .. } => {
            let f = camera.forward();
            [f.x as f32, f.y as f32, f.z as f32, 0.0]
        }
    };
    CameraState {
        view,
        proj,
        mvp,
        view_vec,
    }
}

impl GpuScene {
    pub fn new(shared: &Arc<Shared>, scene: &Scene, desc: &ExecDesc) -> Result<GpuScene, VkError> {
        let meshes: Vec<(&crate::scene::Mesh, [u8; 3])> = scene
            .primitives
            .iter()
            .map(|p| (&p.mesh, p.color))
            .chain(scene.surfaces.iter().map(|s| (&s.mesh, s.color)))
            .collect();
        // Camera-relative vertices: f32 rounding then scales with the distance
        // from the eye, i.e. with the view depth (uniform relative precision),
        // wherever the scene lies in the world.
        let origin = if scene.camera.eye.is_finite() {
            scene.camera.eye
        } else {
            DVec3::ZERO
        };
        let layouts: Vec<Layout> = meshes.iter().map(|(m, _)| corners::layout(m)).collect();
        let normals: Vec<Vec<[f32; 3]>> = meshes.iter().map(|(m, _)| face_normals(m)).collect();
        let mut floats: Vec<f32> = QUAD.to_vec();
        let quad_first = 0;
        let mut ranges = Vec::with_capacity(meshes.len());
        let mut corners = 0u32;
        for (mesh, _) in &meshes {
            let n = mesh.triangles.len() as u32 * 3;
            ranges.push((corners, n));
            corners += n;
        }
        let colors = meshes.iter().map(|(_, c)| *c).collect();
        let bounds = meshes.iter().map(|(m, _)| mesh_bounds(m)).collect();
        // Shared corners of every mesh, then lit corners of every mesh; the
        // indices in the same two runs.
        let mut indices: Vec<u32> = Vec::with_capacity(2 * corners as usize);
        let mut slots = Vec::with_capacity(meshes.len());
        for ((mesh, _), l) in meshes.iter().zip(&layouts) {
            let first = (floats.len() / 6) as u32;
            floats.extend(shared_floats(mesh, l, origin));
            indices.extend(l.shared_index.iter().map(|i| first + i));
            slots.push([(first, l.shared.len() as u32), (0, 0)]);
        }
        let lit_offset = indices.len() as u32;
        debug_assert_eq!(lit_offset, corners);
        for ((((mesh, _), l), n), slot) in meshes.iter().zip(&layouts).zip(&normals).zip(&mut slots)
        {
            let first = (floats.len() / 6) as u32;
            floats.extend(lit_floats(mesh, l, n, origin));
            indices.extend(l.lit_index.iter().map(|i| first + i));
            slot[1] = (first, l.lit.len() as u32);
        }
        let index_buffer = filled(
            shared,
            "indices",
            &ne_bytes(&indices, u32::to_ne_bytes),
            vk::BufferUsageFlags::INDEX_BUFFER,
        )?;
        let vertices = filled(
            shared,
            "vertices",
            &ne_bytes(&floats, f32::to_ne_bytes),
            vk::BufferUsageFlags::VERTEX_BUFFER,
        )?;
        let ties = SceneTies::of_scene(scene);
        Ok(GpuScene {
            vertices,
            indices: index_buffer,
            lit_offset,
            ranges,
            corner_slots: slots,
            colors,
            bounds,
            background: scene.render.background,
            camera: scene.camera,
            origin,
            cam: camera_state(&scene.camera, desc, origin),
            quad_first,
            ties,
        })
    }
}

/// A host-visible buffer holding `bytes` (lavapipe's device memory is host
/// memory; a moved mesh is rewritten in place).
fn filled(
    shared: &Arc<Shared>,
    name: &str,
    bytes: &[u8],
    usage: vk::BufferUsageFlags,
) -> Result<Buffer, VkError> {
    let mut buffer = Buffer::new(
        shared,
        name,
        bytes.len() as u64,
        usage,
        MemoryLocation::CpuToGpu,
    )?;
    buffer.mapped_mut()?.copy_from_slice(bytes);
    Ok(buffer)
}

/// The bytes of `values` as the device reads them (`f32::to_ne_bytes`,
/// `u32::to_ne_bytes`).
fn ne_bytes<T: Copy, const N: usize>(values: &[T], bytes: fn(T) -> [u8; N]) -> Vec<u8> {
    values.iter().flat_map(|&v| bytes(v)).collect()
}

/// The full-screen quad's six vertices (position, then a normal no program
/// reads), at vertex 0 of both vertex buffers.
const QUAD: [f32; 36] = [
    -1.0, -1.0, 0.0, 0.0, 0.0, 1.0, //
    1.0, -1.0, 0.0, 0.0, 0.0, 1.0, //
    1.0, 1.0, 0.0, 0.0, 0.0, 1.0, //
    -1.0, -1.0, 0.0, 0.0, 0.0, 1.0, //
    1.0, 1.0, 0.0, 0.0, 0.0, 1.0, //
    -1.0, 1.0, 0.0, 0.0, 0.0, 1.0, //
];

/// Each triangle's unit face normal, from the mesh's own corner order (not the
/// drawn rotation), in f32: the one value every vertex that carries it holds.
fn face_normals(mesh: &crate::scene::Mesh) -> Vec<[f32; 3]> {
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            let n = (b - a).cross(c - a).normalize_or_zero();
            [n.x as f32, n.y as f32, n.z as f32]
        })
        .collect()
}

/// Position `i` relative to `origin`, rounded once: the same f32 values in
/// every vertex at that position, in all three ways of drawing (module doc).
fn position(mesh: &crate::scene::Mesh, i: u32, origin: DVec3) -> [f32; 3] {
    let p = mesh.positions[i as usize] - origin;
    [p.x as f32, p.y as f32, p.z as f32]
}

/// The vertex floats of `corners` (position index, normal), in order: the
/// one layout all three ways of drawing share (position, then normal).
fn corner_floats(
    mesh: &crate::scene::Mesh,
    origin: DVec3,
    corners: impl Iterator<Item = (u32, [f32; 3])>,
) -> Vec<f32> {
    let mut floats = Vec::with_capacity(corners.size_hint().0 * 6);
    for (i, n) in corners {
        floats.extend(position(mesh, i, origin));
        floats.extend(n);
    }
    floats
}

/// The shared corners: positions only (no program that draws them reads a
/// normal).
fn shared_floats(mesh: &crate::scene::Mesh, l: &Layout, origin: DVec3) -> Vec<f32> {
    corner_floats(mesh, origin, l.shared.iter().map(|&i| (i, [0.0; 3])))
}

/// The lit corners: each triangle's own vertex with its face normal; the
/// corners that are no triangle's own with none (never read).
fn lit_floats(
    mesh: &crate::scene::Mesh,
    l: &Layout,
    normals: &[[f32; 3]],
    origin: DVec3,
) -> Vec<f32> {
    let corners = l
        .lit
        .iter()
        .map(|&(i, owner)| (i, owner.map_or([0.0; 3], |t| normals[t as usize])));
    corner_floats(mesh, origin, corners)
}

fn mesh_bounds(mesh: &crate::scene::Mesh) -> Aabb {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in &mesh.positions {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    Aabb { min: lo, max: hi }
}

impl GpuScene {
    /// Overwrites mesh `i`'s vertices in the mapped buffer (embedding: a moved
    /// mesh). The caller guarantees no submitted frame still reads the buffer.
    pub(super) fn rewrite(
        scene: &mut GpuScene,
        i: usize,
        mesh: &crate::scene::Mesh,
    ) -> Result<(), VkError> {
        let (first, count) = *scene
            .ranges
            .get(i)
            .ok_or_else(|| VkError::Plan(format!("no mesh {i} to move")))?;
        if mesh.triangles.len() * 3 != count as usize {
            return Err(VkError::Plan(format!(
                "mesh {i}: {} triangles given where {} were uploaded (a moved mesh keeps its triangles)",
                mesh.triangles.len(),
                count / 3
            )));
        }
        let l = corners::layout(mesh);
        let [(shared_first, shared_slots), (lit_first, lit_slots)] = scene.corner_slots[i];
        // The layout depends on the triangles only, which a moved mesh keeps.
        if l.shared.len() != shared_slots as usize || l.lit.len() != lit_slots as usize {
            return Err(VkError::Plan(format!(
                "mesh {i}: its triangles differ from the uploaded ones (a moved mesh keeps its triangles)"
            )));
        }
        let normals = face_normals(mesh);
        let origin = scene.origin;
        let write =
            |buffer: &mut Buffer, at_vertex: u32, floats: Vec<f32>| -> Result<(), VkError> {
                let bytes = ne_bytes(&floats, f32::to_ne_bytes);
                let at = at_vertex as usize * 24;
                buffer.mapped_mut()?[at..at + bytes.len()].copy_from_slice(&bytes);
                Ok(())
            };
        write(
            &mut scene.vertices,
            shared_first,
            shared_floats(mesh, &l, origin),
        )?;
        write(
            &mut scene.vertices,
            lit_first,
            lit_floats(mesh, &l, &normals, origin),
        )?;
        // The indices too: triangles of the same count and layout sizes may
        // still be other triangles.
        let shared_index = l.shared_index.iter().map(|k| shared_first + k);
        let lit_index = l.lit_index.iter().map(|k| lit_first + k);
        let bytes = ne_bytes(
            &shared_index.chain(lit_index).collect::<Vec<u32>>(),
            u32::to_ne_bytes,
        );
        let (half, n) = (bytes.len() / 2, first as usize * 4);
        let lit_at = (scene.lit_offset + first) as usize * 4;
        let mapped = scene.indices.mapped_mut()?;
        mapped[n..n + half].copy_from_slice(&bytes[..half]);
        mapped[lit_at..lit_at + half].copy_from_slice(&bytes[half..]);
        scene.bounds[i] = mesh_bounds(mesh);
        // The gaps were the old geometry's: no draw is taken as tie-free now.
        let unknown = TieGaps::unknown(scene.ranges.len());
        scene.ties = SceneTies {
            ties: unknown.clone(),
            shade_ties: unknown,
        };
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each corner's shared and lit vertex hold the same position, bit for
    /// bit: the two ways draw the same triangles (module doc).
    #[test]
    fn the_two_ways_hold_the_same_corners() {
        let mut mesh = crate::scene::shapes::make_sphere(0.9, 12, 8);
        for p in &mut mesh.positions {
            *p += DVec3::new(1.1, -2.3, 0.7);
        }
        let origin = DVec3::new(0.3, 7.0, -11.0);
        let l = corners::layout(&mesh);
        let normals = face_normals(&mesh);
        // As `GpuScene::new` lays one mesh out.
        let mut floats = QUAD.to_vec();
        let shared_first = (floats.len() / 6) as u32;
        floats.extend(shared_floats(&mesh, &l, origin));
        let lit_first = (floats.len() / 6) as u32;
        floats.extend(lit_floats(&mesh, &l, &normals, origin));
        let indices: Vec<u32> = l
            .shared_index
            .iter()
            .map(|k| shared_first + k)
            .chain(l.lit_index.iter().map(|k| lit_first + k))
            .collect();
        let bytes = |f: &[f32]| ne_bytes(f, f32::to_ne_bytes);
        let corners = l.shared_index.len();
        for (k, t) in l.triangles.iter().flatten().enumerate() {
            let at = |v: u32| &floats[v as usize * 6..v as usize * 6 + 3];
            let want = position(&mesh, *t, origin);
            assert_eq!(bytes(at(indices[k])), bytes(&want), "shared corner {k}");
            let lit = indices[corners + k];
            assert_eq!(bytes(at(lit)), bytes(&want), "lit corner {k}");
        }
    }
}
