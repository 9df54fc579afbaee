//! The final shade's depth-equal draws cull the faces that are never visible
//! (`plan::VisibleSides`, `plan::tie_free`), validation on: on a tie-free
//! scene every algorithm's shade culls and its images are those of the
//! unculled shade and match the reference, culling the other side instead
//! loses the surface, a mirrored primitive culls alike; a tie-rule draw keeps
//! both sides where its mesh can win a tie on its hidden faces (a positive
//! primitive's back face on the visible face, its lower index winning), and
//! culls where only lower indices tie with it, changing no pixel.

use peeltrim::plan::{self, Algo, Cull, Fragment, Plan, Prepared, Step};
use peeltrim::scene::Scene;
use peeltrim_cli::output::Images;
use peeltrim_cli::render::{DepthSetup, FrameStats, GpuRenderer};
use peeltrim_reference::compare::{compare, CompareReport};

use crate::algorithms::{load_text, shipped, shipped_with_reference, SIZE};

/// The GPU algorithms whose plans end with the final shade.
fn shaded() -> impl Iterator<Item = Algo> {
    Algo::ALL
        .into_iter()
        .filter(|a| !matches!(a, Algo::Reference | Algo::BlisterPaper))
}

pub(crate) fn frame(scene: &Scene, plan: &Plan) -> (Images, FrameStats) {
    let mut gpu = GpuRenderer::new(scene, crate::setup::device(), DepthSetup::DEFAULT, true)
        .expect("a Vulkan device (lavapipe)");
    let f = gpu
        .frame(plan)
        .unwrap_or_else(|e| panic!("{}: {e}", plan.algo));
    let msgs = gpu.validation_messages();
    assert!(msgs.is_empty(), "{}: validation: {msgs:#?}", plan.algo);
    (f.images, f.stats)
}

/// `plan` with every final-shade draw changed by `f`.
fn with_shade(plan: &Plan, f: impl Fn(&mut plan::Draw, &mut Cull)) -> Plan {
    let mut p = plan.clone();
    for s in &mut p.steps {
        if let Step::Draw(d) = s {
            if let Fragment::ShadeNearDepth {
                mut equal_cull,
                tex,
                eps,
            } = d.fragment
            {
                f(d, &mut equal_cull);
                d.fragment = Fragment::ShadeNearDepth {
                    tex,
                    eps,
                    equal_cull,
                };
            }
        }
    }
    p
}

pub(crate) fn interior(r: &CompareReport) -> (u64, u64) {
    (r.coverage_mismatch_interior, r.prim_mismatch_interior)
}

