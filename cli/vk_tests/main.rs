//! Tests that need a Vulkan device (lavapipe in CI), run with validation layers.
//! They create a CPU (lavapipe) context — or the device `PEELTRIM_TEST_DEVICE`
//! names (`setup`) — and fail, not skip, when none exists; every test ends by
//! asserting that the validation layer reported nothing. `rounding` re-runs the
//! algorithms with a coarser device's vertex snapping emulated; `stability` is the
//! numerical-stability suite.

mod algorithms;
mod blueprint;
mod classic;
mod clears;
mod concurrency;
mod cst;
mod depth_only;
mod depth_probe;
mod direct_shade;
mod embed;
mod gpu_layers;
mod indexed;
mod joined_blocks;
mod kirsch;
mod lighting;
mod limits;
mod many_products;
mod msaa;
mod one_submit;
mod openscad;
mod openscad_3d;
mod openscad_extrude;
mod replay;
mod rounding;
mod scad_models;
mod scs;
mod scs_batch;
mod scs_ortho;
mod see_inside;
mod setup;
mod shadow;
mod stability;
mod tie_free;
mod tie_zones;
mod timestamps;
mod view_convex;
mod visible_side;
mod visible_ties;

use glam::{DMat4, DVec3};
use peeltrim::plan::{
    Clear, CompareOp, Cull, DepthState, Draw, Fragment, Geometry, Loop, Plan, Scissor, StencilFace,
    StencilOp, StencilState, Step,
};
use peeltrim::scene::{Camera, Mesh, Primitive, Projection, RenderSettings, Scene, Shape};
use peeltrim::vk::{ClearMode, Context, ContextDesc, DepthFormat, ExecDesc, Executor, Frame};

const W: u32 = 64;
const H: u32 = 48;
const BG: [u8; 3] = [32, 32, 32];
const FOV: f64 = 40.0;

fn context() -> Context {
    let ctx = Context::new(&ContextDesc {
        device: crate::setup::device(),
        validation: true,
    })
    .expect("a Vulkan device (lavapipe unless PEELTRIM_TEST_DEVICE says) with the validation layer is required");
    assert!(ctx.validation_enabled());
    ctx
}

fn assert_clean(ctx: &Context) {
    let m = ctx.validation_messages();
    assert!(m.is_empty(), "validation messages:\n{}", m.join("\n"));
}

/// A box centred at `c` with full extents `s`, 12 CCW-outward triangles.
fn box_mesh(c: DVec3, s: DVec3) -> Mesh {
    let h = s * 0.5;
    let positions = (0..8)
        .map(|i| {
            c + DVec3::new(
                if i & 1 == 0 { -h.x } else { h.x },
                if i & 2 == 0 { -h.y } else { h.y },
                if i & 4 == 0 { -h.z } else { h.z },
            )
        })
        .collect();
    // Quads CCW seen from outside: (-x) 0,4,6,2  (+x) 1,3,7,5  (-y) 0,1,5,4
    // (+y) 2,6,7,3  (-z) 0,2,3,1  (+z) 4,5,7,6
    let quads = [
        [0, 4, 6, 2],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 2, 3, 1],
        [4, 5, 7, 6],
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    Mesh {
        positions,
        triangles,
    }
}

fn prim(name: &str, mesh: Mesh, color: [u8; 3]) -> Primitive {
    Primitive {
        name: name.into(),
        shape: Shape::Box { size: DVec3::ONE },
        transform: DMat4::IDENTITY,
        mesh,
        color,
        used: true,
    }
}

