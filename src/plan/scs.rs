//! Sequenced convex subtraction (Stewart, Leach & John, "Sequenced convex
//! subtraction", 2000/2002, the successor of their "An Improved Z-Buffer CSG
//! Rendering Algorithm"; the algorithm behind OpenCSG's `SCS`), made tie-correct
//! with the tie rule of the other algorithms.
//!
//! The positive form becomes a sum of products as for Goldfeather (Stewart,
//! Leach & John §3.2, bounding-box pruned). A product `X1 ∩ … ∩ Xa − Y1 − … − Yb` of
//! *convex* primitives is one interval per primitive along each ray, so instead of
//! clipping every literal's surface against every other (O(k²) rasterizations)
//! a single candidate depth `z` per pixel walks front to back (O(k)):
//!
//! 1. **Intersection.** `z` := the farthest front face of the `Xi` (depth test
//!    `Greater` into a surface image cleared to near): the entry into their
//!    intersection, if it is not empty along the ray.
//! 2. **Subtraction.** For each `Yj` in a *subtraction sequence*: where the point
//!    just behind `z` is inside `Yj`, `z` := `Yj`'s back face (the exit from `Yj`).
//!    `z` only moves back, and never into a `Yj` it left, so a sequence in which
//!    every chain of overlapping `Yj` appears in order leaves `z` outside all of
//!    them. `Yj` whose world boxes meet no other `Yj` need one application each;
//!    a group of overlapping ones is ordered along the rays ([`order`]: cutters
//!    with a separating plane in the order every ray meets them, small clumps
//!    of truly overlapping ones spelled out), one application each again
//!    (twice or three times within a clump). Where that fails (a cycle, a
//!    clump of more than three) the group is repeated in rounds, nearest first,
//!    at most as many as it has members, and a round whose exits moved no pixel (an occlusion query over
//!    the exit draws, resolved as the executor resolves every [`Loop`]: replayed
//!    from the previous frame's count and checked on the GPU's results, no CPU
//!    wait inside the frame) ends them early.
//! 3. **Clip.** `z` is kept where the point just behind it is inside every `Xi`
//!    (`z` only moved back, and each `Xi` is one interval along the ray, so this
//!    also rejects rays that miss the intersection), then merged into the output
//!    depth by a less-than test, and the image is shaded by depth as for
//!    Goldfeather. Where every cutter's rays start outside it, `z` is at or
//!    behind each `Xi`'s front face wherever the ray meets `Xi`, so it is inside
//!    `Xi` exactly where `Xi`'s back face lies behind it: the clip draws back
//!    faces only, and a stencil count of those that pass says whether `z` is
//!    inside all of them (`back_face_clip`: `k` back-face draws and one sweep,
//!    where Goldfeather's parity draws both sides of each `Xi` and sweeps once
//!    per eight). The first such product is drawn in the output image itself
//!    (`Target::Output`: the output still holds far there, so the sweep leaves
//!    the product's depth in place and no merge follows); the others in the
//!    surface image. There, with a single `X` (a block minus holes), clip and
//!    merge are one draw of its back faces into the output depth, no full-screen
//!    pass (`back_face_merge`).
//!
//! Every draw is cut to the intersection of the `Xi`'s screen rectangles
//! (`Region::Intersection`): the product lies inside each `Xi`, and only the
//! clip and the merge, both cut to it, read `z`. The clip of a product of one
//! `X` drawn in the output is cut further, to where an exit may have moved
//! `z` (`moved`): elsewhere `z` is `X`'s front face, which the clip keeps;
//! one clip draw and sweep per cluster of cutters apart on screen
//! (`clusters`), and the sweep may draw the cutters' back faces instead of
//! `X`'s front faces, where they cost less (`output_sweep`). The final shade
//! is cut to one positive primitive of each product
//! (`shade_within_products`; docs/bench.md, long
//! products).
//!
//! **Products side by side** (`batch`): products whose pixels cannot meet
//! on screen share one clear and one block per phase, and those apart from
//! the first product drawn in the output are drawn there too.
//!
//! **Ties** (where OpenCSG's fixed-function depth tests z-fight): "inside `Yj`"
//! and "inside `Xi`" are Goldfeather's tolerant parity draws
//! ([`Fragment::NearerThan`]): a face within the tie rule of `z` counts as in
//! front of it ([`super::tie`]), so the point classified is the one just behind
//! `z`. A flush cutter (front faces of `Xi` and `Yj` coincident) therefore
//! subtracts, a cutter that only touches `Xi` from outside (its back face at
//! `z`) does not, and an exit onto another cutter's coincident front face
//! continues into it — whichever of the two coplanar triangles rasterizes
//! nearer. `z` itself is always a rasterized fragment depth kept in a float
//! texture, never a depth-buffer round trip.
//!
//! **Tie-free cutters** (no face within the tie band of another's,
//! [`super::tie_free`]) need none of this: the executor runs their parity draws
//! as plain `LessOrEqual` depth-stencil tests with no fragment shader, against
//! the surface image, as OpenCSG's SCS does; likewise a tie-free `Xi`'s clip by
//! back faces ([`Fragment::BehindThan`]) as a plain `Greater` test, and its merge
//! by back faces with the exact compare (one texel fetch). That image holds `z` wherever a
//! parity draw's result is read because the front draws and every exit write
//! `z` into it as into the texture (the exits' depth test is off, their stencil
//! bit admits one back face per pixel). Where no front face is drawn the image
//! holds near and the texture far. Against either, the parity of a cutter the
//! ray starts outside of is even, so `z` stays far; a cutter the ray may start
//! inside (the eye correction) can differ, but the ray misses an `Xi` there,
//! and the parity clip, always used with such cutters, rejects the pixel
//! whatever `z` became. A back face of `Xi` is drawn only where its front face
//! was, so the image holds `z` wherever the clip by back faces reads it. In the
//! output image the first front face is drawn `Less` against far, and the image
//! holds far wherever the texture does. The exits keep their one-store shader: the
//! merge reads the texture, and with no `discard` the stencil test runs before
//! it, so only the pixels whose `z` moves run it.
//!
//! The exits also test depth `Greater` (and clear their bit whether it passes
//! or not). Where the whole parity set the bit that test always passes (the
//! back face lies beyond `z` by more than the tie rule); it lets a tie-free
//! cutter that every ray starts outside of skip the back faces' half of its
//! parity ([`Fragment::ParityBeforeExit`]): its front faces at or in front of
//! `z` set the bit, its back faces behind `z` exit, OpenCSG's two passes per
//! subtracted primitive, with half the parity fragments.
//!
//! **Where SCS does not apply**, the product is drawn with Goldfeather's steps
//! (`goldfeather::product_steps`) in the same plan, and `scs` says so in its
//! pass names (`surface`, not `scs-front`): a product with a non-convex
//! primitive (its faces are not one interval per ray; Goldfeather peels it in
//! layers), and a product whose ray may start inside a positive primitive (the
//! eye inside it, or an orthographic near plane cutting it: its nearest front
//! face is then not where the ray enters the product). A product of one
//! positive primitive is one draw (`goldfeather::direct_steps`).
#![deny(unsafe_code)]

