//! Where a final-shade piece can skip the check of the output depth: outside
//! the screen rectangles of the primitives that may cut its mesh away
//! (docs/embedding.md).
//!
//! The embedding's written pieces (`vk::exec::record::host`, `Piece::Written`)
//! fetch the output depth on every fragment in front of the host's depth and
//! discard the ones not at it, because a face of the mesh may lie *nearer*
//! than the output depth (cut away by something else) and must not be
//! written. Where no face of the mesh can lie nearer than the output depth,
//! the piece can be drawn as a direct one is (`Piece::WrittenDirect`,
//! `plan::direct_shade`): a fragment behind the visible face is overwritten by
//! the visible face's piece, or fails the depth test after it.
//!
//! **The argument (exact geometry).** Let the solid be `S = ∪ P_k`, the sum of
//! products of the positive form (`goldfeather::products`, pruned by bounding
//! boxes, which keeps each product's point set). Take a product
//! `P = A ∩ ¬C_1 ∩ … ∩ ¬C_n` with exactly one positive literal `A`, and a pixel
//! `p` whose ray (from the near plane) meets no `C_i`. Along that ray `P` is
//! `A`, so at `A`'s first entry point the ray enters `P ⊆ S`; if the ray
//! starts outside `S` (below), `S`'s first entry, the output depth `D(p)`, is
//! at or in front of it, so *every* point of `A` on the ray lies at or behind
//! `D(p)` (all of them lie at or behind `A`'s first entry). Where the ray does
//! meet a `C_i`, a point of `A`'s boundary inside `C_i` lies in both their
//! world boxes ([`meeting`]), and points of that box on rays beyond the near
//! plane project inside its screen rectangle (`vk::scissor::bounds_rect`
//! clips the box to the near plane as the GPU clips the triangles, with a
//! pixel of margin); so a front face of `A` nearer than `D(p)` lies inside
//! the union of those rectangles, and outside it none does. (A through-hole
//! that sticks out of the block is cut to the block's box.) It needs one such product only: `A` may
//! also be a literal of other products, positive or negated; a product with
//! several positive literals gives no region (a face of `A` may lie outside
//! another positive `B` anywhere on screen), and a mesh with no one-positive
//! product gets none.
//!
//! **Rays that start inside.** The argument needs every ray to start outside
//! `S`: where it starts inside (the eye inside a primitive, a near plane
//! cutting one), `A`'s face may lie inside another product with no entry of
//! `S` in front of it. [`CutAway::of`] gives nothing when any used
//! primitive contains the eye or has a vertex in front of the near plane
//! (then the near plane can cut it), and nothing for scenes with surfaces.
//!
//! **Raster depth.** The output depth is a rasterized face depth, compared
//! bit-exactly (`shade_at_depth.frag`, `HOST_WRITE`), and the piece's own
//! fragments are the same rasterization (`gl_Position` is `invariant`). In
//! raster terms the claim is that the plan's output depth at `p` is at or in
//! front of `A`'s nearest drawn fragment, which holds when the algorithm
//! takes `A`'s nearest front fragment as a candidate of `P`, classifies the
//! `C_i` as outside at a pixel where none of them has a fragment (every
//! parity or exit test counts zero faces there), and merges its candidates
//! with a nearer-wins test. The executor uses it only for pieces drawn with
//! their back faces culled (only front faces of `A`, whose nearest one is the
//! entry; a back face of `A` at its own silhouette may rasterize in front of
//! it) and outside tie zones (the depth-equal pieces: no other mesh's face
//! within the tie band, so faces of other meshes do not swap order with
//! `A`'s in raster). Which algorithms qualify:
//! - **Goldfeather** (`goldfeather::product_steps`): each literal's visible
//!   faces are drawn nearest-first into the surface image and clipped against
//!   the *other* literals of the product only, then merged with `Less`: `A`'s
//!   nearest front fragment survives at `p` and bounds the output depth.
//! - **SCS** (`scs`): `z` is `A`'s front face, no exit moves it at `p` (no
//!   cutter fragment), and the clip keeps it where `A`'s back face lies behind
//!   it. The clip tests `z` against `A`'s own back faces, so at `A`'s own
//!   silhouette, where `A` is thinner than the tie band (or its back face
//!   rasterizes in front of its front face), SCS can drop `A`'s face: there
//!   the piece drawn without the fetch shows `A`'s face, as exact geometry
//!   and the reference do, where the standalone frame shows what lies behind
//!   (docs/embedding.md). This is the one difference from the standalone frame the
//!   argument leaves.
//! - The other algorithms (Goldfeather-layered, Trickle, Blister, the CST
//!   variants, Kirsch) are not checked against this argument: none of their
//!   pieces is drawn without the fetch.
#![deny(unsafe_code)]