/// Camera at z = 5 looking down −Z.
fn scene(meshes: Vec<Mesh>) -> Scene {
    let colors = [[200, 100, 50], [50, 200, 100], [100, 50, 200]];
    Scene {
        name: None,
        path: "test.toml".into(),
        camera: Camera {
            eye: DVec3::new(0.0, 0.0, 5.0),
            target: DVec3::ZERO,
            up: DVec3::Y,
            projection: Projection::Perspective { fov_y_deg: FOV },
            near: 1.0,
            far: 10.0,
        },
        render: RenderSettings {
            width: W,
            height: H,
            background: BG,
            samples: 1,
        },
        primitives: meshes
            .into_iter()
            .enumerate()
            .map(|(i, m)| prim(&format!("P{i}"), m, colors[i % 3]))
            .collect(),
        solids: vec![],
        surfaces: vec![],
        warnings: vec![],
        appearance: Default::default(),
    }
}

fn unit_box() -> Mesh {
    box_mesh(DVec3::ZERO, DVec3::splat(2.0))
}

/// Is pixel (x, y)'s centre inside the projection of the square |x|,|y| < half at
/// view depth `d`? `None` when within 0.01 px of the edge.
fn inside_square(x: u32, y: u32, half: f64, d: f64) -> Option<bool> {
    let t = (FOV.to_radians() * 0.5).tan();
    let aspect = W as f64 / H as f64;
    let ex = half / (d * t * aspect) * W as f64 * 0.5; // half-width in pixels
    let ey = half / (d * t) * H as f64 * 0.5;
    let px = (x as f64 + 0.5 - W as f64 * 0.5).abs();
    let py = (y as f64 + 0.5 - H as f64 * 0.5).abs();
    if (px - ex).abs() < 0.01 || (py - ey).abs() < 0.01 {
        return None;
    }
    Some(px < ex && py < ey)
}

fn clear_all() -> Vec<Step> {
    vec![
        Step::Clear(Clear::Color),
        Step::Clear(Clear::DepthStencil {
            ds: 0,
            depth: 1.0,
            stencil: 0,
        }),
    ]
}

fn shade_draw(mesh: u32, cull: Cull) -> Draw {
    Draw {
        geometry: Geometry::Mesh(mesh),
        scissor: Scissor::Full,
        cull,
        ds: 0,
        depth: DepthState {
            compare: CompareOp::Less,
            write: true,
        },
        stencil: None,
        fragment: Fragment::Shade,
        count_samples: false,
    }
}

fn plan(steps: Vec<Step>, textures: u8) -> Plan {
    Plan {
        algo: "test".into(),
        depth_stencils: 1,
        textures,
        stencil_bits: 1,
        output_ds: 0,
        steps,
    }
}

fn run(ctx: &Context, desc: ExecDesc, sc: &Scene, p: &Plan) -> Frame {
    let mut ex = Executor::new(ctx, &desc).expect("executor");
    ex.upload(sc).expect("upload");
    ex.frame(p).expect("execute")
}

fn std_desc() -> ExecDesc {
    ExecDesc {
        width: W,
        height: H,
        depth_format: DepthFormat::D32S8,
        reversed_z: false,
        samples: 1,
    }
}

/// The executor of a scene's frame as the renderer sets it up by default:
/// the scene's size, D32S8, reversed Z.
fn scene_desc(sc: &Scene) -> ExecDesc {
    ExecDesc {
        width: sc.render.width,
        height: sc.render.height,
        depth_format: DepthFormat::D32S8,
        reversed_z: true,
        samples: 1,
    }
}

fn one_box_plan(cull: Cull) -> Plan {
    let mut steps = vec![Step::Pass("shade".into())];
    steps.extend(clear_all());
    steps.push(Step::Draw(shade_draw(0, cull)));
    plan(steps, 0)
}

fn idx(x: u32, y: u32) -> usize {
    (y * W + x) as usize
}

