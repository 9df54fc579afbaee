//! OpenSCAD 2021.01's `import()` of an SVG file as a 2D region, following its
//! `import_svg.cc` and its own SVG reader `libsvg` (`shape.cc`, `path.cc`,
//! `rect.cc`), checked against OpenSCAD's DXF export of small files:
//!
//! - **Page.** With a `viewBox`, user units are scaled to the page size in mm
//!   (`preserveAspectRatio`, default `xMidYMid meet`); `width`/`height` in
//!   `mm`, `cm`, `in`, `pt`, `pc`, `px` (96 per inch), or unitless at `dpi`
//!   (default 72). Without a `viewBox`, one user unit is one mm. Y is flipped:
//!   `y = −s·(vb_y + y_svg) + height` — OpenSCAD adds the `viewBox` origin
//!   instead of subtracting it, and so does this reader. `center = true`
//!   centres the bounding box of the scaled points (without the `viewBox`
//!   offset, as OpenSCAD does).
//! - **Shapes.** `circle` and `ellipse` are 40-gons; path curves (`C`, `S`,
//!   `Q`, `T`) 20 segments each; an arc `A` `⌊|Δθ| · 10/π⌋ + 4` segments (a
//!   rounded `rect` corner: 9). `$fn`/`$fa`/`$fs` play no part.
//! - **Fill and stroke.** Closed outlines are filled whatever `fill` says;
//!   open subpaths (ends over 0.1 apart), `line` and `polyline` are stroked by
//!   `stroke-width` (default 1; `style` is read for it and `stroke-linecap`)
//!   with mitred joins and square caps unless `stroke-linecap` says `butt` or
//!   `round`; a path with a `Z` anywhere leaves its last open subpath filled.
//!   Each element's outlines are filled by the even-odd rule (`fill-rule` is
//!   not read), and the elements are united.
//! - **Skipped,** as by OpenSCAD: `<defs>` contents, `<use>`, `<text>`, CSS
//!   other than `style`'s stroke width and cap, `display`, clipping.
//!
//! The XML is read by `roxmltree`; path data, transforms, lengths, `viewBox`
//! and `preserveAspectRatio` by `svgtypes` (both maintained, panic-free).
//! `usvg` is not used: it turns circles, ellipses and arcs into cubic
//! Béziers and strokes by the SVG rules, and OpenSCAD's 40-gons (0.41% less
//! area than the circle) and its stroking of only the open subpaths would be
//! lost. The flattening below is therefore written here, step for step as
//! libsvg does it. Strokes are `i_overlay`'s (`StrokeOffset`), with
//! Clipper's round-cap step (`ArcTolerance` 0.25 at libsvg's 10⁴ scale).

use glam::{DAffine2, DMat2, DVec2};
use i_overlay::mesh::stroke::offset::StrokeOffset;
use i_overlay::mesh::style::{LineCap, LineJoin, StrokeStyle};
use std::f64::consts::PI;
use std::str::FromStr;

use super::extrude::{self, Op2, Region, MAX_COORD};

/// At most this many points per file (a guard on memory and time).
pub const MAX_POINTS: usize = 2_000_000;
/// At most this many XML nodes.
const MAX_NODES: u32 = 1_000_000;

/// The arguments of `import` that shape an SVG outline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// `dpi`: the size of a unitless length (OpenSCAD's default 72).
    pub dpi: f64,
    /// `center`.
    pub center: bool,
}

/// An imported outline and the remarks made while reading it.
#[derive(Clone, Debug, Default)]
pub struct Outline {
    /// The region (empty when nothing was read).
    pub region: Region,
    /// Non-fatal remarks, without a place (the caller adds it).
    pub warnings: Vec<String>,
}

/// One element's outlines in user units, after its transforms.
type Shape = Vec<Vec<DVec2>>;

struct Reader {
    shapes: Vec<Shape>,
    points: usize,
    skipped: Vec<(String, usize)>,
}

