//! Kirsch, Nienhaus & Döllner's CSG depth peeling (§4, Listings 1 and 2):
//! the depth layers of a sum of products, each product's boundary counted on its
//! own (§7, Fig. 7a).
//!
//! Layer i is computed from layer i − 1's *depth layer map* (a texture): for every
//! product G and every literal P of G, `calcCSG` draws P's potentially visible
//! faces strictly behind the map (§4.3) into a surface image — front faces of an
//! intersected, back faces of a subtracted primitive for the product's *front*
//! surface, the opposite for its *back* surface (layers > 1 only) — clips them by
//! parity against every other literal of G (the visibility channel: one stencil bit
//! per primitive, Goldfeather's `goldfeather::clip_steps`), and merges the
//! survivors into the output depth with a less-than test (the visibility
//! transfer). After all products the output depth is layer i; it becomes the next
//! layer's map. Layer 1 is exactly Goldfeather's opaque render.
//!
//! Parity tolerance: a front surface point is classified `eps` behind itself (where
//! the ray enters the product), a back surface point `eps` in front of itself
//! (where the ray is still inside): both are inside the product, so coincident
//! faces of two literals of one product survive alike and the nearer one (the
//! lower index after shading) is the layer. The peel itself is tolerant too
//! ([`Fragment::PeelTolerant`], [`PEEL_EPS`]): a face within `eps` behind the
//! previous layer is that layer again (coincident faces rasterize an ulp apart),
//! not a new one.
//!
//! The single-product optimization (§4.4, Listing 2): with one product, odd layers
//! are front surfaces and even layers back surfaces, and an even layer is simply
//! the nearest back-mode face of any literal behind the previous layer — no parity.
//! Not used when the eye is inside a literal or an orthographic near plane cuts one
//! (then layer 1 need not be a front surface).
//!
//! Non-convex literals are peeled in a loop as in Goldfeather (Stewart, Leach & John
//! §3.5), starting behind the layer map. A layered plan ends with an
//! occlusion-counted full-screen pass over the pixels the last layer covers (§6: the
//! renderer stops when it counts fewer than `--layer-threshold` samples), then the
//! usual depth-equal shading of that layer.
#![deny(unsafe_code)]

use super::goldfeather::{
    clear_surface, clip_steps, direct_steps, init_steps, literal_peel_loop, merge_steps, products,
    shade_steps, surface_draw_culled, Lit, ProductOptions, CLIP_BITS, CUR, FAR, OUTPUT, PREV, SURF,
};
use super::step::*;
use super::{PlanError, Prepared, VisibleSides};

/// Texture: the depth layer map of the previous layer.
pub(crate) const MAP: Tex = 3;

/// Peeling tolerance (normalized depth): faces within this behind the previous
/// layer belong to it. Goldfeather's parity tolerance, 2⁻¹⁹.
pub const PEEL_EPS: f32 = super::goldfeather::CLIP_EPS;

/// Which surface of a product `calcCSG` finds (Kirsch, Nienhaus & Döllner §4.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Front,
    Back,
}

impl Mode {
    /// `cullMode` of Listing 1.
    fn cull(self, a: Lit) -> Cull {
        match (self, a.visible_cull()) {
            (Mode::Front, c) => c,
            (Mode::Back, Cull::Back) => Cull::Front,
            (Mode::Back, _) => Cull::Back,
        }
    }
}

/// The opaque render: layer 1 (Goldfeather's image).
pub fn plan(prep: &Prepared, opts: &ProductOptions) -> Result<Plan, PlanError> {
    plan_layer(prep, opts, 1, false)
}

