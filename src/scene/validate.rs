//! Mesh validation: a CSG primitive must be closed and consistently oriented
//! (every directed edge used exactly once and its reverse exactly once), and
//! outward (positive signed volume). The parity tests of every algorithm count
//! boundary crossings, so an open or inside-out primitive would silently give a
//! wrong picture; these checks turn that into a load error.

use glam::DVec3;
use std::collections::HashMap;

use super::{Aabb, Mesh};

/// Why a mesh cannot bound a solid. Vertex numbers are 0-based indices into
/// `Mesh::positions` (for an OBJ: the `v` line number minus one).
#[derive(Clone, Debug, PartialEq)]
pub enum MeshProblem {
    NoTriangles,
    /// A triangle names the same vertex twice.
    RepeatedVertex {
        triangle: usize,
        indices: [u32; 3],
    },
    /// The directed edge `a → b` has no triangle using `b → a`.
    Open {
        a: u32,
        b: u32,
        uses: u32,
    },
    /// The directed edge `a → b` is used by more than one triangle.
    SameDirection {
        a: u32,
        b: u32,
        uses: u32,
    },
}

impl MeshProblem {
    /// A sentence naming the offending edge with its vertex numbers (1-based, as in
    /// an OBJ file) and positions, and the fix.
    pub fn describe(&self, mesh: &Mesh) -> String {
        let p = |i: u32| {
            let v = mesh.positions[i as usize];
            format!("v{} ({}, {}, {})", i + 1, v.x, v.y, v.z)
        };
        match *self {
            MeshProblem::NoTriangles => "the mesh has no triangles".to_string(),
            MeshProblem::RepeatedVertex { triangle, indices } => format!(
                "triangle {} uses a vertex twice (v{}, v{}, v{}); remove the degenerate face",
                triangle + 1,
                indices[0] + 1,
                indices[1] + 1,
                indices[2] + 1
            ),
            MeshProblem::Open { a, b, uses } => format!(
                "edge {} → {} is used by {uses} triangle(s) but its reverse by none; a closed \
                 mesh needs each edge in exactly two triangles with opposite directions \
                 (fill the hole, or reverse the winding of the faces that disagree)",
                p(a),
                p(b)
            ),
            MeshProblem::SameDirection { a, b, uses } => format!(
                "edge {} → {} is used by {uses} triangles in the same direction; a closed \
                 mesh needs each edge in exactly two triangles with opposite directions \
                 (the faces are inconsistently oriented or the mesh is non-manifold)",
                p(a),
                p(b)
            ),
        }
    }
}

/// Checks that every directed edge is used exactly once and its reverse exactly once.
/// Reports the problem with the smallest edge so the message is deterministic.
pub fn check_closed(mesh: &Mesh) -> Result<(), MeshProblem> {
    if mesh.triangles.is_empty() {
        return Err(MeshProblem::NoTriangles);
    }
    let mut uses: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.triangles.len() * 3);
    for (k, t) in mesh.triangles.iter().enumerate() {
        let [a, b, c] = *t;
        if a == b || b == c || a == c {
            return Err(MeshProblem::RepeatedVertex {
                triangle: k,
                indices: *t,
            });
        }
        for e in [(a, b), (b, c), (c, a)] {
            *uses.entry(e).or_insert(0) += 1;
        }
    }
    let mut worst: Option<MeshProblem> = None;
    let mut worst_key = (u32::MAX, u32::MAX);
    for (&(a, b), &n) in &uses {
        let problem = if n > 1 {
            Some(MeshProblem::SameDirection { a, b, uses: n })
        } else if !uses.contains_key(&(b, a)) {
            Some(MeshProblem::Open { a, b, uses: n })
        } else {
            None
        };
        if problem.is_some() && (a, b) < worst_key {
            worst_key = (a, b);
            worst = problem;
        }
    }
    match worst {
        Some(p) => Err(p),
        None => Ok(()),
    }
}

/// Signed volume (positive for a closed mesh with outward, CCW triangles).
pub fn signed_volume(mesh: &Mesh) -> f64 {
    // Relative to the first vertex to keep the sum well conditioned far from the origin.
    let o = mesh.positions.first().copied().unwrap_or(DVec3::ZERO);
    mesh.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize] - o);
            a.dot(b.cross(c))
        })
        .sum::<f64>()
        / 6.0
}

/// Number of triangles of zero area (collinear or coincident corners).
#[cfg(test)]
pub fn degenerate_triangles(mesh: &Mesh) -> usize {
    mesh.triangles
        .iter()
        .filter(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            (b - a).cross(c - a).length_squared() == 0.0
        })
        .count()
}

impl Mesh {
    /// Bounding box of the vertices that triangles use; `None` without triangles.
    pub fn aabb(&self) -> Option<Aabb> {
        let mut it = self
            .triangles
            .iter()
            .flatten()
            .map(|&i| self.positions[i as usize]);
        let first = it.next()?;
        let (min, max) = it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p)));
        Some(Aabb { min, max })
    }

    /// Signed volume (the free function `signed_volume`).
    pub fn signed_volume(&self) -> f64 {
        signed_volume(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::shapes::make_box;

    #[test]
    fn detects_open_and_flipped() {
        let mut m = make_box(DVec3::ONE);
        assert!(check_closed(&m).is_ok());
        assert!((signed_volume(&m) - 1.0).abs() < 1e-12);
        let mut open = m.clone();
        open.triangles.pop();
        assert!(matches!(check_closed(&open), Err(MeshProblem::Open { .. })));
        let msg = check_closed(&open).unwrap_err().describe(&open);
        assert!(msg.contains("reverse by none"), "{msg}");
        let t = &mut m.triangles[0];
        t.swap(1, 2);
        assert!(matches!(
            check_closed(&m),
            Err(MeshProblem::SameDirection { .. })
        ));
        let mut inside_out = make_box(DVec3::ONE);
        for t in &mut inside_out.triangles {
            t.swap(1, 2);
        }
        assert!(check_closed(&inside_out).is_ok());
        assert!(signed_volume(&inside_out) < 0.0);
        assert_eq!(
            check_closed(&Mesh::default()),
            Err(MeshProblem::NoTriangles)
        );
        assert_eq!(degenerate_triangles(&inside_out), 0);
    }
}
