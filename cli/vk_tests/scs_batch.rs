//! SCS products side by side (`plan::scs::batch`): products whose pixels
//! cannot meet on screen share their clears and blocks and match the
//! reference in every depth set-up, validation on; the rule is what keeps
//! them right: forcing two products that overlap on screen side by side
//! (a `Prepared` whose screen boxes claim they are apart) breaks the image.

use peeltrim::plan::screen::ScreenBox;
use peeltrim::plan::{self, Algo, Prepared, Step};
use peeltrim::scene::Scene;
use peeltrim_cli::render::{DepthSetup, GpuRenderer};

use crate::algorithms::{CST_PRIM, SIZE};

/// Four balls drilled by vertical cylinders, `(B0 − C0) ∪ … ∪ (B3 − C3)`:
/// B0, B1, B2 in a row across the view, B3 behind B1 (their rectangles
/// overlap on screen).
fn drilled_balls() -> Scene {
    let mut text = String::from(
        r##"
[camera]
eye = [0.0, 1.5, 6.0]
target = [0.0, 0.0, -0.5]
fit = true
"##,
    );
    let at = [(-2.5, 0.0), (0.0, 0.0), (2.5, 0.0), (0.4, -2.5)];
    let mut expr = Vec::new();
    for (i, (x, z)) in at.iter().enumerate() {
        text.push_str(&format!(
            r##"
[[primitive]]
name = "B{i}"
shape = "sphere"
radius = 0.6
translate = [{x}, 0.0, {z}]
[[primitive]]
name = "C{i}"
shape = "cylinder"
radius = 0.25
height = 1.6
translate = [{x}, 0.0, {z}]
color = "#c04040"
"##
        ));
        expr.push(format!("(B{i} - C{i})"));
    }
    text.push_str(&format!("[csg]\nexpr = \"{}\"\n", expr.join(" + ")));
    crate::algorithms::load_text(&text, "drilled_balls.toml")
}

/// Per `scs-front` pass of `p`, the depth-stencil images its front draws use.
fn front_groups(p: &plan::Plan) -> Vec<Vec<u8>> {
    let mut groups: Vec<Vec<u8>> = Vec::new();
    let mut in_front = false;
    for s in &p.steps {
        match s {
            Step::Pass(n) => {
                in_front = n == "scs-front";
                if in_front {
                    groups.push(Vec::new());
                }
            }
            Step::Draw(d) if in_front => groups.last_mut().unwrap().push(d.ds),
            _ => {}
        }
    }
    groups
}

#[test]
fn products_apart_on_screen_share_the_output_and_one_behind_another_does_not() {
    let scene = drilled_balls();
    let prep = Prepared::new(&scene).unwrap();
    let p = plan::build(Algo::Scs, &prep).unwrap();
    // B0, B1, B2 in the output in one pass; B3 (behind B1) alone, in the
    // surface image, then merged.
    assert_eq!(
        front_groups(&p),
        vec![vec![0, 0, 0], vec![1]],
        "{:?}",
        prep.screen
    );
    crate::scs::check(&scene);
}

#[test]
fn forcing_overlapping_products_side_by_side_breaks_the_image() {
    let scene = drilled_balls();
    let reference = peeltrim_reference::render(&scene, SIZE.0, SIZE.1);
    let mut prep = Prepared::new(&scene).unwrap();
    // B0 and C0 claim the whole screen (no product joins the first), the
    // others claim boxes far apart: B1, B2 and B3 go side by side in the
    // surface image, although B3 lies behind B1 on screen.
    let far = |k: f64| {
        Some(ScreenBox {
            lo: glam::DVec2::new(1e10 * k, 0.0),
            hi: glam::DVec2::new(1e10 * k + 10.0, 10.0),
        })
    };
    prep.screen = vec![
        Some(ScreenBox {
            lo: glam::DVec2::splat(-1e12),
            hi: glam::DVec2::splat(1e12),
        }),
        Some(ScreenBox {
            lo: glam::DVec2::splat(-1e12),
            hi: glam::DVec2::splat(1e12),
        }),
    ];
    for k in 1..4 {
        prep.screen.extend([far(k as f64), far(k as f64)]);
    }
    let forced = plan::build(Algo::Scs, &prep).unwrap();
    assert_eq!(front_groups(&forced), vec![vec![0], vec![1, 1, 1]]);
    let mut gpu = GpuRenderer::new(&scene, crate::setup::device(), DepthSetup::DEFAULT, true)
        .expect("a Vulkan device (lavapipe)");
    let f = gpu.frame(&forced).unwrap();
    let msgs = gpu.validation_messages();
    assert!(msgs.is_empty(), "validation messages: {msgs:#?}");
    let r = peeltrim_reference::compare::compare(&reference, &f.images).unwrap();
    // B3's front face, farther, wins the surface image where B1 covers it:
    // B1 loses those pixels to B3.
    assert!(r.prim_mismatch_interior_frac > 10.0 * CST_PRIM, "{r:?}");
}
