//! `hull`, `minkowski` and `resize`: their subtrees evaluated bottom-up into
//! closed parts ("pieces") whose union is the subtree's solid, so no mesh
//! Boolean is needed.
//!
//! - A primitive is one piece; `multmatrix` transforms its children's pieces;
//!   `union`, `group`, `color` and the extrusions pass them on.
//! - `hull`: one piece, the convex hull of every vertex below it (the hull of a
//!   union is the hull of its parts' vertices).
//! - `minkowski`: the sum distributes over union, `(∪Aᵢ) ⊕ (∪Bⱼ) = ∪(Aᵢ ⊕
//!   Bⱼ)`, so the sum of children made of convex pieces is one convex piece per
//!   pair (`super::hull`), as OpenSCAD 2021.01's `applyMinkowski` does after its
//!   convex decomposition. A piece that is not convex is refused: its
//!   decomposition needs the mesh Booleans peeltrim does not evaluate on the CPU.
//! - `resize`: the bounding box of the pieces is the box of the child (every
//!   piece is part of the union), scaled about the origin as OpenSCAD's
//!   `CGALEvaluator` does for `ResizeNode`.
//!
//! `difference` and `intersection` below these nodes are refused by the
//! converter: the hull, sum or box of `A − B` needs the evaluated boundary of
//! `A − B`, a mesh Boolean.

use glam::{DMat4, DVec3};

use super::super::Mesh;
use super::hull;
use super::Pos;
use crate::scene::shapes::apply_transform;

/// A closed part of an evaluated subtree, in the frame of the subtree's node.
#[derive(Clone, Debug)]
pub struct Piece {
    /// The node kind it came from (`cube`, `hull`, ...).
    pub node: String,
    /// That node's place in the file.
    pub pos: Pos,
    pub mesh: Mesh,
    pub rgba: [f32; 4],
    /// Known convex (`Some(true)`), known not (`Some(false)`), or not checked.
    pub convex: Option<bool>,
}

impl Piece {
    fn is_convex(&mut self) -> bool {
        *self
            .convex
            .get_or_insert_with(|| hull::is_convex(&self.mesh))
    }
}

/// `pieces` under `m`.
pub fn transform(pieces: Vec<Piece>, m: &DMat4) -> Vec<Piece> {
    pieces
        .into_iter()
        .map(|mut p| {
            p.mesh = apply_transform(&p.mesh, m);
            p
        })
        .collect()
}

/// Every vertex a triangle of a piece uses.
fn vertices(pieces: &[Piece]) -> Vec<DVec3> {
    pieces
        .iter()
        .flat_map(|p| p.mesh.positions.iter().copied())
        .collect()
}

/// The hull of all pieces: one convex piece, or none when they span no
/// volume (OpenSCAD's hull of flat or empty children is empty too).
pub fn hull(mut pieces: Vec<Piece>, pos: Pos, rgba: [f32; 4]) -> Result<Vec<Piece>, String> {
    // One convex piece is its own hull.
    if let [p] = &pieces[..] {
        if p.convex == Some(true) {
            let mut p = pieces.remove(0);
            (p.node, p.pos, p.rgba) = ("hull".into(), pos, rgba);
            return Ok(vec![p]);
        }
    }
    let pts = vertices(&pieces);
    check_points(pts.len())?;
    Ok(hull::convex_hull(&pts)
        .map(|mesh| Piece {
            node: "hull".into(),
            pos,
            mesh,
            rgba,
            convex: Some(true),
        })
        .into_iter()
        .collect())
}

fn check_points(n: usize) -> Result<(), String> {
    if n > hull::MAX_HULL_POINTS {
        return Err(format!(
            "{n} points to take the convex hull of; at most {} are accepted: lower $fn or raise $fa/$fs below it",
            hull::MAX_HULL_POINTS
        ));
    }
    Ok(())
}

