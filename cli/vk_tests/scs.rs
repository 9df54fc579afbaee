//! SCS (sequenced convex subtraction) on the cases its subtraction sequence and
//! tie rule exist for, against the exact reference (validation on): chains of
//! overlapping cutters (a static sequence for three, rounds for four), and
//! cutters whose faces coincide with each other's and with the block's (one
//! pass in ray order).

use peeltrim::plan::{self, Algo, Fragment, Prepared, Step};
use peeltrim::scene::Scene;

use crate::algorithms::{CST_COV, CST_PRIM, SIZE};

fn load(text: &str) -> Scene {
    crate::algorithms::load_text(text, "scs.toml")
}

/// Renders with scs in every depth set-up; CST's bars (0.05% interior coverage,
/// 0.01% primitive mismatches) and the depth tolerance of the shipped scenes.
/// Returns the loop iterations of the last frame.
pub fn check(scene: &Scene) -> Vec<u32> {
    crate::algorithms::assert_scene(scene, Algo::Scs, CST_COV, CST_PRIM)
}

/// Whether every product of `scene` is drawn by SCS (no Goldfeather fallback).
pub fn all_scs(scene: &Scene) -> bool {
    let prep = Prepared::new(scene).unwrap();
    let p = plan::build(Algo::Scs, &prep).unwrap();
    let passes: Vec<&str> = p
        .steps
        .iter()
        .filter_map(|s| match s {
            Step::Pass(n) => Some(n.as_str()),
            _ => None,
        })
        .collect();
    passes.contains(&"scs-front") && !passes.contains(&"surface")
}

/// The subtraction draws of `scene`'s SCS plan: the cutters' parity draws in
/// order (outside loops) and whether a loop of rounds remains.
fn subtraction(scene: &Scene) -> (Vec<String>, bool) {
    let prep = Prepared::new(scene).unwrap();
    let p = plan::build(Algo::Scs, &prep).unwrap();
    let mut in_subtract = false;
    let mut parity = Vec::new();
    for s in &p.steps {
        match s {
            Step::Pass(n) => in_subtract = n == "subtract",
            Step::Draw(d) if in_subtract && d.cull == peeltrim::plan::Cull::None => {
                let peeltrim::plan::Geometry::Mesh(m) = d.geometry else {
                    panic!("mesh draws only")
                };
                parity.push(scene.primitives[m as usize].name.clone());
            }
            _ => {}
        }
    }
    let rounds = p.loops().next().is_some();
    (parity, rounds)
}

/// A block minus spheres stacked along the view direction, listed deepest
/// first: a ray through the top enters the top sphere, leaves it inside the
/// next, then the next. `n` spheres, each overlapping its neighbours.
fn stacked_spheres(n: usize) -> Scene {
    let names = ["S1", "S2", "S3", "S4"];
    let mut text = String::from(
        r##"
[camera]
eye = [0.3, 4.0, 1.2]
target = [0.0, 0.0, 0.0]
fit = true
[[primitive]]
name = "Block"
shape = "box"
size = [3.0, 1.6, 2.0]
"##,
    );
    let mut expr = String::from("Block");
    for k in (0..n).rev() {
        let y = 0.75 - 0.45 * k as f64;
        let x = [-0.05, 0.0, 0.05, 0.0][k];
        text += &format!(
            "[[primitive]]\nname = \"{}\"\nshape = \"sphere\"\nradius = 0.35\ntranslate = [{x}, {y}, {}]\ncolor = \"#{}\"\n",
            names[k],
            [0.0, 0.05, 0.0, -0.05][k],
            ["d04040", "4060d0", "40a040", "a040a0"][k]
        );
        expr += &format!(" - {}", names[k]);
    }
    text += &format!("[csg]\nexpr = \"{expr}\"\n");
    load(&text)
}

/// Three overlapping spheres in a chain (S1 and S3 apart): a path of
/// overlaps, spelled out as S3 S1 S2 S3 S1 — every chain of it in one
/// sequence with no rounds, S1 and S3 sharing batches.
#[test]
fn a_chain_of_overlapping_cutters_is_one_static_sequence() {
    let scene = stacked_spheres(3);
    assert!(all_scs(&scene));
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    assert!(
        reference.prim.iter().any(|&p| p == 2),
        "the deepest sphere's floor shows"
    );
    let (parity, rounds) = subtraction(&scene);
    assert!(!rounds, "no loop: {parity:?}");
    assert_eq!(parity.len(), 5, "{parity:?}");
    let loops = check(&scene);
    assert!(loops.is_empty(), "{loops:?}");
}

/// Four overlapping spheres in a chain: too many for a static sequence, so
/// rounds, ordered nearest first (the chain moves in the first round; the
/// second finds nothing to move and ends the loop).
#[test]
fn a_longer_chain_takes_rounds_in_ray_order() {
    let scene = stacked_spheres(4);
    assert!(all_scs(&scene));
    let (_, rounds) = subtraction(&scene);
    assert!(rounds);
    let loops = check(&scene);
    assert_eq!(loops.len(), 1, "one loop of rounds: {loops:?}");
    assert!(
        (1..=2).contains(&loops[0]),
        "rounds in ray order: {loops:?}"
    );
}

