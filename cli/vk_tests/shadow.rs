//! Shadows of a `[light]` on the GPU (the solid's depth from the light, then the
//! shadow pass over the eye's frame, all on the GPU) against the reference's
//! exact shadow rays: the lit/shadowed classification agrees at ≥ 99.5% of
//! interior pixels, on the made-for-it scene, with a point light, a
//! grazing light, and on shipped scenes given a light; lit pixels keep the
//! opaque colour exactly and shadowed ones are the CPU's `SHADOW_KEEP` of it;
//! validation clean.

use glam::DVec3;
use peeltrim::plan::Algo;
use peeltrim::scene::light::Light;
use peeltrim::scene::{self, LoadOptions, Scene};
use peeltrim_cli::render::{self, shadow};
use peeltrim_reference::compare::boundary_mask;

use crate::setup::options;

const SIZE: (u32, u32) = (160, 160);
/// The bar: agreement with the reference.
const AGREE: f64 = 0.995;

fn load(name: &str) -> Scene {
    let p = crate::setup::scenes_dir().join(name);
    scene::load(&p, &LoadOptions { size: Some(SIZE) }).unwrap_or_else(|e| panic!("{e}"))
}

/// Agreement of `algo`'s classification with the shadow rays over the interior
/// pixels (not within a pixel of a coverage or id edge of the reference, covered
/// in both), and the count of those pixels and of shadowed ones.
fn agreement(scene: &Scene, light: &Light, algo: Algo) -> (f64, u64, u64) {
    let (w, h) = SIZE;
    let reference = peeltrim_reference::render(scene, w, h);
    let want = peeltrim_reference::shadow::shadow_rays(scene, light, w, h);
    let (_, got) =
        shadow::gpu_shadowed(scene, &options(algo), light).unwrap_or_else(|e| panic!("{e}"));
    let edge = boundary_mask(&reference);
    let (mut n, mut same, mut dark) = (0u64, 0u64, 0u64);
    for i in 0..want.len() {
        if let (false, Some(a), Some(b)) = (edge[i], want[i], got[i]) {
            n += 1;
            same += (a == b) as u64;
            dark += a as u64;
        }
    }
    (same as f64 / n as f64, n, dark)
}

fn check(scene: &Scene, light: &Light, algo: Algo) {
    let (frac, n, dark) = agreement(scene, light, algo);
    eprintln!(
        "shadow {} {algo} {}: {:.3}% of {n} interior pixels agree ({dark} shadowed)",
        scene.name.as_deref().unwrap_or("?"),
        light.describe(),
        frac * 100.0
    );
    assert!(
        dark > n / 50,
        "too few shadowed pixels to test: {dark} of {n}"
    );
    assert!(
        frac >= AGREE,
        "{algo}: {:.3}% < {:.1}%",
        frac * 100.0,
        AGREE * 100.0
    );
}

#[test]
fn made_for_it_scene_matches_shadow_rays() {
    let s = load("shadow_block.toml");
    let light = s.appearance.light.expect("shadow_block has a [light]");
    for algo in [Algo::CstI, Algo::CstZ, Algo::CstG, Algo::Blister] {
        check(&s, &light, algo);
    }
}

#[test]
fn point_light_matches_shadow_rays() {
    let s = load("shadow_block.toml");
    let light = Light::Point {
        position: DVec3::new(-4.0, 9.0, 3.0),
    };
    check(&s, &light, Algo::CstI);
}

/// A light that grazes the floor (about 8° above it) and the plate's top: long
/// shadows, and faces the map barely sees.
#[test]
fn grazing_light_matches_shadow_rays() {
    let s = load("shadow_block.toml");
    let light = Light::Directional {
        direction: DVec3::new(1.0, -0.15, 0.4).normalize(),
    };
    check(&s, &light, Algo::CstZ);
}

#[test]
fn shipped_scenes_with_a_light_match_shadow_rays() {
    let light = Light::Directional {
        direction: DVec3::new(-1.0, -0.8, -0.5).normalize(),
    };
    for name in ["drilled_block.toml", "gear.toml", "complex.toml"] {
        check(&load(name), &light, Algo::CstI);
    }
}

