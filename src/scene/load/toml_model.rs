//! The scene file's TOML model (docs/scene-format.md): one serde struct per table,
//! unknown keys refused, spans kept for error lines; `"#rrggbb"` colours.

use serde::de::{self, Deserializer};
use serde::Deserialize;
use toml::Spanned;

use crate::scene::vector::{self, RawVec};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct FileT {
    pub(super) name: Option<String>,
    pub(super) camera: Option<Spanned<CameraT>>,
    pub(super) render: Option<Spanned<RenderT>>,
    #[serde(default)]
    pub(super) primitive: Vec<Spanned<ShapeT>>,
    pub(super) csg: Option<Spanned<CsgT>>,
    #[serde(default)]
    pub(super) solid: Vec<Spanned<SolidT>>,
    #[serde(default)]
    pub(super) surface: Vec<Spanned<ShapeT>>,
    pub(super) light: Option<Spanned<crate::scene::light::LightT>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CameraT {
    pub(super) eye: Option<RawVec>,
    pub(super) target: Option<RawVec>,
    pub(super) up: Option<RawVec>,
    pub(super) fov_y_deg: Option<f64>,
    pub(super) projection: Option<ProjT>,
    pub(super) ortho_height: Option<f64>,
    pub(super) near: Option<f64>,
    pub(super) far: Option<f64>,
    pub(super) fit: Option<bool>,
}

impl CameraT {
    /// Without `[camera]`: the eye looks from direction `[3, 2, 4]` at the origin,
    /// `fit = true`.
    pub(super) fn fitted_default() -> Self {
        CameraT {
            eye: Some(vector::raw([3.0, 2.0, 4.0])),
            target: None,
            up: None,
            fov_y_deg: None,
            projection: None,
            ortho_height: None,
            near: None,
            far: None,
            fit: Some(true),
        }
    }
}

#[derive(Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
pub(super) enum ProjT {
    Perspective,
    Orthographic,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RenderT {
    pub(super) width: Option<u32>,
    pub(super) height: Option<u32>,
    pub(super) background: Option<Color>,
    /// Samples per pixel: 1, 2, 4 or 8.
    pub(super) samples: Option<u32>,
    pub(super) alpha: Option<f64>,
    pub(super) interference: Option<bool>,
    pub(super) style: Option<String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CsgT {
    pub(super) expr: Option<String>,
    /// An OpenSCAD `.csg` file (relative to the scene file) as the whole model.
    pub(super) openscad: Option<String>,
    pub(super) skip_unsupported: Option<bool>,
    pub(super) alpha: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct SolidT {
    pub(super) name: String,
    pub(super) expr: String,
    pub(super) alpha: Option<f64>,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Debug)]
#[serde(rename_all = "lowercase")]
pub(super) enum ShapeKind {
    Box,
    Sphere,
    Cylinder,
    Cone,
    Torus,
    Mesh,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
pub(super) enum KeepT {
    In,
    Out,
    Paint,
}

/// A `[[primitive]]` or `[[surface]]` table (one struct so the shape keys are shared;
/// the surface-only keys are rejected on primitives after parsing).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ShapeT {
    pub(super) name: String,
    pub(super) shape: ShapeKind,
    pub(super) size: Option<RawVec>,
    pub(super) radius: Option<f64>,
    pub(super) minor_radius: Option<f64>,
    pub(super) height: Option<f64>,
    pub(super) segments: Option<u32>,
    pub(super) rings: Option<u32>,
    pub(super) path: Option<String>,
    pub(super) scale: Option<RawVec>,
    pub(super) rotate_deg: Option<RawVec>,
    pub(super) translate: Option<RawVec>,
    pub(super) color: Option<Color>,
    pub(super) trim: Option<String>,
    pub(super) keep: Option<KeepT>,
    pub(super) paint_color: Option<Color>,
    pub(super) alpha: Option<f64>,
}

/// `"#rrggbb"`.
#[derive(Clone, Copy)]
pub(super) struct Color(pub(super) [u8; 3]);

impl<'de> Deserialize<'de> for Color {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        parse_color(&s).map(Color).ok_or_else(|| {
            de::Error::custom(format!(
                "invalid colour \"{s}\": write \"#rrggbb\" with six hexadecimal digits, e.g. \"#d0a040\""
            ))
        })
    }
}

pub(super) fn parse_color(s: &str) -> Option<[u8; 3]> {
    let h = s.strip_prefix('#')?;
    if h.len() != 6 || !h.chars().all(|c| c.is_ascii_hexdigit()) {
        return None;
    }
    let b = |i: usize| u8::from_str_radix(&h[i..i + 2], 16).ok();
    Some([b(0)?, b(2)?, b(4)?])
}
