//! Where a frame's closing timestamp goes (`DeviceProfile::frame_timestamps`):
//! inside the last block (the CPU rasterizer profile's, one scene fewer for
//! lavapipe) or after every command (the hardware profile's). Both must give the same images
//! and counts but the timestamps written inside a block, and a GPU time that
//! is a positive part of the wall time from submission to completion, frame
//! after frame: loop by loop, recorded and replayed. Validation on.

use peeltrim::plan::{self, Algo, Prepared};
use peeltrim::vk::{DeviceProfile, Executor, FrameTimestamps, Recorded};

use crate::algorithms::shipped;
use crate::{assert_clean, context};

/// Three frames of `algo` on the shipped scene `name` with per-pass
/// timestamps off (as the bench times frames), once per way of closing.
fn same_frames(name: &str, algo: Algo) {
    let scene = shipped(name);
    let plan = plan::build(algo, &Prepared::new(&scene).unwrap()).unwrap();
    let ctx = context();
    let desc = crate::scene_desc(&scene);
    let mut runs = Vec::new();
    for frame_timestamps in [FrameTimestamps::Outside, FrameTimestamps::Binned] {
        let profiled = ctx.with_profile(DeviceProfile {
            frame_timestamps,
            ..*ctx.profile()
        });
        let mut ex = Executor::new(&profiled, &desc).expect("executor");
        ex.upload(&scene).expect("upload");
        ex.set_pass_timestamps(false);
        let frames: Vec<_> = (0..3).map(|_| ex.frame(&plan).expect("frame")).collect();
        runs.push(frames);
    }
    let what = format!("{name} {algo}");
    for (i, (after, inside)) in runs[0].iter().zip(&runs[1]).enumerate() {
        let what = format!("{what} frame {i} ({:?})", inside.stats.recorded);
        assert!(after.images == inside.images, "{what}: images differ");
        let (a, b) = (&after.stats.counts, &inside.stats.counts);
        assert_eq!(a.timestamps_in_block, 0, "{what}");
        assert_eq!(
            b.timestamps_in_block, 1,
            "{what}: the last block closes the frame's time: {b:?}"
        );
        // Only where the closing timestamp went differs.
        let mut b2 = b.clone();
        b2.timestamps_in_block = 0;
        assert_eq!(*a, b2, "{what}: other counts differ");
        for s in [&after.stats, &inside.stats] {
            assert!(
                s.gpu_ms > 0.0 && s.gpu_ms <= s.frame_ms * 1.001 + 0.01,
                "{what}: gpu_ms {} against frame_ms {}",
                s.gpu_ms,
                s.frame_ms
            );
        }
    }
    assert_eq!(runs[1][2].stats.recorded, Recorded::Replayed, "{what}");
    drop(runs);
    assert_clean(&ctx);
}

#[test]
fn closing_inside_the_last_block_changes_no_pixel_and_times_the_frame() {
    same_frames("shadow_block", Algo::Scs);
    same_frames("complex", Algo::Goldfeather);
    same_frames("gear", Algo::Blister);
}
