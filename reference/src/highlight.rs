//! Highlighted primitives (Hable & Rossignac Fig. 1b, §6): the trimmed faces of
//! chosen primitives — the part of their boundary that is the solid's boundary, i.e.
//! the layers whose primitive they are — drawn in a highlight colour: opaque where
//! such a face is the visible layer, as a see-through ghost over the image where
//! it is hidden behind other faces.
#![deny(unsafe_code)]

use super::layers::LayerHit;
use peeltrim::images::shade;

/// The highlight colour.
pub const HIGHLIGHT_RGB: [u8; 3] = [255, 48, 160];
/// Opacity of a hidden highlighted face over the image.
pub const GHOST_ALPHA: f64 = 0.5;

/// What a pixel's highlight did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Highlighted {
    No,
    /// A highlighted face is the pixel's first layer.
    Visible,
    /// A highlighted face lies behind the first layer.
    Hidden,
}

/// The highlighted colour of a pixel whose image colour is `base` and whose
/// layers are `hits`; `chosen[p]` marks the highlighted primitives (0-based).
pub fn highlight_pixel(
    hits: &[LayerHit],
    base: [u8; 4],
    chosen: &[bool],
) -> ([u8; 4], Highlighted) {
    let Some((k, hit)) = hits
        .iter()
        .enumerate()
        .find(|(_, h)| chosen.get(h.prim as usize).copied().unwrap_or(false))
    else {
        return (base, Highlighted::No);
    };
    highlight_at(k, shade(HIGHLIGHT_RGB, hit.cos), base)
}

/// The pixel's colour when its first highlighted face is layer `k` (0-based),
/// shaded `c` in the highlight colour, over the image colour `base`: opaque when
/// it is the first layer, a see-through ghost otherwise.
pub fn highlight_at(k: usize, c: [u8; 4], base: [u8; 4]) -> ([u8; 4], Highlighted) {
    if k == 0 {
        return (c, Highlighted::Visible);
    }
    let mix =
        |i: usize| (GHOST_ALPHA * c[i] as f64 + (1.0 - GHOST_ALPHA) * base[i] as f64).round() as u8;
    ([mix(0), mix(1), mix(2), 255], Highlighted::Hidden)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit(prim: u32, depth: f64) -> LayerHit {
        LayerHit {
            depth,
            prim,
            solid: 0,
            entering: true,
            cos: 1.0,
            normal: [0.0, 0.0, 1.0],
        }
    }

    #[test]
    fn visible_hidden_and_untouched() {
        let base = [10, 20, 30, 255];
        let chosen = [false, true];
        let hits = [hit(0, 1.0), hit(1, 2.0)];
        let (c, h) = highlight_pixel(&hits, base, &chosen);
        assert_eq!(h, Highlighted::Hidden);
        assert_eq!(c, [133, 34, 95, 255]); // (255+10)/2, (48+20)/2, (160+30)/2, rounded
        let (c, h) = highlight_pixel(&hits[1..], base, &chosen);
        assert_eq!((c, h), ([255, 48, 160, 255], Highlighted::Visible));
        assert_eq!(
            highlight_pixel(&hits[..1], base, &chosen),
            (base, Highlighted::No)
        );
        assert_eq!(highlight_pixel(&[], base, &chosen), (base, Highlighted::No));
    }
}