use glam::DVec3;

use super::goldfeather::{self, Lit, DEFAULT_PRODUCT_LIMIT};
use super::rect::Rect;
use super::step::MeshId;
use super::{tie_zones, Algo, Prepared};
use crate::geom::clip::triangle_in_box;
use crate::scene::{Aabb, Camera, Mesh, Projection, Scene};

/// The most cutter sets kept per mesh (one per one-positive product; the
/// executor takes the one that leaves the most pixels free each frame).
pub const MAX_SETS: usize = 8;

/// The most pieces (free and fetching) one mesh's piece is split into.
pub const MAX_PIECES: usize = 48;

/// What one more draw of a piece costs, in pixels of the fetch it saves: a
/// split is taken only where its free pixels exceed this per added draw.
/// Rough, from two paired runs of embedded frames (SCS, 800×800, lavapipe,
/// 2 threads): `interference`'s block, 4 added draws for 0.26 Mpx free, saved
/// about 2 ms; `drilled_block`'s, 44 added draws for 0.22 Mpx, saved nothing
/// measurable: about 40 µs a draw, 5,000 pixels.
pub const PIECE_PIXELS: u64 = 4096;

/// The most triangles the split pieces of one mesh may draw in all: each
/// piece draws the whole mesh under its scissor, so a large mesh gets fewer
/// pieces (a guess, not fitted: the bench's split meshes are boxes).
pub const MAX_PIECE_TRIANGLES: usize = 16_384;

/// Per mesh, the cutter sets of the products in which it is the only positive
/// literal: outside the screen rectangles of one set's meshes no face of the
/// mesh lies nearer than the output depth (module doc). Empty where the
/// argument does not hold.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CutAway {
    by_mesh: Vec<Vec<Vec<MeshId>>>,
    /// Per mesh, per cutter of its sets (sorted by cutter): the world boxes
    /// holding every point of the mesh's faces that face `camera`'s eye
    /// inside the cutter's box ([`facing_parts`]; none: no such face meets
    /// it). Missing for a mesh too large to clip (then [`meeting`] serves).
    faces: Vec<Vec<(MeshId, Vec<Aabb>)>>,
    /// The camera `faces` hold for.
    camera: Option<Camera>,
    /// Per mesh, where its back faces can be visible ([`CutAway::inside_holes`]):
    /// each product that negates it, as its one positive literal and the
    /// cutters joined to the mesh through meeting boxes; `None` where a
    /// product that negates it has several positives, none negates it, or
    /// one has it as a positive ([`inside_sets`]).
    insides: Vec<Option<Vec<(MeshId, Vec<MeshId>)>>>,
}

impl CutAway {
    /// No piece skips the check.
    pub fn none() -> CutAway {
        CutAway::default()
    }

    /// The cutter sets for the plan `algo` builds from `prep` under `scene`'s
    /// camera: none for an algorithm the argument is not checked for, a scene
    /// with surfaces, or a camera whose rays may start inside a primitive
    /// (module doc).
    pub fn of(algo: Algo, prep: &Prepared, scene: &Scene) -> CutAway {
        if !matches!(algo, Algo::Goldfeather | Algo::Scs)
            || !prep.surfaces.is_empty()
            || !scene.surfaces.is_empty()
            || prep.eye_inside.iter().any(|&e| e)
            || prep.near_cut.iter().any(|&c| c)
        {
            return CutAway::none();
        }
        let cam = &scene.camera;
        // Negated so that a vertex whose depth is not a number counts as in
        // front (no split), the conservative side.
        let in_front = scene.primitives.iter().any(|p| {
            p.used
                && p.mesh
                    .positions
                    .iter()
                    .any(|&v| !(cam.view_depth(v) >= cam.near))
        });
        if in_front {
            return CutAway::none();
        }
        let Ok(prods) = goldfeather::products(prep, DEFAULT_PRODUCT_LIMIT) else {
            return CutAway::none();
        };
        let mut cut = CutAway::from_products(&prods, prep.mesh_triangles.len());
        cut.insides = inside_sets(&prods, &prep.mesh_bounds);
        // Every cutter of a one-positive product of each mesh: the kept sets
        // and the ones its cavities' insides are cut to.
        let mut all: Vec<Vec<MeshId>> = vec![Vec::new(); cut.by_mesh.len()];
        for sets in cut.insides.iter().flatten() {
            for (a, comp) in sets {
                if let Some(v) = all.get_mut(*a as usize) {
                    v.extend(comp);
                }
            }
        }
        cut.faces = all
            .into_iter()
            .enumerate()
            .map(|(m, mut cutters)| {
                cutters.extend(cut.by_mesh[m].iter().flatten());
                cutters.sort_unstable();
                cutters.dedup();
                let Some(p) = scene.primitives.get(m) else {
                    return Vec::new();
                };
                if p.mesh.triangles.len() * cutters.len() > MAX_FACE_CLIPS {
                    return Vec::new();
                }
                cutters
                    .into_iter()
                    .filter_map(|c| {
                        let b = prep.mesh_bounds.get(c as usize)?;
                        Some((c, facing_parts(&p.mesh, b, cam)))
                    })
                    .collect()
            })
            .collect();
        cut.camera = Some(*cam);
        cut
    }

