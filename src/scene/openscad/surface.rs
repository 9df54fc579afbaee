//! `surface(file, center, invert)`: a height map as the closed mesh OpenSCAD
//! 2021.01 builds (its `surface.cc`, checked against the OFF it exports).
//!
//! - Data: a PNG (decoded by the `image` crate) gives, per pixel, `z = 100/255 ·
//!   p` with `p = 0.2126 r + 0.7152 g + 0.0722 b` (alpha ignored), the image's
//!   top row at the largest y; `invert` makes it `100/255 · (1 − p)`, the
//!   formula 2021.01 uses (so inverted heights are negative). Any other file is
//!   a `.dat` text: rows of numbers (row k at y = k), blank lines and lines
//!   starting with `#` skipped, a missing value 0, and reading stops at the
//!   first word that is not a number (OpenSCAD warns and keeps what it read).
//!   `invert` has no effect on `.dat` data, as in 2021.01.
//! - Mesh: each grid cell is four triangles around its centre (the mean of its
//!   corners); four walls go down to `min(0, min(z) − 1)`, where a flat bottom
//!   closes the solid (triangulated here as a fan from its centre, which covers
//!   the same rectangle as OpenSCAD's single polygon). `center` moves the grid's
//!   centre to x = y = 0.
//!
//! A grid with fewer than two rows or columns encloses nothing: `None`.

use glam::DVec3;
use std::collections::HashMap;

use super::super::Mesh;

/// A height grid: `z[row][col]`, rows of equal length.
#[derive(Clone, Debug, PartialEq)]
pub struct Heights {
    pub z: Vec<Vec<f64>>,
    /// Why reading stopped early, if it did (a warning).
    pub stopped: Option<String>,
}

/// PNG signature.
const PNG: &[u8] = b"\x89PNG\r\n\x1a\n";

/// Heights from a file's bytes (PNG or `.dat`, by content as OpenSCAD decides).
pub fn heights(bytes: &[u8], invert: bool) -> Result<Heights, String> {
    if bytes.starts_with(PNG) {
        return png(bytes, invert);
    }
    Ok(dat(&String::from_utf8_lossy(bytes)))
}

fn png(bytes: &[u8], invert: bool) -> Result<Heights, String> {
    // The decoder allocates no more than the memory budget (its pixels, then
    // their RGBA copy: a quarter each).
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(crate::budget::current().bytes / 4);
    let mut reader =
        image::ImageReader::with_format(std::io::Cursor::new(bytes), image::ImageFormat::Png);
    reader.limits(limits);
    let img = reader
        .decode()
        .map_err(|e| format!("not a PNG image peeltrim can decode within the memory budget: {e}"))?
        .to_rgba8();
    let (w, h) = img.dimensions();
    let z = (0..h)
        .map(|row| {
            // Row 0 of the grid is the image's bottom row.
            let y = h - 1 - row;
            (0..w)
                .map(|x| {
                    let p = img.get_pixel(x, y).0;
                    let v = 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
                    100.0 / 255.0 * if invert { 1.0 - v } else { v }
                })
                .collect()
        })
        .collect();
    Ok(Heights { z, stopped: None })
}

fn dat(text: &str) -> Heights {
    let mut z: Vec<Vec<f64>> = Vec::new();
    let mut stopped = None;
    for (k, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut row = Vec::new();
        for t in line.split([' ', '\t']).filter(|t| !t.is_empty()) {
            match t.parse::<f64>() {
                Ok(v) if v.is_finite() => row.push(v),
                _ => {
                    stopped = Some(format!(
                        "line {}: `{t}` is not a number; the heights read before it are used, as OpenSCAD does",
                        k + 1
                    ));
                    break;
                }
            }
        }
        z.push(row);
        if stopped.is_some() {
            break;
        }
    }
    let cols = z.iter().map(Vec::len).max().unwrap_or(0);
    for row in &mut z {
        row.resize(cols, 0.0);
    }
    Heights { z, stopped }
}

/// The closed, CCW-outward mesh of a height grid.
pub fn mesh(h: &Heights, center: bool) -> Option<Mesh> {
    let lines = h.z.len();
    let columns = h.z.first().map_or(0, Vec::len);
    if lines < 2 || columns < 2 {
        return None;
    }
    let min = h.z.iter().flatten().fold(0.0f64, |m, &v| m.min(v - 1.0));
    let (ox, oy) = if center {
        (-(columns as f64 - 1.0) / 2.0, -(lines as f64 - 1.0) / 2.0)
    } else {
        (0.0, 0.0)
    };
    let mut b = Builder::default();
    let p = |x: f64, y: f64, z: f64| DVec3::new(ox + x, oy + y, z);
    let d = |i: usize, j: usize| h.z[i][j];
    for i in 1..lines {
        for j in 1..columns {
            let (x, y) = (j as f64, i as f64);
            let v1 = p(x - 1.0, y - 1.0, d(i - 1, j - 1));
            let v2 = p(x, y - 1.0, d(i - 1, j));
            let v3 = p(x - 1.0, y, d(i, j - 1));
            let v4 = p(x, y, d(i, j));
            let c = p(x - 0.5, y - 0.5, (v1.z + v2.z + v3.z + v4.z) / 4.0);
            for (a, bb) in [(v1, v2), (v2, v4), (v4, v3), (v3, v1)] {
                b.polygon(&[a, bb, c]);
            }
        }
    }
    let (cx, cy) = ((columns - 1) as f64, (lines - 1) as f64);
    for i in 1..lines {
        let (y0, y1) = ((i - 1) as f64, i as f64);
        b.polygon(&[
            p(0.0, y0, min),
            p(0.0, y0, d(i - 1, 0)),
            p(0.0, y1, d(i, 0)),
            p(0.0, y1, min),
        ]);
        b.polygon(&[
            p(cx, y1, min),
            p(cx, y1, d(i, columns - 1)),
            p(cx, y0, d(i - 1, columns - 1)),
            p(cx, y0, min),
        ]);
    }
    for j in 1..columns {
        let (x0, x1) = ((j - 1) as f64, j as f64);
        b.polygon(&[
            p(x1, 0.0, min),
            p(x1, 0.0, d(0, j)),
            p(x0, 0.0, d(0, j - 1)),
            p(x0, 0.0, min),
        ]);
        b.polygon(&[
            p(x0, cy, min),
            p(x0, cy, d(lines - 1, j - 1)),
            p(x1, cy, d(lines - 1, j)),
            p(x1, cy, min),
        ]);
    }
    // The bottom, clockwise seen from above: a fan from its centre.
    let mut ring = Vec::new();
    ring.extend((0..columns - 1).map(|j| p(j as f64, 0.0, min)));
    ring.extend((0..lines - 1).map(|i| p(cx, i as f64, min)));
    ring.extend((1..columns).rev().map(|j| p(j as f64, cy, min)));
    ring.extend((1..lines).rev().map(|i| p(0.0, i as f64, min)));
    ring.reverse();
    let centre = p(cx / 2.0, cy / 2.0, min);
    for k in 0..ring.len() {
        b.polygon(&[ring[k], ring[(k + 1) % ring.len()], centre]);
    }
    Some(b.mesh)
}