fn number(n: &roxmltree::Node, name: &str) -> f64 {
    // libsvg's `parse_double`: the number, units ignored, 0 when absent.
    n.attribute(name)
        .and_then(|v| svgtypes::Length::from_str(v.trim()).ok())
        .map(|l| l.number)
        .filter(|x| x.is_finite())
        .unwrap_or(0.0)
}

fn style<'a>(n: &roxmltree::Node<'a, 'a>, name: &str) -> Option<&'a str> {
    n.attribute(name).or_else(|| {
        n.attribute("style")?.split(';').find_map(|s| {
            let (k, v) = s.split_once(':')?;
            (k == name).then_some(v)
        })
    })
}

/// libsvg's stroke of an open path: Clipper's offset by half the width, mitred
/// joins (limit 2), the element's cap.
fn stroke(n: &roxmltree::Node, path: &[DVec2]) -> Shape {
    let w = style(n, "stroke-width")
        .and_then(|v| svgtypes::Length::from_str(v.trim()).ok())
        .map(|l| l.number)
        .filter(|w| w.is_finite() && *w >= 0.01)
        .unwrap_or(1.0);
    // ClipperOffset::DoOffset's round step at libsvg's scale of 10⁴ and
    // Clipper's default ArcTolerance of 0.25.
    let delta = w * 5000.0;
    let step = 2.0 * (1.0 - 0.25 / delta).clamp(-1.0, 1.0).acos();
    let cap = || match style(n, "stroke-linecap").map(str::trim) {
        Some("butt") => LineCap::Butt,
        Some("round") => LineCap::Round(step.max(1e-3)),
        _ => LineCap::Square,
    };
    let points: Vec<[f64; 2]> = path.iter().map(|p| [p.x, p.y]).collect();
    let style = StrokeStyle {
        width: w,
        start_cap: cap(),
        end_cap: cap(),
        join: LineJoin::Miter(PI / 3.0),
    };
    points
        .stroke(style, false)
        .into_iter()
        .flatten()
        .map(|c| c.into_iter().map(|[x, y]| DVec2::new(x, y)).collect())
        .collect()
}

/// `path::arc_to` (SVG 1.1 F.6.5), with libsvg's step count.
fn arc_to(
    out: &mut Vec<DVec2>,
    p1: DVec2,
    mut rx: f64,
    mut ry: f64,
    p2: DVec2,
    angle: f64,
    large: bool,
    sweep: bool,
) {
    let (sin, cos) = (PI * angle / 180.0).sin_cos();
    let d = (p1 - p2) / 2.0;
    let x1 = cos * d.x + sin * d.y;
    let y1 = -sin * d.x + cos * d.y;
    let l = x1 * x1 / (rx * rx) + y1 * y1 / (ry * ry);
    if l > 1.0 {
        rx = (l.sqrt() * rx).abs();
        ry = (l.sqrt() * ry).abs();
    }
    let t1 = (rx * rx * ry * ry - rx * rx * y1 * y1 - ry * ry * x1 * x1).max(0.0);
    let t2 = rx * rx * y1 * y1 + ry * ry * x1 * x1;
    let mut t3 = (t1 / t2).sqrt();
    if large == sweep {
        t3 = -t3;
    }
    let cx_ = t3 * rx * y1 / ry;
    let cy_ = t3 * -ry * x1 / rx;
    let c = DVec2::new(cos * cx_ - sin * cy_, sin * cx_ + cos * cy_) + (p1 + p2) / 2.0;
    let angle_of = |ux: f64, uy: f64, vx: f64, vy: f64| {
        let a = vy.atan2(vx) - uy.atan2(ux);
        if a < 0.0 {
            a + 2.0 * PI
        } else {
            a
        }
    };
    let (ux, uy) = ((x1 - cx_) / rx, (y1 - cy_) / ry);
    let (vx, vy) = ((-x1 - cx_) / rx, (-y1 - cy_) / ry);
    let theta = angle_of(1.0, 0.0, ux, uy);
    let mut delta = angle_of(ux, uy, vx, vy);
    if !sweep {
        delta -= 2.0 * PI;
    }
    if !(theta.is_finite() && delta.is_finite() && c.is_finite()) {
        // Zero radii: a straight line, as the SVG rules say.
        out.push(p2);
        return;
    }
    let steps = (delta.abs() * 10.0 / PI + 4.0) as u32;
    for a in 0..=steps {
        let phi = theta + delta * a as f64 / steps as f64;
        out.push(
            DVec2::new(
                cos * phi.cos() * rx - sin * phi.sin() * ry,
                sin * phi.cos() * rx + cos * phi.sin() * ry,
            ) + c,
        );
    }
}

