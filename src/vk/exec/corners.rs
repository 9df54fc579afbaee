//! How one mesh's triangles reach the vertex shader: which corners are shared
//! between triangles, and in which order each triangle's corners are drawn.
//!
//! Every mesh draw is an indexed draw (`GpuScene`'s doc) from one of two sets
//! of vertices, both drawing the same triangles with the same corners in the
//! same order (so the rasterizer sees bit-identical triangles and depth-equal
//! tests between draws from the two sets hold):
//! - the **shared corners**, one vertex per position the triangles use, for the
//!   programs that read no interpolated output (depth-only, parity, peel,
//!   clip): the fewest vertices to shade;
//! - the **lit corners**, for the shading programs, which read the face's
//!   normal and `n . r` as flat inputs, i.e. from the triangle's provoking
//!   (first) vertex only. So each triangle gets a vertex of its own carrying its
//!   normal, drawn first (the triangle's corners are rotated, which keeps its
//!   winding); its other two corners reuse a recent vertex at their position,
//!   whatever normal that one carries, since no program reads a non-provoking
//!   corner's normal.
//!
//! Why it pays on lavapipe: llvmpipe's draw module, on lavapipe's serial
//! queue thread, shades each index once per 1,024-index segment through a
//! direct-mapped cache of 256 entries keyed by the index, and a non-indexed
//! draw shades every corner. Reuse is kept within [`WINDOW`] vertices so that a
//! reused vertex is still in that cache (docs/executor.md).

use crate::scene::Mesh;

/// A corner reuses a lit vertex at its position only if that vertex is among
/// the last `WINDOW` made: later ones cannot yet have evicted it from the
/// 256-entry direct-mapped cache.
pub(super) const WINDOW: u32 = 240;

/// One mesh's drawing layout (module doc). Corner `k` of the mesh, as drawn,
/// is corner `k % 3` of `triangles[k / 3]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct Layout {
    /// The mesh's triangles in order, each with its corners rotated so that its
    /// lit vertex comes first (position indices).
    pub triangles: Vec<[u32; 3]>,
    /// The shared corners: the position index of each, numbered by first use.
    pub shared: Vec<u32>,
    /// Per drawn corner, its vertex among `shared`.
    pub shared_index: Vec<u32>,
    /// The lit corners: the position index of each, and the triangle whose
    /// face normal it carries (`None`: a corner only, never a provoking vertex).
    pub lit: Vec<(u32, Option<u32>)>,
    /// Per drawn corner, its vertex among `lit`; a triangle's first is its own.
    pub lit_index: Vec<u32>,
}

