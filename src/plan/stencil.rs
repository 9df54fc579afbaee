//! Stencil rules of the papers as plain [`StencilState`] values: the
//! label/parity layout of Blister and CST (Hable & Rossignac §4, Hilbrich appendix B)
//! and ChangeStencilState (Hable & Rossignac §7), which rewrites a stencil value
//! `src` into `dst` by inverting exactly the bits in which they differ. Pure and
//! GPU-free, so unit tests can check every rule by simulating the stencil unit.
#![deny(unsafe_code)]

use super::step::{CompareOp, StencilFace, StencilOp, StencilState};

/// Stencil layout `[label bits | parity]`: the parity bit is bit 0 and the label
/// occupies the `label_bits` bits above it. Labels `0 .. labels` belong to Blist
/// entries; the two exits follow them, so a pixel whose candidate is in the solid
/// holds `T` and stays *locked* (no later pass compares equal to it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LabelLayout {
    pub labels: u32,
    pub label_bits: u8,
}

/// Where a Blist walk goes next.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Next {
    Label(u32),
    True,
    False,
}

impl LabelLayout {
    /// The smallest layout holding `labels` entry labels and the two exits, or
    /// `None` when it would not fit in 8 stencil bits with the parity bit.
    pub fn new(labels: u32) -> Option<Self> {
        let values = labels + 2;
        let label_bits = (32 - (values - 1).leading_zeros()) as u8;
        (label_bits <= 7).then_some(Self {
            labels,
            label_bits: label_bits.max(1),
        })
    }
    pub const PARITY: u8 = 1;
    /// Bits used in all: labels and parity.
    pub fn stencil_bits(&self) -> u8 {
        self.label_bits + 1
    }
    pub fn label_mask(&self) -> u8 {
        (((1u32 << self.label_bits) - 1) << 1) as u8
    }
    pub fn all_mask(&self) -> u8 {
        self.label_mask() | Self::PARITY
    }
    /// The stencil value of a label with a clear parity bit.
    pub fn value(&self, next: Next) -> u8 {
        let l = match next {
            Next::Label(l) => l,
            Next::True => self.labels,
            Next::False => self.labels + 1,
        };
        (l << 1) as u8
    }
}

/// The same rule on both faces.
pub fn both(
    compare: CompareOp,
    pass: StencilOp,
    compare_mask: u8,
    write_mask: u8,
    reference: u8,
) -> StencilState {
    let face = StencilFace {
        compare,
        fail: StencilOp::Keep,
        pass,
        depth_fail: StencilOp::Keep,
    };
    StencilState {
        front: face,
        back: face,
        compare_mask,
        write_mask,
        reference,
    }
}

/// Test only: pass where `(stencil & mask) == reference`, write nothing.
pub fn test_equal(reference: u8, mask: u8) -> StencilState {
    both(CompareOp::Equal, StencilOp::Keep, mask, 0, reference)
}

/// Test only: pass where `(stencil & mask) != reference`, write nothing.
pub fn test_not_equal(reference: u8, mask: u8) -> StencilState {
    both(CompareOp::NotEqual, StencilOp::Keep, mask, 0, reference)
}

/// ChangeStencilState(src, dst) of Hable & Rossignac §7: where the bits under
/// `compare_mask` equal `src`, invert the bits in which `src` and `dst` differ.
/// Drawn as a full-screen rectangle with depth test off.
pub fn change_stencil_state(src: u8, dst: u8, compare_mask: u8) -> StencilState {
    both(
        CompareOp::Equal,
        StencilOp::Invert,
        compare_mask,
        src ^ dst,
        src,
    )
}

/// Parity toggling: where the bits under `compare_mask` equal `reference`,
/// invert `bit` for every fragment that passes the depth test.
pub fn toggle_parity(reference: u8, compare_mask: u8, bit: u8) -> StencilState {
    both(
        CompareOp::Equal,
        StencilOp::Invert,
        compare_mask,
        bit,
        reference,
    )
}

/// A software stencil unit, for tests: what one fragment that passed (or failed)
/// the depth test does to a stencil value under `state` on a front face.
#[cfg(test)]
pub fn simulate(state: &StencilState, value: u8, depth_pass: bool) -> u8 {
    let f = &state.front;
    let passes = compare(
        f.compare,
        state.reference & state.compare_mask,
        value & state.compare_mask,
    );
    let op = match (passes, depth_pass) {
        (false, _) => f.fail,
        (true, false) => f.depth_fail,
        (true, true) => f.pass,
    };
    let new = match op {
        StencilOp::Keep => value,
        StencilOp::Zero => 0,
        StencilOp::Replace => state.reference,
        StencilOp::IncrementAndClamp => value.saturating_add(1),
        StencilOp::DecrementAndClamp => value.saturating_sub(1),
        StencilOp::Invert => !value,
        StencilOp::IncrementAndWrap => value.wrapping_add(1),
        StencilOp::DecrementAndWrap => value.wrapping_sub(1),
    };
    (new & state.write_mask) | (value & !state.write_mask)
}

/// Vulkan's stencil compare: `reference OP stencil` (both already masked).
#[cfg(test)]
fn compare(op: CompareOp, reference: u8, stencil: u8) -> bool {
    match op {
        CompareOp::Never => false,
        CompareOp::Less => reference < stencil,
        CompareOp::Equal => reference == stencil,
        CompareOp::LessOrEqual => reference <= stencil,
        CompareOp::Greater => reference > stencil,
        CompareOp::NotEqual => reference != stencil,
        CompareOp::GreaterOrEqual => reference >= stencil,
        CompareOp::Always => true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn change_stencil_state_maps_src_to_dst_and_nothing_else() {
        for mask in [0x0fu8, 0x3f, 0xff] {
            for src in 0..=mask {
                for dst in 0..=mask {
                    let s = change_stencil_state(src, dst, mask);
                    for v in 0..=mask {
                        let out = simulate(&s, v, true);
                        if v == src {
                            assert_eq!(out, dst, "src {src} dst {dst}");
                        } else {
                            assert_eq!(out, v);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn layout_sizes() {
        // 1 label + 2 exits -> 2 label bits; 6 labels + 2 -> 3 bits; 126 + 2 -> 7 bits.
        assert_eq!(LabelLayout::new(1).unwrap().label_bits, 2);
        assert_eq!(LabelLayout::new(6).unwrap().label_bits, 3);
        assert_eq!(LabelLayout::new(7).unwrap().label_bits, 4);
        assert_eq!(LabelLayout::new(126).unwrap().stencil_bits(), 8);
        assert!(LabelLayout::new(127).is_none());
        let l = LabelLayout::new(3).unwrap();
        assert_eq!(l.value(Next::True), 6);
        assert_eq!(l.value(Next::False), 8);
        assert_eq!(l.all_mask(), 0x0f); // 3 labels + 2 exits need 3 label bits
    }

    #[test]
    fn parity_toggles_only_matching_label() {
        let l = LabelLayout::new(5).unwrap();
        let s = toggle_parity(l.value(Next::Label(2)), l.label_mask(), LabelLayout::PARITY);
        assert_eq!(simulate(&s, 4, true), 5);
        assert_eq!(simulate(&s, 5, true), 4);
        assert_eq!(simulate(&s, 4, false), 4);
        assert_eq!(simulate(&s, 6, true), 6);
    }
}
