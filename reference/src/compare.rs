//! The metrics of `compare` (docs/cli.md): coverage and primitive-id mismatches and
//! depth errors between two renders of the same scene, plus `*_interior` variants
//! that ignore pixels within one pixel (8-neighbourhood) of a coverage or
//! primitive-id boundary of the first image, where a half-pixel difference in
//! rasterization legitimately flips pixels.

use serde::{Deserialize, Serialize};

use peeltrim::Images;

#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    #[error("image sizes differ: {0}x{1} against {2}x{3}")]
    SizeMismatch(u32, u32, u32, u32),
    #[error("image buffers do not match the stated size {0}x{1}")]
    BadBuffers(u32, u32),
}

/// The `compare` output. Depth errors are over pixels covered in both images (0 when
/// there are none); fractions are over all `pixels`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompareReport {
    pub pixels: u64,
    pub coverage_mismatch: u64,
    pub coverage_mismatch_frac: f64,
    pub prim_mismatch: u64,
    pub prim_mismatch_frac: f64,
    /// Pixels covered in both.
    pub covered_both: u64,
    pub depth_abs_err_max: f64,
    pub depth_abs_err_p99: f64,
    pub depth_abs_err_mean: f64,
    /// Pixels not within one pixel of a boundary of the first image.
    pub interior_pixels: u64,
    pub coverage_mismatch_interior: u64,
    pub coverage_mismatch_interior_frac: f64,
    pub prim_mismatch_interior: u64,
    pub prim_mismatch_interior_frac: f64,
    pub depth_abs_err_max_interior: f64,
    pub depth_abs_err_p99_interior: f64,
    pub depth_abs_err_mean_interior: f64,
}

fn covered(depth: f32, prim: u16) -> bool {
    prim != 0 || depth.is_finite()
}

/// (max, p99 by nearest rank, mean); zeros for no samples.
fn stats(mut e: Vec<f64>) -> (f64, f64, f64) {
    if e.is_empty() {
        return (0.0, 0.0, 0.0);
    }
    e.sort_unstable_by(f64::total_cmp);
    let n = e.len();
    let rank = ((0.99 * n as f64).ceil() as usize).clamp(1, n);
    (e[n - 1], e[rank - 1], e.iter().sum::<f64>() / n as f64)
}

/// Pixels of `a` within one pixel (8-neighbourhood) of a coverage or id change.
pub fn boundary_mask(a: &Images) -> Vec<bool> {
    let (w, h) = (a.width as usize, a.height as usize);
    let key = |i: usize| (covered(a.depth[i], a.prim[i]), a.prim[i]);
    let mut m = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let k = key(y * w + x);
            'n: for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let (nx, ny) = (x as i64 + dx, y as i64 + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    if key(ny as usize * w + nx as usize) != k {
                        m[y * w + x] = true;
                        break 'n;
                    }
                }
            }
        }
    }
    m
}

