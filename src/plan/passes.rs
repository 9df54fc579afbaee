//! The plan passes: the fixed pipeline that turns an algorithm's plan into
//! what the executor records, under a device profile and a view. Each pass is a
//! pure function of the plan, the scene's geometry, the camera and the
//! profile's facts ([`PassFacts`]); the executor runs these same functions
//! (kept per plan and camera, `plan::memo`) and records their answers, and
//! `peeltrim plan --device-profile P` prints them ([`lower_plan`]). In order:
//!
//! 1. **scissors**: each mesh's screen rectangle, its world box clipped to the
//!    near plane and projected ([`scissor::bounds_rect`]); a draw's scissor is
//!    the union of its meshes' ([`RectUnions::scissor`]);
//! 2. **tie-free decisions** ([`tie_free`], `plan::tie_free`): which tolerant
//!    parity, clip, peel and shade draws cannot meet the tie rule of
//!    coincident faces (Rossignac & Wu, §4: the ε-tolerant depth comparisons)
//!    under this camera and snapping, and so run as plain depth tests; the
//!    final shade's depth-equal draws only where the profile's rasterizer
//!    interpolates depth from unsnapped vertices;
//! 3. **direct shades** (`plan::direct_shade`): a one-primitive product is
//!    shaded in its own visible-surface draw, and the final shade skips it;
//! 4. **lowering** (`plan::lower`): each draw becomes what is recorded — off
//!    screen, dropped, a direct shade, fixed-function, tie-depth, or the tie
//!    rule (over tie zones only, `plan::tie_zones`);
//! 5. **reach** ([`reach`], `plan::reach`): each clear and copy cut to the
//!    pixels later steps read of it, as the draws are lowered. It also
//!    depends on what earlier frames left in the output images, so the
//!    executor runs it per recording with the outputs' state, and the
//!    printout shows it for the first frame and for the frames after.

use std::borrow::Cow;

use glam::DMat4;

use super::direct_shade::DirectShades;
use super::lower::{lower, Lowering, RecordedDraw};
use super::reach::{self as reach_of, ClearNeed, FrameReach, KeptImages};
use super::scissor::{self, Rect, RectUnions};
use super::tie_free::{TieBand, TieFree};
use super::visible_ties::visible_ties;
use super::{Plan, Step};
use crate::geom::ties::TieGaps;
use crate::scene::camera::DepthConvention;
use crate::scene::{Aabb, Camera, Mesh, Scene};

/// What the passes need of a device profile (`vk::DeviceProfile`) and the
/// depth set-up: the facts that change what is recorded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PassFacts {
    /// Subpixel bits the rasterizer snaps vertices to (the tie band's width).
    pub subpixel_bits: u32,
    /// The final shade may draw tie-free meshes as depth-equal draws: the
    /// raster depth is as exact as the tie rule's plane depth (a rasterizer
    /// that interpolates depth from unsnapped vertices, on D32S8).
    pub depth_equal_shades: bool,
    /// Parity and clip draws that may meet a tie run the rule as their depth
    /// test (`Fragment::TieDepth`): the depth image holds the texture's float
    /// (D32S8).
    pub tie_depth: bool,
}

/// Which meshes' faces could meet the tie rule (`geom::ties`), and those of
/// them that may hold a visible point of the solid (`plan::visible_ties`),
/// which the final shade reads.
#[derive(Clone, Debug)]
pub struct SceneTies {
    /// Every mesh's possible tie partners.
    pub ties: TieGaps,
    /// The ties the final shade can see.
    pub shade_ties: TieGaps,
}

impl SceneTies {
    /// The ties of `scene`'s primitives, then its surfaces (the executor's
    /// mesh order).
    pub fn of_scene(scene: &Scene) -> SceneTies {
        let meshes = scene_meshes(scene);
        let ties = TieGaps::new(&meshes);
        // The solids' union (the opaque shade) and each solid (the layers).
        let mut exprs: Vec<_> = super::union_of_solids(scene).into_iter().collect();
        if scene.solids.len() > 1 {
            exprs.extend(scene.solids.iter().map(|s| s.expr.clone()));
        }
        let shade_ties = visible_ties(&ties, &meshes, &exprs, scene.primitives.len());
        SceneTies { ties, shade_ties }
    }
}

/// `scene`'s meshes in the executor's order: primitives, then surfaces.
pub(crate) fn scene_meshes(scene: &Scene) -> Vec<&Mesh> {
    let prims = scene.primitives.iter().map(|p| &p.mesh);
    prims
        .chain(scene.surfaces.iter().map(|s| &s.mesh))
        .collect()
}