/// The plan whose output is layer `layer` (1-based) of the scene's products: layers
/// 1 .. `layer` peeled in turn, the last one shaded. With `count`, an
/// occlusion-counted pass after the last loop counts the pixels the layer covers
/// (the executor's `final_samples`).
pub fn plan_layer(
    prep: &Prepared,
    opts: &ProductOptions,
    layer: u32,
    count: bool,
) -> Result<Plan, PlanError> {
    assert!(layer >= 1, "layers are 1-based");
    let prods = products(prep, opts.limit)?;
    let single = prods.len() == 1
        && prods[0].iter().all(|l| {
            let at = |v: &[bool]| v.get(l.prim as usize).copied().unwrap_or(false);
            !at(&prep.eye_inside) && !at(&prep.near_cut)
        });
    let mut b = Builder {
        prep,
        eps: opts.eps,
        steps: init_steps(),
        loops: false,
    };
    for i in 1..=layer {
        if i > 1 {
            b.steps.push(Step::Pass("layer map".into()));
            b.steps.push(Step::CopyDepthToTexture {
                ds: OUTPUT,
                dst: MAP,
            });
            b.steps.push(Step::Clear(Clear::DepthStencil {
                ds: OUTPUT,
                depth: FAR,
                stencil: 0,
            }));
        }
        if single && i % 2 == 0 {
            b.back_csg(&prods[0]);
            continue;
        }
        for p in &prods {
            b.calc_csg(p, Mode::Front, i);
            if i > 1 && !single {
                b.calc_csg(p, Mode::Back, i);
            }
        }
    }
    if count {
        b.steps.push(Step::Pass("count".into()));
        b.steps.push(count_pass(prep));
    }
    // Layer 1 is the solid's visible surface; deeper layers hold the products'
    // back surfaces too (§4.1), where any face may show.
    let sides = match layer {
        1 => VisibleSides::entries(prep),
        _ => VisibleSides::none(),
    };
    b.steps.extend(shade_steps(prep, SURF, &sides));
    Ok(Plan {
        algo: super::Algo::Kirsch.name().into(),
        depth_stencils: 2,
        textures: if layer > 1 {
            4
        } else if b.loops {
            3
        } else {
            1
        },
        stencil_bits: CLIP_BITS,
        output_ds: OUTPUT,
        steps: b.steps,
    })
}

/// Counts (occlusion query) the pixels where the output depth holds a layer.
fn count_pass(prep: &Prepared) -> Step {
    super::common::count_covered(OUTPUT, Scissor::BoundsOf(prep.solid_meshes.clone()))
}

struct Builder<'a> {
    prep: &'a Prepared,
    eps: f32,
    steps: Vec<Step>,
    loops: bool,
}