    /// From the sum of products (positive literals first, as
    /// `goldfeather::products` sorts them) over `meshes` meshes: each
    /// product with exactly one positive literal gives that mesh its negated
    /// literals as one set (none: the whole piece is free). The smallest
    /// [`MAX_SETS`] sets are kept, without repeats.
    pub fn from_products(prods: &[Vec<Lit>], meshes: usize) -> CutAway {
        let mut by_mesh: Vec<Vec<Vec<MeshId>>> = vec![Vec::new(); meshes];
        for p in prods {
            let mut positive = p.iter().filter(|l| !l.negated);
            let (Some(a), None) = (positive.next(), positive.next()) else {
                continue;
            };
            let Some(sets) = by_mesh.get_mut(a.prim as usize) else {
                continue;
            };
            let mut cutters: Vec<MeshId> = p.iter().filter(|l| l.negated).map(|l| l.prim).collect();
            cutters.sort_unstable();
            cutters.dedup();
            if !sets.contains(&cutters) {
                sets.push(cutters);
            }
        }
        for sets in &mut by_mesh {
            sets.sort_by_key(|s| s.len());
            sets.truncate(MAX_SETS);
        }
        CutAway {
            by_mesh,
            ..CutAway::default()
        }
    }

    /// World boxes outside whose screen rectangles no back face of mesh `c`
    /// can be visible (its inside, drawn with its front faces culled), or
    /// `None` where the argument gives nothing. A back face `q` of `c` seen
    /// from outside the solid is seen through an opening: on the ray, `q`
    /// bounds a product `P = A ∩ ¬c ∩ …` (one positive, `A`), and between
    /// the ray's last entry `a` into `A` and `q` every point lies in `A` but
    /// not in the solid, so in some cutter of `P`; those cutters cover the
    /// segment, so they are joined to `c` through boxes that meet, and the
    /// one holding `a` holds a front face of `A` there: `a` lies in the
    /// [`CutAway::holes`] of `A` and one of `c`'s joined cutters. (The rays
    /// start outside the solid, as [`CutAway::of`] checked for its camera:
    /// `None` for another `camera`.)
    pub fn inside_holes(&self, c: MeshId, bounds: &[Aabb], camera: &Camera) -> Option<Vec<Aabb>> {
        if self.camera.as_ref() != Some(camera) {
            return None;
        }
        let sets = self.insides.get(c as usize)?.as_ref()?;
        let camera = Some(camera);
        Some(
            sets.iter()
                .flat_map(|(a, comp)| comp.iter().flat_map(|&k| self.holes(*a, k, bounds, camera)))
                .collect(),
        )
    }

    /// World boxes holding every point of mesh `m`'s faces drawn front-facing
    /// under `camera` that lies inside cutter `c` (`bounds`: the world box
    /// per mesh): [`facing_parts`] where they were found for this camera,
    /// else (another camera, or `None`) the two boxes' [`meeting`]. Empty: no
    /// such point.
    pub fn holes(
        &self,
        m: MeshId,
        c: MeshId,
        bounds: &[Aabb],
        camera: Option<&Camera>,
    ) -> Vec<Aabb> {
        let found = self
            .faces
            .get(m as usize)
            .filter(|_| camera.is_some() && self.camera.as_ref() == camera)
            .and_then(|f| {
                f.binary_search_by_key(&c, |(k, _)| *k)
                    .ok()
                    .map(|i| &f[i].1)
            });
        match found {
            Some(parts) => parts.clone(),
            None => match (bounds.get(m as usize), bounds.get(c as usize)) {
                (Some(a), Some(b)) => meeting(a, b).into_iter().collect(),
                _ => Vec::new(),
            },
        }
    }

    /// Mesh `m`'s cutter sets (empty: none of its pieces skips the check).
    pub fn cutters(&self, m: MeshId) -> &[Vec<MeshId>] {
        self.by_mesh.get(m as usize).map_or(&[], Vec::as_slice)
    }

    /// The camera the sets were made for (`None`: made for none, as
    /// [`CutAway::none`]).
    pub fn camera(&self) -> Option<&Camera> {
        self.camera.as_ref()
    }