/// The Minkowski sum of the children, each a union of pieces: one convex
/// piece per combination of the children's pieces. A child without pieces is
/// the empty set, which OpenSCAD skips; no child gives nothing.
pub fn minkowski(kids: Vec<Vec<Piece>>, pos: Pos, rgba: [f32; 4]) -> Result<Vec<Piece>, String> {
    let mut kids = kids.into_iter().filter(|k| !k.is_empty());
    let Some(mut acc) = kids.next() else {
        return Ok(Vec::new());
    };
    let mut any = false;
    for mut next in kids {
        any = true;
        for p in acc.iter_mut().chain(next.iter_mut()) {
            if !p.is_convex() {
                return Err(format!(
                    "its child `{}` (line {}) is not convex; peeltrim sums convex parts only (a union of convex parts is fine): split it into convex parts such as cubes, spheres, cylinders or hulls",
                    p.node, p.pos.line
                ));
            }
        }
        let pairs = acc.len().saturating_mul(next.len());
        let work: usize = acc
            .iter()
            .flat_map(|a| {
                next.iter()
                    .map(move |b| a.mesh.positions.len() * b.mesh.positions.len())
            })
            .sum();
        check_points(work)?;
        let mut out = Vec::with_capacity(pairs);
        for a in &acc {
            for b in &next {
                if let Some(mesh) = hull::minkowski_convex(&a.mesh.positions, &b.mesh.positions) {
                    out.push(Piece {
                        node: "minkowski".into(),
                        pos,
                        mesh,
                        rgba,
                        convex: Some(true),
                    });
                }
            }
        }
        acc = out;
    }
    if !any {
        // A single child is itself, in the minkowski's colour.
        for p in &mut acc {
            p.rgba = rgba;
        }
    }
    Ok(acc)
}

