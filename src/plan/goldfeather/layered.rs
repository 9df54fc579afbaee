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
        let layer = |first: bool, region: &Region| {
            let mut draws = Vec::new();
            for (meshes, cull) in [(&pos, Cull::Back), (&neg, Cull::Front)] {
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
        let tail = |region: &Region| {
            let mut tail = vec![Step::CopyTexture {
                src: CUR,
                dst: SURF,
            }];
            tail.extend(clip_steps_in(p, region, opts.eps, &prep.eye_inside));
            tail.extend(merge_steps_in(region));
            tail
        };
        steps.extend(layer(true, &region));
        steps.extend(tail(&region));
        steps.push(Step::CopyTexture {
            src: CUR,
            dst: PREV,
        });
        steps.push(super::super::common::peel_loop(
            prep,
            &all,
            layer(false, &later),
            tail(&later),
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
