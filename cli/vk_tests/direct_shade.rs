//! One-primitive products shaded in their own draw (`plan::direct_shade`): the
//! frame matches the reference, and keeps the final shade draw for a product
//! whose mesh has a face coincident with another product's, where the tie rule
//! (the lowest index wins) decides the visible id. Only where the device
//! profile allows depth-equal shades (`DeviceProfile::depth_equal_shades`):
//! elsewhere no direct draw shades.

use peeltrim::plan::{self, Algo, Prepared, Step};
use peeltrim_cli::render::{DepthSetup, GpuRenderer};
use peeltrim_reference::compare::compare;
use peeltrim_reference::precision::spec_depth_check;

use crate::algorithms::{load_text, SIZE};

/// The algorithms that draw one-primitive products directly.
const DIRECT: [Algo; 4] = [
    Algo::Scs,
    Algo::Goldfeather,
    Algo::GoldfeatherLayered,
    Algo::Kirsch,
];

/// The camera of both scenes.
pub(crate) const CAMERA: &str = r##"
name = "direct"
[camera]
eye = [3.0, 2.5, 4.0]
target = [0.0, 0.0, 0.0]
fit = true
"##;

/// A housing: a block minus a bore, primitives 1 and 2 of both scenes.
pub(crate) const HOUSING: &str = r##"
[[primitive]]
name = "Block"
shape = "box"
size = [2.0, 1.5, 1.0]
color = "#c0a060"
[[primitive]]
name = "Bore"
shape = "cylinder"
radius = 0.3
height = 2.0
rotate_deg = [90.0, 0.0, 0.0]
translate = [-0.4, 0.0, 0.0]
color = "#805020"
[[solid]]
name = "housing"
expr = "Block - Bore"
"##;

/// The housing with `first` (primitive 0) before it and `last` after it.
fn scene(first: &str, last: &str) -> String {
    format!("{CAMERA}{first}{HOUSING}{last}")
}

/// A ball sticking out of the housing's front face (in front of the housing
/// at some pixels, behind its front face at others) and a cube behind it
/// (hidden by the housing at some pixels): two direct products overlapping
/// another product in both depth orders, no two faces coincident.
const BALL: &str = r##"
[[primitive]]
name = "Ball"
shape = "sphere"
radius = 0.45
translate = [0.55, 0.2, 0.45]
color = "#4080c0"
[[solid]]
name = "ball"
expr = "Ball"
"##;
const CUBE: &str = r##"
[[primitive]]
name = "Cube"
shape = "box"
size = [0.7, 0.7, 0.7]
translate = [-1.05, 0.45, -0.55]
color = "#60a060"
[[solid]]
name = "cube"
expr = "Cube"
"##;

/// A lid (index 0) whose front face lies in the housing's front face plane,
/// over a wide strip: the tie rule gives those pixels to the lid, the lowest
/// index, which the final shade draws last. Its product must keep the old
/// path (shaded in its direct draw, before the final shade, the housing's
/// tie-rule draw would overwrite it there). A post far from both is tie-free
/// and shades in its direct draw.
const LID: &str = r##"
[[primitive]]
name = "Lid"
shape = "box"
size = [0.8, 1.0, 0.6]
translate = [0.5, 0.45, 0.2]
color = "#4080c0"
[[solid]]
name = "lid"
expr = "Lid"
"##;
const POST: &str = r##"
[[primitive]]
name = "Post"
shape = "cylinder"
radius = 0.15
height = 1.0
translate = [-1.5, 0.3, -1.2]
color = "#60a060"
[[solid]]
name = "post"
expr = "Post"
"##;

/// The direct draws of `algo`'s plan of `prep`.
fn direct_draws(algo: Algo, prep: &Prepared) -> u64 {
    let plan = plan::build(algo, prep).unwrap_or_else(|e| panic!("{algo}: {e}"));
    let mut pass = "";
    let mut n = 0;
    for s in &plan.steps {
        match s {
            Step::Pass(p) => pass = p,
            Step::Draw(_) if pass == "direct" => n += 1,
            _ => {}
        }
    }
    n
}

/// For each algorithm that draws products directly: the direct draws that
/// shade equal `shading(direct draws of the plan)` (none where the profile
/// allows no depth-equal shade), and the images match the reference with no
/// interior mismatch.
fn check(text: &str, name: &str, shading: impl Fn(u64) -> u64) {
    let scene = load_text(text, name);
    let prep = Prepared::new(&scene).expect("prepared");
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    let mut gpu = GpuRenderer::new(&scene, crate::setup::device(), DepthSetup::DEFAULT, true)
        .expect("a Vulkan device (lavapipe)");
    let shades = gpu
        .context()
        .profile()
        .depth_equal_shades(DepthSetup::DEFAULT.exec_format().0);
    let mut failures = Vec::new();
    for algo in DIRECT {
        let direct = direct_draws(algo, &prep);
        assert!(direct >= 2, "{name} {algo}: {direct} direct draws");
        let plan = plan::build(algo, &prep).unwrap_or_else(|e| panic!("{algo}: {e}"));
        // The first frame of a plan runs loop by loop, which keeps the depth
        // draw and the shade; the second is recorded.
        gpu.frame(&plan).unwrap_or_else(|e| panic!("{algo}: {e}"));
        let f = gpu.frame(&plan).unwrap_or_else(|e| panic!("{algo}: {e}"));
        let (new, n) = (f.images, &f.stats.exec.counts);
        let want = if shades { shading(direct) } else { 0 };
        assert_eq!(n.direct_shade_draws, want, "{name} {algo}: {n:?}");
        let r = compare(&reference, &new).expect("same size");
        let s = spec_depth_check(&reference, &new, &scene.camera, &gpu.precision());
        if r.coverage_mismatch_interior > 0 || r.prim_mismatch_interior > 0 || s.ratio_p99 > 1.0 {
            failures.push(format!("{name} {algo} against the reference: {r:?} {s:?}"));
        }
        eprintln!(
            "{name} {algo}: {} of {direct} direct draws shade; draws {}, mesh pixels {}",
            n.direct_shade_draws, n.draws, n.mesh_pixels
        );
    }
    let msgs = gpu.validation_messages();
    assert!(msgs.is_empty(), "validation messages: {msgs:#?}");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn direct_products_in_front_of_and_behind_another_shade_in_their_own_draw() {
    check(&scene(BALL, CUBE), "overlap", |direct| direct);
}

#[test]
fn a_direct_product_with_a_coincident_face_keeps_the_tie_rule() {
    // The lid keeps its depth-only draw and its final shade draw; the post
    // shades directly.
    check(&scene(LID, POST), "lid", |direct| direct - 1);
}
