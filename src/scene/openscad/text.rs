//! OpenSCAD 2021.01's `text()` as a 2D region, following its `text.cc` and
//! `FreetypeRenderer.cc` / `DrawingCallback.cc`:
//!
//! - the font is sized so that one em is `size · 100/72` units (FreeType's
//!   `FT_Set_Char_Size(size · 1000, 100 dpi)`, outlines divided by 1000);
//! - each quadratic or cubic segment becomes `max(⌊n/8⌋ + 1, 2)` straight
//!   ones at equal parameter steps, where `n` is `get_fragments_from_r(size)`;
//! - advances and the `valign` extents are divided by 1024 rather than 1000
//!   (OpenSCAD's `/ 64 / 16`), so glyphs sit 2.3 % closer than the font's
//!   nominal advance, and `valign` uses grid-fitted (whole-pixel) boxes;
//! - `halign`: `left`, `center`, `right` of the summed advances; `valign`:
//!   `baseline`, `bottom`, `center`, `top`; `spacing` scales advances;
//!   `direction`: `ltr`, `rtl` (glyphs in reverse order), `ttb`/`btt`
//!   (glyphs stacked downwards/upwards by the font's line height, centred on
//!   x = 0 — HarfBuzz's vertical origin, approximated).
//!
//! Glyphs are read with `ttf-parser` (a maintained, panic-free TrueType and
//! OpenType parser). Not reproduced: HarfBuzz shaping (ligatures, GPOS
//! kerning, complex scripts: each character maps to its own glyph) and
//! FreeType's hinting (at OpenSCAD's 217 pixels per em of a size-10 text it
//! moves points by under 0.002 units). The glyph contours are filled by the
//! non-zero rule with `i_overlay`, as OpenSCAD's Clipper union does.
//!
//! Fonts: Liberation Sans 2.1 (SIL OFL 1.1, `assets/fonts/`), Regular, Bold,
//! Italic and Bold Italic, for the default font and every `Liberation Sans`
//! name; DejaVu Sans (Bitstream Vera licence, `assets/fonts/`, Book only) for
//! `DejaVu Sans` and `Bitstream Vera Sans`, which fontconfig maps to it on
//! Debian; any other family is drawn in Liberation Sans with a warning, as
//! OpenSCAD falls back to its default when fontconfig has no match.

use glam::DVec2;
use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::overlay_rule::OverlayRule;

use super::args::Args;
use super::extrude::{overlay, Region};
use super::parse::{Node, ValueKind};
use super::tessellate;
use super::ScadError;

const REGULAR: &[u8] = include_bytes!("../../../assets/fonts/LiberationSans-Regular.ttf");
const BOLD: &[u8] = include_bytes!("../../../assets/fonts/LiberationSans-Bold.ttf");
const ITALIC: &[u8] = include_bytes!("../../../assets/fonts/LiberationSans-Italic.ttf");
const BOLD_ITALIC: &[u8] = include_bytes!("../../../assets/fonts/LiberationSans-BoldItalic.ttf");
const DEJAVU: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// At most this many characters per `text` (a guard on the outline size).
pub const MAX_CHARS: usize = 10_000;

/// The shipped face for an OpenSCAD font name (`"Family:style=Style"`), and a
/// warning when the family is not Liberation Sans.
pub fn face_for(font: &str) -> (&'static [u8], Option<String>) {
    let mut parts = font.split(':');
    let family = parts.next().unwrap_or("").trim();
    let style = parts
        .filter_map(|p| p.trim().strip_prefix("style="))
        .next()
        .unwrap_or("")
        .to_ascii_lowercase();
    let bold = style.contains("bold");
    let italic = style.contains("italic") || style.contains("oblique");
    let data = match (bold, italic) {
        (true, true) => BOLD_ITALIC,
        (true, false) => BOLD,
        (false, true) => ITALIC,
        (false, false) => REGULAR,
    };
    let dejavu = ["DejaVu Sans", "Bitstream Vera Sans"]
        .iter()
        .any(|f| family.eq_ignore_ascii_case(f));
    if dejavu {
        let warning = (bold || italic).then(|| {
            format!("font \"{font}\": only DejaVu Sans Book is shipped with peeltrim; drawn in it")
        });
        return (DEJAVU, warning);
    }
    let known = family.is_empty() || family.eq_ignore_ascii_case("Liberation Sans");
    let warning = (!known).then(|| {
        format!("font \"{family}\" is not shipped with peeltrim; drawn in Liberation Sans (its default, as OpenSCAD falls back to its default font)")
    });
    (data, warning)
}

