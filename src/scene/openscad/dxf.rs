//! OpenSCAD 2021.01's `import()` of a DXF file as a 2D region, following its
//! `DxfData` constructor and `DxfData::toPolygon2d` (`dxfdata.cc`, `grid.h`):
//!
//! - entities read: `LINE`, `LWPOLYLINE` (its bulges are ignored: arcs in a
//!   polyline are drawn as straight chords, as OpenSCAD draws them), `CIRCLE`,
//!   `ARC`, `ELLIPSE` (also elliptical arcs) and `INSERT` of a block made of
//!   those; every other entity (`POLYLINE`, `SPLINE`, `TEXT`, ...) is skipped
//!   with OpenSCAD's warning "Unsupported DXF Entity";
//! - a circle has `get_fragments_from_r(r)` segments (`$fn`, `$fa`, `$fs`), an
//!   arc `⌈n · sweep / 360°⌉`, an ellipse `⌈n(r_major) · sweep / 2π⌉`;
//! - `layer = ""` reads every layer, else only entities on that layer (blocks
//!   are read whole); `origin` is subtracted from the entity coordinates and the
//!   result multiplied by `scale`;
//! - every segment end is snapped to a grid of 2⁻¹⁰ units (a point within one
//!   cell of an existing one joins it), segments are chained into paths —
//!   first the open ones, from an end no other segment touches, then the
//!   closed ones — and open paths are closed by a straight edge;
//! - the paths are filled by the even-odd rule (OpenSCAD's Clipper
//!   sanitisation), so nested outlines alternate between solid and hole.
//!
//! The file is read by the `dxf` crate (IxMilia's maintained DXF reader: ASCII
//! and binary DXF, every code page). The chaining is written here because it
//! is OpenSCAD's own (no library joins segments in its order and grid); it
//! keeps OpenSCAD's order of paths but finds the next open end with a
//! candidate set instead of OpenSCAD's rescan from the first segment, so
//! 10⁵ disjoint segments take milliseconds, not minutes.

use glam::{DAffine2, DVec2};
use std::collections::{BTreeSet, HashMap};

use super::extrude::{self, Region, MAX_COORD};
use super::tessellate::{self, Resolution};

/// OpenSCAD 2021.01's `GRID_COARSE` (observed: imported points land on
/// multiples of 2⁻¹⁰).
const GRID: f64 = 1.0 / 1024.0;
/// At most this many segments per file (a guard on memory and time).
pub const MAX_SEGMENTS: usize = 2_000_000;

/// The arguments of `import` that shape a DXF outline.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// `layer`: empty reads every layer.
    pub layer: String,
    /// `origin`: subtracted from the coordinates before `scale`.
    pub origin: DVec2,
    /// `scale`.
    pub scale: f64,
    /// `$fn`, `$fa`, `$fs` (clamped).
    pub res: Resolution,
}

/// An imported outline and the remarks made while reading it.
#[derive(Clone, Debug, Default)]
pub struct Outline {
    /// The region (empty when nothing was read).
    pub region: Region,
    /// Non-fatal remarks, without a place (the caller adds it).
    pub warnings: Vec<String>,
}

type Cell = (i64, i64);

/// OpenSCAD's `Grid2d` of segment ends.
#[derive(Default)]
struct Grid {
    /// Per cell: the segments with an end in it (in order of addition), how
    /// many of those are still unused, and the first possibly unused entry.
    cells: HashMap<Cell, CellData>,
}

#[derive(Default)]
struct CellData {
    entries: Vec<u32>,
    live: u32,
    cursor: usize,
}

