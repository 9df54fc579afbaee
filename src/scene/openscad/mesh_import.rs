//! `import()` of 3D meshes: STL (ASCII and binary) and OFF, each as one closed,
//! CCW-outward mesh, or an error naming the file and the fix.
//!
//! - STL (3D Systems' StereoLithography format): read by the `stl_io` crate,
//!   vertices welded where their `f32` coordinates are equal (as OpenSCAD's
//!   `import_stl` welds them). A binary file whose 80-byte header begins with
//!   `solid ` (OpenSCAD's own test file `import_bin_solid.stl` is one) is read
//!   as binary when the ASCII reading fails and the length is `84 + 50 n`.
//!   Facets are CCW seen from outside, the renderer's winding.
//! - OFF (Geomview's Object File Format): read here, because no maintained
//!   crate reads it without bringing a whole geometry kernel. Tokens are
//!   whitespace-separated, `#` starts a comment; the header `OFF` (or `COFF`,
//!   `NOFF`, `CNOFF`, whose extra per-vertex numbers are skipped) is followed
//!   by the vertex, face and edge counts, the vertices, then each face as its
//!   point count and indices (trailing colour numbers ignored). Faces are CCW
//!   seen from outside (CGAL's and OpenSCAD's export), triangulated in their
//!   plane as `polyhedron` faces are (`super::tessellate`).
//!
//! A degenerate triangle (a repeated vertex) is dropped. The result must be
//! closed and consistently oriented, checked by the caller.

use glam::DVec3;
use std::io::Cursor;
use std::path::Path;

use super::super::Mesh;
use super::tessellate;

/// Reads `path` (`.stl` or `.off`, by extension, case-insensitive).
pub fn read(path: &Path) -> Result<Mesh, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("stl") => parse_stl(&bytes),
        Some("off") => parse_off(&String::from_utf8_lossy(&bytes)),
        _ => Err("peeltrim imports .stl and .off meshes (3MF and AMF are not read yet): convert the file to STL or OFF".into()),
    }
    .map_err(|e| format!("{}: {e}", path.display()))
}

/// STL bytes, ASCII or binary.
pub fn parse_stl(bytes: &[u8]) -> Result<Mesh, String> {
    let binary_len = bytes.len() >= 84
        && bytes.len() as u64
            == 84 + 50 * u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
    let read = |b: &[u8]| stl_io::read_stl(&mut Cursor::new(b));
    let indexed = match read(bytes) {
        Ok(m) => m,
        Err(e) if bytes.starts_with(b"solid ") && binary_len => {
            // A binary file whose header begins with "solid ": skip the probe.
            let mut b = bytes.to_vec();
            b[..6].copy_from_slice(b"binary");
            read(&b).map_err(|_| format!("not a valid STL file: {e}"))?
        }
        Err(e) => return Err(format!("not a valid STL file: {e}")),
    };
    let mut mesh = Mesh {
        positions: indexed
            .vertices
            .iter()
            .map(|v| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64))
            .collect(),
        triangles: Vec::with_capacity(indexed.faces.len()),
    };
    if let Some(v) = mesh.positions.iter().find(|p| !p.is_finite()) {
        return Err(format!(
            "a vertex has the coordinate {v}: infinite or NaN numbers cannot make geometry"
        ));
    }
    for f in &indexed.faces {
        let [a, b, c] = f.vertices.map(|i| i as u32);
        if a != b && b != c && a != c {
            mesh.triangles.push([a, b, c]);
        }
    }
    if mesh.triangles.is_empty() {
        return Err("the STL file has no facets".into());
    }
    Ok(mesh)
}