#[test]
fn shade_one_box_coverage_depth_prim() {
    let ctx = context();
    let sc = scene(vec![unit_box()]);
    let f = run(&ctx, std_desc(), &sc, &one_box_plan(Cull::Back));
    let im = &f.images;
    assert_eq!((im.width, im.height), (W, H));
    let mut covered = 0;
    for y in 0..H {
        for x in 0..W {
            let i = idx(x, y);
            let Some(inside) = inside_square(x, y, 1.0, 4.0) else {
                continue;
            };
            if inside {
                covered += 1;
                assert_eq!(im.prim[i], 1, "pixel {x},{y}");
                let d = im.depth[i] as f64;
                assert!(((d - 4.0) / 4.0).abs() < 1e-4, "depth {d} at {x},{y}");
                assert_eq!(im.color[i][3], 255);
            } else {
                assert_eq!(im.prim[i], 0, "pixel {x},{y}");
                assert_eq!(im.depth[i], f32::INFINITY);
                assert_eq!(im.color[i], [BG[0], BG[1], BG[2], 255]);
            }
        }
    }
    assert!(covered > 100, "{covered}");
    // The centre pixel looks straight at the face: |n . v| ~ 1, full colour.
    let c = im.color[idx(W / 2, H / 2)];
    for k in 0..3 {
        let want: i32 = [200, 100, 50][k];
        assert!((c[k] as i32 - want).abs() <= 1, "{c:?}");
    }
    assert_eq!(f.stats.counts.draws, 1);
    assert_eq!(f.stats.counts.mesh_draws, 1);
    assert_eq!(f.stats.counts.triangles, 12);
    assert_eq!(f.stats.per_pass.len(), 1);
    assert_eq!(f.stats.per_pass[0].name, "shade");
    assert_eq!(f.stats.per_pass[0].draws, 1);
    assert!(f.stats.gpu_ms >= 0.0 && f.stats.cpu_ms > 0.0);
    assert_clean(&ctx);
}

/// Outward (CCW) faces seen from outside are FRONT: culling back faces shows the
/// near face, culling front faces shows the far face.
#[test]
fn front_face_convention() {
    let ctx = context();
    let sc = scene(vec![unit_box()]);
    let back = run(&ctx, std_desc(), &sc, &one_box_plan(Cull::Back));
    let front = run(&ctx, std_desc(), &sc, &one_box_plan(Cull::Front));
    let none = run(&ctx, std_desc(), &sc, &one_box_plan(Cull::None));
    let c = idx(W / 2, H / 2);
    assert!(
        (back.images.depth[c] - 4.0).abs() < 1e-3,
        "{}",
        back.images.depth[c]
    );
    assert!(
        (front.images.depth[c] - 6.0).abs() < 1e-3,
        "{}",
        front.images.depth[c]
    );
    assert!((none.images.depth[c] - 4.0).abs() < 1e-3);
    assert_eq!(back.images.prim, front.images.prim);
    assert_clean(&ctx);
}

/// A full-screen draw with the depth test off and no fragment output on
/// stencil bit 0: `compare` against `reference`, where it passes `op` (both
/// sides), written where `write` is 1.
fn bit_draw(compare: CompareOp, op: StencilOp, write: u8, reference: u8) -> Draw {
    let face = StencilFace {
        compare,
        fail: StencilOp::Keep,
        pass: op,
        depth_fail: op,
    };
    Draw {
        geometry: Geometry::FullScreen { depth: 0.0 },
        cull: Cull::None,
        depth: DepthState {
            compare: CompareOp::Always,
            write: false,
        },
        stencil: Some(StencilState {
            front: face,
            back: face,
            compare_mask: 1,
            write_mask: write,
            reference,
        }),
        fragment: Fragment::None,
        ..shade_draw(0, Cull::None)
    }
}