fn bezier(out: &mut Vec<DVec2>, pts: &[DVec2]) {
    for i in 1..=20 {
        let a = i as f64 / 20.0;
        let b = 1.0 - a;
        out.push(match pts {
            [p0, c, p1] => *p0 * b * b + *c * 2.0 * b * a + *p1 * a * a,
            [p0, c1, c2, p1] => {
                *p0 * b * b * b + *c1 * 3.0 * b * b * a + *c2 * 3.0 * b * a * a + *p1 * a * a * a
            }
            _ => unreachable!("quadratic or cubic"),
        });
    }
}

fn is_open(p: &[DVec2]) -> bool {
    match (p.first(), p.last()) {
        (Some(a), Some(b)) => a.distance(*b) > 0.1,
        _ => false,
    }
}

/// `path::set_attrs`: the subpaths of path data `d`, open ones stroked.
fn path(n: &roxmltree::Node, d: &str, warnings: &mut Vec<String>) -> Shape {
    use svgtypes::PathSegment as S;
    let mut list: Shape = vec![Vec::new()];
    let (mut cur, mut start) = (DVec2::ZERO, DVec2::ZERO);
    let mut last_c2: Option<DVec2> = None;
    let mut last_q: Option<DVec2> = None;
    let mut closed = false;
    for seg in svgtypes::PathParser::from(d) {
        let seg = match seg {
            Ok(s) => s,
            Err(e) => {
                warnings.push(format!("path data \"{}\": {e}; read up to there", short(d)));
                break;
            }
        };
        let rel = |abs: bool, x: f64, y: f64, cur: DVec2| {
            if abs {
                DVec2::new(x, y)
            } else {
                cur + DVec2::new(x, y)
            }
        };
        let (mut c2, mut q) = (None, None);
        match seg {
            S::MoveTo { abs, x, y } => {
                let p = rel(abs, x, y, cur);
                let back = list.last().expect("one subpath at least");
                if !back.is_empty() {
                    if is_open(back) {
                        let open = list.pop().expect("non-empty");
                        list.extend(stroke(n, &open));
                    }
                    list.push(Vec::new());
                }
                list.last_mut().expect("pushed").push(p);
                cur = p;
                start = p;
            }
            S::LineTo { abs, x, y } => {
                cur = rel(abs, x, y, cur);
                list.last_mut().expect("one").push(cur);
            }
            S::HorizontalLineTo { abs, x } => {
                cur.x = if abs { x } else { cur.x + x };
                list.last_mut().expect("one").push(cur);
            }
            S::VerticalLineTo { abs, y } => {
                cur.y = if abs { y } else { cur.y + y };
                list.last_mut().expect("one").push(cur);
            }
            S::CurveTo {
                abs,
                x1,
                y1,
                x2,
                y2,
                x,
                y,
            } => {
                let (a, b, p) = (
                    rel(abs, x1, y1, cur),
                    rel(abs, x2, y2, cur),
                    rel(abs, x, y, cur),
                );
                bezier(list.last_mut().expect("one"), &[cur, a, b, p]);
                (c2, cur) = (Some(b), p);
            }
            S::SmoothCurveTo { abs, x2, y2, x, y } => {
                let a = last_c2.map_or(cur, |c| cur * 2.0 - c);
                let (b, p) = (rel(abs, x2, y2, cur), rel(abs, x, y, cur));
                bezier(list.last_mut().expect("one"), &[cur, a, b, p]);
                (c2, cur) = (Some(b), p);
            }
            S::Quadratic { abs, x1, y1, x, y } => {
                let (a, p) = (rel(abs, x1, y1, cur), rel(abs, x, y, cur));
                bezier(list.last_mut().expect("one"), &[cur, a, p]);
                (q, cur) = (Some(a), p);
            }
            S::SmoothQuadratic { abs, x, y } => {
                let a = last_q.map_or(cur, |c| cur * 2.0 - c);
                let p = rel(abs, x, y, cur);
                bezier(list.last_mut().expect("one"), &[cur, a, p]);
                (q, cur) = (Some(a), p);
            }
            S::EllipticalArc {
                abs,
                rx,
                ry,
                x_axis_rotation,
                large_arc,
                sweep,
                x,
                y,
            } => {
                let p = rel(abs, x, y, cur);
                arc_to(
                    list.last_mut().expect("one"),
                    cur,
                    rx.abs(),
                    ry.abs(),
                    p,
                    x_axis_rotation,
                    large_arc,
                    sweep,
                );
                cur = p;
            }
            S::ClosePath { .. } => {
                let back = list.last_mut().expect("one");
                if let Some(&p) = back.first() {
                    back.push(p);
                    cur = p;
                } else {
                    cur = start;
                }
                list.push(Vec::new());
                closed = true;
            }
        }
        (last_c2, last_q) = (c2, q);
    }
    while list.last().is_some_and(|p| p.is_empty()) {
        list.pop();
    }
    if !closed && list.last().is_some_and(|p| is_open(p)) {
        let open = list.pop().expect("non-empty");
        list.extend(stroke(n, &open));
    }
    list
}

