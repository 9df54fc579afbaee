//! Edge maps of depth layers (Kirsch, Nienhaus & Döllner §5.1–5.2): silhouettes are
//! discontinuities of the depth layer map, creases discontinuities of the normal
//! buffer. One rule, shared by every producer of layers (the reference's exact
//! layers, the GPU's peeled ones) so that edge maps are compared, not eyeballed;
//! `shaders/edges.frag` states the same rule for the GPU.
//!
//! The rule: both pixels of a 4-neighbour pair are edge pixels when their coverage
//! differs, when both are covered and their depths differ by more than
//! [`EdgeRule::depth_rel`] of the nearer depth (silhouettes), or when their
//! normals differ by more than [`EdgeRule::angle_deg`] (creases). Pixels of the
//! image border are never edge pixels (the world beyond the image is unknown), but
//! a pair with a border pixel still marks its inner pixel.
#![deny(unsafe_code)]

/// The thresholds of the edge rule (`--edge-depth`, `--edge-angle`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeRule {
    /// Relative depth jump, a fraction of the nearer depth (default 0.01).
    pub depth_rel: f64,
    /// Angle between normals, in degrees (default 30).
    pub angle_deg: f64,
}

impl Default for EdgeRule {
    fn default() -> Self {
        EdgeRule {
            depth_rel: 0.01,
            angle_deg: 30.0,
        }
    }
}

impl EdgeRule {
    /// Checks the thresholds: `depth_rel > 0`, `0 < angle_deg < 180`.
    pub fn check(self) -> Result<EdgeRule, String> {
        if !(self.depth_rel.is_finite() && self.depth_rel > 0.0) {
            return Err(format!(
                "--edge-depth {} is out of range: give a positive fraction of the nearer depth, e.g. 0.01 (1%)",
                self.depth_rel
            ));
        }
        if !(self.angle_deg > 0.0 && self.angle_deg < 180.0) {
            return Err(format!(
                "--edge-angle {} is out of range: give degrees between 0 and 180 (exclusive), e.g. 30",
                self.angle_deg
            ));
        }
        Ok(self)
    }

    /// Whether the pair `(a, b)` is a discontinuity. A pixel is covered when its
    /// depth is finite; normals are unit vectors (any common frame).
    pub fn discontinuous(&self, da: f32, na: [f32; 3], db: f32, nb: [f32; 3]) -> bool {
        let (ca, cb) = (da.is_finite(), db.is_finite());
        if ca != cb {
            return true;
        }
        if !ca {
            return false;
        }
        let (da, db) = (da as f64, db as f64);
        let nearer = da.abs().min(db.abs());
        if (da - db).abs() > self.depth_rel * nearer {
            return true;
        }
        let dot: f64 = na.iter().zip(&nb).map(|(x, y)| *x as f64 * *y as f64).sum();
        dot < self.angle_deg.to_radians().cos()
    }
}

/// The edge map of one layer: `depth` (view-space, `+inf` where the layer has no
/// point) and `normal` of a `width × height` image, row-major; `true` = edge.
pub fn edge_map(
    depth: &[f32],
    normal: &[[f32; 3]],
    width: u32,
    height: u32,
    rule: &EdgeRule,
) -> Vec<bool> {
    let (w, h) = (width as usize, height as usize);
    assert!(
        depth.len() == w * h && normal.len() == w * h,
        "edge_map: buffers do not match {width}x{height}"
    );
    let mut e = vec![false; w * h];
    let inner = |x: usize, y: usize| x > 0 && y > 0 && x + 1 < w && y + 1 < h;
    let mark = |i: usize, j: usize, e: &mut Vec<bool>| {
        if rule.discontinuous(depth[i], normal[i], depth[j], normal[j]) {
            if inner(i % w, i / w) {
                e[i] = true;
            }
            if inner(j % w, j / w) {
                e[j] = true;
            }
        }
    };
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if x + 1 < w {
                mark(i, i + 1, &mut e);
            }
            if y + 1 < h {
                mark(i, i + w, &mut e);
            }
        }
    }
    e
}