/// Compares `b` against `a` (boundaries for the interior metrics are `a`'s).
pub fn compare(a: &Images, b: &Images) -> Result<CompareReport, CompareError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(CompareError::SizeMismatch(
            a.width, a.height, b.width, b.height,
        ));
    }
    let n = a.width as usize * a.height as usize;
    for img in [a, b] {
        if img.depth.len() != n || img.prim.len() != n {
            return Err(CompareError::BadBuffers(img.width, img.height));
        }
    }
    let edge = boundary_mask(a);
    let (mut cov, mut prim, mut cov_i, mut prim_i, mut interior) = (0u64, 0u64, 0u64, 0u64, 0u64);
    let (mut err, mut err_i) = (vec![], vec![]);
    #[allow(clippy::needless_range_loop)] // five parallel buffers
    for i in 0..n {
        let ca = covered(a.depth[i], a.prim[i]);
        let cb = covered(b.depth[i], b.prim[i]);
        let inner = !edge[i];
        interior += inner as u64;
        if ca != cb {
            cov += 1;
            cov_i += inner as u64;
        } else if ca {
            if a.prim[i] != b.prim[i] {
                prim += 1;
                prim_i += inner as u64;
            }
            let e = (a.depth[i] as f64 - b.depth[i] as f64).abs();
            let e = if e.is_nan() { f64::INFINITY } else { e };
            err.push(e);
            if inner {
                err_i.push(e);
            }
        }
    }
    let covered_both = err.len() as u64;
    let (mx, p99, mean) = stats(err);
    let (mx_i, p99_i, mean_i) = stats(err_i);
    let frac = |c: u64| if n == 0 { 0.0 } else { c as f64 / n as f64 };
    Ok(CompareReport {
        pixels: n as u64,
        coverage_mismatch: cov,
        coverage_mismatch_frac: frac(cov),
        prim_mismatch: prim,
        prim_mismatch_frac: frac(prim),
        covered_both,
        depth_abs_err_max: mx,
        depth_abs_err_p99: p99,
        depth_abs_err_mean: mean,
        interior_pixels: interior,
        coverage_mismatch_interior: cov_i,
        coverage_mismatch_interior_frac: frac(cov_i),
        prim_mismatch_interior: prim_i,
        prim_mismatch_interior_frac: frac(prim_i),
        depth_abs_err_max_interior: mx_i,
        depth_abs_err_p99_interior: p99_i,
        depth_abs_err_mean_interior: mean_i,
    })
}

/// What `compare` adds for two multisampled renders (each with its
/// per-pixel coverage, `coverage.png`): the coverage fractions and the
/// resolved colours. Depth and primitive of the defined sample (sample 0)
/// are [`compare`]'s metrics on the same images.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SampleReport {
    /// Largest and mean difference of the coverage fraction (0..1).
    pub coverage_frac_err_max: f64,
    pub coverage_frac_err_mean: f64,
    /// Pixels whose coverage fractions differ by more than 1/8, and their
    /// fraction of all pixels.
    pub coverage_off_by_eighth: u64,
    pub coverage_off_by_eighth_frac: f64,
    /// Largest and mean difference of a resolved colour channel (0..255).
    pub color_err_max: u8,
    pub color_err_mean: f64,
}

