//! Trickle (Rossignac & Wu, §2–4; Epstein, Jansen & Rossignac): per
//! product of the sum of products, buffer 2 (`Z2`, a depth texture) trickles front
//! to back through the product's primitives until it rests on the product's
//! visible front; buffer 1 (the output depth) keeps the nearest product.
//!
//! Per product, buffer 2 starts at the nearest face of any of the product's
//! primitives (within the first positive primitive's screen bounds; far elsewhere,
//! which no product can reach), not at the near plane as in the paper: the visible
//! point is where the ray *enters* the product, never the near-plane cut, and no
//! crossing lies in between, so this is right whether or not the ray starts inside
//! the product (an eye inside it, or an orthographic near plane cutting it). Then,
//! circulating through the primitives Q of the product (Rossignac & Wu §2, the UNTIL
//! loop of lines 10–31):
//! - buffer 3 (`Z3`): the nearest face of Q with `Z2 < Z − eps`, selected with a
//!   depth-less test in a scratch depth-stencil image while a shader discards the
//!   other fragments ([`Fragment::PeelTolerant`]), its depth copied to texture `Z3`;
//! - in the same draw, the flag `ff` (a stencil bit, initialised to 1 for a
//!   positive and 0 for a complemented Q) is inverted by every face with
//!   `Z2 < Z − eps`, depth test passed or not: parity classification (§3.4), so
//!   `ff` = 1 says the point just behind `Z2` is outside the literal;
//! - where `ff` = 1, `Z2 := Z3` ([`Fragment::CopyTexel`]): the point is out of the
//!   product, and so is everything up to the next face of Q.
//!
//! Termination: the paper stops after NumberOfPrimitives consecutive scans that
//! changed no pixel (k starts at −1 so a one-primitive product is scanned twice,
//! §3.1). A static plan checks once per *round* over all primitives instead: the
//! round's [`Loop`] head copies `Z2` aside and ends with an occlusion-counted draw
//! that passes where `Z2` changed (moves to far are final and not counted). A round
//! without change is n consecutive unchanged scans at every pixel, so the result
//! is the paper's; a product takes at most one round more than the paper's
//! circulation. A one-primitive product still takes two rounds, as with k = −1.
//! The merge into buffer 1 is a depth-less test (line 33's eps only kept colours
//! apart; shading here is a separate pass that paints faces within
//! [`super::SHADE_EPS`] of the final depth, lowest primitive index
//! winning on coincident faces, as in [`super::goldfeather`]).
//!
//! ## eps (§3.2–3.3)
//! Every comparison of a scanned depth with `Z2` is made `eps` behind the scanned
//! point, so a face coincident with `Z2` (another primitive's face on the same
//! plane, or the front and back faces of one primitive at a silhouette) counts as
//! *at* the point, and the classification is that of the neighbourhood just behind
//! it: coincident faces produce no dangling faces and no z-fighting speckles. The
//! price: any part of the solid thinner than `eps` along the ray (in normalized
//! depth; in view space about `eps · z² (f − n) / (f n)` at view depth z for near n
//! and far f) is treated as flat and vanishes — "regularization modulo eps". The
//! compared values are the rasterizer's `f32` depths (textures are `R32F`), whose
//! error on a coincident face is a few ulps of 2⁻²⁴ (values just below 1.0), and a
//! real move must also show in the depth format for the change count (the d24
//! quantum is 2⁻²⁴ too). So the default is 32 such quanta, [`DEFAULT_EPS`] = 2⁻¹⁹;
//! [`TrickleOptions::eps`] overrides it, and the plan names it in its first pass.
#![deny(unsafe_code)]

use super::goldfeather::{init_steps, products, shade_steps, Lit, ProductOptions, FAR, OUTPUT};
use super::step::*;
use super::{stencil, PlanError, Prepared};

/// 32 quanta of a 24-bit depth buffer (and f32 ulps just below 1.0).
pub const DEFAULT_EPS: f32 = 1.0 / (1 << 19) as f32;

/// Trickle's options.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct TrickleOptions {
    pub products: ProductOptions,
    /// The depth tolerance in normalized depth; `None`: [`DEFAULT_EPS`].
    pub eps: Option<f32>,
}

impl TrickleOptions {
    pub fn eps(&self) -> f32 {
        self.eps.unwrap_or(DEFAULT_EPS)
    }
}

/// The scratch depth-stencil image: buffer 3's depth test and the `ff` stencil bit.
const SCAN: Ds = 1;
/// Buffer 2, buffer 3, and buffer 2 at the start of a round.
const Z2: Tex = 0;
const Z3: Tex = 1;
const Z2_START: Tex = 2;
const FF: u8 = 1;

/// The name of the plan's first pass, which carries eps for the printout and stats.
pub fn init_pass_name(eps: f32) -> String {
    format!("init eps={eps:.3e}")
}

/// Builds the Trickle plan.
pub fn plan(prep: &Prepared, opts: &TrickleOptions) -> Result<Plan, PlanError> {
    let eps = opts.eps();
    let prods = products(prep, opts.products.limit)?;
    let mut steps = init_steps();
    steps[0] = Step::Pass(init_pass_name(eps));
    for p in &prods {
        steps.extend(product_steps(prep, p, eps));
    }
    // Culls nothing: the depth is of any face its peels met (both sides), so
    // at a crossing edge it may be a face that is never visible, which the
    // shade alone colours (`vk_tests/tie_zones.rs` saw one such pixel).
    steps.extend(shade_steps(prep, Z3, &super::VisibleSides::none()));
    Ok(Plan {
        algo: "trickle".into(),
        depth_stencils: 2,
        textures: 3,
        stencil_bits: 1,
        output_ds: OUTPUT,
        steps,
    })
}