mod batch;
pub(crate) mod hull;
pub(crate) mod order;

use std::cell::Cell;

use super::goldfeather::{self, Lit, ProductOptions, Region, CLIP_BITS, OUTPUT, SURF, SURFACE};
use super::screen::ScreenBox;
use super::step::*;
use super::{eye, PlanError, Prepared};
pub use hull::{Hull, Viewpoint};

/// Stencil bits of the surface image that one batch of subtractions uses: one
/// per subtracted primitive, eight primitives whose boxes are disjoint per batch.
const SUB_BITS: usize = CLIP_BITS as usize;

/// Builds the SCS plan.
pub fn plan(prep: &Prepared, opts: &ProductOptions) -> Result<Plan, PlanError> {
    let prods = goldfeather::products(prep, opts.limit)?;
    let prods = without_apart_cutters(prods, prep, &Cell::new(MAX_PRUNE_TESTS));
    let tests = Cell::new(order::MAX_PAIR_TESTS);
    let mut steps = goldfeather::init_steps();
    let (mut loops, mut surface) = (false, false);
    // The first product SCS clips by back faces is drawn first, in the output
    // image itself (`Target::Output`); the output depth is the nearest over the
    // products, whatever their order.
    let in_place = prods.iter().position(|p| {
        goldfeather::direct_steps(p, prep).is_none()
            && applies(p, prep)
            && back_face_clip_applies(p, prep)
    });
    let order = in_place
        .into_iter()
        .chain((0..prods.len()).filter(|&i| Some(i) != in_place));
    // Products of one primitive last (`goldfeather::direct_last`).
    let (order, direct) = goldfeather::direct_last(&prods, order, prep);
    // Each SCS product's subtraction sequence, in plan order (the pair tests
    // are shared), then the products side by side in one block each ([`batch`]).
    let scs: Vec<(usize, Sequence)> = order
        .iter()
        .filter(|&&i| applies(&prods[i], prep))
        .map(|&i| (i, sequence_within(&negated(&prods[i]), prep, &tests)))
        .collect();
    let groups = batch::groups(&prods, &scs, in_place, prep);
    for &i in &order {
        let p = &prods[i];
        let Some((target, members)) = groups.led_by(i) else {
            if !applies(p, prep) {
                surface = true;
                loops |= goldfeather::product_steps(p, prep, opts.eps, &mut steps);
            }
            continue;
        };
        surface |= target == Target::Surface;
        let parts = members
            .iter()
            .map(|&(m, seq)| product_steps(&prods[m], seq.clone(), prep, opts.eps, target));
        steps.extend(batch::steps(parts.collect()));
    }
    steps.extend(direct);
    steps.extend(shade_within_products(
        goldfeather::shade_steps(prep, SURF, &super::VisibleSides::entries(prep)),
        &prods,
        prep,
    ));
    Ok(Plan {
        algo: super::Algo::Scs.name().into(),
        // The surface image only for a product that is not drawn in the output.
        depth_stencils: if surface { 2 } else { 1 },
        // Goldfeather's peel textures only for a fallback product that peels.
        textures: if loops { 3 } else { 1 },
        // Only what a draw uses: a plan of one-primitive products draws no
        // stencil (and runs on a depth-only format, plan::formats).
        stencil_bits: if super::formats::steps_need_stencil(&steps) {
            CLIP_BITS
        } else {
            0
        },
        output_ds: OUTPUT,
        steps,
    })
}