/// Cutters with coincident faces: K2's exit face (x = -0.5) is K1's entry face
/// (the exit continues into K1, two rounds), and K2's and a pocket's top faces
/// are the block's (flush cuts).
#[test]
fn coincident_cutters_are_tie_correct() {
    let scene = load(
        r##"
[camera]
eye = [3.0, 2.5, 2.0]
target = [0.0, 0.0, 0.0]
fit = true
[[primitive]]
name = "Block"
shape = "box"
size = [4.0, 1.0, 2.0]
[[primitive]]
name = "K1"
shape = "box"
size = [1.0, 0.6, 2.4]
translate = [-1.0, 0.3, 0.0]
color = "#d04040"
[[primitive]]
name = "K2"
shape = "box"
size = [0.8, 0.3, 2.4]
translate = [-0.1, 0.35, 0.0]
color = "#40a040"
[[primitive]]
name = "Flush"
shape = "box"
size = [0.6, 0.5, 0.6]
translate = [1.2, 0.25, 0.0]
color = "#4060d0"
[csg]
expr = "Block - K1 - K2 - Flush"
"##,
    );
    assert!(all_scs(&scene));
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    for p in 2..=4u16 {
        assert!(reference.prim.iter().any(|&q| q == p), "cutter {p} shows");
    }
    // K1 and K2 share a face: apart, K2 on the eye's side, so K2 then K1 in
    // one pass (no rounds), the exit from K2 continuing into K1.
    let (parity, rounds) = subtraction(&scene);
    assert!(!rounds, "{parity:?}");
    let at = |n: &str| parity.iter().position(|p| p == n).unwrap();
    assert!(at("K2") < at("K1"), "{parity:?}");
    let loops = check(&scene);
    assert!(loops.is_empty(), "{loops:?}");
}

/// The eye inside a subtracted sphere (perspective): its parity counted from the
/// near plane is inverted, which the eye correction turns back into membership,
/// so SCS still draws the product (the block's near part scooped out, the
/// sphere's far side showing).
#[test]
fn the_eye_inside_a_subtracted_primitive() {
    let scene = load(
        r##"
[camera]
eye = [0.3, 0.4, 3.0]
target = [0.0, 0.0, 0.0]
fov_y_deg = 60
[[primitive]]
name = "Block"
shape = "box"
size = [2.0, 2.0, 2.0]
[[primitive]]
name = "Bubble"
shape = "sphere"
radius = 2.5
translate = [0.0, 0.0, 3.0]
color = "#d04040"
[csg]
expr = "Block - Bubble"
"##,
    );
    let prep = Prepared::new(&scene).unwrap();
    assert_eq!(prep.eye_inside[..2], [false, true]);
    assert!(all_scs(&scene));
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    assert!(reference.prim.iter().any(|&p| p == 2), "the bubble shows");
    check(&scene);
}