/// Edge pixels of a map.
pub fn count(edges: &[bool]) -> u64 {
    edges.iter().filter(|&&e| e).count() as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    const Z: [f32; 3] = [0.0, 0.0, 1.0];
    const INF: f32 = f32::INFINITY;

    /// A `w × h` layer: depth and normal from a function of the pixel.
    fn layer(
        w: usize,
        h: usize,
        f: impl Fn(usize, usize) -> (f32, [f32; 3]),
    ) -> (Vec<f32>, Vec<[f32; 3]>) {
        (0..h * w).map(|i| f(i % w, i / w)).unzip()
    }

    fn at(e: &[bool], w: usize, x: usize, y: usize) -> bool {
        e[y * w + x]
    }

    #[test]
    fn coverage_step_marks_both_sides_but_never_the_border() {
        // A square [3, 7) x [2, 6) on background in a 10x8 image.
        let (d, n) = layer(10, 8, |x, y| {
            if (3..7).contains(&x) && (2..6).contains(&y) {
                (5.0, Z)
            } else {
                (INF, [0.0; 3])
            }
        });
        let e = edge_map(&d, &n, 10, 8, &EdgeRule::default());
        // Left side: x = 2 (outside) and x = 3 (inside) on rows 2..6.
        for y in 2..6 {
            assert!(at(&e, 10, 2, y) && at(&e, 10, 3, y), "row {y}");
            assert!(at(&e, 10, 6, y) && at(&e, 10, 7, y), "row {y}");
            assert!(!at(&e, 10, 1, y) && !at(&e, 10, 8, y));
        }
        // Interior pixel untouched; corners of the square's outside ring only
        // through 4-neighbours (the diagonal pixel (2, 1) is not an edge).
        assert!(!at(&e, 10, 4, 3));
        assert!(!at(&e, 10, 2, 1));
        // 12 pixels inside (corners shared by two sides), 16 outside.
        assert_eq!(count(&e), 28);
        // Touching the image border: a square from x = 0 marks no border pixel.
        let (d, n) = layer(10, 8, |x, _| if x < 4 { (5.0, Z) } else { (INF, [0.0; 3]) });
        let e = edge_map(&d, &n, 10, 8, &EdgeRule::default());
        for y in 0..8 {
            assert_eq!(at(&e, 10, 3, y), (1..7).contains(&y));
            assert!(!at(&e, 10, 0, y));
        }
        assert!(!e[..10].iter().any(|&b| b) && !e[70..].iter().any(|&b| b));
    }

    #[test]
    fn depth_jump_is_relative_to_the_nearer_depth() {
        // Left half at depth 10, right half at 10 + jump: an edge iff jump > 0.1.
        // −0.099: the nearer depth is 9.901, whose 1% (0.099 01) is not exceeded.
        for (jump, want) in [
            (0.09f32, false),
            (0.11, true),
            (-0.099, false),
            (-0.11, true),
        ] {
            let (d, n) = layer(8, 6, |x, _| (if x < 4 { 10.0 } else { 10.0 + jump }, Z));
            let e = edge_map(&d, &n, 8, 6, &EdgeRule::default());
            assert_eq!(at(&e, 8, 3, 2), want, "jump {jump}");
            assert_eq!(at(&e, 8, 4, 2), want, "jump {jump}");
            assert_eq!(count(&e), if want { 8 } else { 0 }, "jump {jump}");
        }
        // A smooth slope (1% per pixel would be an edge at 1.5%, not at 0.5%).
        let (d, n) = layer(8, 6, |x, _| (10.0 * 1.005f32.powi(x as i32), Z));
        assert_eq!(count(&edge_map(&d, &n, 8, 6, &EdgeRule::default())), 0);
        let (d, n) = layer(8, 6, |x, _| (10.0 * 1.015f32.powi(x as i32), Z));
        assert_eq!(count(&edge_map(&d, &n, 8, 6, &EdgeRule::default())), 6 * 4);
    }

    #[test]
    fn crease_by_normal_angle() {
        let tilt = |deg: f32| {
            let r = deg.to_radians();
            [r.sin(), 0.0, r.cos()]
        };
        for (deg, edge) in [(29.0, false), (31.0, true), (90.0, true), (180.0, true)] {
            let (d, n) = layer(8, 6, |x, _| (3.0, if x < 4 { Z } else { tilt(deg) }));
            let e = edge_map(&d, &n, 8, 6, &EdgeRule::default());
            assert_eq!(at(&e, 8, 4, 3), edge, "{deg} degrees");
            assert!(!at(&e, 8, 2, 3));
        }
        // A looser rule ignores the 31-degree crease, a tighter one finds 20.
        let (d, n) = layer(8, 6, |x, _| (3.0, if x < 4 { Z } else { tilt(31.0) }));
        let loose = EdgeRule {
            angle_deg: 45.0,
            ..Default::default()
        };
        assert_eq!(count(&edge_map(&d, &n, 8, 6, &loose)), 0);
        let (d, n) = layer(8, 6, |x, _| (3.0, if x < 4 { Z } else { tilt(20.0) }));
        let tight = EdgeRule {
            angle_deg: 15.0,
            ..Default::default()
        };
        assert_eq!(count(&edge_map(&d, &n, 8, 6, &tight)), 8);
    }

    #[test]
    fn thresholds_are_checked() {
        assert!(EdgeRule::default().check().is_ok());
        let bad = EdgeRule {
            depth_rel: 0.0,
            ..Default::default()
        };
        assert!(bad.check().unwrap_err().contains("--edge-depth"));
        let bad = EdgeRule {
            angle_deg: 180.0,
            ..Default::default()
        };
        assert!(bad.check().unwrap_err().contains("--edge-angle"));
    }
}
