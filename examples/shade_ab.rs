//! Interleaved A/B timing of the shade and merge passes in one process: for
//! each scene and algorithm, frames of every variant of the plan alternate, so
//! that a shared machine's load falls on all of them alike. Prints the median
//! process CPU time per frame (every thread: lavapipe's rasterizer work; run
//! with `LP_NUM_THREADS=0` to rasterize in this thread).
//!
//! `cargo run --release --example shade_ab -- SIZE FRAMES ALGOS SCENE...`
//!
//! Variants: `plan` (as built); `shaded-merge` (a solid's CST merge shading
//! colour and id, `ShadeAtDepth`, as before `DepthAtDepth`); `no-shade` (the
//! final shade pass left out: a wrong image, the rest of the frame's cost);
//! `plain-shade` (its draws without the tie test: a wrong image, the cost of
//! rasterizing them); `mesh-merge` (Goldfeather's full-screen merges of the
//! surface texture as redraws of the surface at that depth); `unculled-shade`
//! (the shade's depth-equal draws culling nothing, as before
//! `plan::VisibleSides`: the same image). After the CPU time, the median GPU
//! time of the final shade pass per variant.
//! `SHADE_AB=plan,no-shade` picks variants (e.g. one under `perf record`).
//! README, "The shade and merge passes on lavapipe".

#[path = "ab_common/mod.rs"]
mod ab_common;

use ab_common::{for_each_run, median};
use peeltrim::plan::{Cull, Fragment, Geometry, Plan, Scissor, Step};
use peeltrim::vk::Executor;

fn shaded_merge(plan: &Plan) -> Plan {
    let mut p = plan.clone();
    let visit = |s: &mut Step| {
        if let Step::Draw(d) = s {
            if let Fragment::DepthAtDepth { tex } = d.fragment {
                d.fragment = Fragment::ShadeAtDepth { tex };
            }
        }
    };
    for s in &mut p.steps {
        if let Step::Loop(l) = s {
            l.head.iter_mut().chain(l.tail.iter_mut()).for_each(visit);
        } else {
            visit(s);
        }
    }
    p
}

/// Goldfeather's merges (full-screen `DepthFromTexture` of the surface texture
/// after a `merge` pass) as a redraw of the surface's meshes at that depth.
fn mesh_merge(plan: &Plan) -> Plan {
    fn visit(steps: &mut [Step], pass: &mut String) {
        for s in steps {
            match s {
                Step::Pass(n) => *pass = n.clone(),
                Step::Loop(l) => {
                    visit(&mut l.head, pass);
                    visit(&mut l.tail, pass);
                }
                Step::Draw(d) if pass == "merge" => {
                    if let (Fragment::DepthFromTexture { src }, Scissor::BoundsOf(ms)) =
                        (&d.fragment, &d.scissor)
                    {
                        d.geometry = Geometry::Meshes(ms.clone());
                        d.fragment = Fragment::DepthAtDepth { tex: *src };
                        d.cull = Cull::None;
                    }
                }
                _ => {}
            }
        }
    }
    let mut p = plan.clone();
    visit(&mut p.steps, &mut String::new());
    p
}

fn plain_shade(plan: &Plan) -> Plan {
    let mut p = plan.clone();
    for s in &mut p.steps {
        if let Step::Draw(d) = s {
            if let Fragment::ShadeNearDepth { .. } = d.fragment {
                d.fragment = Fragment::Shade;
            }
        }
    }
    p
}

fn unculled_shade(plan: &Plan) -> Plan {
    let mut p = plan.clone();
    for s in &mut p.steps {
        if let Step::Draw(d) = s {
            if let Fragment::ShadeNearDepth { equal_cull, .. } = &mut d.fragment {
                *equal_cull = Cull::None;
            }
        }
    }
    p
}

fn no_shade(plan: &Plan) -> Plan {
    let mut p = plan.clone();
    let at = p
        .steps
        .iter()
        .rposition(|s| matches!(s, Step::Pass(n) if n == "shade"))
        .expect("a shade pass");
    p.steps.truncate(at);
    p
}

fn main() {
    let all: [(&str, fn(&Plan) -> Plan); 6] = [
        ("plan", |p| p.clone()),
        ("unculled-shade", unculled_shade),
        ("shaded-merge", shaded_merge),
        ("plain-shade", plain_shade),
        ("mesh-merge", mesh_merge),
        ("no-shade", no_shade),
    ];
    let pick = std::env::var("SHADE_AB").unwrap_or_default();
    let variants: Vec<_> = all
        .into_iter()
        .filter(|v| pick.is_empty() || pick.split(',').any(|p| p == v.0))
        .collect();
    for_each_run(|ctx, scene, name, algo, built, desc, frames| {
        let plans: Vec<Plan> = variants.iter().map(|v| (v.1)(&built)).collect();
        let mut exs: Vec<Executor> = plans
            .iter()
            .map(|p| {
                let mut e = Executor::new(ctx, desc).expect("executor");
                e.upload(scene).expect("upload");
                e.set_cut_away(ab_common::cut_away(scene, algo));
                for _ in 0..2 {
                    e.execute(p).expect("warm-up");
                }
                e
            })
            .collect();
        let mut cpu = vec![Vec::new(); variants.len()];
        let mut shade = vec![Vec::new(); variants.len()];
        for _ in 0..frames {
            for (i, e) in exs.iter_mut().enumerate() {
                let stats = e.execute(&plans[i]).expect("frame");
                cpu[i].push(stats.frame_cpu_ms);
                let pass = stats.per_pass.iter().rfind(|p| p.name == "shade");
                shade[i].push(pass.map_or(0.0, |p| p.gpu_ms));
            }
        }
        print!("{:16} {:12}", name, algo.name());
        for (i, v) in variants.iter().enumerate() {
            print!("  {}: {:7.2}", v.0, median(cpu[i].clone()));
        }
        print!("  | shade gpu ms");
        for (i, v) in variants.iter().enumerate() {
            print!("  {}: {:6.2}", v.0, median(shade[i].clone()));
        }
        println!();
    });
}
