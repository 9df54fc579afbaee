//! Tolerant draws that cannot meet a tie because nothing they test against
//! holds a partner face (`plan::tie_free`'s per-draw half).
//!
//! A tolerant parity, clip, merge or peel draw of mesh `m` differs from its
//! plain form only where a face of `m` lies within the tie band of the face
//! whose depth the texture (and, for the plain parity and clip tests, the
//! depth-stencil image) holds at that pixel. `plan::tie_free` asks whether
//! `m` has a partner face anywhere in the scene; here the plan itself says
//! which meshes' faces each texture and depth-stencil image may hold when the
//! draw reads it, and the draw is tie-free when none of them is a partner of
//! `m` (`m` itself included, for a thin wall of its own). SCS, for one, draws
//! each product's front faces and exits into a texture cleared per product:
//! complex's base is flush with the upright and the ribs, which are other
//! products, so the base's clip and the upright's, boss's and ribs' merges
//! cannot tie with what they read.
//!
//! Walking the steps in order: a clear empties an image; a draw adds its
//! meshes to the texture its program writes and, when it writes depth, to its
//! depth-stencil image; a copy carries the source's set (a depth bound
//! carries none: it is never read as a surface); a full-screen pass
//! writing depth from a texture carries that texture's, any other leaves the
//! image unknown (every mesh). A loop's body is walked until the sets stop
//! growing, its draws decided on every walk. Draws that are the same in
//! several places are tie-free only where all of them are.

use std::collections::{BTreeSet, HashMap};

use super::step::*;
use super::usage::{color_targets, Resource};

/// A draw as the decisions key it: its meshes, program kind, the images it
/// reads and its tolerance.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct DrawKey {
    meshes: Vec<MeshId>,
    kind: u8,
    tex: Tex,
    ds: Ds,
    eps: u32,
}

impl DrawKey {
    /// The key of a tolerant parity, clip, merge or peel draw of meshes;
    /// `None` for any other draw.
    pub fn of(d: &Draw) -> Option<DrawKey> {
        let meshes = match &d.geometry {
            Geometry::Mesh(m) => vec![*m],
            Geometry::Meshes(ms) => ms.clone(),
            // Constant-depth sweeps are never tolerant draws.
            Geometry::FullScreen { .. } | Geometry::Footprint { .. } => return None,
        };
        let (kind, tex, eps) = match d.fragment {
            Fragment::NearerThan { tex, eps } => (0, tex, eps),
            Fragment::ParityBeforeExit { tex, eps } => (1, tex, eps),
            Fragment::BehindThan { tex, eps } => (2, tex, eps),
            Fragment::MergeBehind { tex, eps } => (3, tex, eps),
            Fragment::PeelTolerant { prev, eps, .. } => (4, prev, eps),
            _ => return None,
        };
        Some(DrawKey {
            meshes,
            kind,
            tex,
            ds: d.ds,
            eps: eps.abs().to_bits(),
        })
    }

    /// Whether the plain form tests against the depth-stencil image (parity
    /// and clip) rather than only the texture (merge and peel keep reading it).
    fn reads_ds(&self) -> bool {
        self.kind <= 2
    }
}

/// The meshes whose faces an image may hold; `None`: any.
type Faces = Option<BTreeSet<MeshId>>;

/// Per tolerant draw of a plan, whether no image it reads can hold a face of
/// a partner of its meshes ([module doc](self)); `partners(m, eps)`: the
/// meshes with a face within the band of tolerance `eps` of one of `m`'s
/// (`m` itself for a thin wall of its own), `None` when unknown.
pub fn decide(
    steps: &[Step],
    partners: &dyn Fn(MeshId, f32) -> Option<Vec<MeshId>>,
) -> HashMap<DrawKey, bool> {
    let mut walk = Walk {
        held: HashMap::new(),
        free: HashMap::new(),
        partners,
    };
    walk.steps(steps);
    walk.free
}

struct Walk<'a> {
    /// Absent: unknown, as `None`.
    held: HashMap<Resource, Faces>,
    free: HashMap<DrawKey, bool>,
    partners: &'a dyn Fn(MeshId, f32) -> Option<Vec<MeshId>>,
}

