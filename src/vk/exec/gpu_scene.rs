//! The uploaded scene: every mesh's triangles in one vertex buffer (primitives in
//! file order, then surfaces, then a full-screen quad, then each mesh's shared
//! corners, then each mesh's lit corners), an index buffer, per-mesh colours,
//! bounds, and the camera-derived matrices the push constants and scissors use.
//!
//! A mesh is drawn one of three ways from the one buffer, all three drawing its
//! triangles with the same corners in the same order (`corners::layout`), from
//! the same f32 positions (one rounding of `p - origin`), so the rasterizer
//! sees bit-identical triangles and depth-equal tests between them hold:
//! - indexed from its shared corners: the programs that read no interpolated
//!   output (`FragmentKind::interpolated`), the depth-only, parity, peel and
//!   clip passes;
//! - indexed from its lit corners: the shading programs (each triangle's own
//!   provoking vertex carries its face normal);
//! - non-indexed from its soup corners (three a triangle, each with the face
//!   normal): only with `Executor::set_indexed(false)` (A/B measurements).
//!
//! The index buffer holds, for soup corner `k` (the quad excluded), its shared
//! corner at `k` and its lit corner at `lit_offset + k`, so a draw's
//! `(first, count)` range is the same range of triangles in all three ways.
//! Why: `corners`'s doc (llvmpipe shades each index once per segment, on
//! lavapipe's serial queue thread).

use std::sync::Arc;

use ash::vk;
use glam::{DMat4, DVec3};
use gpu_allocator::MemoryLocation;

use super::corners::{self, Layout};
use super::ExecDesc;
use crate::geom::ties::TieGaps;
use crate::plan::visible_ties::visible_ties;
use crate::scene::camera::DepthConvention;
use crate::scene::{Aabb, Camera, Projection, Scene};
use crate::vk::error::VkError;
use crate::vk::instance::Shared;
use crate::vk::memory::Buffer;

pub(super) struct GpuScene {
    pub vertices: Buffer,
    /// Two u32 indices per soup corner (the quad excluded): its shared corner,
    /// then at `lit_offset` further its lit corner (module doc).
    pub indices: Buffer,
    /// Where the lit corners' indices start in `indices`, in indices.
    pub lit_offset: u32,
    /// `(first vertex, vertex count)` per mesh; consecutive meshes are contiguous.
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
    /// First vertex of the full-screen quad (6 vertices).
    pub quad_first: u32,
    /// Which meshes' faces could meet the tie rule (`geom::ties`); unknown
    /// (every mesh possibly tied) once a mesh was moved.
    pub ties: TieGaps,
    /// Those of `ties` that may hold a visible point of the solid, which the
    /// final shade reads (`plan::visible_ties`); unknown with `ties`.
    pub shade_ties: TieGaps,
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
        let mut floats: Vec<f32> = Vec::new();
        let mut ranges = Vec::new();
        let mut colors = Vec::new();
        let mut bounds = Vec::new();
        for (((mesh, color), l), n) in meshes.iter().zip(&layouts).zip(&normals) {
            let first = (floats.len() / 6) as u32;
            floats.extend(soup_floats(mesh, l, n, origin));
            ranges.push((first, (floats.len() / 6) as u32 - first));
            colors.push(*color);
            bounds.push(mesh_bounds(mesh));
        }
        let quad_first = (floats.len() / 6) as u32;
        for (x, y) in [
            (-1.0f32, -1.0f32),
            (1.0, -1.0),
            (1.0, 1.0),
            (-1.0, -1.0),
            (1.0, 1.0),
            (-1.0, 1.0),
        ] {
            floats.extend([x, y, 0.0, 0.0, 0.0, 1.0]);
        }
        // Shared corners of every mesh, then lit corners of every mesh; the
        // indices in the same two runs.
        let mut indices: Vec<u32> = Vec::with_capacity(2 * quad_first as usize);
        let mut slots = Vec::with_capacity(meshes.len());
        for ((mesh, _), l) in meshes.iter().zip(&layouts) {
            let first = (floats.len() / 6) as u32;
            floats.extend(shared_floats(mesh, l, origin));
            indices.extend(l.shared_index.iter().map(|i| first + i));
            slots.push([(first, l.shared.len() as u32), (0, 0)]);
        }
        let lit_offset = indices.len() as u32;
        debug_assert_eq!(lit_offset, quad_first);
        for ((((mesh, _), l), n), slot) in meshes.iter().zip(&layouts).zip(&normals).zip(&mut slots) {
            let first = (floats.len() / 6) as u32;
            floats.extend(lit_floats(mesh, l, n, origin));
            indices.extend(l.lit_index.iter().map(|i| first + i));
            slot[1] = (first, l.lit.len() as u32);
        }
        let index_bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_ne_bytes()).collect();
        let mut index_buffer = Buffer::new(
            shared,
            "indices",
            index_bytes.len() as u64,
            vk::BufferUsageFlags::INDEX_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        index_buffer.mapped_mut()?.copy_from_slice(&index_bytes);
        let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_ne_bytes()).collect();
        let mut vertices = Buffer::new(
            shared,
            "vertices",
            bytes.len() as u64,
            vk::BufferUsageFlags::VERTEX_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        vertices.mapped_mut()?.copy_from_slice(&bytes);
        let refs: Vec<&crate::scene::Mesh> = meshes.iter().map(|(m, _)| *m).collect();
        let ties = TieGaps::new(&refs);
        // The solids' union (the opaque shade) and each solid (the layers).
        let mut exprs: Vec<_> = crate::plan::union_of_solids(scene).into_iter().collect();
        if scene.solids.len() > 1 {
            exprs.extend(scene.solids.iter().map(|s| s.expr.clone()));
        }
        let shade_ties = visible_ties(&ties, &refs, &exprs, scene.primitives.len());
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
            shade_ties,
        })
    }
}

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