/// `resize(newsize, auto)`: OpenSCAD 2021.01's rule. Each axis with a non-zero
/// `newsize` scales to it; an `auto` axis with newsize 0 takes the scale of
/// the axis with the largest newsize (the first of equals); the others keep
/// 1. The scaling is about the origin. `Err` for a flat child resized along
/// its flat axis (OpenSCAD leaves the child as it is then, with an error).
pub fn resize_scale(pieces: &[Piece], newsize: DVec3, auto: [bool; 3]) -> Result<DVec3, String> {
    let Some((lo, hi)) = pieces
        .iter()
        .filter_map(|p| p.mesh.aabb())
        .map(|b| (b.min, b.max))
        .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
    else {
        return Ok(DVec3::ONE);
    };
    let size = hi - lo;
    let mut scale = DVec3::ONE;
    let mut max_axis = 0;
    for i in 0..3 {
        if newsize[i] != 0.0 {
            if size[i] == 0.0 {
                return Err(format!(
                    "the child is flat along {} (its size there is 0), so it cannot be resized to {}; OpenSCAD leaves it unresized, and so does peeltrim",
                    ["x", "y", "z"][i],
                    newsize[i]
                ));
            }
            scale[i] = newsize[i] / size[i];
        }
        if newsize[i] > newsize[max_axis] {
            max_axis = i;
        }
    }
    let auto_scale = scale[max_axis];
    for i in 0..3 {
        if auto[i] && newsize[i] == 0.0 {
            scale[i] = auto_scale;
        }
    }
    Ok(scale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::fixtures::box_mesh;

    fn resize(p: Vec<Piece>, newsize: DVec3, auto: [bool; 3]) -> Result<Vec<Piece>, String> {
        let s = resize_scale(&p, newsize, auto)?;
        Ok(transform(p, &DMat4::from_scale(s)))
    }

    fn at(line: usize) -> Pos {
        Pos { line, col: 1 }
    }

    fn piece(lo: DVec3, hi: DVec3) -> Piece {
        Piece {
            node: "cube".into(),
            pos: at(1),
            mesh: box_mesh(lo, hi),
            rgba: [1.0; 4],
            convex: None,
        }
    }

    fn bounds(p: &[Piece]) -> (DVec3, DVec3) {
        p.iter()
            .map(|p| p.mesh.aabb().unwrap())
            .map(|b| (b.min, b.max))
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)))
            .unwrap()
    }

    #[test]
    fn resize_follows_openscad() {
        // Observed with OpenSCAD 2021.01 on cube([2, 4, 8]).
        let c = || vec![piece(DVec3::ZERO, DVec3::new(2.0, 4.0, 8.0))];
        let r = resize(c(), DVec3::new(10.0, 30.0, 0.0), [false, false, true]).unwrap();
        assert_eq!(bounds(&r).1, DVec3::new(10.0, 30.0, 60.0));
        let r = resize(c(), DVec3::new(0.0, 12.0, 0.0), [true; 3]).unwrap();
        assert_eq!(bounds(&r).1, DVec3::new(6.0, 12.0, 24.0));
        let moved = vec![piece(DVec3::ONE, DVec3::new(3.0, 5.0, 9.0))];
        let r = resize(moved, DVec3::new(6.0, 0.0, 0.0), [false; 3]).unwrap();
        assert_eq!(
            bounds(&r),
            (DVec3::new(3.0, 1.0, 1.0), DVec3::new(9.0, 5.0, 9.0))
        );
        let flat = vec![Piece {
            mesh: Mesh {
                positions: vec![DVec3::ZERO, DVec3::X, DVec3::Y],
                triangles: vec![[0, 1, 2]],
            },
            ..piece(DVec3::ZERO, DVec3::ONE)
        }];
        assert!(resize(flat, DVec3::new(0.0, 0.0, 3.0), [false; 3])
            .unwrap_err()
            .contains("flat along z"));
    }

    #[test]
    fn minkowski_sums_convex_pieces_pairwise() {
        let two = vec![
            piece(DVec3::ZERO, DVec3::ONE),
            piece(DVec3::new(5.0, 0.0, 0.0), DVec3::new(6.0, 1.0, 1.0)),
        ];
        let small = vec![piece(DVec3::splat(-0.5), DVec3::splat(0.5))];
        let s = minkowski(vec![two, Vec::new(), small], at(7), [0.5; 4]).unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(bounds(&s), (DVec3::splat(-0.5), DVec3::new(6.5, 1.5, 1.5)));
        assert!(s.iter().all(|p| p.node == "minkowski" && p.pos.line == 7));
        let l = Piece {
            mesh: crate::scene::fixtures::joined(
                box_mesh(DVec3::ZERO, DVec3::new(2.0, 1.0, 1.0)),
                box_mesh(DVec3::new(0.0, 1.0, 0.0), DVec3::new(1.0, 2.0, 1.0)),
            ),
            node: "polyhedron".into(),
            pos: at(3),
            ..piece(DVec3::ZERO, DVec3::ONE)
        };
        let e = minkowski(
            vec![vec![l], vec![piece(DVec3::ZERO, DVec3::ONE)]],
            at(1),
            [1.0; 4],
        )
        .unwrap_err();
        assert!(e.contains("`polyhedron` (line 3) is not convex"), "{e}");
        assert!(minkowski(vec![], at(1), [1.0; 4]).unwrap().is_empty());
    }

    #[test]
    fn hull_of_separate_parts_is_one_piece() {
        let h = hull(
            vec![
                piece(DVec3::ZERO, DVec3::ONE),
                piece(DVec3::new(3.0, 0.0, 0.0), DVec3::new(4.0, 1.0, 1.0)),
            ],
            at(2),
            [1.0; 4],
        )
        .unwrap();
        assert_eq!(h.len(), 1);
        assert!((h[0].mesh.signed_volume() - 4.0).abs() < 1e-12);
        assert!(hull(Vec::new(), at(2), [1.0; 4]).unwrap().is_empty());
    }
}
