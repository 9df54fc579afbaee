//! The embedding's direct final pass (docs/embedding.md): the plan's last
//! pass, the depth-equal shade of `plan::tie` (docs/precision.md),
//! drawn straight into the host's colour and depth attachments, so that an
//! embedded frame does the standalone frame's work and no composite pass
//! (`vk::composite`, the fallback) remains.
//!
//! The standalone pass draws the solid's meshes in descending index order,
//! the last writer (the lowest index) winning; so does this one. A mesh the
//! standalone frame shades with a plain depth-`EQUAL` test (`plan::tie_free`:
//! no face can tie with it) gets the same test here, against the host's depth
//! after one full-screen depth merge (`DepthFromTextureHost`) wrote the output
//! depth into it wherever the CSG is nearer: the test runs before the shader
//! (`shaders/shade_at_depth.frag`, `HOST`), so only the visible fragments run
//! it; on lavapipe a per-fragment fetch of the output depth for every fragment
//! cost the embedded frame 20% more than the standalone one on `interference`.
//! A mesh that keeps the tie rule is drawn with
//! `shaders/shade_near_depth.frag` (`HOST`) on the depth copy: every face that
//! passes the tie test at a pixel writes the same depth, the visible one, under
//! the host's test with equality (`LESS_OR_EQUAL`, reversed
//! `GREATER_OR_EQUAL`). Exact ties between the host's depth and the CSG's
//! visible depth go to the CSG, drawn last.
//!
//! The shader of a depth-equal piece fetches the output depth once per
//! visible fragment, to turn away a hidden face that merely equals a host
//! depth nearer than the CSG. A one-primitive product the standalone frame
//! shades in its direct draw (`plan::direct_shade`, the same decision) has
//! no face nearer than the output depth, so its piece skips that fetch
//! (`shaders/shade.frag`, `HOST`). The merge keeps no discard of far
//! pixels: a far depth fails the host's strict test by itself.
//!
//! The merge's shader writes `gl_FragDepth`, so lavapipe tests it late and
//! runs it on every pixel of its rectangle. Where the pieces' own fragments
//! are fewer ([`writes_depth`], a pure choice from their scissors and
//! culling), there is no merge: each depth-equal piece tests the host's depth
//! with equality and writes its raster depth, its shader
//! (`shade_at_depth.frag`, `HOST_WRITE`) discarding every fragment not at the
//! output depth; a shader that discards but writes no depth keeps the test
//! before it on lavapipe, so fragments behind the host's geometry cost little.
//! A directly shaded product's piece needs no fetch there either
//! (`Piece::WrittenDirect`): tested and written before its shader, as in the
//! standalone frame, since any fragment of it that is not the visible one lies
//! behind the visible face, whose piece overwrites it. So does the part of a
//! written piece outside the screen rectangles of its mesh's cutters
//! (`Piece::WrittenUncut`, `plan::cut_away`: a mesh that is the only positive
//! literal of a product has no face nearer than the output depth outside its
//! cutters; docs/embedding.md).

use ash::vk;

use super::Recorder;
use crate::plan::cut_away::{self, CutAway};
use crate::plan::direct_shade::DirectShades;
use crate::plan::tie_zones;
use crate::plan::usage::{Resource, Usage};
use crate::plan::{
    CompareOp, Cull, DepthState, Draw, Ds, Fragment, Geometry, MeshId, Plan, Step, Tex,
};
use crate::scene::Aabb;
use crate::vk::conv;
use crate::vk::error::VkError;
use crate::vk::pipeline::{FragmentKind, PipelineDesc, PushConstants};
use crate::vk::scissor::{bounds_rect, Rect};
use crate::vk::submit;

/// The most rectangles a cavity's inside is drawn in (`Recorder::cut_insides`):
/// each draws the whole mesh under its scissor.
const INSIDE_PIECES: usize = 4;

/// The host's side of a direct final pass.
#[derive(Clone, Copy, Debug)]
pub(crate) struct HostShade<'a> {
    /// The host's colour attachment view and format (in `COLOR_ATTACHMENT_OPTIMAL`).
    pub color: (vk::ImageView, vk::Format),
    /// The host's depth attachment view and format (in
    /// `DEPTH_STENCIL_ATTACHMENT_OPTIMAL`); its stencil is not bound.
    pub depth: (vk::ImageView, vk::Format),
    /// The host's colour format is `_SRGB` (drawn with the decoding variant).
    pub srgb: bool,
    /// Samples per pixel of the host's attachments (peeltrim's images'
    /// count, `EmbedDesc::samples`).
    pub samples: u32,
    /// Where the frame's occlusion counts are copied (pairs of `u64` with
    /// availability, room for every counted draw), before the pass's barrier
    /// makes them visible to the host.
    pub counts: Option<vk::Buffer>,
    /// Per mesh, the cutters outside whose screen rectangles none of its
    /// faces lies nearer than the output depth (`plan::cut_away`): its
    /// depth-equal piece is drawn there without the fetch.
    pub cut_away: &'a CutAway,
}

/// How many steps at the end of `plan` are its final depth-equal shade as the
/// direct pass draws it: one `ShadeNearDepth` draw per mesh into the output
/// depth-stencil, after the copy of its depth into their texture. `None` when
/// the plan ends otherwise (`blister-paper` has no such pass). A stencil test of
/// these draws is dropped: plans use it only to keep them to pixels where the
/// loop left a visible depth (Blister's locked pixels; the others are pushed
/// back to far), and the `HOST` shader discards far pixels itself.
pub(crate) fn final_shade(plan: &Plan) -> Option<usize> {
    let mut tex: Option<Tex> = None;
    for (n, s) in plan.steps.iter().rev().enumerate() {
        match s {
            Step::Draw(Draw {
                geometry: Geometry::Mesh(_),
                fragment: Fragment::ShadeNearDepth { tex: t, .. },
                ds,
                count_samples: false,
                ..
            }) if *ds == plan.output_ds && tex.is_none_or(|x| x == *t) => tex = Some(*t),
            Step::CopyDepthToTexture { ds, dst } if *ds == plan.output_ds && tex == Some(*dst) => {
                return Some(n)
            }
            _ => return None,
        }
    }
    None
}

