//! Where a final-shade piece can skip the check of the output depth: outside
//! the screen rectangles of the primitives that may cut its mesh away (issue
//! 14, "Speed"; README "Embedding", "Shade pieces outside their cutters").
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
//!   (README). This is the one difference from the standalone frame the
//!   argument leaves.
//! - The other algorithms (Goldfeather-layered, Trickle, Blister, the CST
//!   variants, Kirsch) are not checked against this argument: none of their
//!   pieces is drawn without the fetch.
#![deny(unsafe_code)]

use super::goldfeather::{self, Lit, DEFAULT_PRODUCT_LIMIT};
use super::rect::Rect;
use super::step::MeshId;
use super::{tie_zones, Algo, Prepared};
use crate::scene::{Aabb, Scene};

/// The most cutter sets kept per mesh (one per one-positive product; the
/// executor takes the one that leaves the most pixels free each frame).
pub const MAX_SETS: usize = 8;

/// The most pieces (free and fetching) one mesh's piece is split into.
pub const MAX_PIECES: usize = 48;

/// What one more draw of a piece costs, in pixels of the fetch it saves: a
/// split is taken only where its free pixels exceed this per added draw.
/// Rough, from two A/B runs of `examples/embed_ab` (SCS, 800×800, lavapipe,
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
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CutAway {
    by_mesh: Vec<Vec<Vec<MeshId>>>,
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
        match goldfeather::products(prep, DEFAULT_PRODUCT_LIMIT) {
            Ok(prods) => CutAway::from_products(&prods, prep.mesh_triangles.len()),
            Err(_) => CutAway::none(),
        }
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
        CutAway { by_mesh }
    }

    /// Mesh `m`'s cutter sets (empty: none of its pieces skips the check).
    pub fn cutters(&self, m: MeshId) -> &[Vec<MeshId>] {
        self.by_mesh.get(m as usize).map_or(&[], Vec::as_slice)
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
    fn large_meshes_get_fewer_pieces() {
        assert_eq!(piece_cap(12), MAX_PIECES);
        assert_eq!(piece_cap(0), MAX_PIECES);
        assert_eq!(piece_cap(4096), 4);
        assert_eq!(piece_cap(100_000), 0);
    }
}
