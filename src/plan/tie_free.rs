//! Plain depth tests where the tie rule cannot change a draw's result (issue 9
//! §5; README "Per-fragment work"). The tolerant parity and peel shaders
//! (`nearer_than`, `peel_tolerant`, [`super::tie`]) decide per fragment whether a
//! face is coincident with the depth in a texture; they `discard` and write
//! stencil, so llvmpipe runs every fragment of the draw through them before its
//! depth and stencil tests. Where no face of the drawn meshes can come within
//! the tie band of any other face, their answer is the plain comparison's:
//!
//! - a parity draw [`Fragment::NearerThan`] (depth test off) becomes a
//!   depth-stencil-only draw ([`Fragment::None`], `shaders/none.frag`) tested
//!   `LessOrEqual` (`eps > 0`: faces at or in front of the candidate count) or
//!   `Less` (`eps < 0`: only faces strictly in front) against its depth-stencil
//!   image, which holds the texture's depth wherever the draw's result is read
//!   (the plans' invariant, documented at [`Fragment::NearerThan`]); llvmpipe then
//!   tests depth and stencil before an empty shader, as OpenCSG's parity passes;
//! - SCS's clip by back faces [`Fragment::BehindThan`], the parity test's
//!   complement, likewise becomes a depth-stencil-only draw tested `Greater`
//!   (`GreaterOrEqual` for `eps < 0`);
//! - SCS's merge by back faces [`Fragment::MergeBehind`] keeps its program (it
//!   writes the texture's depth) with the exact compare (`eps` 0: one texel
//!   fetch instead of three, no derivatives);
//! - a tolerant peel [`Fragment::PeelTolerant`] becomes the exact peel
//!   ([`Fragment::Peel`], one texel fetch instead of three and no derivatives);
//! - a draw of the final shade [`Fragment::ShadeNearDepth`]
//!   ([`super::tie::shade_near_depth`]: compare `Always`, the tie test in the
//!   shader, `gl_FragDepth` written) becomes OpenCSG's shading: the plain
//!   [`Fragment::Shade`] program tested `Equal` against the depth-stencil image,
//!   no depth written, no texture read, so llvmpipe tests depth before the
//!   shader, and, as OpenCSG culls, the faces of its mesh that are never
//!   visible culled (`equal_cull`, [`super::VisibleSides`]). The image holds
//!   the visible face's raster depth bit-exactly in every plan: written by the
//!   face's own draw (Blister's peels, CST's [`Fragment::DepthAtDepth`]
//!   merges), or by a full-screen `gl_FragDepth` copy
//!   of a texture that holds that draw's `gl_FragCoord.z` (Goldfeather's, Kirsch's,
//!   SCS's and Trickle's merges), which the depth format rounds as it rounds the
//!   rasterized depth; `gl_Position` is `invariant`, so the shade's redraw of the
//!   face reproduces it (`vk_tests/tie_free.rs` checks every algorithm on every
//!   depth set-up, vertex snapping emulated too). A tie-free mesh's draw then
//!   passes exactly where its face is the visible one, as its tie test did; the
//!   draws that keep the rule still draw in descending index order, and a
//!   depth-equal draw and a tie-rule draw can both pass at one pixel only where
//!   two faces cross within the tie band (an edge of the image), where the rule
//!   mesh wins whatever the order. The depth output is then the raster depth, not
//!   the plane depth at the pixel centre (README "Precision and ties"). The depth
//!   copy that opens the shade is scissored to the meshes that keep the rule, or
//!   dropped when none does ([`TieFree::shade_copies`]).
//!
//! A shade draw of a mesh that keeps the rule runs it only inside the screen
//! rectangles of its tie zones and the depth-equal draw over the rest of its
//! rectangle ([`ShadeRule`], `plan::tie_zones`); the copy then covers those
//! rectangles only.
//!
//! Which meshes are tie-free comes from [`TieGaps`] (camera-independent: the
//! smallest distance between a mesh's faces and a parallel, overlapping face)
//! and [`TieBand`] (the band's width in world units for one camera, image size
//! and vertex snapping): a mesh is tie-free for a tolerance when its smallest gap
//! is wider than the band. The texture's faces come from meshes of the same scene,
//! so a mesh with no partner at all within the band cannot tie whatever the
//! texture holds. A draw whose meshes have partners is tie-free still where no
//! image it reads can hold a partner's faces (`plan::tie_context`: the plan
//! says which meshes each image may hold). [`TieFree`] is those decisions, per
//! tolerance of the plan; the executor keeps its recording while a moving
//! camera leaves them unchanged.

use std::collections::HashMap;

use super::rect::Rect;
use super::step::*;
use super::tie::REVERSED_SCALE;
use super::tie_context::{self, DrawKey};
pub use super::tie_zones::ShadeRule;
use super::visible_side::rule_may_cull;
use crate::geom::ties::TieGaps;
use crate::scene::{Aabb, Camera, Projection};

/// Depth quantum of a 24-bit buffer (and the largest ulp of standard-Z floats
/// below 1).
const QUANTUM_STANDARD: f64 = 1.0 / (1u64 << 24) as f64;
/// Relative ulp bound of a reversed-Z float depth.
const QUANTUM_REVERSED: f64 = 1.0 / (1u64 << 23) as f64;
/// Relative f32 rounding of vertices and transforms allowed for (2⁻¹⁸ of the
/// distance from the eye: four times the 2⁻²⁰ of README "Precision and ties").
const ROUNDING: f64 = 1.0 / (1u64 << 18) as f64;
/// Every bound below is doubled (the depth slope is taken as constant over the
/// band; the band is a tiny fraction of the view depth).
const SAFETY: f64 = 2.0;