    /// Whether no mesh has a set.
    pub fn is_empty(&self) -> bool {
        self.by_mesh.iter().all(Vec::is_empty)
    }
}

/// The world box holding every point of mesh box `a` inside cutter box `c`:
/// their intersection, `None` where they do not meet.
pub fn meeting(a: &Aabb, c: &Aabb) -> Option<Aabb> {
    let (min, max) = (a.min.max(c.min), a.max.min(c.max));
    (min.cmple(max).all()).then_some(Aabb { min, max })
}

/// Per mesh `c`, the products of `prods` that negate it, each as its one
/// positive literal and the cutters joined to `c` through meeting `bounds`
/// (`c` among them); `None` where one of those products has another number
/// of positives, none negates `c`, or a product has `c` as a positive
/// literal ([`CutAway::inside_holes`]).
pub fn inside_sets(prods: &[Vec<Lit>], bounds: &[Aabb]) -> Vec<Option<Vec<(MeshId, Vec<MeshId>)>>> {
    let mut out: Vec<Option<Vec<(MeshId, Vec<MeshId>)>>> = vec![Some(Vec::new()); bounds.len()];
    let meets = |x: MeshId, y: MeshId| match (bounds.get(x as usize), bounds.get(y as usize)) {
        (Some(a), Some(b)) => meeting(a, b).is_some(),
        _ => true,
    };
    for p in prods {
        let mut positive = p.iter().filter(|l| !l.negated);
        let one = match (positive.next(), positive.next()) {
            (Some(a), None) => Some(a.prim),
            _ => None,
        };
        let mut cutters: Vec<MeshId> = p.iter().filter(|l| l.negated).map(|l| l.prim).collect();
        cutters.sort_unstable();
        cutters.dedup();
        // The cutters joined through meeting boxes, each group found once
        // (breadth first), then given to each of its members.
        let mut group = vec![usize::MAX; cutters.len()];
        let mut groups: Vec<Vec<MeshId>> = Vec::new();
        for start in 0..cutters.len() {
            if group[start] != usize::MAX {
                continue;
            }
            let g = groups.len();
            group[start] = g;
            let mut members = vec![start];
            let mut i = 0;
            while i < members.len() {
                let x = cutters[members[i]];
                for (j, &y) in cutters.iter().enumerate() {
                    if group[j] == usize::MAX && meets(x, y) {
                        group[j] = g;
                        members.push(j);
                    }
                }
                i += 1;
            }
            let mut comp: Vec<MeshId> = members.into_iter().map(|j| cutters[j]).collect();
            comp.sort_unstable();
            groups.push(comp);
        }
        for (k, &c) in cutters.iter().enumerate() {
            let Some(slot) = out.get_mut(c as usize) else {
                continue;
            };
            let (Some(sets), Some(a)) = (slot.as_mut(), one) else {
                *slot = None;
                continue;
            };
            let comp = &groups[group[k]];
            if !sets.iter().any(|(b, g)| *b == a && g == comp) {
                sets.push((a, comp.clone()));
            }
        }
    }
    // A mesh that is also a positive literal: its faces are drawn for that
    // product too, so no draw of it is cut to its openings.
    for p in prods {
        for l in p.iter().filter(|l| !l.negated) {
            if let Some(slot) = out.get_mut(l.prim as usize) {
                *slot = None;
            }
        }
    }
    for slot in &mut out {
        if slot.as_ref().is_some_and(Vec::is_empty) {
            *slot = None;
        }
    }
    out
}

/// The most triangle clips [`CutAway::of`] does for one mesh (its triangles
/// times its cutters); a larger mesh keeps its boxes' [`meeting`].
pub const MAX_FACE_CLIPS: usize = 65_536;

/// The most boxes kept per mesh and cutter ([`facing_parts`]).
pub const MAX_FACE_BOXES: usize = 4;

/// Whether triangle `tri` is drawn front-facing under `camera` (wound
/// counter-clockwise seen from the eye, `vk::conv::FRONT_FACE`). Faces seen
/// edge-on, within 1e-6 of their normal, count as facing: the rasterizer's
/// winding may go either way there.
pub fn faces_eye(camera: &Camera, [a, b, c]: [DVec3; 3]) -> bool {
    let n = (b - a).cross(c - a);
    let to_eye = match camera.projection {
        Projection::Perspective { .. } => camera.eye - a,
        Projection::Orthographic { .. } => -camera.forward(),
    };
    !(n.dot(to_eye) <= -1e-6 * n.length() * to_eye.length())
}