/// `text(...)` of `node`, in its own frame.
pub fn region(node: &Node, warnings: &mut Vec<String>) -> Result<Region, ScadError> {
    let a = Args::new(
        node,
        &["text", "size", "font"],
        &[
            "direction",
            "language",
            "script",
            "halign",
            "valign",
            "spacing",
        ],
        warnings,
    )?;
    let string = |name: &str, default: &str| -> Result<String, ScadError> {
        Ok(match a.get(name) {
            None => default.to_string(),
            Some(v) => match &v.kind {
                ValueKind::Str(s) => s.clone(),
                _ => {
                    return Err(ScadError::new(
                        v.pos,
                        format!("`{name}` of `text` must be a string"),
                    ))
                }
            },
        })
    };
    let text = match a.get("text") {
        Some(v) if !matches!(v.kind, ValueKind::Str(_)) => {
            // OpenSCAD prints numbers given as text as strings; anything else
            // is not text.
            return Err(ScadError::new(v.pos, "`text` of `text` must be a string"));
        }
        _ => string("text", "")?,
    };
    let size = a.number("size")?.unwrap_or(10.0);
    let spacing = a.number("spacing")?.unwrap_or(1.0);
    let font = string("font", "")?;
    let direction = string("direction", "ltr")?;
    let halign = string("halign", "left")?;
    let valign = string("valign", "baseline")?;
    let res = super::convert::resolution(&a, warnings)?;
    let at = format!("{}:{}", node.pos.line, node.pos.col);
    let chars: Vec<char> = text.chars().collect();
    if chars.len() > MAX_CHARS {
        return Err(ScadError::new(
            node.pos,
            format!(
                "`text` has {} characters; at most {MAX_CHARS} are accepted: split it",
                chars.len()
            ),
        ));
    }
    if !(size > 0.0) || chars.is_empty() {
        return Ok(Region::default());
    }
    let fragments = tessellate::fragments(size, res);
    if fragments > crate::scene::load::MAX_DIVISIONS as u64 {
        return Err(ScadError::new(
            node.pos,
            format!(
                "`text` would have {fragments} fragments (from $fn = {}, $fa = {}, $fs = {}); at most {} are accepted: lower $fn or raise $fa/$fs",
                res.fn_, res.fa, res.fs, crate::scene::load::MAX_DIVISIONS
            ),
        ));
    }
    let segments = (fragments / 8 + 1).max(2) as usize;
    let (data, warning) = face_for(&font);
    if let Some(w) = warning {
        warnings.push(format!("{at}: {w}"));
    }
    let face = ttf_parser::Face::parse(data, 0)
        .map_err(|e| ScadError::new(node.pos, format!("the shipped font cannot be read ({e})")))?;
    let upem = face.units_per_em() as f64;
    // Font units → model units for outlines, and for advances/extents.
    let k = size * 100.0 / 72.0 / upem;
    let k_adv = k * 1000.0 / 1024.0;
    let vertical = matches!(direction.as_str(), "ttb" | "btt");
    let mut order: Vec<char> = chars;
    if direction == "rtl" || direction == "btt" {
        order.reverse();
    }
    for (name, v, ok) in [
        (
            "direction",
            &direction,
            ["ltr", "rtl", "ttb", "btt"].as_slice(),
        ),
        ("halign", &halign, ["left", "center", "right"].as_slice()),
        (
            "valign",
            &valign,
            ["baseline", "bottom", "center", "top"].as_slice(),
        ),
    ] {
        if !ok.contains(&v.as_str()) {
            warnings.push(format!(
                "{at}: unknown `{name}` \"{v}\" of `text` (use {}); taken as \"{}\", as OpenSCAD does",
                ok.iter().map(|s| format!("\"{s}\"")).collect::<Vec<_>>().join(", "),
                ok[0]
            ));
        }
    }
    let line = (face.ascender() as f64 - face.descender() as f64) * k_adv;
    // Glyphs, their pens, and the extents OpenSCAD aligns by.
    let mut glyphs = Vec::new();
    let (mut width, mut ascend, mut descend) = (0.0f64, 0.0f64, 0.0f64);
    let mut pen = DVec2::ZERO;
    for c in order {
        let Some(g) = face.glyph_index(c).or_else(|| face.glyph_index('\u{fffd}')) else {
            continue;
        };
        let adv = face.glyph_hor_advance(g).unwrap_or(0) as f64 * k_adv * spacing;
        let bbox = face.glyph_bounding_box(g);
        // Grid-fitted box in OpenSCAD's 26.6 units (1/64 pixel = 1/1000 unit).
        let fit = |v: f64, up: bool| {
            let u = v * k * 1000.0 / 64.0;
            (if up { u.ceil() } else { u.floor() }) * 64.0 / 1024.0
        };
        let origin = if vertical {
            DVec2::new(-adv / 2.0, -line * 0.8)
        } else {
            DVec2::ZERO
        };
        glyphs.push((g, pen + origin));
        match bbox {
            Some(b) if !vertical => {
                ascend = ascend.max(fit(b.y_max as f64, true).max(0.0));
                descend = descend.max((-fit(b.y_min as f64, false)).max(0.0));
            }
            Some(b) => {
                width = width.max(fit(b.x_max as f64, true) - fit(b.x_min as f64, false));
            }
            None => {}
        }
        if vertical {
            pen.y -= line * spacing;
            ascend -= line * spacing;
        } else {
            pen.x += adv;
            width += adv;
        }
    }
    let x_offset = match halign.as_str() {
        "right" => -width,
        "center" => -width / 2.0,
        _ => 0.0,
    };
    let y_offset = match valign.as_str() {
        "top" => -ascend,
        "center" => descend / 2.0 - ascend / 2.0,
        "bottom" => descend,
        _ => 0.0,
    };
    let shift = DVec2::new(x_offset, y_offset);
    let mut contours: Vec<Vec<[f64; 2]>> = Vec::new();
    for (g, at) in glyphs {
        let mut b = Flatten {
            k,
            at: at + shift,
            segments,
            pen: DVec2::ZERO,
            current: Vec::new(),
            out: &mut contours,
        };
        face.outline_glyph(g, &mut b);
        b.finish();
    }
    if contours.is_empty() {
        return Ok(Region::default());
    }
    // Before the polygon library snaps everything to one grid over the extent.
    if contours
        .iter()
        .flatten()
        .any(|p| !(p[0].abs().max(p[1].abs()) <= super::extrude::MAX_COORD))
    {
        return Err(ScadError::new(
            node.pos,
            format!(
                "`text` reaches coordinates beyond ±{:e} (from its size and spacing); scale the model down",
                super::extrude::MAX_COORD
            ),
        ));
    }
    Ok(Region::from_shapes(overlay(
        &contours,
        &[],
        OverlayRule::Subject,
        FillRule::NonZero,
    )))
}

