//! The rasterization floor: one plain z-buffered draw of every solid
//! primitive's triangles, back faces culled, depth only, into a cleared depth
//! target (a z-prepass of the scene as if it were not CSG). Every image-based
//! CSG algorithm submits each primitive's triangles at least once and
//! rasterizes its potentially visible faces into a depth buffer (Goldfeather,
//! Hultquist & Fuchs §3; Rossignac & Wu §2), then shades, so no frame of the
//! same scene, size and depth set-up costs less: the bench reports each
//! algorithm's frame as a multiple of it. It is not a CSG image.
#![deny(unsafe_code)]

use super::step::*;
use super::Prepared;

/// The floor's plan for `prep`: clears, then one depth-tested, depth-only
/// draw of all solid meshes, back faces culled.
pub fn plan(prep: &Prepared) -> Plan {
    let mut steps = super::common::init_output(0, 1.0);
    steps.push(Step::Pass("floor".into()));
    if !prep.solid_meshes.is_empty() {
        steps.push(Step::Draw(Draw {
            geometry: Geometry::Meshes(prep.solid_meshes.clone()),
            scissor: Scissor::bounds_of_all(&prep.solid_meshes),
            cull: Cull::Back,
            ds: 0,
            depth: DepthState {
                compare: CompareOp::Less,
                write: true,
            },
            stencil: None,
            fragment: Fragment::None,
            count_samples: false,
        }));
    }
    Plan {
        algo: "floor".into(),
        depth_stencils: 1,
        textures: 0,
        stencil_bits: 0,
        output_ds: 0,
        steps,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::fixtures::block_minus_spheres;

    #[test]
    fn one_draw_of_every_solid_triangle() {
        let scene = block_minus_spheres(3);
        let prep = Prepared::new(&scene).unwrap();
        let p = plan(&prep);
        super::super::validate::validate(&p, prep.mesh_triangles.len() as u32).unwrap();
        let draws: Vec<&Draw> = p
            .steps
            .iter()
            .filter_map(|s| match s {
                Step::Draw(d) => Some(d),
                _ => None,
            })
            .collect();
        assert_eq!(draws.len(), 1);
        assert_eq!(draws[0].geometry.meshes(), &prep.solid_meshes[..]);
        assert_eq!(draws[0].cull, Cull::Back);
        let c = super::super::print::count(&p.steps, &prep);
        let all: usize = prep
            .solid_meshes
            .iter()
            .map(|&m| prep.mesh_triangles[m as usize])
            .sum();
        let all = all as u64;
        assert_eq!(c.triangles, all);
        assert!(!super::super::formats::needs_stencil(&p));
    }
}