/// The final shade's draws cut to where the solid can be: within the
/// rectangle of one positive primitive of each product (the one with the
/// smallest screen box), since every product lies inside each of its
/// positives and the output holds far elsewhere, which no face is shaded
/// against. A cutter's box may reach far beyond the products it cuts
/// (complex's chamfer box `RibCut`, nonconvex_obj's bores below the
/// bracket): its shade drew its faces there, and the output's clears
/// reached every pixel a frame wrote or might write (`plan::reach`). A mesh
/// still draws wherever it can tie with the visible surface of any product
/// (the tie rule names every primitive with a face there, docs/precision.md), not
/// only within the products that name it. With surfaces in the scene (drawn outside
/// the products) the shade is left whole.
fn shade_within_products(shade: Vec<Step>, prods: &[Vec<Lit>], prep: &Prepared) -> Vec<Step> {
    if !prep.surfaces.is_empty() {
        return shade;
    }
    let area = |m: MeshId| {
        prep.screen
            .get(m as usize)
            .copied()
            .flatten()
            .map_or(f64::INFINITY, |b| (b.hi - b.lo).element_product())
    };
    let mut within: Vec<MeshId> = prods
        .iter()
        .filter_map(|p| {
            p.iter()
                .filter(|l| !l.negated)
                .map(|l| l.prim)
                .min_by(|&a, &b| area(a).total_cmp(&area(b)))
        })
        .collect();
    within.sort_unstable();
    within.dedup();
    shade
        .into_iter()
        .map(|s| match s {
            Step::Draw(
                d @ Draw {
                    fragment: Fragment::ShadeNearDepth { .. },
                    ..
                },
            ) => Step::Draw(Draw {
                scissor: Scissor::Within {
                    meshes: d.geometry.meshes().to_vec(),
                    within: within.clone(),
                },
                ..d
            }),
            s => s,
        })
        .collect()
}

/// The products `prods` without the cutters that cannot change them: a
/// subtracted primitive with a plane between it and one of the product's
/// positive primitives ([`hull::apart`], on the vertices, so for any
/// primitive) has no interior point in common with the product, which lies
/// inside that positive. Bounding boxes keep it (the products are pruned by
/// box, Stewart, Leach & John §3.2): the gear's recesses, cylinders of radius
/// 1.6 whose square boxes reach the teeth at the diagonals (radius 1.9 and
/// out), were subtracted from 16 of its 36 teeth, each such product a block
/// of its own with two clears, two parity draws, two exits and a merge;
/// without them each tooth is one direct draw. A cutter that only touches the
/// positive (a face on a face) subtracts nothing under the tie rule either
/// (module documentation: a cutter touching `Xi` from outside does not).
/// At most `tests` pair tests in all ([`MAX_PRUNE_TESTS`] in a plan, apart
/// from the ordering's, [`order::MAX_PAIR_TESTS`]); past them cutters are
/// kept.
fn without_apart_cutters(
    prods: Vec<Vec<Lit>>,
    prep: &Prepared,
    tests: &Cell<usize>,
) -> Vec<Vec<Lit>> {
    let hull = |l: &Lit| prep.hulls.get(l.prim as usize);
    prods
        .into_iter()
        .map(|p| {
            let xs: Vec<&Hull> = p.iter().filter(|l| !l.negated).filter_map(hull).collect();
            p.iter()
                .copied()
                .filter(|y| {
                    let (true, Some(h)) = (y.negated, hull(y)) else {
                        return true;
                    };
                    if tests.get() < xs.len() {
                        return true;
                    }
                    tests.set(tests.get() - xs.len());
                    !xs.iter().any(|x| hull::apart(x, h).is_some())
                })
                .collect()
        })
        .collect()
}

/// Most cutter and positive primitive pairs one plan tests for a separating
/// plane to drop the cutter ([`without_apart_cutters`]), as many as the
/// ordering's tests: thousands of products keep their cutters past it.
const MAX_PRUNE_TESTS: usize = 20_000;

/// The subtracted literals of product `p`.
fn negated(p: &[Lit]) -> Vec<Lit> {
    p.iter().copied().filter(|l| l.negated).collect()
}

/// Whether SCS draws product `p`: every primitive convex, and no ray starts
/// inside a positive one (see the module documentation).
pub fn applies(p: &[Lit], prep: &Prepared) -> bool {
    let flag = |v: &[bool], m: MeshId| v.get(m as usize).copied().unwrap_or(false);
    p.iter().all(|l| prep.convex(l.prim))
        && !p
            .iter()
            .any(|l| !l.negated && (flag(&prep.eye_inside, l.prim) || flag(&prep.near_cut, l.prim)))
}

/// Which products `scs` draws with Goldfeather's steps and why, for the command
/// line (`None` when SCS draws them all, or when the products cannot be formed:
/// the plan then fails with that error).
pub fn fallback_warning(prep: &Prepared) -> Option<String> {
    let prods = goldfeather::products(prep, goldfeather::DEFAULT_PRODUCT_LIMIT).ok()?;
    let flag = |v: &[bool], m: MeshId| v.get(m as usize).copied().unwrap_or(false);
    let (mut fallback, mut nonconvex, mut start_inside) = (0, Vec::new(), Vec::new());
    for p in prods.iter().filter(|p| p.len() > 1 && !applies(p, prep)) {
        fallback += 1;
        for l in p {
            if !prep.convex(l.prim) {
                nonconvex.push(l.prim + 1);
            } else if !l.negated && (flag(&prep.eye_inside, l.prim) || flag(&prep.near_cut, l.prim))
            {
                start_inside.push(l.prim + 1);
            }
        }
    }
    if fallback == 0 {
        return None;
    }
    let list = |v: &mut Vec<u32>| {
        v.sort_unstable();
        v.dedup();
        v.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
    };
    let mut why = Vec::new();
    if !nonconvex.is_empty() {
        why.push(format!(
            "non-convex primitive(s) {} (SCS needs one front and one back face per ray; from this camera their faces may overlap on screen)",
            list(&mut nonconvex)
        ));
    }
    if !start_inside.is_empty() {
        why.push(format!(
            "rays starting inside positive primitive(s) {} (eye inside, or the orthographic near plane cuts them)",
            list(&mut start_inside)
        ));
    }
    Some(format!(
        "scs draws {fallback} of {} products with goldfeather's steps: {} (primitives by 1-based index in file order); \
         the image is exact either way",
        prods.len(),
        why.join("; ")
    ))
}