/// The soup: three vertices a triangle, in the drawn corner order, each with
/// the face normal.
fn soup_floats(mesh: &crate::scene::Mesh, l: &Layout, normals: &[[f32; 3]], origin: DVec3) -> Vec<f32> {
    let mut floats = Vec::with_capacity(l.triangles.len() * 18);
    for (t, n) in l.triangles.iter().zip(normals) {
        for &i in t {
            floats.extend(position(mesh, i, origin));
            floats.extend(n);
        }
    }
    floats
}

/// The shared corners: positions only (no program that draws them reads a
/// normal).
fn shared_floats(mesh: &crate::scene::Mesh, l: &Layout, origin: DVec3) -> Vec<f32> {
    let mut floats = Vec::with_capacity(l.shared.len() * 6);
    for &i in &l.shared {
        floats.extend(position(mesh, i, origin));
        floats.extend([0.0; 3]);
    }
    floats
}

/// The lit corners: each triangle's own vertex with its face normal; the
/// corners that are no triangle's own with none (never read).
fn lit_floats(mesh: &crate::scene::Mesh, l: &Layout, normals: &[[f32; 3]], origin: DVec3) -> Vec<f32> {
    let mut floats = Vec::with_capacity(l.lit.len() * 6);
    for &(i, owner) in &l.lit {
        floats.extend(position(mesh, i, origin));
        floats.extend(owner.map_or([0.0; 3], |t| normals[t as usize]));
    }
    floats
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
        let normals = face_normals(mesh);
        let origin = scene.origin;
        let mut write = |at_vertex: u32, floats: Vec<f32>| -> Result<(), VkError> {
            let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_ne_bytes()).collect();
            let at = at_vertex as usize * 24;
            scene.vertices.mapped_mut()?[at..at + bytes.len()].copy_from_slice(&bytes);
            Ok(())
        };
        write(first, soup_floats(mesh, &l, &normals, origin))?;
        // Each set of corners where the moved mesh's fit in the slots the
        // uploaded one had; otherwise its indices name its own soup corners
        // (the same triangles, drawn without the sharing).
        let [(shared_first, shared_slots), (lit_first, lit_slots)] = scene.corner_slots[i];
        let soup: Vec<u32> = (first..first + count).collect();
        let shared_index: Vec<u32> = match l.shared.len() <= shared_slots as usize {
            true => {
                write(shared_first, shared_floats(mesh, &l, origin))?;
                l.shared_index.iter().map(|k| shared_first + k).collect()
            }
            false => soup.clone(),
        };
        let lit_index: Vec<u32> = match l.lit.len() <= lit_slots as usize {
            true => {
                write(lit_first, lit_floats(mesh, &l, &normals, origin))?;
                l.lit_index.iter().map(|k| lit_first + k).collect()
            }
            false => soup,
        };
        for (offset, idx) in [(0, shared_index), (scene.lit_offset, lit_index)] {
            let bytes: Vec<u8> = idx.iter().flat_map(|i| i.to_ne_bytes()).collect();
            let at = (offset + first) as usize * 4;
            scene.indices.mapped_mut()?[at..at + bytes.len()].copy_from_slice(&bytes);
        }
        scene.bounds[i] = mesh_bounds(mesh);
        // The gaps were the old geometry's: no draw is taken as tie-free now.
        scene.ties = TieGaps::unknown(scene.ranges.len());
        scene.shade_ties = scene.ties.clone();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every corner's vertex in the shared and lit sets holds the soup
    /// corner's position bit for bit, and a triangle's own lit vertex its
    /// normal: the three ways draw the same triangles (module doc).
    #[test]
    fn the_three_ways_hold_the_same_corners() {
        let mut mesh = crate::scene::shapes::make_sphere(0.9, 12, 8);
        for p in &mut mesh.positions {
            *p += DVec3::new(1.1, -2.3, 0.7);
        }
        let origin = DVec3::new(0.3, 7.0, -11.0);
        let l = corners::layout(&mesh);
        let normals = face_normals(&mesh);
        let soup = soup_floats(&mesh, &l, &normals, origin);
        let shared = shared_floats(&mesh, &l, origin);
        let lit = lit_floats(&mesh, &l, &normals, origin);
        let bits = |f: &[f32]| f.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(soup.len(), l.triangles.len() * 18);
        for k in 0..l.triangles.len() * 3 {
            let v = &soup[k * 6..k * 6 + 6];
            let s = l.shared_index[k] as usize * 6;
            let t = l.lit_index[k] as usize * 6;
            assert_eq!(bits(&shared[s..s + 3]), bits(&v[..3]), "shared corner {k}");
            assert_eq!(bits(&lit[t..t + 3]), bits(&v[..3]), "lit corner {k}");
            if k % 3 == 0 {
                assert_eq!(bits(&lit[t + 3..t + 6]), bits(&v[3..]), "triangle {}'s normal", k / 3);
            }
        }
    }
}