fn full(
    scissor: Scissor,
    ds: Ds,
    depth: DepthState,
    stencil: Option<StencilState>,
    fragment: Fragment,
) -> Draw {
    Draw {
        geometry: Geometry::FullScreen { depth: 0.0 },
        scissor,
        cull: Cull::None,
        ds,
        depth,
        stencil,
        fragment,
        count_samples: false,
    }
}

fn product_steps(prep: &Prepared, p: &[Lit], eps: f32) -> Vec<Step> {
    // `products` puts a positive literal first; the product lies in its bounds.
    let region = vec![p[0].prim];
    let no_depth = DepthState {
        compare: CompareOp::Always,
        write: false,
    };
    let mut steps = vec![
        Step::Pass("product".into()),
        Step::Clear(Clear::Texture {
            tex: Z2,
            depth: FAR,
        }),
    ];
    // Z2 = the nearest face (beyond the near plane) of any of the product's
    // primitives: no crossing lies between the near plane and it, so the visible
    // entry is there or behind it, and the near-plane cut is never drawn (the eye,
    // or an orthographic eye plane, may lie inside the product). `ff` counts the
    // faces *behind* Z2, which classify the point whatever the eye's position.
    steps.push(Step::Clear(Clear::DepthStencil {
        ds: SCAN,
        depth: FAR,
        stencil: 0,
    }));
    for l in p {
        steps.push(Step::Draw(Draw {
            geometry: Geometry::Mesh(l.prim),
            scissor: Scissor::BoundsOf(region.clone()),
            cull: Cull::None,
            ds: SCAN,
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: None,
            fragment: Fragment::WriteDepth { out: Z2 },
            count_samples: false,
        }));
    }
    let mut head = vec![
        Step::Pass("trickle".into()),
        Step::CopyTexture {
            src: Z2,
            dst: Z2_START,
        },
    ];
    for &q in p {
        head.push(Step::Clear(Clear::DepthStencil {
            ds: SCAN,
            depth: FAR,
            stencil: if q.negated { 0 } else { FF },
        }));
        head.push(Step::Clear(Clear::Texture {
            tex: Z3,
            depth: FAR,
        }));
        let flip = StencilFace {
            compare: CompareOp::Always,
            fail: StencilOp::Keep,
            pass: StencilOp::Invert,
            depth_fail: StencilOp::Invert,
        };
        // Outside the product's region Z2 is far: no face is behind it, so the
        // scan changes nothing there and is cut to the region.
        head.push(Step::Draw(Draw {
            geometry: Geometry::Mesh(q.prim),
            scissor: Scissor::Within {
                meshes: vec![q.prim],
                within: region.clone(),
            },
            cull: Cull::None,
            ds: SCAN,
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: Some(StencilState {
                front: flip,
                back: flip,
                compare_mask: 0,
                write_mask: FF,
                reference: 0,
            }),
            fragment: Fragment::PeelTolerant {
                prev: Z2,
                out: Z3,
                eps,
            },
            count_samples: false,
        }));
        // ff = 1 outside a positive Q's projection too, so its move covers the
        // product's region; a complemented Q only sets ff within its own bounds.
        let moved = if q.negated {
            Scissor::Within {
                meshes: vec![q.prim],
                within: region.clone(),
            }
        } else {
            Scissor::BoundsOf(region.clone())
        };
        head.push(Step::Draw(full(
            moved,
            SCAN,
            no_depth,
            Some(stencil::test_equal(FF, FF)),
            Fragment::CopyTexel { src: Z3, out: Z2 },
        )));
    }
    // Change detection: Z2 at the round's start as depth, then count where Z2 differs.
    head.push(Step::Pass("trickle-change".into()));
    head.push(Step::Draw(full(
        Scissor::BoundsOf(region.clone()),
        SCAN,
        DepthState {
            compare: CompareOp::Always,
            write: true,
        },
        None,
        Fragment::DepthFromTexture { src: Z2_START },
    )));
    let mut count = full(
        Scissor::BoundsOf(region.clone()),
        SCAN,
        DepthState {
            compare: CompareOp::NotEqual,
            write: false,
        },
        None,
        Fragment::DepthFromTexture { src: Z2 },
    );
    count.count_samples = true;
    head.push(Step::Draw(count));
    let all: Vec<MeshId> = p.iter().map(|l| l.prim).collect();
    let max_iterations = prep.triangles_in(&all).max(1) as u32 + 2;
    steps.push(Step::Loop(Loop {
        head,
        tail: Vec::new(),
        max_iterations,
    }));
    steps.push(Step::Pass("merge".into()));
    steps.push(Step::Draw(full(
        Scissor::BoundsOf(region),
        OUTPUT,
        DepthState {
            compare: CompareOp::Less,
            write: true,
        },
        None,
        Fragment::DepthFromTexture { src: Z2 },
    )));
    steps
}