/// Where a product's candidate depth `z` is kept (module documentation, 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    /// The surface image (cleared to near), then merged into the output.
    Surface,
    /// The output image itself, while it holds far and stencil 0 everywhere
    /// (the first product drawn): the clip's sweep leaves the product's depth
    /// there, and no merge is needed.
    Output,
}

impl Target {
    fn ds(self) -> Ds {
        match self {
            Target::Surface => SURFACE,
            Target::Output => OUTPUT,
        }
    }
}

/// Whether the rays of every cutter of `p` start outside it, so that the
/// clip can go by the positive primitives' back faces ([`back_face_clip`]),
/// with a stencil count of them that fits the stencil bits.
fn back_face_clip_applies(p: &[Lit], prep: &Prepared) -> bool {
    let flag = |v: &[bool], m: MeshId| v.get(m as usize).copied().unwrap_or(false);
    let start_inside = |y: &Lit| flag(&prep.eye_inside, y.prim) || flag(&prep.near_cut, y.prim);
    let positives = p.iter().filter(|l| !l.negated).count();
    !p.iter().any(|l| l.negated && start_inside(l)) && positives < 1 << CLIP_BITS
}

/// The steps of one product of convex primitives (module documentation, 1–3),
/// by phase ([`batch::Parts`]), with its subtraction sequence `seq`.
/// `Target::Output` needs [`back_face_clip_applies`].
fn product_steps(
    p: &[Lit],
    seq: Sequence,
    prep: &Prepared,
    eps: f32,
    target: Target,
) -> batch::Parts {
    let xs: Vec<Lit> = p.iter().copied().filter(|l| !l.negated).collect();
    // Where the product can be: inside every positive primitive, so inside the
    // intersection of their rectangles. Only the clip and the merge read `z`,
    // and both are cut to it, so every draw is.
    let region = Region::Intersection(xs.iter().map(|l| l.prim).collect());
    let ds = target.ds();
    let mut clears = Vec::new();
    if target == Target::Surface {
        clears.push(Step::Clear(Clear::DepthStencil {
            ds,
            depth: 0.0,
            stencil: 0,
        }));
    }
    clears.push(Step::Clear(Clear::Texture {
        tex: SURF,
        depth: goldfeather::FAR,
    }));
    // The farthest front face; where no front face is drawn `z` stays far, which
    // no subtraction moves and the clip rejects. In the output (far
    // everywhere) the first one is drawn `Less`: where it is not drawn the
    // product is empty, and `z` stays far in the image as in the texture.
    let mut front = Vec::new();
    for (i, x) in xs.iter().enumerate() {
        let compare = match target {
            Target::Output if i == 0 => CompareOp::Less,
            _ => CompareOp::Greater,
        };
        front.push(Step::Draw(Draw {
            geometry: Geometry::Mesh(x.prim),
            scissor: region.cut(x.prim),
            cull: x.visible_cull(),
            ds,
            depth: DepthState {
                compare,
                write: true,
            },
            stencil: None,
            fragment: Fragment::WriteDepth { out: SURF },
            count_samples: false,
        }));
    }
    let at = Subtraction {
        prep,
        region: &region,
        eps,
        count: false,
        ds,
    };
    let once = subtract(&seq.once, at);
    let rounds = (!seq.rounds.is_empty()).then(|| {
        let mut head = vec![Step::Pass("subtract".into())];
        head.extend(subtract(&seq.rounds, Subtraction { count: true, ..at }));
        Step::Loop(Loop {
            head,
            tail: Vec::new(),
            max_iterations: seq.max_rounds,
        })
    });
    let back_faces = back_face_clip_applies(p, prep);
    assert!(
        back_faces || target == Target::Surface,
        "a product is drawn in the output only when its clip goes by back faces"
    );
    let mut finish = Vec::new();
    match (xs.as_slice(), target) {
        ([x], Target::Surface) if back_faces => finish.extend(back_face_merge(*x, &region, eps)),
        (_, Target::Output) => {
            let over = output_sweep(p, &region, prep);
            let at = moved(p, prep).unwrap_or_else(|| vec![region]);
            finish.extend(back_face_clip(&xs, &at, eps, Sweep::Output(over)))
        }
        (_, Target::Surface) if back_faces => {
            finish.extend(back_face_clip(
                &xs,
                std::slice::from_ref(&region),
                eps,
                Sweep::Surface,
            ));
            finish.extend(goldfeather::merge_steps_in(&region));
        }
        (_, Target::Surface) => {
            finish.extend(goldfeather::clip_steps_in(
                &xs,
                &region,
                eps,
                &prep.eye_inside,
            ));
            finish.extend(goldfeather::merge_steps_in(&region));
        }
    }
    batch::Parts {
        clears,
        front,
        once,
        rounds,
        finish,
    }
}