/// Invert a stencil bit where a small box is, then reset those pixels with a
/// scissored full-screen background pass that tests the bit.
#[test]
fn stencil_invert_then_background() {
    let ctx = context();
    let small = box_mesh(DVec3::new(0.0, 0.0, 1.5), DVec3::splat(0.5));
    let sc = scene(vec![unit_box(), small]);
    let mut steps = clear_all();
    steps.push(Step::Draw(shade_draw(0, Cull::Back)));
    steps.push(Step::Draw(Draw {
        geometry: Geometry::Mesh(1),
        cull: Cull::Back,
        ..bit_draw(CompareOp::Always, StencilOp::Invert, 1, 0)
    }));
    steps.push(Step::Draw(Draw {
        geometry: Geometry::FullScreen { depth: 0.0 },
        scissor: Scissor::BoundsOf(vec![1]),
        fragment: Fragment::Background,
        ..bit_draw(CompareOp::Equal, StencilOp::Keep, 0, 1)
    }));
    let f = run(&ctx, std_desc(), &sc, &plan(steps, 0));
    let im = &f.images;
    let mut reset = 0;
    for y in 0..H {
        for x in 0..W {
            let i = idx(x, y);
            // The small box's front face: |x|,|y| < 0.25 at view depth 3.25.
            let (Some(in_small), Some(in_big)) = (
                inside_square(x, y, 0.25, 3.25),
                inside_square(x, y, 1.0, 4.0),
            ) else {
                continue;
            };
            let want = if in_small {
                0
            } else if in_big {
                1
            } else {
                0
            };
            assert_eq!(im.prim[i], want, "pixel {x},{y}");
            if in_small {
                reset += 1;
                assert_eq!(im.color[i], [BG[0], BG[1], BG[2], 255]);
            }
        }
    }
    assert!(reset > 4, "{reset}");
    assert_eq!(f.stats.counts.fullscreen_passes, 1);
    let px = f.stats.counts.fullscreen_pixels;
    assert!(px > reset as u64 && px < (W * H) as u64 / 4, "{px}");
    assert_clean(&ctx);
}

fn peel_loop_plan(shade: bool) -> Plan {
    let mut steps = clear_all();
    steps.push(Step::Clear(Clear::Texture { tex: 0, depth: 0.0 }));
    steps.push(Step::Pass("peel".into()));
    steps.push(Step::Loop(Loop {
        head: vec![
            Step::Clear(Clear::DepthStencil {
                ds: 0,
                depth: 1.0,
                stencil: 0,
            }),
            Step::Clear(Clear::Texture { tex: 1, depth: 1.0 }),
            Step::Draw(Draw {
                geometry: Geometry::Meshes(vec![0]),
                scissor: Scissor::BoundsOf(vec![0]),
                fragment: Fragment::Peel {
                    prev: 0,
                    out: 1,
                    shade,
                },
                count_samples: true,
                ..shade_draw(0, Cull::None)
            }),
        ],
        tail: vec![Step::CopyTexture { src: 1, dst: 0 }],
        max_iterations: 10,
    }));
    plan(steps, 2)
}

/// A box has two depth layers: the loop runs its head 3 times (2 layers, 1 empty).
#[test]
fn peel_loop_stops_after_two_layers() {
    let ctx = context();
    let sc = scene(vec![unit_box()]);
    let p = peel_loop_plan(false);
    let f = run(&ctx, std_desc(), &sc, &p);
    assert_eq!(f.stats.counts.loop_iterations, vec![3]);
    assert!(f.stats.counts.samples_counted > 0);
    assert_eq!(f.stats.counts.draws, 3);
    assert_eq!(f.stats.counts.triangles, 36);
    // Deterministic counts: a second run gives the same.
    let g = run(&ctx, std_desc(), &sc, &p);
    assert_eq!(f.stats.counts, g.stats.counts);
    // Reversed Z and the shading variant peel the same layers.
    let r = run(
        &ctx,
        ExecDesc {
            reversed_z: true,
            samples: 1,
            ..std_desc()
        },
        &sc,
        &peel_loop_plan(true),
    );
    assert_eq!(r.stats.counts.loop_iterations, vec![3]);
    assert_eq!(
        r.stats.counts.samples_counted,
        f.stats.counts.samples_counted
    );
    assert_clean(&ctx);
}