/// The tie band as a world distance between two faces, under one camera: two
/// faces farther apart than [`TieBand::world`] are never within the tie rule's
/// tolerance of each other at any pixel.
///
/// Along a view ray at angle β to the view axis, faces a distance `h` apart
/// differ in view depth by at least `h cos β`. The rule's tolerance in
/// normalized depth, `eps' + 2^-bits · fwidth(z)`, is in view depth `eps' /
/// |dz/dw| + 2^-bits (|∂w/∂x| + |∂w/∂y|)`; for parallel planes the second term
/// is at most `2^(2-bits)` pixel footprints in perspective (`2^(1-bits)`
/// orthographic) whatever their angle to the ray, because the separation along
/// the ray grows with the same `1/cos` as the slope. With the depth-format
/// quantum, f32 rounding and a factor of two for safety, the band in world units
/// is `SAFETY · (per_eps · |eps| + fixed) + rounding`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TieBand {
    /// World units per unit of the draw's `|eps|`.
    per_eps: f64,
    /// The part independent of `eps`: quantum and vertex snapping, before
    /// [`SAFETY`].
    fixed: f64,
    /// f32 rounding of positions, world units.
    rounding: f64,
}

impl TieBand {
    /// The band for `camera` on a `width × height` image of a device that snaps
    /// vertices to `2^-subpixel_bits` pixel, with reversed or standard Z, for
    /// faces inside `bounds`.
    pub fn new(
        camera: &Camera,
        width: u32,
        height: u32,
        subpixel_bits: u32,
        reversed_z: bool,
        bounds: &Aabb,
    ) -> TieBand {
        let (n, f) = (camera.near, camera.far);
        let mut w_max = n;
        let mut t_max: f64 = 0.0;
        for k in 0..8 {
            let p = glam::DVec3::new(
                if k & 1 == 0 {
                    bounds.min.x
                } else {
                    bounds.max.x
                },
                if k & 2 == 0 {
                    bounds.min.y
                } else {
                    bounds.max.y
                },
                if k & 4 == 0 {
                    bounds.min.z
                } else {
                    bounds.max.z
                },
            );
            w_max = w_max.max(camera.view_depth(p));
            t_max = t_max.max((p - camera.eye).length());
        }
        // Nothing beyond the far plane is drawn (and an empty box gives -inf).
        let w_max = if w_max.is_finite() { w_max.min(f) } else { f };
        let t_max = if t_max.is_finite() { t_max } else { f };
        let snap = 0.5f64.powi(subpixel_bits.min(30) as i32);
        let (depth_per_z, slope, cos_beta) = match camera.projection {
            Projection::Perspective { fov_y_deg } => {
                let tan_half = (fov_y_deg.to_radians() * 0.5).tan();
                let aspect = width as f64 / height as f64;
                let cos_beta = 1.0 / (1.0 + tan_half * tan_half * (1.0 + aspect * aspect)).sqrt();
                // World size of a pixel at distance t: at most t · ρ.
                let rho = 2.0 * tan_half / height as f64;
                // View depth per unit of (reversed: relative) normalized depth.
                let per_z = if reversed_z {
                    w_max
                } else {
                    (f - n) * w_max * w_max / (f * n)
                };
                (per_z, 4.0 * snap * t_max * rho, cos_beta)
            }
            Projection::Orthographic { height: view_h } => {
                (f - n, 2.0 * snap * view_h / height as f64, 1.0)
            }
        };
        let (per_eps, quantum) = if reversed_z {
            (
                REVERSED_SCALE as f64 * depth_per_z,
                QUANTUM_REVERSED * depth_per_z,
            )
        } else {
            (depth_per_z, QUANTUM_STANDARD * depth_per_z)
        };
        TieBand {
            per_eps: per_eps / cos_beta,
            fixed: (quantum + slope) / cos_beta,
            rounding: ROUNDING * t_max,
        }
    }

    /// The band of a draw with tolerance `eps` (normalized depth), world units.
    pub fn world(&self, eps: f32) -> f64 {
        SAFETY * (self.per_eps * eps.abs() as f64 + self.fixed) + self.rounding
    }
}

/// Which meshes are tie-free under one camera, per tolerance a plan uses.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TieFree {
    /// `|eps|` (its bits), then per mesh: no face within that band of a
    /// parallel face. The tolerances of parity and peel draws.
    by_eps: Vec<(u32, Vec<bool>)>,
    /// Per tolerance of the final shades ([`Fragment::ShadeNearDepth`],
    /// [module doc](self)), per mesh: where its shade keeps the rule.
    shade: Vec<(u32, Vec<ShadeRule>)>,
    /// Per tolerance of the final shades, per mesh: its rule draws may cull
    /// the faces that are never visible (`visible_side::rule_may_cull`).
    rule_cull: Vec<(u32, Vec<bool>)>,
    /// Per tolerant draw of the plan: no image it reads holds a partner face
    /// of its meshes (`plan::tie_context`).
    by_draw: HashMap<DrawKey, bool>,
}

impl TieFree {
    /// Nothing tie-free: every tolerant draw keeps its shader.
    pub fn none() -> TieFree {
        TieFree::default()
    }

