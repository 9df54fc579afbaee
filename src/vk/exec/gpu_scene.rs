//! The uploaded scene: every mesh's triangles in one vertex buffer (primitives in
//! file order, then surfaces, then a full-screen quad, then each mesh's shared
//! corners), with per-mesh colours, bounds, and the camera-derived matrices the
//! push constants and scissors use.
//!
//! Two ways to draw a mesh from the one buffer:
//! - non-indexed, from its own triangles' corners, each with its face's flat
//!   normal: the shading programs, which read the normal;
//! - indexed (`indices`, u32), from its shared corners: every program that
//!   reads no interpolated output (`FragmentKind::interpolated`), i.e. the
//!   depth-only, parity, peel and clip passes. The index of soup corner `k` is
//!   at `indices[k]`, so a draw's `(first, count)` range is the same in both.
//!   llvmpipe's draw module shades each index once per 1,024-index segment
//!   (a direct-mapped cache of 256 entries keyed by the index), and runs on
//!   lavapipe's serial queue thread: a tessellated sphere's 1,584 corners are
//!   ~300 shaded vertices (README "Indexed draws for the depth-only passes").
//!   Positions are the same f32 values in both (one rounding of `p - origin`),
//!   so depth-equal tests between the two ways still see identical depths.

use std::sync::Arc;

use ash::vk;
use glam::{DMat4, DVec3};
use gpu_allocator::MemoryLocation;

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
    /// One u32 index per soup corner (the quad excluded), into the shared
    /// corners at the buffer's end (module doc).
    pub indices: Buffer,
    /// `(first vertex, vertex count)` per mesh; consecutive meshes are contiguous.
    pub ranges: Vec<(u32, u32)>,
    /// `(first vertex, vertex count)` of each mesh's shared corners.
    pub shared_corners: Vec<(u32, u32)>,
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
        let mut floats: Vec<f32> = Vec::new();
        let mut ranges = Vec::new();
        let mut colors = Vec::new();
        let mut bounds = Vec::new();
        for (mesh, color) in &meshes {
            let first = (floats.len() / 6) as u32;
            floats.extend(mesh_vertices(mesh, origin));
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
        let mut indices: Vec<u32> = Vec::with_capacity(quad_first as usize);
        let mut shared_corners = Vec::with_capacity(meshes.len());
        for (mesh, _) in &meshes {
            let first = (floats.len() / 6) as u32;
            let (corners, local) = shared_corners_of(mesh);
            floats.extend(corner_floats(mesh, &corners, origin));
            indices.extend(local.iter().map(|i| first + i));
            shared_corners.push((first, corners.len() as u32));
        }
        debug_assert_eq!(indices.len(), quad_first as usize);
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
            ranges,
            shared_corners,
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

/// A mesh's non-indexed vertices: position relative to `origin` then flat face
/// normal per corner.
fn mesh_vertices(mesh: &crate::scene::Mesh, origin: DVec3) -> Vec<f32> {
    let mut floats = Vec::with_capacity(mesh.triangles.len() * 18);
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a).normalize_or_zero();
        for p in [a - origin, b - origin, c - origin] {
            floats.extend([p.x as f32, p.y as f32, p.z as f32]);
            floats.extend([n.x as f32, n.y as f32, n.z as f32]);
        }
    }
    floats
}

/// A mesh's shared corners: the positions its triangles use, in the order of
/// first use (so that one draw's indices are close together, as the vertex
/// cache's direct mapping wants), and each triangle corner's index among them.
fn shared_corners_of(mesh: &crate::scene::Mesh) -> (Vec<u32>, Vec<u32>) {
    let mut slot = vec![u32::MAX; mesh.positions.len()];
    let mut corners = Vec::new();
    let mut local = Vec::with_capacity(mesh.triangles.len() * 3);
    for &i in mesh.triangles.iter().flatten() {
        let s = &mut slot[i as usize];
        if *s == u32::MAX {
            *s = corners.len() as u32;
            corners.push(i);
        }
        local.push(*s);
    }
    (corners, local)
}

/// The shared corners' vertices: the position rounded as `mesh_vertices`
/// rounds it (bit-identical), and no normal (no program that draws them reads
/// one).
fn corner_floats(mesh: &crate::scene::Mesh, corners: &[u32], origin: DVec3) -> Vec<f32> {
    let mut floats = Vec::with_capacity(corners.len() * 6);
    for &i in corners {
        let p = mesh.positions[i as usize] - origin;
        floats.extend([p.x as f32, p.y as f32, p.z as f32, 0.0, 0.0, 0.0]);
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
        let floats = mesh_vertices(mesh, scene.origin);
        if floats.len() != count as usize * 6 {
            return Err(VkError::Plan(format!(
                "mesh {i}: {} triangles given where {} were uploaded (a moved mesh keeps its triangles)",
                floats.len() / 18,
                count / 3
            )));
        }
        let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_ne_bytes()).collect();
        let at = first as usize * 24;
        scene.vertices.mapped_mut()?[at..at + bytes.len()].copy_from_slice(&bytes);
        // The shared corners too, where the moved mesh's fit in the slots the
        // uploaded one had; otherwise its indices name its own soup corners
        // (the same draw, without the sharing).
        let (shared_first, slots) = scene.shared_corners[i];
        let (corners, local) = shared_corners_of(mesh);
        let indices: Vec<u32> = match corners.len() <= slots as usize {
            true => {
                let floats = corner_floats(mesh, &corners, scene.origin);
                let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_ne_bytes()).collect();
                let at = shared_first as usize * 24;
                scene.vertices.mapped_mut()?[at..at + bytes.len()].copy_from_slice(&bytes);
                local.iter().map(|l| shared_first + l).collect()
            }
            false => (first..first + count).collect(),
        };
        let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_ne_bytes()).collect();
        let at = first as usize * 4;
        scene.indices.mapped_mut()?[at..at + bytes.len()].copy_from_slice(&bytes);
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
    use crate::scene::Mesh;

    /// Two triangles sharing an edge: four corners, numbered by first use, and
    /// an unused position left out.
    #[test]
    fn shared_corners_are_numbered_by_first_use() {
        let mesh = Mesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::ONE, DVec3::Z],
            triangles: vec![[3, 1, 2], [1, 0, 2]],
        };
        let (corners, local) = shared_corners_of(&mesh);
        assert_eq!(corners, vec![3, 1, 2, 0]);
        assert_eq!(local, vec![0, 1, 2, 1, 3, 2]);
    }

    /// Each shared corner is bit for bit the soup corner it stands for: the
    /// depth-equal tests between indexed and non-indexed draws rely on it.
    #[test]
    fn shared_corners_round_as_the_soup_does() {
        let mut mesh = crate::scene::shapes::make_sphere(0.9, 12, 8);
        for p in &mut mesh.positions {
            *p += DVec3::new(1.1, -2.3, 0.7);
        }
        let origin = DVec3::new(0.3, 7.0, -11.0);
        let soup = mesh_vertices(&mesh, origin);
        let (corners, local) = shared_corners_of(&mesh);
        let shared = corner_floats(&mesh, &corners, origin);
        assert_eq!(local.len() * 6, soup.len());
        assert!(corners.len() * 3 < local.len(), "a sphere shares its corners");
        for (k, &l) in local.iter().enumerate() {
            let s = &shared[l as usize * 6..l as usize * 6 + 3];
            let v = &soup[k * 6..k * 6 + 3];
            let bits = |f: &[f32]| f.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(s), bits(v), "corner {k}");
        }
    }
}
