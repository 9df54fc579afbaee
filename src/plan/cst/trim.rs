//! Trim(V) against a plain Blist (Hable & Rossignac §4; cst-z and cst-i): per entry,
//! parity draws and ChangeStencilState sweeps; and the [`Trimmer`] interface the CST
//! loop drives (cst-g's is in [`super::group`]).
#![deny(unsafe_code)]

use super::super::common::{next, sweep};
use super::super::stencil::{self, LabelLayout, Next};
use super::super::step::*;
use super::{parity_draw, tie_draws, Peeled, TrimVolume, WORK};
use crate::csg::BlistEntry;
use crate::plan::PlanError;

/// Trim(V) against a plain Blist (Hable & Rossignac §4): per entry, its parity
/// draw(s) and two ChangeStencilState sweeps (parity set → the literal's "in" target,
/// clear → "out"). The tie rules of [`tie_draws`] are written for candidates on a
/// front face of the peeled literal, which is all a solid's leaf peels.
fn trim_blist(peeled: &Peeled, vol: &TrimVolume, layout: &LabelLayout, steps: &mut Vec<Step>) {
    let label_mask = layout.label_mask();
    let all_mask = layout.all_mask();
    for (e, &rel) in vol.blist.entries.iter().zip(&vol.relation) {
        let here = layout.value(Next::Label(e.label));
        let (on_inside, on_outside) = entry_targets(e);
        for (compare, cull) in tie_draws(peeled, e.prim, e.leaf, e.negated, rel) {
            steps.push(parity_draw(
                e.prim,
                peeled.prim,
                compare,
                cull,
                stencil::toggle_parity(here, label_mask, LabelLayout::PARITY),
            ));
        }
        steps.extend(literal_sweeps(
            e.prim,
            peeled.prim,
            here,
            LabelLayout::PARITY,
            (layout.value(on_inside), layout.value(on_outside)),
            all_mask,
        ));
    }
}

/// The ChangeStencilState sweeps that follow a literal's parity draws: pixels at
/// `here` with `parity` set go to the "inside" value, the others to the
/// "outside" one (`to`). The parity-set sweep is scissored to where the
/// literal's mesh drew (inside the peeled leaf's rectangle too), the other to
/// the leaf's. A target that reuses `here` (label reuse, Hable & Rossignac Fig. 11)
/// needs no sweep of its own, only the parity cleared — after the other rule moved
/// its pixels, so they are not swept again.
pub(crate) fn literal_sweeps(
    prim: MeshId,
    peeled: MeshId,
    here: u8,
    parity: u8,
    to: (u8, u8),
    all_mask: u8,
) -> Vec<Step> {
    let (on_inside, on_outside) = to;
    let inside = sweep(
        WORK,
        Scissor::Overlap {
            of: vec![prim],
            and: vec![peeled],
        },
        stencil::change_stencil_state(here | parity, on_inside, all_mask),
    );
    let outside = sweep(
        WORK,
        Scissor::BoundsOf(vec![peeled]),
        stencil::change_stencil_state(here, on_outside, all_mask),
    );
    if on_inside == here {
        vec![outside, inside]
    } else if on_outside == here {
        vec![inside]
    } else {
        vec![inside, outside]
    }
}

/// Targets of an entry for a point inside / outside its mesh.
pub(crate) fn entry_targets(e: &BlistEntry) -> (Next, Next) {
    if e.negated {
        (next(e.if_false), next(e.if_true))
    } else {
        (next(e.if_true), next(e.if_false))
    }
}

/// The stencil values one trim reads and writes, from its layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Codes {
    /// Stencil value of an unlocked pixel about to be classified (parity clear).
    pub start: u8,
    /// Stencil value of a locked pixel (candidate in V).
    pub locked: u8,
    /// Stencil value of a rejected pixel after the trim.
    pub rejected: u8,
    /// All stencil bits in use.
    pub mask: u8,
    /// How many stencil bits the trim needs.
    pub bits: u8,
}

impl Codes {
    /// The codes of a layout whose walk targets have the stencil values `value`
    /// gives, starting at `start`.
    pub fn new(start: Next, value: impl Fn(Next) -> u8, mask: u8, bits: u8) -> Self {
        Codes {
            start: value(start),
            locked: value(Next::True),
            rejected: value(Next::False),
            mask,
            bits,
        }
    }
}

/// How Trim(V) is done for one CST, with the stencil values it needs.
pub trait Trimmer {
    /// The stencil values of this trim.
    fn codes(&self) -> Codes;
    /// Appends the trim's steps.
    fn trim(&self, steps: &mut Vec<Step>);
}

pub(crate) struct BlistTrimmer<'a> {
    pub(crate) peeled: Peeled,
    pub(crate) vol: &'a TrimVolume,
    pub(crate) layout: LabelLayout,
}

impl<'a> BlistTrimmer<'a> {
    /// The trimmer of `peeled` against `vol`'s Blist, its labels in the fewest
    /// stencil bits, starting at the first entry's label.
    pub(crate) fn new(peeled: Peeled, vol: &'a TrimVolume) -> Result<Self, PlanError> {
        let layout = LabelLayout::new(vol.blist.num_labels).ok_or(PlanError::TooManyLabels {
            labels: vol.blist.num_labels,
        })?;
        Ok(BlistTrimmer {
            peeled,
            vol,
            layout,
        })
    }
}

impl Trimmer for BlistTrimmer<'_> {
    fn codes(&self) -> Codes {
        let l = &self.layout;
        Codes::new(
            Next::Label(self.vol.blist.entries[0].label),
            |n| l.value(n),
            l.all_mask(),
            l.stencil_bits(),
        )
    }
    fn trim(&self, steps: &mut Vec<Step>) {
        trim_blist(&self.peeled, self.vol, &self.layout, steps)
    }
}