/// Every algorithm on `scene` (tie-free: every shade draw depth-equal): the
/// shade culls, changes no pixel of the unculled shade, matches the
/// reference, and culling the visible side instead shows in the images.
fn culls_right(scene: &Scene, want_culled: u64) {
    let prep = Prepared::new(scene).expect("prepared");
    let reference = peeltrim_reference::render(scene, SIZE.0, SIZE.1);
    let mut failures = Vec::new();
    for algo in shaded() {
        let built = plan::build(algo, &prep).unwrap_or_else(|e| panic!("{algo}: {e}"));
        let (culled, stats) = frame(scene, &built);
        let c = &stats.exec.counts;
        // Where the profile allows no depth-equal shade every shade draw
        // keeps the rule (and culls alike).
        if crate::setup::depth_equal_shades() {
            assert_eq!(c.shade_rule_draws, 0, "{algo}: tie-free scene: {c:?}");
        }
        // Trickle's shade culls nothing (`plan::trickle`).
        let want = if algo == Algo::Trickle {
            0
        } else {
            want_culled
        };
        assert_eq!(c.shade_culled_draws, want, "{algo}: {c:?}");
        let none = with_shade(&built, |_, cull| *cull = Cull::None);
        let (plain, plain_stats) = frame(scene, &none);
        assert_eq!(plain_stats.exec.counts.shade_culled_draws, 0, "{algo}");
        let same = interior(&compare(&plain, &culled).expect("same size"));
        let r = compare(&reference, &culled).expect("same size");
        let flip = with_shade(&built, |_, cull| {
            *cull = match *cull {
                Cull::Back => Cull::Front,
                Cull::Front => Cull::Back,
                Cull::None => Cull::None,
            }
        });
        let (wrong, _) = frame(scene, &flip);
        let w = compare(&reference, &wrong).expect("same size");
        eprintln!(
            "{algo}: {} culled draws; against the unculled shade {same:?}; reference {:?}; other side culled {:?}",
            c.shade_culled_draws,
            interior(&r),
            interior(&w)
        );
        if same != (0, 0) {
            failures.push(format!("{algo}: the unculled shade differs: {same:?}"));
        }
        if r.coverage_mismatch_interior_frac > 0.001 || r.prim_mismatch_interior_frac > 0.01 {
            failures.push(format!("{algo} against the reference: {r:?}"));
        }
        // The visible faces culled: most of the surface left unshaded. Not
        // Blister's: its peel already wrote the locked face's colour and id,
        // which its shade draws again (it matters only where faces tie).
        let unseen = w.coverage_mismatch_interior_frac + w.prim_mismatch_interior_frac < 0.2;
        if !matches!(algo, Algo::Blister | Algo::Trickle) && unseen {
            failures.push(format!(
                "{algo}: culling the visible side went unseen: {w:?}"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_depth_equal_shade_culls_the_side_never_visible() {
    // A block (positive) minus twelve cylinders (subtracted), no ties.
    culls_right(&shipped("drilled_block"), 13);
}

#[test]
fn a_mirrored_primitive_culls_alike() {
    // Both primitives mirrored (negative scales, one of them twice): their
    // windings are reversed on loading, so front faces stay outward.
    let scene = load_text(
        r##"
name = "mirrored"
[camera]
eye = [2.0, 3.0, 4.0]
target = [0.0, 0.0, 0.0]
fit = true
[[primitive]]
name = "block"
shape = "box"
size = [2.0, 1.0, 1.5]
scale = [-1.0, 1.0, 1.0]
rotate_deg = [0.0, 20.0, 0.0]
color = "#d08040"
[[primitive]]
name = "hole"
shape = "cylinder"
radius = 0.3
height = 3.0
scale = [1.0, -1.0, -1.0]
rotate_deg = [10.0, 0.0, 0.0]
translate = [0.3, 0.0, 0.1]
color = "#4080d0"
[csg]
expr = "block - hole"
"##,
        "mirrored.toml",
    );
    culls_right(&scene, 2);
}

#[test]
fn tie_rule_draws_keep_the_back_face_that_wins_a_tie() {
    // A's back face (z = 1) lies on B's front face; C removes all of A and
    // ends there too. The visible point is B's face, and A, the lowest index
    // with a face there, is its primitive (the tie rule) although A is only
    // ever positive: its shade must not cull its back faces.
    let scene = load_text(
        r##"
name = "back_face_tie"
[camera]
eye = [0.7, 0.9, 6.0]
target = [0.0, 0.0, 0.5]
fit = true
[[primitive]]
name = "A"
shape = "box"
size = [1.0, 1.0, 1.0]
translate = [0.0, 0.0, 1.5]
color = "#d04040"
[[primitive]]
name = "B"
shape = "box"
size = [2.0, 2.0, 1.0]
translate = [0.0, 0.0, 0.5]
color = "#40a040"
[[primitive]]
name = "C"
shape = "box"
size = [1.4, 1.4, 2.0]
translate = [0.0, 0.0, 2.0]
color = "#4060d0"
[csg]
expr = "(A - C) + B"
"##,
        "back_face_tie.toml",
    );
    let prep = Prepared::new(&scene).expect("prepared");
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    // Where the reference shows A (id 1), through B's face.
    let a_pixels = reference.prim.iter().filter(|&&p| p == 1).count() as u64;
    assert!(a_pixels > 500, "A's id shows on {a_pixels} pixels");
    let mut failures = Vec::new();
    for algo in [Algo::Scs, Algo::Goldfeather, Algo::CstI, Algo::Blister] {
        let built = plan::build(algo, &prep).unwrap_or_else(|e| panic!("{algo}: {e}"));
        let (images, stats) = frame(&scene, &built);
        let c = &stats.exec.counts;
        assert!(c.shade_rule_draws > 0, "{algo}: A and B tie: {c:?}");
        let r = compare(&reference, &images).expect("same size");
        // The rule draws culling what the depth-equal ones may: A loses.
        let forced = with_shade(&built, |d, cull| d.cull = *cull);
        let (wrong, _) = frame(&scene, &forced);
        let w = compare(&reference, &wrong).expect("same size");
        eprintln!(
            "{algo}: {c:?}\n  reference {:?}, rule draws culled {:?}",
            interior(&r),
            interior(&w)
        );
        if interior(&r) != (0, 0) {
            failures.push(format!("{algo} against the reference: {r:?}"));
        }
        if w.prim_mismatch_interior < a_pixels / 2 {
            failures.push(format!("{algo}: culled rule draws kept A's id: {w:?}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn tied_meshes_cull_where_only_lower_indices_tie_with_them() {
    // speckle: C fills a half of A that B removes, their faces flush;
    // assembly: the flange flush on the block. A mesh whose tie partners all
    // have lower indices runs no rule at all (`plan::tie_zones`: only the
    // lower index of a pair does in their zone): its depth-equal draw culls.
    let mut failures = Vec::new();
    for name in ["speckle", "assembly"] {
        let (scene, prep, reference) = shipped_with_reference(name);
        for algo in [Algo::Scs, Algo::Goldfeather, Algo::CstI, Algo::Blister] {
            let built = plan::build(algo, &prep).unwrap_or_else(|e| panic!("{algo}: {e}"));
            let (culled, stats) = frame(&scene, &built);
            let c = &stats.exec.counts;
            assert!(c.shade_rule_draws > 0, "{name} {algo}: ties: {c:?}");
            // Every depth-equal draw culls.
            assert!(
                c.shade_culled_draws >= c.shade_fixed_draws,
                "{name} {algo}: a depth-equal draw not culled: {c:?}"
            );
            let none = with_shade(&built, |_, cull| *cull = Cull::None);
            let (plain, plain_stats) = frame(&scene, &none);
            assert_eq!(plain_stats.exec.counts.shade_culled_draws, 0);
            let same = interior(&compare(&plain, &culled).expect("same size"));
            let r = compare(&reference, &culled).expect("same size");
            eprintln!(
                "{name} {algo}: culled {} of {} rule and {} depth-equal draws; against the unculled shade {same:?}; reference {:?}",
                c.shade_culled_draws,
                c.shade_rule_draws,
                c.shade_fixed_draws,
                interior(&r)
            );
            if same != (0, 0) {
                failures.push(format!(
                    "{name} {algo}: the unculled shade differs: {same:?}"
                ));
            }
            if r.coverage_mismatch_interior_frac > 0.001 || r.prim_mismatch_interior_frac > 0.01 {
                failures.push(format!("{name} {algo} against the reference: {r:?}"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