/// Where the clip of product `p` drawn in the output must run when it has
/// one positive primitive `x`: where a cutter's exit may have moved `z`
/// (`x`'s rectangle cut to the union of the cutters', as their exits are).
/// Elsewhere `z` is `x`'s front face, or far where no front face was drawn:
/// the point just behind a front face of convex `x` is inside it, so the clip
/// would keep every such pixel (interference: the block's clip over the bore
/// only). `None` with several positive primitives: `z`, the farthest front
/// face, may lie behind another one's back face anywhere.
///
/// The cutters come in clusters ([`clusters`]), one clip draw and sweep
/// each: nonconvex_obj's two bores lie at opposite ends of the bracket, and
/// the rectangle of both covered most of it. Clusters may overlap (the
/// executor's rectangles are its meshes' boxes', grown after a camera move):
/// the clip's stencil op is then idempotent ([`back_face_clip`]). Clusters
/// pay at the bench's sizes (a draw counts as [`DRAW_PIXELS`]): at 128×128
/// (the GPU tests' size) every product keeps one.
fn moved(p: &[Lit], prep: &Prepared) -> Option<Vec<Region>> {
    let [x] = p.iter().filter(|l| !l.negated).collect::<Vec<_>>()[..] else {
        return None;
    };
    let ys: Vec<MeshId> = p.iter().filter(|l| l.negated).map(|l| l.prim).collect();
    (!ys.is_empty()).then(|| {
        clusters(x.prim, &ys, prep)
            .into_iter()
            .map(Region::Union)
            .collect()
    })
}

/// Pixels one more draw is counted as, for choosing the clip's clusters: a
/// guess, as [`DRAW_TRIANGLES`] (docs/bench.md).
const DRAW_PIXELS: f64 = 16384.0;

/// At most this many cutters are clustered; more stay one cluster (the
/// greedy merge below is cubic).
const MAX_CLUSTERED: usize = 32;

/// The cutters `ys` of a product of one positive primitive `x` in clusters
/// whose screen boxes, cut to `x`'s, each cost a clip draw and a sweep: two
/// clusters merge while their union's box costs less than the two boxes and
/// a pair of draws ([`DRAW_PIXELS`] each). One cluster of all where a screen
/// box is unknown.
fn clusters(x: MeshId, ys: &[MeshId], prep: &Prepared) -> Vec<Vec<MeshId>> {
    let screen = |m: MeshId| prep.screen.get(m as usize).copied().flatten();
    let all = || vec![ys.to_vec()];
    let Some(xb) = screen(x) else {
        return all();
    };
    let cut = |b: ScreenBox| {
        let (lo, hi) = (b.lo.max(xb.lo), b.hi.min(xb.hi));
        (hi - lo).max(glam::DVec2::ZERO).element_product()
    };
    let boxes: Option<Vec<ScreenBox>> = ys.iter().map(|&y| screen(y)).collect();
    let Some(boxes) = boxes.filter(|_| ys.len() <= MAX_CLUSTERED) else {
        return all();
    };
    let mut cs: Vec<(ScreenBox, Vec<MeshId>)> =
        boxes.into_iter().zip(ys.iter().map(|&y| vec![y])).collect();
    'merge: loop {
        for i in 0..cs.len() {
            for j in i + 1..cs.len() {
                let union = cs[i].0.union(&cs[j].0);
                if cut(union) <= cut(cs[i].0) + cut(cs[j].0) + 2.0 * DRAW_PIXELS {
                    let (_, b) = cs.remove(j);
                    cs[i].0 = union;
                    cs[i].1.extend(b);
                    continue 'merge;
                }
            }
        }
        break;
    }
    cs.into_iter().map(|(_, c)| c).collect()
}

/// Triangles one more draw is counted as, for choosing what a sweep draws:
/// a guess, not a calibration. A one-frame callgrind run of nonconvex_obj's
/// bracket (12 triangles) swept over its two bores instead (248, two draws)
/// ran 2 M more instructions in lavapipe, where many_50's 6048 fewer
/// triangles (one draw for one) ran 7.9 M fewer (docs/perf/: the output
/// clip's sweep over the cutters).
const DRAW_TRIANGLES: usize = 1024;

/// The footprints the clip's sweep of product `p`, drawn in the output,
/// covers ([`footprint_sweep`]), each with its scissor. By default the first
/// positive primitive's front faces over the clip's rectangle. With one
/// positive primitive `x` the sweep need only reach where an exit moved `z`
/// ([`moved`]): elsewhere `z` is `x`'s front face, which the count keeps, or
/// far, which the sweep would write again. Every exit draws its cutter's back
/// faces within the product's region, so the cutters' back faces, culled and
/// cut as the exits, cover those pixels; they are swept instead where they
/// cost less ([`DRAW_TRIANGLES`]: a sphere drilled by a cylinder sweeps the
/// cylinder's 96 triangles, not the sphere's 528; a box drilled by twelve
/// holes keeps the box's 12). A pixel covered twice is swept twice, which the
/// sweep's stencil allows (its second fragment sees the count it left).
fn output_sweep(p: &[Lit], region: &Region, prep: &Prepared) -> Vec<(Lit, Scissor)> {
    let x = *p
        .iter()
        .find(|l| !l.negated)
        .expect("a product has a positive primitive");
    let Some(clipped) = moved(p, prep) else {
        return vec![(x, region.cut(x.prim))];
    };
    let ys = negated(p);
    let cost = |ls: &[Lit]| -> usize {
        ls.iter()
            .map(|l| prep.mesh_triangles[l.prim as usize] + DRAW_TRIANGLES)
            .sum()
    };
    if cost(&ys) < cost(&[x]) {
        // Each cutter's footprint where its exits drew: within its cluster's
        // count draws ([`clip_cut`]), and all that `z` can have moved in.
        ys.into_iter()
            .map(|y| (y, exit_scissor(y.prim, x.prim)))
            .collect()
    } else {
        clipped
            .into_iter()
            .map(|r| (x, clip_cut(&r, x.prim)))
            .collect()
    }
}

