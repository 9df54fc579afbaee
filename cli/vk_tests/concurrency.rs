//! Contexts created, used and dropped on several threads at once, as the parallel
//! test harness (or an application with a context per thread) does, with the
//! validation layer on. Creating or destroying an instance or device rewrites the
//! layer's process-wide table that every call through the layer reads
//! (`vk::layer_lock`); without the lock this died of SIGSEGV within seconds
//! (about one run in three of this test on a 2-core machine).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;

use crate::{
    assert_clean, clear_all, context, idx, plan, scene, shade_draw, std_desc, unit_box, H, W,
};
use peeltrim::plan::{Cull, Plan, Step};
use peeltrim::vk::Executor;

/// Rounds of context churn per maker thread (`PEELTRIM_STRESS_ROUNDS`, default 10).
fn rounds() -> usize {
    match std::env::var("PEELTRIM_STRESS_ROUNDS") {
        Err(_) => 10,
        Ok(s) => s
            .parse()
            .unwrap_or_else(|_| panic!("PEELTRIM_STRESS_ROUNDS='{s}': a whole number")),
    }
}

/// The box drawn 400 times, alternately culling back and front faces: a frame
/// records a few thousand commands, each a lookup in the layer's table.
fn many_draws() -> Plan {
    let mut steps = vec![Step::Pass("shade".into())];
    steps.extend(clear_all());
    for i in 0..400 {
        let cull = if i % 2 == 0 { Cull::Back } else { Cull::Front };
        steps.push(Step::Draw(shade_draw(0, cull)));
    }
    plan(steps, 0)
}

#[test]
fn frames_on_some_contexts_while_others_come_and_go() {
    let done = Arc::new(AtomicBool::new(false));
    let plan = many_draws();
    let callers: Vec<_> = (0..2)
        .map(|t| {
            let done = done.clone();
            let plan = plan.clone();
            thread::spawn(move || {
                let ctx = context();
                let mut ex = Executor::new(&ctx, &std_desc()).expect("executor");
                ex.upload(&scene(vec![unit_box()])).expect("upload");
                let mut frames = 0u32;
                // At least a few frames, and frames for as long as the makers run.
                while frames < 3 || !done.load(Ordering::Relaxed) {
                    // Records the frame again (a replay would make few calls).
                    ex.forget_recording();
                    let f = ex.frame(&plan).expect("frame");
                    assert_eq!(f.images.prim[idx(W / 2, H / 2)], 1, "caller {t}");
                    assert_eq!(f.images.prim[idx(0, 0)], 0, "caller {t}");
                    frames += 1;
                }
                drop(ex);
                assert_clean(&ctx);
                frames
            })
        })
        .collect();
    let makers: Vec<_> = (0..2)
        .map(|_| {
            thread::spawn(move || {
                for _ in 0..rounds() {
                    let ctx = context();
                    assert_clean(&ctx);
                }
            })
        })
        .collect();
    for m in makers {
        m.join().expect("contexts come and go");
    }
    done.store(true, Ordering::Relaxed);
    for c in callers {
        let frames = c.join().expect("frames on a long-lived context");
        assert!(frames >= 3, "{frames}");
    }
}

/// The lock itself, at a far higher call rate than frames reach: two threads
/// create and destroy fences on their own long-lived contexts (holding the
/// context's `layer_use`, as a host calling its device does) while two others
/// create and drop contexts. Without the lock this crashed in about one run in
/// three (20 rounds).
#[test]
fn raw_calls_under_the_lock_while_contexts_come_and_go() {
    let done = Arc::new(AtomicBool::new(false));
    let callers: Vec<_> = (0..2)
        .map(|_| {
            let done = done.clone();
            thread::spawn(move || {
                let ctx = context();
                let d = ctx.raw_device();
                let mut calls = 0u64;
                while calls < 100 || !done.load(Ordering::Relaxed) {
                    let _layer = ctx.layer_use();
                    // SAFETY: a live device of a live context; the fence is
                    // destroyed right after, unused.
                    unsafe {
                        let f = d
                            .create_fence(&ash::vk::FenceCreateInfo::default(), None)
                            .expect("a fence");
                        d.destroy_fence(f, None);
                    }
                    calls += 1;
                }
                assert_clean(&ctx);
            })
        })
        .collect();
    let makers: Vec<_> = (0..2)
        .map(|_| {
            thread::spawn(move || {
                for _ in 0..2 * rounds() {
                    assert_clean(&context());
                }
            })
        })
        .collect();
    for m in makers {
        m.join().expect("contexts come and go");
    }
    done.store(true, Ordering::Relaxed);
    for c in callers {
        c.join().expect("fences on a long-lived context");
    }
}