/// Compares `b`'s coverage and resolved colour against `a`'s (`cov_*`: each
/// pixel's covered samples ×255 over the samples).
pub fn compare_samples(
    a: &Images,
    cov_a: &[u8],
    b: &Images,
    cov_b: &[u8],
) -> Result<SampleReport, CompareError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(CompareError::SizeMismatch(
            a.width, a.height, b.width, b.height,
        ));
    }
    let n = a.width as usize * a.height as usize;
    if [cov_a.len(), cov_b.len(), a.color.len(), b.color.len()] != [n; 4] {
        return Err(CompareError::BadBuffers(a.width, a.height));
    }
    let mut r = SampleReport::default();
    let (mut cov_sum, mut col_sum) = (0.0, 0.0);
    for i in 0..n {
        let e = (cov_a[i] as f64 - cov_b[i] as f64).abs() / 255.0;
        cov_sum += e;
        r.coverage_frac_err_max = r.coverage_frac_err_max.max(e);
        // A byte of rounding beside the 1/8.
        if e > 0.125 + 1.0 / 255.0 {
            r.coverage_off_by_eighth += 1;
        }
        for c in 0..3 {
            let d = a.color[i][c].abs_diff(b.color[i][c]);
            r.color_err_max = r.color_err_max.max(d);
            col_sum += d as f64;
        }
    }
    if n > 0 {
        r.coverage_frac_err_mean = cov_sum / n as f64;
        r.coverage_off_by_eighth_frac = r.coverage_off_by_eighth as f64 / n as f64;
        r.color_err_mean = col_sum / (3 * n) as f64;
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_report_counts_coverage_past_an_eighth() {
        let a = rect(4, 1, 0, 4, 0, 1, 1.0);
        let cov_a = [255, 191, 128, 0];
        let cov_b = [255, 128, 128, 64];
        let r = compare_samples(&a, &cov_a, &a, &cov_b).unwrap();
        // 191 → 128 is 1/4 off; 0 → 64 is 1/4 off.
        assert_eq!(r.coverage_off_by_eighth, 2);
        assert_eq!(r.coverage_off_by_eighth_frac, 0.5);
        assert!((r.coverage_frac_err_max - 64.0 / 255.0).abs() < 1e-12);
        assert_eq!(r.color_err_max, 0);
        assert!(compare_samples(&a, &cov_a[..3], &a, &cov_b).is_err());
    }

    /// A rectangle `[x0, x1) × [y0, y1)` of prim `id` at depth `z` (left half id,
    /// right half id + 1), on background.
    fn rect(w: u32, h: u32, x0: u32, x1: u32, y0: u32, y1: u32, z: f32) -> Images {
        let n = (w * h) as usize;
        let mut img = Images {
            width: w,
            height: h,
            color: vec![[0, 0, 0, 255]; n],
            depth: vec![f32::INFINITY; n],
            prim: vec![0; n],
        };
        let xm = (x0 + x1) / 2;
        for y in y0..y1 {
            for x in x0..x1 {
                let i = (y * w + x) as usize;
                img.depth[i] = z + x as f32 * 0.01;
                img.prim[i] = if x < xm { 1 } else { 2 };
            }
        }
        img
    }

    #[test]
    fn identical_images_give_zeros() {
        let a = rect(40, 30, 5, 30, 4, 25, 2.0);
        let r = compare(&a, &a).unwrap();
        assert_eq!(r.pixels, 1200);
        assert_eq!((r.coverage_mismatch, r.prim_mismatch), (0, 0));
        assert_eq!(
            (
                r.depth_abs_err_max,
                r.depth_abs_err_p99,
                r.depth_abs_err_mean
            ),
            (0.0, 0.0, 0.0)
        );
        assert_eq!(r.covered_both, 25 * 21);
        assert!(r.interior_pixels > 0 && r.interior_pixels < 1200);
        let json = serde_json::to_value(&r).unwrap();
        for k in [
            "pixels",
            "coverage_mismatch",
            "prim_mismatch",
            "depth_abs_err_max",
            "depth_abs_err_p99",
            "depth_abs_err_mean",
            "coverage_mismatch_frac",
            "prim_mismatch_frac",
            "coverage_mismatch_interior",
            "prim_mismatch_interior",
            "depth_abs_err_max_interior",
            "interior_pixels",
        ] {
            assert!(json.get(k).is_some(), "{k}");
        }
    }

    #[test]
    fn shifted_edge_mismatches_only_near_boundary() {
        let a = rect(40, 30, 5, 30, 4, 25, 2.0);
        let b = rect(40, 30, 6, 30, 4, 25, 2.0); // left edge moved by one pixel
        let r = compare(&a, &b).unwrap();
        assert_eq!(r.coverage_mismatch, 21);
        assert!((r.coverage_mismatch_frac - 21.0 / 1200.0).abs() < 1e-12);
        // The id split moves from x=17 to x=18: one column of prim mismatches.
        assert_eq!(r.prim_mismatch, 21);
        assert_eq!(r.coverage_mismatch_interior, 0);
        assert_eq!(r.prim_mismatch_interior, 0);
        assert_eq!(r.depth_abs_err_max, 0.0);
        // A depth offset in one interior pixel shows in every depth metric.
        let mut c = a.clone();
        c.depth[15 * 40 + 10] += 0.5;
        let r = compare(&a, &c).unwrap();
        assert!((r.depth_abs_err_max - 0.5).abs() < 1e-6);
        assert!((r.depth_abs_err_max_interior - 0.5).abs() < 1e-6);
        assert_eq!(r.depth_abs_err_p99, 0.0);
        assert!((r.depth_abs_err_mean - 0.5 / 525.0).abs() < 1e-7);
        assert!(compare(&a, &rect(41, 30, 5, 30, 4, 25, 2.0)).is_err());
    }
}