/// World boxes that hold every point of `mesh`'s faces facing `camera`'s
/// eye ([`faces_eye`]) inside `cutter` (its box grown by 1e-6 of its
/// coordinates' size, for the clip's rounding): each such triangle clipped
/// to the box, boxes that touch merged, at most [`MAX_FACE_BOXES`] (else
/// one, their bounds). Tighter than the boxes' [`meeting`]: a hole bored
/// down through a block meets the block's box over its whole depth, but its
/// visible faces only at the top face's opening (the bottom face faces
/// away, so it is culled and needs no check).
pub fn facing_parts(mesh: &Mesh, cutter: &Aabb, camera: &Camera) -> Vec<Aabb> {
    let size = cutter.min.abs().max(cutter.max.abs()).max_element();
    let grow = 1e-6 * (1.0 + size);
    let grown = Aabb {
        min: cutter.min - grow,
        max: cutter.max + grow,
    };
    let mut parts: Vec<Aabb> = Vec::new();
    for t in &mesh.triangles {
        let tri = t.map(|i| mesh.positions[i as usize]);
        if !faces_eye(camera, tri) {
            continue;
        }
        let Some(mut b) = triangle_in_box(tri, &grown) else {
            continue;
        };
        // Merge with every kept box it touches, until none does.
        while let Some(i) = parts.iter().position(|p| meeting(p, &b).is_some()) {
            let p = parts.swap_remove(i);
            b = Aabb {
                min: b.min.min(p.min),
                max: b.max.max(p.max),
            };
        }
        parts.push(b);
    }
    if parts.len() > MAX_FACE_BOXES {
        let all = parts[1..].iter().fold(parts[0], |a, p| Aabb {
            min: a.min.min(p.min),
            max: a.max.max(p.max),
        });
        parts = vec![all];
    }
    parts
}

/// The most pieces a mesh of `triangles` triangles is split into: at most
/// [`MAX_PIECES`] and [`MAX_PIECE_TRIANGLES`] triangles drawn in all.
pub fn piece_cap(triangles: usize) -> usize {
    (MAX_PIECE_TRIANGLES / triangles.max(1)).min(MAX_PIECES)
}