impl Grid {
    /// `Grid2d::align`: the point's cell, or an existing neighbour within one
    /// cell (the nearest by steps, the first found on ties); the cell exists
    /// afterwards.
    fn align(&mut self, p: DVec2) -> Cell {
        let (mut ix, mut iy) = ((p.x / GRID).round() as i64, (p.y / GRID).round() as i64);
        if !self.cells.contains_key(&(ix, iy)) {
            let mut dist = 10;
            let (cx, cy) = (ix, iy);
            for jx in cx - 1..=cx + 1 {
                for jy in cy - 1..=cy + 1 {
                    if !self.cells.contains_key(&(jx, jy)) {
                        continue;
                    }
                    let d = (cx - jx).abs() + (cy - jy).abs();
                    if d < dist {
                        dist = d;
                        ix = jx;
                        iy = jy;
                    }
                }
            }
        }
        self.cells.entry((ix, iy)).or_default();
        (ix, iy)
    }
}

/// The segments of a drawing, snapped.
#[derive(Default)]
struct Segments {
    grid: Grid,
    lines: Vec<[Cell; 2]>,
}

impl Segments {
    fn add(&mut self, a: DVec2, b: DVec2) -> Result<(), String> {
        if self.lines.len() >= MAX_SEGMENTS {
            return Err(format!(
                "it makes more than {MAX_SEGMENTS} segments; raise $fa/$fs or lower $fn, or simplify the drawing"
            ));
        }
        let ca = self.grid.align(a);
        let cb = self.grid.align(b);
        let i = self.lines.len() as u32;
        for c in [ca, cb] {
            let d = self.grid.cells.get_mut(&c).expect("aligned cells exist");
            d.entries.push(i);
            d.live += 1;
        }
        self.lines.push([ca, cb]);
        Ok(())
    }

    /// OpenSCAD's path extraction: open paths (from an end no other unused
    /// segment touches, lowest segment first), then closed ones.
    fn paths(mut self) -> Vec<(Vec<Cell>, bool)> {
        let n = self.lines.len();
        let mut used = vec![false; n];
        let own = |l: &[Cell; 2], c: Cell| (l[0] == c) as u32 + (l[1] == c) as u32;
        // An end of line `i` no other unused line touches.
        let free_end = |g: &Grid, used: &[bool], lines: &[[Cell; 2]], i: usize| -> Option<usize> {
            if used[i] {
                return None;
            }
            (0..2).find(|&j| {
                let c = lines[i][j];
                g.cells[&c].live == own(&lines[i], c)
            })
        };
        let mut candidates: BTreeSet<usize> = (0..n)
            .filter(|&i| free_end(&self.grid, &used, &self.lines, i).is_some())
            .collect();
        let mut paths = Vec::new();
        let mut first_unused = 0;
        loop {
            let start = loop {
                let Some(i) = candidates.pop_first() else {
                    break None;
                };
                if let Some(j) = free_end(&self.grid, &used, &self.lines, i) {
                    break Some((i, j, false));
                }
            };
            let start = match start {
                Some(s) => s,
                None => {
                    while first_unused < n && used[first_unused] {
                        first_unused += 1;
                    }
                    if first_unused == n {
                        break;
                    }
                    (first_unused, 0, true)
                }
            };
            let (mut line, mut point, closed) = start;
            let mut path = vec![self.lines[line][point]];
            loop {
                let end = self.lines[line][1 - point];
                path.push(end);
                used[line] = true;
                let ends = self.lines[line];
                // A segment with both ends in one cell is listed there twice.
                for c in &ends {
                    let d = self.grid.cells.get_mut(c).expect("cells exist");
                    d.live -= 1;
                    if !closed && d.live <= 2 {
                        for &e in &d.entries {
                            let e = e as usize;
                            if !used[e] {
                                candidates.insert(e);
                            }
                        }
                    }
                }
                let d = self.grid.cells.get_mut(&end).expect("cells exist");
                while d.cursor < d.entries.len() && used[d.entries[d.cursor] as usize] {
                    d.cursor += 1;
                }
                let Some(&k) = d.entries.get(d.cursor) else {
                    break;
                };
                line = k as usize;
                point = if self.lines[line][0] == end { 0 } else { 1 };
            }
            paths.push((path, closed));
        }
        paths
    }
}

