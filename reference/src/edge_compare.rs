//! Comparing two edge maps of the same layer (Kirsch, Nienhaus & Döllner §5; the
//! "blueprint edges" criterion): the fraction of the reference's edge pixels
//! that lie within one pixel of an edge pixel of ours (recall), and the fraction of
//! ours that lie farther than one pixel from every edge pixel of the reference
//! (strays). "Within one pixel" is the 8-neighbourhood (Chebyshev distance ≤ 1),
//! since rasterizers may legitimately place a boundary half a pixel off.
#![deny(unsafe_code)]

use serde::Serialize;

/// How well edge map `ours` matches edge map `reference`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct EdgeAgreement {
    pub reference_edges: u64,
    pub our_edges: u64,
    /// Reference edge pixels with one of ours within one pixel.
    pub reference_matched: u64,
    /// Our edge pixels with none of the reference's within one pixel.
    pub ours_stray: u64,
    /// `reference_matched / reference_edges` (1 when the reference has none).
    pub matched_frac: f64,
    /// `ours_stray / our_edges` (0 when we have none).
    pub stray_frac: f64,
}

/// For each pixel: whether `m` has a set pixel within one pixel (8-neighbourhood).
fn dilate(m: &[bool], w: usize, h: usize) -> Vec<bool> {
    let mut out = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            if !m[y * w + x] {
                continue;
            }
            for ny in y.saturating_sub(1)..(y + 2).min(h) {
                for nx in x.saturating_sub(1)..(x + 2).min(w) {
                    out[ny * w + nx] = true;
                }
            }
        }
    }
    out
}

/// Compares `ours` against `reference`, both `width × height`, row-major.
pub fn compare_edges(reference: &[bool], ours: &[bool], width: u32, height: u32) -> EdgeAgreement {
    let (w, h) = (width as usize, height as usize);
    assert!(
        reference.len() == w * h && ours.len() == w * h,
        "compare_edges: maps do not match {width}x{height}"
    );
    let near_ours = dilate(ours, w, h);
    let near_ref = dilate(reference, w, h);
    let count = |m: &[bool]| m.iter().filter(|&&b| b).count() as u64;
    let both = |a: &[bool], b: &[bool], want: bool| {
        a.iter().zip(b).filter(|&(&x, &y)| x && y == want).count() as u64
    };
    let (reference_edges, our_edges) = (count(reference), count(ours));
    let reference_matched = both(reference, &near_ours, true);
    let ours_stray = both(ours, &near_ref, false);
    EdgeAgreement {
        reference_edges,
        our_edges,
        reference_matched,
        ours_stray,
        matched_frac: if reference_edges == 0 {
            1.0
        } else {
            reference_matched as f64 / reference_edges as f64
        },
        stray_frac: if our_edges == 0 {
            0.0
        } else {
            ours_stray as f64 / our_edges as f64
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 20x20 map with the vertical line x = `col` over rows 2..18.
    fn line(col: usize) -> Vec<bool> {
        let mut m = vec![false; 400];
        for y in 2..18 {
            m[y * 20 + col] = true;
        }
        m
    }

    #[test]
    fn identical_and_one_pixel_shift_agree() {
        let a = line(10);
        let r = compare_edges(&a, &a, 20, 20);
        assert_eq!((r.reference_edges, r.our_edges), (16, 16));
        assert_eq!((r.matched_frac, r.stray_frac), (1.0, 0.0));
        let r = compare_edges(&a, &line(11), 20, 20);
        assert_eq!((r.matched_frac, r.stray_frac), (1.0, 0.0));
    }

    #[test]
    fn two_pixel_shift_misses_and_strays() {
        let r = compare_edges(&line(10), &line(12), 20, 20);
        assert_eq!((r.reference_matched, r.ours_stray), (0, 16));
        assert_eq!((r.matched_frac, r.stray_frac), (0.0, 1.0));
        // Ours has half the line plus a far-off extra edge.
        let mut ours = line(10);
        for y in 10..18 {
            ours[y * 20 + 10] = false;
        }
        ours[5 * 20 + 2] = true;
        let r = compare_edges(&line(10), &ours, 20, 20);
        // Rows 2..10 matched directly, row 10 through the diagonal neighbour row 9.
        assert_eq!(r.reference_matched, 9);
        assert_eq!(r.ours_stray, 1);
        assert!((r.matched_frac - 9.0 / 16.0).abs() < 1e-12);
        assert!((r.stray_frac - 1.0 / 9.0).abs() < 1e-12);
    }

    #[test]
    fn empty_maps() {
        let none = vec![false; 400];
        let r = compare_edges(&none, &none, 20, 20);
        assert_eq!((r.matched_frac, r.stray_frac), (1.0, 0.0));
        let r = compare_edges(&line(3), &none, 20, 20);
        assert_eq!((r.matched_frac, r.stray_frac), (0.0, 0.0));
    }
}
