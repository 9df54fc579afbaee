//! Prints where a plan's draws may touch pixels at 800×800: each mesh's
//! rectangle as the executor derives it (its world box, clipped to the near
//! plane, `vk::scissor::bounds_rect`) next to the box of its vertices'
//! projections (`plan::screen`), then every draw with its pass, mesh, cull,
//! fragment program and scissor rectangle, and the total the bench counts as
//! `mesh_pixels` (docs/bench.md, long
//! products).
//!
//! `cargo run --release --example plan_scissors -- ALGO SCENE`

use peeltrim::plan::step::{Geometry, Step};
use peeltrim::scene::camera::DepthConvention;
use peeltrim::vk::scissor::{bounds_rect, RectUnions};

const SIZE: u32 = 800;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let [_, algo, path] = &args[..] else {
        panic!("usage: plan_scissors ALGO SCENE");
    };
    let algo = peeltrim::Algo::parse(algo).expect("an algorithm name");
    let opts = peeltrim::scene::LoadOptions {
        size: Some((SIZE, SIZE)),
    };
    let scene = peeltrim::scene::load_with(std::path::Path::new(path), &opts, false)
        .unwrap_or_else(|e| panic!("{e}"));
    let prep = peeltrim::plan::Prepared::new(&scene).expect("a plan");
    let plan = peeltrim::plan::build(algo, &prep).expect("a plan");
    let cam = &scene.camera;
    let (view, proj) = (cam.view(), cam.proj(1.0, DepthConvention::Standard));
    let rects: Vec<_> = prep
        .mesh_bounds
        .iter()
        .map(|b| bounds_rect(view, proj, cam.near, std::slice::from_ref(b), SIZE, SIZE))
        .collect();
    let names = scene.mesh_names();
    let vertices = peeltrim::plan::screen::of_scene(&scene);
    for (i, r) in rects.iter().enumerate() {
        let v = vertices.get(i).copied().flatten().map(|b| {
            let (lo, hi) = (b.lo.as_ivec2(), b.hi.as_ivec2());
            (
                lo.x,
                lo.y,
                hi.x,
                hi.y,
                ((b.hi - b.lo).element_product()) as i64,
            )
        });
        println!(
            "mesh {:10} box {:?} {:7}  vertices {v:?}",
            names[i],
            (r.x0, r.y0, r.x1, r.y1),
            r.area()
        );
    }
    // Where each cutter's inside can be seen through an opening
    // (`CutAway::inside_holes`, what `Scissor::Openings` and the final
    // shade's cavity insides are cut to).
    let cut = peeltrim::plan::cut_away::CutAway::of(algo, &prep, &scene);
    let openings: Vec<_> = (0..rects.len() as u32)
        .map(|c| {
            let boxes = cut.inside_holes(c, &prep.mesh_bounds, cam)?;
            Some(bounds_rect(view, proj, cam.near, &boxes, SIZE, SIZE))
        })
        .collect();
    for (i, o) in openings.iter().enumerate() {
        if let Some(o) = o {
            println!(
                "openings {:10} {:?} {:7}",
                names[i],
                (o.x0, o.y0, o.x1, o.y1),
                o.area()
            );
        }
    }
    let unions = RectUnions::new(&rects).with_openings(&openings);
    let mut pass = String::new();
    let total = walk(&plan.steps, &unions, &names, &mut pass);
    println!("total scissor px {total}");
}

/// Prints the draws of `steps` (a loop's head once); returns their pixels.
fn walk(steps: &[Step], unions: &RectUnions, names: &[String], pass: &mut String) -> u64 {
    let mut total = 0;
    for s in steps {
        match s {
            Step::Pass(p) => pass.clone_from(p),
            Step::Loop(l) => total += walk(&l.head, unions, names, pass),
            Step::Draw(d) => {
                let r = unions.scissor(&d.scissor, SIZE, SIZE);
                total += r.area();
                let what = match &d.geometry {
                    Geometry::Mesh(m) => names[*m as usize].clone(),
                    Geometry::Footprint { mesh, .. } => format!("fp:{}", names[*mesh as usize]),
                    g => format!("{g:?}").chars().take(20).collect(),
                };
                let fragment = format!("{:?}", d.fragment);
                let fragment = fragment.split(' ').next().unwrap_or_default();
                println!(
                    "{pass:10} {what:12} {:?} {fragment:22} {:7} {:?}",
                    d.cull,
                    r.area(),
                    (r.x0, r.y0, r.x1, r.y1)
                );
            }
            _ => {}
        }
    }
    total
}
