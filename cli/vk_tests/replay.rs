//! Record once, replay: a moved camera replays the kept recording
//! (only the camera's uniform buffer changes) while every mesh stays inside the
//! scissor it was recorded with, and the replayed images are the images of a
//! frame recorded for that camera, bit for bit, and match the reference.

use glam::DQuat;
use peeltrim::plan::{self, Algo, Prepared};
use peeltrim::scene::{Camera, Scene};
use peeltrim::vk::Recorded;
use peeltrim_cli::render::{DepthSetup, GpuRenderer};
use peeltrim_reference::compare::compare;

use crate::algorithms::{load, SIZE};

/// `cam` orbited by `deg` degrees about its up axis through its target.
fn orbit(cam: &Camera, deg: f64) -> Camera {
    let turn = DQuat::from_axis_angle(cam.up.normalize(), deg.to_radians());
    Camera {
        eye: cam.target + turn * (cam.eye - cam.target),
        ..*cam
    }
}

fn renderer(scene: &Scene) -> GpuRenderer {
    GpuRenderer::new(scene, crate::setup::device(), DepthSetup::D32S8, true)
        .expect("a Vulkan device (lavapipe)")
}

#[test]
fn an_orbiting_camera_replays_the_recording_with_the_images_of_a_fresh_one() {
    let scene = load(&crate::setup::scenes_dir().join("gear.toml"));
    let plan = plan::build(Algo::CstI, &Prepared::new(&scene).unwrap()).unwrap();
    let mut gpu = renderer(&scene);
    let kinds: Vec<Recorded> = (0..2)
        .map(|_| gpu.execute(&plan).unwrap().exec.recorded)
        .collect();
    assert_eq!(kinds, [Recorded::Stepwise, Recorded::New]);
    // The first move leaves the exact scissors: recorded again, with margins.
    gpu.set_camera(&orbit(&scene.camera, 0.5)).unwrap();
    assert_eq!(gpu.execute(&plan).unwrap().exec.recorded, Recorded::Camera);
    // The next one stays inside them: replayed, nothing recorded.
    let moved = orbit(&scene.camera, 1.0);
    gpu.set_camera(&moved).unwrap();
    let replay = gpu.frame(&plan).unwrap();
    assert_eq!(replay.stats.exec.recorded, Recorded::ReplayedMovedCamera);
    assert_eq!(replay.stats.exec.record_ms, 0.0);
    // A camera that stays gets exact scissors again (one recording).
    let still = gpu.frame(&plan).unwrap();
    assert_eq!(still.stats.exec.recorded, Recorded::Camera);
    assert!(
        still.stats.exec.counts.fullscreen_pixels <= replay.stats.exec.counts.fullscreen_pixels
    );

    // The same upload (vertices relative to the same eye), recorded for `moved`.
    let mut fresh = renderer(&scene);
    fresh.set_camera(&moved).unwrap();
    fresh.execute(&plan).unwrap();
    let want = fresh.frame(&plan).unwrap();
    assert_eq!(want.stats.exec.recorded, Recorded::New);
    assert!(
        replay.images == want.images,
        "replayed images differ from a fresh recording's"
    );
    assert!(still.images == want.images);
    let reference = peeltrim_reference::render(
        &Scene {
            camera: moved,
            ..scene.clone()
        },
        SIZE.0,
        SIZE.1,
    );
    let r = compare(&reference, &replay.images).unwrap();
    assert_eq!(r.coverage_mismatch_interior, 0, "{r:?}");
    assert!(r.prim_mismatch_interior_frac <= 0.0001, "{r:?}");
    for g in [&gpu, &fresh] {
        let m = g.validation_messages();
        assert!(m.is_empty(), "validation messages: {m:#?}");
    }
}

/// Re-recording skips what the command buffer already holds: consecutive
/// draws of a plan differ in a few states, not in all of them.
#[test]
fn recording_sets_only_the_state_that_changes() {
    let scene = load(&crate::setup::scenes_dir().join("gear.toml"));
    let plan = plan::build(Algo::Blister, &Prepared::new(&scene).unwrap()).unwrap();
    let mut gpu = renderer(&scene);
    gpu.execute(&plan).unwrap();
    let c = gpu.execute(&plan).unwrap().exec.counts;
    // Every draw used to record 14 state commands and a push (docs/executor.md); now
    // far fewer per draw call.
    let per_call = c.state_commands as f64 / (c.draw_calls + c.fullscreen_passes) as f64;
    eprintln!(
        "blister gear: {} state commands for {} draw calls and {} full-screen passes ({per_call:.2} per draw)",
        c.state_commands, c.draw_calls, c.fullscreen_passes
    );
    assert!(per_call < 4.0, "{per_call} state commands per draw");
    assert!(gpu.validation_messages().is_empty());
}