    /// The decisions for the tolerances of `plan`'s tolerant draws; the final
    /// shades' from `shade_gaps`, the zones of `gaps` that may hold a visible
    /// point (`plan::visible_ties`); `project` gives the screen rectangle of a
    /// world box under the camera of `band` (the full screen for one crossing
    /// the near plane).
    pub fn new(
        gaps: &TieGaps,
        shade_gaps: &TieGaps,
        band: &TieBand,
        plan: &Plan,
        project: &dyn Fn(&crate::scene::Aabb) -> Rect,
    ) -> TieFree {
        // The final shade, and since SCS's exits move the depth image with the
        // texture, every plan's parity draws (module doc).
        let mut shade_eps = shade_tolerances(&plan.steps);
        shade_eps.sort_unstable();
        shade_eps.dedup();
        // Only a shade of the solid's boundary, which it says by culling
        // (`VisibleSides` comes from the solid), may use the zones the solid
        // shows; Kirsch's deeper layers show the products' boundaries.
        let shade_gaps = if shows_solid(&plan.steps) {
            shade_gaps
        } else {
            gaps
        };
        let meshes = shade_gaps.min_gap.len() as u32;
        let shade = per_mesh(&shade_eps, band, meshes, |m, b| {
            ShadeRule::decide(shade_gaps, m, b, project)
        });
        let rule_cull = per_mesh(&shade_eps, band, meshes, |m, b| {
            rule_may_cull(shade_gaps, m, b)
        });
        let mut eps: Vec<u32> = Vec::new();
        tolerances(&plan.steps, &mut eps);
        let by_eps = decide(gaps, band, eps);
        // Unknown beyond the gaps' cap.
        let partners = |m: MeshId, eps: f32| {
            let b = band.world(eps);
            (b.is_finite() && b <= gaps.cap).then(|| {
                let pairs = gaps
                    .pairs
                    .iter()
                    .filter(|&&(x, y, g)| g <= b && (x == m || y == m));
                pairs.map(|&(x, y, _)| if x == m { y } else { x }).collect()
            })
        };
        TieFree {
            by_eps,
            shade,
            rule_cull,
            by_draw: tie_context::decide(&plan.steps, &partners),
        }
    }

    /// Whether a recording made with these decisions is right for `exact`'s
    /// camera: the same parity and peel decisions, and final shades that draw
    /// the rule wherever `exact`'s would ([`ShadeRule::serves`]).
    pub fn serves(&self, exact: &TieFree) -> bool {
        self.by_eps == exact.by_eps
            && self.by_draw == exact.by_draw
            && self.rule_cull == exact.rule_cull
            && self.shade.len() == exact.shade.len()
            && self.shade.iter().zip(&exact.shade).all(|((k, a), (l, b))| {
                k == l && a.len() == b.len() && a.iter().zip(b).all(|(a, b)| a.serves(b))
            })
    }

    /// These decisions with the final shades' rule rectangles grown by `mx`,
    /// `my` pixels (a moving camera's recording; `Scissors::grown`).
    pub fn grown(&self, mx: u32, my: u32, width: u32, height: u32) -> TieFree {
        let shade = self
            .shade
            .iter()
            .map(|(k, rules)| {
                let rules = rules.iter().map(|r| r.grown(mx, my, width, height));
                (*k, rules.collect())
            })
            .collect();
        TieFree {
            by_eps: self.by_eps.clone(),
            shade,
            rule_cull: self.rule_cull.clone(),
            by_draw: self.by_draw.clone(),
        }
    }

    /// These decisions with every final shade keeping the tie rule (A/B
    /// measurements, `Executor::set_fixed_shade`).
    pub fn keep_shade_rule(self) -> TieFree {
        TieFree {
            shade: Vec::new(),
            ..self
        }
    }

    /// These decisions with every final shade that keeps the rule keeping it
    /// over its whole rectangle (A/B measurements, `Executor::set_tie_zones`).
    pub fn without_zones(self) -> TieFree {
        let shade = self
            .shade
            .into_iter()
            .map(|(k, rules)| {
                let rules = rules.into_iter().map(|r| match r {
                    ShadeRule::Zones(_) => ShadeRule::Everywhere,
                    other => other,
                });
                (k, rules.collect())
            })
            .collect();
        TieFree { shade, ..self }
    }

    /// Whether every mesh of `meshes` is tie-free at tolerance `eps`.
    pub fn meshes_free(&self, meshes: &[MeshId], eps: f32) -> bool {
        all_free(&self.by_eps, meshes, eps)
    }

    /// Whether tolerant `draw` of `meshes` cannot meet a tie at `eps`: its
    /// meshes are tie-free, or nothing it reads holds a partner face of
    /// theirs (`plan::tie_context`).
    fn draw_free(&self, draw: &Draw, meshes: &[MeshId], eps: f32) -> bool {
        self.meshes_free(meshes, eps)
            || DrawKey::of(draw).is_some_and(|k| self.by_draw.get(&k) == Some(&true))
    }

    /// Whether the final shade's draws of every mesh of `meshes` at tolerance
    /// `eps` run as depth-equal draws ([module doc](self)).
    pub fn shade_free(&self, meshes: &[MeshId], eps: f32) -> bool {
        let rules = self.shade_rules(eps);
        !meshes.is_empty()
            && meshes
                .iter()
                .all(|&m| rules.get(m as usize) == Some(&ShadeRule::Free))
    }

