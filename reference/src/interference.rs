//! Interference of an assembly's solids, exactly (Hable & Rossignac §6; the GPU
//! computes it as `(A−B')+(B−A')`): along each pixel's line, the nearest point where
//! the line enters the intersection of two solids is drawn opaque in the
//! interference colour, the solids' layers in front of it semi-transparent; and
//! per pair of solids, the pixels whose line meets their intersection.
#![deny(unsafe_code)]

use rayon::prelude::*;

use super::layers::{blend, LayerHit, Layers, Scratch};
use peeltrim::images::shade;
use peeltrim::scene::Scene;

/// The colour of an interference.
pub const INTERFERENCE_RGB: [u8; 3] = [255, 40, 40];
/// Opacity of a solid's layers in front of an interference (or of all of them
/// where there is none), unless its `alpha` says less than 1.
pub const SOLID_ALPHA: f64 = 0.3;

/// A pair of solids that interfere, and on how many pixels.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct InterferingPair {
    pub solids: [String; 2],
    pub pixels: u64,
}

/// The interference image of a `width × height` frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Interference {
    pub color: Vec<[u8; 4]>,
    /// 1 where the pixel shows an interference, else 0 (row-major).
    pub mask: Vec<bool>,
    /// Pairs with at least one pixel, in solid order.
    pub pairs: Vec<InterferingPair>,
}

/// Renders the interference view of `scene`.
pub fn render_interference(scene: &Scene, width: u32, height: u32) -> Interference {
    let layers = Layers::new(scene);
    let tol = layers.prep.tol;
    let bg = scene.render.background;
    let alpha = |h: &LayerHit| {
        let a = scene.appearance.alpha_of(h.prim, h.solid);
        if a < 1.0 {
            a
        } else {
            SOLID_ALPHA
        }
    };
    type Px = ([u8; 4], Option<LayerHit>, Vec<bool>);
    let px: Vec<Px> = (0..height)
        .into_par_iter()
        .map_init(Scratch::default, |s, y| {
            (0..width)
                .map(|x| {
                    let mut hits = Vec::new();
                    let (fx, fy) = (x as f64 + 0.5, y as f64 + 0.5);
                    layers.cast_with(s, fx, fy, width, height, usize::MAX, &mut hits);
                    let color = match s.clash {
                        None => blend(scene, &hits, alpha, bg),
                        Some(c) => {
                            let front = hits.iter().take_while(|h| h.depth < c.depth - tol);
                            let n = front.count();
                            let back = shade(INTERFERENCE_RGB, c.cos);
                            blend(scene, &hits[..n], alpha, [back[0], back[1], back[2]])
                        }
                    };
                    (color, s.clash, s.pairs_hit.clone())
                })
                .collect::<Vec<_>>()
        })
        .flatten()
        .collect();
    let pairs = layers
        .pairs
        .iter()
        .enumerate()
        .map(|(pi, &(a, b))| InterferingPair {
            solids: [a, b].map(|i| scene.solids[i as usize].name.clone()),
            pixels: px.iter().filter(|p| p.2[pi]).count() as u64,
        })
        .filter(|p| p.pixels > 0)
        .collect();
    Interference {
        color: px.iter().map(|p| p.0).collect(),
        mask: px.iter().map(|p| p.1.is_some()).collect(),
        pairs,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use peeltrim::scene::fixtures::*;
    use peeltrim::scene::{Projection, Solid};

    /// Boxes a = [-1,1]³ and b = [0,2]×[-0.5,0.5]×[-1,0.5] in two solids, c far
    /// away in a third: a and b interfere on x ∈ (0, 1), |y| < 0.5; c with none.
    #[test]
    fn pairs_and_pixels_of_two_overlapping_boxes() {
        let mut c = camera(DVec3::new(0.0, 0.0, 5.0), DVec3::ZERO, 40.0, 0.1, 100.0);
        c.projection = Projection::Orthographic { height: 6.0 };
        let bx = |lo: [f64; 3], hi: [f64; 3]| box_mesh(DVec3::from(lo), DVec3::from(hi));
        let leaf = |i: u32| {
            let mut e = ExprBuilder::default();
            let l = e.leaf(i);
            e.build(l)
        };
        let mut sc = scene(
            c,
            vec![
                prim("a", bx([-1.0; 3], [1.0; 3]), [200, 200, 200]),
                prim("b", bx([0.0, -0.5, -1.0], [2.0, 0.5, 0.5]), [0, 0, 200]),
                prim("c", bx([-2.9, 2.0, 0.0], [-2.0, 2.9, 1.0]), [0, 200, 0]),
            ],
            leaf(0),
        );
        for (i, n) in [(1, "b"), (2, "c")] {
            sc.solids.push(Solid {
                name: n.into(),
                expr: leaf(i),
            });
        }
        // 60 × 60 pixels of 0.1: x ∈ (0, 1) is 10 columns, |y| < 0.5 10 rows.
        let img = render_interference(&sc, 60, 60);
        assert_eq!(
            img.pairs,
            vec![InterferingPair {
                solids: ["csg".into(), "b".into()],
                pixels: 100
            }]
        );
        assert_eq!(img.mask.iter().filter(|&&m| m).count(), 100);
        let i = 25 * 60 + 35; // x = 0.55, y = 0.45
        assert!(img.mask[i]);
        // a's front face (z = 1, alpha 0.3) over the opaque clash at z = 0.5.
        let k = |c: f64, h: f64| (0.3 * c + 0.7 * h).round() as u8;
        assert_eq!(
            img.color[i],
            [k(200.0, 255.0), k(200.0, 40.0), k(200.0, 40.0), 255]
        );
        assert!(!img.mask[25 * 60 + 15]); // x = -1.45: a only
                                          // b sticking out of a (x = 1.55): no clash, b's two faces at alpha 0.3.
        let j = 25 * 60 + 45;
        assert!(!img.mask[j]);
        let bg: f64 = 20.0; // fixture background [10, 20, 30], green channel
        let g = (0.3 * 0.0 + 0.7 * 0.3 * 0.0 + 0.49 * bg).round() as u8;
        assert_eq!(img.color[j][1], g);
    }
}