/// Positive primitive `x`'s rectangle cut to the clip's `region`. A cluster
/// of one cutter `c` ([`moved`]) is cut as `c`'s exits are
/// ([`Scissor::Openings`], `batch_steps`): `z` moved only where they drew,
/// so the clip's count and sweep change nothing elsewhere, and the same
/// scissor resolves to the same rectangle for all three (grown alike after
/// a camera move). Where the executor knows `c`'s openings that is a few
/// pixels of the bore's mouth, not the bore's whole rectangle.
fn clip_cut(region: &Region, x: MeshId) -> Scissor {
    match region {
        Region::Union(cs) if cs.len() == 1 => exit_scissor(cs[0], x),
        r => r.cut(x),
    }
}

/// The scissor of cutter `c`'s parity and exit draws in a product of one
/// positive primitive `x` (`batch_steps`: `c`'s rectangle and `x`'s, cut to
/// `c`'s openings), which the clip after them shares.
fn exit_scissor(c: MeshId, x: MeshId) -> Scissor {
    Scissor::Openings {
        of: c,
        and: vec![x],
    }
}

/// Where the clip by back faces leaves its result: in the output, swept over
/// the footprints given ([`output_sweep`]), or in the surface image
/// ([`Target`]).
enum Sweep {
    Output(Vec<(Lit, Scissor)>),
    Surface,
}

/// The clip of a product whose cutters' rays all start outside them (module
/// documentation, 3): `z` is at or behind every positive primitive's front
/// face wherever it is drawn, so it is inside `xi` exactly where `xi`'s back
/// face lies behind it ([`Fragment::BehindThan`], the tie rule decided as the
/// parity clip's), and in the product where all `k` back faces pass. Each
/// passing back face increments the stencil (one back face per pixel and
/// primitive); one sweep sets far where the count is not `k` (a ray missing
/// an `xi` draws none of its back faces) and clears the count. In the output
/// image the sweep writes the image only, over footprints
/// ([`footprint_sweep`], [`output_sweep`]); in the surface image the texture
/// too, for the merge that follows, over the product's rectangle. The
/// count draws run once per region of `regions` (several only for one
/// positive primitive, [`moved`]); with several, a passing back face sets
/// the count to 1 instead of incrementing it, so a pixel in two regions'
/// rectangles counts once.
fn back_face_clip(xs: &[Lit], regions: &[Region], eps: f32, sweep: Sweep) -> Vec<Step> {
    let target = match sweep {
        Sweep::Output(_) => Target::Output,
        Sweep::Surface => Target::Surface,
    };
    let k = xs.len() as u32;
    assert!(
        k < 1 << CLIP_BITS,
        "{k} positive primitives overflow the stencil count"
    );
    let inside = k as u8;
    // The bits the count needs.
    let mask = (u32::MAX >> (k.leading_zeros())) as u8;
    assert!(
        regions.len() == 1 || (k == 1 && target == Target::Output),
        "only a product of one positive primitive drawn in the output clips by regions"
    );
    // Several regions may overlap: set the count there. One region keeps
    // the increment, which also rejects a second back face (a primitive
    // wrongly taken as convex shows wrong, `vk_tests/view_convex.rs`).
    let (count, reference) = if regions.len() > 1 {
        (StencilOp::Replace, inside)
    } else {
        (StencilOp::IncrementAndClamp, 0)
    };
    let ds = target.ds();
    let mut steps = vec![Step::Pass("clip".into())];
    for region in regions {
        for x in xs {
            steps.push(Step::Draw(Draw {
                geometry: Geometry::Mesh(x.prim),
                scissor: clip_cut(region, x.prim),
                cull: Cull::Front,
                ds,
                depth: DepthState {
                    compare: CompareOp::Always,
                    write: false,
                },
                stencil: Some(super::stencil::both(
                    CompareOp::Always,
                    count,
                    0,
                    mask,
                    reference,
                )),
                fragment: Fragment::BehindThan { tex: SURF, eps },
                count_samples: false,
            }));
        }
    }
    match sweep {
        Sweep::Output(over) => steps.extend(
            over.into_iter()
                .map(|(l, scissor)| footprint_sweep(l, scissor, mask, inside)),
        ),
        Sweep::Surface => steps.push(goldfeather::reject_sweep_into(
            ds,
            Fragment::WriteDepth { out: SURF },
            mask,
            inside,
            regions[0].rect(),
        )),
    }
    steps
}

/// One draw of the clip's sweep of a product drawn in the output
/// (`Target::Output`): far where the count of `mask` bits is not `inside`,
/// over the footprint of literal `l` within `scissor` only (a quad over the
/// product's rectangle covered the whole image on nonconvex_obj, four times
/// the pixels). By default `l` is the product's first positive primitive `x`:
/// only there can `z` be other than far. The output held far everywhere,
/// `x`'s front faces wrote the first `z` with `Less`, and every later front
/// face (`Greater`) and exit (`Greater`, behind `z`) passes only where one
/// was written, so elsewhere the count is 0 and far is what the image holds.
/// `x` is convex from the eye, so its front faces, drawn with the cull of
/// its front draw and the clip's scissor (the front draw's, or less:
/// [`moved`]) ([`Geometry::Footprint`]: at the far depth, clipped as that
/// draw), cover each of those pixels once. With one positive primitive the
/// cutters' back faces may stand in ([`output_sweep`]). The count is kept
/// where it passes (stencil `fail` keeps it: where a pixel is covered twice,
/// its second fragment must not reject it), and nothing reads the output's
/// stencil there after the clip (products side by side, [`batch`], clip
/// other pixels).
fn footprint_sweep(l: Lit, scissor: Scissor, mask: u8, inside: u8) -> Step {
    let Step::Draw(sweep) =
        goldfeather::reject_sweep_into(OUTPUT, Fragment::None, mask, inside, scissor)
    else {
        unreachable!("a reject sweep is a draw")
    };
    let mut stencil = sweep.stencil.expect("a reject sweep tests the stencil");
    stencil.front.fail = StencilOp::Keep;
    stencil.back.fail = StencilOp::Keep;
    Step::Draw(Draw {
        geometry: Geometry::Footprint {
            mesh: l.prim,
            depth: goldfeather::FAR,
        },
        cull: l.visible_cull(),
        stencil: Some(stencil),
        ..sweep
    })
}

