//! `import(file = "x.dxf" | "x.svg", ...)` inside a 2D subtree: the node's
//! arguments, the file (relative to the `.csg` file's folder, as OpenSCAD
//! writes the path it was given), and the reader by extension
//! (`super::dxf`, `super::svg`). A file that cannot be opened is OpenSCAD's
//! warning and the empty set; an unreadable one is an error at the node.

use glam::DVec2;
use std::path::Path;

use super::args::{self, Args};
use super::extrude::Region;
use super::parse::{Node, ValueKind};
use super::{dxf, svg, ScadError};

/// At most this many bytes per imported 2D file.
pub const MAX_BYTES: u64 = 256 << 20;

/// Whether an `import` node names a DXF or SVG file (else a mesh).
pub fn is_2d_file(node: &Node) -> bool {
    node.args
        .iter()
        .find(|a| matches!(a.name.as_deref(), Some("file" | "filename") | None))
        .is_some_and(|a| match &a.value.kind {
            ValueKind::Str(f) => {
                let f = f.to_ascii_lowercase();
                f.ends_with(".dxf") || f.ends_with(".svg")
            }
            _ => false,
        })
}

/// The outline of a 2D `import` node; `base` is the `.csg` file's folder.
pub fn region(node: &Node, base: &Path, warnings: &mut Vec<String>) -> Result<Region, ScadError> {
    let a = Args::new(
        node,
        &["file", "layer", "convexity", "origin", "scale"],
        &[
            "filename",
            "layername",
            "center",
            "dpi",
            "width",
            "height",
            "id",
            "timestamp",
        ],
        warnings,
    )?;
    let at = |m: String| ScadError::new(node.pos, m);
    let file = match a
        .get("file")
        .or_else(|| a.get("filename"))
        .map(|v| (&v.kind, v.pos))
    {
        Some((ValueKind::Str(f), _)) => f.clone(),
        Some((_, pos)) => return Err(ScadError::new(pos, "`file` of `import` must be a string")),
        None => return Err(at("`import` needs `file = \"...\"`".into())),
    };
    let path = base.join(&file);
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let fail = |m: String| {
        at(format!(
            "`import` of {}: {m} (the path is relative to the .csg file's folder)",
            path.display()
        ))
    };
    let bytes = match std::fs::metadata(&path) {
        Ok(m) if m.is_file() && m.len() > MAX_BYTES => {
            return Err(fail(format!(
                "the file has {} bytes; at most {MAX_BYTES} are read",
                m.len()
            )))
        }
        Ok(m) if m.is_file() => std::fs::read(&path).map_err(|e| fail(e.to_string()))?,
        r => {
            let why = r.map_or_else(|e| e.to_string(), |_| "not a file".to_string());
            warnings.push(format!(
                "{}:{}: `import`: cannot open {} ({why}; the path is relative to the .csg file's folder); OpenSCAD warns and makes nothing of it, and so does peeltrim",
                node.pos.line,
                node.pos.col,
                path.display()
            ));
            return Ok(Region::default());
        }
    };
    let (region, notes) = match ext.as_str() {
        "dxf" => {
            let origin = match a.get("origin") {
                None => DVec2::ZERO,
                Some(v) => match args::numbers(v, "`origin` of `import`")?[..] {
                    [x, y] => DVec2::new(x, y),
                    _ => return Err(ScadError::new(v.pos, "`origin` of `import` must be [x, y]")),
                },
            };
            let layer = match a
                .get("layer")
                .or_else(|| a.get("layername"))
                .map(|v| &v.kind)
            {
                Some(ValueKind::Str(l)) => l.clone(),
                _ => String::new(),
            };
            let o = dxf::Options {
                layer,
                origin,
                scale: a.number("scale")?.unwrap_or(1.0),
                res: super::convert::resolution(&a, warnings)?,
            };
            let out = dxf::read(&bytes, &o).map_err(fail)?;
            (out.region, out.warnings)
        }
        "svg" => {
            let text =
                String::from_utf8(bytes).map_err(|_| fail("the file is not UTF-8 text".into()))?;
            let o = svg::Options {
                dpi: a.number("dpi")?.unwrap_or(72.0),
                center: a.boolean("center")?.unwrap_or(false),
            };
            let out = svg::read(&text, &o).map_err(fail)?;
            (out.region, out.warnings)
        }
        _ => {
            return Err(fail(format!(
            "a 2D import reads DXF or SVG files, not \"{ext}\"; export the outline as DXF or SVG"
        )))
        }
    };
    let name = path.display();
    warnings.extend(notes.into_iter().map(|w| {
        format!(
            "{}:{}: `import` of {name}: {w}",
            node.pos.line, node.pos.col
        )
    }));
    Ok(region)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::openscad::tessellate::Resolution;

    fn area(r: &Region) -> f64 {
        r.signed_area()
    }

    /// The shipped model's drawings against OpenSCAD 2021.01's DXF export of
    /// `import(...)` of each (area, vertex count).
    #[test]
    fn shipped_drawings_match_openscad() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/openscad");
        let dxf_bytes = std::fs::read(dir.join("flange.dxf")).unwrap();
        for (layer, a, n) in [("outline", 2847.4784, 32), ("holes", 309.5688, 50)] {
            let o = dxf::Options {
                layer: layer.into(),
                origin: DVec2::ZERO,
                scale: 1.0,
                res: Resolution::default(),
            };
            let out = dxf::read(&dxf_bytes, &o).unwrap();
            assert!(
                (area(&out.region) - a).abs() < 1e-3,
                "{layer}: {}",
                area(&out.region)
            );
            assert_eq!(out.region.vertex_count(), n, "{layer}");
        }
        let text = std::fs::read_to_string(dir.join("drop.svg")).unwrap();
        let out = svg::read(
            &text,
            &svg::Options {
                dpi: 72.0,
                center: false,
            },
        )
        .unwrap();
        assert!(
            (area(&out.region) - 378.0294).abs() < 1e-3,
            "{}",
            area(&out.region)
        );
        assert_eq!(out.region.vertex_count(), 82);
    }

    fn node(text: &str) -> (crate::scene::openscad::parse::Tree, Node) {
        let tree = crate::scene::openscad::parse::parse(text).unwrap();
        let n = tree.nodes[0].clone();
        (tree, n)
    }

    #[test]
    fn missing_and_wrong_files() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/openscad");
        let mut w = Vec::new();
        let (_, n) = node("import(file = \"nothere.dxf\");");
        assert!(region(&n, &dir, &mut w).unwrap().is_empty());
        assert!(
            w[0].starts_with("1:1: `import`: cannot open") && w[0].contains("nothere.dxf"),
            "{w:?}"
        );
        let (_, n) = node("import(file = \"import_outline.scad\");");
        let e = region(&n, &dir, &mut w).unwrap_err();
        assert!(
            e.message.contains("DXF or SVG") && e.message.contains("import_outline.scad"),
            "{e}"
        );
        let (_, n) = node("import(file = \"flange.dxf\", origin = [1, 2, 3]);");
        assert!(region(&n, &dir, &mut w)
            .unwrap_err()
            .message
            .contains("[x, y]"));
        // A DXF read as SVG: a located error naming the file.
        let tmp = std::env::temp_dir().join(format!("peeltrim-import2d-{}", std::process::id()));
        std::fs::create_dir_all(&tmp).unwrap();
        std::fs::copy(dir.join("flange.dxf"), tmp.join("flange.svg")).unwrap();
        let (_, n) = node("import(file = \"flange.svg\");");
        let e = region(&n, &tmp, &mut w).unwrap_err();
        assert!(
            e.message.contains("flange.svg") && e.message.contains("not a readable SVG"),
            "{e}"
        );
        std::fs::remove_dir_all(&tmp).ok();
    }

    /// Mutated bytes of the shipped drawings: each read gives an outline or
    /// an error, never a panic, in bounded time.
    #[test]
    fn fuzz_mutated_drawings() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0xd8f);
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/openscad");
        let dxf_bytes = std::fs::read(dir.join("flange.dxf")).unwrap();
        let svg_bytes = std::fs::read(dir.join("drop.svg")).unwrap();
        let pieces: [&[u8]; 10] = [
            b"nan",
            b"-1e308",
            b"1e999",
            b"\n",
            b"0\nCIRCLE\n",
            b"<g>",
            b"</svg>",
            b"\"",
            b"9999",
            b"M",
        ];
        let mutate = |rng: &mut rand_chacha::ChaCha8Rng, b: &[u8]| {
            let mut m = b.to_vec();
            for _ in 0..rng.gen_range(1..6) {
                let at = rng.gen_range(0..=m.len());
                match rng.gen_range(0..4) {
                    0 => m.truncate(at),
                    1 if at < m.len() => m[at] = rng.gen(),
                    2 => {
                        let p = pieces[rng.gen_range(0..pieces.len())];
                        m.splice(at..at, p.iter().copied());
                    }
                    _ => {
                        let end = (at + rng.gen_range(0..200)).min(m.len());
                        let copy = m[at..end].to_vec();
                        m.splice(at..at, copy);
                    }
                }
            }
            m
        };
        let o = dxf::Options {
            layer: String::new(),
            origin: DVec2::ZERO,
            scale: 1.0,
            res: Resolution::default(),
        };
        let finite = |r: &Region| r.shapes.iter().flatten().flatten().all(|p| p.is_finite());
        for _ in 0..200 {
            let t = std::time::Instant::now();
            let m = mutate(&mut rng, &dxf_bytes);
            if let Ok(out) = dxf::read(&m, &o) {
                assert!(finite(&out.region));
            }
            let m = mutate(&mut rng, &svg_bytes);
            if let Ok(out) = svg::read(
                &String::from_utf8_lossy(&m),
                &svg::Options {
                    dpi: 72.0,
                    center: false,
                },
            ) {
                assert!(finite(&out.region));
            }
            assert!(t.elapsed().as_secs() < 10, "slow mutated drawing");
        }
    }
}