/// A plan recorded anew (≤ 1 µs per draw) draws what its first
/// recording drew, pixel for pixel, with the same commands. Whatever host
/// memory a driver takes for recorded commands through the command pool's
/// arena (`vk::cmd_arena`) is reused by a re-recording without growing it.
/// How much it takes is the driver's affair (lavapipe: a block per command;
/// SwiftShader: none through the callbacks), so it is printed, not asserted.
#[test]
fn a_plan_recorded_anew_draws_the_images_of_its_first_recording() {
    for (name, algo) in [
        ("gear.toml", Algo::CstI),
        ("complex.toml", Algo::Goldfeather),
    ] {
        let scene = load(&crate::setup::scenes_dir().join(name));
        let plan = plan::build(algo, &Prepared::new(&scene).unwrap()).unwrap();
        let mut gpu = renderer(&scene);
        gpu.execute(&plan).unwrap();
        let first = gpu.frame(&plan).unwrap();
        assert_eq!(first.stats.exec.recorded, Recorded::New);
        // Warm: every chunk a recording needs exists after one.
        assert!(gpu.time_recording(&plan, 1).unwrap().is_some());
        let before = gpu.command_arena();
        let reps = 3;
        let times = gpu.time_recording(&plan, reps).unwrap().unwrap();
        assert_eq!(times.len(), reps as usize);
        let after = gpu.command_arena();
        let c = &first.stats.exec.counts;
        let per_recording = (after.small + after.large - before.small - before.large) / reps as u64;
        eprintln!(
            "{name}: {per_recording} arena blocks per recording of {} draws and {} state commands",
            c.draws, c.state_commands
        );
        assert_eq!(after.chunks, before.chunks, "{name}: the arena grew");
        let again = gpu.frame(&plan).unwrap();
        assert_eq!(again.stats.exec.recorded, Recorded::Replayed);
        assert_eq!(again.stats.exec.counts, first.stats.exec.counts);
        assert!(
            again.images == first.images,
            "{name}: the re-recorded frame differs from the first recording's"
        );
        let m = gpu.validation_messages();
        assert!(m.is_empty(), "validation messages: {m:#?}");
    }
}

/// The loop-by-loop first frame (several submissions) and the unrolled second
/// one (one) time the same passes from their timestamps (`add_gpu_times`):
/// the same passes in the same order, each a share of the frame's GPU time.
#[test]
fn stepwise_and_unrolled_frames_time_the_same_passes() {
    let scene = load(&crate::setup::scenes_dir().join("gear.toml"));
    let plan = plan::build(Algo::Blister, &Prepared::new(&scene).unwrap()).unwrap();
    let mut gpu = renderer(&scene);
    let frames: Vec<_> = (0..2).map(|_| gpu.execute(&plan).unwrap().exec).collect();
    assert_eq!(frames[0].recorded, Recorded::Stepwise);
    assert_eq!(frames[1].recorded, Recorded::New);
    assert!(
        !frames[0].counts.loop_iterations.is_empty() && frames[0].counts.submits > 1,
        "{:?}",
        frames[0].counts
    );
    let names =
        |i: usize| -> Vec<&str> { frames[i].per_pass.iter().map(|p| p.name.as_str()).collect() };
    assert!(names(0).len() > 1, "{:?}", names(0));
    assert_eq!(names(0), names(1));
    for s in &frames {
        let passes: f64 = s.per_pass.iter().map(|p| p.gpu_ms).sum();
        assert!(passes > 0.0, "{:?}", s.per_pass);
        // Work before the first pass counts in the frame's time only.
        assert!(passes <= s.gpu_ms * (1.0 + 1e-9), "{passes} > {}", s.gpu_ms);
        assert!(s.per_pass.iter().all(|p| p.gpu_ms >= 0.0));
    }
    assert!(gpu.validation_messages().is_empty());
}
