//! Plain depth tests where the tie rule cannot change a draw's result
//! (docs/executor.md). The tolerant parity and peel shaders
//! (`nearer_than`, `peel_tolerant`, `plan::tie`) decide per fragment whether a
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
//!   the plane depth at the pixel centre (docs/precision.md). The depth
//!   copy that opens the shade is scissored to the meshes that keep the rule, or
//!   dropped when none does ([`TieFree::shade_copies`]).
//!
//! Where a draw may meet a tie, SCS's parity before an exit and its clip run the
//! rule as the depth test instead of the shader ([`Fragment::TieDepth`],
//! `shaders/tie_depth.frag`; [`TieFree::with_tie_depth`]): the fragment's
//! depth moved by the tolerance, against the depth-stencil image, which on D32
//! holds the texture's float. They then read no texture, so SCS's exits write
//! none and no barrier separates its batches. Only for meshes whose possible
//! partners are parallel to them (`TieGaps::ties_flat`): the depth test
//! always widens by the slope term, the shader only where the gradients agree.
//!
//! A shade draw of a mesh that keeps the rule runs it only inside the screen
//! rectangles of its tie zones and the depth-equal draw over the rest of its
//! rectangle ([`ShadeRule`], `plan::tie_zones`); the copy then covers those
//! rectangles only.
//!
//! Which meshes are tie-free comes from `TieGaps` (camera-independent: the
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
use super::tie_context::{self, DrawKey};
pub use super::tie_zones::ShadeRule;
use super::visible_side::rule_may_cull;
use crate::geom::ties::TieGaps;

mod band;
mod copies;
mod lowering;

pub use band::TieBand;
pub use copies::ShadeCopy;

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
    /// Whether a parity or clip draw that may meet a tie runs its rule as the
    /// depth test ([`Fragment::TieDepth`]): the depth-stencil images hold the
    /// depth exactly as the textures do (D32; [`TieFree::with_tie_depth`]).
    tie_depth: bool,
    /// Per mesh: every face that may tie with one of its faces is parallel to
    /// it ([`TieGaps::ties_flat`]), so the depth test's rule, which always
    /// widens by the slope term, agrees with the texture's.
    flat: Vec<bool>,
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
            tie_depth: false,
            flat: (0..gaps.min_gap.len() as u32)
                .map(|m| gaps.ties_flat(m))
                .collect(),
        }
    }

    /// These decisions with the parity and clip draws that may meet a tie
    /// running the rule as their depth test ([`Fragment::TieDepth`]) where
    /// `on`. Only right where each depth-stencil image holds the depth its
    /// texture holds bit for bit (D32: both are the fragment's float depth);
    /// D24 rounds the image's.
    pub fn with_tie_depth(self, on: bool) -> TieFree {
        TieFree {
            tie_depth: on,
            ..self
        }
    }

    /// Whether a recording made with these decisions is right for `exact`'s
    /// camera: the same parity and peel decisions, and final shades that draw
    /// the rule wherever `exact`'s would ([`ShadeRule::serves`]).
    pub fn serves(&self, exact: &TieFree) -> bool {
        self.by_eps == exact.by_eps
            && self.tie_depth == exact.tie_depth
            && self.flat == exact.flat
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
            tie_depth: self.tie_depth,
            flat: self.flat.clone(),
        }
    }

    /// These decisions with every final shade keeping the tie rule: where the
    /// device profile allows no depth-equal shade (`Executor::depth_equal_shades`).
    pub fn keep_shade_rule(self) -> TieFree {
        TieFree {
            shade: Vec::new(),
            ..self
        }
    }

    /// Whether every mesh of `meshes` ties only with parallel faces, if at
    /// all ([`TieGaps::ties_flat`]; not decided: no).
    fn ties_flat(&self, meshes: &[MeshId]) -> bool {
        !meshes.is_empty()
            && meshes
                .iter()
                .all(|&m| self.flat.get(m as usize).copied().unwrap_or(false))
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

    /// Per mesh, the final shades' rule at tolerance `eps` (empty: not decided,
    /// the rule everywhere).
    fn shade_rules(&self, eps: f32) -> &[ShadeRule] {
        let key = eps.abs().to_bits();
        self.shade
            .iter()
            .find(|(k, _)| *k == key)
            .map_or(&[], |(_, r)| r.as_slice())
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
    use super::super::testing::{band, cube, parity, plan_of, whole};
    use super::super::SHADE_EPS;
    use super::*;
    use crate::scene::Mesh;
    use glam::DVec3;

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
}