/// `DrawingCallback`: glyph contours in font units → flattened model contours.
struct Flatten<'a> {
    k: f64,
    at: DVec2,
    segments: usize,
    pen: DVec2,
    current: Vec<[f64; 2]>,
    out: &'a mut Vec<Vec<[f64; 2]>>,
}

impl Flatten<'_> {
    fn vertex(&mut self, v: DVec2) {
        let p = v * self.k + self.at;
        self.current.push([p.x, p.y]);
    }
    fn finish(&mut self) {
        if self.current.len() >= 3 {
            self.out.push(std::mem::take(&mut self.current));
        }
        self.current.clear();
    }
}

impl ttf_parser::OutlineBuilder for Flatten<'_> {
    fn move_to(&mut self, x: f32, y: f32) {
        self.finish();
        self.pen = DVec2::new(x as f64, y as f64);
        self.vertex(self.pen);
    }
    fn line_to(&mut self, x: f32, y: f32) {
        self.pen = DVec2::new(x as f64, y as f64);
        self.vertex(self.pen);
    }
    fn quad_to(&mut self, x1: f32, y1: f32, x: f32, y: f32) {
        let (p0, c, p) = (
            self.pen,
            DVec2::new(x1 as f64, y1 as f64),
            DVec2::new(x as f64, y as f64),
        );
        for i in 1..=self.segments {
            let a = i as f64 / self.segments as f64;
            self.vertex(p0 * (1.0 - a).powi(2) + c * 2.0 * (1.0 - a) * a + p * a * a);
        }
        self.pen = p;
    }
    fn curve_to(&mut self, x1: f32, y1: f32, x2: f32, y2: f32, x: f32, y: f32) {
        let (p0, c1, c2, p) = (
            self.pen,
            DVec2::new(x1 as f64, y1 as f64),
            DVec2::new(x2 as f64, y2 as f64),
            DVec2::new(x as f64, y as f64),
        );
        for i in 1..=self.segments {
            let a = i as f64 / self.segments as f64;
            let b = 1.0 - a;
            self.vertex(
                p0 * b.powi(3) + c1 * 3.0 * b * b * a + c2 * 3.0 * b * a * a + p * a.powi(3),
            );
        }
        self.pen = p;
    }
    fn close(&mut self) {}
}