fn finite(p: DVec2, what: &str) -> Result<DVec2, String> {
    if p.is_finite() && p.abs().max_element() <= MAX_COORD {
        Ok(p)
    } else {
        Err(format!(
            "{what} has a coordinate that is not a number or beyond ±{MAX_COORD:e} ({}, {}); fix the drawing",
            p.x, p.y
        ))
    }
}

fn radius(r: f64, what: &str) -> Result<f64, String> {
    if r.is_finite() && r.abs() <= MAX_COORD {
        Ok(r)
    } else {
        Err(format!(
            "{what} has a radius that is not a number or beyond ±{MAX_COORD:e} ({r}); fix the drawing"
        ))
    }
}

/// A fragment count, refused beyond the segment budget.
fn count(n: f64, what: &str) -> Result<u64, String> {
    if !(n <= MAX_SEGMENTS as f64) {
        return Err(format!(
            "{what} would have {n} segments; at most {MAX_SEGMENTS} are accepted: raise $fa/$fs or lower $fn"
        ));
    }
    Ok(n.max(0.0) as u64)
}

/// The entity's kind as DXF names it (`SPLINE`, `TEXT`, ...).
fn entity_name(e: &::dxf::entities::EntityType) -> String {
    let debug = format!("{e:?}");
    let name: String = debug.chars().take_while(|c| c.is_alphanumeric()).collect();
    name.to_ascii_uppercase()
}