/// The layout of `mesh` (module doc).
pub(super) fn layout(mesh: &Mesh) -> Layout {
    let n = mesh.triangles.len();
    let mut triangles = Vec::with_capacity(n);
    let mut lit: Vec<(u32, Option<u32>)> = Vec::with_capacity(n * 3 / 2);
    let mut lit_index = Vec::with_capacity(n * 3);
    // The newest lit vertex at each position.
    let mut newest = vec![u32::MAX; mesh.positions.len()];
    let recent = |newest: &[u32], p: u32, next: u32| {
        let v = newest[p as usize];
        v != u32::MAX && next - v < WINDOW
    };
    for (t, tri) in mesh.triangles.iter().enumerate() {
        // The provoking corner: one with no recent vertex, so that the
        // triangle's own vertex also serves its neighbours there; else the
        // triangle's first.
        let next = lit.len() as u32;
        let r = (0..3)
            .find(|&k| !recent(&newest, tri[k], next))
            .unwrap_or(0);
        let drawn = [tri[r], tri[(r + 1) % 3], tri[(r + 2) % 3]];
        triangles.push(drawn);
        let own = lit.len() as u32;
        lit.push((drawn[0], Some(t as u32)));
        newest[drawn[0] as usize] = own;
        lit_index.push(own);
        for &p in &drawn[1..] {
            let next = lit.len() as u32;
            if !recent(&newest, p, next) {
                lit.push((p, None));
                newest[p as usize] = next;
            }
            lit_index.push(newest[p as usize]);
        }
    }
    let mut slot = vec![u32::MAX; mesh.positions.len()];
    let mut shared = Vec::new();
    let mut shared_index = Vec::with_capacity(n * 3);
    for &p in triangles.iter().flatten() {
        let s = &mut slot[p as usize];
        if *s == u32::MAX {
            *s = shared.len() as u32;
            shared.push(p);
        }
        shared_index.push(*s);
    }
    Layout {
        triangles,
        shared,
        shared_index,
        lit,
        lit_index,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn sphere() -> Mesh {
        crate::scene::shapes::make_sphere(1.0, 32, 16)
    }

    /// Each drawn triangle is its mesh triangle, rotated: the same corners in
    /// the same cyclic order, so the same winding.
    #[test]
    fn triangles_are_rotations_of_the_mesh_triangles() {
        let mesh = sphere();
        let l = layout(&mesh);
        assert_eq!(l.triangles.len(), mesh.triangles.len());
        for (d, t) in l.triangles.iter().zip(&mesh.triangles) {
            let rotations = [[t[0], t[1], t[2]], [t[1], t[2], t[0]], [t[2], t[0], t[1]]];
            assert!(rotations.contains(d), "{d:?} is no rotation of {t:?}");
        }
    }

    /// Both sets draw every corner at its position; a triangle's first lit
    /// vertex carries that triangle's normal, and no other does.
    #[test]
    fn every_corner_has_its_position_and_each_triangle_its_own_first_vertex() {
        let mesh = sphere();
        let l = layout(&mesh);
        for (k, &p) in l.triangles.iter().flatten().enumerate() {
            assert_eq!(l.shared[l.shared_index[k] as usize], p, "shared corner {k}");
            assert_eq!(l.lit[l.lit_index[k] as usize].0, p, "lit corner {k}");
        }
        let mut owners = vec![0; l.triangles.len()];
        for (t, _) in l.triangles.iter().enumerate() {
            assert_eq!(l.lit[l.lit_index[3 * t] as usize].1, Some(t as u32));
        }
        for (_, owner) in &l.lit {
            if let Some(t) = owner {
                owners[*t as usize] += 1;
            }
        }
        assert!(
            owners.iter().all(|&c| c == 1),
            "one own vertex per triangle"
        );
    }

    /// Reuse stays within the cache's window, and it pays: a sphere's lit
    /// corners are far fewer than its 3 corners a triangle, its shared corners
    /// exactly its positions.
    #[test]
    fn reuse_is_recent_and_saves_most_corners() {
        let mesh = sphere();
        let l = layout(&mesh);
        let mut made = 0u32;
        for (k, &v) in l.lit_index.iter().enumerate() {
            made = made.max(v + 1);
            assert!(made - v <= WINDOW, "corner {k} reuses vertex {v} of {made}");
        }
        let t = l.triangles.len();
        assert_eq!(l.shared.len(), mesh.positions.len());
        // 976 for its 960 triangles: nearly every corner is some triangle's own.
        assert!(
            l.lit.len() < t + t / 10,
            "{} lit vertices for {t} triangles",
            l.lit.len()
        );
    }

    /// A quad's two triangles: four shared corners; the second triangle's
    /// corner at position 3 is new, so it is drawn first, as that triangle's
    /// own vertex (rotated, the same winding).
    #[test]
    fn a_quad() {
        let mesh = Mesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::ONE, DVec3::Y],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        };
        let l = layout(&mesh);
        assert_eq!(l.triangles, vec![[0, 1, 2], [3, 0, 2]]);
        assert_eq!(l.shared, vec![0, 1, 2, 3]);
        assert_eq!(l.shared_index, vec![0, 1, 2, 3, 0, 2]);
        assert_eq!(
            l.lit,
            vec![(0, Some(0)), (1, None), (2, None), (3, Some(1))]
        );
        assert_eq!(l.lit_index, vec![0, 1, 2, 3, 0, 2]);
    }
}