fn short(d: &str) -> String {
    let s: String = d.chars().take(40).collect();
    if s.len() < d.len() {
        format!("{s}...")
    } else {
        s
    }
}

fn points(n: &roxmltree::Node) -> Vec<DVec2> {
    let v: Vec<f64> = svgtypes::NumberListParser::from(n.attribute("points").unwrap_or(""))
        .map_while(Result::ok)
        .collect();
    v.chunks_exact(2).map(|c| DVec2::new(c[0], c[1])).collect()
}

/// `draw_ellipse`: 40 points from angle 2π/40, `(rx sin a, ry cos a)`.
fn ellipse(c: DVec2, rx: f64, ry: f64) -> Vec<DVec2> {
    (1..=40)
        .map(|i| {
            let a = i as f64 * (2.0 * PI / 40.0);
            DVec2::new(rx * a.sin(), ry * a.cos()) + c
        })
        .collect()
}

fn transform(n: &roxmltree::Node) -> DAffine2 {
    n.attribute("transform")
        .and_then(|t| svgtypes::Transform::from_str(t).ok())
        .map(|t| DAffine2 {
            matrix2: DMat2::from_cols_array(&[t.a, t.b, t.c, t.d]),
            translation: DVec2::new(t.e, t.f),
        })
        .filter(|m| m.is_finite())
        .unwrap_or(DAffine2::IDENTITY)
}