/// Whether `plan` takes its colour from its peel (`blister-paper`): every draw
/// that writes colour is a `Peel { shade: true }` draw of meshes into the output
/// depth-stencil, writing its depth, or a `Background` reset that pushes that
/// depth to far; nothing else writes it.
fn colours_from_peel(plan: &Plan) -> bool {
    let ds = plan.output_ds;
    let mut peels = false;
    for s in flat_steps(plan) {
        let Step::Draw(d) = s else { continue };
        let writes_ds = d.ds == ds && d.depth.write;
        match (&d.fragment, &d.geometry) {
            (Fragment::Peel { shade: true, .. }, Geometry::Mesh(_) | Geometry::Meshes(_))
                if writes_ds =>
            {
                peels = true
            }
            (Fragment::Background, Geometry::FullScreen { depth })
                if writes_ds && *depth == 1.0 => {}
            (
                Fragment::Shade
                | Fragment::Paint { .. }
                | Fragment::Background
                | Fragment::Peel { shade: true, .. }
                | Fragment::ShadeNearDepth { .. }
                | Fragment::ShadeAtDepth { .. },
                _,
            ) => return false,
            _ if writes_ds => return false,
            _ => {}
        }
    }
    peels
}

/// Every step of `plan`, a loop's as its head then its tail.
fn flat_steps(plan: &Plan) -> Vec<&Step> {
    plan.steps
        .iter()
        .flat_map(|s| match s {
            Step::Loop(l) => l.head.iter().chain(&l.tail).collect(),
            s => vec![s],
        })
        .collect()
}

/// The texture that holds, wherever a plan coloured by its peel keeps a colour
/// ([`colours_from_peel`]: the ids are not 0 there), the depth of the face that
/// wrote it, as a 32-bit float: the peels' `out` (the peel writes
/// `gl_FragCoord.z` there with the colour, and a locked pixel is never peeled
/// again), when every peel writes it and nothing else does but a clear before
/// the loops. The composite reads it instead of the depth-stencil: lavapipe
/// fetches a D32S8 texel several times slower than an R32F one.
pub(crate) fn peel_depth(plan: &Plan) -> Option<Tex> {
    if !colours_from_peel(plan) {
        return None;
    }
    let mut out: Option<Tex> = None;
    let peels = plan.steps.iter().flat_map(|s| match s {
        Step::Loop(l) => l.head.iter().chain(&l.tail).collect::<Vec<_>>(),
        _ => vec![],
    });
    for s in peels.clone() {
        if let Step::Draw(Draw {
            fragment:
                Fragment::Peel {
                    out: o,
                    shade: true,
                    ..
                },
            ..
        }) = s
        {
            if out.is_some_and(|t| t != *o) {
                return None;
            }
            out = Some(*o);
        }
    }
    let out = out?;
    let writes_out = |s: &Step| {
        s.usage()
            .iter()
            .any(|(r, u)| *r == Resource::Texture(out) && u.writes())
    };
    let peel = |s: &Step| {
        matches!(
            s,
            Step::Draw(Draw {
                fragment: Fragment::Peel { shade: true, .. },
                ..
            })
        )
    };
    let outside_ok = plan
        .steps
        .iter()
        .all(|s| matches!(s, Step::Loop(_) | Step::Clear(_)) || !writes_out(s));
    let inside_ok = peels.into_iter().all(|s| peel(s) || !writes_out(s));
    (outside_ok && inside_ok).then_some(out)
}

/// Copies the first `n` occlusion queries of `pool`, each with its availability
/// (two `u64`), into `buffer` (room for `n` pairs), once the device has them.
/// Outside rendering; the queries were reset and ended in this command buffer.
pub(crate) fn copy_counts(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    pool: vk::QueryPool,
    n: u32,
    buffer: vk::Buffer,
) {
    // SAFETY: the caller's contract: outside rendering, `n` queries of this
    // recording, a buffer of at least `n` pairs of u64.
    unsafe {
        device.cmd_copy_query_pool_results(
            cmd,
            pool,
            0,
            n,
            buffer,
            0,
            16,
            // WAIT: on the device (no CPU wait), for the last draws may still
            // be rasterizing (lavapipe), and an unavailable count would leave
            // the frame unchecked: every query copied was ended in this
            // recording, so each becomes available.
            vk::QueryResultFlags::TYPE_64
                | vk::QueryResultFlags::WITH_AVAILABILITY
                | vk::QueryResultFlags::WAIT,
        )
    };
}

/// The memory barriers before peeltrim draws into a host's attachments: the
/// host's earlier attachment writes before this pass's attachment reads and
/// writes, and with `counted` the count copy before the host's reads. Their
/// source and destination stages.
pub(crate) fn host_barriers(
    counted: bool,
) -> (
    (vk::PipelineStageFlags, vk::PipelineStageFlags),
    Vec<vk::MemoryBarrier<'static>>,
) {
    let att = vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT
        | vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS
        | vk::PipelineStageFlags::LATE_FRAGMENT_TESTS;
    let mut memory = vec![vk::MemoryBarrier::default()
        .src_access_mask(
            vk::AccessFlags::COLOR_ATTACHMENT_WRITE
                | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
        )
        .dst_access_mask(
            vk::AccessFlags::COLOR_ATTACHMENT_READ
                | vk::AccessFlags::COLOR_ATTACHMENT_WRITE
                | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_READ
                | vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE,
        )];
    let (mut src, mut dst) = (att, att);
    if counted {
        memory.push(
            vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ),
        );
        src |= vk::PipelineStageFlags::TRANSFER;
        dst |= vk::PipelineStageFlags::HOST;
    }
    ((src, dst), memory)
}