/// The view the passes decide for: the camera and its matrices, the image
/// size and depth convention, and each mesh's world box.
#[derive(Clone, Copy, Debug)]
pub struct View<'a> {
    /// The camera (near plane, projection).
    pub camera: &'a Camera,
    /// World to view.
    pub view: DMat4,
    /// View to clip, in the depth convention of `reversed_z`.
    pub proj: DMat4,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Reversed depth (near = 1).
    pub reversed_z: bool,
    /// Each mesh's world box, in the executor's mesh order.
    pub bounds: &'a [Aabb],
}

impl View<'_> {
    /// Pass 1: each mesh's screen rectangle.
    pub fn mesh_rects(&self) -> Vec<Rect> {
        let (w, h) = (self.width, self.height);
        let (view, proj, near) = (self.view, self.proj, self.camera.near);
        let project =
            |b: &Aabb| scissor::bounds_rect(view, proj, near, std::slice::from_ref(b), w, h);
        self.bounds.iter().map(project).collect()
    }
}

/// Pass 2: `plan`'s tie-free decisions under `view` on a device with `facts`
/// (`plan::tie_free`): every final shade keeps the tie rule unless
/// `facts.depth_equal_shades`.
pub fn tie_free(plan: &Plan, view: &View, ties: &SceneTies, facts: &PassFacts) -> TieFree {
    let all = view
        .bounds
        .iter()
        .fold(crate::geom::bounds(&[]), |a, b| Aabb {
            min: a.min.min(b.min),
            max: a.max.max(b.max),
        });
    let band = TieBand::new(
        view.camera,
        view.width,
        view.height,
        facts.subpixel_bits,
        view.reversed_z,
        &all,
    );
    let (w, h) = (view.width, view.height);
    let (v, p, near) = (view.view, view.proj, view.camera.near);
    let project = |b: &Aabb| scissor::bounds_rect(v, p, near, std::slice::from_ref(b), w, h);
    let decided = TieFree::new(&ties.ties, &ties.shade_ties, &band, plan, &project);
    let decided = match facts.depth_equal_shades {
        true => decided,
        false => decided.keep_shade_rule(),
    };
    decided.with_tie_depth(facts.tie_depth)
}

/// Pass 3: the one-primitive products of `steps` shaded in their direct draws.
pub fn direct_shades(steps: &[&Step], output_ds: u8, ties: &TieFree) -> DirectShades {
    DirectShades::decide(steps, output_ds, |m, eps| ties.shade_depth_equal(m, eps))
}

/// Pass 5: what the clears and copies of a recording of `steps` (loops
/// unrolled) reach, its draws lowered with `ties` (a texture only tie-free
/// draws sampled is read by nobody), for outputs that hold `now` before it;
/// and what it assumes they hold (`plan::reach::recording_reach`).
pub fn reach(
    steps: &[&Step],
    ties: &TieFree,
    scissor: impl Fn(&super::Scissor) -> Rect,
    images: reach_of::Images<'_>,
    now: &KeptImages,
) -> (FrameReach, KeptImages) {
    let lowered: Vec<Step> = steps.iter().map(|s| ties.lowered(s)).collect();
    let lowered: Vec<&Step> = lowered.iter().collect();
    reach_of::recording_reach(&lowered, scissor, images, now)
}

/// The kind of a recorded step in the passes' printout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepKind {
    /// A draw.
    Draw,
    /// A clear of one image.
    Clear,
    /// A copy.
    Copy,
}

/// One draw, clear or copy of a plan as the passes lower it: where it is in
/// the plan and what is recorded for it.
#[derive(Clone, Debug, PartialEq)]
pub struct LoweredDraw {
    /// A draw, a clear (one per image cleared) or a copy.
    pub kind: StepKind,
    /// Index among the plan's steps of its kind, loop bodies once, in order.
    pub index: usize,
    /// The plan's pass the step belongs to (its last `Step::Pass`).
    pub pass: String,
    /// What is recorded, in words.
    pub recorded: String,
}