/// The segments of one entity (`None`: not a kind OpenSCAD reads). `map`
/// places entity coordinates (origin and scale in the ENTITIES section, the
/// identity in a block); `rscale` scales radii.
fn entity_segments(
    e: &::dxf::entities::EntityType,
    map: &dyn Fn(f64, f64) -> DVec2,
    rscale: f64,
    o: &Options,
    blocks: &HashMap<String, Vec<(DVec2, DVec2)>>,
    out: &mut Vec<(DVec2, DVec2)>,
    bulges: &mut usize,
) -> Result<bool, String> {
    use ::dxf::entities::EntityType as T;
    use std::f64::consts::PI;
    match e {
        T::Line(l) => {
            let a = finite(map(l.p1.x, l.p1.y), "a LINE")?;
            let b = finite(map(l.p2.x, l.p2.y), "a LINE")?;
            out.push((a, b));
        }
        T::LwPolyline(p) => {
            let v: Vec<DVec2> = p
                .vertices
                .iter()
                .map(|v| finite(map(v.x, v.y), "an LWPOLYLINE"))
                .collect::<Result<_, _>>()?;
            *bulges += p.vertices.iter().filter(|v| v.bulge != 0.0).count();
            out.extend(v.windows(2).map(|w| (w[0], w[1])));
            if p.is_closed() && !v.is_empty() {
                out.push((v[v.len() - 1], v[0]));
            }
        }
        T::Circle(c) => {
            let center = finite(map(c.center.x, c.center.y), "a CIRCLE")?;
            let r = radius(c.radius * rscale, "a CIRCLE")?;
            let n = tessellate::fragments(r, o.res);
            count(n as f64, "a CIRCLE")?;
            let at = |i: u64| {
                let a = 2.0 * PI * i as f64 / n as f64;
                DVec2::new(a.cos() * r + center.x, a.sin() * r + center.y)
            };
            out.extend((0..n).map(|i| (at(i), at(i + 1))));
        }
        T::Arc(a) => {
            let center = finite(map(a.center.x, a.center.y), "an ARC")?;
            let r = radius(a.radius * rscale, "an ARC")?;
            let (start, mut stop) = (a.start_angle, a.end_angle);
            if !(start.is_finite() && stop.is_finite()) {
                return Err("an ARC has an angle that is not a number; fix the drawing".into());
            }
            // OpenSCAD adds whole turns one at a time; a bounded equivalent.
            if start > stop {
                stop += 360.0 * ((start - stop) / 360.0).ceil();
                while start > stop {
                    stop += 360.0;
                }
            }
            let sweep = stop - start;
            let n = tessellate::fragments(r, o.res) as f64;
            let n = count((n * sweep / 360.0).ceil(), "an ARC")?;
            let at = |i: u64| {
                let t = (start + sweep * i as f64 / n as f64) * PI / 180.0;
                DVec2::new(t.cos() * r + center.x, t.sin() * r + center.y)
            };
            out.extend((0..n).map(|i| (at(i), at(i + 1))));
        }
        T::Ellipse(el) => {
            let center = finite(map(el.center.x, el.center.y), "an ELLIPSE")?;
            // OpenSCAD reads the major axis end (codes 11/21) as a point, so
            // `origin` is subtracted from it too, and the axis ratio (code 40)
            // is scaled like a radius.
            let ce = finite(map(el.major_axis.x, el.major_axis.y), "an ELLIPSE")?;
            let (start, mut stop) = (el.start_parameter, el.end_parameter);
            if !(start.is_finite() && stop.is_finite() && el.minor_axis_ratio.is_finite()) {
                return Err(
                    "an ELLIPSE has a parameter that is not a number; fix the drawing".into(),
                );
            }
            if start > stop {
                stop += 2.0 * PI * ((start - stop) / (2.0 * PI)).ceil();
                while start > stop {
                    stop += 2.0 * PI;
                }
            }
            let r_major = ce.length();
            let rot = {
                let c = if r_major > 0.0 {
                    (ce.x / r_major).clamp(-1.0, 1.0)
                } else {
                    1.0
                };
                let a = c.acos();
                if ce.y < 0.0 {
                    2.0 * PI - a
                } else {
                    a
                }
            };
            let r_minor = r_major * el.minor_axis_ratio * rscale;
            let sweep = stop - start;
            let n = tessellate::fragments(r_major, o.res) as f64;
            let n = count((n * sweep / (2.0 * PI)).ceil(), "an ELLIPSE")?;
            let at = |i: u64| {
                let a = start + sweep * i as f64 / n as f64;
                let p = DVec2::new(a.cos() * r_major, a.sin() * r_minor);
                DVec2::new(
                    rot.cos() * p.x - rot.sin() * p.y + center.x,
                    rot.sin() * p.x + rot.cos() * p.y + center.y,
                )
            };
            out.extend((0..n).map(|i| (at(i), at(i + 1))));
        }
        T::Insert(ins) => {
            let at = finite(map(ins.location.x, ins.location.y), "an INSERT")?;
            let (sx, sy, rot) = (ins.x_scale_factor, ins.y_scale_factor, ins.rotation);
            if !(sx.is_finite() && sy.is_finite() && rot.is_finite()) {
                return Err(
                    "an INSERT has a scale or rotation that is not a number; fix the drawing"
                        .into(),
                );
            }
            let a = rot * PI / 180.0;
            let place = |p: DVec2| {
                let l = DVec2::new(p.x * sx, p.y * sy);
                DVec2::new(a.cos() * l.x - a.sin() * l.y, a.sin() * l.x + a.cos() * l.y) * o.scale
                    + at
            };
            if let Some(lines) = blocks.get(&ins.name) {
                if out.len() + lines.len() > MAX_SEGMENTS {
                    return Err(format!(
                        "its INSERTs make more than {MAX_SEGMENTS} segments; simplify the drawing"
                    ));
                }
                for &(p, q) in lines {
                    out.push((
                        finite(place(p), "an INSERT")?,
                        finite(place(q), "an INSERT")?,
                    ));
                }
            }
        }
        _ => return Ok(false),
    }
    Ok(true)
}