/// Welds vertices by position and fan-triangulates convex polygons given
/// counter-clockwise seen from outside.
#[derive(Default)]
struct Builder {
    mesh: Mesh,
    index: HashMap<[u64; 3], u32>,
}

impl Builder {
    fn vertex(&mut self, p: DVec3) -> u32 {
        let n = self.mesh.positions.len() as u32;
        *self
            .index
            .entry(p.to_array().map(f64::to_bits))
            .or_insert_with(|| {
                self.mesh.positions.push(p);
                n
            })
    }

    fn polygon(&mut self, pts: &[DVec3]) {
        let ids: Vec<u32> = pts.iter().map(|&p| self.vertex(p)).collect();
        for k in 1..ids.len() - 1 {
            self.mesh.triangles.push([ids[0], ids[k], ids[k + 1]]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::validate::{check_closed, signed_volume};

    #[test]
    fn dat_rows_comments_ragged_and_bad_words() {
        let h = dat("# c\n1 2 3\n\n4\t5\n");
        assert_eq!(h.z, vec![vec![1.0, 2.0, 3.0], vec![4.0, 5.0, 0.0]]);
        assert!(h.stopped.is_none());
        let h = dat("1 2\n3 x 4\n5 6\n");
        assert_eq!(h.z, vec![vec![1.0, 2.0], vec![3.0, 0.0]]);
        assert!(h.stopped.unwrap().starts_with("line 2: `x`"));
    }

    /// OpenSCAD 2021.01's OFF export of `surface("h.dat")` for `1 2 3 / 4 5
    /// 6.5`: 14 vertices, bottom at z = 0, the cell centres at the corner means.
    #[test]
    fn mesh_matches_openscad_export() {
        let h = dat("1 2 3\n4 5 6.5\n");
        let m = mesh(&h, false).unwrap();
        check_closed(&m).unwrap();
        assert!(signed_volume(&m) > 0.0);
        for v in [
            DVec3::new(0.5, 0.5, 3.0),
            DVec3::new(1.5, 0.5, 4.125),
            DVec3::new(2.0, 1.0, 0.0),
        ] {
            assert!(m.positions.contains(&v), "{v}");
        }
        // OpenSCAD's 14, and the bottom fan's centre.
        assert_eq!(m.positions.len(), 15);
        let c = mesh(&h, true).unwrap();
        let b = c.aabb().unwrap();
        assert_eq!(
            (b.min, b.max),
            (DVec3::new(-1.0, -0.5, 0.0), DVec3::new(1.0, 0.5, 6.5))
        );
        // The volume: the bottom at 0, the top a bilinear-ish surface.
        let vol = signed_volume(&m);
        assert!(vol > 2.0 * 1.0 && vol < 2.0 * 6.5, "{vol}");
        assert!(mesh(&dat("1 2 3\n"), false).is_none());
        assert!(mesh(&dat(""), false).is_none());
    }

    #[test]
    fn png_heights_and_invert_as_openscad() {
        // 2×2: red, green / blue, grey 100 (top row first, as the file stores it).
        let mut img = image::RgbImage::new(2, 2);
        img.put_pixel(0, 0, image::Rgb([255, 0, 0]));
        img.put_pixel(1, 0, image::Rgb([0, 255, 0]));
        img.put_pixel(0, 1, image::Rgb([0, 0, 255]));
        img.put_pixel(1, 1, image::Rgb([100, 100, 100]));
        let mut bytes = Vec::new();
        img.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .unwrap();
        let h = heights(&bytes, false).unwrap();
        // OpenSCAD 2021.01 exported 7.22, 39.2157 / 21.26, 71.52.
        let near = |a: f64, b: f64| (a - b).abs() < 1e-4;
        assert!(near(h.z[0][0], 7.22) && near(h.z[0][1], 39.2157));
        assert!(near(h.z[1][0], 21.26) && near(h.z[1][1], 71.52));
        let h = heights(&bytes, true).unwrap();
        assert!(near(h.z[0][0], -6.82784) && near(h.z[1][1], -71.1278));
        let m = mesh(&h, false).unwrap();
        check_closed(&m).unwrap();
        assert!(near(m.aabb().unwrap().min.z, -72.1278));
        assert!(heights(b"\x89PNG\r\n\x1a\ngarbage", false)
            .unwrap_err()
            .contains("PNG"));
    }
}