/// Every pass on `plan` for `scene` at `width`×`height` on a device with
/// `facts`: each draw's lowering and each clear's and copy's reach, loop
/// bodies listed (and run) once. The printout of `peeltrim plan
/// --device-profile`. Reach is shown for the first frame and for the frames
/// after it, whose outputs hold what the one before left.
pub fn lower_plan(
    plan: &Plan,
    scene: &Scene,
    width: u32,
    height: u32,
    reversed_z: bool,
    facts: &PassFacts,
) -> Vec<LoweredDraw> {
    let convention = match reversed_z {
        true => DepthConvention::Reversed,
        false => DepthConvention::Standard,
    };
    let camera = &scene.camera;
    let bounds: Vec<Aabb> = scene_meshes(scene)
        .iter()
        .map(|m| crate::geom::bounds(&m.positions))
        .collect();
    let view = View {
        camera,
        view: camera.view(),
        proj: camera.proj(width as f64 / height as f64, convention),
        width,
        height,
        reversed_z,
        bounds: &bounds,
    };
    let rects = RectUnions::new(&view.mesh_rects());
    let ties = tie_free(plan, &view, &SceneTies::of_scene(scene), facts);
    let mut flat = Vec::new();
    for s in &plan.steps {
        flatten(s, &mut flat);
    }
    let direct = direct_shades(&flat, plan.output_ds, &ties);
    let outputs = reach_of::outputs(plan.output_ds, false);
    let images = reach_of::Images {
        outputs: &outputs,
        normals: false,
        size: (width, height),
    };
    let scissor = |s: &super::Scissor| rects.scissor(s, width, height);
    let (first, _) = reach(&flat, &ties, scissor, images, &KeptImages::new());
    let (later, _) = reach(&flat, &ties, scissor, images, &first.kept);
    let (mut clears, mut copies, mut draws) = (0, 0, 0);
    let mut out = Vec::new();
    let mut pass = String::new();
    let push = |kind, index, recorded, pass: &String, out: &mut Vec<LoweredDraw>| {
        out.push(LoweredDraw {
            kind,
            index,
            pass: pass.clone(),
            recorded,
        });
    };
    for s in flat {
        match s {
            Step::Pass(p) => pass = p.to_string(),
            Step::Draw(d) => {
                let rect = rects.scissor(&d.scissor, width, height);
                let recorded = describe(&lower(d, false, rect, &ties, &direct));
                push(StepKind::Draw, draws, recorded, &pass, &mut out);
                draws += 1;
            }
            Step::Clear(c) => {
                for r in reach_of::cleared(c, false).iter() {
                    let what = format!(
                        "{r:?} reaches {} (later frames: {})",
                        clear_reach(first.clears[clears], width, height),
                        clear_reach(later.clears[clears], width, height)
                    );
                    push(StepKind::Clear, clears, what, &pass, &mut out);
                    clears += 1;
                }
            }
            Step::CopyTexture { .. }
            | Step::CopyDepthBound { .. }
            | Step::CopyDepthToTexture { .. } => {
                let what = format!(
                    "{} reaches {}",
                    super::print::copy_words(s),
                    rect_words(first.copies[copies], width, height)
                );
                push(StepKind::Copy, copies, what, &pass, &mut out);
                copies += 1;
            }
            Step::Loop(_) => {}
        }
    }
    out
}

/// A clear's reach in words.
fn clear_reach(need: ClearNeed, width: u32, height: u32) -> String {
    match need {
        ClearNeed::Held => "nothing, held by an earlier clear to the same value".into(),
        ClearNeed::Reach(r) => rect_words(r, width, height),
    }
}

/// A reached region in words.
fn rect_words(r: Rect, width: u32, height: u32) -> String {
    match r {
        _ if r.is_empty() => "nothing".into(),
        _ if r == Rect::full(width, height) => "the whole image".into(),
        r => format!(
            "x {}..{}, y {}..{} ({:.0}% of the image)",
            r.x0,
            r.x1,
            r.y0,
            r.y1,
            100.0 * r.area() as f64 / (width as f64 * height as f64)
        ),
    }
}

/// `s` and the steps of its loop bodies, once each, in order.
fn flatten<'a>(s: &'a Step, out: &mut Vec<&'a Step>) {
    match s {
        Step::Loop(l) => l.head.iter().chain(&l.tail).for_each(|b| flatten(b, out)),
        other => out.push(other),
    }
}

