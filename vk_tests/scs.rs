//! SCS (sequenced convex subtraction) on the cases its subtraction sequence and
//! tie rule exist for, against the exact reference (validation on): a chain of
//! overlapping cutters that needs several rounds, and cutters whose faces
//! coincide with each other's and with the block's.

use peeltrim::plan::{self, Algo, Prepared, Step};
use peeltrim::scene::Scene;

use crate::algorithms::{CST_COV, CST_PRIM, SIZE};

fn load(text: &str) -> Scene {
    crate::algorithms::load_text(text, "scs.toml")
}

/// Renders with scs in every depth set-up; CST's bars (0.05% interior coverage,
/// 0.01% primitive mismatches) and the depth tolerance of the shipped scenes.
/// Returns the loop iterations of the last frame.
fn check(scene: &Scene) -> Vec<u32> {
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

/// A block minus three overlapping spheres stacked along the view direction,
/// listed deepest first: a ray through the top enters S1, leaves it inside S2,
/// then S3, so the round S3, S2, S1 needs three rounds (the sequence's bound).
#[test]
fn a_chain_of_overlapping_cutters_takes_several_rounds() {
    let scene = load(
        r##"
primitive = [
  { name = "Block", shape = "box", size = [3.0, 1.6, 2.0] },
  { name = "S3", shape = "sphere", radius = 0.35, translate = [0.05, -0.15, 0.0], color = "#40a040" },
  { name = "S2", shape = "sphere", radius = 0.35, translate = [0.0, 0.3, 0.05], color = "#4060d0" },
  { name = "S1", shape = "sphere", radius = 0.35, translate = [-0.05, 0.75, 0.0], color = "#d04040" },
]
camera = { eye = [0.3, 4.0, 1.2], target = [0.0, 0.0, 0.0], fit = true }
csg = { expr = "Block - S3 - S2 - S1" }
"##,
    );
    assert!(all_scs(&scene));
    let reference = peeltrim::reference::render(&scene, SIZE.0, SIZE.1);
    assert!(
        reference.prim.iter().any(|&p| p == 2),
        "the deepest sphere's floor shows"
    );
    let loops = check(&scene);
    assert_eq!(loops.len(), 1, "one loop of rounds: {loops:?}");
    assert!(
        loops[0] >= 2,
        "the chain needs more than one round: {loops:?}"
    );
}

/// Cutters with coincident faces: K2's exit face (x = -0.5) is K1's entry face
/// (the exit continues into K1, two rounds), and K2's and a pocket's top faces
/// are the block's (flush cuts).
#[test]
fn coincident_cutters_are_tie_correct() {
    let scene = load(
        r##"
primitive = [
  { name = "Block", shape = "box", size = [4.0, 1.0, 2.0] },
  { name = "K1", shape = "box", size = [1.0, 0.6, 2.4], translate = [-1.0, 0.3, 0.0], color = "#d04040" },
  { name = "K2", shape = "box", size = [0.8, 0.3, 2.4], translate = [-0.1, 0.35, 0.0], color = "#40a040" },
  { name = "Flush", shape = "box", size = [0.6, 0.5, 0.6], translate = [1.2, 0.25, 0.0], color = "#4060d0" },
]
camera = { eye = [3.0, 2.5, 2.0], target = [0.0, 0.0, 0.0], fit = true }
csg = { expr = "Block - K1 - K2 - Flush" }
"##,
    );
    assert!(all_scs(&scene));
    let reference = peeltrim::reference::render(&scene, SIZE.0, SIZE.1);
    for p in 2..=4u16 {
        assert!(reference.prim.iter().any(|&q| q == p), "cutter {p} shows");
    }
    let loops = check(&scene);
    assert_eq!(loops, vec![2], "K2 then K1 through their shared face");
}

/// The eye inside a subtracted sphere (perspective): its parity counted from the
/// near plane is inverted, which the eye correction turns back into membership,
/// so SCS still draws the product (the block's near part scooped out, the
/// sphere's far side showing).
#[test]
fn the_eye_inside_a_subtracted_primitive() {
    let scene = load(
        r##"
primitive = [
  { name = "Block", shape = "box", size = [2.0, 2.0, 2.0] },
  { name = "Bubble", shape = "sphere", radius = 2.5, translate = [0.0, 0.0, 3.0], color = "#d04040" },
]
camera = { eye = [0.3, 0.4, 3.0], target = [0.0, 0.0, 0.0], fov_y_deg = 60 }
csg = { expr = "Block - Bubble" }
"##,
    );
    let prep = Prepared::new(&scene).unwrap();
    assert_eq!(prep.eye_inside[..2], [false, true]);
    assert!(all_scs(&scene));
    let reference = peeltrim::reference::render(&scene, SIZE.0, SIZE.1);
    assert!(reference.prim.iter().any(|&p| p == 2), "the bubble shows");
    check(&scene);
}
