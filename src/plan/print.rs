//! Human-readable printout of a plan (`peeltrim plan`), and its static counts per
//! loop iteration: what one peel layer costs before anything is executed.
#![deny(unsafe_code)]

use std::fmt::Write;

use super::step::*;
use super::Prepared;

/// Static cost of a list of steps, loops counted once.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct StaticCounts {
    /// Draw steps.
    pub draws: u64,
    /// Draws that rasterize meshes (footprint passes included).
    pub mesh_draws: u64,
    /// Draws of a full-screen rectangle.
    pub fullscreen_passes: u64,
    /// Full-screen passes cut to a mesh's footprint ([`Geometry::Footprint`]),
    /// counted in `mesh_draws` too.
    pub footprint_passes: u64,
    /// Triangles the mesh draws rasterize.
    pub triangles: u64,
}

impl StaticCounts {
    fn add(&mut self, o: StaticCounts) {
        self.draws += o.draws;
        self.mesh_draws += o.mesh_draws;
        self.fullscreen_passes += o.fullscreen_passes;
        self.footprint_passes += o.footprint_passes;
        self.triangles += o.triangles;
    }
}

/// The static counts of `steps`: each loop's head and tail counted once.
pub fn count(steps: &[Step], prep: &Prepared) -> StaticCounts {
    let mut c = StaticCounts::default();
    for s in steps {
        match s {
            Step::Draw(d) => {
                c.draws += 1;
                match &d.geometry {
                    Geometry::Mesh(m) => {
                        c.mesh_draws += 1;
                        c.triangles += prep.mesh_triangles[*m as usize] as u64;
                    }
                    Geometry::Meshes(ms) => {
                        c.mesh_draws += 1;
                        c.triangles += prep.triangles_in(ms) as u64;
                    }
                    Geometry::FullScreen { .. } => c.fullscreen_passes += 1,
                    // A full-screen pass over a mesh's footprint: a mesh draw,
                    // as the executor counts it.
                    Geometry::Footprint { mesh, .. } => {
                        c.mesh_draws += 1;
                        c.footprint_passes += 1;
                        c.triangles += prep.mesh_triangles[*mesh as usize] as u64;
                    }
                }
            }
            Step::Loop(l) => {
                c.add(count(&l.head, prep));
                c.add(count(&l.tail, prep));
            }
            _ => {}
        }
    }
    c
}

/// The plan as text, one step a line, with mesh names.
pub fn print(plan: &Plan, prep: &Prepared, names: &[String]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "plan {}: {} depth-stencil image(s), {} depth texture(s), {} stencil bits",
        plan.algo, plan.depth_stencils, plan.textures, plan.stencil_bits
    );
    print_steps(&mut out, &plan.steps, prep, names, 1);
    let c = count(&plan.steps, prep);
    let _ = writeln!(
        out,
        "static counts (loops once): {} draws, {} mesh draws, {} full-screen passes, {} triangles",
        c.draws, c.mesh_draws, c.fullscreen_passes, c.triangles
    );
    if c.footprint_passes > 0 {
        let _ = writeln!(
            out,
            "  and {} full-screen passes cut to a mesh's footprint",
            c.footprint_passes
        );
    }
    out
}

fn mesh_name(names: &[String], m: MeshId) -> &str {
    names.get(m as usize).map(String::as_str).unwrap_or("?")
}

fn print_steps(out: &mut String, steps: &[Step], prep: &Prepared, names: &[String], indent: usize) {
    let pad = "  ".repeat(indent);
    for s in steps {
        match s {
            Step::Pass(n) => {
                let _ = writeln!(out, "{pad}-- {n}");
            }
            Step::Clear(c) => {
                let _ = writeln!(out, "{pad}clear {c:?}");
            }
            Step::CopyTexture { .. }
            | Step::CopyDepthBound { .. }
            | Step::CopyDepthToTexture { .. } => {
                let _ = writeln!(out, "{pad}{}", copy_words(s));
            }
            Step::Loop(l) => {
                let _ = writeln!(out, "{pad}repeat (at most {}) {{", l.max_iterations);
                print_steps(out, &l.head, prep, names, indent + 1);
                let _ = writeln!(out, "{pad}  until no sample passed; then");
                print_steps(out, &l.tail, prep, names, indent + 1);
                let _ = writeln!(out, "{pad}}}");
            }
            Step::Draw(d) => {
                let geo = match &d.geometry {
                    Geometry::Mesh(m) => format!("mesh {}", mesh_name(names, *m)),
                    Geometry::Meshes(ms) => {
                        let n: Vec<&str> = ms.iter().map(|&m| mesh_name(names, m)).collect();
                        format!("meshes [{}]", n.join(" "))
                    }
                    Geometry::FullScreen { depth } => format!("screen@{depth}"),
                    Geometry::Footprint { mesh, depth } => {
                        format!("footprint {}@{depth}", mesh_name(names, *mesh))
                    }
                };
                let st = match &d.stencil {
                    None => "stencil off".to_string(),
                    Some(s) => format!(
                        "stencil {:?} ref {:#04x} cmp {:#04x} wr {:#04x} pass {:?}",
                        s.front.compare, s.reference, s.compare_mask, s.write_mask, s.front.pass
                    ),
                };
                let _ = writeln!(
                    out,
                    "{pad}draw {geo} ds{} depth {:?}{} cull {:?} {st} frag {:?}{}",
                    d.ds,
                    d.depth.compare,
                    if d.depth.write { "+write" } else { "" },
                    d.cull,
                    d.fragment,
                    if d.count_samples { " [query]" } else { "" }
                );
            }
        }
    }
}

/// A copy step in words (`copy tex0 -> tex1`); empty for any other step.
pub(crate) fn copy_words(step: &Step) -> String {
    match step {
        Step::CopyTexture { src, dst } => format!("copy tex{src} -> tex{dst}"),
        Step::CopyDepthBound { src, dst } => {
            format!("copy depth-stencil ds{src} -> ds{dst} (a bound)")
        }
        Step::CopyDepthToTexture { ds, dst } => format!("copy depth ds{ds} -> tex{dst}"),
        _ => String::new(),
    }
}
