//! CST(S, V) for one surface S (Hable & Rossignac §4): the peel–trim–push loop
//! (unrolled when the number of layers is known), then Render(S), merged into the
//! final image, optionally marked or painted (§6).
#![deny(unsafe_code)]

use super::super::stencil;
use super::super::step::*;
use super::super::{Prepared, SHADE_EPS};
use super::{Trimmer, CUR, FAR, FINAL, PREV, WORK};

/// How many layers of a surface the peel may need.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layers {
    /// Unknown: loop until an occlusion query says the peel reached no pixel (at
    /// most this many times).
    AtMost(u32),
    /// Exactly this many peels suffice (Hable & Rossignac §4: a convex surface needs
    /// one pass when only front faces are trimmed, two otherwise): the loop is
    /// unrolled, with no occlusion query, no empty last peel and no extra submits.
    Known(u32),
}

impl Layers {
    /// The bound for the mesh `m` peeled with `cull`.
    pub fn of(prep: &Prepared, m: MeshId, cull: Cull) -> Layers {
        if prep.convex(m) {
            Layers::Known(if cull == Cull::None { 2 } else { 1 })
        } else {
            // A front-face (or back-face) peel of a closed mesh has at most half its
            // faces per pixel; both faces at most all of them.
            Layers::AtMost(prep.mesh_triangles[m as usize] as u32 + 1)
        }
    }
}

/// CST(S, V) merged into [`FINAL`] (Hable & Rossignac §4): `Initialize; Repeat
/// {Peel(S); Trim(V); Push()} until Done; Render(S)`. `trimmer: None` means V is the
/// universe: the first layer of S is drawn directly.
///
/// `floor`: a depth texture the peeling starts behind (Hable & Rossignac §6: the
/// layers after the first initialize *PrevDepth* at the previous layer's depth), or
/// `None` to start at the near plane.
pub fn cst(
    surface: MeshId,
    peel_cull: Cull,
    trimmer: Option<&dyn Trimmer>,
    layers: Layers,
    merge: Merge,
    floor: Option<Tex>,
    steps: &mut Vec<Step>,
) {
    let me = vec![surface];
    let Some(t) = trimmer else {
        steps.push(Step::Pass("merge".into()));
        let fragment = match floor {
            None => Fragment::Shade,
            Some(prev) => Fragment::Peel {
                prev,
                out: CUR,
                shade: true,
            },
        };
        steps.push(render_draw(surface, peel_cull, merge, fragment));
        merge.paint(surface, peel_cull, steps);
        return;
    };
    let codes = t.codes();
    steps.push(Step::Pass("init".into()));
    steps.push(Step::Clear(Clear::DepthStencil {
        ds: WORK,
        depth: FAR,
        stencil: codes.start,
    }));
    steps.push(match floor {
        None => Step::Clear(Clear::Texture {
            tex: PREV,
            depth: 0.0,
        }),
        Some(src) => Step::CopyTexture { src, dst: PREV },
    });
    steps.push(Step::Clear(Clear::Texture {
        tex: CUR,
        depth: FAR,
    }));

    // Peel(S): the nearest face strictly behind Front, at unlocked pixels only.
    let head = vec![
        Step::Pass("peel".into()),
        Step::Draw(Draw {
            geometry: Geometry::Mesh(surface),
            scissor: Scissor::BoundsOf(me.clone()),
            cull: peel_cull,
            ds: WORK,
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: Some(stencil::test_equal(codes.start, codes.mask)),
            // Behind a floor, a face within the tie tolerance of the previous layer
            // is that layer's point again (a coincident face of another primitive,
            // rasterized a few ulps behind), as the reference groups crossings
            // closer than its tolerance.
            fragment: match floor {
                None => Fragment::Peel {
                    prev: PREV,
                    out: CUR,
                    shade: false,
                },
                Some(_) => Fragment::PeelTolerant {
                    prev: PREV,
                    out: CUR,
                    eps: SHADE_EPS,
                },
            },
            count_samples: true,
        }),
    ];
    let mut tail = vec![Step::Pass("trim".into())];
    t.trim(&mut tail);
    // Push(): rejected candidates go back to the start label with a far depth, so the
    // next peel advances them; locked ones (label T) keep their depth.
    tail.push(Step::Pass("push".into()));
    tail.push(Step::Draw(Draw {
        geometry: Geometry::FullScreen { depth: FAR },
        scissor: Scissor::BoundsOf(me.clone()),
        cull: Cull::None,
        ds: WORK,
        depth: DepthState {
            compare: CompareOp::Always,
            write: true,
        },
        stencil: Some(stencil::change_stencil_state(
            codes.rejected,
            codes.start,
            codes.mask,
        )),
        fragment: Fragment::None,
        count_samples: false,
    }));
    tail.push(Step::CopyTexture {
        src: CUR,
        dst: PREV,
    });
    let uncounted = |s: &Step| {
        let mut s = s.clone();
        if let Step::Draw(d) = &mut s {
            d.count_samples = false;
        }
        s
    };
    // Render(S). Every pixel without a kept point is knocked out of the
    // recorded layer (a far depth), then S is shaded where its depth equals it.
    // After a loop those pixels have a far depth in WORK (never peeled, pushed,
    // or locked only because nothing was left to peel).
    let mut knock = knock_out(
        &me,
        DepthState {
            compare: CompareOp::Equal,
            write: false,
        },
        None,
    );
    match layers {
        Layers::AtMost(max_iterations) => steps.push(Step::Loop(Loop {
            head,
            tail,
            max_iterations,
        })),
        Layers::Known(1) => {
            // One layer: Push() would only feed the knock-out (no peel follows),
            // and the recorded layer still holds its clear (far) wherever the
            // peel did not write. So the rejected candidates are knocked out by
            // their stencil label directly: one full-screen pass, not two, and
            // the same recorded layer.
            steps.extend(head.iter().map(uncounted));
            let push = |s: &Step| matches!(s, Step::Pass(name) if name == "push");
            steps.extend(tail.iter().take_while(|s| !push(s)).cloned());
            knock = knock_out(
                &me,
                DepthState {
                    compare: CompareOp::Always,
                    write: false,
                },
                Some(stencil::test_equal(codes.rejected, codes.mask)),
            );
        }
        Layers::Known(n) => {
            for i in 0..n {
                steps.extend(head.iter().map(uncounted));
                // The last layer's copy to PrevDepth would feed no peel.
                let last = i + 1 == n;
                steps.extend(
                    tail.iter()
                        .filter(|s| !(last && matches!(s, Step::CopyTexture { .. })))
                        .cloned(),
                );
            }
        }
    }
    steps.push(Step::Pass("merge".into()));
    steps.push(knock);
    steps.push(render_draw(surface, peel_cull, merge, merge.at_depth()));
    merge.paint(surface, peel_cull, steps);
}

