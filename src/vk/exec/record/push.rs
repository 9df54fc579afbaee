//! Push-constant elision (fewer commands per draw): a draw's push
//! constants are recorded only where a field its shaders read differs from
//! what the command buffer holds.
//!
//! Push constants are command-buffer state that outlives pipeline binds of one
//! layout. Most fields are read by few programs ([`FragmentKind::reads`]):
//! `mvp` only by the full-screen quad (meshes take the camera's matrix), `view`
//! only by the edge pass, `color` by the programs with a colour or a tolerance,
//! `prim` by the shading ones. A draw's unread fields are kept from the last
//! push, so that alternating draws (a trim's mesh draw and full-screen sweep)
//! settle after one push each instead of pushing at every draw.
//!
//! [`FragmentKind::reads`]: crate::vk::pipeline::FragmentKind::reads

use crate::vk::pipeline::{PushConstants, Reads};

/// The push constants the current command buffer holds.
#[derive(Clone, Copy, Debug, Default)]
pub(in crate::vk::exec) struct PushTracker {
    held: Option<PushConstants>,
}

impl PushTracker {
    /// A fresh command buffer: nothing pushed yet.
    pub fn reset(&mut self) {
        self.held = None;
    }

    /// What to push before a draw that wants `want` and reads `reads` of it
    /// (and `flags` and `snap`): `None` when what is held already serves it,
    /// else `want` with its unread fields kept from the last push (now held).
    pub fn next(&mut self, want: &PushConstants, reads: Reads) -> Option<PushConstants> {
        let mut next = *want;
        if let Some(held) = &self.held {
            if !reads.mvp {
                next.mvp = held.mvp;
            }
            if !reads.view {
                next.view = held.view;
            }
            if !reads.color {
                next.color = held.color;
            }
            if !reads.prim {
                next.prim = held.prim;
            }
            if next == *held {
                return None;
            }
        }
        self.held = Some(next);
        Some(next)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vk::pipeline::FragmentKind;

    fn pc(depth: f32, color: [f32; 4]) -> PushConstants {
        let mut mvp = [0.0; 16];
        mvp[14] = depth;
        PushConstants {
            mvp,
            color,
            flags: 1,
            ..Default::default()
        }
    }

    #[test]
    fn the_first_draw_pushes_and_an_equal_one_does_not() {
        let mut t = PushTracker::default();
        assert!(t.next(&pc(0.0, [1.0; 4]), Reads::ALL).is_some());
        assert!(t.next(&pc(0.0, [1.0; 4]), Reads::ALL).is_none());
        // A fresh command buffer holds nothing.
        t.reset();
        assert!(t.next(&pc(0.0, [1.0; 4]), Reads::ALL).is_some());
    }

    #[test]
    fn alternating_draws_settle_after_one_push_each() {
        // A trim: a mesh draw with a tolerance in `color.a` (reads no `mvp`),
        // then a full-screen sweep (reads `mvp`, no colour).
        let mesh = (
            pc(0.5, [0.0, 0.0, 0.0, 1e-6]),
            FragmentKind::NearerThan.reads(),
        );
        let sweep = (
            pc(0.0, [0.2; 4]),
            Reads {
                mvp: true,
                ..FragmentKind::None.reads()
            },
        );
        let mut t = PushTracker::default();
        let mut pushes = 0;
        for _ in 0..5 {
            for (want, reads) in [&mesh, &sweep] {
                if let Some(p) = t.next(want, *reads) {
                    pushes += 1;
                    // What is pushed is what the draw wants in what it reads.
                    if reads.color {
                        assert_eq!(p.color, want.color);
                    }
                    if reads.mvp {
                        assert_eq!(p.mvp, want.mvp);
                    }
                }
            }
        }
        assert_eq!(pushes, 2);
    }

    #[test]
    fn a_read_field_that_differs_is_pushed_again() {
        let mut t = PushTracker::default();
        let reads = FragmentKind::NearerThan.reads();
        t.next(&pc(0.0, [0.0, 0.0, 0.0, 1e-6]), reads);
        let p = t.next(&pc(0.0, [0.0, 0.0, 0.0, 2e-6]), reads);
        assert_eq!(p.map(|p| p.color[3]), Some(2e-6));
        // Flags are read by every draw.
        let mut other = pc(0.0, [0.0, 0.0, 0.0, 2e-6]);
        other.flags = 3;
        assert!(t.next(&other, Reads::default()).is_some());
        // Per-mesh shading reads the primitive id.
        let shade = FragmentKind::Shade.reads();
        let mut a = pc(0.0, [0.5; 4]);
        a.prim = 1;
        t.next(&a, shade);
        a.prim = 2;
        assert!(t.next(&a, shade).is_some());
    }
}
