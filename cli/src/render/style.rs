//! Composing `color.png` from the layers of the solid in a [`Style`] (Kirsch,
//! Nienhaus & Döllner §4.5 transparency, §5.3 blueprint composition, §5.4
//! edge-enhanced transparency). Every style composes back to front, as the paper
//! renders its layers as depth sprites: the last layer first, layer 1 last.
//!
//! - `transparent`: `C ← a_k c_k + (1 − a_k) C`, from the background.
//! - `blueprint` (depth-complexity cueing): where layer k covers a pixel,
//!   `C ← mix(C, FILL, FILL_ALPHA)` (the tone deepens with the depth complexity),
//!   and on its edge pixels `C ← mix(C, EDGE, EDGE_ALPHA)` (the paper's alpha =
//!   edge intensity, colour = intensity × a bluish constant; our edge maps are
//!   binary, so the intensity is the constant `EDGE_ALPHA`).
//! - `wireframe`: only edge pixels, replaced (a threshold): hidden edges
//!   `HIDDEN`, visible ones (layer 1) `VISIBLE` on top.
//! - `blueprint-transparent`: as `transparent` with each layer's colour multiplied
//!   by `EDGE_DARKEN` on its edge pixels.
#![deny(unsafe_code)]

use crate::output::Images;
use peeltrim::scene::style::Style;
use peeltrim::scene::Scene;

/// Blueprint fill per covering layer (bluish) and its opacity.
pub const FILL: [u8; 3] = [40, 90, 190];
pub const FILL_ALPHA: f64 = 0.12;
/// Blueprint edge colour and opacity.
pub const EDGE: [u8; 3] = [150, 200, 255];
pub const EDGE_ALPHA: f64 = 0.8;
/// Wireframe colours of visible (layer 1) and hidden edges.
pub const VISIBLE: [u8; 3] = [255, 255, 255];
pub const HIDDEN: [u8; 3] = [80, 130, 220];
/// Edge-enhanced transparency: a layer's colour is multiplied by this on its edges.
pub const EDGE_DARKEN: f64 = 0.15;
/// The opacity of every layer in the transparent styles when the scene gives no
/// `alpha` below 1 (an opaque scene would otherwise show layer 1 only).
pub const DEFAULT_ALPHA: f64 = 0.4;

/// One layer as the styles see it, pixels row-major.
pub struct StyleLayer<'a> {
    /// The layer's shaded colour (the standard shading of its crossing).
    pub color: &'a [[u8; 4]],
    /// Whether the layer has a point at the pixel.
    pub covered: Vec<bool>,
    /// The layer's edge map (empty when the style needs none).
    pub edges: &'a [bool],
    /// The layer's opacity at each pixel (for the transparent styles).
    pub alpha: Vec<f64>,
}

fn mix(c: [f64; 3], to: [u8; 3], a: f64) -> [f64; 3] {
    [0, 1, 2].map(|i| (1.0 - a) * c[i] + a * to[i] as f64)
}

/// `color.png` in `style` from `layers` (layer 1 first) over `background`.
/// `Opaque` is not composed here (the frame's own image is the answer).
pub fn compose(style: Style, layers: &[StyleLayer], background: [u8; 3], n: usize) -> Vec<[u8; 4]> {
    assert!(
        style != Style::Opaque,
        "the opaque style is the frame's own image"
    );
    (0..n)
        .map(|i| {
            let mut c = background.map(|v| v as f64);
            for (k, l) in layers.iter().enumerate().rev() {
                let edge = style.edges() && l.edges[i];
                // The edge rule marks both sides of a silhouette, so an edge
                // pixel may lie just outside the layer: drawn as an edge, without
                // a surface.
                let covered = l.covered[i];
                if !covered && !edge {
                    continue;
                }
                let own = [l.color[i][0], l.color[i][1], l.color[i][2]];
                c = match style {
                    Style::Opaque => unreachable!("checked above"),
                    Style::Transparent | Style::BlueprintTransparent if !covered => c,
                    Style::Transparent => mix(c, own, l.alpha[i]),
                    Style::BlueprintTransparent => {
                        let k = if edge { EDGE_DARKEN } else { 1.0 };
                        let dark = own.map(|v| (v as f64 * k).round() as u8);
                        mix(c, dark, l.alpha[i])
                    }
                    Style::Blueprint => {
                        let filled = if covered { mix(c, FILL, FILL_ALPHA) } else { c };
                        if edge {
                            mix(filled, EDGE, EDGE_ALPHA)
                        } else {
                            filled
                        }
                    }
                    Style::Wireframe if edge => {
                        (if k == 0 { VISIBLE } else { HIDDEN }).map(|v| v as f64)
                    }
                    Style::Wireframe => c,
                };
            }
            let px = |v: f64| v.round().clamp(0.0, 255.0) as u8;
            [px(c[0]), px(c[1]), px(c[2]), 255]
        })
        .collect()
}