    /// Whether the final shade's draw of mesh `m` at tolerance `eps` runs
    /// depth-`EQUAL` over its whole rectangle: tie-free, or its tie zones all
    /// off screen (what `plan::direct_shade` needs to shade `m` in its
    /// direct draw instead).
    pub fn shade_depth_equal(&self, m: MeshId, eps: f32) -> bool {
        match self.shade_rules(eps).get(m as usize) {
            Some(ShadeRule::Free) => true,
            Some(ShadeRule::Zones(z)) => z.is_empty(),
            _ => false,
        }
    }

    /// A final shade's draw that keeps the tie rule, culling the faces of its
    /// mesh that are never visible where it can never be the lowest index of
    /// a tie on them (`visible_side::rule_may_cull`); `None` where it culls
    /// nothing more than `draw`.
    pub fn culled_rule(&self, draw: &Draw) -> Option<Draw> {
        let (
            Fragment::ShadeNearDepth {
                eps, equal_cull, ..
            },
            Geometry::Mesh(m),
        ) = (&draw.fragment, &draw.geometry)
        else {
            return None;
        };
        let key = eps.abs().to_bits();
        let may = self
            .rule_cull
            .iter()
            .find(|(k, _)| *k == key)
            .and_then(|(_, v)| v.get(*m as usize).copied())
            .unwrap_or(false);
        (may && is_final_shade(draw) && *equal_cull != draw.cull).then(|| Draw {
            cull: *equal_cull,
            ..draw.clone()
        })
    }

    /// Per mesh, the final shades' rule at tolerance `eps` (empty: not decided,
    /// the rule everywhere).
    fn shade_rules(&self, eps: f32) -> &[ShadeRule] {
        let key = eps.abs().to_bits();
        self.shade
            .iter()
            .find(|(k, _)| *k == key)
            .map_or(&[], |(_, r)| r.as_slice())
    }

    /// The screen rectangles to which a final shade's draw keeps the tie rule,
    /// when that is not its whole rectangle: the draw runs the rule there and
    /// [`TieFree::depth_equal`] elsewhere ([`ShadeRule::Zones`]). `None` for
    /// every other draw.
    pub fn shade_zones(&self, draw: &Draw) -> Option<&[Rect]> {
        let (Fragment::ShadeNearDepth { eps, .. }, Geometry::Mesh(m)) =
            (&draw.fragment, &draw.geometry)
        else {
            return None;
        };
        if !is_final_shade(draw) {
            return None;
        }
        match self.shade_rules(*eps).get(*m as usize) {
            Some(ShadeRule::Zones(r)) => Some(r),
            _ => None,
        }
    }

    /// A final shade's draw as OpenCSG's depth-`EQUAL` shading ([module
    /// doc](self)), whatever the decisions: `None` for other draws. It culls
    /// the faces that are never visible (`equal_cull`,
    /// [`super::VisibleSides`]): it passes only at its own faces' raster
    /// depth, so a culled face could pass only where it crosses the visible
    /// one, and it is drawn only where it cannot tie with it.
    pub fn depth_equal(draw: &Draw) -> Option<Draw> {
        let Fragment::ShadeNearDepth { equal_cull, .. } = draw.fragment else {
            return None;
        };
        is_final_shade(draw).then(|| Draw {
            cull: equal_cull,
            depth: DepthState {
                compare: CompareOp::Equal,
                write: false,
            },
            fragment: Fragment::Shade,
            ..draw.clone()
        })
    }

    /// The draw with plain tests in place of the tie rule, when the rule cannot
    /// change its result ([module doc](self)); `None` otherwise.
    pub fn fixed_function(&self, draw: &Draw) -> Option<Draw> {
        let meshes: &[MeshId] = match &draw.geometry {
            Geometry::Mesh(m) => std::slice::from_ref(m),
            Geometry::Meshes(ms) => ms,
            Geometry::FullScreen { .. } | Geometry::Footprint { .. } => return None,
        };
        match draw.fragment {
            Fragment::NearerThan { eps, .. } | Fragment::ParityBeforeExit { eps, .. } => {
                let compare = if eps < 0.0 {
                    CompareOp::Less
                } else {
                    CompareOp::LessOrEqual
                };
                // The exit's `Greater` test stands for the back faces' half of
                // the parity (`Fragment::ParityBeforeExit`).
                let cull = match draw.fragment {
                    Fragment::ParityBeforeExit { .. } => Cull::Back,
                    _ => draw.cull,
                };
                self.plain_test(draw, meshes, eps, compare)
                    .map(|d| Draw { cull, ..d })
            }
            // NearerThan's complement: the opposite plain compare.
            Fragment::BehindThan { eps, .. } => {
                let compare = if eps < 0.0 {
                    CompareOp::GreaterOrEqual
                } else {
                    CompareOp::Greater
                };
                self.plain_test(draw, meshes, eps, compare)
            }
            // The merge writes the texture's depth, so it keeps its program,
            // with the exact compare (one fetch, no derivatives).
            Fragment::MergeBehind { tex, eps }
                if eps != 0.0 && self.draw_free(draw, meshes, eps) =>
            {
                Some(Draw {
                    fragment: Fragment::MergeBehind { tex, eps: 0.0 },
                    ..draw.clone()
                })
            }
            Fragment::PeelTolerant { prev, out, eps } if self.draw_free(draw, meshes, eps) => {
                Some(Draw {
                    fragment: Fragment::Peel {
                        prev,
                        out,
                        shade: false,
                    },
                    ..draw.clone()
                })
            }
            Fragment::ShadeNearDepth { eps, .. } if self.shade_free(meshes, eps) => {
                Self::depth_equal(draw)
            }
            _ => None,
        }
    }

