//! OpenSCAD's forgiving reading of a closed mesh whose faces disagree in
//! orientation: each connected part is made consistent by a breadth-first walk
//! over shared edges (a face's neighbour must traverse their common edge the
//! other way), then turned outward by the sign of its volume. OpenSCAD
//! 2021.01's preview draws such a polyhedron, its CGAL render reports "mesh is
//! not closed" and drops it; peeltrim draws it, with a warning.

use std::collections::HashMap;
use std::collections::VecDeque;

use crate::scene::validate::{check_closed, MeshProblem};
use crate::scene::Mesh;

/// Reorients `mesh` in place. `Ok(n)`: `n` triangles were reversed; `Err`:
/// the mesh is open or not manifold (an edge with other than two faces), which
/// no orientation repairs.
pub fn reorient(mesh: &mut Mesh) -> Result<usize, MeshProblem> {
    let n = mesh.triangles.len();
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::with_capacity(n * 3 / 2);
    for (t, tri) in mesh.triangles.iter().enumerate() {
        if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
            return Err(MeshProblem::RepeatedVertex {
                triangle: t,
                indices: *tri,
            });
        }
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            edges
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(t as u32);
        }
    }
    let has = |tri: &[u32; 3], a: u32, b: u32| (0..3).any(|k| tri[k] == a && tri[(k + 1) % 3] == b);
    let mut flipped = vec![false; n];
    let mut seen = vec![false; n];
    let mut count = 0;
    for start in 0..n {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        let mut part = vec![start];
        let mut queue = VecDeque::from([start]);
        while let Some(t) = queue.pop_front() {
            let tri = mesh.triangles[t];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let Some(ts) = edges.get(&(a.min(b), a.max(b))) else {
                    continue;
                };
                if ts.len() != 2 {
                    continue;
                }
                for &u in ts {
                    let u = u as usize;
                    if seen[u] {
                        continue;
                    }
                    seen[u] = true;
                    // The neighbour must use b → a.
                    if has(&mesh.triangles[u], a, b) {
                        mesh.triangles[u].swap(1, 2);
                        flipped[u] = !flipped[u];
                    }
                    part.push(u);
                    queue.push_back(u);
                }
            }
        }
        let part_mesh_volume: f64 = part
            .iter()
            .map(|&t| {
                let [a, b, c] = mesh.triangles[t].map(|i| mesh.positions[i as usize]);
                a.dot(b.cross(c))
            })
            .sum();
        if part_mesh_volume < 0.0 {
            for &t in &part {
                mesh.triangles[t].swap(1, 2);
                flipped[t] = !flipped[t];
            }
        }
        count += part.iter().filter(|&&t| flipped[t]).count();
    }
    check_closed(mesh)?;
    Ok(count)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::fixtures::{box_mesh, joined};
    use crate::scene::validate::signed_volume;
    use glam::DVec3;

    #[test]
    fn flipped_faces_are_turned_back() {
        let mut m = box_mesh(DVec3::ZERO, DVec3::ONE);
        for t in [0, 5, 7] {
            m.triangles[t].swap(1, 2);
        }
        assert!(check_closed(&m).is_err());
        assert_eq!(reorient(&mut m), Ok(3));
        assert!((signed_volume(&m) - 1.0).abs() < 1e-12);
        // Two parts, one inside out as a whole, one consistent.
        let mut inv = box_mesh(DVec3::splat(3.0), DVec3::splat(4.0));
        for t in &mut inv.triangles {
            t.swap(1, 2);
        }
        let mut two = joined(box_mesh(DVec3::ZERO, DVec3::ONE), inv);
        assert_eq!(reorient(&mut two), Ok(12));
        assert!((signed_volume(&two) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn open_meshes_stay_errors() {
        let mut m = box_mesh(DVec3::ZERO, DVec3::ONE);
        m.triangles.pop();
        assert!(matches!(reorient(&mut m), Err(MeshProblem::Open { .. })));
        let mut d = box_mesh(DVec3::ZERO, DVec3::ONE);
        d.triangles[0] = [0, 0, 1];
        assert!(matches!(
            reorient(&mut d),
            Err(MeshProblem::RepeatedVertex { .. })
        ));
    }
}