/// The clip and merge of a product with one positive primitive `x` (module
/// documentation, 3) whose cutters all start outside every ray, drawn in the
/// surface image (not the first such product), as one draw
/// of `x`'s back faces into the output depth ([`Fragment::MergeBehind`]) and
/// no full-screen pass. Where the ray meets `x`, `z` is at or behind its
/// front face (it starts there and only moves back), so `z` is inside `x`
/// exactly where the back face is behind it (the tie rule, as the parity
/// clip's); there the back face's fragment carries `z` into the output with
/// the less-than test. Where the ray misses `x`, no front face was drawn and
/// `z` is still the texture's far (no cutter's parity is odd along a ray
/// starting outside it, so no exit moved it), and no back face is drawn
/// either. A convex `x` has one back face per pixel, so each pixel merges at
/// most once.
fn back_face_merge(x: Lit, region: &Region, eps: f32) -> Vec<Step> {
    vec![
        Step::Pass("merge".into()),
        Step::Draw(Draw {
            geometry: Geometry::Mesh(x.prim),
            scissor: region.cut(x.prim),
            cull: Cull::Front,
            ds: OUTPUT,
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: None,
            fragment: Fragment::MergeBehind { tex: SURF, eps },
            count_samples: false,
        }),
    ]
}

/// A product's subtraction sequence (module documentation, 2).
#[derive(Clone, Debug, PartialEq)]
pub struct Sequence {
    /// Applied once, in this order: the subtracted primitives whose boxes meet
    /// no other's, and the groups of overlapping ones that [`order`] sorts
    /// along the rays (a primitive of a clump appears more than once),
    /// interleaved so that batches of disjoint boxes fill up.
    pub once: Vec<Lit>,
    /// One round over every group of overlapping subtracted primitives (the
    /// groups interleaved, so that batches of disjoint boxes fill up).
    pub rounds: Vec<Lit>,
    /// Rounds that suffice: the largest group's size.
    pub max_rounds: u32,
}

/// Groups `ys` by overlapping world boxes (connected components: an exit from
/// one `Yj` can only land inside a `Yk` whose box meets its own).
#[cfg(test)]
pub fn sequence(ys: &[Lit], prep: &Prepared) -> Sequence {
    sequence_within(ys, prep, &Cell::new(order::MAX_PAIR_TESTS))
}

/// [`sequence`] with at most `tests` pair tests left for ordering groups.
fn sequence_within(ys: &[Lit], prep: &Prepared, tests: &Cell<usize>) -> Sequence {
    let boxes = &prep.mesh_bounds;
    let mut group: Vec<usize> = (0..ys.len()).collect();
    fn root(g: &mut [usize], mut i: usize) -> usize {
        while g[i] != i {
            g[i] = g[g[i]];
            i = g[i];
        }
        i
    }
    for i in 0..ys.len() {
        for j in i + 1..ys.len() {
            let (a, b) = (&boxes[ys[i].prim as usize], &boxes[ys[j].prim as usize]);
            if !super::cst::disjoint(a, b) {
                let (ri, rj) = (root(&mut group, i), root(&mut group, j));
                group[ri] = rj;
            }
        }
    }
    let mut members: Vec<Vec<Lit>> = vec![Vec::new(); ys.len()];
    for (i, &y) in ys.iter().enumerate() {
        let r = root(&mut group, i);
        members[r].push(y);
    }
    let (mut sorted, mut groups) = (Vec::new(), Vec::new());
    for m in members.into_iter().filter(|m| !m.is_empty()) {
        match ordered(&m, prep, tests) {
            Ok(seq) => sorted.push(seq),
            Err(round) => groups.push(round),
        }
    }
    let touch =
        |a: Lit, b: Lit| !super::cst::disjoint(&boxes[a.prim as usize], &boxes[b.prim as usize]);
    let once = order::by_levels(&sorted, touch);
    let max_rounds = groups.iter().map(Vec::len).max().unwrap_or(0) as u32;
    let rounds = order::by_levels(&groups, touch);
    Sequence {
        once,
        rounds,
        max_rounds,
    }
}

/// The group `m` of cutters with touching boxes applied once each in ray
/// order ([`order::sequence`]; a single cutter is itself), or, where that
/// does not apply, one round over it in the order [`order::rounds_order`]
/// gives (as listed when the view or the hulls are unknown, the group is
/// larger than [`order::MAX_GROUP`], or the plan's [`order::MAX_PAIR_TESTS`]
/// are spent: thousands of products of overlapping cutters).
fn ordered(m: &[Lit], prep: &Prepared, tests: &Cell<usize>) -> Result<Vec<Lit>, Vec<Lit>> {
    let pairs = m.len() * m.len().saturating_sub(1) / 2;
    let (hulls, view) = match (m, prep.viewpoint) {
        ([_], _) => return Ok(m.to_vec()),
        (_, Some(view)) if m.len() <= order::MAX_GROUP && pairs <= tests.get() => (
            m.iter()
                .map(|l| prep.hulls.get(l.prim as usize))
                .collect::<Option<Vec<&Hull>>>(),
            view,
        ),
        _ => return Err(m.to_vec()),
    };
    let Some(hulls) = hulls else {
        return Err(m.to_vec());
    };
    tests.set(tests.get() - pairs);
    let boxes = &prep.mesh_bounds;
    let touch = |i: usize, j: usize| {
        !super::cst::disjoint(&boxes[m[i].prim as usize], &boxes[m[j].prim as usize])
    };
    let pairs = order::pairs(&hulls, touch, view);
    let pick = |seq: Vec<usize>| seq.into_iter().map(|i| m[i]).collect();
    match order::sequence(m.len(), &pairs) {
        Some(seq) => Ok(pick(seq)),
        None => {
            let depth: Vec<f64> = m
                .iter()
                .map(|l| view.nearest(&boxes[l.prim as usize]))
                .collect();
            Err(pick(order::rounds_order(m.len(), &pairs, &depth)))
        }
    }
}

