//! Goldfeather's z-buffer CSG (Goldfeather et al. via Stewart, Leach & John,
//! §3): the positive form becomes a sum of products (§3.2); per product
//! and per literal, the literal's *potentially visible* faces — front faces of a
//! positive, back faces of a complemented primitive (§3.4) — are drawn into a
//! *surface* depth-stencil image, clipped there by parity against every other
//! primitive of the product (§3.1, §3.3; one stencil bit per primitive, eight
//! primitives per reject sweep), and the survivors are merged into the *output* depth
//! with a less-than test (§3.5). A final pass shades by depth-equal (within a
//! tolerance).
//!
//! Parity counts a primitive's faces at *or in front of* the surface point (depth
//! `LessOrEqual`), so it classifies the point just behind the surface — where the
//! ray enters the product. Exactly so, on coincident faces the answer would depend
//! on which of the two triangles rasterizes nearer (Goldfeather's classic
//! speckles); so the parity draws keep the faces at most [`ProductOptions::eps`]
//! behind the surface depth (a float texture, [`Fragment::NearerThan`]), which
//! classifies the point `eps` behind the surface, as Trickle does (Rossignac & Wu
//! §3.2): coincident faces classify alike, and parts of the solid thinner than `eps`
//! along the ray vanish. `eps = 0` gives the exact test.
//!
//! Non-convex primitives (§3.5, Goldfeather's layers): a mesh may show several
//! potentially visible faces at one pixel, and the nearest one may be clipped away
//! while a deeper one survives, so each such literal's faces are *peeled* layer by
//! layer (strictly behind the previous layer, a texture) in a loop that an occlusion
//! query stops when a layer is empty. Convexity is decided per mesh on the CPU
//! (every vertex on the inner side of every face plane, [`super::is_convex`]); a convex
//! mesh has one such face per pixel and takes the single-draw fast path.
//!
//! Depth tolerances: `eps` in the classification (above); survivors keep their
//! `f32` fragment depth in a texture, so the merge loses nothing to a depth-buffer
//! round trip. The shading pass then
//! paints every face within [`super::SHADE_EPS`] (2⁻²⁰ normalized depth) of the final
//! depth, primitives in *descending* index order, so where faces of several
//! primitives coincide the lowest index is written last and wins (`prim.png`,
//! docs/precision.md) — depth-equal would fail on coincident faces of different
//! triangles, which rasterize an ulp or two apart.
#![deny(unsafe_code)]

pub(crate) mod layered;

use super::step::*;
use super::{PlanError, Prepared, VisibleSides};
use crate::csg::products::{sum_of_products, Literal};

/// Default bound on the number of products of the sum-of-products form.
pub const DEFAULT_PRODUCT_LIMIT: usize = 4096;

/// Options shared by the product-based builders.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProductOptions {
    /// The expansion fails fast (with a [`PlanError::Products`] naming the count and
    /// suggesting `--algo cst-i`) past this many products.
    pub limit: usize,
    /// Goldfeather's parity tolerance (normalized depth): a face counts for the
    /// parity of a surface point when it is at most `eps` behind it, so the point
    /// classified is `eps` behind the surface and coincident faces classify alike
    /// whatever their rounding (Trickle's rule, Rossignac & Wu §3.2). 0: exact
    /// `LessOrEqual`, with Goldfeather's speckles on coincident faces.
    pub eps: f32,
}

impl Default for ProductOptions {
    fn default() -> Self {
        ProductOptions {
            limit: DEFAULT_PRODUCT_LIMIT,
            eps: CLIP_EPS,
        }
    }
}

/// Default parity tolerance: 32 quanta of a 24-bit depth buffer, 2⁻¹⁹.
pub const CLIP_EPS: f32 = 1.0 / (1 << 19) as f32;

/// One literal of a product, as the plan builders need it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Lit {
    pub(crate) prim: MeshId,
    pub(crate) negated: bool,
}

impl Lit {
    /// The faces that may be visible on the product: front faces of a positive,
    /// back faces of a complemented primitive (Stewart, Leach & John §3.4).
    pub fn visible_cull(self) -> Cull {
        if self.negated {
            Cull::Front
        } else {
            Cull::Back
        }
    }
}

/// The most literal pairs (Σ k² over products of k literals) a product-based
/// plan may draw: past it a frame takes many minutes on lavapipe.
pub const MAX_PRODUCT_WORK: u64 = 20_000_000;