/// Depth-stencil image 1 cleared to `clear`, then texture 0's depths written
/// into it by a full-screen draw at `depth` (which `DepthFromTexture` replaces),
/// counting samples with `count`.
fn restore_depth(clear: f32, depth: f32, count: bool) -> [Step; 2] {
    [
        Step::Clear(Clear::DepthStencil {
            ds: 1,
            depth: clear,
            stencil: 0,
        }),
        Step::Draw(Draw {
            geometry: Geometry::FullScreen { depth },
            ds: 1,
            depth: DepthState {
                compare: CompareOp::Always,
                write: true,
            },
            fragment: Fragment::DepthFromTexture { src: 0 },
            count_samples: count,
            ..shade_draw(0, Cull::None)
        }),
    ]
}

/// Peel the first layer, copy it into a depth texture and back into the depth
/// buffer, then shade with depth Equal: the same picture as a plain shade.
#[test]
fn depth_copies_round_trip() {
    let ctx = context();
    let sc = scene(vec![unit_box()]);
    for reversed_z in [false, true] {
        let desc = ExecDesc {
            reversed_z,
            samples: 1,
            ..std_desc()
        };
        let mut steps = clear_all();
        steps.push(Step::Draw(Draw {
            fragment: Fragment::None,
            ..shade_draw(0, Cull::Back)
        }));
        steps.push(Step::CopyDepthToTexture { ds: 0, dst: 0 });
        steps.extend(restore_depth(1.0, 0.5, false));
        steps.push(Step::Draw(Draw {
            ds: 1,
            depth: DepthState {
                compare: CompareOp::Equal,
                write: false,
            },
            ..shade_draw(0, Cull::Back)
        }));
        let mut p = plan(steps, 1);
        p.depth_stencils = 2;
        p.output_ds = 1;
        let f = run(&ctx, desc, &sc, &p);
        let base = run(&ctx, desc, &sc, &one_box_plan(Cull::Back));
        assert_eq!(f.images.prim, base.images.prim, "reversed_z={reversed_z}");
        assert_eq!(f.images.color, base.images.color);
        assert_eq!(f.images.depth, base.images.depth);
    }
    assert_clean(&ctx);
}

/// D24S8, D32S8 and reversed-Z D32S8 agree on coverage and (within a few quanta)
/// depth.
#[test]
fn depth_formats_agree() {
    let ctx = context();
    let sc = scene(vec![
        unit_box(),
        box_mesh(DVec3::new(0.8, 0.3, 0.5), DVec3::new(0.6, 1.2, 3.0)),
    ]);
    let mut steps = clear_all();
    steps.push(Step::Draw(Draw {
        geometry: Geometry::Meshes(vec![0, 1]),
        ..shade_draw(0, Cull::Back)
    }));
    let p = plan(steps, 0);
    let frames: Vec<Frame> = [
        (DepthFormat::D24S8, false),
        (DepthFormat::D32S8, false),
        (DepthFormat::D32S8, true),
    ]
    .into_iter()
    // A device without D24S8 (SwiftShader) compares the two D32S8 conventions.
    .filter(|&(f, _)| {
        let ok = ctx.depth_format_usable(f.vk());
        if !ok {
            eprintln!("note: the device lacks {f:?}: not compared");
        }
        ok
    })
    .map(|(depth_format, reversed_z)| {
        run(
            &ctx,
            ExecDesc {
                depth_format,
                reversed_z,
                samples: 1,
                ..std_desc()
            },
            &sc,
            &p,
        )
    })
    .collect();
    let a = &frames[frames.len() - 2].images;
    assert!(a.prim.contains(&2) && a.prim.contains(&1));
    for f in &frames {
        let b = &f.images;
        let diff = a.prim.iter().zip(&b.prim).filter(|(x, y)| x != y).count();
        assert!(diff <= 2, "{diff} prim mismatches");
        for i in 0..a.depth.len() {
            if a.prim[i] != 0 && a.prim[i] == b.prim[i] {
                let (x, y) = (a.depth[i] as f64, b.depth[i] as f64);
                assert!(((x - y) / x).abs() < 2e-4, "{x} vs {y}");
            }
        }
    }
    assert_clean(&ctx);
}