/// With a light, lit pixels and background keep the opaque frame's colour,
/// shadowed ones are darkened, and the counts say how many of each.
#[test]
fn shadows_change_only_shadowed_pixels() {
    let s = load("shadow_block.toml");
    for algo in [Algo::Reference, Algo::CstI] {
        let lit = render::render(&s, &options(algo)).unwrap_or_else(|e| panic!("{e}"));
        let opaque = render::render_opaque(&s, &options(algo)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(lit.images.depth, opaque.images.depth);
        assert_eq!(lit.images.prim, opaque.images.prim);
        let st = lit.stats.shadow.clone().expect("shadow stats");
        let covered = opaque.images.prim.iter().filter(|&&p| p != 0).count() as u64;
        assert_eq!(st.lit_pixels + st.shadowed_pixels, covered);
        assert!(st.shadowed_pixels > covered / 20, "{st:?}");
        let changed = (0..lit.images.color.len())
            .filter(|&i| lit.images.color[i] != opaque.images.color[i])
            .count() as u64;
        // A shadowed pixel whose colour halves to itself (black) is the only
        // way to be shadowed and unchanged.
        assert!(changed <= st.shadowed_pixels && changed * 100 >= st.shadowed_pixels * 99);
        // Every changed pixel is exactly the CPU's darkening of the opaque one
        // (the GPU pass blends; the rounding must be the same).
        for i in 0..lit.images.color.len() {
            if lit.images.color[i] != opaque.images.color[i] {
                let mut want = [opaque.images.color[i]];
                shadow::apply(&mut want, &[Some(true)], &s.appearance.light.unwrap());
                assert_eq!(lit.images.color[i], want[0], "pixel {i}");
            }
        }
        assert!(opaque.stats.shadow.is_none());
        assert_eq!(
            st.shadow_map_size.is_some(),
            algo != Algo::Reference,
            "{st:?}"
        );
    }
}

/// A shadowed frame whose light map and eye frame replay their recordings is
/// one queue submission (map, eye and shadow pass together) and gives the
/// image and shadow mask of the plan's first frame, which ran frame by frame.
#[test]
fn replayed_shadowed_frames_are_one_submission_with_the_same_images() {
    let s = load("shadow_block.toml");
    let light = s.appearance.light.expect("a light");
    let o = options(Algo::CstI);
    let prep = peeltrim::plan::Prepared::new(&s).unwrap();
    let plan = peeltrim::plan::build_with(Algo::CstI, &prep, &o.build).unwrap();
    let mut gpu = render::GpuRenderer::for_options(&s, &o).unwrap_or_else(|e| panic!("{e}"));
    let mut sh = shadow::GpuShadows::for_renderer(&mut gpu, &s, &light, Algo::CstI, &o.build)
        .unwrap_or_else(|e| panic!("{e}"));
    let (_, first) = sh.frame(&mut gpu, &plan, &s.camera, false).unwrap();
    assert!(first.submits >= 3, "map, eye and pass: {first:?}");
    let want = (gpu.read_back().unwrap(), sh.mask().unwrap());
    assert!(want.1.iter().filter(|&&m| m).count() > 500);
    for new_map in [true, false] {
        let (eye, cost) = sh.frame(&mut gpu, &plan, &s.camera, new_map).unwrap();
        assert_eq!(cost.submits, 1, "{cost:?}");
        assert_eq!(cost.map.is_some(), new_map);
        assert_ne!(eye.exec.recorded, peeltrim::vk::Recorded::Stepwise);
        let got = (gpu.read_back().unwrap(), sh.mask().unwrap());
        assert!(got.0.color == want.0.color && got.0.prim == want.0.prim);
        assert!(got.1 == want.1, "shadow masks differ");
    }
    let msgs = gpu.validation_messages();
    assert!(msgs.is_empty(), "{msgs:?}");
}

/// Shadows in an embedded frame (`view`'s path: the map rendered once, the
/// pass recorded into the host's command buffer after the frame) give the same
/// image as `render`'s standalone frames, with validation on.
#[test]
fn embedded_frames_have_the_same_shadows() {
    use peeltrim::vk::{self, OffscreenHost};
    use peeltrim::{CsgScene, EmbedDesc, LoopCounts};
    let s = load("shadow_block.toml");
    let light = s.appearance.light.expect("a light");
    let o = options(Algo::CstI);
    let (want, _) = shadow::gpu_shadowed(&s, &o, &light).unwrap_or_else(|e| panic!("{e}"));
    let ctx = vk::Context::new(&vk::ContextDesc {
        device: o.device,
        validation: true,
    })
    .unwrap();
    let (format, reversed_z) = o.depth.exec_format();
    let extent = [s.render.width, s.render.height];
    let mut csg = CsgScene::from_scene(
        &ctx,
        &s,
        &EmbedDesc {
            extent,
            reversed_z,
            frames_in_flight: 1,
            algo: Algo::CstI,
            loop_counts: LoopCounts::Learn,
            internal_depth: format,
            samples: 1,
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    shadow::embed_shadows(csg.recorder(), &ctx, o.depth, &s, &light, Algo::CstI)
        .unwrap_or_else(|e| panic!("{e}"));
    let mut host = OffscreenHost::new(&ctx, extent).unwrap();
    let far = if reversed_z { 0.0 } else { 1.0 };
    for _ in 0..2 {
        host.clear(s.render.background, far).unwrap();
        let st = host.frame(csg.recorder()).unwrap_or_else(|e| panic!("{e}"));
        // The shadow pass reads peeltrim's images: the composite fallback.
        let composite = Some(vk::embed::HostPath::CompositeShadows);
        assert_eq!(st.host_path, composite);
    }
    let got = csg.recorder().read_back().unwrap();
    assert!(
        ctx.validation_messages().is_empty(),
        "{:?}",
        ctx.validation_messages()
    );
    let same = (0..got.color.len())
        .filter(|&i| got.color[i] == want.images.color[i])
        .count();
    let dark = want.stats.shadow.as_ref().unwrap().shadowed_pixels;
    eprintln!(
        "embedded shadows: {same} of {} pixels equal ({dark} shadowed)",
        got.color.len()
    );
    assert!(dark > 500, "{dark}");
    assert_eq!(same, got.color.len());
}

/// `--interference` on the GPU (each pair's `A·B` by a CST variant) against the
/// reference's exact interference: pixel sets within 0.1% of the interior pixels
/// (not within a pixel of an edge of the reference's coverage, ids or
/// interference), the same pairs with nearly the same pixel counts.
#[test]
fn interference_matches_the_reference() {
    use peeltrim_cli::render::interference::gpu_interference;
    let s = load("interference.toml");
    let (w, h) = SIZE;
    let want = peeltrim_reference::interference::render_interference(&s, w, h);
    let reference = peeltrim_reference::render(&s, w, h);
    let mut edge = boundary_mask(&reference);
    let (wu, hu) = (w as usize, h as usize);
    for y in 0..hu {
        for x in 0..wu {
            let i = y * wu + x;
            let differs = (y.saturating_sub(1)..(y + 2).min(hu))
                .flat_map(|ny| (x.saturating_sub(1)..(x + 2).min(wu)).map(move |nx| ny * wu + nx))
                .any(|j| want.mask[j] != want.mask[i]);
            edge[i] |= differs;
        }
    }
    assert!(want.pairs.len() == 2, "{:?}", want.pairs);
    for algo in [Algo::CstI, Algo::CstZ, Algo::CstG] {
        let got = gpu_interference(&s, &options(algo)).unwrap_or_else(|e| panic!("{e}"));
        let mask = got.mask();
        let interior = edge.iter().filter(|e| !**e).count();
        let wrong = (0..mask.len())
            .filter(|&i| !edge[i] && mask[i] != want.mask[i])
            .count();
        let shown = want.mask.iter().filter(|m| **m).count();
        eprintln!(
            "interference {algo}: {wrong} of {interior} interior pixels differ; {shown} shown; pairs {:?} (reference {:?})",
            got.pairs, want.pairs
        );
        assert!(shown > 100, "{shown}");
        assert!(wrong as f64 <= 0.001 * interior as f64, "{algo}: {wrong}");
        assert_eq!(got.pairs.len(), want.pairs.len(), "{:?}", got.pairs);
        for (g, r) in got.pairs.iter().zip(&want.pairs) {
            assert_eq!(g.solids, r.solids);
            let d = g.pixels.abs_diff(r.pixels);
            assert!(
                d * 50 <= r.pixels,
                "{algo} {:?}: {} vs {}",
                g.solids,
                g.pixels,
                r.pixels
            );
        }
    }
    // The view itself: the solids' GPU layers semi-transparent in front of the
    // interference, as the reference composites them: within 2/255 at ≥ 99.9%
    // of the interior pixels.
    let (frame, _, _) =
        peeltrim_cli::render::interference::render_interference(&s, &options(Algo::CstI))
            .unwrap_or_else(|e| panic!("{e}"));
    let interior = edge.iter().filter(|e| !**e).count();
    let off = (0..edge.len())
        .filter(|&i| {
            !edge[i] && (0..3).any(|c| frame.images.color[i][c].abs_diff(want.color[i][c]) > 2)
        })
        .count();
    eprintln!("interference colour: {off} of {interior} interior pixels off by more than 2/255");
    assert!(off as f64 <= 0.001 * interior as f64, "{off} of {interior}");
    // Other algorithms say they cannot.
    let e = gpu_interference(&s, &options(Algo::Blister)).unwrap_err();
    assert!(e.to_string().contains("cst-i"), "{e}");
}