/// Reads a DXF drawing (`bytes`) as OpenSCAD 2021.01 imports it.
pub fn read(bytes: &[u8], o: &Options) -> Result<Outline, String> {
    if !(o.scale.is_finite() && o.origin.is_finite()) {
        return Err("`origin` and `scale` must be finite numbers".into());
    }
    let mut reader = std::io::Cursor::new(bytes);
    let drawing = ::dxf::Drawing::load(&mut reader).map_err(|e| {
        format!("it is not a readable DXF drawing ({e}); export it again as DXF (R12 or later)")
    })?;
    let mut warnings = Vec::new();
    let mut unsupported: Vec<(String, usize)> = Vec::new();
    let mut note = |name: String| match unsupported.iter_mut().find(|(n, _)| *n == name) {
        Some((_, k)) => *k += 1,
        None => unsupported.push((name, 1)),
    };
    let mut bulges = 0;
    let mut seg = Segments::default();
    // Blocks: raw coordinates, snapped to the same grid (as OpenSCAD does).
    let mut blocks: HashMap<String, Vec<(DVec2, DVec2)>> = HashMap::new();
    let identity = |x: f64, y: f64| DVec2::new(x, y);
    for b in drawing.blocks() {
        let mut out = Vec::new();
        for e in &b.entities {
            if !entity_segments(
                &e.specific,
                &identity,
                1.0,
                o,
                &blocks,
                &mut out,
                &mut bulges,
            )? {
                note(entity_name(&e.specific));
            }
            if out.len() > MAX_SEGMENTS {
                return Err(format!(
                    "its blocks make more than {MAX_SEGMENTS} segments; simplify the drawing"
                ));
            }
        }
        let out = out
            .into_iter()
            .map(|(p, q)| {
                let (a, b) = (seg.grid.align(p), seg.grid.align(q));
                let f = |c: Cell| DVec2::new(c.0 as f64 * GRID, c.1 as f64 * GRID);
                (f(a), f(b))
            })
            .collect();
        blocks.insert(b.name.clone(), out);
    }
    let map = |x: f64, y: f64| (DVec2::new(x, y) - o.origin) * o.scale;
    let mut layers: Vec<&str> = Vec::new();
    let mut out = Vec::new();
    for e in drawing.entities() {
        let layer = e.common.layer.as_str();
        if !layers.contains(&layer) {
            layers.push(layer);
        }
        if !(o.layer.is_empty() || o.layer == layer) {
            continue;
        }
        out.clear();
        if !entity_segments(
            &e.specific,
            &map,
            o.scale,
            o,
            &blocks,
            &mut out,
            &mut bulges,
        )? {
            note(entity_name(&e.specific));
        }
        for &(a, b) in &out {
            seg.add(a, b)?;
        }
    }
    for (name, k) in unsupported {
        warnings.push(format!(
            "Unsupported DXF Entity '{name}' ({k}x): OpenSCAD skips it, and so does peeltrim"
        ));
    }
    if bulges > 0 {
        warnings.push(format!(
            "{bulges} LWPOLYLINE vertices have a bulge (an arc); OpenSCAD 2021.01 draws them as straight segments, and so does peeltrim"
        ));
    }
    if !o.layer.is_empty() && !layers.contains(&o.layer.as_str()) {
        warnings.push(format!(
            "no entity is on layer \"{}\" (the layers are {}); the import is empty, as in OpenSCAD",
            o.layer,
            layers
                .iter()
                .map(|l| format!("\"{l}\""))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let point = |c: Cell| DVec2::new(c.0 as f64 * GRID, c.1 as f64 * GRID);
    let rings: Vec<Vec<DVec2>> = seg
        .paths()
        .into_iter()
        .map(|(path, closed)| {
            // `toPolygon2d`: reversed, a closed path without its repeated end.
            let skip = closed as usize;
            path.iter()
                .rev()
                .take(path.len() - skip)
                .map(|&c| point(c))
                .collect()
        })
        .collect();
    Ok(Outline {
        region: extrude::polygon(&rings, &DAffine2::IDENTITY),
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts() -> Options {
        Options {
            layer: String::new(),
            origin: DVec2::ZERO,
            scale: 1.0,
            res: Resolution::default(),
        }
    }

    /// A DXF of just an ENTITIES section.
    pub(crate) fn dxf(entities: &[Vec<(i32, String)>]) -> Vec<u8> {
        let mut s = String::from("  0\nSECTION\n  2\nENTITIES\n");
        for e in entities {
            for (c, v) in e {
                s.push_str(&format!("{c}\n{v}\n"));
            }
        }
        s.push_str("  0\nENDSEC\n  0\nEOF\n");
        s.into_bytes()
    }

    fn lw(pts: &[(f64, f64)], closed: bool, layer: &str) -> Vec<(i32, String)> {
        let mut e = vec![
            (0, "LWPOLYLINE".to_string()),
            (8, layer.to_string()),
            (90, pts.len().to_string()),
            (70, (closed as i32).to_string()),
        ];
        for (x, y) in pts {
            e.push((10, x.to_string()));
            e.push((20, y.to_string()));
        }
        e
    }

    fn square(x: f64, y: f64, s: f64, layer: &str) -> Vec<(i32, String)> {
        lw(
            &[(x, y), (x + s, y), (x + s, y + s), (x, y + s)],
            true,
            layer,
        )
    }

    fn area(r: &Region) -> f64 {
        r.signed_area()
    }

    #[test]
    fn circle_has_openscads_segments_and_grid() {
        let c = |r: f64| {
            vec![
                (0, "CIRCLE".to_string()),
                (8, "0".to_string()),
                (10, "0".to_string()),
                (20, "0".to_string()),
                (40, r.to_string()),
            ]
        };
        let o = read(&dxf(&[c(10.0)]), &opts()).unwrap();
        // OpenSCAD 2021.01: 30 segments, area 311.8681 (its DXF export).
        assert_eq!(o.region.vertex_count(), 30);
        assert!(
            (area(&o.region) - 311.8681).abs() < 1e-3,
            "{}",
            area(&o.region)
        );
        let mut seven = opts();
        seven.res.fn_ = 7.0;
        let o = read(&dxf(&[c(10.0)]), &seven).unwrap();
        assert_eq!(o.region.vertex_count(), 7);
        // Points on OpenSCAD's 2⁻¹⁰ grid: (6.23535, 7.81836), area 273.6447.
        assert!(
            (area(&o.region) - 273.6447).abs() < 1e-3,
            "{}",
            area(&o.region)
        );
        let on_grid = o.region.shapes[0][0]
            .iter()
            .all(|p| (p.x * 1024.0).fract() == 0.0 && (p.y * 1024.0).fract() == 0.0);
        assert!(on_grid);
    }

    #[test]
    fn nested_outlines_alternate_and_open_paths_close() {
        let nested = dxf(&[
            square(0.0, 0.0, 10.0, "0"),
            square(2.0, 2.0, 6.0, "0"),
            square(4.0, 4.0, 2.0, "0"),
        ]);
        let o = read(&nested, &opts()).unwrap();
        assert!((area(&o.region) - 68.0).abs() < 1e-9);
        // An open polyline is closed by a straight edge (OpenSCAD: area 50 + 25).
        let open = dxf(&[
            lw(&[(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)], false, "0"),
            square(20.0, 0.0, 5.0, "0"),
        ]);
        let o = read(&open, &opts()).unwrap();
        assert!((area(&o.region) - 75.0).abs() < 1e-9);
    }

    #[test]
    fn arc_and_lines_chain_into_one_outline() {
        let arc = vec![
            (0, "ARC".to_string()),
            (8, "0".to_string()),
            (10, "0".to_string()),
            (20, "0".to_string()),
            (40, "10".to_string()),
            (50, "0".to_string()),
            (51, "90".to_string()),
        ];
        let line = |x1: f64, y1: f64, x2: f64, y2: f64| {
            vec![
                (0, "LINE".to_string()),
                (8, "0".to_string()),
                (10, x1.to_string()),
                (20, y1.to_string()),
                (11, x2.to_string()),
                (21, y2.to_string()),
            ]
        };
        let o = read(
            &dxf(&[arc, line(10.0, 0.0, 0.0, 0.0), line(0.0, 0.0, 0.0, 10.0)]),
            &opts(),
        )
        .unwrap();
        // OpenSCAD: ⌈30 · 90/360⌉ = 8 arc segments and two lines, area 78.0373.
        assert_eq!(o.region.vertex_count(), 10);
        assert!(
            (area(&o.region) - 78.0373).abs() < 1e-3,
            "{}",
            area(&o.region)
        );
    }

    #[test]
    fn layer_origin_and_scale() {
        let two = dxf(&[square(0.0, 0.0, 10.0, "A"), square(20.0, 0.0, 5.0, "B")]);
        let mut o = opts();
        o.layer = "A".into();
        assert!((area(&read(&two, &o).unwrap().region) - 100.0).abs() < 1e-9);
        o.layer = "X".into();
        let r = read(&two, &o).unwrap();
        assert!(r.region.is_empty());
        assert!(r.warnings[0].contains("\"A\", \"B\""), "{:?}", r.warnings);
        let mut o = opts();
        o.origin = DVec2::new(1.0, 2.0);
        o.scale = 2.0;
        let r = read(&two, &o).unwrap().region;
        assert!((area(&r) - 500.0).abs() < 1e-9);
        let e = Extents::of(&r);
        assert_eq!((e.min_x, e.max_x), (-2.0, 48.0));
    }

    use super::super::extrude::Extents;

    #[test]
    fn bad_drawings_are_errors_or_warnings() {
        assert!(read(b"not a dxf at all", &opts()).is_err());
        assert!(read(b"", &opts()).is_ok_and(|o| o.region.is_empty()));
        let nan = dxf(&[lw(&[(0.0, 0.0), (f64::NAN, 0.0), (1.0, 1.0)], true, "0")]);
        let e = read(&nan, &opts()).unwrap_err();
        assert!(e.contains("LWPOLYLINE"), "{e}");
        let spline = dxf(&[
            vec![(0, "SPLINE".to_string()), (8, "0".to_string())],
            square(0.0, 0.0, 1.0, "0"),
        ]);
        let o = read(&spline, &opts()).unwrap();
        assert!(
            o.warnings.iter().any(|w| w.contains("'SPLINE' (1x)")),
            "{:?}",
            o.warnings
        );
        let mut huge = opts();
        huge.res.fn_ = 1e12;
        let c = vec![
            (0, "CIRCLE".to_string()),
            (8, "0".to_string()),
            (10, "0".to_string()),
            (20, "0".to_string()),
            (40, "1".to_string()),
        ];
        assert!(read(&dxf(&[c]), &huge).unwrap_err().contains("segments"));
    }

    #[test]
    fn many_disjoint_segments_are_fast() {
        let lines: Vec<_> = (0..100_000)
            .map(|i| {
                let x = (i % 300) as f64 * 3.0;
                let y = (i / 300) as f64 * 3.0;
                vec![
                    (0, "LINE".to_string()),
                    (8, "0".to_string()),
                    (10, x.to_string()),
                    (20, y.to_string()),
                    (11, (x + 1.0).to_string()),
                    (21, (y + 1.0).to_string()),
                ]
            })
            .collect();
        let t = std::time::Instant::now();
        let o = read(&dxf(&lines), &opts()).unwrap();
        assert!(o.region.is_empty(), "two-point paths enclose nothing");
        assert!(t.elapsed().as_secs_f64() < 20.0);
    }
}