/// The sum of products of the prepared scene, pruned by bounding boxes; products
/// without a positive literal (unbounded) are dropped.
pub fn products(prep: &Prepared, limit: usize) -> Result<Vec<Vec<Lit>>, PlanError> {
    let bounds = |prim: u32| {
        let b = &prep.mesh_bounds[prim as usize];
        (b.min.to_array(), b.max.to_array())
    };
    let prods = sum_of_products(&prep.positive, &bounds, limit)
        .map_err(|e| PlanError::Products(e.to_string()))?;
    let lit = |l: &Literal| Lit {
        prim: l.prim,
        negated: l.negated,
    };
    // Goldfeather draws every literal of a product once per literal (O(k²) per
    // product of k); refuse before a plan of that many steps is built.
    let work: u64 = prods.iter().map(|p| (p.literals.len() as u64).pow(2)).sum();
    if work > MAX_PRODUCT_WORK {
        return Err(PlanError::TooMuchWork {
            what: format!(
                "the {} products of the sum-of-products form hold {} literals; drawing each against each is {work} rasterizations",
                prods.len(),
                prods.iter().map(|p| p.literals.len()).sum::<usize>()
            ),
            limit: MAX_PRODUCT_WORK,
            fix: "use --algo cst-i or --algo blister, which work on the tree".to_string(),
        });
    }
    let mut out: Vec<Vec<Lit>> = Vec::with_capacity(prods.len());
    for p in &prods {
        let mut lits: Vec<Lit> = p.literals.iter().map(lit).collect();
        // Positive literals first: the Trickle traversal and the scissors use the first.
        lits.sort_by_key(|l| (l.negated, l.prim));
        lits.dedup();
        if lits.first().is_some_and(|l| !l.negated) {
            out.push(lits);
        }
    }
    Ok(out)
}

/// The depth-stencil image holding the final visible surface.
pub(crate) const OUTPUT: Ds = 0;
/// The surface depth-stencil image of one product's literal or layer.
pub(crate) const SURFACE: Ds = 1;
/// Texture: the clipped surface, copied for the merge.
pub(crate) const SURF: Tex = 0;
/// Textures of the layer peel: the previous and the current layer.
pub(crate) const PREV: Tex = 1;
pub(crate) const CUR: Tex = 2;
pub(crate) const FAR: f32 = 1.0;