    /// `step` as the executor records it, for what it reads
    /// (`plan::reach`): a draw [`TieFree::fixed_function`] rewrites, rewritten;
    /// the final shades' draws as planned (what their depth copy must cover
    /// is [`TieFree::shade_copies`]' to decide); any other step as it is.
    pub fn lowered(&self, step: &Step) -> Step {
        match step {
            Step::Draw(d) if !matches!(d.fragment, Fragment::ShadeNearDepth { .. }) => self
                .fixed_function(d)
                .map_or_else(|| step.clone(), Step::Draw),
            _ => step.clone(),
        }
    }

    /// A tolerant parity-like `draw` of `meshes` as a depth-stencil draw with
    /// no program, tested `compare` against its image, when its meshes are
    /// tie-free at `eps` and it has no depth test of its own (the shader's
    /// compare can replace only that).
    fn plain_test(
        &self,
        draw: &Draw,
        meshes: &[MeshId],
        eps: f32,
        compare: CompareOp,
    ) -> Option<Draw> {
        let off = DepthState {
            compare: CompareOp::Always,
            write: false,
        };
        if draw.depth != off || !self.draw_free(draw, meshes, eps) {
            return None;
        }
        Some(Draw {
            depth: DepthState {
                compare,
                write: false,
            },
            fragment: Fragment::None,
            ..draw.clone()
        })
    }

    /// For every [`Step::CopyDepthToTexture`] of `steps`, in order, what it must
    /// cover once the final shades' draws are rewritten by
    /// [`TieFree::fixed_function`].
    pub fn shade_copies(&self, steps: &[&Step]) -> Vec<ShadeCopy> {
        let mut out = Vec::new();
        for (i, s) in steps.iter().enumerate() {
            let Step::CopyDepthToTexture { ds, dst } = s else {
                continue;
            };
            let group: Vec<&Draw> = steps[i + 1..]
                .iter()
                .map_while(|s| match s {
                    Step::Draw(d) => match d.fragment {
                        Fragment::ShadeNearDepth { tex, .. } if tex == *dst && d.ds == *ds => {
                            Some(d)
                        }
                        _ => None,
                    },
                    _ => None,
                })
                .collect();
            let after = &steps[i + 1 + group.len()..];
            if group.is_empty() || after.iter().any(|s| samples(s, *dst)) {
                out.push(ShadeCopy::AsPlanned);
                continue;
            }
            let mut rule: Vec<(MeshId, Option<Vec<Rect>>)> = group
                .into_iter()
                .filter(|d| self.fixed_function(d).is_none())
                .flat_map(|d| {
                    let zones = self.shade_zones(d).map(<[Rect]>::to_vec);
                    match &d.geometry {
                        Geometry::Mesh(m) => vec![(*m, zones)],
                        Geometry::Meshes(ms) => ms.iter().map(|&m| (m, None)).collect(),
                        Geometry::FullScreen { .. } | Geometry::Footprint { .. } => {
                            panic!("a final shade draws meshes (plan::tie::shade_near_depth)")
                        }
                    }
                })
                .collect();
            rule.sort_unstable_by_key(|r| r.0);
            out.push(ShadeCopy::ReadBy(rule));
        }
        out
    }
}

/// Whether `draw` is a final shade's draw as `plan::tie::shade_near_depth`
/// makes it: the tie test in the shader, its depth written.
fn is_final_shade(draw: &Draw) -> bool {
    let shade = DepthState {
        compare: CompareOp::Always,
        write: true,
    };
    matches!(draw.fragment, Fragment::ShadeNearDepth { .. }) && draw.depth == shade
}

/// What a depth copy must cover ([`TieFree::shade_copies`]).
#[derive(Clone, Debug, PartialEq)]
pub enum ShadeCopy {
    /// The whole image, as planned: not the copy opening a final shade, or one
    /// whose texture a later step reads.
    AsPlanned,
    /// The copy opening a final shade, read by nothing but the shade's draws of
    /// these meshes, which keep the tie rule: the screen bounds of these meshes,
    /// each cut to its rule rectangles where it has them
    /// ([`TieFree::shade_zones`]; `None`: its whole rectangle), with the tie
    /// test's neighbour fetches. None: nobody reads the copy.
    ReadBy(Vec<(MeshId, Option<Vec<Rect>>)>),
}

/// Whether `step` (or a loop's body) reads texture `tex`.
fn samples(step: &Step, tex: Tex) -> bool {
    match step {
        Step::Loop(l) => l.head.iter().chain(&l.tail).any(|s| samples(s, tex)),
        s => s
            .usage()
            .iter()
            .any(|&(r, u)| r == super::usage::Resource::Texture(tex) && !u.writes()),
    }
}

/// Per tolerance of `eps` (bits of `|eps|`, any order, repeats allowed): per
/// mesh, whether its smallest gap to a parallel face is wider than the band.
fn decide(gaps: &TieGaps, band: &TieBand, mut eps: Vec<u32>) -> Vec<(u32, Vec<bool>)> {
    eps.sort_unstable();
    eps.dedup();
    eps.into_iter()
        .map(|bits| {
            let b = band.world(f32::from_bits(bits));
            let free = gaps
                .min_gap
                .iter()
                .map(|&g| b.is_finite() && b <= gaps.cap && g > b)
                .collect();
            (bits, free)
        })
        .collect()
}