/// Paint writes the shaded paint colour and the mesh's id; WriteDepth records depths that
/// DepthFromTexture restores, leaving far (empty) pixels untouched.
#[test]
fn paint_write_depth_and_restore() {
    let ctx = context();
    let sc = scene(vec![unit_box()]);
    let mut steps = clear_all();
    steps.push(Step::Clear(Clear::Texture { tex: 0, depth: 1.0 }));
    steps.push(Step::Draw(Draw {
        fragment: Fragment::Paint { rgb: [255, 0, 0] },
        ..shade_draw(0, Cull::Back)
    }));
    steps.push(Step::Draw(Draw {
        depth: DepthState {
            compare: CompareOp::Equal,
            write: false,
        },
        fragment: Fragment::WriteDepth { out: 0 },
        ..shade_draw(0, Cull::Back)
    }));
    steps.extend(restore_depth(0.25, 0.0, true));
    for reversed_z in [false, true] {
        let mut p = plan(steps.clone(), 1);
        p.depth_stencils = 2;
        p.output_ds = 1;
        let desc = ExecDesc {
            reversed_z,
            samples: 1,
            ..std_desc()
        };
        let f = run(&ctx, desc, &sc, &p);
        let base = run(&ctx, desc, &sc, &one_box_plan(Cull::Back));
        assert_eq!(f.images.prim, base.images.prim);
        let covered = f.images.prim.iter().filter(|&&p| p == 1).count() as u64;
        // Only the box's pixels pass the restore draw.
        assert_eq!(f.stats.counts.samples_counted, covered);
        for i in 0..f.images.prim.len() {
            if f.images.prim[i] == 1 {
                // Paint is shaded like the mesh colour (200, 100, 50): same factor.
                let [r, g, b, a] = f.images.color[i];
                let want = base.images.color[i][0] as f64 * 255.0 / 200.0;
                assert!(
                    (r as f64 - want).abs() <= 1.5 && g == 0 && b == 0 && a == 255,
                    "{:?}",
                    f.images.color[i]
                );
                assert_eq!(f.images.depth[i], base.images.depth[i]);
            }
        }
    }
    assert_clean(&ctx);
}

/// Out-of-range ids and nested loops are plan errors, not crashes.
#[test]
fn invalid_plans_are_errors() {
    let ctx = context();
    let sc = scene(vec![unit_box()]);
    let mut ex = Executor::new(&ctx, &std_desc()).expect("executor");
    assert!(
        ex.execute(&one_box_plan(Cull::Back)).is_err(),
        "no scene yet"
    );
    ex.upload(&sc).expect("upload");
    let mut bad = one_box_plan(Cull::Back);
    bad.steps.push(Step::Draw(shade_draw(7, Cull::Back)));
    assert!(ex.execute(&bad).is_err());
    let inner = Loop {
        head: vec![],
        tail: vec![],
        max_iterations: 1,
    };
    let nested = plan(
        vec![Step::Loop(Loop {
            head: vec![Step::Loop(inner)],
            tail: vec![],
            max_iterations: 2,
        })],
        0,
    );
    assert!(ex.execute(&nested).is_err());
    // The executor still works afterwards.
    let f = ex.frame(&one_box_plan(Cull::Back)).expect("execute");
    assert!(f.images.prim.contains(&1));
    drop(ex);
    assert_clean(&ctx);
}

