//! Goldfeather by layers, O(kn) (Stewart, Leach & John, §4–5): instead of
//! one surface per literal, the union of a product's potentially visible faces is
//! cut into its depth-complexity layers, and each whole layer is clipped at once
//! against *all* primitives of the product — including the primitive each layer
//! pixel came from, which the less-or-equal parity test classifies as §4.3 asks
//! (a front face of a positive primitive counts itself: inside; a back face of a
//! complemented one sees two faces: outside). The nearest surviving point of every
//! layer is merged into the output depth with less-than. Per product of n
//! literals and depth complexity k: k layer extractions of n meshes, k clips of n
//! meshes and k merges, instead of n² rasterizations.
//!
//! Layer extraction: the paper's stencil-count rule (`EQUAL i`, `INCR`) needs a
//! stencil reference that changes with the layer number i, which a static plan
//! cannot express inside a data-dependent loop, and k is only known after a
//! read-back. So layer i is extracted by depth peeling instead — the nearest
//! visible face strictly behind layer i−1 (a texture) — in a [`Loop`] whose
//! occlusion query stops at the first empty layer. The layers are then depth
//! sorted (the stencil rule's are in draw order; either is a partition of the same
//! fragments up to coincident faces, which classify alike), and the depth
//! complexity k is the executor's `loop_iterations` minus one per product.
//! Non-convex primitives need nothing special: their extra faces are extra layers.
//!
//! Layers are peeled front to back, so a pixel's first surviving layer is its
//! nearest visible point, and no farther layer can win the less-than merge.
//! Each iteration therefore starts the surface image at the output depth
//! resolved so far instead of far: a pixel already resolved (by an earlier
//! layer or product) passes no peel fragment, does not keep the loop going, and
//! rejects the clip draws' fragments behind it in the depth test. The loop runs
//! to the deepest *unresolved* pixel, not to the product's depth complexity.
//!
//! A product `x ∩ ¬c₁ ∩ … ∩ ¬cₙ` of one positive primitive that is convex in
//! this view, the eye outside it (a block minus holes), is entered once, at
//! `x`'s front face: every point of it lies at or behind that face. Its first
//! layer is that face alone, and its later layers are the holes' back faces
//! behind it; `x` is not drawn again. A point of hole `c`'s back face is never
//! inside `c` (§4.3) and lies inside another hole only where their boxes meet,
//! so the later layers are clipped by `x` and by the holes whose boxes meet
//! another's, each cut to those. Holes that never meet (a drilled block) cost
//! one parity draw and one sweep per later layer, as Goldfeather's O(n) clips
//! of each hole's surface do, instead of n + 1 draws and ⌈(n + 1)/8⌉ sweeps.
#![deny(unsafe_code)]

use super::*;