/// The full-screen pass that writes a far depth into the recorded layer
/// ([`CUR`]) where WORK's `depth` and `stencil` tests pass: the pixels without a
/// kept point, which Render(S) must not shade.
fn knock_out(me: &[MeshId], depth: DepthState, stencil: Option<StencilState>) -> Step {
    Step::Draw(Draw {
        geometry: Geometry::FullScreen { depth: FAR },
        scissor: Scissor::BoundsOf(me.to_vec()),
        cull: Cull::None,
        ds: WORK,
        depth,
        stencil,
        fragment: Fragment::WriteDepth { out: CUR },
        count_samples: false,
    })
}

/// Render(S)'s draw into [`FINAL`]: S's peeled faces, nearest wins, shaded by
/// `fragment` (all of them, or only at the kept depth).
fn render_draw(surface: MeshId, peel_cull: Cull, merge: Merge, fragment: Fragment) -> Step {
    Step::Draw(Draw {
        geometry: Geometry::Mesh(surface),
        scissor: Scissor::BoundsOf(vec![surface]),
        cull: peel_cull,
        ds: FINAL,
        depth: DepthState {
            compare: CompareOp::Less,
            write: true,
        },
        stencil: merge.stencil(),
        fragment,
        count_samples: false,
    })
}

/// Stencil bit of [`FINAL`] set where a `[[surface]]` won the merge: the final
/// depth-equal shading of the solids' meshes skips those pixels (a surface point
/// keeps its own colour, or its paint colour, even where a solid face passes
/// within [`SHADE_EPS`] of it).
pub const SURFACE_MARK: u8 = 0x01;
/// Stencil bit of [`FINAL`] set by a painted surface's merge and cleared by its
/// paint draw.
pub const PAINT_PENDING: u8 = 0x02;

/// How Render(S) writes into [`FINAL`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Merge {
    /// Mark the pixels won with [`SURFACE_MARK`] (surfaces; solids merge first).
    pub mark: bool,
    /// Repaint the pixels won in this colour (CST painting, Hable & Rossignac §6).
    pub paint: Option<[u8; 3]>,
}

impl Merge {
    /// A solid's leaf: shaded, unmarked.
    pub const SOLID: Merge = Merge {
        mark: false,
        paint: None,
    };

    /// Render(S)'s fragment program at the kept depth. A solid's colour and id
    /// are written by the plan's final depth-equal shading at every pixel the
    /// merge wins (the face rasterizes to the depth it left there, within the
    /// shading's tolerance), so its merge writes depth alone: no colour targets,
    /// no shading per fragment. Surfaces keep theirs (that shading skips them).
    pub(crate) fn at_depth(&self) -> Fragment {
        if *self == Merge::SOLID {
            Fragment::DepthAtDepth { tex: CUR }
        } else {
            Fragment::ShadeAtDepth { tex: CUR }
        }
    }

    fn stencil(&self) -> Option<StencilState> {
        let bits = match (self.mark, self.paint.is_some()) {
            (false, false) => return None,
            (true, false) => SURFACE_MARK,
            (false, true) => PAINT_PENDING,
            (true, true) => SURFACE_MARK | PAINT_PENDING,
        };
        Some(stencil::both(
            CompareOp::Always,
            StencilOp::Replace,
            0,
            bits,
            bits,
        ))
    }

    /// After the shaded merge: S again at exactly the depth it left in [`FINAL`]
    /// (the same rasterization reproduces it bit-exactly), in the paint colour, at
    /// the pixels this merge won; clears their pending bit.
    fn paint(&self, surface: MeshId, cull: Cull, steps: &mut Vec<Step>) {
        let Some(rgb) = self.paint else { return };
        steps.push(Step::Draw(Draw {
            geometry: Geometry::Mesh(surface),
            scissor: Scissor::BoundsOf(vec![surface]),
            cull,
            ds: FINAL,
            depth: DepthState {
                compare: CompareOp::Equal,
                write: false,
            },
            stencil: Some(stencil::both(
                CompareOp::Equal,
                StencilOp::Zero,
                PAINT_PENDING,
                PAINT_PENDING,
                PAINT_PENDING,
            )),
            fragment: Fragment::Paint { rgb },
            count_samples: false,
        }));
    }
}