/// An embedding host's device: the wrapped context runs plans and, when dropped,
/// destroys nothing it did not create (the owner's teardown stays clean).
#[test]
fn from_raw_borrows_the_hosts_device() {
    let host = context();
    // SAFETY: the handles come from a live context that outlives `embedded`; it was
    // created with Vulkan 1.3, dynamicRendering and maintenance4; nothing else submits
    // to the queue meanwhile.
    let embedded = unsafe {
        Context::from_raw(
            host.raw_entry().clone(),
            host.raw_instance().clone(),
            host.raw_physical_device(),
            host.raw_device().clone(),
            host.queue_family(),
            host.raw_queue(),
        )
    }
    .expect("from_raw");
    assert_eq!(embedded.device_name(), host.device_name());
    let sc = scene(vec![unit_box()]);
    let f = run(&embedded, std_desc(), &sc, &one_box_plan(Cull::Back));
    assert!(f.images.prim.contains(&1));
    drop(embedded);
    // The host's device still works.
    let g = run(&host, std_desc(), &sc, &one_box_plan(Cull::Back));
    assert_eq!(f.images, g.images);
    assert_clean(&host);
}

/// Peels the union of two boxes, one behind the other from the start camera.
fn two_box_peel() -> (Scene, Plan) {
    let sc = scene(vec![
        box_mesh(DVec3::ZERO, DVec3::ONE),
        box_mesh(DVec3::new(0.0, 0.0, -1.6), DVec3::ONE),
    ]);
    let mut p = peel_loop_plan(true);
    for s in &mut p.steps {
        if let Step::Loop(l) = s {
            for h in &mut l.head {
                if let Step::Draw(d) = h {
                    d.geometry = Geometry::Meshes(vec![0, 1]);
                    d.scissor = Scissor::BoundsOf(vec![0, 1]);
                }
            }
        }
    }
    (sc, p)
}

/// The first frame of a plan learns its loop counts with one submission per head
/// and tail; later frames are one submission of a kept recording (replayed: no
/// recording time), and when a new view changes the depth complexity the check of
/// the GPU's counts falls back, so every image equals a fresh executor's.
#[test]
fn loops_replay_in_one_submission_and_survive_a_changed_depth_complexity() {
    let ctx = context();
    let (mut sc, p) = two_box_peel();
    let mut ex = Executor::new(&ctx, &std_desc()).expect("executor");
    ex.upload(&sc).expect("upload");
    let first = ex.frame(&p).expect("frame");
    // In line: four layers, and a fifth head that finds none.
    assert_eq!(first.stats.counts.loop_iterations, vec![5]);
    assert!(first.stats.counts.submits > 1);
    let second = ex.frame(&p).expect("frame");
    assert_eq!(second.stats.counts.submits, 1);
    assert!(second.stats.record_ms > 0.0);
    assert_eq!(second.images, first.images);
    assert_eq!(second.stats.counts.loop_iterations, vec![5]);
    assert_eq!(
        second.stats.counts.samples_counted,
        first.stats.counts.samples_counted
    );
    let third = ex.frame(&p).expect("frame");
    assert_eq!(third.stats.record_ms, 0.0, "replayed, not recorded");
    assert_eq!(third.stats.counts.submits, 1);
    assert_eq!(third.images, first.images);
    assert!(third.stats.frame_ms > 0.0 && third.stats.frame_ms <= third.stats.cpu_ms);

    // Side by side: two layers. The replayed guess of five fails its check.
    let home = sc.camera;
    sc.camera.eye = DVec3::new(5.0, 0.0, 0.0);
    ex.set_camera(&sc.camera).expect("camera");
    let side = ex.frame(&p).expect("frame");
    assert_eq!(side.stats.counts.loop_iterations, vec![3]);
    // A fresh executor moved the same way runs loop by loop: the reference.
    let mut other = Executor::new(&ctx, &std_desc()).expect("executor");
    let mut at_home = sc.clone();
    at_home.camera = home;
    other.upload(&at_home).expect("upload");
    other.set_camera(&sc.camera).expect("camera");
    let fresh = other.frame(&p).expect("frame");
    assert!(fresh.stats.counts.submits > 1);
    assert_eq!(side.images, fresh.images);
    drop(other);
    let again = ex.frame(&p).expect("frame");
    assert_eq!(again.stats.counts.submits, 1);
    assert_eq!(again.images, fresh.images);
    // Back in line: the guess of three is too few, which the check also sees.
    ex.set_camera(&home).expect("camera");
    let back = ex.frame(&p).expect("frame");
    assert_eq!(back.stats.counts.loop_iterations, vec![5]);
    assert_eq!(back.images, first.images);
    drop(ex);
    assert_clean(&ctx);
}