/// Tie-free cutters draw only their front faces in the parity
/// (`Fragment::ParityBeforeExit`), and their exits test depth `Greater`. A
/// cutter that lies wholly in front of `z` (the rod F, which grooves the
/// ball at one end and crosses between the eye and the ball's near side at
/// the other; a cutter outside the ball altogether would be dropped from the
/// product, `plan::scs`) then sets its bit with its
/// front faces and fails its exit's depth test: the exit must clear the bit
/// anyway, or the hole S8, which takes the same bit in the next batch right
/// behind F on screen, would lose its parity there.
#[test]
fn tie_free_cutters_draw_front_faces_and_clear_every_bit() {
    let mut text = String::from(
        r##"
[camera]
eye = [5.0, 5.0, 5.0]
target = [0.0, 0.0, 0.0]
fit = true
[[primitive]]
name = "Ball"
shape = "sphere"
radius = 1.0
[[primitive]]
name = "F"
shape = "cylinder"
radius = 0.05
height = 0.99
rotate_deg = [45.0, 0.0, 0.0]
translate = [0.82, 0.55, 0.55]
color = "#d04040"
"##,
    );
    // Seven holes on the far side, apart from each other, filling F's batch.
    let back = [
        [-0.9, 0.0, 0.0],
        [0.0, -0.9, 0.0],
        [0.0, 0.0, -0.9],
        [-0.64, -0.64, 0.0],
        [-0.64, 0.0, -0.64],
        [0.0, -0.64, -0.64],
        [-0.52, -0.52, -0.52],
    ];
    let mut expr = String::from("Ball - F");
    for (k, c) in back.iter().enumerate() {
        text += &format!(
            "[[primitive]]\nname = \"S{}\"\nshape = \"sphere\"\nradius = 0.15\ntranslate = [{}, {}, {}]\n",
            k + 1,
            c[0],
            c[1],
            c[2]
        );
        expr += &format!(" - S{}", k + 1);
    }
    text += "[[primitive]]\nname = \"S8\"\nshape = \"sphere\"\nradius = 0.25\ntranslate = [0.5, 0.5, 0.5]\ncolor = \"#4060d0\"\n";
    expr += " - S8";
    text += &format!("[csg]\nexpr = \"{expr}\"\n");
    let scene = load(&text);
    assert!(all_scs(&scene));
    // F opens the first batch (bit 0), S8 the second (bit 0 again).
    let (parity, rounds) = subtraction(&scene);
    assert!(!rounds, "{parity:?}");
    let order: Vec<String> = ["F", "S1", "S2", "S3", "S4", "S5", "S6", "S7", "S8"]
        .map(String::from)
        .to_vec();
    assert_eq!(parity, order);
    let prep = Prepared::new(&scene).unwrap();
    let p = plan::build(Algo::Scs, &prep).unwrap();
    let before_exit = p
        .steps
        .iter()
        .filter(|s| matches!(s, Step::Draw(d) if matches!(d.fragment, Fragment::ParityBeforeExit { .. })))
        .count();
    assert_eq!(before_exit, 9);
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    assert!(reference.prim.iter().any(|&q| q == 10), "S8's hole shows");
    assert!(reference.prim.contains(&2), "F's groove shows");
    let tol = crate::algorithms::depth_tolerance(&scene);
    for depth in crate::setup::usable_setups() {
        let (r, stats, depth_ok) =
            crate::algorithms::run_gpu(&scene, Algo::Scs, depth, &reference, tol).unwrap();
        let c = &stats.exec.counts;
        let at = format!("{}: {r:?} {c:?}", depth.name());
        // Every parity draw ran front faces only, as a plain depth test, and
        // so did the ball's back-face clip (`Fragment::BehindThan`).
        assert_eq!((c.tie_free_draws, c.tie_rule_draws), (10, 0), "{at}");
        assert!(r.coverage_mismatch_interior_frac <= CST_COV, "{at}");
        assert!(r.prim_mismatch_interior_frac <= CST_PRIM, "{at}");
        assert!(depth_ok, "depth, {at}");
    }
}

/// Three SCS products side by side: `Block1 − Hole1` (the first: drawn in the
/// output, clipped by its back faces), `Block2 ∩ Ball − Hole2` (two positive
/// primitives: a stencil count of their back faces, one sweep, a full-screen
/// merge) and `Block3 − Hole3` (apart from the first on screen: drawn in the
/// output beside it, clipped by its back faces). With `flush` the
/// holes of blocks 1 and 3 end in the blocks' top and bottom faces
/// (coincident caps: those meshes can tie); else they stick out.
fn three_products(flush: bool) -> Scene {
    let hole = if flush { 1.0 } else { 1.6 };
    load(&format!(
        r##"
[camera]
eye = [1.0, 3.0, 5.0]
target = [0.0, 0.0, 0.0]
fit = true
[[primitive]]
name = "Block1"
shape = "box"
size = [1.2, 1.0, 1.2]
translate = [-1.6, 0.0, 0.0]
[[primitive]]
name = "Hole1"
shape = "cylinder"
radius = 0.3
height = {hole}
translate = [-1.6, 0.0, 0.0]
color = "#d04040"
[[primitive]]
name = "Block2"
shape = "box"
size = [1.2, 1.0, 1.2]
[[primitive]]
name = "Ball"
shape = "sphere"
radius = 0.75
translate = [0.0, 0.35, 0.0]
color = "#40a040"
[[primitive]]
name = "Hole2"
shape = "cylinder"
radius = 0.2
height = 1.6
color = "#4060d0"
[[primitive]]
name = "Block3"
shape = "box"
size = [1.2, 1.0, 1.2]
translate = [1.6, 0.0, 0.0]
[[primitive]]
name = "Hole3"
shape = "cylinder"
radius = 0.3
height = {hole}
translate = [1.6, 0.0, 0.0]
color = "#a040a0"
[csg]
expr = "(Block1 - Hole1) + (Block2 * Ball - Hole2) + (Block3 - Hole3)"
"##
    ))
}