/// How one piece of the host's final shade is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Piece {
    /// With the tie rule on the depth copy (`ShadeNearDepthHost`), the
    /// visible depth written.
    Rule,
    /// Depth-`EQUAL` against the merged depth, the output depth fetched to
    /// turn away a face that only equals the host's (`ShadeAtDepthHost`).
    AtDepth,
    /// Depth-`EQUAL` against the merged depth with no fetch (`ShadeHost`): a
    /// one-primitive product the standalone frame shades in its direct draw
    /// (`plan::direct_shade`), none of whose faces lies nearer than the
    /// output depth, so none can equal a host depth nearer than it.
    Direct,
    /// With no merge: `LESS_OR_EQUAL` against the host's depth (before the
    /// shader), the output depth fetched and every fragment not at it
    /// discarded, the raster depth of the rest (the visible face's) written
    /// (`ShadeAtDepthHostWrite`).
    Written,
    /// With no merge, a `Direct` piece: `LESS_OR_EQUAL` against the host's
    /// depth, tested and written before the shader, which fetches nothing
    /// (`ShadeHost`). None of its faces lies nearer than the output depth, so
    /// a fragment of it that is not the visible one lies behind the visible
    /// face, whose piece passes wherever the CSG is in front of the host and
    /// overwrites it, drawn before or after; ties keep the plan's order.
    WrittenDirect,
    /// With no merge, drawn as `WrittenDirect`: the part of a depth-equal
    /// piece outside the screen rectangles of the cutters of a product in
    /// which its mesh is the only positive literal (`plan::cut_away`), where
    /// none of its front faces (its back faces culled) lies nearer than the
    /// output depth. Only with no merge: after one, the fetch runs on the
    /// visible fragments alone, and the draws a split adds cost more than
    /// that (`complex`, measured on lavapipe).
    WrittenUncut,
}

impl Piece {
    /// Drawn with no fetch of the output depth (`ShadeHost`).
    fn fetch_free(self) -> bool {
        matches!(
            self,
            Piece::Direct | Piece::WrittenDirect | Piece::WrittenUncut
        )
    }
}

/// One depth-equal piece of the final shade as [`writes_depth`] prices it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Priced {
    /// Its scissor.
    pub rect: Rect,
    /// Its culling.
    pub cull: Cull,
    /// A piece that fetches nothing (`Piece::Direct`, `Piece::WrittenUncut`)
    /// and is tested before its shader.
    pub direct: bool,
}

/// The order of the written pieces that lets the solid's faces hide the
/// cavities' insides before their shader: every piece but the insides (a
/// `Written` piece drawn with its front faces culled: a subtracted mesh's
/// inside, mostly behind the solid's faces) in plan order, then the insides in
/// reverse plan order, each drawn with the strict compare (`true`). `None`,
/// keeping the plan's order, where that could change a pixel: a rule piece or a
/// merge path, no inside, or an inside whose rectangle meets that of a piece
/// before it in plan order that is not an inside.
///
/// Why the result is the plan order's: every fragment that passes writes its
/// pixel's output depth, or, for the fetch-free pieces, a depth at or behind
/// it. After the others, a pixel holds the host's depth, the output depth
/// (a piece at it passed) or a hidden fetch-free fragment's depth behind it.
/// An inside at the output depth then passes strictly only in the first and
/// last case; in the second a piece that meets it passed, which comes after
/// it in plan order (the condition), so it wins the tie there in plan order
/// too. Among the insides, the first drawn that passes keeps the pixel, the
/// last in plan order. The one difference: where an inside's visible face has
/// bit-equal depth with the host's geometry the host's pixel stays (the plan
/// order gives it to the CSG, as the other pieces' `LESS_OR_EQUAL` does).
fn insides_last(pieces: &[(Cull, Piece, Rect)]) -> Option<Vec<(usize, bool)>> {
    let inside = |(c, p, _): &(Cull, Piece, Rect)| *p == Piece::Written && *c == Cull::Front;
    let plain = pieces.iter().all(|(_, p, _)| {
        matches!(
            p,
            Piece::Written | Piece::WrittenDirect | Piece::WrittenUncut
        )
    });
    if !plain || !pieces.iter().any(inside) {
        return None;
    }
    for (i, a) in pieces.iter().enumerate().filter(|(_, a)| inside(a)) {
        let met = pieces[..i]
            .iter()
            .any(|b| !inside(b) && !b.2.intersect(&a.2).is_empty());
        if met {
            return None;
        }
    }
    let (ins, rest): (Vec<usize>, Vec<usize>) =
        (0..pieces.len()).partition(|&i| inside(&pieces[i]));
    let mut order: Vec<(usize, bool)> = rest.into_iter().map(|i| (i, false)).collect();
    order.extend(ins.into_iter().rev().map(|i| (i, true)));
    Some(order)
}

/// Whether the final shade's depth-equal pieces are drawn `Written`, each
/// testing the host's depth with equality and writing its own, rather than
/// after the depth merge: whichever runs the shader on fewer pixels, as
/// lavapipe prices them (docs/embedding.md).
///
/// The merge runs its shader (a depth fetch and `gl_FragDepth`, tested late)
/// on every pixel of its rectangle, the bounds of the pieces' scissors; the
/// pieces after it test depth-`EQUAL` before their shader, so their hidden
/// fragments cost little. A `Written` piece runs its shader (a depth fetch and
/// a compare) on every fragment in front of the host's depth, hidden or not.
/// A mesh drawn with its back faces culled shows mostly the faces it draws:
/// about one fragment per pixel of its scissor. The back faces a front cull
/// keeps (a subtracted mesh's inside) and a mesh drawn whole lie mostly behind
/// the solid's faces, which the plan's order (descending index) draws after
/// them: two. A direct piece costs nothing on either side: written
/// (`Piece::WrittenDirect`) or after the merge, its fragments are tested
/// before a shader that fetches nothing, as in the standalone frame; nor
/// does the part of a piece outside its mesh's cutters
/// (`Piece::WrittenUncut`), drawn the same way. One
/// merge pixel costs as much as 4 such fragments (fitted on
/// embedded frames on lavapipe, SCS and Goldfeather, 800×800, with the direct pieces
/// written: the pieces win on `complex` (3.5 fragments per merge pixel) and
/// `drilled_block` (2.7), which took the merge at 2.5, and on the rest of the
/// bench's scenes; the example's box with four bites, at 4.2, keeps it).
pub(crate) fn writes_depth(pieces: &[Priced]) -> bool {
    let written: u64 = pieces
        .iter()
        .map(|p| match (p.direct, p.cull) {
            (true, _) => 0,
            (false, Cull::Back) => p.rect.area(),
            (false, Cull::Front | Cull::None) => 2 * p.rect.area(),
        })
        .sum();
    let merged = pieces
        .iter()
        .fold(Rect::EMPTY, |a, p| a.union(&p.rect))
        .area();
    written <= 4 * merged
}