/// Clears as load ops and as clear commands (the hardware and the CPU
/// rasterizer profiles' ways, `DeviceProfile::clears`) give the same images
/// and counts.
#[test]
fn clear_modes_agree() {
    let ctx = context();
    let (sc, p) = two_box_peel();
    let mut frames = Vec::new();
    for clears in [ClearMode::LoadOp, ClearMode::Command] {
        let profiled = ctx.with_profile(peeltrim::vk::DeviceProfile {
            clears,
            ..*ctx.profile()
        });
        let mut ex = Executor::new(&profiled, &std_desc()).expect("executor");
        ex.upload(&sc).expect("upload");
        ex.frame(&p).expect("frame");
        frames.push(ex.frame(&p).expect("replayed frame"));
    }
    assert_eq!(frames[0].images, frames[1].images);
    assert_eq!(
        frames[0].stats.counts.samples_counted,
        frames[1].stats.counts.samples_counted
    );
    assert!(frames[0].images.prim.contains(&1) && frames[0].images.prim.contains(&2));
    assert_clean(&ctx);
}

/// Meshes that follow each other in the vertex buffer and need no per-mesh
/// constants are one draw call; shading keeps one per mesh (its primitive id).
#[test]
fn contiguous_meshes_share_a_draw_call() {
    let ctx = context();
    let (sc, p) = two_box_peel();
    let mut unshaded = p.clone();
    for s in &mut unshaded.steps {
        if let Step::Loop(l) = s {
            for h in &mut l.head {
                if let Step::Draw(d) = h {
                    d.fragment = Fragment::Peel {
                        prev: 0,
                        out: 1,
                        shade: false,
                    };
                }
            }
        }
    }
    let shaded = run(&ctx, std_desc(), &sc, &p);
    let merged = run(&ctx, std_desc(), &sc, &unshaded);
    assert_eq!(shaded.stats.counts.draw_calls, 2 * 5);
    assert_eq!(merged.stats.counts.draw_calls, 5);
    assert_eq!(merged.stats.counts.triangles, shaded.stats.counts.triangles);
    assert_eq!(
        merged.stats.counts.samples_counted,
        shaded.stats.counts.samples_counted
    );
    assert_clean(&ctx);
}

/// Moving the camera of an uploaded scene renders what a fresh upload with that
/// camera renders (the viewer's orbit path). Not bit-exactly: vertices stay
/// relative to the eye at upload (camera-relative f32 rounding), a fresh upload
/// rounds them relative to the new eye; rasterization may differ on edges only.
#[test]
fn set_camera_equals_a_fresh_upload() {
    let ctx = context();
    let mut sc = scene(vec![unit_box()]);
    let p = one_box_plan(Cull::Back);
    let mut exec = Executor::new(&ctx, &std_desc()).expect("executor");
    exec.upload(&sc).expect("upload");
    let before = exec.frame(&p).expect("frame");
    sc.camera.eye = DVec3::new(1.5, 2.0, 4.5);
    exec.set_camera(&sc.camera).expect("set_camera");
    let moved = exec.frame(&p).expect("frame");
    let fresh = run(&ctx, std_desc(), &sc, &p);
    let r = peeltrim_reference::compare::compare(&fresh.images, &moved.images).expect("same size");
    assert_eq!(
        (r.coverage_mismatch_interior, r.prim_mismatch_interior),
        (0, 0),
        "{r:?}"
    );
    assert!(r.coverage_mismatch <= 8, "{r:?}");
    assert!(r.depth_abs_err_max_interior <= 1e-5, "{r:?}");
    assert_ne!(moved.images, before.images, "the camera did move");
    assert_clean(&ctx);
}