/// Builds the Goldfeather plan (O(n²) rasterizations per product of n literals).
pub fn plan(prep: &Prepared, opts: &ProductOptions) -> Result<Plan, PlanError> {
    let prods = products(prep, opts.limit)?;
    let mut steps = init_steps();
    let mut loops = false;
    let (order, direct) = direct_last(&prods, 0..prods.len(), prep);
    for i in order {
        loops |= product_steps(&prods[i], prep, opts.eps, &mut steps);
    }
    steps.extend(direct);
    steps.extend(shade_steps(prep, SURF, &VisibleSides::entries(prep)));
    Ok(Plan {
        algo: "goldfeather".into(),
        depth_stencils: 2,
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

/// One product's Goldfeather steps (§3.3–3.5), appended to `steps`: per literal
/// its visible faces clipped by parity against the others and merged; a
/// non-convex literal peeled in a loop. Returns whether it peels (the plan then
/// needs the peel textures).
pub(crate) fn product_steps(p: &[Lit], prep: &Prepared, eps: f32, steps: &mut Vec<Step>) -> bool {
    let mut loops = false;
    for (i, &a) in p.iter().enumerate() {
        let others: Vec<Lit> = p
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(_, &l)| l)
            .collect();
        let mut clip_merge = clip_steps(&others, &[a.prim], eps, &prep.eye_inside);
        clip_merge.extend(merge_steps(&[a.prim]));
        if prep.convex(a.prim) {
            steps.push(Step::Pass("surface".into()));
            steps.push(clear_surface());
            steps.push(Step::Clear(Clear::Texture {
                tex: SURF,
                depth: FAR,
            }));
            steps.push(surface_draw(a, Fragment::WriteDepth { out: SURF }, false));
            steps.extend(clip_merge);
        } else {
            // Goldfeather's layers (§3.5): peel the literal's visible faces.
            loops = true;
            steps.push(Step::Pass("surface".into()));
            steps.push(Step::Clear(Clear::Texture {
                tex: PREV,
                depth: 0.0,
            }));
            let peel = Fragment::Peel {
                prev: PREV,
                out: CUR,
                shade: false,
            };
            steps.push(literal_peel_loop(
                surface_draw(a, peel, true),
                clip_merge,
                prep.triangles_in(&[a.prim]),
            ));
        }
    }
    loops
}

/// Goldfeather's layers of a non-convex literal (§3.5): `peel` (a counted
/// surface draw into `CUR`, behind `PREV`) each iteration, the layer then clipped
/// and merged by `clip_merge` and made the next `PREV`; at most one layer per
/// triangle of the literal's `triangles`.
pub(crate) fn literal_peel_loop(peel: Step, clip_merge: Vec<Step>, triangles: usize) -> Step {
    let mut tail = vec![Step::CopyTexture {
        src: CUR,
        dst: SURF,
    }];
    tail.extend(clip_merge);
    tail.push(Step::CopyTexture {
        src: CUR,
        dst: PREV,
    });
    Step::Loop(Loop {
        head: peel_head(vec![peel]),
        tail,
        max_iterations: triangles.max(1) as u32 + 1,
    })
}

/// A product of one positive primitive is that primitive: its nearest front
/// face is drawn straight into the output depth with one draw (as OpenCSG's
/// users do), with no surface image, clip or merge. Not when the eye is inside
/// it: then the product's visible point is not on a front face.
pub(crate) fn direct_steps(p: &[Lit], prep: &Prepared) -> Option<Vec<Step>> {
    let [a] = p else { return None };
    if a.negated
        || prep
            .eye_inside
            .get(a.prim as usize)
            .copied()
            .unwrap_or(false)
    {
        return None;
    }
    Some(vec![
        Step::Pass("direct".into()),
        Step::Draw(Draw {
            geometry: Geometry::Mesh(a.prim),
            scissor: Scissor::BoundsOf(vec![a.prim]),
            cull: a.visible_cull(),
            ds: OUTPUT,
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: None,
            fragment: Fragment::None,
            count_samples: false,
        }),
    ])
}

/// The products of `order` (indices into `prods`) that are not drawn
/// directly, in that order, and the direct steps of the others, in that order
/// too: a plan draws them after every other product. The output depth is the
/// nearest over the products whatever their order, and drawn last, after the
/// other products' merges, a direct draw is the last to write where its mesh
/// is visible: the executor can then shade it in that draw
/// (`plan::direct_shade`), whose depth test also rejects the pixels the
/// others already cover nearer before the shading program runs.
pub(crate) fn direct_last(
    prods: &[Vec<Lit>],
    order: impl Iterator<Item = usize>,
    prep: &Prepared,
) -> (Vec<usize>, Vec<Step>) {
    let (mut rest, mut direct) = (Vec::new(), Vec::new());
    for i in order {
        match direct_steps(&prods[i], prep) {
            Some(d) => direct.extend(d),
            None => rest.push(i),
        }
    }
    (rest, direct)
}

/// The first steps: the output depth-stencil image and the colour targets
/// cleared.
pub(crate) fn init_steps() -> Vec<Step> {
    super::common::init_output(OUTPUT, FAR)
}

/// The head of a layer-peeling loop: fresh surface image, the current layer
/// texture at far (a pixel without a layer now has none behind either), `draws`.
pub(crate) fn peel_head(draws: Vec<Step>) -> Vec<Step> {
    let mut head = vec![
        Step::Pass("surface".into()),
        clear_surface(),
        Step::Clear(Clear::Texture {
            tex: CUR,
            depth: FAR,
        }),
    ];
    head.extend(draws);
    head
}

pub(crate) fn clear_surface() -> Step {
    Step::Clear(Clear::DepthStencil {
        ds: SURFACE,
        depth: FAR,
        stencil: 0,
    })
}

/// The literal's potentially visible faces into the surface image, nearest wins.
pub(crate) fn surface_draw(a: Lit, fragment: Fragment, count_samples: bool) -> Step {
    surface_draw_culled(a, a.visible_cull(), fragment, count_samples)
}

/// [`surface_draw`] of the faces `cull` keeps (Kirsch, Nienhaus & Döllner's back
/// surfaces, §4.3).
pub(crate) fn surface_draw_culled(
    a: Lit,
    cull: Cull,
    fragment: Fragment,
    count_samples: bool,
) -> Step {
    let one = Geometry::Mesh(a.prim);
    into_surface(
        one,
        Scissor::BoundsOf(vec![a.prim]),
        cull,
        fragment,
        count_samples,
    )
}

/// A draw of `geometry` in `scissor`, the faces `cull` keeps, into the
/// surface image, nearest wins.
pub(crate) fn into_surface(
    geometry: Geometry,
    scissor: Scissor,
    cull: Cull,
    fragment: Fragment,
    count_samples: bool,
) -> Step {
    Step::Draw(Draw {
        geometry,
        scissor,
        cull,
        ds: SURFACE,
        depth: DepthState {
            compare: CompareOp::Less,
            write: true,
        },
        stencil: None,
        fragment,
        count_samples,
    })
}

/// Parity clipping of the surface image against each literal in `against`
/// (Stewart, Leach & John §3.3), eight primitives at a time, one stencil bit each: a
/// parity draw inverts a primitive's bit for each of its faces at most `eps` behind
/// the surface point; then one sweep resets the depth to far wherever any bit says
/// "outside" (clear for a positive, set for a complemented literal: the masked
/// stencil differs from the expected pattern) and clears the bits everywhere.
/// `surface` names the meshes whose faces may be in the surface image.
///
/// `eye_inside` (per mesh) marks primitives containing the eye: their parity
/// counted from the near plane is inverted, so the expected bit flips.
///
/// Only pixels of the surface matter: elsewhere its depth is far before and
/// after the sweep. So a parity draw is cut to the surface's rectangle (a large
/// primitive clipping a small literal rasterizes only where the literal is), no
/// bit is set outside it, and the sweep covers it alone.
pub(crate) fn clip_steps(
    against: &[Lit],
    surface: &[MeshId],
    eps: f32,
    eye_inside: &[bool],
) -> Vec<Step> {
    clip_steps_in(against, &Region::Union(surface.to_vec()), eps, eye_inside)
}

/// Where a surface's pixels can be: within the rectangle of a union of meshes
/// (a literal's or a layer's faces), or of an intersection (an SCS product lies
/// inside every one of its positive primitives).
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Region {
    Union(Vec<MeshId>),
    Intersection(Vec<MeshId>),
    /// Within `inside`'s rectangle and the rectangle of all of `holes`: the
    /// pixels where a product of one positive primitive `inside` and
    /// complemented `holes` can stay unresolved after its first layer
    /// (layered Goldfeather: elsewhere the first layer is `inside`'s nearest
    /// front face, which no hole reaches).
    Holes {
        inside: MeshId,
        holes: Vec<MeshId>,
    },
}

impl Region {
    /// The region's rectangle: the sweeps and the merge cover it.
    pub(crate) fn rect(&self) -> Scissor {
        match self {
            Region::Union(ms) => Scissor::BoundsOf(ms.clone()),
            Region::Intersection(ms) => Scissor::Overlap {
                of: ms[..1].to_vec(),
                and: ms[1..].to_vec(),
            },
            Region::Holes { inside, holes } => Scissor::Overlap {
                of: holes.clone(),
                and: vec![*inside],
            },
        }
    }

    /// The rectangle of `meshes` cut to the region.
    pub(crate) fn cut_all(&self, meshes: &[MeshId]) -> Scissor {
        match self {
            Region::Union(_) => Scissor::BoundsOf(meshes.to_vec()),
            Region::Intersection(inside) => Scissor::Overlap {
                of: meshes.to_vec(),
                and: inside.clone(),
            },
            Region::Holes { holes, .. } => Scissor::Within {
                meshes: meshes.to_vec(),
                within: holes.clone(),
            },
        }
    }

    /// Mesh `m`'s rectangle cut to the region: a draw whose effect is read only
    /// inside it.
    pub(crate) fn cut(&self, m: MeshId) -> Scissor {
        match self {
            Region::Union(ms) => Scissor::Within {
                meshes: vec![m],
                within: ms.clone(),
            },
            Region::Intersection(ms) => Scissor::Overlap {
                of: vec![m],
                and: ms.clone(),
            },
            Region::Holes { .. } => self.cut_all(&[m]),
        }
    }
}

/// [`clip_steps`] of a surface that lies in `region`.
pub(crate) fn clip_steps_in(
    against: &[Lit],
    region: &Region,
    eps: f32,
    eye_inside: &[bool],
) -> Vec<Step> {
    let cut: Vec<(Lit, Scissor)> = against.iter().map(|&b| (b, region.cut(b.prim))).collect();
    clip_steps_cut(&cut, region.rect(), eps, eye_inside)
}

/// [`clip_steps`] with each literal's parity draw cut to its own scissor
/// (where it can hold a surface point) and the sweeps to `sweep`.
pub(crate) fn clip_steps_cut(
    against: &[(Lit, Scissor)],
    sweep: Scissor,
    eps: f32,
    eye_inside: &[bool],
) -> Vec<Step> {
    let mut steps = vec![Step::Pass("clip".into())];
    for chunk in against.chunks(CLIP_BITS as usize) {
        let (mut mask, mut inside) = (0u8, 0u8);
        for (k, (b, scissor)) in chunk.iter().enumerate() {
            let bit = 1u8 << k;
            mask |= bit;
            if b.negated == eye_inside.get(b.prim as usize).copied().unwrap_or(false) {
                inside |= bit;
            }
            steps.push(clip_parity_draw(
                b.prim,
                Cull::None,
                scissor.clone(),
                bit,
                eps,
            ));
        }
        steps.push(reject_sweep(mask, inside, sweep.clone()));
    }
    steps
}

/// The faces of `prim` that `cull` keeps, at most `eps` behind the surface
/// texture, invert `bit` of the surface image (a clip's parity draw).
pub(crate) fn clip_parity_draw(
    prim: MeshId,
    cull: Cull,
    scissor: Scissor,
    bit: u8,
    eps: f32,
) -> Step {
    Step::Draw(Draw {
        geometry: Geometry::Mesh(prim),
        scissor,
        cull,
        ds: SURFACE,
        depth: DepthState {
            compare: CompareOp::Always,
            write: false,
        },
        stencil: Some(super::stencil::both(
            CompareOp::Always,
            StencilOp::Invert,
            0,
            bit,
            0,
        )),
        fragment: Fragment::NearerThan { tex: SURF, eps },
        count_samples: false,
    })
}

/// Stencil bits of the surface image used for parity (one per clipping primitive).
pub(crate) const CLIP_BITS: u8 = 8;

/// Where `(stencil & mask) != inside`, depth := far in the image and in the
/// surface texture `SURF` (the pixel leaves the surface); the bits under `mask`
/// are cleared on every swept pixel, pass or fail.
pub(crate) fn reject_sweep(mask: u8, inside: u8, scissor: Scissor) -> Step {
    reject_sweep_into(
        SURFACE,
        Fragment::WriteDepth { out: SURF },
        mask,
        inside,
        scissor,
    )
}

/// [`reject_sweep`] of depth-stencil image `ds` with program `fragment` (SCS's
/// clip in the output image needs no texture written: [`Fragment::None`]).
pub(crate) fn reject_sweep_into(
    ds: Ds,
    fragment: Fragment,
    mask: u8,
    inside: u8,
    scissor: Scissor,
) -> Step {
    let face = StencilFace {
        compare: CompareOp::NotEqual,
        fail: StencilOp::Zero,
        pass: StencilOp::Zero,
        depth_fail: StencilOp::Zero,
    };
    Step::Draw(Draw {
        geometry: Geometry::FullScreen { depth: FAR },
        scissor,
        cull: Cull::None,
        ds,
        depth: DepthState {
            compare: CompareOp::Always,
            write: true,
        },
        stencil: Some(StencilState {
            front: face,
            back: face,
            compare_mask: mask,
            write_mask: mask,
            reference: inside,
        }),
        fragment,
        count_samples: false,
    })
}

/// Merge of the clipped surface into the output depth with less-than (§3.5).
pub(crate) fn merge_steps(surface: &[MeshId]) -> Vec<Step> {
    merge_steps_in(&Region::Union(surface.to_vec()))
}

/// [`merge_steps`] of a surface that lies in `region`.
pub(crate) fn merge_steps_in(region: &Region) -> Vec<Step> {
    vec![
        Step::Pass("merge".into()),
        Step::Draw(Draw {
            geometry: Geometry::FullScreen { depth: FAR },
            scissor: region.rect(),
            cull: Cull::None,
            ds: OUTPUT,
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: None,
            fragment: Fragment::DepthFromTexture { src: SURF },
            count_samples: false,
        }),
    ]
}

/// Shading of the output depth (copied into texture `tex`): every solid
/// primitive's faces (both orientations: complemented primitives show their back
/// faces) within [`super::SHADE_EPS`] of it, in descending index order, so that on
/// coincident faces the lowest index is written last and wins. A tolerance rather
/// than depth-equal, because coincident faces of different triangles rasterize to
/// depths an ulp or two apart. `sides`: the faces that can be visible on the
/// output ([`super::VisibleSides`]).
pub(crate) fn shade_steps(prep: &Prepared, tex: Tex, sides: &VisibleSides) -> Vec<Step> {
    super::shade_near_depth(&prep.solid_meshes, OUTPUT, tex, None, sides)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::plan::print::count;
    use crate::scene::fixtures::{self, block_minus_spheres, product_blowup, ExprBuilder};
    use glam::DVec3;

    fn static_counts(plan: &Plan, prep: &Prepared) -> crate::plan::print::StaticCounts {
        count(&plan.steps, prep)
    }

    use crate::plan::is_convex;

    #[test]
    fn convexity() {
        let b = fixtures::box_mesh(DVec3::ZERO, DVec3::ONE);
        assert!(is_convex(&b));
        assert!(is_convex(&fixtures::sphere_mesh(DVec3::ZERO, 1.0, 16, 8)));
        // An L-shaped union of two boxes glued into one mesh is not.
        let l = fixtures::box_mesh(DVec3::ZERO, DVec3::ONE);
        let other = fixtures::box_mesh(DVec3::new(1.0, 0.0, 0.0), DVec3::new(2.0, 3.0, 1.0));
        let l = fixtures::joined(l, other);
        assert!(!is_convex(&l));
    }

    #[test]
    fn a_product_of_one_primitive_is_one_draw() {
        // block + (s0 * block2): the product {block} is drawn directly.
        let mut scene = block_minus_spheres(1);
        let mut b = ExprBuilder::default();
        let (x, y, z) = (b.leaf(0), b.leaf(1), b.leaf(0));
        let yz = b.inter(y, z);
        let root = b.union(x, yz);
        scene.solids[0].expr = b.build(root);
        let prep = Prepared::new(&scene).unwrap();
        for build in [plan, layered::plan] {
            let steps = build(&prep, &ProductOptions::default()).unwrap().steps;
            let at = steps
                .iter()
                .position(|s| matches!(s, Step::Pass(p) if p == "direct"))
                .expect("a direct pass");
            let Step::Draw(d) = &steps[at + 1] else {
                panic!("the direct pass draws: {:?}", steps[at + 1]);
            };
            assert_eq!(
                (&d.geometry, d.ds, d.cull, d.depth.compare),
                (&Geometry::Mesh(0), OUTPUT, Cull::Back, CompareOp::Less)
            );
            assert!(matches!(steps.get(at + 2), Some(Step::Pass(_)) | None));
        }
        // With the eye inside the primitive the general path is kept.
        let mut inside = prep.clone();
        inside.eye_inside = vec![true, false];
        let steps = plan(&inside, &ProductOptions::default()).unwrap().steps;
        assert!(!steps
            .iter()
            .any(|s| matches!(s, Step::Pass(p) if p == "direct")));
    }

    #[test]
    fn parity_draws_and_sweeps_are_cut_to_the_surface() {
        // block - s0 - s1: each literal's surface is clipped by the other two.
        let prep = Prepared::new(&block_minus_spheres(2)).unwrap();
        let steps = plan(&prep, &ProductOptions::default()).unwrap().steps;
        let mut surface = None;
        let (mut parity, mut sweeps) = (0, 0);
        for s in &steps {
            let Step::Draw(d) = s else { continue };
            match (&d.fragment, &d.geometry) {
                (Fragment::WriteDepth { .. }, Geometry::Mesh(m)) => surface = Some(*m),
                (Fragment::NearerThan { .. }, Geometry::Mesh(b)) => {
                    let a = surface.expect("a surface before its clip");
                    assert_ne!(*b, a);
                    assert_eq!(
                        d.scissor,
                        Scissor::Within {
                            meshes: vec![*b],
                            within: vec![a],
                        }
                    );
                    parity += 1;
                }
                (Fragment::WriteDepth { .. }, Geometry::FullScreen { .. }) => {
                    assert_eq!(d.scissor, Scissor::BoundsOf(vec![surface.unwrap()]));
                    sweeps += 1;
                }
                _ => {}
            }
        }
        assert_eq!((parity, sweeps), (6, 3));
    }

    #[test]
    fn one_product_for_block_minus_spheres() {
        let scene = block_minus_spheres(8);
        let prep = Prepared::new(&scene).unwrap();
        let p = products(&prep, 4096).unwrap();
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].len(), 9);
        assert!(!p[0][0].negated && p[0][1..].iter().all(|l| l.negated));
    }

    /// The scissors of the draws into the surface image (the layer draws).
    fn peel_scissors(steps: &[Step]) -> Vec<(Geometry, Scissor)> {
        steps
            .iter()
            .filter_map(|s| match s {
                Step::Draw(d) if d.ds == SURFACE && d.depth.write && d.stencil.is_none() => {
                    Some((d.geometry.clone(), d.scissor.clone()))
                }
                _ => None,
            })
            .collect()
    }

    /// The meshes of the parity draws and their scissors.
    fn parity_draws(steps: &[Step]) -> Vec<(MeshId, Scissor)> {
        steps
            .iter()
            .filter_map(|s| match s {
                Step::Draw(Draw {
                    geometry: Geometry::Mesh(m),
                    fragment: Fragment::NearerThan { .. },
                    scissor,
                    ..
                }) => Some((*m, scissor.clone())),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn layered_enters_a_convex_block_once_and_peels_only_the_holes_after() {
        let scene = block_minus_spheres(4);
        let prep = Prepared::new(&scene).unwrap();
        assert!(prep.convex(0));
        let l = layered::plan(&prep, &ProductOptions::default()).unwrap();
        let holes: Vec<MeshId> = (1..=4).collect();
        // The first layer: the block's front faces alone, within its
        // rectangle; clipped by every literal.
        let at = l.steps.iter().position(|s| matches!(s, Step::Loop(_)));
        let before = &l.steps[..at.expect("a peel loop")];
        assert_eq!(
            peel_scissors(before),
            vec![(
                Geometry::Meshes(vec![0]),
                Scissor::Overlap {
                    of: vec![0],
                    and: vec![0]
                }
            )]
        );
        let clipped: Vec<MeshId> = parity_draws(before).iter().map(|d| d.0).collect();
        assert_eq!(clipped, vec![0, 1, 2, 3, 4]);
        // The loop: the spheres' back faces alone, within the spheres'
        // rectangle (the block is resolved everywhere else by its first
        // layer), clipped by the block only: no two spheres' boxes meet, so
        // no sphere's wall lies inside another sphere.
        let lp = l.loops().next().expect("a peel loop");
        assert_eq!(
            peel_scissors(&lp.head),
            vec![(
                Geometry::Meshes(holes.clone()),
                Scissor::Within {
                    meshes: holes.clone(),
                    within: holes.clone()
                }
            )]
        );
        assert_eq!(
            parity_draws(&lp.tail),
            vec![(
                0,
                Scissor::Within {
                    meshes: vec![0],
                    within: holes
                }
            )]
        );
        // One bit, one sweep.
        let sweeps = lp
            .tail
            .iter()
            .filter(|s| matches!(s, Step::Draw(d) if matches!(d.geometry, Geometry::FullScreen { .. }) && d.ds == SURFACE))
            .count();
        assert_eq!(sweeps, 1);
    }

    #[test]
    fn layered_later_layers_clip_by_the_holes_that_meet() {
        // Sphere 2 moved onto sphere 1: their boxes meet, a point of one's
        // wall may lie inside the other; spheres 0 and 3 meet none.
        let mut scene = block_minus_spheres(4);
        let c1 = scene.primitives[2].mesh.positions.iter().sum::<DVec3>()
            / scene.primitives[2].mesh.positions.len() as f64;
        scene.primitives[3].mesh = fixtures::sphere_mesh(c1 + DVec3::X * 0.3, 0.4, 12, 6);
        let prep = Prepared::new(&scene).unwrap();
        let l = layered::plan(&prep, &ProductOptions::default()).unwrap();
        let lp = l.loops().next().expect("a peel loop");
        let within = |m: MeshId, w: Vec<MeshId>| Scissor::Within {
            meshes: vec![m],
            within: w,
        };
        assert_eq!(
            parity_draws(&lp.tail),
            vec![
                (0, within(0, vec![1, 2, 3, 4])),
                (2, within(2, vec![3])),
                (3, within(3, vec![2])),
            ]
        );
    }

    #[test]
    fn layered_peels_every_literal_after_a_non_convex_positive() {
        let mut scene = block_minus_spheres(2);
        let l = fixtures::box_mesh(DVec3::new(-3.0, -1.0, -1.0), DVec3::new(-1.0, 1.0, 1.0));
        let other = fixtures::box_mesh(DVec3::new(-1.0, -1.0, -1.0), DVec3::new(0.0, 2.0, 1.0));
        scene.primitives[0].mesh = fixtures::joined(l, other);
        let prep = Prepared::new(&scene).unwrap();
        assert!(!prep.convex(0));
        let l = layered::plan(&prep, &ProductOptions::default()).unwrap();
        let lp = l.loops().next().expect("a peel loop");
        // A ray may leave and re-enter the block: its later front faces are
        // layers too, and any layer may lie inside any sphere (the second
        // sphere misses the block's box: no literal of the product).
        let drawn: Vec<Geometry> = peel_scissors(&lp.head).into_iter().map(|d| d.0).collect();
        assert_eq!(
            drawn,
            vec![Geometry::Meshes(vec![0]), Geometry::Meshes(vec![1])]
        );
        let clipped: Vec<MeshId> = parity_draws(&lp.tail).iter().map(|d| d.0).collect();
        assert_eq!(clipped, vec![0, 1]);
    }

    #[test]
    fn layered_is_kn_and_goldfeather_is_n_squared() {
        let mut rows = Vec::new();
        for n in [4u32, 8, 16, 32] {
            let scene = block_minus_spheres(n);
            let prep = Prepared::new(&scene).unwrap();
            let g = plan(&prep, &ProductOptions::default()).unwrap();
            let l = layered::plan(&prep, &ProductOptions::default()).unwrap();
            let (gc, lc) = (static_counts(&g, &prep), static_counts(&l, &prep));
            // Goldfeather: every primitive is convex, so no loop; per literal one
            // surface draw, n parity draws and n sweeps over n+1 literals.
            assert!(!g.steps.iter().any(|s| matches!(s, Step::Loop(_))));
            let lits = n as u64 + 1;
            assert_eq!(gc.mesh_draws, lits * lits + prep.solid_meshes.len() as u64);
            // Layered: the first layer (the block) clipped by every literal,
            // then the loop body counted once: the spheres, clipped by the
            // block (their boxes do not meet).
            assert_eq!(
                lc.mesh_draws,
                (1 + lits) + 2 + prep.solid_meshes.len() as u64
            );
            rows.push((n, gc.triangles, lc.triangles));
        }
        // Triangles per frame grow quadratically for Goldfeather, linearly per
        // layer for the layered form.
        let (n0, g0, l0) = rows[0];
        let (n1, g1, l1) = rows[3];
        let r = (n1 / n0) as f64;
        assert!(g1 as f64 / g0 as f64 > 0.6 * r * r, "{rows:?}");
        assert!((l1 as f64 / l0 as f64) < 1.5 * r, "{rows:?}");
    }

    #[test]
    fn non_convex_literal_is_peeled_in_a_loop() {
        let mut scene = block_minus_spheres(2);
        let l = fixtures::box_mesh(DVec3::new(-3.0, -1.0, -1.0), DVec3::new(-1.0, 1.0, 1.0));
        let other = fixtures::box_mesh(DVec3::new(-1.0, -1.0, -1.0), DVec3::new(0.0, 2.0, 1.0));
        let l = fixtures::joined(l, other);
        scene.primitives[0].mesh = l;
        let prep = Prepared::new(&scene).unwrap();
        assert!(!prep.mesh_convex[0]);
        let g = plan(&prep, &ProductOptions::default()).unwrap();
        assert_eq!(
            g.steps
                .iter()
                .filter(|s| matches!(s, Step::Loop(_)))
                .count(),
            1
        );
    }

    #[test]
    fn too_many_products_fail_fast_naming_count_and_cst_i() {
        let scene = product_blowup(40);
        let prep = Prepared::new(&scene).unwrap();
        for algo in [
            crate::plan::Algo::Goldfeather,
            crate::plan::Algo::GoldfeatherLayered,
            crate::plan::Algo::Trickle,
        ] {
            let t = std::time::Instant::now();
            let err = crate::plan::build(algo, &prep).unwrap_err().to_string();
            assert!(t.elapsed().as_secs_f64() < 1.0, "{algo}: {:?}", t.elapsed());
            assert!(err.contains("cst-i") && err.contains("4096"), "{err}");
        }
        // Just under the limit it builds.
        let small = Prepared::new(&product_blowup(6)).unwrap();
        assert_eq!(products(&small, 4096).unwrap().len(), 64);
    }

    #[test]
    fn trickle_eps_is_reported_and_overridable() {
        let prep = Prepared::new(&block_minus_spheres(3)).unwrap();
        let t = crate::plan::trickle::plan(&prep, &Default::default()).unwrap();
        assert_eq!(
            t.steps[0],
            Step::Pass(crate::plan::trickle::init_pass_name(
                crate::plan::trickle::DEFAULT_EPS
            ))
        );
        let opts = crate::plan::trickle::TrickleOptions {
            eps: Some(1e-5),
            ..Default::default()
        };
        let t = crate::plan::trickle::plan(&prep, &opts).unwrap();
        assert_eq!(t.steps[0], Step::Pass("init eps=1.000e-5".into()));
        let mut found = false;
        for s in &t.steps {
            if let Step::Loop(l) = s {
                for h in &l.head {
                    if let Step::Draw(Draw {
                        fragment: Fragment::PeelTolerant { eps, .. },
                        ..
                    }) = h
                    {
                        assert_eq!(*eps, 1e-5);
                        found = true;
                    }
                }
            }
        }
        assert!(found);
    }
}