/// Per tolerance of `eps` (bits of `|eps|`), `f(mesh, band)` for each of
/// `meshes` meshes, the band in world units.
fn per_mesh<T>(
    eps: &[u32],
    band: &TieBand,
    meshes: u32,
    f: impl Fn(MeshId, f64) -> T,
) -> Vec<(u32, Vec<T>)> {
    let each = |&bits: &u32| {
        let b = band.world(f32::from_bits(bits));
        (bits, (0..meshes).map(|m| f(m, b)).collect())
    };
    eps.iter().map(each).collect()
}

/// Whether `meshes` is not empty and each is tie-free at `eps` in `by_eps`
/// (a tolerance not decided: none is).
fn all_free(by_eps: &[(u32, Vec<bool>)], meshes: &[MeshId], eps: f32) -> bool {
    let key = eps.abs().to_bits();
    let Some((_, free)) = by_eps.iter().find(|(k, _)| *k == key) else {
        return false;
    };
    !meshes.is_empty()
        && meshes
            .iter()
            .all(|&m| free.get(m as usize).copied().unwrap_or(false))
}

/// The `|eps|` bits of every final-shade draw in `steps` (top level: a shade
/// is never inside a loop, `plan::tie::shade_near_depth`).
fn shade_tolerances(steps: &[Step]) -> Vec<u32> {
    steps
        .iter()
        .filter_map(|s| match s {
            Step::Draw(d) => match d.fragment {
                Fragment::ShadeNearDepth { eps, .. } => Some(eps.abs().to_bits()),
                _ => None,
            },
            _ => None,
        })
        .collect()
}

/// Whether the final shade of `steps` shows the solid's boundary: some draw
/// of it culls a side (`VisibleSides::entries` or `exits`, derived from the
/// solid); a shade that culls nothing may show anything (Kirsch's deeper
/// layers: the products' boundaries).
fn shows_solid(steps: &[Step]) -> bool {
    steps.iter().any(|s| {
        matches!(s, Step::Draw(Draw {
            fragment: Fragment::ShadeNearDepth { equal_cull, .. },
            ..
        }) if *equal_cull != Cull::None)
    })
}