impl Reader {
    fn walk(
        &mut self,
        n: roxmltree::Node,
        m: DAffine2,
        warnings: &mut Vec<String>,
    ) -> Result<(), String> {
        // Depth-first with an explicit stack: deep nesting cannot overflow.
        let mut stack = vec![(n, m)];
        while let Some((n, parent)) = stack.pop() {
            if !n.is_element() {
                continue;
            }
            let name = n.tag_name().name();
            let m = parent * transform(&n);
            let shape: Shape = match name {
                "defs" | "use" | "text" | "style" | "script" | "metadata" | "title" | "desc" => {
                    if matches!(name, "use" | "text") {
                        match self.skipped.iter_mut().find(|(k, _)| k == name) {
                            Some((_, c)) => *c += 1,
                            None => self.skipped.push((name.to_string(), 1)),
                        }
                    }
                    continue;
                }
                "svg" | "g" => Vec::new(),
                "path" => path(&n, n.attribute("d").unwrap_or(""), warnings),
                "rect" => {
                    let (x, y, w, h) = (
                        number(&n, "x"),
                        number(&n, "y"),
                        number(&n, "width"),
                        number(&n, "height"),
                    );
                    let (mut rx, mut ry) = (number(&n, "rx"), number(&n, "ry"));
                    let (has_rx, has_ry) = (rx.abs() >= 1e-8, ry.abs() >= 1e-8);
                    if has_rx || has_ry {
                        if !has_rx {
                            rx = ry;
                        } else if !has_ry {
                            ry = rx;
                        }
                        rx = rx.min(w / 2.0);
                        ry = ry.min(h / 2.0);
                        let d = format!(
                            "M {},{} H {} A {rx},{ry} 0 0,1 {},{} V {} A {rx},{ry} 0 0,1 {},{} H {} A {rx},{ry} 0 0,1 {},{} V {} A {rx},{ry} 0 0,1 {},{} z",
                            x + rx, y, x + w - rx, x + w, y + ry, y + h - ry, x + w - rx, y + h, x + rx, x, y + h - ry, y + ry, x + rx, y
                        );
                        path(&n, &d, warnings)
                    } else {
                        vec![vec![
                            DVec2::new(x, y),
                            DVec2::new(x + w, y),
                            DVec2::new(x + w, y + h),
                            DVec2::new(x, y + h),
                            DVec2::new(x, y),
                        ]]
                    }
                }
                "circle" => {
                    let r = number(&n, "r");
                    vec![ellipse(
                        DVec2::new(number(&n, "cx"), number(&n, "cy")),
                        r,
                        r,
                    )]
                }
                "ellipse" => vec![ellipse(
                    DVec2::new(number(&n, "cx"), number(&n, "cy")),
                    number(&n, "rx"),
                    number(&n, "ry"),
                )],
                "line" => stroke(
                    &n,
                    &[
                        DVec2::new(number(&n, "x1"), number(&n, "y1")),
                        DVec2::new(number(&n, "x2"), number(&n, "y2")),
                    ],
                ),
                "polyline" => stroke(&n, &points(&n)),
                "polygon" => {
                    let mut p = points(&n);
                    if let Some(&f) = p.first() {
                        p.push(f);
                    }
                    vec![p]
                }
                _ => Vec::new(),
            };
            let shape: Shape = shape
                .into_iter()
                .map(|ring| ring.into_iter().map(|p| m.transform_point2(p)).collect())
                .collect();
            self.points += shape.iter().map(Vec::len).sum::<usize>();
            if self.points > MAX_POINTS {
                return Err(format!(
                    "it has more than {MAX_POINTS} outline points; simplify the drawing"
                ));
            }
            if let Some(p) = shape
                .iter()
                .flatten()
                .find(|p| !(p.is_finite() && p.abs().max_element() <= MAX_COORD))
            {
                return Err(format!(
                    "a <{name}> has a point that is not a number or beyond ±{MAX_COORD:e} ({}, {}); fix the drawing",
                    p.x, p.y
                ));
            }
            if !shape.is_empty() {
                self.shapes.push(shape);
            }
            // Only containers pass their transform on (libsvg's parents).
            let pass = if matches!(name, "svg" | "g") {
                m
            } else {
                parent
            };
            let kids: Vec<_> = n.children().filter(|c| c.is_element()).collect();
            stack.extend(kids.into_iter().rev().map(|c| (c, pass)));
        }
        Ok(())
    }
}

