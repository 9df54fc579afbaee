//! SCS with an orthographic camera whose near plane cuts a subtracted primitive
//! (validation on). Rays of the pixels inside the cut start inside the cutter,
//! so its parity counted from the near plane is inverted there and only there:
//! no per-primitive flip is right (that is for a perspective eye inside it), and
//! the per-pixel eye correction ([`peeltrim::plan`]'s `eye` module) must make
//! "bit set" mean "inside" for SCS's subtraction draws as for its clip. SCS,
//! Goldfeather and CST-I are held to the reference with no interior mismatch.

use peeltrim::plan::{Algo, Prepared};
use peeltrim::scene::Scene;

use crate::algorithms::{assert_scene, load_text, SIZE};
use crate::scs::all_scs;

/// An orthographic view down −Z (slightly tilted) with the near plane at view
/// depth 2: the 2-unit block's front face lies behind it, the cutters' near
/// ends (z > 2) in front of it.
fn ortho(primitives: &[&str], expr: &str) -> Scene {
    let text = format!(
        r##"
primitive = [
  {{ name = "Block", shape = "box", size = [2.0, 2.0, 2.0] }},
  {}
]
camera = {{ eye = [0.5, 0.7, 4.0], projection = "orthographic", ortho_height = 3.5, near = 2.0, far = 7.0 }}
csg = {{ expr = "{expr}" }}
"##,
        primitives.join(",\n  ")
    );
    load_text(&text, "scs_ortho.toml")
}

/// A cylinder along Z from z = −0.8 (its floor inside the block) to z = 3.2
/// (in front of the near plane).
const PIN: &str = r##"{ name = "Pin", shape = "cylinder", radius = 0.45, height = 4.0, rotate_deg = [90.0, 0.0, 0.0], translate = [0.2, -0.1, 1.2], color = "#d04040" }"##;

/// SCS, Goldfeather and CST-I match the reference exactly (no interior
/// coverage or primitive mismatch, depth within the tolerance).
fn exact(scene: &Scene) {
    for algo in [Algo::Scs, Algo::Goldfeather, Algo::CstI] {
        assert_scene(scene, algo, 0.0, 0.0);
    }
}

/// Which primitives (1-based ids) the reference shows.
fn shown(scene: &Scene) -> Vec<u16> {
    let reference = peeltrim_reference::render(scene, SIZE.0, SIZE.1);
    let mut ids: Vec<u16> = reference.prim.into_iter().filter(|&p| p != 0).collect();
    ids.sort_unstable();
    ids.dedup();
    ids
}

/// A block minus a pin through the near plane: inside the pin the ray starts in
/// the cutter, the block's front face is not drawn and the pin's floor is.
#[test]
fn a_near_plane_through_a_subtracted_cylinder() {
    let scene = ortho(&[PIN], "Block - Pin");
    let prep = Prepared::new(&scene).unwrap();
    assert_eq!(
        prep.near_cut[..2],
        [false, true],
        "the near plane cuts the pin"
    );
    assert_eq!(prep.eye_inside[..2], [false, false]);
    assert!(all_scs(&scene), "SCS draws the product");
    assert_eq!(shown(&scene), [1, 2], "the block and the pin's floor show");
    exact(&scene);
}

/// An intersected product (block ∩ ball) minus two overlapping cutters that the
/// near plane both cuts: their static sequence (`a b a`, `plan::scs::order`)
/// repeats corrected parity draws, and the clip is the parity clip of two
/// positive primitives.
#[test]
fn a_near_plane_through_overlapping_cutters_of_an_intersection() {
    let ball = r##"{ name = "Ball", shape = "sphere", radius = 1.35, color = "#40a040" }"##;
    let notch = r##"{ name = "Notch", shape = "box", size = [0.8, 0.5, 3.0], translate = [-0.4, 0.5, 0.6], color = "#4060d0" }"##;
    let scene = ortho(&[PIN, ball, notch], "Block * Ball - Pin - Notch");
    let prep = Prepared::new(&scene).unwrap();
    assert_eq!(prep.near_cut[..4], [false, true, false, true]);
    assert!(all_scs(&scene), "SCS draws the product");
    assert_eq!(shown(&scene), [1, 2, 3, 4], "every primitive shows");
    let loops = assert_scene(&scene, Algo::Scs, 0.0, 0.0);
    assert!(
        loops.is_empty(),
        "two overlapping cutters take a static sequence, not rounds: {loops:?}"
    );
    exact(&scene);
}

/// The pin intersected (a positive primitive the near plane cuts): its nearest
/// front face is not where the ray enters the product, so SCS draws that
/// product with Goldfeather's steps, and the image is still exact.
#[test]
fn a_near_plane_through_an_intersected_cylinder() {
    let notch = r##"{ name = "Notch", shape = "box", size = [0.8, 0.5, 3.0], translate = [-0.1, 0.0, 0.6], color = "#4060d0" }"##;
    let scene = ortho(&[PIN, notch], "(Block - Notch) * Pin");
    let prep = Prepared::new(&scene).unwrap();
    assert_eq!(prep.near_cut[..3], [false, true, true]);
    assert!(
        !all_scs(&scene),
        "the product falls back to Goldfeather's steps"
    );
    assert_eq!(shown(&scene), [1, 2, 3], "every primitive shows");
    exact(&scene);
}