/// `color.png` of `scene` in its (layered) style from `layers` (layer 1 first)
/// with their edge maps (empty when the style needs none); the one composition of
/// every producer of layers. `hit(k, i)` names layer k's crossing at pixel i as
/// (0-based primitive, solid whose opacity it takes), `None` where there is none.
/// A layer's opacity is the scene's for that primitive when the scene is
/// see-through, else [`DEFAULT_ALPHA`].
pub fn compose_scene(
    scene: &Scene,
    layers: &[&Images],
    edges: &[Vec<bool>],
    hit: impl Fn(usize, usize) -> Option<(u32, u32)>,
) -> Vec<[u8; 4]> {
    let transparent = scene.appearance.is_transparent();
    let n = scene.render.width as usize * scene.render.height as usize;
    let styled: Vec<StyleLayer> = layers
        .iter()
        .enumerate()
        .map(|(k, l)| StyleLayer {
            color: &l.color,
            covered: l.depth.iter().map(|d| d.is_finite()).collect(),
            edges: edges.get(k).map_or(&[][..], |e| &e[..]),
            alpha: (0..n)
                .map(|i| match hit(k, i) {
                    Some((prim, solid)) if transparent => scene.appearance.alpha_of(prim, solid),
                    Some(_) => DEFAULT_ALPHA,
                    None => 1.0,
                })
                .collect(),
        })
        .collect();
    compose(scene.appearance.style, &styled, scene.render.background, n)
}

#[cfg(test)]
mod tests {
    use super::*;

    const BG: [u8; 3] = [20, 20, 20];

    /// Two layers over 3 pixels: pixel 0 has both, pixel 1 only layer 1, pixel 2
    /// none. Layer 1 is an edge at pixel 0, layer 2 at pixel 0 too.
    fn layers<'a>(
        c1: &'a [[u8; 4]],
        c2: &'a [[u8; 4]],
        e1: &'a [bool],
        e2: &'a [bool],
    ) -> Vec<StyleLayer<'a>> {
        vec![
            StyleLayer {
                color: c1,
                covered: vec![true, true, false],
                edges: e1,
                alpha: vec![0.5; 3],
            },
            StyleLayer {
                color: c2,
                covered: vec![true, false, false],
                edges: e2,
                alpha: vec![0.5; 3],
            },
        ]
    }

    #[test]
    fn transparent_blends_back_to_front() {
        let c1 = [[200, 0, 0, 255]; 3];
        let c2 = [[0, 200, 0, 255]; 3];
        let l = layers(&c1, &c2, &[false; 3], &[false; 3]);
        let out = compose(Style::Transparent, &l, BG, 3);
        // Pixel 0: bg → 0.5 green → 0.5 red: (100 + 5, 50 + 5, 5).
        assert_eq!(out[0], [105, 55, 5, 255]);
        assert_eq!(out[1], [110, 10, 10, 255]);
        assert_eq!(out[2], [20, 20, 20, 255]);
    }

    #[test]
    fn edge_styles_mark_edges_and_wireframe_shows_visible_on_top() {
        let c1 = [[200, 200, 200, 255]; 3];
        let c2 = c1;
        let (e1, e2) = ([true, false, false], [true, false, false]);
        let l = layers(&c1, &c2, &e1, &e2);
        let w = compose(Style::Wireframe, &l, BG, 3);
        assert_eq!(w[0], [255, 255, 255, 255]);
        assert_eq!(w[1], [20, 20, 20, 255]); // covered but no edge
                                             // An edge pixel just outside layer 1 (pixel 2) is still drawn.
        let e1c = [true, false, true];
        let outside = layers(&c1, &c2, &e1c, &e2);
        assert_eq!(
            compose(Style::Wireframe, &outside, BG, 3)[2],
            [255, 255, 255, 255]
        );
        assert_eq!(
            compose(Style::Transparent, &outside, BG, 3)[2],
            [20, 20, 20, 255]
        );
        let (e1b, e2b) = ([false; 3], [true, false, false]);
        let hidden = layers(&c1, &c2, &e1b, &e2b);
        assert_eq!(
            compose(Style::Wireframe, &hidden, BG, 3)[0],
            [80, 130, 220, 255]
        );
        // Blueprint: more layers, deeper tone; edges brighter than fill.
        let b = compose(Style::Blueprint, &hidden, BG, 3);
        assert!(b[0][2] > b[1][2] && b[1][2] > b[2][2], "{b:?}");
        let plain = compose(
            Style::Blueprint,
            &layers(&c1, &c2, &[false; 3], &[false; 3]),
            BG,
            3,
        );
        assert!(b[0][2] > plain[0][2] + 50, "{b:?} {plain:?}");
        // Edge-enhanced transparency darkens exactly the edge pixels.
        let t = compose(Style::Transparent, &l, BG, 3);
        let et = compose(Style::BlueprintTransparent, &l, BG, 3);
        assert!(et[0][0] < t[0][0] / 2, "{et:?} {t:?}");
        assert_eq!(et[1], t[1]);
    }
}
