//! What the outputs keep from one frame to the next ([module doc](super)):
//! where an output was last cleared to the value a frame clears
//! it to and not written since, it already holds that value and needs no
//! clear; a recording replayed from other frames assumes what it may
//! ([`assume`], [`holds`]).

use std::collections::BTreeMap;

use super::super::rect::Rect;
use super::super::step::{Clear, Scissor, Step};
use super::super::usage::Resource;
use super::{infos, items, writes, Images, Info, Item};

/// An output image's contents between frames: `value` (a clear) everywhere
/// outside `dirty`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kept {
    pub value: Clear,
    pub dirty: Rect,
}

/// What the outputs hold between frames, by image (an image not listed: unknown).
pub type KeptImages = BTreeMap<Resource, Kept>;

/// What the outputs hold after `steps` run from `before`, whether their clears
/// reach what [`super::frame_reach`] says or whole images: an output cleared in the
/// frame holds its last clear's value outside what is written after it (that
/// clear reaches every pixel earlier frames and this one dirtied); one not
/// cleared gains the frame's writes. Images the frame uses other than as
/// outputs hold nothing known. A frame run loop by loop is described by its
/// loops' head, tail and head again (every write that can follow a clear in
/// the loop follows it there).
pub fn kept_after(
    steps: &[&Step],
    scissor: impl Fn(&Scissor) -> Rect,
    images: Images<'_>,
    before: &KeptImages,
) -> KeptImages {
    let items = items(steps);
    let infos = infos(&items, &scissor, images.normals);
    kept_after_items(&items, &infos, images, before)
}

pub(super) fn kept_after_items(
    items: &[Item<'_>],
    infos: &[Info],
    images: Images<'_>,
    before: &KeptImages,
) -> KeptImages {
    let normals = images.normals;
    let mut kept = before.clone();
    for info in infos {
        for &(r, _) in info.uses.iter() {
            if !images.outputs.contains(&r) {
                kept.remove(&r);
            }
        }
    }
    for &r in images.outputs {
        match writes(items, infos, r, normals) {
            (_, Some(value), after) => {
                kept.insert(
                    r,
                    Kept {
                        value,
                        dirty: after,
                    },
                );
            }
            (all, None, _) => {
                if let Some(k) = kept.get_mut(&r) {
                    k.dirty = k.dirty.union(&all);
                }
            }
        }
    }
    kept
}

/// The outputs' state a recording made for a frame that starts from `now`
/// should assume so that its replays stay valid: `now` widened by the dirty
/// regions the frame itself leaves (`after`), where the values agree. A frame
/// recorded for the result is correct from `now` and from what it leaves.
pub fn assume(now: &KeptImages, after: &KeptImages) -> KeptImages {
    now.iter()
        .filter_map(|(r, k)| {
            let a = after.get(r)?;
            (a.value == k.value).then_some((
                *r,
                Kept {
                    value: k.value,
                    dirty: k.dirty.union(&a.dirty),
                },
            ))
        })
        .collect()
}

/// Whether images holding `now` satisfy what a recording assumed (`assumed`):
/// every output it counts on holds the same value outside a region inside the
/// one assumed.
pub fn holds(now: &KeptImages, assumed: &KeptImages) -> bool {
    assumed.iter().all(|(r, a)| {
        now.get(r).is_some_and(|k| {
            k.value == a.value && (k.dirty.is_empty() || a.dirty.contains(&k.dirty))
        })
    })
}