impl Walk<'_> {
    fn steps(&mut self, steps: &[Step]) {
        for s in steps {
            match s {
                Step::Loop(l) => self.repeat(l),
                Step::Draw(d) => {
                    self.read(d);
                    self.write(d);
                }
                Step::Clear(c) => {
                    let r = match *c {
                        Clear::DepthStencil { ds, .. } => Resource::DepthStencil(ds),
                        Clear::Texture { tex, .. } => Resource::Texture(tex),
                        Clear::Color => continue,
                    };
                    self.held.insert(r, Some(BTreeSet::new()));
                }
                Step::CopyTexture { src, dst } => {
                    let f = self.faces(Resource::Texture(*src));
                    self.held.insert(Resource::Texture(*dst), f);
                }
                // A bound: its depth is never read as a surface where no
                // later draw replaced it.
                Step::CopyDepthBound { dst, .. } => {
                    self.held
                        .insert(Resource::DepthStencil(*dst), Some(BTreeSet::new()));
                }
                Step::CopyDepthToTexture { ds, dst } => {
                    let f = self.faces(Resource::DepthStencil(*ds));
                    self.held.insert(Resource::Texture(*dst), f);
                }
                Step::Pass(_) => {}
            }
        }
    }

    /// A loop: its body walked until the sets settle (each walk deciding its
    /// draws), or every image unknown and one more walk; the loop may stop
    /// after its head, so what follows sees the sets after the head or the
    /// tail.
    fn repeat(&mut self, l: &Loop) {
        let walk = |w: &mut Self| {
            w.steps(&l.head);
            let after_head = w.held.clone();
            w.steps(&l.tail);
            after_head
        };
        let mut after_head = HashMap::new();
        let mut settled = false;
        for _ in 0..8 {
            let before = self.held.clone();
            after_head = walk(self);
            if self.held == before {
                settled = true;
                break;
            }
        }
        if !settled {
            for v in self.held.values_mut() {
                *v = None;
            }
            after_head = walk(self);
        }
        for (r, f) in after_head {
            let now = join(self.held.get(&r).cloned().flatten(), f);
            self.held.insert(r, now);
        }
    }

    /// What `r` may hold: unknown until a clear or a copy says.
    fn faces(&self, r: Resource) -> Faces {
        self.held.get(&r).cloned().flatten()
    }

    /// Decides a tolerant draw from what its images hold now.
    fn read(&mut self, d: &Draw) {
        let Some(key) = DrawKey::of(d) else {
            return;
        };
        let mut read = vec![Resource::Texture(key.tex)];
        if key.reads_ds() {
            read.push(Resource::DepthStencil(d.ds));
        }
        let sets: Option<Vec<&BTreeSet<MeshId>>> = read
            .iter()
            .map(|r| self.held.get(r).and_then(Option::as_ref))
            .collect();
        let eps = f32::from_bits(key.eps);
        let free = sets.is_some_and(|sets| {
            key.meshes.iter().all(|&m| {
                (self.partners)(m, eps)
                    .is_some_and(|ps| ps.iter().all(|p| sets.iter().all(|s| !s.contains(p))))
            })
        });
        let slot = self.free.entry(key).or_insert(true);
        *slot &= free;
    }

    /// Adds what `d` writes to the images it writes.
    fn write(&mut self, d: &Draw) {
        let meshes: Faces = match (&d.geometry, &d.fragment) {
            (Geometry::Mesh(m), _) => Some(BTreeSet::from([*m])),
            (Geometry::Meshes(ms), _) => Some(ms.iter().copied().collect()),
            (
                Geometry::FullScreen { .. },
                Fragment::DepthFromTexture { src } | Fragment::CopyTexel { src, .. },
            ) => self.faces(Resource::Texture(*src)),
            // A constant depth (SCS's reject sweep writes the far plane):
            // unknown, as a full-screen pass's.
            (Geometry::FullScreen { .. } | Geometry::Footprint { .. }, _) => None,
        };
        let mut targets: Vec<Resource> = color_targets(&d.fragment)
            .into_iter()
            .filter(|r| matches!(r, Resource::Texture(_)))
            .collect();
        if d.depth.write {
            targets.push(Resource::DepthStencil(d.ds));
        }
        for r in targets {
            // In place: unknown stays unknown.
            if let Some(slot) = self.held.get_mut(&r) {
                match (slot.as_mut(), &meshes) {
                    (Some(set), Some(ms)) => set.extend(ms),
                    _ => *slot = None,
                }
            }
        }
    }
}

/// Both sets of faces (unknown if either is).
fn join(a: Faces, b: Faces) -> Faces {
    let (mut a, b) = (a?, b?);
    a.extend(b);
    Some(a)
}

#[cfg(test)]
mod tests {
    use super::super::testing::mesh_draw;
    use super::*;

    const EPS: f32 = 1e-6;

    /// Mesh `mesh`'s draw of `fragment`, depth-tested `Less` and written
    /// when `write`.
    fn draw(mesh: MeshId, fragment: Fragment, write: bool) -> Step {
        let mut d = mesh_draw(mesh, fragment);
        if write {
            d.depth = DepthState {
                compare: CompareOp::Less,
                write,
            };
        }
        Step::Draw(d)
    }

