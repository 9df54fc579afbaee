//! `bench --embedded`: the embedded frame against the standalone one.

use peeltrim::vk::embed::HostPath;
use peeltrim::Algo;

/// `bench --embedded`'s pairs: at least 15 however few frames are asked for; the
/// embedded frame draws exactly what the standalone one draws (its final shade
/// straight into the host's targets: no composite pass; `coincident`'s few
/// depth-equal pieces write their own depth, with no merge); both timings are
/// read, and the validation layer reports nothing.
#[test]
fn bench_pairs_time_equal_work() {
    use peeltrim::plan::{self, Prepared};
    use peeltrim_cli::bench::embedded::{measure, MIN_PAIRS};
    use peeltrim_cli::render::{DepthSetup, GpuRenderer};
    let mut scene = crate::algorithms::load(&crate::setup::scenes_dir().join("coincident.toml"));
    (scene.render.width, scene.render.height) = (96, 80);
    let plan = plan::build(Algo::Goldfeather, &Prepared::new(&scene).unwrap()).unwrap();
    let mut gpu =
        GpuRenderer::new(&scene, crate::setup::device(), DepthSetup::D32S8, true).unwrap();
    // The work to compare with: the host path keeps every final-shade draw,
    // where a standalone frame shades one-primitive products in their own
    // draw (`plan::direct_shade`): each such draw stands for one of the
    // host's final-shade draws. The first frame learns the loop counts, the
    // second records the replay.
    gpu.execute(&plan).unwrap();
    let alone = gpu.execute(&plan).unwrap().exec;
    let t = measure(&mut gpu, &plan, &scene, Algo::Goldfeather, (1, 3)).unwrap();
    assert_eq!(t.pairs, MIN_PAIRS);
    assert_eq!(t.host_path, Some(HostPath::Direct), "{t:?}");
    // Less the parts of pieces split at their mesh's cutters
    // (`plan::cut_away`), which only the embedded frame draws.
    let c = &alone.counts;
    assert_eq!(
        t.draws - t.split_draws,
        c.draws + c.direct_shade_draws,
        "{t:?}"
    );
    // No depth merge: the depth-equal pieces cost fewer pixels writing
    // their own depth (`record::host::writes_depth`).
    if gpu
        .context()
        .profile()
        .depth_equal_shades(DepthSetup::D32S8.exec_format().0)
    {
        assert!(c.shade_fixed_draws + c.direct_shade_draws > 0, "{alone:?}");
    }
    assert_eq!(t.fullscreen_passes, c.fullscreen_passes, "{t:?}");
    // The host's shade draws the directly shaded meshes again.
    let host_triangles = t.triangles - t.split_triangles;
    match c.direct_shade_draws {
        0 => assert_eq!(host_triangles, c.triangles, "{t:?}"),
        _ => assert!(host_triangles > c.triangles, "{t:?}"),
    }
    for v in [t.standalone_frame_ms_median, t.frame_ms_median, t.ratio] {
        assert!(v > 0.0 && v.is_finite(), "{t:?}");
    }
    // Unix: CPU time is read from the process CPU clock.
    for v in [
        t.standalone_frame_cpu_ms_median,
        t.frame_cpu_ms_median,
        t.cpu_ratio,
    ] {
        assert!(v > 0.0 && v.is_finite(), "{t:?}");
    }
    let msgs = gpu.validation_messages();
    assert!(msgs.is_empty(), "{msgs:?}");
}