/// The clip by back faces and the merge by back faces take the cheap path
/// where their meshes cannot tie ([`Fragment::BehindThan`] as a plain depth
/// test, [`Fragment::MergeBehind`] with one fetch) and keep the tie rule where
/// they can; both scenes match the reference in every depth set-up.
#[test]
fn back_face_clips_and_merges_are_tie_free_only_where_nothing_ties() {
    use peeltrim::plan::{Fragment, Geometry};
    use peeltrim_cli::render::{DepthSetup, GpuRenderer};
    for flush in [false, true] {
        let scene = three_products(flush);
        assert!(all_scs(&scene));
        let prep = Prepared::new(&scene).unwrap();
        let p = plan::build(Algo::Scs, &prep).unwrap();
        // The tolerant draws, by name of their mesh and kind.
        let mut tolerant = Vec::new();
        let (mut merges, mut clips) = (0, 0);
        for s in &p.steps {
            let Step::Draw(d) = s else { continue };
            let Geometry::Mesh(m) = d.geometry else {
                continue;
            };
            let name = scene.primitives[m as usize].name.clone();
            match d.fragment {
                Fragment::NearerThan { .. } | Fragment::ParityBeforeExit { .. } => {
                    tolerant.push(name)
                }
                Fragment::BehindThan { .. } => {
                    clips += 1;
                    tolerant.push(name)
                }
                Fragment::MergeBehind { .. } => {
                    merges += 1;
                    tolerant.push(name)
                }
                _ => {}
            }
        }
        // Three parity draws and Block1's, Block2's, Ball's and Block3's
        // back-face clips: Block3 − Hole3 is apart from the first product on
        // screen, so it is drawn in the output beside it (`plan::scs::batch`)
        // and needs no merge either.
        assert_eq!((tolerant.len(), clips, merges), (7, 4, 0), "{tolerant:?}");
        let tied = tolerant
            .iter()
            .filter(|n| ["Block1", "Hole1", "Block3", "Hole3"].contains(&n.as_str()))
            .count() as u64;
        assert_eq!(tied, 4, "{tolerant:?}");
        let mut gpu = GpuRenderer::new(&scene, crate::setup::device(), DepthSetup::DEFAULT, true)
            .expect("a Vulkan device (lavapipe)");
        let fast = gpu.frame(&p).expect("a frame");
        let msgs = gpu.validation_messages();
        assert!(msgs.is_empty(), "validation messages: {msgs:#?}");
        let c = &fast.stats.exec.counts;
        let at = format!("flush {flush}: {c:?}");
        if flush {
            // The flush holes and their blocks keep the rule, as the depth
            // test (their partners are coplanar, `Fragment::TieDepth`); the
            // middle product's draws go plain.
            assert_eq!(
                (c.tie_rule_draws, c.tie_depth_draws, c.tie_free_draws),
                (0, tied, 7 - tied),
                "{at}"
            );
        } else {
            assert_eq!((c.tie_rule_draws, c.tie_free_draws), (0, 7), "{at}");
        }
        let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
        for p in 1..=7u16 {
            assert!(
                reference.prim.iter().any(|&q| q == p),
                "flush {flush}: primitive {p} shows"
            );
        }
        check(&scene);
    }
}