/// OFF text.
pub fn parse_off(text: &str) -> Result<Mesh, String> {
    // (line, token) pairs, comments removed.
    let mut toks = text.lines().enumerate().flat_map(|(k, l)| {
        l.split('#')
            .next()
            .unwrap_or("")
            .split_whitespace()
            .map(move |t| (k + 1, t))
    });
    let mut peek = toks.next();
    let mut extra = 0;
    if let Some((_, h)) = peek {
        if h.ends_with("OFF") {
            extra = match h {
                "OFF" => 0,
                "COFF" => 4,
                "NOFF" => 3,
                "CNOFF" => 7,
                _ => {
                    return Err(format!(
                        "the header `{h}` is not one peeltrim reads: OFF, COFF, NOFF or CNOFF"
                    ))
                }
            };
            peek = toks.next();
        }
    }
    let mut toks = peek.into_iter().chain(toks);
    let mut next = |what: &str| -> Result<(usize, &str), String> {
        toks.next()
            .ok_or_else(|| format!("the file ends before {what}"))
    };
    let mut count = |what: &str| -> Result<usize, String> {
        let (l, t) = next(what)?;
        t.parse::<usize>()
            .map_err(|_| format!("line {l}: {what} must be a count, not `{t}`"))
    };
    let nv = count("the vertex count")?;
    let nf = count("the face count")?;
    let _ne = count("the edge count")?;
    let mut positions = Vec::with_capacity(nv.min(1 << 20));
    let mut coord = |what: &str| -> Result<f64, String> {
        let (l, t) = next(what)?;
        t.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("line {l}: {what} `{t}` is not a finite number"))
    };
    for _ in 0..nv {
        let p = DVec3::new(
            coord("a vertex coordinate")?,
            coord("a vertex coordinate")?,
            coord("a vertex coordinate")?,
        );
        for _ in 0..extra {
            coord("a vertex's colour or normal")?;
        }
        positions.push(p);
    }
    drop(coord);
    let mut faces = Vec::with_capacity(nf.min(1 << 20));
    let mut last_line = 0;
    for fi in 0..nf {
        let (l, t) = next("a face")?;
        let n: usize = t.parse().map_err(|_| {
            format!("line {l}: face {fi} must start with its point count, not `{t}`")
        })?;
        if n < 3 {
            return Err(format!(
                "line {l}: face {fi} has {n} point(s); a face needs at least 3"
            ));
        }
        let mut f = Vec::with_capacity(n.min(1 << 16));
        for _ in 0..n {
            let (l, t) = next("a face's point index")?;
            let i = t.parse::<usize>().ok().filter(|&i| i < nv).ok_or_else(|| {
                format!(
                    "line {l}: `{t}` in face {fi} is not a vertex index (an integer from 0 to {})",
                    nv as i64 - 1
                )
            })?;
            f.push(i as u32);
        }
        // CCW from outside; `polyhedron` takes OpenSCAD's clockwise order.
        f.reverse();
        faces.push(f);
        last_line = l;
    }
    // Numbers after a face on its line are its colour; nothing else may follow.
    for (l, t) in toks {
        if l != last_line {
            return Err(format!(
                "line {l}: `{t}` follows the last of the {nf} faces the header announced"
            ));
        }
    }
    let mut mesh = tessellate::polyhedron(positions, &faces)
        .ok_or_else(|| "the OFF file has no faces".to_string())?;
    mesh.triangles
        .retain(|&[a, b, c]| a != b && b != c && a != c);
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::validate::{check_closed, signed_volume};

    const CUBE_OFF: &str =
        "OFF\n# a unit cube\n8 6 12\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n\
        4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7 0.5 0.5 0.5\n";

    #[test]
    fn off_cube_is_closed_and_outward() {
        let m = parse_off(CUBE_OFF).unwrap();
        check_closed(&m).unwrap();
        assert!((signed_volume(&m) - 1.0).abs() < 1e-12);
        // Counts on the header line, no header at all.
        let m = parse_off(&CUBE_OFF.replace("OFF\n# a unit cube\n8 6 12", "8 6 12")).unwrap();
        assert_eq!(m.triangles.len(), 12);
    }

    #[test]
    fn off_errors_name_the_line() {
        let e = parse_off("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n").unwrap_err();
        assert!(e.starts_with("line 6:") && e.contains("`7`"), "{e}");
        let e = parse_off("OFF\n3 1 0\n0 0 0\n1 nan 0\n").unwrap_err();
        assert!(e.starts_with("line 4:") && e.contains("finite"), "{e}");
        assert!(parse_off("OFF\n3 1").unwrap_err().contains("ends before"));
        assert!(parse_off("").unwrap_err().contains("ends before"));
        let e = parse_off("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n9 9\n").unwrap_err();
        assert!(e.contains("follows the last"), "{e}");
        assert!(parse_off("4OFF\n").unwrap_err().contains("header"));
        // A huge announced count is not allocated up front.
        assert!(parse_off("OFF\n999999999999 1 0\n")
            .unwrap_err()
            .contains("ends before"));
    }

    fn stl_ascii(tris: &[[[f32; 3]; 3]]) -> Vec<u8> {
        let mut s = String::from("solid t\n");
        for t in tris {
            s += "facet normal 0 0 0\nouter loop\n";
            for v in t {
                s += &format!("vertex {} {} {}\n", v[0], v[1], v[2]);
            }
            s += "endloop\nendfacet\n";
        }
        s += "endsolid t\n";
        s.into_bytes()
    }

    fn stl_binary(header: &[u8], tris: &[[[f32; 3]; 3]]) -> Vec<u8> {
        let mut b = vec![0u8; 80];
        b[..header.len()].copy_from_slice(header);
        b.extend((tris.len() as u32).to_le_bytes());
        for t in tris {
            b.extend([0u8; 12]);
            for v in t {
                for c in v {
                    b.extend(c.to_le_bytes());
                }
            }
            b.extend([0u8; 2]);
        }
        b
    }

    fn tetra() -> Vec<[[f32; 3]; 3]> {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]
            .iter()
            .map(|t| t.map(|i| p[i]))
            .collect()
    }

    #[test]
    fn stl_ascii_binary_and_solid_headed_binary() {
        for bytes in [
            stl_ascii(&tetra()),
            stl_binary(b"peeltrim", &tetra()),
            stl_binary(b"solid but binary", &tetra()),
        ] {
            let m = parse_stl(&bytes).unwrap();
            assert_eq!(m.positions.len(), 4);
            check_closed(&m).unwrap();
            assert!((signed_volume(&m) - 1.0 / 6.0).abs() < 1e-9);
        }
        assert!(
            parse_stl(b"solid x\nfacet normal 0 0 0\nouter loop\nvertex 1 2\n")
                .unwrap_err()
                .contains("not a valid STL")
        );
        assert!(parse_stl(b"").unwrap_err().contains("STL"));
        let empty = stl_binary(b"x", &[]);
        assert!(parse_stl(&empty).unwrap_err().contains("no facets"));
    }
}