impl Builder<'_> {
    fn convex(&self, prim: MeshId) -> bool {
        self.prep.convex(prim)
    }

    /// The fragment of a surface draw of layer `i`: everything for layer 1, else
    /// only what lies behind the layer map.
    fn peel(&self, i: u32, prev: Tex, out: Tex) -> Fragment {
        if i == 1 {
            Fragment::WriteDepth { out }
        } else {
            Fragment::PeelTolerant {
                prev,
                out,
                eps: PEEL_EPS,
            }
        }
    }

    /// `calcCSG(G, mode)` of Listing 1 for layer `i`.
    fn calc_csg(&mut self, p: &[Lit], mode: Mode, i: u32) {
        if i == 1 && mode == Mode::Front {
            if let Some(direct) = direct_steps(p, self.prep) {
                self.steps.extend(direct);
                return;
            }
        }
        // The visible point of a back surface is classified just in front of it.
        let eps = match mode {
            Mode::Front => self.eps,
            Mode::Back => -self.eps,
        };
        for (k, &a) in p.iter().enumerate() {
            let others: Vec<Lit> = p
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != k)
                .map(|(_, &l)| l)
                .collect();
            let mut clip_merge = clip_steps(&others, &[a.prim], eps, &self.prep.eye_inside);
            clip_merge.extend(merge_steps(&[a.prim]));
            let cull = mode.cull(a);
            // With no other literal the nearest face is the product's: no peel loop.
            if self.convex(a.prim) || others.is_empty() {
                self.steps.push(Step::Pass("surface".into()));
                self.steps.push(clear_surface());
                self.steps.push(Step::Clear(Clear::Texture {
                    tex: SURF,
                    depth: FAR,
                }));
                let frag = self.peel(i, MAP, SURF);
                self.steps.push(surface_draw_culled(a, cull, frag, false));
                self.steps.extend(clip_merge);
                continue;
            }
            // Goldfeather's layers of a non-convex literal, behind the layer map.
            self.loops = true;
            self.steps.push(Step::Pass("surface".into()));
            self.steps.push(if i == 1 {
                Step::Clear(Clear::Texture {
                    tex: PREV,
                    depth: 0.0,
                })
            } else {
                Step::CopyTexture {
                    src: MAP,
                    dst: PREV,
                }
            });
            let frag = if i == 1 {
                Fragment::Peel {
                    prev: PREV,
                    out: CUR,
                    shade: false,
                }
            } else {
                self.peel(i, PREV, CUR)
            };
            self.steps.push(literal_peel_loop(
                surface_draw_culled(a, cull, frag, true),
                clip_merge,
                self.prep.triangles_in(&[a.prim]),
            ));
        }
    }

    /// `backCSG(G)` of Listing 2: the nearest back-mode face of any literal behind
    /// the layer map, straight into the output depth.
    fn back_csg(&mut self, p: &[Lit]) {
        self.steps.push(Step::Pass("back".into()));
        for &a in p {
            self.steps.push(Step::Draw(Draw {
                geometry: Geometry::Mesh(a.prim),
                scissor: Scissor::BoundsOf(vec![a.prim]),
                cull: Mode::Back.cull(a),
                ds: OUTPUT,
                depth: DepthState {
                    compare: CompareOp::Less,
                    write: true,
                },
                stencil: None,
                // The texture written is scratch: the next surface clears it.
                fragment: self.peel(2, MAP, SURF),
                count_samples: false,
            }));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{build, Algo};
    use crate::scene::fixtures::block_minus_spheres;
    use crate::scene::fixtures::{self, ExprBuilder};
    use glam::DVec3;

    fn draws(steps: &[Step]) -> Vec<&Draw> {
        steps
            .iter()
            .flat_map(|s| match s {
                Step::Draw(d) => vec![d],
                Step::Loop(l) => l
                    .head
                    .iter()
                    .chain(&l.tail)
                    .filter_map(|s| match s {
                        Step::Draw(d) => Some(d),
                        _ => None,
                    })
                    .collect(),
                _ => vec![],
            })
            .collect()
    }

    #[test]
    fn layer_one_is_goldfeathers_plan() {
        let prep = Prepared::new(&block_minus_spheres(3)).unwrap();
        let k = build(Algo::Kirsch, &prep).unwrap();
        let g = build(Algo::Goldfeather, &prep).unwrap();
        assert_eq!(k.algo, "kirsch");
        assert_eq!(draws(&k.steps), draws(&g.steps));
    }

    #[test]
    fn single_product_even_layers_draw_back_faces_without_parity() {
        let prep = Prepared::new(&block_minus_spheres(3)).unwrap();
        let opts = ProductOptions::default();
        let l1 = plan_layer(&prep, &opts, 1, true).unwrap();
        let l2 = plan_layer(&prep, &opts, 2, true).unwrap();
        let extra: Vec<&Draw> = draws(&l2.steps)
            .into_iter()
            .filter(|d| d.ds == OUTPUT && matches!(d.geometry, Geometry::Mesh(_)))
            .filter(|d| matches!(d.fragment, Fragment::PeelTolerant { .. }))
            .collect();
        // Listing 2: one draw per literal, the opposite faces of layer 1's.
        assert_eq!(extra.len(), 4);
        assert_eq!(extra[0].cull, Cull::Front); // the block: intersected
        assert!(extra[1..].iter().all(|d| d.cull == Cull::Back)); // spheres: subtracted
        let parity = |p: &Plan| {
            draws(&p.steps)
                .iter()
                .filter(|d| matches!(d.fragment, Fragment::NearerThan { .. }))
                .count()
        };
        assert_eq!(parity(&l1), parity(&l2));
        // Layer 3 is calcCSG(front) behind the map again: parity twice over.
        let l3 = plan_layer(&prep, &opts, 3, true).unwrap();
        assert_eq!(parity(&l3), 2 * parity(&l1));
        // Exactly one counted draw, after the last loop.
        for p in [&l1, &l2, &l3] {
            assert_eq!(
                draws(&p.steps).iter().filter(|d| d.count_samples).count(),
                1
            );
        }
    }

    #[test]
    fn several_products_peel_front_and_back_surfaces() {
        // a + (b - c): two products, the second clipped.
        let mut scene = block_minus_spheres(2);
        let mut e = ExprBuilder::default();
        let (a, b, c) = (e.leaf(0), e.leaf(1), e.leaf(2));
        scene.primitives[1].mesh = fixtures::box_mesh(DVec3::splat(1.5), DVec3::splat(2.5));
        scene.primitives[2].mesh = fixtures::box_mesh(DVec3::splat(2.0), DVec3::splat(3.0));
        let bc = e.diff(b, c);
        let root = e.union(a, bc);
        scene.solids[0].expr = e.build(root);
        let prep = Prepared::new(&scene).unwrap();
        let opts = ProductOptions::default();
        let l2 = plan_layer(&prep, &opts, 2, false).unwrap();
        let parity: Vec<f32> = draws(&l2.steps)
            .iter()
            .filter_map(|d| match d.fragment {
                Fragment::NearerThan { eps, .. } => Some(eps),
                _ => None,
            })
            .collect();
        // Layer 1: b clipped by c, c by b (front); layer 2: the same front and back.
        assert_eq!(parity.len(), 6);
        assert_eq!(parity.iter().filter(|&&e| e < 0.0).count(), 2);
        let crate::plan::Plan { textures, .. } = l2;
        assert_eq!(textures, 4);
    }

    #[test]
    fn too_many_products_fail_like_goldfeather() {
        let prep = Prepared::new(&crate::scene::fixtures::product_blowup(40)).unwrap();
        let err = build(Algo::Kirsch, &prep).unwrap_err().to_string();
        assert!(err.contains("cst-i") && err.contains("4096"), "{err}");
    }
}