/// Subtracts `ys` in order, in batches of up to [`SUB_BITS`] primitives whose
/// boxes are pairwise disjoint (at most one of them holds a pixel's `z`, and no
/// exit lands in another, so the batch equals its sequence): per primitive a
/// parity draw into its bit (inside: odd), then per primitive its back faces
/// written into `z` where its bit is set, clearing the bit.
#[derive(Clone, Copy)]
struct Subtraction<'a> {
    prep: &'a Prepared,
    /// Where the product can be (every draw is cut to it).
    region: &'a Region,
    eps: f32,
    /// The exits count samples (the rounds' early out).
    count: bool,
    /// The image holding `z` ([`Target`]).
    ds: Ds,
}

fn subtract(ys: &[Lit], at: Subtraction) -> Vec<Step> {
    let (prep, region, eps, count, ds) = (at.prep, at.region, at.eps, at.count, at.ds);
    let mut steps = Vec::new();
    let mut batch: Vec<Lit> = Vec::new();
    let flush = |batch: &mut Vec<Lit>, steps: &mut Vec<Step>| {
        steps.extend(batch_steps(batch, region, eps, prep, count, ds));
        batch.clear();
    };
    for &y in ys {
        let meets = |b: &Lit| {
            !super::cst::disjoint(
                &prep.mesh_bounds[b.prim as usize],
                &prep.mesh_bounds[y.prim as usize],
            )
        };
        if batch.len() == SUB_BITS || batch.iter().any(meets) {
            flush(&mut batch, &mut steps);
        }
        batch.push(y);
    }
    flush(&mut batch, &mut steps);
    steps
}

fn batch_steps(
    ys: &[Lit],
    region: &Region,
    eps: f32,
    prep: &Prepared,
    count: bool,
    ds: Ds,
) -> Vec<Step> {
    // Both draws of a cutter cut to where `z` can lie inside it (the bits
    // its parity sets are cleared by its exit within the same rectangle).
    let scissor = |m: MeshId| match region.cut(m) {
        Scissor::Overlap { of, and } if of == [m] => Scissor::Openings { of: m, and },
        s => s,
    };
    let draw = |y: &Lit, cull, depth, stencil, fragment, count_samples| {
        Step::Draw(Draw {
            geometry: Geometry::Mesh(y.prim),
            scissor: scissor(y.prim),
            cull,
            ds,
            depth,
            stencil: Some(stencil),
            fragment,
            count_samples,
        })
    };
    let flag = |v: &[bool], m: MeshId| v.get(m as usize).copied().unwrap_or(false);
    let mut parity = Vec::new();
    for (k, y) in ys.iter().enumerate() {
        let bit = 1u8 << k;
        // A cutter every ray starts outside of needs its back faces' half of
        // the parity only where it may tie: its exit's `Greater` test stands
        // for it elsewhere ([`Fragment::ParityBeforeExit`]).
        let fragment = if flag(&prep.eye_inside, y.prim) || flag(&prep.near_cut, y.prim) {
            Fragment::NearerThan { tex: SURF, eps }
        } else {
            Fragment::ParityBeforeExit { tex: SURF, eps }
        };
        parity.push(draw(
            y,
            Cull::None,
            DepthState {
                compare: CompareOp::Always,
                write: false,
            },
            super::stencil::both(CompareOp::Always, StencilOp::Invert, 0, bit, 0),
            fragment,
            false,
        ));
    }
    // A primitive containing a perspective eye has its parity counted from the
    // near plane inverted; the eye correction (all its faces once more) turns the
    // bit into membership, so "inside" is "bit set" for every primitive and each
    // exit draw clears what its parity draw set (a closed convex mesh has a back
    // face wherever the bit is set).
    let mut steps = eye::correct(parity, &prep.eye_inside);
    for (k, y) in ys.iter().enumerate() {
        let bit = 1u8 << k;
        // The exit moves `z` in the depth-stencil image as in the texture, so the
        // image holds `z` wherever a later parity draw reads it, and a tie-free
        // parity draw can test it with the fixed-function depth test
        // ([`super::tie_free`]). Where the bit is set by the whole parity the
        // back face lies behind `z` (beyond the tie rule's tolerance), so the
        // `Greater` test passes there; it matters where a tie-free cutter's
        // parity drew its front faces only (set: the front face at or in front
        // of `z`), and rejects the cutters wholly in front of `z`. The bit is
        // cleared either way, for the next batch.
        let mut stencil = super::stencil::both(CompareOp::Equal, StencilOp::Zero, bit, bit, bit);
        stencil.front.depth_fail = StencilOp::Zero;
        stencil.back.depth_fail = StencilOp::Zero;
        steps.push(draw(
            y,
            Cull::Front,
            DepthState {
                compare: CompareOp::Greater,
                write: true,
            },
            stencil,
            Fragment::WriteDepth { out: SURF },
            count,
        ));
    }
    steps
}

#[cfg(test)]
mod tests;