/// What is recorded for a lowered draw, in words.
pub(crate) fn describe(d: &RecordedDraw) -> String {
    let draw = |d: &Cow<super::Draw>| format!("{:?} {:?}", d.fragment, d.depth.compare);
    match d {
        RecordedDraw::OffScreen => "nothing (off screen)".into(),
        RecordedDraw::Dropped => "nothing (its product is shaded by its direct draw)".into(),
        RecordedDraw::One(d, how) => {
            let why = match how {
                Lowering::Planned => "as planned",
                Lowering::TieRule => "tie rule",
                Lowering::DirectShade => "direct shade",
                Lowering::FixedFunction { shade: true } => "depth-equal shade",
                Lowering::FixedFunction { shade: false } => "tie-free: plain depth test",
                Lowering::TieDepth => "tie rule as the depth test",
                Lowering::ShadeRule { culled: true } => {
                    "shade with the tie rule, hidden faces culled"
                }
                Lowering::ShadeRule { culled: false } => "shade with the tie rule",
            };
            format!("{why}: {}", draw(d))
        }
        RecordedDraw::Zoned { rule, zones, .. } => format!(
            "tie rule in {} zone(s), depth-equal elsewhere: {}",
            zones.len(),
            draw(rule)
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plan::{build, Algo, Prepared};
    use crate::scene::fixtures::block_minus_spheres;

    const CPU: PassFacts = PassFacts {
        subpixel_bits: 8,
        depth_equal_shades: true,
        tie_depth: true,
    };
    const HARDWARE: PassFacts = PassFacts {
        depth_equal_shades: false,
        ..CPU
    };

    fn lowered(algo: Algo, facts: &PassFacts) -> Vec<LoweredDraw> {
        let scene = block_minus_spheres(4);
        let plan = build(algo, &Prepared::new(&scene).unwrap()).unwrap();
        lower_plan(&plan, &scene, 200, 150, true, facts)
    }

    #[test]
    fn every_draw_of_the_plan_is_lowered_once() {
        let scene = block_minus_spheres(4);
        let plan = build(Algo::Goldfeather, &Prepared::new(&scene).unwrap()).unwrap();
        let mut flat = Vec::new();
        plan.steps.iter().for_each(|s| flatten(s, &mut flat));
        let draws = flat.iter().filter(|s| matches!(s, Step::Draw(_))).count();
        let l = lower_plan(&plan, &scene, 200, 150, true, &CPU);
        let l: Vec<_> = l.iter().filter(|d| d.kind == StepKind::Draw).collect();
        assert_eq!(l.len(), draws);
        assert!(l.iter().enumerate().all(|(i, d)| d.index == i));
    }

    #[test]
    fn only_a_profile_with_unsnapped_depth_gets_depth_equal_shades() {
        for algo in [Algo::Goldfeather, Algo::CstI, Algo::Scs] {
            let cpu = lowered(algo, &CPU);
            let hw = lowered(algo, &HARDWARE);
            assert_eq!(cpu.len(), hw.len(), "{algo}");
            let equal = |l: &[LoweredDraw]| {
                l.iter()
                    .filter(|d| {
                        d.recorded.starts_with("depth-equal shade")
                            || d.recorded.contains("depth-equal elsewhere")
                    })
                    .count()
            };
            assert!(equal(&cpu) > 0, "{algo}: {cpu:#?}");
            assert_eq!(equal(&hw), 0, "{algo}: {hw:#?}");
        }
    }

    #[test]
    fn clears_and_copies_show_their_reach_first_and_later() {
        let l = lowered(Algo::GoldfeatherLayered, &CPU);
        let of = |k| l.iter().filter(move |d: &&LoweredDraw| d.kind == k);
        // The output is cleared whole once; later frames only where the
        // first one drew.
        let out = of(StepKind::Clear)
            .find(|d| d.recorded.starts_with("DepthStencil(0)"))
            .expect("the output's clear");
        assert!(
            out.recorded
                .contains("reaches the whole image (later frames: x "),
            "{out:?}"
        );
        // The layer loop starts its surface image as a copy of the output,
        // cut to the block's rectangle.
        let copy = of(StepKind::Copy)
            .find(|d| d.recorded.starts_with("copy depth-stencil ds0 -> ds1"))
            .expect("the bound's copy");
        assert!(copy.recorded.contains("reaches x "), "{copy:?}");
        assert!(of(StepKind::Draw).count() > 0);
    }

    #[test]
    fn the_spheres_cannot_tie_so_their_parity_draws_are_plain_depth_tests() {
        let l = lowered(Algo::Goldfeather, &HARDWARE);
        assert!(
            l.iter().any(|d| d.recorded.starts_with("tie-free")),
            "{l:#?}"
        );
    }
}