/// The `|eps|` bits of every tolerant parity or peel draw in `steps`.
fn tolerances(steps: &[Step], out: &mut Vec<u32>) {
    for s in steps {
        match s {
            Step::Draw(d) => match d.fragment {
                Fragment::NearerThan { eps, .. }
                | Fragment::ParityBeforeExit { eps, .. }
                | Fragment::BehindThan { eps, .. }
                | Fragment::MergeBehind { eps, .. }
                | Fragment::PeelTolerant { eps, .. } => out.push(eps.abs().to_bits()),
                _ => {}
            },
            Step::Loop(l) => {
                tolerances(&l.head, out);
                tolerances(&l.tail, out);
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::testing::{
        band, camera, half_free, parity, plan_of, the_draw as draw, unit, whole,
    };
    use super::super::SHADE_EPS;
    use super::*;
    use crate::scene::{shapes, Mesh};
    use glam::DVec3;

    #[test]
    fn the_band_scales_with_the_pixel_and_the_snapping() {
        // The snapping part is proportional to the pixel's size: 8× at 1/8 the size.
        let (fine, coarse) = (band(800, 8, true), band(100, 8, true));
        assert!((coarse.fixed - 8.0 * fine.fixed).abs() < 1e-2 * coarse.fixed);
        // 4 bits (the coarsest conformant device) snap 16× coarser than 8.
        assert!(band(800, 4, true).world(0.0) > 10.0 * band(800, 8, true).world(0.0));
        // At 800 px a pixel is ~6e-3 wide at the far corner (6 units away);
        // 2^-6 of it (snapping 2^-8, two faces, perspective, safety) over cos β,
        // plus rounding: ~2.6e-4. A 1e-3 thin wall is outside the band.
        let w = fine.world(SHADE_EPS);
        assert!(w > 1e-4 && w < 5e-4, "{w}");
    }

    #[test]
    fn reversed_z_tolerances_are_narrower_than_standard_ones() {
        // Standard Z: (f - n) w² / (f n) = 6.9 view units per unit of eps at the
        // far corner; reversed Z: REVERSED_SCALE · w = 0.75.
        let (std, rev) = (band(800, 8, false), band(800, 8, true));
        assert!((std.per_eps / rev.per_eps - 6.0 * 6.0 * 4.0 / 21.0 / 0.75).abs() < 1e-9);
        let ortho = camera(
            DVec3::new(0.0, 0.0, 5.0),
            Projection::Orthographic { height: 3.0 },
        );
        let o = TieBand::new(&ortho, 800, 800, 8, false, &unit());
        // Orthographic standard Z: (f - n) per unit of eps; snapping 2^-7 of 3/800.
        assert!((o.per_eps - 4.0).abs() < 1e-12);
        assert!((o.fixed - (4.0 / (1u64 << 24) as f64 + 2.0 / 256.0 * 3.0 / 800.0)).abs() < 1e-12);
    }

    fn cube(center: DVec3, half: DVec3) -> Mesh {
        let mut m = shapes::make_box(half * 2.0);
        for p in &mut m.positions {
            *p += center;
        }
        m
    }

    /// Tie-free decisions for the meshes 0 and 1 of a two-box scene under a
    /// 5-unit-away camera at `size` pixels.
    fn decide(b: Mesh, size: u32) -> Vec<bool> {
        let a = cube(DVec3::ZERO, DVec3::splat(0.5));
        let gaps = TieGaps::new(&[&a, &b]);
        let plan = plan_of(vec![parity(0, SHADE_EPS), parity(1, SHADE_EPS)]);
        let free = TieFree::new(&gaps, &gaps, &band(size, 8, true), &plan, &whole);
        (0..2).map(|m| free.meshes_free(&[m], SHADE_EPS)).collect()
    }

    #[test]
    fn ties_are_decided_by_distance_overlap_and_image_size() {
        // Coplanar and overlapping (top faces at y = 0.5): never tie-free.
        let flush = cube(DVec3::new(0.2, 0.3, 0.0), DVec3::new(0.5, 0.2, 0.4));
        assert_eq!(decide(flush.clone(), 800), vec![false, false]);
        assert_eq!(decide(flush, 4000), vec![false, false]);
        // Coplanar but disjoint: tie-free.
        let apart = cube(DVec3::new(1.5, 0.3, 0.0), DVec3::new(0.5, 0.2, 0.4));
        assert_eq!(decide(apart, 800), vec![true, true]);
        // Parallel faces 1e-3 apart (a thin wall between two solids): beyond the
        // band at 800 pixels, inside it at 32 pixels, where a pixel is 0.2 wide.
        let wall = cube(DVec3::new(0.2, 0.301, 0.0), DVec3::new(0.5, 0.2, 0.4));
        assert_eq!(decide(wall.clone(), 800), vec![true, true]);
        assert_eq!(decide(wall, 32), vec![false, false]);
    }

    #[test]
    fn tie_free_parity_draws_become_plain_depth_tests() {
        let steps = vec![
            parity(0, SHADE_EPS),
            parity(0, -SHADE_EPS),
            parity(1, SHADE_EPS),
        ];
        let free = half_free(&plan_of(steps.clone()));
        let fast: Vec<Option<Draw>> = steps
            .into_iter()
            .map(|s| free.fixed_function(&draw(s)))
            .collect();
        let compare = |d: &Option<Draw>| {
            let d = d.as_ref().expect("rewritten");
            assert_eq!(d.fragment, Fragment::None);
            assert!(!d.depth.write);
            d.depth.compare
        };
        assert_eq!(compare(&fast[0]), CompareOp::LessOrEqual);
        assert_eq!(compare(&fast[1]), CompareOp::Less);
        // The possibly tied mesh keeps the tie rule.
        assert_eq!(fast[2], None);
        assert!(fast.iter().flatten().all(|d| d.cull == Cull::None));
    }

    #[test]
    fn a_tie_free_parity_before_an_exit_draws_front_faces_only() {
        let before_exit = |mesh| {
            let mut d = draw(parity(mesh, SHADE_EPS));
            d.fragment = Fragment::ParityBeforeExit {
                tex: 1,
                eps: SHADE_EPS,
            };
            d
        };
        let plan = plan_of(vec![Step::Draw(before_exit(0)), Step::Draw(before_exit(1))]);
        let free = half_free(&plan);
        let fast = free.fixed_function(&before_exit(0)).expect("rewritten");
        assert_eq!(
            (
                fast.cull,
                fast.depth.compare,
                fast.depth.write,
                &fast.fragment
            ),
            (Cull::Back, CompareOp::LessOrEqual, false, &Fragment::None)
        );
        // The possibly tied mesh keeps every face and the tie rule.
        assert_eq!(free.fixed_function(&before_exit(1)), None);
    }

    #[test]
    fn only_draws_without_a_depth_test_and_known_tolerances_are_rewritten() {
        let free = half_free(&plan_of(vec![parity(0, SHADE_EPS)]));
        let mut d = draw(parity(0, SHADE_EPS));
        d.depth.compare = CompareOp::Less;
        assert_eq!(free.fixed_function(&d), None);
        // A tolerance the plan did not have was never decided.
        assert_eq!(free.fixed_function(&draw(parity(0, 1e-3))), None);
        assert_eq!(
            TieFree::none().fixed_function(&draw(parity(0, SHADE_EPS))),
            None
        );
        // Several meshes: all must be tie-free.
        let mut d = draw(parity(0, SHADE_EPS));
        d.geometry = Geometry::Meshes(vec![0, 1]);
        assert_eq!(free.fixed_function(&d), None);
    }

    #[test]
    fn tie_free_tolerant_peels_become_exact_peels() {
        let peel = |mesh| {
            Step::Draw(Draw {
                fragment: Fragment::PeelTolerant {
                    prev: 0,
                    out: 1,
                    eps: SHADE_EPS,
                },
                depth: DepthState {
                    compare: CompareOp::Less,
                    write: true,
                },
                ..draw(parity(mesh, SHADE_EPS))
            })
        };
        let plan = plan_of(vec![Step::Loop(Loop {
            head: vec![peel(0), peel(1)],
            tail: vec![],
            max_iterations: 3,
        })]);
        let free = half_free(&plan);
        let fast = free.fixed_function(&draw(peel(0))).expect("tie-free");
        assert_eq!(
            fast.fragment,
            Fragment::Peel {
                prev: 0,
                out: 1,
                shade: false
            }
        );
        assert_eq!(fast.depth, draw(peel(0)).depth);
        assert_eq!(free.fixed_function(&draw(peel(1))), None);
    }

    /// A final shade of meshes `ms` (depth-stencil 0, texture 1) after `before`.
    fn shaded(before: Vec<Step>, ms: &[MeshId]) -> Plan {
        let mut steps = before;
        steps.extend(super::super::shade_near_depth(
            ms,
            0,
            1,
            None,
            &super::super::VisibleSides::none(),
        ));
        plan_of(steps)
    }

    fn refs(plan: &Plan) -> Vec<&Step> {
        plan.steps.iter().collect()
    }

    #[test]
    fn tie_free_shade_draws_become_depth_equal_shading() {
        let plan = shaded(vec![parity(0, SHADE_EPS)], &[0, 1]);
        let free = half_free(&plan);
        let shade: Vec<Draw> = plan.steps[3..].iter().cloned().map(draw).collect();
        // Descending order: mesh 1 (can tie) first, then mesh 0.
        assert_eq!(shade[0].geometry, Geometry::Mesh(1));
        assert_eq!(free.fixed_function(&shade[0]), None);
        let fast = free.fixed_function(&shade[1]).expect("mesh 0 is tie-free");
        assert_eq!(fast.fragment, Fragment::Shade);
        assert_eq!(
            fast.depth,
            DepthState {
                compare: CompareOp::Equal,
                write: false
            }
        );
        assert_eq!((fast.ds, fast.stencil, fast.cull), (0, None, Cull::None));
        // The A/B switch keeps the rule.
        assert_eq!(
            free.clone().keep_shade_rule().fixed_function(&shade[1]),
            None
        );
    }

    /// `d` with the culling its depth-equal form may take set to `c`.
    fn sided(mut d: Draw, c: Cull) -> Draw {
        if let Fragment::ShadeNearDepth { equal_cull, .. } = &mut d.fragment {
            *equal_cull = c;
        }
        d
    }

    #[test]
    fn shade_draws_cull_the_faces_never_visible_where_no_tie_can_need_them() {
        let plan = shaded(Vec::new(), &[0, 1]);
        let shade: Vec<Draw> = plan.steps[2..].iter().cloned().map(draw).collect();
        let (one, zero) = (
            sided(shade[0].clone(), Cull::Front),
            sided(shade[1].clone(), Cull::Back),
        );
        // Mesh 0 is tie-free: its depth-equal draw culls.
        let free = half_free(&plan);
        assert_eq!(free.fixed_function(&zero).map(|d| d.cull), Some(Cull::Back));
        assert_eq!(free.culled_rule(&zero).map(|d| d.cull), Some(Cull::Back));
        // Mesh 1 keeps the rule, but ties only with itself: its rule draw culls.
        assert_eq!(free.fixed_function(&one), None);
        let rule = free.culled_rule(&one).expect("no other mesh ties with 1");
        assert_eq!(
            rule,
            Draw {
                cull: Cull::Front,
                ..one.clone()
            }
        );
        // Nothing to cull, or nothing decided: no culled draw.
        assert_eq!(free.culled_rule(&shade[0]), None);
        assert_eq!(TieFree::none().culled_rule(&one), None);
        // Mesh 0 tied with the higher mesh 1: 0's hidden faces may win a tie.
        let gaps = TieGaps {
            min_gap: vec![0.0, 0.0],
            cap: 1.0,
            pairs: vec![(0, 1, 0.0)],
            zones: vec![],
        };
        let tied = TieFree::new(&gaps, &gaps, &band(800, 8, true), &plan, &whole);
        assert_eq!(tied.culled_rule(&zero), None);
        assert_eq!(tied.culled_rule(&one).map(|d| d.cull), Some(Cull::Front));
    }

    #[test]
    fn the_shade_copy_reaches_the_rule_meshes_or_nothing() {
        let plan = shaded(Vec::new(), &[0, 1]);
        assert_eq!(
            half_free(&plan).shade_copies(&refs(&plan)),
            vec![ShadeCopy::ReadBy(vec![(1, None)])]
        );
        // Every draw depth-equal: nobody reads the copy.
        let plan = shaded(Vec::new(), &[0]);
        assert_eq!(
            half_free(&plan).shade_copies(&refs(&plan)),
            vec![ShadeCopy::ReadBy(vec![])]
        );
        // Nothing decided: every mesh keeps the rule.
        assert_eq!(
            TieFree::none().shade_copies(&refs(&plan)),
            vec![ShadeCopy::ReadBy(vec![(0, None)])]
        );
        // A copy read by something else (CST layers' floor), or whose texture
        // a later step reads, stays as planned.
        let floor = Step::CopyDepthToTexture { ds: 0, dst: 1 };
        let mut steps = vec![floor.clone(), Step::Pass("x".into()), floor];
        steps.extend(super::super::shade_near_depth(
            &[0],
            0,
            1,
            None,
            &super::super::VisibleSides::none(),
        ));
        steps.push(parity(0, SHADE_EPS));
        let plan = plan_of(steps);
        assert_eq!(
            half_free(&plan).shade_copies(&refs(&plan)),
            vec![
                ShadeCopy::AsPlanned,
                ShadeCopy::AsPlanned,
                ShadeCopy::AsPlanned
            ]
        );
    }
}