    /// Mesh `m`'s front faces into texture 0 and depth-stencil 0.
    fn front(m: MeshId) -> Step {
        draw(m, Fragment::WriteDepth { out: 0 }, true)
    }

    fn clip(m: MeshId) -> Step {
        draw(m, Fragment::BehindThan { tex: 0, eps: EPS }, false)
    }

    fn clears() -> Vec<Step> {
        vec![
            Step::Clear(Clear::DepthStencil {
                ds: 0,
                depth: 1.0,
                stencil: 0,
            }),
            Step::Clear(Clear::Texture { tex: 0, depth: 1.0 }),
        ]
    }

    /// Meshes 0 and 1 are flush (partners); 2 ties with nothing.
    fn flush(m: MeshId, _: f32) -> Option<Vec<MeshId>> {
        Some(match m {
            0 => vec![1],
            1 => vec![0],
            _ => vec![],
        })
    }

    fn free(steps: &[Step], d: &Step) -> Option<bool> {
        let Step::Draw(d) = d else { unreachable!() };
        decide(steps, &flush).get(&DrawKey::of(d)?).copied()
    }

    #[test]
    fn a_draw_is_free_where_what_it_reads_holds_no_partner() {
        // Product of 0 alone, then 0's clip: 1 never reached the images.
        let mut steps = clears();
        steps.extend([front(0), front(2), clip(0)]);
        assert_eq!(free(&steps, &clip(0)), Some(true));
        // Not where 1's faces are in the texture or the depth image.
        let mut steps = clears();
        steps.extend([front(1), front(0), clip(0)]);
        assert_eq!(free(&steps, &clip(0)), Some(false));
        // A clear in between empties them again.
        let mut steps = clears();
        steps.push(front(1));
        steps.extend(clears());
        steps.extend([front(0), clip(0)]);
        assert_eq!(free(&steps, &clip(0)), Some(true));
        // Images never cleared may hold anything.
        assert_eq!(free(&[front(0), clip(0)], &clip(0)), Some(false));
        // Not a tolerant draw: no decision.
        assert_eq!(free(&steps, &front(0)), None);
    }

    #[test]
    fn copies_full_screen_writes_and_repeated_draws_are_followed() {
        // 1 in the depth image, copied into the texture: 0's merge reads it.
        let merge = draw(0, Fragment::MergeBehind { tex: 0, eps: EPS }, true);
        let mut steps = clears();
        steps.extend([
            draw(1, Fragment::Shade, true),
            Step::CopyDepthToTexture { ds: 0, dst: 0 },
            merge.clone(),
        ]);
        assert_eq!(free(&steps, &merge), Some(false));
        // A full-screen depth write of a constant: unknown faces.
        let mut steps = clears();
        steps.push(Step::Draw(Draw {
            geometry: Geometry::FullScreen { depth: 1.0 },
            ..match front(2) {
                Step::Draw(d) => d,
                _ => unreachable!(),
            }
        }));
        steps.push(clip(0));
        assert_eq!(free(&steps, &clip(0)), Some(false));
        // The same draw twice, free once: not free.
        let mut steps = clears();
        steps.extend([front(0), clip(0), front(1), clip(0)]);
        assert_eq!(free(&steps, &clip(0)), Some(false));
    }

    #[test]
    fn a_loop_sees_what_its_later_iterations_and_its_tail_wrote() {
        // 0's peel reads texture 0; 1 writes it later in the body.
        let peel = draw(
            0,
            Fragment::PeelTolerant {
                prev: 0,
                out: 0,
                eps: EPS,
            },
            true,
        );
        let body = |tail: Vec<Step>| {
            let mut steps = clears();
            steps.push(Step::Loop(Loop {
                head: vec![peel.clone()],
                tail,
                max_iterations: 4,
            }));
            steps
        };
        assert_eq!(free(&body(vec![front(2)]), &peel), Some(true));
        assert_eq!(free(&body(vec![front(1)]), &peel), Some(false));
        // After a loop whose tail clears, what follows sees the head's writes.
        let mut steps = body(vec![Step::Clear(Clear::Texture { tex: 0, depth: 1.0 })]);
        steps[2] = Step::Loop(Loop {
            head: vec![front(1)],
            tail: vec![Step::Clear(Clear::Texture { tex: 0, depth: 1.0 })],
            max_iterations: 4,
        });
        steps.push(draw(0, Fragment::MergeBehind { tex: 0, eps: EPS }, true));
        let merge = steps.last().unwrap().clone();
        assert_eq!(free(&steps, &merge), Some(false));
    }
}
