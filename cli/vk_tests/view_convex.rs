//! View-dependent convexity (`plan/view_convex.rs`) against the exact reference,
//! validation on: the L-bracket of `nonconvex_obj` is convex from its scene's
//! camera (every algorithm takes the convex path: SCS's, no peeling), and from a
//! camera looking along its notch, where rays enter it twice, it is not (the
//! peeling paths are kept, and the convex path would be wrong there).

use peeltrim::plan::{self, Algo, Plan, Prepared, Step};
use peeltrim::scene::{self, LoadOptions, Scene};
use peeltrim_cli::render::DepthSetup;

use crate::algorithms::{depth_tolerance, SIZE};

/// `nonconvex_obj.toml` with its `[camera]` table replaced by `camera` (`None`:
/// the scene's own).
fn nonconvex_obj(camera: Option<&str>) -> Scene {
    let path = crate::setup::scenes_dir().join("nonconvex_obj.toml");
    let text = std::fs::read_to_string(&path).expect("the shipped scene");
    let text = match camera {
        None => text,
        Some(cam) => {
            let start = text.find("[camera]").expect("a camera table");
            let end = start + text[start..].find("[[primitive]]").expect("primitives");
            format!("{}{cam}\n{}", &text[..start], &text[end..])
        }
    };
    scene::load_str(&text, &path, &LoadOptions { size: Some(SIZE) })
        .unwrap_or_else(|e| panic!("{e}"))
}

/// A camera on the line x + y = 2.15 through both arms: a ray there enters the
/// vertical arm, crosses the notch and enters the horizontal arm.
const ALONG_THE_NOTCH: &str = r#"[camera]
eye = [4.0, -1.85, 1.5]
target = [0.25, 1.9, 0.5]
fit = true
"#;

fn passes(p: &Plan) -> Vec<&str> {
    p.steps
        .iter()
        .filter_map(|s| match s {
            Step::Pass(n) => Some(n.as_str()),
            _ => None,
        })
        .collect()
}

/// Renders `plan` of `algo` and returns (interior coverage, interior primitive)
/// mismatch fractions and whether the depth passes; asserts no validation message.
fn render(scene: &Scene, plan: &Plan, depth: DepthSetup) -> (f64, f64, bool) {
    let reference = peeltrim_reference::render(scene, SIZE.0, SIZE.1);
    let mut gpu =
        peeltrim_cli::render::GpuRenderer::new(scene, crate::setup::device(), depth, true)
            .expect("a Vulkan device");
    let frame = gpu.frame(plan).expect("frame");
    let msgs = gpu.validation_messages();
    assert!(msgs.is_empty(), "{}: validation: {msgs:#?}", plan.algo);
    let r = peeltrim_reference::compare::compare(&reference, &frame.images).expect("compare");
    let depth_ok = crate::setup::depth_passes(
        r.depth_abs_err_p99_interior <= depth_tolerance(scene),
        &gpu,
        scene,
        &reference,
        &frame.images,
    );
    eprintln!(
        "{} {}: {r:?} draws {} loops {:?}",
        plan.algo,
        depth.name(),
        frame.stats.exec.counts.draws,
        frame.stats.exec.counts.loop_iterations
    );
    (
        r.coverage_mismatch_interior_frac,
        r.prim_mismatch_interior_frac,
        depth_ok,
    )
}

/// CST's bars: 0.05% interior coverage, 0.01% interior primitive mismatches.
fn assert_matches(scene: &Scene, plan: &Plan, depth: DepthSetup) {
    let (cov, prim, depth_ok) = render(scene, plan, depth);
    assert!(
        cov <= 0.0005,
        "{} {}: coverage {cov}",
        plan.algo,
        depth.name()
    );
    assert!(
        prim <= 0.0001,
        "{} {}: primitive {prim}",
        plan.algo,
        depth.name()
    );
    assert!(depth_ok, "{} {}: depth", plan.algo, depth.name());
}

const ALGOS: [Algo; 6] = [
    Algo::Scs,
    Algo::Goldfeather,
    Algo::GoldfeatherLayered,
    Algo::Kirsch,
    Algo::CstI,
    Algo::CstG,
];

#[test]
fn the_l_bracket_takes_the_convex_paths_from_its_scene_camera() {
    let scene = nonconvex_obj(None);
    let prep = Prepared::new(&scene).unwrap();
    assert!(!prep.mesh_convex[0] && prep.view_convex[0]);
    let scs = plan::build(Algo::Scs, &prep).unwrap();
    let names = passes(&scs);
    assert!(
        names.contains(&"scs-front") && !names.contains(&"surface"),
        "{names:?}"
    );
    assert!(prep.warnings(Algo::Scs).is_empty());
    for algo in ALGOS {
        let p = plan::build(algo, &prep).unwrap();
        if matches!(algo, Algo::Scs | Algo::Goldfeather | Algo::Kirsch) {
            // Nothing left to peel: no loop (CST unrolls a known number of
            // peels; layered Goldfeather peels the product's layers anyway).
            assert_eq!(p.loops().count(), 0, "{algo}");
        }
        let depths = match algo == Algo::Scs {
            true => crate::setup::usable_setups(),
            false => vec![crate::setup::usable(DepthSetup::D24S8)],
        };
        for depth in depths {
            assert_matches(&scene, &p, depth);
        }
    }
}

#[test]
fn along_the_notch_the_l_bracket_is_peeled_and_must_be() {
    let scene = nonconvex_obj(Some(ALONG_THE_NOTCH));
    let prep = Prepared::new(&scene).unwrap();
    assert!(!prep.mesh_convex[0] && !prep.view_convex[0]);
    let scs = plan::build(Algo::Scs, &prep).unwrap();
    assert!(passes(&scs).contains(&"surface"), "{:?}", passes(&scs));
    for algo in [Algo::Scs, Algo::Goldfeather, Algo::CstI] {
        assert_matches(
            &scene,
            &plan::build(algo, &prep).unwrap(),
            crate::setup::usable(DepthSetup::D24S8),
        );
    }
    // Called convex here, SCS takes the farther arm's front face where a ray
    // enters twice: the slow path is needed, not just kept.
    let mut wrong = prep.clone();
    wrong.view_convex[0] = true;
    let fast = plan::build(Algo::Scs, &wrong).unwrap();
    assert!(passes(&fast).contains(&"scs-front"));
    let (cov, prim, _) = render(&scene, &fast, crate::setup::usable(DepthSetup::D24S8));
    assert!(
        cov > 0.001 || prim > 0.001,
        "the convex path is wrong along the notch: coverage {cov} primitive {prim}"
    );
}