/// The pipeline of host program `kind` for the host's formats.
fn host_pipeline(h: &HostShade, kind: FragmentKind) -> PipelineDesc {
    PipelineDesc {
        fragment: kind,
        color_formats: vec![h.color.1],
        depth_stencil_format: Some(h.depth.1),
        normals: false,
        samples: h.samples,
    }
}

impl Recorder<'_> {
    /// Records `shade` (the plan's last steps, [`final_shade`]'s draws, in plan
    /// order) into the host's attachments, after the rest of the frame: the
    /// occlusion counts copied to `h.counts`, one barrier (what the draws
    /// sample to sampled, the host's attachment writes, the counts for the
    /// host), one rendering block, then every image back to `REST`.
    ///
    /// A shade draw the standalone frame runs as a plain depth-`EQUAL` draw
    /// (`TieFree::fixed_function`: no face can tie with it) is drawn with
    /// `ShadeAtDepthHost` depth-`EQUAL` against the host's depth after the
    /// depth merge ([`Recorder::host_merge`]) put the output depth there
    /// wherever it is nearer: the test runs before the shader, so only the
    /// fragments at the visible depth run it (and fetch the output depth, to
    /// turn away a face that only equals the host's). The draws that keep the
    /// tie rule use `ShadeNearDepthHost` on the copy, writing the visible depth
    /// where it is nearer than or equal to the host's. The draws keep the plan's
    /// order (descending index), so the last writer, the lowest index, stays,
    /// as in the standalone frame.
    ///
    /// Where [`writes_depth`] says the pieces cost fewer pixels than the
    /// merge, every depth-equal piece is drawn `Written` instead, with no merge.
    ///
    /// The meshes of `direct` (one-primitive products, `plan::direct_shade`:
    /// the standalone frame shades them in their direct draws) are drawn
    /// depth-`EQUAL` too, with `ShadeHost`, which fetches nothing: their
    /// direct draw wrote their nearest face's depth into the output depth
    /// and nothing after it moved that depth farther, so no face of theirs
    /// lies nearer than the output depth, and a fragment that equals the
    /// merged depth is at the output depth, visible, in front of the host's
    /// geometry or tied with it.
    pub fn host_shade(
        &mut self,
        h: &HostShade,
        shade: &[&Step],
        direct: &DirectShades,
    ) -> Result<(), VkError> {
        self.end_block();
        let device = self.b.device;
        let n = self.queries.len() as u32;
        let counted = n > 0 && h.counts.is_some();
        if let (true, Some(buffer)) = (counted, h.counts) {
            copy_counts(device, self.cmd, self.b.occlusion, n, buffer);
        }
        // (draw, piece, rect), in plan order: a zoned draw as its rule pieces
        // and its depth-equal pieces (`record/shade.rs`'s `zoned_shade`).
        let mut draws: Vec<(Draw, Piece, Rect)> = Vec::new();
        for s in shade {
            let Step::Draw(d) = s else {
                panic!("final_shade selects draws only")
            };
            let scissor = self.scissor(&d.scissor);
            if scissor.is_empty() {
                self.stats.counts.skipped_steps += 1;
                continue;
            }
            if let Some(zones) = self.b.ties.shade_zones(d) {
                let rule: Vec<Rect> = zones
                    .iter()
                    .map(|z| z.intersect(&scissor))
                    .filter(|r| !r.is_empty())
                    .collect();
                // The host's pieces stay disjoint (`writes_depth` below).
                let rule = tie_zones::merge(rule, tie_zones::MAX_CUT_RECTS);
                let rest = tie_zones::subtract(scissor, &rule);
                // Culling what can never win the tie (`plan::visible_side`).
                let culled = self.b.ties.culled_rule(d).unwrap_or_else(|| d.clone());
                draws.extend(rule.into_iter().map(|r| (culled.clone(), Piece::Rule, r)));
                draws.extend(rest.into_iter().map(|r| (d.clone(), Piece::AtDepth, r)));
                continue;
            }
            match self.b.ties.fixed_function(d) {
                // Culling the faces that are never visible, as standalone.
                Some(f) => draws.push((
                    Draw {
                        cull: f.cull,
                        ..d.clone()
                    },
                    match direct.drops(d) {
                        true => Piece::Direct,
                        false => Piece::AtDepth,
                    },
                    scissor,
                )),
                // Culling what can never win the tie (`plan::visible_side`).
                None => draws.push((
                    self.b.ties.culled_rule(d).unwrap_or_else(|| d.clone()),
                    Piece::Rule,
                    scissor,
                )),
            }
        }
        // The merge, or each depth-equal piece writing its own depth: which
        // costs fewer shaded pixels (`writes_depth`); written, the parts of
        // depth-equal pieces outside their cutters skip the fetch
        // (`plan::cut_away`), taken where they tip the choice too.
        let priced = |draws: &[(Draw, Piece, Rect)]| -> Vec<Priced> {
            draws
                .iter()
                .filter(|(_, piece, _)| *piece != Piece::Rule)
                .map(|(d, piece, r)| Priced {
                    rect: *r,
                    cull: d.cull,
                    direct: piece.fetch_free(),
                })
                .collect()
        };
        let draws = self.cut_insides(draws, h.cut_away);
        let mut draws = match self.split_uncut(&draws, h.cut_away) {
            Some((split, extra, triangles)) if writes_depth(&priced(&split)) => {
                self.stats.counts.shade_split_draws += extra;
                self.stats.counts.shade_split_triangles += triangles;
                split
            }
            _ => draws,
        };
        if writes_depth(&priced(&draws)) {
            for (_, piece, _) in draws.iter_mut() {
                *piece = match *piece {
                    Piece::Direct => Piece::WrittenDirect,
                    Piece::AtDepth => Piece::Written,
                    p => p,
                };
            }
        }
        let rule_tex = draws
            .iter()
            .find(|(_, piece, _)| *piece == Piece::Rule)
            .map(|(d, _, _)| match d.fragment {
                Fragment::ShadeNearDepth { tex, .. } => tex,
                _ => panic!("final_shade selects ShadeNearDepth draws"),
            });
        // The output depth the merge reads (and the `AtDepth` pieces).
        let equal_ds = draws
            .iter()
            .find(|(_, piece, _)| *piece != Piece::Rule)
            .map(|(d, _, _)| d.ds);
        let mut uses = Vec::new();
        uses.extend(rule_tex.map(|t| (Resource::Texture(t), Usage::Sampled)));
        uses.extend(equal_ds.map(|ds| (Resource::DepthStencil(ds), Usage::Sampled)));
        self.settle_clears(&uses);
        let ((src, dst), images) = self.image_transitions(&uses, false, &[]);
        let ((hsrc, hdst), memory) = host_barriers(counted);
        submit::pipeline_barrier(device, self.cmd, (src | hsrc, dst | hdst), &memory, &images);
        self.stats.counts.barriers += 1;

        // The sRGB decode is a variant of its own (`build.rs`).
        let (rule_kind, equal_kind, direct_kind, written_kind) = match h.srgb {
            true => (
                FragmentKind::ShadeNearDepthHostSrgb,
                FragmentKind::ShadeAtDepthHostSrgb,
                FragmentKind::ShadeHostSrgb,
                FragmentKind::ShadeAtDepthHostWriteSrgb,
            ),
            false => (
                FragmentKind::ShadeNearDepthHost,
                FragmentKind::ShadeAtDepthHost,
                FragmentKind::ShadeHost,
                FragmentKind::ShadeAtDepthHostWrite,
            ),
        };
        self.begin_host_block(h);
        let flags = self.flags();
        if let Some(ds) = equal_ds {
            self.host_merge(h, ds, &draws, flags)?;
        }
        let shape: Vec<_> = draws.iter().map(|(d, p, r)| (d.cull, *p, *r)).collect();
        let order =
            insides_last(&shape).unwrap_or_else(|| (0..draws.len()).map(|i| (i, false)).collect());
        self.stats.counts.shade_insides_last += order.iter().filter(|(_, s)| *s).count() as u64;
        for &(i, strict) in &order {
            let (draw, piece, rect) = &draws[i];
            let (kind, set) = match piece {
                Piece::Rule => (rule_kind, rule_tex.map(Resource::Texture)),
                Piece::AtDepth => (equal_kind, equal_ds.map(Resource::DepthStencil)),
                Piece::Direct | Piece::WrittenDirect | Piece::WrittenUncut => (direct_kind, None),
                Piece::Written => (written_kind, equal_ds.map(Resource::DepthStencil)),
            };
            let set = set.map(|r| self.b.targets.sampling_set(r));
            let pipeline = self.b.pipelines.get(&host_pipeline(h, kind))?;
            self.bind(pipeline, set);
            self.host_draw(draw, *piece, *rect, flags, strict);
        }
        self.close_in_block(true);
        // SAFETY: closes the block `begin_host_block` opened.
        unsafe { device.cmd_end_rendering(self.cmd) };
        self.rest_all();
        Ok(())
    }

    /// `draws` with each `AtDepth` piece of a cavity's inside (a mesh drawn
    /// with its front faces culled) cut to where it can be visible
    /// (`CutAway::inside_holes`: the screen rectangles of the openings it
    /// is seen through), merged to at most [`INSIDE_PIECES`] rectangles
    /// within its own; dropped where none is on screen. Exact geometry
    /// shows no back face of the mesh elsewhere, so no pixel changes; the
    /// fragments cut are hidden ones, which on the written path each ran
    /// the fetch where they lay nearer than the host's depth.
    fn cut_insides(
        &mut self,
        draws: Vec<(Draw, Piece, Rect)>,
        cut: &CutAway,
    ) -> Vec<(Draw, Piece, Rect)> {
        if cut.is_empty() {
            return draws;
        }
        let scene = self.b.scene;
        let mut out = Vec::with_capacity(draws.len());
        for (d, piece, rect) in draws {
            let boxes = match (&d.geometry, piece, d.cull) {
                (Geometry::Mesh(c), Piece::AtDepth, Cull::Front) => {
                    cut.inside_holes(*c, &scene.bounds, &scene.camera)
                }
                _ => None,
            };
            let Some(boxes) = boxes else {
                out.push((d, piece, rect));
                continue;
            };
            let seen: Vec<Rect> = self
                .screen_rects(&boxes)
                .map(|r| r.intersect(&rect))
                .filter(|r| !r.is_empty())
                .collect();
            let seen = tie_zones::merge(seen, INSIDE_PIECES);
            let kept: u64 = seen.iter().map(Rect::area).sum();
            self.stats.counts.shade_insides_cut_pixels += rect.area().saturating_sub(kept);
            out.extend(seen.into_iter().map(|r| (d.clone(), piece, r)));
        }
        out
    }

    /// The non-empty screen rectangles of world `boxes` under the current
    /// camera (clipped to its near plane, a pixel of margin).
    fn screen_rects<'s>(&'s self, boxes: &'s [Aabb]) -> impl Iterator<Item = Rect> + 's {
        let scene = self.b.scene;
        let (w, h) = (self.b.desc.width, self.b.desc.height);
        let (view, proj, near) = (scene.cam.view, scene.cam.proj, scene.camera.near);
        boxes
            .iter()
            .map(move |b| bounds_rect(view, proj, near, std::slice::from_ref(b), w, h))
            .filter(|r| !r.is_empty())
    }

    /// `draws` with each `AtDepth` piece drawn with its back faces culled,
    /// of a mesh with cutter sets in `cut` (`plan::cut_away`: the only
    /// positive literal of a product), split by the set that saves the
    /// most (`cut_away::split`: free pixels, less `cut_away::PIECE_PIXELS`
    /// per added draw): `WrittenUncut` outside the screen rectangles of
    /// its front faces inside the set's meshes (`CutAway::holes`), none of
    /// its front faces nearer than
    /// the output depth there, and `AtDepth` over them (to be drawn
    /// `Written`); kept whole where no split saves anything. The pieces of
    /// one mesh are disjoint, so their order among themselves does not
    /// matter; they take the mesh's place in plan order. With the draws and
    /// triangles the splits add; `None` where nothing was split.
    fn split_uncut(
        &self,
        draws: &[(Draw, Piece, Rect)],
        cut: &CutAway,
    ) -> Option<(Vec<(Draw, Piece, Rect)>, u64, u64)> {
        if cut.is_empty() {
            return None;
        }
        let mut out = Vec::with_capacity(draws.len());
        let (mut extra, mut extra_triangles) = (0, 0);
        for (d, piece, rect) in draws.iter().cloned() {
            let m = match (&d.geometry, piece, d.cull) {
                (Geometry::Mesh(m), Piece::AtDepth, Cull::Back) => *m,
                _ => {
                    out.push((d, piece, rect));
                    continue;
                }
            };
            let scene = self.b.scene;
            let triangles = scene.ranges[m as usize].1 as usize / 3;
            let cap = cut_away::piece_cap(triangles);
            // Where a cutter can hold a front face of the mesh: the screen
            // rectangles of the world boxes of those faces inside its box
            // (`CutAway::holes`).
            let camera = Some(&scene.camera);
            let holes = |c: MeshId| {
                let boxes = cut.holes(m, c, &scene.bounds, camera);
                self.screen_rects(&boxes).collect::<Vec<_>>()
            };
            let best = cut
                .cutters(m)
                .iter()
                .filter_map(|set| {
                    let holes: Vec<Rect> = set.iter().flat_map(|&c| holes(c)).collect();
                    cut_away::split(rect, &holes, cap, cut_away::PIECE_PIXELS)
                })
                .max_by_key(|(free, fetched)| {
                    let area: u64 = free.iter().map(Rect::area).sum();
                    let added = (free.len() + fetched.len()) as u64 - 1;
                    area as i64 - (added * cut_away::PIECE_PIXELS) as i64
                });
            match best {
                Some((free, fetched)) => {
                    let added = (free.len() + fetched.len()) as u64 - 1;
                    extra += added;
                    extra_triangles += added * triangles as u64;
                    out.extend(
                        free.into_iter()
                            .map(|r| (d.clone(), Piece::WrittenUncut, r)),
                    );
                    out.extend(fetched.into_iter().map(|r| (d.clone(), Piece::AtDepth, r)));
                }
                None => out.push((d, piece, rect)),
            }
        }
        out.iter()
            .any(|(_, p, _)| *p == Piece::WrittenUncut)
            .then_some((out, extra, extra_triangles))
    }

    /// The depth merge before the depth-equal draws: over their scissors, the
    /// output depth-stencil `ds`'s depth written into the host's depth where it
    /// is nearer (the host's strict test; far pixels discarded), so that a
    /// plain depth-`EQUAL` test against the host's depth keeps a face's
    /// fragments where it is the visible one and the CSG is in front. One
    /// full-screen draw with no colour written (`DepthFromTextureHost`);
    /// none when every depth-equal piece writes its own depth.
    fn host_merge(
        &mut self,
        h: &HostShade,
        ds: Ds,
        draws: &[(Draw, Piece, Rect)],
        flags: u32,
    ) -> Result<(), VkError> {
        let mut equal = draws
            .iter()
            .filter(|(_, piece, _)| matches!(piece, Piece::AtDepth | Piece::Direct));
        let rect = equal.clone().fold(Rect::EMPTY, |a, (_, _, r)| a.union(r));
        let Some((first, _, _)) = equal.next().filter(|_| !rect.is_empty()) else {
            return Ok(());
        };
        let merge = Draw {
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: None,
            cull: Cull::None,
            ..first.clone()
        };
        self.set_state(Some(&merge), rect);
        let kind = FragmentKind::DepthFromTextureHost;
        let pipeline = self.b.pipelines.get(&host_pipeline(h, kind))?;
        let set = self.b.targets.sampling_set(Resource::DepthStencil(ds));
        self.bind(pipeline, Some(set));
        let pc = PushConstants {
            mvp: Self::fullscreen_matrix(0.0),
            flags,
            snap: self.b.snap,
            ..Default::default()
        };
        self.quad_pass(kind, &pc, rect.area());
        Ok(())
    }

    /// Opens a rendering block on the host's attachments, keeping their contents.
    fn begin_host_block(&mut self, h: &HostShade) {
        let color = [vk::RenderingAttachmentInfo::default()
            .image_view(h.color.0)
            .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::LOAD)
            .store_op(vk::AttachmentStoreOp::STORE)];
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(h.depth.0)
            .image_layout(vk::ImageLayout::DEPTH_STENCIL_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::LOAD)
            .store_op(vk::AttachmentStoreOp::STORE);
        let ri = vk::RenderingInfo::default()
            .render_area(conv::rect2d(Rect::full(
                self.b.desc.width,
                self.b.desc.height,
            )))
            .layer_count(1)
            .color_attachments(&color)
            .depth_attachment(&depth);
        // SAFETY: outside rendering (ended above); the host's views are of the
        // embedder's size, in the layouts `Embedder::record`'s contract names.
        unsafe { self.b.device.cmd_begin_rendering(self.cmd, &ri) };
        self.stats.counts.render_passes += 1;
    }

    /// One shade draw of one mesh into the host's attachments: with the tie
    /// rule (`Piece::Rule`, `ShadeNearDepthHost`: the visible depth written),
    /// at the output depth (depth-`EQUAL` against the merged depth, none
    /// written), or at the output depth with no merge (`Piece::Written`: the
    /// host's test with equality, the raster depth of the fragments the shader
    /// keeps written).
    /// `strict`: `LESS` where the piece would test `LESS_OR_EQUAL`
    /// ([`insides_last`]).
    fn host_draw(&mut self, draw: &Draw, piece: Piece, scissor: Rect, flags: u32, strict: bool) {
        let (m, eps) = match (&draw.geometry, &draw.fragment) {
            (Geometry::Mesh(m), Fragment::ShadeNearDepth { eps, .. }) => (*m, *eps),
            _ => panic!("final_shade selects ShadeNearDepth draws of one mesh"),
        };
        // Mirrored for reversed Z. The rule's fragments write the visible
        // depth where it is nearer than or equal to the host's (the host's
        // depth there may be the merge's, the same value), and so do the
        // written pieces' (their raster depth, the visible one, or discarded);
        // the depth-equal draws after a merge test the merged depth and write
        // none. No stencil; the culling of the standalone frame's draw.
        let rule = piece == Piece::Rule;
        let written = matches!(
            piece,
            Piece::Rule | Piece::Written | Piece::WrittenDirect | Piece::WrittenUncut
        );
        let depth = match written {
            true => DepthState {
                compare: match strict {
                    true => CompareOp::Less,
                    false => CompareOp::LessOrEqual,
                },
                write: true,
            },
            false => DepthState {
                compare: CompareOp::Equal,
                write: false,
            },
        };
        let host = Draw {
            depth,
            stencil: None,
            ..draw.clone()
        };
        self.set_state(Some(&host), scissor);
        let scene = self.b.scene;
        let c = scene.colors[m as usize].map(|v| v as f32 / 255.0);
        self.push(&PushConstants {
            // The tolerance travels in the colour's alpha, as in the plan's draw.
            color: [c[0], c[1], c[2], eps],
            prim: m + 1,
            flags,
            snap: self.b.snap,
            ..Default::default()
        });
        let (first, count) = scene.ranges[m as usize];
        // Inside the host block with the pipeline bound; every host program
        // shades (reads the interpolated outputs).
        self.draw_corners(true, first, count);
        let c = &mut self.stats.counts;
        c.draws += 1;
        c.mesh_draws += 1;
        c.mesh_pixels += scissor.area();
        c.triangles += count as u64 / 3;
        match rule {
            true => {
                c.shade_rule_draws += 1;
                c.shade_rule_pixels += scissor.area();
            }
            false => c.shade_fixed_draws += 1,
        }
        let direct = matches!(piece, Piece::Direct | Piece::WrittenDirect);
        c.direct_shade_draws += direct as u64;
        let written = matches!(
            piece,
            Piece::Written | Piece::WrittenDirect | Piece::WrittenUncut
        );
        c.shade_written_draws += written as u64;
        if piece == Piece::WrittenUncut {
            c.shade_uncut_draws += 1;
            c.shade_uncut_pixels += scissor.area();
        }
        if piece == Piece::Written {
            c.shade_written_fetch_pixels += scissor.area();
        }
        c.shade_culled_draws += (draw.cull != Cull::None) as u64;
        if let Some(i) = self.pass {
            self.stats.per_pass[i].draws += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(x0: u32, x1: u32) -> Rect {
        Rect {
            x0,
            y0: 0,
            x1,
            y1: 10,
        }
    }

    #[test]
    fn insides_go_last_in_reverse_only_where_no_earlier_face_meets_them() {
        let hole = |x0, x1| (Cull::Front, Piece::Written, r(x0, x1));
        let block = (Cull::Back, Piece::Written, r(0, 100));
        let free = (Cull::Back, Piece::WrittenUncut, r(0, 100));
        // Two holes before the block (plan order): the block and its free
        // part first, then the holes last to first, strict.
        let p = [hole(10, 20), hole(30, 40), block, free];
        assert_eq!(
            insides_last(&p),
            Some(vec![(2, false), (3, false), (1, true), (0, true)])
        );
        // A solid's face before a hole it meets would lose the tie it wins in
        // plan order: kept as it is.
        assert_eq!(insides_last(&[block, hole(10, 20)]), None);
        // One it does not meet is fine.
        let away = (Cull::Back, Piece::Written, r(50, 60));
        assert_eq!(
            insides_last(&[away, hole(10, 20), block]),
            Some(vec![(0, false), (2, false), (1, true)])
        );
        // No inside, a rule piece or a merge (depth-equal pieces): nothing to do.
        assert_eq!(insides_last(&[block, free]), None);
        let rule = (Cull::Front, Piece::Rule, r(10, 20));
        assert_eq!(insides_last(&[hole(10, 20), rule, block]), None);
        let merged = (Cull::Front, Piece::AtDepth, r(10, 20));
        assert_eq!(
            insides_last(&[merged, (Cull::Back, Piece::AtDepth, r(0, 100))]),
            None
        );
    }

    /// The plan builders' shade draw of mesh `m`.
    fn shade(m: u32, tex: Tex, ds: u8) -> Step {
        let mut steps =
            crate::plan::shade_near_depth(&[m], ds, tex, None, &crate::plan::VisibleSides::none());
        steps.pop().expect("a pass, a copy and the draw")
    }

    fn plan(steps: Vec<Step>) -> Plan {
        Plan {
            algo: "t".into(),
            depth_stencils: 2,
            textures: 2,
            stencil_bits: 0,
            output_ds: 1,
            steps,
        }
    }

    #[test]
    fn the_final_shade_is_the_copy_and_the_shade_draws_after_it() {
        let copy = Step::CopyDepthToTexture { ds: 1, dst: 1 };
        let p = plan(vec![
            Step::Pass("shade".into()),
            copy.clone(),
            shade(2, 1, 1),
            shade(1, 1, 1),
            shade(0, 1, 1),
        ]);
        assert_eq!(final_shade(&p), Some(3));
        // Built by the plan builders: every GPU algorithm but blister-paper.
        let p = plan(crate::plan::shade_near_depth(
            &[0, 1],
            1,
            1,
            None,
            &crate::plan::VisibleSides::none(),
        ));
        assert_eq!(final_shade(&p), Some(2));
    }

    /// Whether SPIR-V `words` call GLSL.std.450 `Pow` (instruction 26): the
    /// sRGB decode's, the only `pow` of the host shaders.
    fn calls_pow(spv: &[u8]) -> bool {
        let words: Vec<u32> = spv
            .chunks_exact(4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
            .collect();
        let mut i = 5; // after the header
        let mut found = false;
        while i < words.len() {
            let (count, opcode) = ((words[i] >> 16) as usize, words[i] & 0xffff);
            // OpExtInst: type, result, set, instruction, operands.
            found |= opcode == 12 && words.get(i + 4) == Some(&26);
            i += count.max(1);
        }
        found
    }

    #[test]
    fn only_the_srgb_variants_decode() {
        // lavapipe computes both sides of a flag's branch for every fragment:
        // a UNORM or float host must get a variant with no decode at all.
        macro_rules! spv {
            ($f:literal) => {
                include_bytes!(concat!(env!("OUT_DIR"), "/", $f, ".spv")).as_slice()
            };
        }
        for (name, plain, srgb) in [
            (
                "shade_near_depth",
                spv!("shade_near_depth.frag.host"),
                spv!("shade_near_depth.frag.host_srgb"),
            ),
            (
                "shade_at_depth",
                spv!("shade_at_depth.frag.host"),
                spv!("shade_at_depth.frag.host_srgb"),
            ),
            (
                "shade",
                spv!("shade.frag.host"),
                spv!("shade.frag.host_srgb"),
            ),
            (
                "composite",
                spv!("composite.frag"),
                spv!("composite.frag.host_srgb"),
            ),
        ] {
            assert!(!calls_pow(plain), "{name}'s plain variant decodes sRGB");
            assert!(calls_pow(srgb), "{name}'s _SRGB variant does not decode");
        }
    }

    /// `blister-paper` keeps its peel's depth in the peel's `out` texture;
    /// every other GPU algorithm colours in its final shade, and a plan where
    /// anything else writes that texture has none.
    #[test]
    fn only_a_plan_coloured_by_its_peel_has_a_peel_depth() {
        use crate::plan::{Algo, Prepared};
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
        let opts = crate::scene::LoadOptions::default();
        let scene = crate::scene::load(&dir.join("interference.toml"), &opts).unwrap();
        let prep = Prepared::new(&scene).unwrap();
        for algo in Algo::ALL.into_iter().filter(|a| *a != Algo::Reference) {
            let p = crate::plan::build(algo, &prep).unwrap();
            let depth = peel_depth(&p);
            match algo {
                Algo::BlisterPaper => assert_eq!(depth, Some(1), "{p:?}"),
                _ => assert_eq!(depth, None, "{algo:?}"),
            }
        }
        let mut p = crate::plan::build(Algo::BlisterPaper, &prep).unwrap();
        let Some(Step::Loop(l)) = p.steps.iter_mut().find(|s| matches!(s, Step::Loop(_))) else {
            panic!("blister-paper peels in a loop");
        };
        l.tail.push(Step::CopyDepthToTexture { ds: 0, dst: 1 });
        assert_eq!(peel_depth(&p), None);
    }

    /// The pieces write their own depth where their fragments are fewer than
    /// the merge's pixels: a few meshes on a large screen rectangle (one
    /// drawn whole counting twice), not many subtracted meshes inside one
    /// solid's rectangle, whose hidden back faces the merge turns away early.
    #[test]
    fn the_pieces_write_their_depth_where_they_cost_fewer_pixels_than_the_merge() {
        let r = |x0, y0, x1, y1| Rect { x0, y0, x1, y1 };
        let p = |rect, cull| Priced {
            rect,
            cull,
            direct: false,
        };
        // One solid: its pixels once (or twice) against its rectangle.
        assert!(writes_depth(&[p(r(0, 0, 100, 100), Cull::Back)]));
        assert!(writes_depth(&[p(r(0, 0, 100, 100), Cull::None)]));
        // Two apart: the merge's bounds hold the gap too.
        let apart = [
            p(r(0, 0, 10, 10), Cull::Back),
            p(r(90, 90, 100, 100), Cull::Front),
        ];
        assert!(writes_depth(&apart));
        // A block and twelve holes inside its rectangle (`drilled_block`);
        // twice as many holes, each one's inside behind the block, cost more
        // shaded fragments than the merge's pixels.
        let block = p(r(0, 40, 200, 180), Cull::Back);
        let holes = |n: u32| (0..n).map(move |i| p(r(5 * i, 50, 5 * i + 35, 120), Cull::Front));
        let drilled: Vec<Priced> = std::iter::once(block).chain(holes(12)).collect();
        assert!(writes_depth(&drilled));
        let drilled: Vec<Priced> = std::iter::once(block).chain(holes(24)).collect();
        assert!(!writes_depth(&drilled));
        // Exactly 4 fragments per merge pixel: written (ties go to no merge).
        let edge = [
            p(r(0, 0, 100, 100), Cull::Front),
            p(r(0, 0, 100, 100), Cull::Front),
        ];
        assert!(writes_depth(&edge));
        let over = [edge[0], edge[1], p(r(0, 0, 1, 100), Cull::Back)];
        assert!(!writes_depth(&over));
        // A direct piece costs nothing: the merge's rectangle grows, the
        // written pieces' fragments do not.
        let direct = Priced {
            rect: r(100, 0, 200, 100),
            cull: Cull::Back,
            direct: true,
        };
        assert!(writes_depth(&[over[0], over[1], over[2], direct]));
    }

    #[test]
    fn plans_ending_otherwise_have_no_final_shade() {
        let copy = Step::CopyDepthToTexture { ds: 1, dst: 1 };
        // Another depth-stencil, another texture, a step after, no copy.
        for steps in [
            vec![copy.clone(), shade(0, 1, 0)],
            vec![copy.clone(), shade(1, 0, 1)],
            vec![copy.clone(), shade(0, 1, 1), Step::Pass("x".into())],
            vec![shade(0, 1, 1)],
            vec![copy.clone()],
            vec![],
        ] {
            assert_eq!(final_shade(&plan(steps.clone())), None, "{steps:?}");
        }
    }
}