/// Builds the layered Goldfeather plan.
pub fn plan(prep: &Prepared, opts: &ProductOptions) -> Result<Plan, PlanError> {
    let prods = products(prep, opts.limit)?;
    let mut steps = init_steps();
    let (order, direct) = direct_last(&prods, 0..prods.len(), prep);
    for p in order.iter().map(|&i| &prods[i]) {
        let pos: Vec<MeshId> = p.iter().filter(|l| !l.negated).map(|l| l.prim).collect();
        let neg: Vec<MeshId> = p.iter().filter(|l| l.negated).map(|l| l.prim).collect();
        let all: Vec<MeshId> = p.iter().map(|l| l.prim).collect();
        // The product lies inside each of its positive primitives, so its
        // visible points project into the overlap of their rectangles: the
        // layers, clips and merges need nothing outside it (as SCS's products,
        // `Region::Intersection`). A product of complements only is unbounded.
        let region = match pos.is_empty() {
            true => Region::Union(all.clone()),
            false => Region::Intersection(pos.clone()),
        };
        // The first layer is the nearest face: no previous layer to peel
        // behind, so it runs once before the loop and its draws only write
        // their depth (a peel test would pass everywhere, at a texture read
        // per fragment); the loop peels behind it.
        // After the first layer, a product of one positive primitive (the
        // eye outside it, its faces whole) is resolved wherever no
        // complemented primitive reaches: its first layer there is the
        // positive's nearest front face. The later layers are cut to the
        // complements' rectangle.
        let single = match pos[..] {
            [x] if !prep.eye_inside[x as usize] && !prep.near_cut[x as usize] => Some(x),
            _ => None,
        };
        let later = match single {
            Some(inside) => Region::Holes {
                inside,
                holes: neg.clone(),
            },
            None => region.clone(),
        };
        // Which faces each layer draws: the potentially visible ones (front
        // faces of the positives, back faces of the complements, §3.4). When
        // that one positive is also convex in this view, a ray enters it
        // once, at its front face: every point of the product lies at or
        // behind that face, and no other face of it is potentially visible.
        // The first layer is then that face alone (a complement's back face
        // in front of it lies outside the product), and the later layers are
        // the complements' back faces behind it: the positive is not drawn
        // again.
        let entry = single.filter(|&x| prep.convex(x) && !neg.is_empty());
        let (first_faces, later_faces) = match entry {
            Some(_) => (vec![(&pos, Cull::Back)], vec![(&neg, Cull::Front)]),
            None => {
                let both = vec![(&pos, Cull::Back), (&neg, Cull::Front)];
                (both.clone(), both)
            }
        };
        let layer = |first: bool, region: &Region| {
            let faces = match first {
                true => &first_faces,
                false => &later_faces,
            };
            let mut draws = Vec::new();
            for &(meshes, cull) in faces {
                if meshes.is_empty() {
                    continue;
                }
                let fragment = match first {
                    true => Fragment::WriteDepth { out: CUR },
                    false => Fragment::Peel {
                        prev: PREV,
                        out: CUR,
                        shade: false,
                    },
                };
                let geometry = Geometry::Meshes(meshes.clone());
                let scissor = region.cut_all(meshes);
                draws.push(into_surface(geometry, scissor, cull, fragment, !first));
            }
            // The surface image starts as a copy of the output: its depth is
            // the bound, its stencil 0 (this plan never writes the output's).
            let mut head = peel_head(draws);
            head[1] = Step::CopyDepthBound {
                src: OUTPUT,
                dst: SURFACE,
            };
            head
        };
        let tail = |region: &Region, against: Vec<(Lit, Scissor)>| {
            let mut tail = vec![Step::CopyTexture {
                src: CUR,
                dst: SURF,
            }];
            tail.extend(clip_steps_cut(
                &against,
                region.rect(),
                opts.eps,
                &prep.eye_inside,
            ));
            tail.extend(merge_steps_in(region));
            tail
        };
        let every = |region: &Region| -> Vec<(Lit, Scissor)> {
            p.iter().map(|&l| (l, region.cut(l.prim))).collect()
        };
        let later_clip = match entry {
            Some(x) => entry_clip(x, &neg, &later, prep),
            None => every(&later),
        };
        steps.extend(layer(true, &region));
        steps.extend(tail(&region, every(&region)));
        steps.push(Step::CopyTexture {
            src: CUR,
            dst: PREV,
        });
        steps.push(super::super::common::peel_loop(
            prep,
            &all,
            layer(false, &later),
            tail(&later, later_clip),
            CUR,
            PREV,
        ));
    }
    steps.extend(direct);
    steps.extend(shade_steps(prep, SURF, &VisibleSides::entries(prep)));
    Ok(Plan {
        algo: "goldfeather-layered".into(),
        depth_stencils: 2,
        textures: 3,
        stencil_bits: CLIP_BITS,
        output_ds: OUTPUT,
        steps,
    })
}

/// What a later layer of a product `x ∩ ¬holes…` entered at the convex
/// positive `x`'s front face is clipped against, each literal cut to where it
/// can change the answer. Its points are complements' back faces behind that
/// face. `x` may be behind them (a hole's wall below the block): `x` clips
/// everywhere. A point of hole `c`'s back face is never inside `c` itself
/// (both of `c`'s faces count at or in front of it, §4.3), and lies inside
/// another hole `k` only where their boxes meet: `k` clips only within the
/// rectangle of the holes whose boxes meet its own, and not at all where none
/// does. The boxes are grown by [`MEET_MARGIN`] of `x`'s box, so that faces
/// a rounding apart, which the parity tolerance classifies as coincident,
/// still meet.
fn entry_clip(x: MeshId, holes: &[MeshId], later: &Region, prep: &Prepared) -> Vec<(Lit, Scissor)> {
    let grown = |m: MeshId| {
        let b = &prep.mesh_bounds[m as usize];
        let d = prep.mesh_bounds[x as usize].max - prep.mesh_bounds[x as usize].min;
        let margin = d.length() * MEET_MARGIN;
        (b.min - margin, b.max + margin)
    };
    let boxes: Vec<_> = holes.iter().map(|&k| grown(k)).collect();
    let meet = |i: usize, j: usize| {
        let ((a0, a1), (b0, b1)) = (boxes[i], boxes[j]);
        a0.cmple(b1).all() && b0.cmple(a1).all()
    };
    let positive = Lit {
        prim: x,
        negated: false,
    };
    let mut out = vec![(positive, later.cut(x))];
    for (i, &k) in holes.iter().enumerate() {
        let near: Vec<MeshId> = (0..holes.len())
            .filter(|&j| j != i && meet(i, j))
            .map(|j| holes[j])
            .collect();
        if near.is_empty() {
            continue;
        }
        let hole = Lit {
            prim: k,
            negated: true,
        };
        out.push((
            hole,
            Scissor::Within {
                meshes: vec![k],
                within: near,
            },
        ));
    }
    out
}

/// How much [`entry_clip`] grows the holes' boxes, as a fraction of the
/// positive's box diagonal.
const MEET_MARGIN: f64 = 1e-3;