/// `to_mm` of `import_svg.cc`.
fn to_mm(len: Option<svgtypes::Length>, vb: Option<f64>, dpi: f64) -> f64 {
    use svgtypes::LengthUnit as U;
    let Some(l) = len else {
        return vb.map_or(0.0, |v| 25.4 * v / dpi);
    };
    match l.unit {
        U::None => 25.4 * l.number / dpi,
        U::Px => 25.4 * l.number / 96.0,
        U::Pt => 25.4 * l.number / 72.0,
        U::Pc => 25.4 * l.number / 6.0,
        U::In => 25.4 * l.number,
        U::Cm => 10.0 * l.number,
        U::Mm => l.number,
        _ => vb.unwrap_or(0.0),
    }
}

/// Reads an SVG document (`text`) as OpenSCAD 2021.01 imports it.
pub fn read(text: &str, o: &Options) -> Result<Outline, String> {
    if !(o.dpi.is_finite() && o.dpi >= 0.001) {
        return Err(format!("`dpi` must be a positive number (it is {})", o.dpi));
    }
    let doc = roxmltree::Document::parse_with_options(
        text,
        roxmltree::ParsingOptions {
            allow_dtd: true,
            nodes_limit: MAX_NODES,
            ..roxmltree::ParsingOptions::default()
        },
    )
    .map_err(|e| format!("it is not a readable SVG document ({e})"))?;
    let root = doc.root_element();
    if root.tag_name().name() != "svg" {
        return Err(format!(
            "its root element is <{}>, not <svg>; give an SVG file",
            root.tag_name().name()
        ));
    }
    let length = |name: &str| {
        root.attribute(name)
            .and_then(|v| svgtypes::Length::from_str(v.trim()).ok())
    };
    let vb = root
        .attribute("viewBox")
        .and_then(|v| svgtypes::ViewBox::from_str(v).ok())
        .filter(|v| v.w > 0.0 && v.h > 0.0 && v.w.is_finite() && v.h.is_finite());
    let width_mm = to_mm(length("width"), vb.map(|v| v.w), o.dpi);
    let height_mm = to_mm(length("height"), vb.map(|v| v.h), o.dpi);
    let mut scale = DVec2::ONE;
    let mut align = DVec2::ZERO;
    let mut origin = DVec2::ZERO;
    if let Some(v) = vb {
        scale = DVec2::new(width_mm / v.w, height_mm / v.h);
        let ar = root
            .attribute("preserveAspectRatio")
            .and_then(|a| svgtypes::AspectRatio::from_str(a).ok())
            .unwrap_or_default();
        use svgtypes::Align as A;
        if ar.align != A::None {
            let s = if ar.slice {
                scale.max_element()
            } else {
                scale.min_element()
            };
            scale = DVec2::splat(s);
            let (ax, ay) = match ar.align {
                A::XMinYMin => (0, 0),
                A::XMidYMin => (1, 0),
                A::XMaxYMin => (2, 0),
                A::XMinYMid => (0, 1),
                A::XMidYMid => (1, 1),
                A::XMaxYMid => (2, 1),
                A::XMinYMax => (0, 2),
                A::XMidYMax => (1, 2),
                A::XMaxYMax => (2, 2),
                A::None => (0, 0),
            };
            let place = |k: i32, page: f64, view: f64| match k {
                1 => page / 2.0 - s * view / 2.0,
                2 => page - s * view,
                _ => 0.0,
            };
            align = DVec2::new(place(ax, width_mm, v.w), place(ay, height_mm, v.h));
        }
        origin = DVec2::new(v.x, v.y);
    }
    let mut reader = Reader {
        shapes: Vec::new(),
        points: 0,
        skipped: Vec::new(),
    };
    let mut warnings = Vec::new();
    // The root's own transform is not applied (libsvg's root has no parent).
    for kid in root.children().filter(|c| c.is_element()) {
        reader.walk(kid, DAffine2::IDENTITY, &mut warnings)?;
    }
    for (name, k) in &reader.skipped {
        warnings.push(format!(
            "{k} <{name}> element(s) skipped: OpenSCAD 2021.01 does not import them, and neither does peeltrim"
        ));
    }
    let (mut lo, mut hi) = (DVec2::INFINITY, DVec2::NEG_INFINITY);
    for p in reader.shapes.iter().flatten().flatten() {
        lo = lo.min(*p * scale);
        hi = hi.max(*p * scale);
    }
    let c = if o.center {
        (lo + hi) / 2.0
    } else {
        DVec2::new(-align.x, height_mm - align.y)
    };
    let page = |p: DVec2| {
        DVec2::new(
            scale.x * (p.x - origin.x) - c.x,
            scale.y * (-origin.y - p.y) + c.y,
        )
    };
    let regions: Vec<Region> = reader
        .shapes
        .iter()
        .map(|s| {
            let rings: Vec<Vec<DVec2>> = s
                .iter()
                .map(|r| r.iter().map(|&p| page(p)).collect())
                .collect();
            extrude::polygon(&rings, &DAffine2::IDENTITY)
        })
        .filter(|r| !r.is_empty())
        .collect();
    Ok(Outline {
        region: extrude::boolean(Op2::Union, regions),
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MM: &str = r#"width="100mm" height="100mm" viewBox="0 0 100 100""#;

    fn svg(attrs: &str, body: &str) -> String {
        format!(r#"<svg xmlns="http://www.w3.org/2000/svg" {attrs}>{body}</svg>"#)
    }

    fn read72(s: &str) -> Outline {
        read(
            s,
            &Options {
                dpi: 72.0,
                center: false,
            },
        )
        .unwrap()
    }

    fn area(r: &Region) -> f64 {
        r.signed_area()
    }

    fn bbox(r: &Region) -> [f64; 4] {
        let (mut lo, mut hi) = (DVec2::INFINITY, DVec2::NEG_INFINITY);
        for p in r.shapes.iter().flatten().flatten() {
            (lo, hi) = (lo.min(*p), hi.max(*p));
        }
        [lo.x, lo.y, hi.x, hi.y].map(|v| (v * 1e4).round() / 1e4)
    }

    /// Areas and boxes from OpenSCAD 2021.01's DXF export of the same files.
    #[test]
    fn shapes_match_openscad() {
        let cases = [
            // (attributes, body, area, bbox, vertices)
            (
                r#"width="100" height="100""#,
                r#"<rect x="10" y="10" width="20" height="30"/>"#,
                600.0,
                [10.0, -4.7222, 30.0, 25.2778],
                4,
            ),
            (
                r#"width="100px" height="100px""#,
                r#"<rect x="10" y="10" width="20" height="30"/>"#,
                600.0,
                [10.0, -13.5417, 30.0, 16.4583],
                4,
            ),
            (
                MM,
                r#"<circle cx="50" cy="50" r="10"/>"#,
                312.8705,
                [40.0, 40.0, 60.0, 60.0],
                40,
            ),
            (
                MM,
                r#"<path d="M10 10 H50 V50 H10 Z M20 20 H40 V40 H20 Z"/>"#,
                1200.0,
                [10.0, 50.0, 50.0, 90.0],
                8,
            ),
            (
                MM,
                r#"<rect x="10" y="10" width="20" height="20"/><rect x="20" y="20" width="20" height="20"/>"#,
                700.0,
                [10.0, 60.0, 40.0, 90.0],
                8,
            ),
            (
                MM,
                r#"<path d="M10 10 H50 V50" stroke-width="4"/>"#,
                336.0,
                [8.0, 48.0, 52.0, 92.0],
                6,
            ),
            (
                MM,
                r#"<path d="M10 10 C 10 50 50 50 50 10 Z"/>"#,
                956.004,
                [10.0, 60.0, 50.0, 90.0],
                21,
            ),
            (
                MM,
                r#"<path d="M10 50 A 20 20 0 0 1 50 50 Z"/>"#,
                623.0595,
                [10.0, 50.0, 50.0, 70.0],
                15,
            ),
            (
                MM,
                r#"<rect x="10" y="10" width="40" height="30" rx="5"/>"#,
                1178.1412,
                [10.0, 60.0, 50.0, 90.0],
                40,
            ),
            (
                MM,
                r#"<g transform="translate(10,5) scale(2)"><rect x="0" y="0" width="10" height="5"/></g>"#,
                200.0,
                [10.0, 85.0, 30.0, 95.0],
                4,
            ),
            (
                r#"width="100mm" height="50mm" viewBox="10 20 200 100""#,
                r#"<rect x="10" y="20" width="20" height="10"/>"#,
                50.0,
                [0.0, 25.0, 10.0, 30.0],
                4,
            ),
            (
                r#"width="100mm" height="50mm" viewBox="0 0 100 100""#,
                r#"<rect width="100" height="100"/>"#,
                2500.0,
                [25.0, 0.0, 75.0, 50.0],
                4,
            ),
            (
                MM,
                r#"<defs><rect x="10" y="10" width="20" height="20"/></defs><line x1="10" y1="10" x2="50" y2="10" stroke-width="4"/>"#,
                176.0,
                [8.0, 88.0, 52.0, 92.0],
                4,
            ),
            (
                MM,
                r#"<polygon points="10,10 50,10 30,40"/><polyline points="60,60 80,60 80,80" stroke-width="2"/>"#,
                684.0,
                [10.0, 19.0, 81.0, 90.0],
                9,
            ),
        ];
        for (attrs, body, a, b, n) in cases {
            let o = read72(&svg(attrs, body));
            assert!(
                (area(&o.region) - a).abs() < 2e-3,
                "{body}: area {} vs {a}",
                area(&o.region)
            );
            assert_eq!(bbox(&o.region), b, "{body}");
            assert_eq!(o.region.vertex_count(), n, "{body}");
        }
    }

    #[test]
    fn center_and_dpi() {
        let s = svg(
            r#"width="100mm" height="100mm" viewBox="10 10 100 100""#,
            r#"<rect x="20" y="20" width="20" height="10"/>"#,
        );
        let o = read(
            &s,
            &Options {
                dpi: 72.0,
                center: true,
            },
        )
        .unwrap();
        assert_eq!(bbox(&o.region), [-20.0, -15.0, 0.0, -5.0]);
        let s = svg(
            r#"width="100" height="100" viewBox="0 0 100 100""#,
            r#"<rect x="10" y="10" width="20" height="30"/>"#,
        );
        let o = read(
            &s,
            &Options {
                dpi: 96.0,
                center: false,
            },
        )
        .unwrap();
        assert!((area(&o.region) - 42.0026).abs() < 1e-3);
    }

    #[test]
    fn bad_documents_are_errors_or_warnings() {
        let o = Options {
            dpi: 72.0,
            center: false,
        };
        assert!(read("not xml", &o)
            .unwrap_err()
            .contains("not a readable SVG"));
        assert!(read("<html/>", &o).unwrap_err().contains("<html>"));
        let bad_path = read(&svg(MM, r#"<path d="M10 10 H50 V50 H10 Z M 20 x"/>"#), &o).unwrap();
        assert!(
            bad_path.warnings[0].contains("read up to there"),
            "{:?}",
            bad_path.warnings
        );
        assert!((area(&bad_path.region) - 1600.0).abs() < 1e-9);
        let text = read(&svg(MM, r#"<text>hi</text><use href="\#a"/>"#), &o).unwrap();
        assert!(text.region.is_empty() && text.warnings.len() == 2);
        let nan = read(
            &svg(
                MM,
                r#"<path d="M 1e308 0 L 1e308 1e308 L 0 1 Z" transform="scale(10)"/>"#,
            ),
            &o,
        );
        assert!(nan.unwrap_err().contains("not a number"));
        let deep = format!("{}{}", "<g>".repeat(5000), "</g>".repeat(5000));
        match read(&svg(MM, &deep), &o) {
            Ok(r) => assert!(r.region.is_empty()),
            Err(e) => assert!(e.contains("not a readable SVG"), "{e}"),
        }
    }
}
