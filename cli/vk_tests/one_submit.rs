//! One submission per layered frame: from a session's second frame
//! on, the transparent composite on the GPU (`--alpha`, gear), the layers of an
//! assembly with the opaque image (`--layers 4`), Kirsch's transparent layers
//! and the interference view's layers are each one command buffer submitted
//! once; the third frame replays it without recording; the images are the
//! first (layer by layer) frame's, bit for bit.

use peeltrim::plan::Algo;
use peeltrim::scene::{load, Scene};
use peeltrim::vk::Recorded;
use peeltrim_cli::render::layers::{render_layered_in, LayerOptions, LayeredFrame, LayeredSession};

use crate::setup::options;

fn scene(name: &str, alpha: Option<f64>) -> Scene {
    let path = crate::setup::scenes_dir().join(name);
    let mut s = load(&path, &Default::default()).unwrap_or_else(|e| panic!("{e}"));
    s.render.width = 96;
    s.render.height = 72;
    if alpha.is_some() {
        s.appearance.alpha = alpha;
    }
    s
}

/// Three frames of one session.
fn frames(s: &Scene, algo: Algo, lopts: &LayerOptions) -> Vec<LayeredFrame> {
    let mut session = LayeredSession::default();
    (0..3)
        .map(|_| {
            render_layered_in(&mut session, s, &options(algo), lopts)
                .unwrap_or_else(|e| panic!("{} {}: {e}", s.path.display(), algo.name()))
        })
        .collect()
}

/// The later frames' submissions (`pairs`: one more, the interference pairs'
/// before the layers'), replay and images.
fn assert_one_submit(name: &str, f: &[LayeredFrame], pairs: u64) {
    let exec = |i: usize| &f[i].frame.stats.exec;
    assert_eq!(exec(0).recorded, Recorded::Stepwise, "{name}");
    assert!(
        exec(0).counts.submits > pairs + 1,
        "{name}: {:?}",
        exec(0).counts.submits
    );
    for i in 1..3 {
        assert_eq!(exec(i).counts.submits, pairs + 1, "{name}: frame {}", i + 1);
    }
    assert_eq!(exec(1).recorded, Recorded::New, "{name}");
    if pairs == 0 {
        assert_eq!(exec(2).recorded, Recorded::Replayed, "{name}");
        assert_eq!(exec(2).record_ms, 0.0, "{name}");
    }
    for later in &f[1..] {
        let (a, b) = (&f[0].frame.images, &later.frame.images);
        assert!(a.color == b.color, "{name}: colour differs");
        assert!(a.prim == b.prim, "{name}: primitive ids differ");
        assert!(
            a.depth
                .iter()
                .zip(&b.depth)
                .all(|(x, y)| x.to_bits() == y.to_bits()),
            "{name}: depth differs"
        );
        assert_eq!(
            f[0].layer_stats.layer_pixels,
            later.layer_stats.layer_pixels
        );
        assert_eq!(f[0].layers.len(), later.layers.len());
        for (x, y) in f[0].layers.iter().zip(&later.layers) {
            assert!(x.images.prim == y.images.prim, "{name}: a layer differs");
        }
    }
}

#[test]
fn layered_frames_are_one_submission_after_the_first() {
    let gear = scene("gear.toml", Some(0.5));
    let f = frames(&gear, Algo::CstI, &LayerOptions::default());
    assert_eq!(f[0].layer_stats.composited_on_gpu, Some(true));
    assert_one_submit("gear --alpha 0.5 (cst-i)", &f, 0);

    let four = LayerOptions {
        max_layers: Some(4),
        ..Default::default()
    };
    let assembly = scene("assembly.toml", None);
    assert_one_submit(
        "assembly --layers 4 (cst-g)",
        &frames(&assembly, Algo::CstG, &four),
        0,
    );

    let kirsch = scene("gear.toml", Some(0.5));
    assert_one_submit(
        "gear --alpha 0.5 --layers 4 (kirsch)",
        &frames(&kirsch, Algo::Kirsch, &four),
        0,
    );
}

#[test]
fn interference_layers_are_one_submission_after_the_first() {
    let s = scene("interference.toml", None);
    let f = frames(&s, Algo::CstI, &LayerOptions::default());
    // The pairs' frames, then the layers' (each recorded again: the two have
    // other uploads).
    assert_one_submit("interference (cst-i)", &f, 1);
}
