//! Clears and copies cut to what is read (`plan::reach`), frame after frame:
//! the outputs keep their pixels between frames and are cleared only where
//! earlier frames and this one dirty them, so outside the CSG they must still
//! hold the background, the far depth and id 0 — after replays, camera moves
//! and other plans on the same executor.

use peeltrim::plan::{build, Algo, Plan, Prepared};
use peeltrim::scene::{Camera, Projection, Scene};
use peeltrim::vk::Executor;
use peeltrim_cli::output::Images;

use crate::{algorithms, assert_clean, context};

/// `cam` seen from `k` times as far (the CSG shrinks to a small part of the
/// image), shifted sideways by `side` of that distance.
fn away(cam: &Camera, k: f64, side: f64) -> Camera {
    let back = cam.eye - cam.target;
    let right = back.cross(cam.up).normalize() * back.length() * k * side;
    let mut c = *cam;
    c.eye = cam.target + back * k + right;
    c.target = cam.target + right;
    c.far = cam.far * k;
    if let Projection::Orthographic { height } = cam.projection {
        c.projection = Projection::Orthographic { height: height * k };
    }
    c
}

/// Pixels of `img` without a primitive hold the background and the far depth;
/// how many there are.
fn background_outside(img: &Images, bg: [u8; 3], what: &str) -> usize {
    let mut n = 0;
    for (i, &p) in img.prim.iter().enumerate() {
        if p == 0 {
            let c = img.color[i];
            assert_eq!([c[0], c[1], c[2]], bg, "{what}: pixel {i} has no primitive");
            assert!(img.depth[i].is_infinite(), "{what}: pixel {i} has a depth");
            n += 1;
        }
    }
    n
}

/// The same frames on one executor (its clears the device profile's):
/// plan `a` at `cams[0]` three times (loop by loop, recorded, replayed), `b`
/// once, `a` again, then `a` at `cams[1]` twice (moved, then still) and back
/// at `cams[0]`. Outside the CSG every frame's outputs hold the background;
/// pixels the CSG covered at `cams[0]` but not at `cams[1]` are background
/// again.
fn frames_agree(sc: &Scene, a: &Plan, b: &Plan, cams: [Camera; 2], what: &str) {
    let ctx = context();
    let desc = crate::scene_desc(sc);
    let mut e = Executor::new(&ctx, &desc).expect("executor");
    e.upload(sc).expect("upload");
    let seq: [(&Plan, usize); 8] = [
        (a, 0),
        (a, 0),
        (a, 0),
        (b, 0),
        (a, 0),
        (a, 1),
        (a, 1),
        (a, 0),
    ];
    let mut covered_before: Option<Vec<bool>> = None;
    let mut revealed = 0;
    for (i, (p, c)) in seq.into_iter().enumerate() {
        e.set_camera(&cams[c]).expect("camera");
        let cut = e.frame(p).expect("frame");
        let what = format!("{what} frame {i} ({}, camera {c})", p.algo);
        let outside = background_outside(&cut.images, sc.render.background, &what);
        assert!(
            outside * 2 > cut.images.prim.len(),
            "{what}: the CSG should cover a small part of the image"
        );
        let covered: Vec<bool> = cut.images.prim.iter().map(|&p| p != 0).collect();
        if c == 1 {
            if let Some(before) = &covered_before {
                revealed += before
                    .iter()
                    .zip(&covered)
                    .filter(|(b, n)| **b && !**n)
                    .count();
            }
        } else {
            covered_before = Some(covered);
        }
    }
    assert!(
        revealed > 0,
        "{what}: the camera move should uncover pixels"
    );
    drop(e);
    assert_clean(&ctx);
}

#[test]
fn outside_the_csg_the_outputs_hold_the_background() {
    let cases = [
        ("complex.toml", Algo::CstI, Algo::Goldfeather),
        ("complex.toml", Algo::Goldfeather, Algo::Scs),
        // Goldfeather's layer loop copies textures.
        ("nonconvex_obj.toml", Algo::Goldfeather, Algo::CstI),
    ];
    for (name, a, b) in cases {
        let mut sc = algorithms::load(&crate::setup::scenes_dir().join(name));
        let cams = [away(&sc.camera, 2.5, 0.0), away(&sc.camera, 2.5, 0.15)];
        sc.camera = cams[0];
        let prep = Prepared::new(&sc).expect("prepared");
        let (pa, pb) = (
            build(a, &prep).expect("plan"),
            build(b, &prep).expect("plan"),
        );
        let what = format!("{name} {}", a.name());
        frames_agree(&sc, &pa, &pb, cams, &what);
    }
}