/// The L-bracket of `nonconvex_obj` (convex from above) drilled through
/// along the view by two cylinders: through the holes `z` exits the bracket,
/// the clip's count stays 0 and only the reject sweep sets far there. The
/// sweep covers the bracket's footprint (its front faces at the far depth,
/// `plan::scs::footprint_sweep`), not the whole image: without it the holes
/// show the cylinders' exits (the control below), with it the image has 0
/// interior mismatches in every depth set-up, validation on. The candidate
/// texture is read by nobody once the parity and clip draws are tie-free
/// (`plan::reach`): the front and exit draws are depth-only and its clear is
/// dropped.
#[test]
fn the_clip_sweep_covers_the_footprint_of_a_drilled_nonconvex_bracket() {
    let text = r##"
[camera]
eye = [0.9, 0.8, 6.0]
target = [0.8, 0.8, 0.5]
fit = true
[[primitive]]
name = "L"
shape = "mesh"
path = "meshes/l_bracket.obj"
[[primitive]]
name = "H1"
shape = "cylinder"
radius = 0.2
height = 2.0
segments = 24
rotate_deg = [90.0, 0.0, 0.0]
translate = [1.4, 0.25, 0.5]
color = "#d06040"
[[primitive]]
name = "H2"
shape = "cylinder"
radius = 0.2
height = 2.0
segments = 24
rotate_deg = [90.0, 0.0, 0.0]
translate = [0.25, 1.4, 0.5]
color = "#d06040"
[csg]
expr = "L - H1 - H2"
"##;
    let path = crate::setup::scenes_dir().join("drilled_bracket.toml");
    let scene = peeltrim::scene::load_str(
        text,
        &path,
        &peeltrim::scene::LoadOptions { size: Some(SIZE) },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(all_scs(&scene), "the bracket is convex from above");
    let prep = Prepared::new(&scene).unwrap();
    let p = plan::build(Algo::Scs, &prep).unwrap();
    let sweeps = clip_sweeps(&p);
    let swept: Vec<(u32, plan::Cull)> = sweeps.iter().map(|&(_, m, c)| (m, c)).collect();
    assert_eq!(
        swept,
        vec![(0, plan::Cull::Back)],
        "one sweep, over the bracket's front faces (its 8 faces cost less than the holes')"
    );
    let sweeps: Vec<usize> = sweeps.iter().map(|s| s.0).collect();
    // Seen through: the reference shows the background inside the
    // bracket's silhouette, where the sweep rejects `z`.
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    let (w, h) = (SIZE.0 as usize, SIZE.1 as usize);
    let centre = |x: f64, y: f64| {
        let p = glam::DVec3::new(x, y, 0.5);
        let (px, py) = scene.camera.pixel_of(p, SIZE.0, SIZE.1);
        reference.prim[(py as usize).min(h - 1) * w + (px as usize).min(w - 1)]
    };
    assert_eq!(centre(1.4, 0.25), 0, "the background through hole 1");
    assert_eq!(centre(0.25, 1.4), 0, "the background through hole 2");
    // Every parity and clip draw tie-free: the front draw and both exits
    // write no texture.
    let depth_only = assert_swept(&scene, &reference, &p, &sweeps, 3);
    assert!(
        depth_only > 0,
        "some set-up draws the texture writes depth-only"
    );
}

/// Renders plan `p` of `scene` in every depth set-up, three frames each
/// (loop by loop, recorded, replayed: only recordings plan the clears and
/// the texture writes, `plan::reach`), against the reference: 0 interior
/// mismatches, the depth tolerance, `sweeps.len()` footprint passes, no
/// validation message. The control: without the sweeps (steps `sweeps`) the
/// holes keep the cutters' exits. Returns the frames that drew
/// `dead_writes` texture writes depth-only (those with no tie-rule draw).
fn assert_swept(
    scene: &Scene,
    reference: &peeltrim_cli::output::Images,
    p: &plan::Plan,
    sweeps: &[usize],
    dead_writes: u64,
) -> u32 {
    use peeltrim_cli::render::{DepthSetup, GpuRenderer};
    let tol = crate::algorithms::depth_tolerance(scene);
    let mut depth_only = 0;
    for depth in crate::setup::usable_setups() {
        let mut gpu = GpuRenderer::new(scene, crate::setup::device(), depth, true)
            .expect("a Vulkan device (lavapipe)");
        for frame in 0..3 {
            let f = gpu.frame(p).unwrap();
            let r = peeltrim_reference::compare::compare(reference, &f.images).unwrap();
            let c = &f.stats.exec.counts;
            let at = format!("{} frame {frame}: {r:?} {c:?}", depth.name());
            assert_eq!(c.footprint_passes, sweeps.len() as u64, "{at}");
            assert_eq!(r.coverage_mismatch_interior, 0, "{at}");
            assert_eq!(r.prim_mismatch_interior, 0, "{at}");
            let depth_ok = crate::setup::depth_passes(
                r.depth_abs_err_p99_interior <= tol,
                &gpu,
                scene,
                reference,
                &f.images,
            );
            assert!(depth_ok, "depth, {at}");
            if frame > 0 && c.tie_rule_draws == 0 {
                assert_eq!(c.dead_texture_writes, dead_writes, "{at}");
                depth_only += 1;
            }
        }
        let msgs = gpu.validation_messages();
        assert!(msgs.is_empty(), "{}: {msgs:#?}", depth.name());
    }
    let mut unswept = p.clone();
    for &i in sweeps.iter().rev() {
        unswept.steps.remove(i);
    }
    let mut gpu = GpuRenderer::new(
        scene,
        crate::setup::device(),
        crate::setup::usable(DepthSetup::ALL[0]),
        true,
    )
    .expect("a Vulkan device (lavapipe)");
    let frame = gpu.frame(&unswept).unwrap();
    let r = peeltrim_reference::compare::compare(reference, &frame.images).expect("same size");
    assert!(r.coverage_mismatch_interior > 100, "{r:?}");
    assert!(gpu.validation_messages().is_empty());
    depth_only
}

/// The draws of `p` that write the depth texture (fronts and exits): those
/// the executor drops where nothing ties.
fn depth_writes(p: &plan::Plan) -> u64 {
    p.steps
        .iter()
        .filter(|s| matches!(s, Step::Draw(d) if matches!(d.fragment, Fragment::WriteDepth { .. })))
        .count() as u64
}

/// The indices of `p`'s clip sweeps (footprints that clear the count).
fn clip_sweeps(p: &plan::Plan) -> Vec<(usize, u32, plan::Cull)> {
    use peeltrim::plan::{Geometry, StencilOp};
    (0..p.steps.len())
        .filter_map(|i| match &p.steps[i] {
            Step::Draw(d) if d.stencil.is_some_and(|s| s.front.pass == StencilOp::Zero) => {
                match d.geometry {
                    Geometry::Footprint { mesh, .. } => Some((i, mesh, d.cull)),
                    _ => None,
                }
            }
            _ => None,
        })
        .collect()
}

#[test]
fn a_drilled_sphere_is_swept_over_its_cutters_back_faces() {
    // A fine sphere (3968 triangles) drilled along the view and across it
    // by cylinders of 96: the clip's sweep draws the cylinders' back faces
    // where their exits ran, not the sphere's front faces. Seen through the
    // first bore, the background; the bores cross, so some pixels are swept
    // twice.
    let scene = load(
        r##"
[camera]
eye = [0.3, 0.4, 5.0]
target = [0.0, 0.0, 0.0]
fit = true
[[primitive]]
name = "S"
shape = "sphere"
radius = 1.0
segments = 64
rings = 32
[[primitive]]
name = "Along"
shape = "cylinder"
radius = 0.3
height = 3.0
segments = 24
rotate_deg = [90.0, 0.0, 0.0]
[[primitive]]
name = "Across"
shape = "cylinder"
radius = 0.25
height = 3.0
segments = 24
rotate_deg = [0.0, 0.0, 90.0]
translate = [0.0, 0.2, 0.3]
[csg]
expr = "S - Along - Across"
"##,
    );
    assert!(all_scs(&scene));
    let prep = Prepared::new(&scene).unwrap();
    let p = plan::build(Algo::Scs, &prep).unwrap();
    let sweeps = clip_sweeps(&p);
    let meshes: Vec<(u32, plan::Cull)> = sweeps.iter().map(|&(_, m, c)| (m, c)).collect();
    assert_eq!(
        meshes,
        vec![(1, plan::Cull::Front), (2, plan::Cull::Front)],
        "one sweep per cutter, over its back faces"
    );
    let at: Vec<usize> = sweeps.iter().map(|s| s.0).collect();
    // The bores cross: a clump, one of them applied twice. Every front and
    // exit draw writes no texture where nothing ties.
    let writes = depth_writes(&p);
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    assert_swept(&scene, &reference, &p, &at, writes);
}

/// A slab turned 45° about y and drilled by a bore longer than the slab is
/// high, with a ball added beside it: under the fitted camera the slab's
/// world box has a corner in front of the near plane, and the bore reaches
/// far beyond the slab on screen.
fn drilled_turned_slab() -> Scene {
    load(
        r##"
[camera]
eye = [3.0, 2.5, 4.0]
target = [0.0, 0.0, 0.0]
fit = true
[[primitive]]
name = "Slab"
shape = "box"
size = [2.4, 0.6, 2.4]
rotate_deg = [0.0, 45.0, 0.0]
[[primitive]]
name = "Bore"
shape = "cylinder"
radius = 0.25
height = 4.0
segments = 24
translate = [0.3, 0.0, 0.3]
[[primitive]]
name = "Ball"
shape = "sphere"
radius = 0.45
segments = 24
rings = 12
translate = [-1.9, 0.2, 1.1]
[csg]
expr = "Slab - Bore + Ball"
"##,
    )
}

/// `p` with every final shade draw's scissor replaced by `scissor(mesh)`.
fn with_shade_scissors(p: &plan::Plan, scissor: impl Fn(u32) -> plan::Scissor) -> plan::Plan {
    let mut p = p.clone();
    for s in &mut p.steps {
        if let Step::Draw(d) = s {
            if let (Fragment::ShadeNearDepth { .. }, plan::Geometry::Mesh(m)) =
                (&d.fragment, &d.geometry)
            {
                d.scissor = scissor(*m);
            }
        }
    }
    p
}

#[test]
fn the_shade_and_the_output_clears_are_cut_to_the_products() {
    // The final shade draws each mesh within the rectangles of the slab and
    // the ball only (the bore shows inside the slab), and the outputs'
    // clears follow what the frames write: the same images as the shade over
    // each mesh's whole rectangle, over three frames in every depth set-up,
    // with fewer pixels scissored and cleared. Cut to the ball alone, the
    // slab would not be shaded: the test fails then.
    use peeltrim_cli::render::{DepthSetup, GpuRenderer};
    let scene = drilled_turned_slab();
    assert!(all_scs(&scene));
    let prep = Prepared::new(&scene).unwrap();
    let p = plan::build(Algo::Scs, &prep).unwrap();
    let within = |ids: Vec<u32>| {
        move |m| plan::Scissor::Within {
            meshes: vec![m],
            within: ids.clone(),
        }
    };
    assert_eq!(
        p,
        with_shade_scissors(&p, within(vec![0, 2])),
        "cut to slab and ball"
    );
    let whole = with_shade_scissors(&p, |m| plan::Scissor::BoundsOf(vec![m]));
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    let tol = crate::algorithms::depth_tolerance(&scene);
    for depth in crate::setup::usable_setups() {
        let mut cut = GpuRenderer::new(&scene, crate::setup::device(), depth, true)
            .expect("a Vulkan device (lavapipe)");
        let mut old = GpuRenderer::new(&scene, crate::setup::device(), depth, true)
            .expect("a Vulkan device (lavapipe)");
        for frame in 0..3 {
            let (f, o) = (cut.frame(&p).unwrap(), old.frame(&whole).unwrap());
            let (c, oc) = (&f.stats.exec.counts, &o.stats.exec.counts);
            let at = format!("{} frame {frame}: {c:?} / {oc:?}", depth.name());
            matches_reference(&at, &cut, &scene, &reference, &f.images, tol);
            assert!(f.images.color == o.images.color, "colour, {at}");
            assert!(f.images.prim == o.images.prim, "ids, {at}");
            assert!(c.mesh_pixels < oc.mesh_pixels, "{at}");
            if frame > 0 {
                assert!(c.cleared_pixels < oc.cleared_pixels, "{at}");
            }
        }
        for gpu in [&cut, &old] {
            let msgs = gpu.validation_messages();
            assert!(msgs.is_empty(), "{}: {msgs:#?}", depth.name());
        }
    }
    let ball_only = with_shade_scissors(&p, within(vec![2]));
    let mut gpu = GpuRenderer::new(
        &scene,
        crate::setup::device(),
        crate::setup::usable(DepthSetup::ALL[0]),
        true,
    )
    .expect("a Vulkan device (lavapipe)");
    let f = gpu.frame(&ball_only).unwrap();
    let r = peeltrim_reference::compare::compare(&reference, &f.images).unwrap();
    assert!(r.coverage_mismatch_interior > 100, "{r:?}");
}

#[test]
fn bores_far_apart_are_clipped_in_clusters_that_may_overlap() {
    // A wide slab drilled at two opposite corners: one clip draw and one
    // sweep of the slab per bore, each cut to its bore, where one over the
    // rectangle of both covered most of the slab. Widened to that rectangle
    // (as a grown scissor after a camera move would be), both draws cover
    // the same pixels: the count is set, not incremented, so the image is
    // the same. At the bench's size: a draw counts as 16384 pixels.
    const BIG: (u32, u32) = (800, 800);
    let load = |text: &str| {
        let opts = peeltrim::scene::load::LoadOptions { size: Some(BIG) };
        peeltrim::scene::load_str(text, std::path::Path::new("scs.toml"), &opts).unwrap()
    };
    let scene = load(
        r##"
[camera]
eye = [0.5, 4.0, 3.0]
target = [0.0, 0.0, 0.0]
fit = true
[[primitive]]
name = "Slab"
shape = "box"
size = [4.0, 0.5, 2.0]
[[primitive]]
name = "A"
shape = "cylinder"
radius = 0.3
height = 2.0
segments = 24
translate = [-1.5, 0.0, -0.6]
[[primitive]]
name = "B"
shape = "cylinder"
radius = 0.3
height = 2.0
segments = 24
translate = [1.5, 0.0, 0.6]
[csg]
expr = "Slab - A - B"
"##,
    );
    assert!(all_scs(&scene));
    let prep = Prepared::new(&scene).unwrap();
    let p = plan::build(Algo::Scs, &prep).unwrap();
    let sweeps = clip_sweeps(&p);
    let within = |ys: Vec<u32>| plan::Scissor::Within {
        meshes: vec![0],
        within: ys,
    };
    let scissor = |i: usize| match &p.steps[i] {
        Step::Draw(d) => d.scissor.clone(),
        s => panic!("a draw: {s:?}"),
    };
    // Each cut as its bore's exits are (`Scissor::Openings`: the bore's and
    // the slab's rectangles, cut to the bore's openings where the executor
    // knows them).
    let opening = |y: u32| plan::Scissor::Openings {
        of: y,
        and: vec![0],
    };
    let at: Vec<usize> = sweeps.iter().map(|s| s.0).collect();
    assert_eq!(
        at.iter().map(|&i| scissor(i)).collect::<Vec<_>>(),
        vec![opening(1), opening(2)],
        "one sweep of the slab per bore"
    );
    let writes = depth_writes(&p);
    let reference = peeltrim_reference::render(&scene, BIG.0, BIG.1);
    assert_swept(&scene, &reference, &p, &at, writes);
    // Every clip draw and sweep over the rectangle of both bores.
    let mut wide = p.clone();
    let clip_pass = p
        .steps
        .iter()
        .position(|s| matches!(s, Step::Pass(n) if n == "clip"))
        .unwrap();
    for s in &mut wide.steps[clip_pass..=at[1]] {
        if let Step::Draw(d) = s {
            d.scissor = within(vec![1, 2]);
        }
    }
    assert_swept(&scene, &reference, &wide, &at, writes);
    // Given the cutter sets, the clip and its sweeps are cut to the bores'
    // mouths with their exits: the same image, far fewer pixels.
    use peeltrim_cli::render::{DepthSetup, GpuRenderer};
    let gpu = || {
        GpuRenderer::new(
            &scene,
            crate::setup::device(),
            crate::setup::usable(DepthSetup::ALL[2]),
            true,
        )
        .expect("a Vulkan device (lavapipe)")
    };
    // Against the clip as it was (each over its bore's whole rectangle),
    // with the same sets.
    let mut uncut = p.clone();
    for s in &mut uncut.steps[clip_pass..=at[1]] {
        if let Step::Draw(d) = s {
            if let plan::Scissor::Openings { of, .. } = d.scissor {
                d.scissor = within(vec![of]);
            }
        }
    }
    let (mut cut, mut whole) = (gpu(), gpu());
    cut.set_cut_away(Algo::Scs, &prep, &scene);
    whole.set_cut_away(Algo::Scs, &prep, &scene);
    let (f, o) = (cut.frame(&p).unwrap(), whole.frame(&uncut).unwrap());
    assert!(f.images.color == o.images.color && f.images.prim == o.images.prim);
    assert!(f.images.depth == o.images.depth);
    let (c, oc) = (&f.stats.exec.counts, &o.stats.exec.counts);
    assert!(
        c.mesh_pixels < oc.mesh_pixels,
        "{} / {}",
        c.mesh_pixels,
        oc.mesh_pixels
    );
    let r = peeltrim_reference::compare::compare(&reference, &f.images).unwrap();
    assert_eq!(
        r.coverage_mismatch_interior + r.prim_mismatch_interior,
        0,
        "{r:?}"
    );
    assert!(cut.validation_messages().is_empty());
}

/// SCS's subtractions cut to the openings a cutter can act in
/// (`plan::Scissor::Openings`, `GpuRenderer::set_cut_away`), and the final
/// shade's depth-equal draws of a cavity's inside cut to the openings it is
/// seen through (`record::lower::seen_inside`; SCS and Goldfeather): on the
/// shipped scenes with cutters, in every depth set-up, the same colour, ids
/// and depth as with every draw whole, and as the reference says, with fewer
/// pixels scissored; after a camera move (sets for another camera serve
/// nothing) and back, still the same images. Validation on.
#[test]
fn subtractions_and_insides_cut_to_the_openings_change_no_pixel() {
    use peeltrim_cli::render::GpuRenderer;
    for name in [
        "drilled_block",
        "complex",
        "nonconvex_obj",
        "interference",
        "many_50",
    ] {
        let (scene, prep, reference) = crate::algorithms::shipped_with_reference(name);
        let tol = crate::algorithms::depth_tolerance(&scene);
        let mut moved = scene.camera;
        moved.eye = moved.target + glam::DQuat::from_rotation_y(0.02) * (moved.eye - moved.target);
        for algo in [Algo::Scs, Algo::Goldfeather] {
            let p = plan::build(algo, &prep).unwrap();
            let mut insides_cut = 0;
            for depth in crate::setup::usable_setups() {
                let gpu = || {
                    GpuRenderer::new(&scene, crate::setup::device(), depth, true)
                        .expect("a Vulkan device (lavapipe)")
                };
                let (mut cut, mut whole) = (gpu(), gpu());
                cut.set_cut_away(algo, &prep, &scene);
                for (frame, camera) in [scene.camera, scene.camera, moved, scene.camera]
                    .into_iter()
                    .enumerate()
                {
                    cut.set_camera(&camera).unwrap();
                    whole.set_camera(&camera).unwrap();
                    let (f, o) = (cut.frame(&p).unwrap(), whole.frame(&p).unwrap());
                    let (c, oc) = (&f.stats.exec.counts, &o.stats.exec.counts);
                    let at = format!(
                        "{name}, {algo}, {} frame {frame}: {c:?} / {oc:?}",
                        depth.name()
                    );
                    assert!(f.images.color == o.images.color, "colour, {at}");
                    assert!(f.images.prim == o.images.prim, "ids, {at}");
                    assert!(f.images.depth == o.images.depth, "depth, {at}");
                    if camera == scene.camera {
                        matches_reference(&at, &cut, &scene, &reference, &f.images, tol);
                    }
                    // What the shade's insides lost, and for SCS the
                    // subtractions on top (while the sets hold).
                    assert_eq!(oc.shade_insides_cut_pixels, 0, "{at}");
                    let kept = c.mesh_pixels + c.shade_insides_cut_pixels;
                    match (algo, frame < 2) {
                        (Algo::Scs, true) => assert!(kept < oc.mesh_pixels, "{at}"),
                        _ => assert_eq!(kept, oc.mesh_pixels, "{at}"),
                    }
                    insides_cut += c.shade_insides_cut_pixels;
                }
                for gpu in [&cut, &whole] {
                    let msgs = gpu.validation_messages();
                    assert!(msgs.is_empty(), "{name} {}: {msgs:#?}", depth.name());
                }
            }
            // Every one of these scenes shows a cutter's inside through its
            // openings only, in draws that cannot tie (in some depth set-ups:
            // a coarser one may keep the tie rule, which is never cut; so
            // does every set-up of a profile without depth-equal shades).
            let shades = crate::setup::depth_equal_shades();
            assert_eq!(insides_cut > 0, shades, "{name}, {algo}");
        }
    }
}

/// `images`, rendered by `gpu`, have no interior coverage or id mismatch
/// against `reference` and its depth within `tol` (or the device's bounds).
fn matches_reference(
    at: &str,
    gpu: &peeltrim_cli::render::GpuRenderer,
    scene: &Scene,
    reference: &peeltrim_cli::output::Images,
    images: &peeltrim_cli::output::Images,
    tol: f64,
) {
    let r = peeltrim_reference::compare::compare(reference, images).unwrap();
    assert_eq!(r.coverage_mismatch_interior, 0, "{r:?} {at}");
    assert_eq!(r.prim_mismatch_interior, 0, "{r:?} {at}");
    let depth_ok = crate::setup::depth_passes(
        r.depth_abs_err_p99_interior <= tol,
        gpu,
        scene,
        reference,
        images,
    );
    assert!(depth_ok, "depth, {r:?} {at}");
}