/// `outer` split into `(free, fetched)`: disjoint rectangles, together exactly
/// `outer`'s pixels, the fetched ones covering every pixel of `outer` inside a
/// rectangle of `holes`, at most `cap` in all. Of the exact union of the
/// holes and the holes merged to ever fewer (`tie_zones::merge`: overlapping
/// ones into their bounds, then the pair that adds the least area; growing a
/// hole only moves pixels from free to fetched, which is always safe), the
/// split whose free pixels less `piece_pixels` per added draw are the most.
/// `None` where no split saves anything (the piece stays whole and
/// fetching).
pub fn split(
    outer: Rect,
    holes: &[Rect],
    cap: usize,
    piece_pixels: u64,
) -> Option<(Vec<Rect>, Vec<Rect>)> {
    if outer.is_empty() || cap == 0 {
        return None;
    }
    let holes: Vec<Rect> = holes
        .iter()
        .map(|h| h.intersect(&outer))
        .filter(|h| !h.is_empty())
        .collect();
    if holes.is_empty() {
        return Some((vec![outer], Vec::new()));
    }
    // What a split saves: its free pixels, less `piece_pixels` for each
    // draw it adds.
    let score = |free: &[Rect], fetched: &[Rect]| -> i64 {
        let area: u64 = free.iter().map(Rect::area).sum();
        area as i64 - ((free.len() + fetched.len()) as i64 - 1) * piece_pixels as i64
    };
    let mut best: Option<(i64, Vec<Rect>, Vec<Rect>)> = None;
    let mut consider = |free: Vec<Rect>, fetched: Vec<Rect>| {
        let s = score(&free, &fetched);
        if free.len() + fetched.len() <= cap && s > 0 && best.as_ref().is_none_or(|b| s > b.0) {
            best = Some((s, free, fetched));
        }
    };
    // The exact union (`subtract` takes overlapping holes as they are;
    // merging overlapping ones into their bounds first can swallow the
    // whole rectangle), then ever fewer merged holes: fewer pieces, fewer
    // free pixels.
    let free = tie_zones::subtract(outer, &holes);
    if free.is_empty() {
        return None;
    }
    let fetched = tie_zones::subtract(outer, &free);
    consider(free, fetched);
    for max in (1..=holes.len()).rev() {
        let fetched = tie_zones::merge(holes.clone(), max);
        let free = tie_zones::subtract(outer, &fetched);
        if free.is_empty() {
            // Each lower count merges further: no free pixel left there.
            break;
        }
        consider(free, fetched);
    }
    best.map(|(_, free, fetched)| (free, fetched))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(x0: u32, y0: u32, x1: u32, y1: u32) -> Rect {
        Rect { x0, y0, x1, y1 }
    }

    fn pos(prim: MeshId) -> Lit {
        Lit {
            prim,
            negated: false,
        }
    }

    fn neg(prim: MeshId) -> Lit {
        Lit {
            prim,
            negated: true,
        }
    }

    /// Every pixel of `outer` in exactly one piece, no piece outside it, every
    /// hole pixel in a fetched piece.
    fn check(outer: Rect, holes: &[Rect], free: &[Rect], fetched: &[Rect]) {
        for y in 0..outer.y1 + 2 {
            for x in 0..outer.x1 + 2 {
                let p = r(x, y, x + 1, y + 1);
                let in_free = free.iter().filter(|q| q.contains(&p)).count();
                let in_fetched = fetched.iter().filter(|q| q.contains(&p)).count();
                let want = usize::from(outer.contains(&p));
                assert_eq!(in_free + in_fetched, want, "({x}, {y})");
                if outer.contains(&p) && holes.iter().any(|h| h.contains(&p)) {
                    assert_eq!(in_fetched, 1, "hole pixel ({x}, {y}) left free");
                }
            }
        }
    }

    #[test]
    fn a_mesh_gets_the_cutters_of_each_product_it_is_the_only_positive_of() {
        // Block - H0 - H1, as one product; Shaft alone; Pin ∩ Rod (two
        // positives: no set); Rod also cut by Pin in a product of its own.
        let prods = vec![
            vec![pos(0), neg(1), neg(2)],
            vec![pos(3)],
            vec![pos(4), pos(5)],
            vec![pos(5), neg(4)],
            // The block again, cut by one hole only (a smaller set first).
            vec![pos(0), neg(2)],
            vec![pos(0), neg(1), neg(2)],
        ];
        let c = CutAway::from_products(&prods, 7);
        assert_eq!(c.cutters(0), &[vec![2], vec![1, 2]]);
        assert_eq!(c.cutters(3), &[Vec::<MeshId>::new()]);
        assert!(c.cutters(4).is_empty());
        assert_eq!(c.cutters(5), &[vec![4]]);
        // Cutters, out-of-range meshes and meshes in no product: none.
        assert!(c.cutters(1).is_empty() && c.cutters(6).is_empty());
        assert!(c.cutters(40).is_empty());
        assert!(!c.is_empty() && CutAway::none().is_empty());
    }

    #[test]
    fn at_most_max_sets_sets_are_kept_the_smallest_first() {
        let prods: Vec<Vec<Lit>> = (0..12)
            .map(|k| {
                std::iter::once(pos(0))
                    .chain((1..=12 - k).map(neg))
                    .collect()
            })
            .collect();
        let c = CutAway::from_products(&prods, 13);
        assert_eq!(c.cutters(0).len(), MAX_SETS);
        assert_eq!(c.cutters(0)[0], vec![1]);
        assert!(c.cutters(0).windows(2).all(|w| w[0].len() <= w[1].len()));
    }

    #[test]
    fn a_rectangle_splits_into_free_pieces_around_its_holes_and_fetched_ones_over_them() {
        let outer = r(10, 10, 60, 50);
        // No hole on it: one free piece.
        assert_eq!(
            split(outer, &[r(0, 0, 5, 5)], 4, 0),
            Some((vec![outer], vec![]))
        );
        // One hole inside: four free bands around it, the hole fetched.
        let holes = [r(20, 20, 30, 30)];
        let (free, fetched) = split(outer, &holes, MAX_PIECES, 0).unwrap();
        check(outer, &holes, &free, &fetched);
        assert_eq!((free.len(), fetched), (4, vec![r(20, 20, 30, 30)]));
        // A hole reaching past the edge is clipped to it.
        let holes = [r(0, 0, 30, 30)];
        let (free, fetched) = split(outer, &holes, MAX_PIECES, 0).unwrap();
        check(outer, &holes, &free, &fetched);
        assert_eq!(fetched, vec![r(10, 10, 30, 30)]);
        // Overlapping holes fetch their exact union (disjoint pieces).
        let holes = [r(20, 20, 30, 30), r(25, 25, 35, 35)];
        let (free, fetched) = split(outer, &holes, MAX_PIECES, 0).unwrap();
        check(outer, &holes, &free, &fetched);
        let area = |v: &[Rect]| v.iter().map(Rect::area).sum::<u64>();
        assert_eq!(area(&fetched), 100 + 100 - 25);
        // Too many pieces for the cap: merged into their bounds.
        let (free, fetched) = split(outer, &holes, 5, 0).unwrap();
        check(outer, &holes, &free, &fetched);
        assert_eq!(fetched, vec![r(20, 20, 35, 35)]);
        // Holes covering everything: nothing free, the piece stays whole.
        assert_eq!(split(outer, &[r(0, 0, 100, 100)], MAX_PIECES, 0), None);
        assert_eq!(split(Rect::EMPTY, &[], MAX_PIECES, 0), None);
        // A split whose free pixels do not pay for its added draws: none.
        let holes = [r(11, 11, 59, 49)];
        assert!(split(outer, &holes, MAX_PIECES, 0).is_some());
        assert_eq!(split(outer, &holes, MAX_PIECES, PIECE_PIXELS), None);
        // One that does, with the draws it adds priced.
        let holes = [r(10, 10, 20, 20)];
        let (free, fetched) = split(r(0, 0, 200, 200), &holes, MAX_PIECES, PIECE_PIXELS).unwrap();
        assert_eq!((free.len(), fetched), (4, holes.to_vec()));
    }

    #[test]
    fn a_grid_of_holes_is_merged_until_the_pieces_fit_the_cap() {
        // Twelve holes in a 4 × 3 grid (drilled_block's pattern).
        let outer = r(0, 0, 200, 150);
        let holes: Vec<Rect> = (0..4)
            .flat_map(|i| {
                (0..3).map(move |j| r(20 + 45 * i, 20 + 45 * j, 45 + 45 * i, 45 + 45 * j))
            })
            .collect();
        for cap in [MAX_PIECES, 12, 5] {
            let (free, fetched) = split(outer, &holes, cap, 0).unwrap();
            assert!(
                free.len() + fetched.len() <= cap,
                "{cap}: {free:?} {fetched:?}"
            );
            check(outer, &holes, &free, &fetched);
            let area: u64 = free.iter().map(Rect::area).sum();
            assert!(area > 0);
        }
        // One piece only: no split (a free and a fetched piece at least).
        assert_eq!(split(outer, &holes, 1, 0), None);
        // More pieces allowed: more pixels free.
        let free_area = |cap| -> u64 {
            split(outer, &holes, cap, 0)
                .unwrap()
                .0
                .iter()
                .map(Rect::area)
                .sum()
        };
        assert!(free_area(5) <= free_area(12) && free_area(12) <= free_area(64));
        assert_eq!(free_area(200), outer.area() - 12 * 25 * 25);
    }

    #[test]
    fn a_cutter_counts_only_where_it_meets_the_mesh_box() {
        use glam::DVec3;
        let b = |min: [f64; 3], max: [f64; 3]| Aabb {
            min: DVec3::from(min),
            max: DVec3::from(max),
        };
        // A hole through a block, sticking out above and below it.
        let block = b([0.0, 0.0, 0.0], [4.0, 1.0, 4.0]);
        let hole = b([1.0, -1.0, 1.0], [2.0, 2.0, 2.0]);
        assert_eq!(
            meeting(&block, &hole),
            Some(b([1.0, 0.0, 1.0], [2.0, 1.0, 2.0]))
        );
        assert_eq!(meeting(&hole, &block), meeting(&block, &hole));
        // Touching boxes meet in a face; apart, not at all.
        let touching = b([4.0, 0.0, 0.0], [5.0, 1.0, 1.0]);
        assert_eq!(
            meeting(&block, &touching),
            Some(b([4.0, 0.0, 0.0], [4.0, 1.0, 1.0]))
        );
        assert_eq!(meeting(&block, &b([5.0, 0.0, 0.0], [6.0, 1.0, 1.0])), None);
    }

    #[test]
    fn a_bore_holds_the_faces_towards_the_eye_only_at_its_opening() {
        use crate::scene::shapes::make_box;
        use glam::DVec3;
        // A block of 4 × 1 × 4 centred at the origin, a bore of 0.5 × 0.5
        // through it, standing 0.5 out above and below.
        let block = make_box(DVec3::new(4.0, 1.0, 4.0));
        let bore = Aabb {
            min: DVec3::new(0.5, -1.0, 0.5),
            max: DVec3::new(1.0, 1.0, 1.0),
        };
        let cam = |eye: DVec3| Camera {
            eye,
            target: DVec3::ZERO,
            up: DVec3::Y,
            projection: Projection::Perspective { fov_y_deg: 40.0 },
            near: 0.1,
            far: 100.0,
        };
        let near = |a: &Aabb, b: &Aabb| {
            (a.min - b.min).abs().max_element() < 1e-5 && (a.max - b.max).abs().max_element() < 1e-5
        };
        let top = Aabb {
            min: DVec3::new(0.5, 0.5, 0.5),
            max: DVec3::new(1.0, 0.5, 1.0),
        };
        // From above: only the top face's opening (the bottom one is culled).
        let above = cam(DVec3::new(2.0, 6.0, 3.0));
        let parts = facing_parts(&block, &bore, &above);
        assert_eq!(parts.len(), 1, "{parts:?}");
        assert!(near(&parts[0], &top), "{parts:?}");
        // From below: the bottom one.
        let below = cam(DVec3::new(2.0, -6.0, 3.0));
        let parts = facing_parts(&block, &bore, &below);
        assert_eq!(parts.len(), 1, "{parts:?}");
        assert!(
            near(
                &parts[0],
                &Aabb {
                    min: DVec3::new(0.5, -0.5, 0.5),
                    max: DVec3::new(1.0, -0.5, 1.0),
                }
            ),
            "{parts:?}"
        );
        // A cutter that meets the block's box but none of its faces (a
        // pocket inside): nothing.
        let pocket = Aabb {
            min: DVec3::new(0.5, -0.2, 0.5),
            max: DVec3::new(1.0, 0.2, 1.0),
        };
        assert!(facing_parts(&block, &pocket, &above).is_empty());
        assert!(meeting(&bounds_of(&block), &pocket).is_some());
        // Seen edge-on the top face still counts (the raster may draw it).
        let edge_on = cam(DVec3::new(9.0, 0.5, 0.75));
        let parts = facing_parts(&block, &bore, &edge_on);
        assert!(parts.iter().any(|p| near(p, &top)), "{parts:?}");
        // Orthographic from above: the same opening.
        let ortho = Camera {
            projection: Projection::Orthographic { height: 6.0 },
            ..above
        };
        let parts = facing_parts(&block, &bore, &ortho);
        assert!(parts.len() == 1 && near(&parts[0], &top), "{parts:?}");

        // `holes` serves the parts for their camera only, else the meeting.
        let (bounds, mut cut) = {
            let mut cut = CutAway::from_products(&[vec![pos(0), neg(1)]], 2);
            cut.faces = vec![vec![(1, facing_parts(&block, &bore, &above))], Vec::new()];
            cut.camera = Some(above);
            (vec![bounds_of(&block), bore], cut)
        };
        let got = cut.holes(0, 1, &bounds, Some(&above));
        assert!(got.len() == 1 && near(&got[0], &top), "{got:?}");
        let whole = meeting(&bounds[0], &bore).into_iter().collect::<Vec<_>>();
        assert_eq!(cut.holes(0, 1, &bounds, Some(&below)), whole);
        assert_eq!(cut.holes(0, 1, &bounds, None), whole);
        assert!(cut.holes(0, 7, &bounds, None).is_empty());
        // The bore's inside: seen only through the top opening, for the
        // camera the sets were made for.
        cut.insides = inside_sets(&[vec![pos(0), neg(1)]], &bounds);
        let got = cut.inside_holes(1, &bounds, &above).expect("one product");
        assert!(got.len() == 1 && near(&got[0], &top), "{got:?}");
        assert_eq!(cut.inside_holes(1, &bounds, &below), None);
        assert_eq!(cut.inside_holes(0, &bounds, &above), None);
    }

    #[test]
    fn a_cavity_is_seen_through_the_openings_of_the_cutters_it_meets() {
        use glam::DVec3;
        let b = |x: f64| Aabb {
            min: DVec3::new(x, 0.0, 0.0),
            max: DVec3::new(x + 1.0, 1.0, 1.0),
        };
        // Block 0 minus 1, 2, 3: 1 and 2 overlap (a counterbore), 3 apart;
        // 4 ∩ 5 minus 6 (two positives); 7 is never negated.
        let bounds = vec![
            b(0.0),
            b(0.0),
            b(0.5),
            b(3.0),
            b(9.0),
            b(9.0),
            b(9.0),
            b(0.0),
        ];
        let prods = vec![
            vec![pos(0), neg(1), neg(2), neg(3)],
            vec![pos(4), pos(5), neg(6)],
            vec![pos(7)],
            // 3 also cuts 7 alone.
            vec![pos(7), neg(3)],
            // 1 stands alone too: drawn as a positive, never cut.
            vec![pos(1)],
        ];
        let sets = inside_sets(&prods, &bounds);
        assert_eq!(sets[1], None);
        assert_eq!(sets[2], Some(vec![(0, vec![1, 2])]));
        assert_eq!(sets[3], Some(vec![(0, vec![3]), (7, vec![3])]));
        // Negated in a product of two positives; never negated: nothing.
        assert_eq!(sets[6], None);
        assert_eq!((sets[0].clone(), sets[7].clone()), (None, None));
    }

    fn bounds_of(m: &Mesh) -> Aabb {
        crate::geom::bounds(&m.positions)
    }

    #[test]
    fn large_meshes_get_fewer_pieces() {
        assert_eq!(piece_cap(12), MAX_PIECES);
        assert_eq!(piece_cap(0), MAX_PIECES);
        assert_eq!(piece_cap(4096), 4);
        assert_eq!(piece_cap(100_000), 0);
    }
}
