//! Loading a scene file (CONTRACT.md §1): TOML → validated [`Scene`] with
//! world-space meshes, parsed expressions, and a camera with definite near/far.
//!
//! Every user mistake is a [`SceneError`] naming the file, the line (TOML syntax and
//! type errors: line and column) or the key path (`primitive[3] "B": radius`, entries
//! counted from 1), and the fix. Loading only reads files.
//!
//! Choices the contract leaves open (also in the README):
//! - `[camera]` may be omitted: the eye looks from direction `[3, 2, 4]` at the
//!   origin with `fit = true`. When present, `eye` is required and `target` defaults
//!   to `[0, 0, 0]`.
//! - `projection = "orthographic"` without `fit` requires `ortho_height`.
//! - A scene needs `[csg]`, `[[solid]]`s or `[[surface]]`s (a scene of trimmed
//!   surfaces only is allowed); with none of them nothing would be drawn: error.
//! - Keys that do not apply to a shape (`radius` on a box) are errors, as are
//!   `trim`/`keep`/`paint_color` on a primitive.
//! - A torus needs `minor_radius < radius` (otherwise it self-intersects).
//! - `segments` and `rings` are at most 65536 and their product at most 2^24, and
//!   the meshes' estimated memory ([`super::cost`]) must fit the memory budget.
//! - Vectors are exactly 3 numbers (`vector.rs`); a file named `.scad` is
//!   refused as OpenSCAD source ([`super::kind`]).
//! - Surface `keep` defaults to `"in"`, `paint_color` to `"#c02020"`; a `trim`
//!   may be unbounded (e.g. `!A`), a solid may not.
//! - Names share one namespace across primitives and surfaces; solid names are
//!   unique among solids.
//! - `LoadOptions::size` overrides `[render]` width/height before `fit`, and the
//!   final size is stored in `Scene::render`.
//! - Extension: `[csg] openscad = "model.csg"` makes an OpenSCAD model the whole
//!   scene (`super::openscad`), with OpenSCAD's camera and background defaults;
//!   a path ending in `.csg` is loaded as that scene with every default.

use glam::DVec3;
use serde::de::{self, Deserializer};
use serde::Deserialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use toml::Spanned;

use super::cost;
use super::fit;
use super::kind;
use super::obj::load_obj;
use super::shapes::{self, default_rings, DEFAULT_SEGMENTS};
use super::validate::{check_closed, signed_volume};
use super::vector::{self, RawVec};
use super::{
    Camera, Keep, Mesh, Primitive, Projection, RenderSettings, Scene, Shape, Solid, Surface,
};
use crate::csg::Expr;

/// Options from the command line that change how a scene is resolved.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// `--size WxH`: overrides `[render]` width and height (and so what `fit` frames).
    pub size: Option<(u32, u32)>,
}

/// A user mistake in a scene file (or a file it names).
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{}: cannot read the scene file: {source}", path.display())]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    /// TOML syntax, unknown keys, wrong types, missing keys: with line and column.
    #[error("{}:{line}:{column}: {message}\n{snippet}", path.display())]
    Syntax {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
        snippet: String,
    },
    /// A file that is not a scene (e.g. OpenSCAD source).
    #[error("{}: {message}", path.display())]
    Unsupported { path: PathBuf, message: String },
    /// A value that parses but is not valid, located by its key path.
    #[error("{}{}: {key}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Invalid {
        path: PathBuf,
        /// Line of the table the key belongs to, when known.
        line: Option<usize>,
        key: String,
        message: String,
    },
}

/// Largest `segments` / `rings`, and of their product.
pub const MAX_DIVISIONS: u32 = 65536;
pub const MAX_GRID: u64 = 1 << 24;
/// Largest image side accepted from `[render]` or `--size`.
pub const MAX_SIZE: u32 = 16384;

// ---------------------------------------------------------------- TOML model

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileT {
    name: Option<String>,
    camera: Option<Spanned<CameraT>>,
    render: Option<Spanned<RenderT>>,
    #[serde(default)]
    primitive: Vec<Spanned<ShapeT>>,
    csg: Option<Spanned<CsgT>>,
    #[serde(default)]
    solid: Vec<Spanned<SolidT>>,
    #[serde(default)]
    surface: Vec<Spanned<ShapeT>>,
    light: Option<Spanned<super::light::LightT>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraT {
    eye: Option<RawVec>,
    target: Option<RawVec>,
    up: Option<RawVec>,
    fov_y_deg: Option<f64>,
    projection: Option<ProjT>,
    ortho_height: Option<f64>,
    near: Option<f64>,
    far: Option<f64>,
    fit: Option<bool>,
}

impl CameraT {
    /// Without `[camera]`: the eye looks from direction `[3, 2, 4]` at the origin,
    /// `fit = true`.
    fn fitted_default() -> Self {
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
enum ProjT {
    Perspective,
    Orthographic,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderT {
    width: Option<u32>,
    height: Option<u32>,
    background: Option<Color>,
    alpha: Option<f64>,
    interference: Option<bool>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CsgT {
    expr: Option<String>,
    /// An OpenSCAD `.csg` file (relative to the scene file) as the whole model.
    openscad: Option<String>,
    skip_unsupported: Option<bool>,
    alpha: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SolidT {
    name: String,
    expr: String,
    alpha: Option<f64>,
}

#[derive(Deserialize, Clone, Copy, PartialEq, Debug)]
#[serde(rename_all = "lowercase")]
enum ShapeKind {
    Box,
    Sphere,
    Cylinder,
    Cone,
    Torus,
    Mesh,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(rename_all = "lowercase")]
enum KeepT {
    In,
    Out,
    Paint,
}

/// A `[[primitive]]` or `[[surface]]` table (one struct so the shape keys are shared;
/// the surface-only keys are rejected on primitives after parsing).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ShapeT {
    name: String,
    shape: ShapeKind,
    size: Option<RawVec>,
    radius: Option<f64>,
    minor_radius: Option<f64>,
    height: Option<f64>,
    segments: Option<u32>,
    rings: Option<u32>,
    path: Option<String>,
    scale: Option<RawVec>,
    rotate_deg: Option<RawVec>,
    translate: Option<RawVec>,
    color: Option<Color>,
    trim: Option<String>,
    keep: Option<KeepT>,
    paint_color: Option<Color>,
    alpha: Option<f64>,
}

/// `"#rrggbb"`.
#[derive(Clone, Copy)]
struct Color([u8; 3]);

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

fn parse_color(s: &str) -> Option<[u8; 3]> {
    let h = s.strip_prefix('#')?;
    if h.len() != 6 || !h.chars().all(|c| c.is_ascii_hexdigit()) {
        return None;
    }
    let b = |i: usize| u8::from_str_radix(&h[i..i + 2], 16).ok();
    Some([b(0)?, b(2)?, b(4)?])
}

// ---------------------------------------------------------------- loading

/// Loads and validates a scene file.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Scene, SceneError> {
    load_with(path, opts, false)
}

/// [`load`], with `skip_unsupported` (`--skip-unsupported`): unsupported nodes of
/// an OpenSCAD model are dropped with a warning instead of being an error. A path
/// ending in `.csg` is an OpenSCAD model (see [`super::openscad`]).
pub fn load_with(
    path: &Path,
    opts: &LoadOptions,
    skip_unsupported: bool,
) -> Result<Scene, SceneError> {
    kind::refuse_unsupported(path)?;
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    load_str_with(&text, path, opts, skip_unsupported).map_err(|e| kind::hint(path, e))
}

/// Loads a scene from its text; `path` names it in errors and meshes are relative
/// to its directory.
pub fn load_str(text: &str, path: &Path, opts: &LoadOptions) -> Result<Scene, SceneError> {
    load_str_with(text, path, opts, false)
}

fn is_csg_path(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csg"))
}

fn load_str_with(
    text: &str,
    path: &Path,
    opts: &LoadOptions,
    skip_unsupported: bool,
) -> Result<Scene, SceneError> {
    // A `.csg` file is the scene `[csg] openscad = "<it>"` with every default.
    let file_name = path.file_name().map(|f| f.to_string_lossy().into_owned());
    let virtual_toml = match (&file_name, is_csg_path(path)) {
        (Some(f), true) => Some(format!(
            "name = {}\n[csg]\nopenscad = {}\n",
            toml::Value::String(
                path.file_stem()
                    .map_or_else(|| "csg".to_string(), |s| s.to_string_lossy().into_owned())
            ),
            toml::Value::String(f.clone())
        )),
        _ => None,
    };
    Loader {
        path,
        text: virtual_toml.as_deref().unwrap_or(text),
        dir: path.parent().unwrap_or(Path::new(".")).to_path_buf(),
        warnings: Vec::new(),
        mesh_bytes: std::cell::Cell::new(0),
        skip_unsupported,
        inline_csg: virtual_toml.is_some().then_some(text),
    }
    .run(opts)
}

struct Loader<'a> {
    path: &'a Path,
    text: &'a str,
    dir: PathBuf,
    warnings: Vec<String>,
    /// Estimated bytes of the meshes so far ([`cost`]), against the budget.
    mesh_bytes: std::cell::Cell<u64>,
    /// `--skip-unsupported` (or'ed with `[csg] skip_unsupported`).
    skip_unsupported: bool,
    /// The text of the `.csg` file this scene was made for (a `.csg` loaded
    /// directly), instead of reading `[csg] openscad` from disk.
    inline_csg: Option<&'a str>,
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
    (line, col)
}

fn valid_name(s: &str) -> bool {
    let mut c = s.chars();
    matches!(c.next(), Some(f) if f.is_ascii_alphabetic() || f == '_')
        && c.all(|ch| ch.is_ascii_alphanumeric() || ch == '_')
}

impl Loader<'_> {
    fn line(&self, span: std::ops::Range<usize>) -> Option<usize> {
        Some(line_col(self.text, span.start).0)
    }

    /// The `alpha` keys of the primitives, the solids (`[csg]` first) and
    /// `[render]` (extension, [`super::Appearance`]).
    fn appearance(
        &self,
        file: &FileT,
        render_alpha: Option<f64>,
        render_line: Option<usize>,
    ) -> Result<super::Appearance, SceneError> {
        let primitive_alpha = file
            .primitive
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let key = format!("primitive[{}] \"{}\"", i + 1, t.get_ref().name);
                self.alpha(t.get_ref().alpha, self.line(t.span()), &key)
            })
            .collect::<Result<_, _>>()?;
        let csg = file
            .csg
            .iter()
            .map(|c| self.alpha(c.get_ref().alpha, self.line(c.span()), "csg"));
        let solids = file.solid.iter().enumerate().map(|(i, t)| {
            let key = format!("solid[{}] \"{}\"", i + 1, t.get_ref().name);
            self.alpha(t.get_ref().alpha, self.line(t.span()), &key)
        });
        Ok(super::Appearance {
            alpha: self.alpha(render_alpha, render_line, "render")?,
            solid_alpha: csg.chain(solids).collect::<Result<_, _>>()?,
            primitive_alpha,
            interference: file
                .render
                .as_ref()
                .and_then(|r| r.get_ref().interference)
                .unwrap_or(false),
            light: None,
        })
    }

    /// An optional `alpha` key, checked to lie in (0, 1].
    fn alpha(
        &self,
        a: Option<f64>,
        line: Option<usize>,
        key: &str,
    ) -> Result<Option<f64>, SceneError> {
        a.map(super::appearance::check_alpha)
            .transpose()
            .map_err(|m| self.invalid(line, format!("{key}: alpha"), m))
    }

    fn invalid(
        &self,
        line: Option<usize>,
        key: impl Into<String>,
        message: impl Into<String>,
    ) -> SceneError {
        SceneError::Invalid {
            path: self.path.to_path_buf(),
            line,
            key: key.into(),
            message: message.into(),
        }
    }

    fn syntax(&self, e: toml::de::Error) -> SceneError {
        let (line, column, snippet) = match e.span() {
            Some(span) => {
                let (l, c) = line_col(self.text, span.start);
                let src = self.text.lines().nth(l - 1).unwrap_or("");
                let width = self.text[span.start..span.end.min(self.text.len())]
                    .lines()
                    .next()
                    .map(|s| s.chars().count())
                    .unwrap_or(1)
                    .max(1);
                let gutter = l.to_string().len();
                let snippet = format!(
                    "{:g$} |\n{l} | {src}\n{:g$} | {}{}",
                    "",
                    "",
                    " ".repeat(c - 1),
                    "^".repeat(width),
                    g = gutter
                );
                (l, c, snippet)
            }
            None => (1, 1, String::new()),
        };
        SceneError::Syntax {
            path: self.path.to_path_buf(),
            line,
            column,
            message: e.message().trim_end().to_string(),
            snippet,
        }
    }

    fn run(mut self, opts: &LoadOptions) -> Result<Scene, SceneError> {
        let file: FileT = toml::from_str(self.text).map_err(|e| self.syntax(e))?;
        if file
            .csg
            .as_ref()
            .is_some_and(|c| c.get_ref().openscad.is_some())
        {
            return self.run_openscad(file, opts);
        }

        // Names: one namespace for primitives and surfaces.
        let mut names: HashMap<String, String> = HashMap::new();
        let tables = file
            .primitive
            .iter()
            .enumerate()
            .map(|(i, p)| ("primitive", i, p))
            .chain(
                file.surface
                    .iter()
                    .enumerate()
                    .map(|(i, s)| ("surface", i, s)),
            );
        for (kind, i, t) in tables {
            let name = &t.get_ref().name;
            let key = format!("{kind}[{}] \"{name}\"", i + 1);
            if !valid_name(name) {
                return Err(self.invalid(
                    self.line(t.span()),
                    format!("{key}: name"),
                    format!(
                        "\"{name}\" is not a valid name: use a letter or `_` followed by letters, digits or `_` (e.g. \"A\", \"hole_2\")"
                    ),
                ));
            }
            if let Some(prev) = names.insert(name.clone(), key.clone()) {
                return Err(self.invalid(
                    self.line(t.span()),
                    format!("{key}: name"),
                    format!(
                        "\"{name}\" is already the name of {}; names must be unique in the file",
                        prev.split(' ').next().unwrap_or(&prev)
                    ),
                ));
            }
        }
        let prim_index: HashMap<&str, u32> = file
            .primitive
            .iter()
            .enumerate()
            .map(|(i, p)| (p.get_ref().name.as_str(), i as u32))
            .collect();

        // Primitives (local meshes kept for validation in file coordinates).
        let mut primitives = Vec::with_capacity(file.primitive.len());
        let mut local_meshes = Vec::with_capacity(file.primitive.len());
        for (i, t) in file.primitive.iter().enumerate() {
            let p = t.get_ref();
            let key = format!("primitive[{}] \"{}\"", i + 1, p.name);
            let line = self.line(t.span());
            for (k, present) in [
                ("trim", p.trim.is_some()),
                ("keep", p.keep.is_some()),
                ("paint_color", p.paint_color.is_some()),
            ] {
                if present {
                    return Err(self.invalid(
                        line,
                        format!("{key}: {k}"),
                        format!("`{k}` applies only to a [[surface]]; remove it or make this table a [[surface]]"),
                    ));
                }
            }
            let (shape, local, transform) = self.build_shape(p, &key, line)?;
            let mesh = shapes::apply_transform(&local, &transform);
            primitives.push(Primitive {
                name: p.name.clone(),
                shape,
                transform,
                mesh,
                color: p.color.map_or([0xc0, 0xc0, 0xc0], |c| c.0),
                used: false,
            });
            local_meshes.push(local);
        }

        // Expressions.
        let mut solids = Vec::new();
        if let Some(csg) = &file.csg {
            if let Some(s) = file.solid.first() {
                return Err(self.invalid(
                    self.line(s.span()),
                    "solid",
                    "[csg] and [[solid]] cannot be used together: move the [csg] expression into a [[solid]] table, or use only [csg]",
                ));
            }
            let line = self.line(csg.span());
            let src = csg.get_ref().expr.as_deref().ok_or_else(|| {
                self.invalid(
                    line,
                    "csg: expr",
                    "missing: [csg] needs `expr = \"...\"` over the primitive names, or `openscad = \"model.csg\"`",
                )
            })?;
            if csg.get_ref().skip_unsupported.is_some() {
                return Err(self.invalid(
                    line,
                    "csg: skip_unsupported",
                    "`skip_unsupported` applies only with `openscad = \"model.csg\"`; remove it",
                ));
            }
            let expr = self.parse_expr(src, &prim_index, line, "csg: expr")?;
            self.check_bounded(&expr, line, "csg: expr", src)?;
            solids.push(Solid {
                name: file.name.clone().unwrap_or_else(|| "csg".to_string()),
                expr,
            });
        }
        let mut solid_names: HashMap<&str, usize> = HashMap::new();
        for (i, t) in file.solid.iter().enumerate() {
            let s = t.get_ref();
            let line = self.line(t.span());
            let key = format!("solid[{}] \"{}\"", i + 1, s.name);
            if let Some(prev) = solid_names.insert(&s.name, i) {
                return Err(self.invalid(
                    line,
                    format!("{key}: name"),
                    format!(
                        "\"{}\" is already the name of solid[{}]; solid names must be unique",
                        s.name,
                        prev + 1
                    ),
                ));
            }
            let k = format!("{key}: expr");
            let expr = self.parse_expr(&s.expr, &prim_index, line, &k)?;
            self.check_bounded(&expr, line, &k, &s.expr)?;
            solids.push(Solid {
                name: s.name.clone(),
                expr,
            });
        }

        // Surfaces.
        let mut surfaces = Vec::with_capacity(file.surface.len());
        for (i, t) in file.surface.iter().enumerate() {
            let s = t.get_ref();
            let line = self.line(t.span());
            let key = format!("surface[{}] \"{}\"", i + 1, s.name);
            if s.alpha.is_some() {
                return Err(self.invalid(
                    line,
                    format!("{key}: alpha"),
                    "`alpha` applies to a [[primitive]], a [[solid]], [csg] or [render]; surfaces are drawn opaque: remove it",
                ));
            }
            let trim_src = s.trim.as_deref().ok_or_else(|| {
                self.invalid(
                    line,
                    format!("{key}: trim"),
                    "missing `trim`: give the trimming volume over primitive names, e.g. trim = \"A + B\"",
                )
            })?;
            let trim = self.parse_expr(trim_src, &prim_index, line, &format!("{key}: trim"))?;
            let (shape, local, transform) = self.build_shape(s, &key, line)?;
            let mesh = shapes::apply_transform(&local, &transform);
            surfaces.push(Surface {
                name: s.name.clone(),
                shape,
                transform,
                mesh,
                color: s.color.map_or([0xc0, 0xc0, 0xc0], |c| c.0),
                trim,
                keep: match s.keep.unwrap_or(KeepT::In) {
                    KeepT::In => Keep::In,
                    KeepT::Out => Keep::Out,
                    KeepT::Paint => Keep::Paint,
                },
                paint_color: s.paint_color.map_or([0xc0, 0x20, 0x20], |c| c.0),
            });
        }
        if solids.is_empty() && surfaces.is_empty() {
            return Err(self.invalid(
                None,
                "csg",
                "nothing to draw: add a [csg] table with `expr = \"...\"`, [[solid]] tables, or [[surface]] tables",
            ));
        }

        // Which primitives are drawn; those must bound solids.
        for e in solids
            .iter()
            .map(|s| &s.expr)
            .chain(surfaces.iter().map(|s| &s.trim))
        {
            for p in e.leaves() {
                primitives[p as usize].used = true;
            }
        }
        for (i, p) in primitives.iter().enumerate() {
            let line = self.line(file.primitive[i].span());
            let key = format!("primitive[{}] \"{}\"", i + 1, p.name);
            if !p.used {
                self.warnings.push(format!(
                    "{}: {key} is not named by any expression and is not drawn",
                    self.path.display()
                ));
                continue;
            }
            if matches!(p.shape, Shape::Mesh { .. }) {
                let local = &local_meshes[i];
                if let Err(problem) = check_closed(local) {
                    return Err(self.invalid(
                        line,
                        format!("{key}: path"),
                        format!(
                            "the mesh is used in a CSG expression but is not a closed, consistently oriented surface: {}",
                            problem.describe(local)
                        ),
                    ));
                }
                let v = signed_volume(local);
                if v < 0.0 {
                    return Err(self.invalid(
                        line,
                        format!("{key}: path"),
                        "the mesh is inside out (negative signed volume: its triangles wind clockwise seen from outside); reverse the vertex order of every face",
                    ));
                }
                if v == 0.0 {
                    return Err(self.invalid(
                        line,
                        format!("{key}: path"),
                        "the mesh encloses no volume",
                    ));
                }
            }
        }

        self.finish(file, opts, primitives, solids, surfaces, false)
    }

    /// `[csg] openscad = "model.csg"`: the OpenSCAD model is the whole scene.
    fn run_openscad(mut self, file: FileT, opts: &LoadOptions) -> Result<Scene, SceneError> {
        let csg = file.csg.as_ref().expect("checked by the caller");
        let line = self.line(csg.span());
        let c = csg.get_ref();
        let rel = c.openscad.as_deref().expect("checked by the caller");
        if c.expr.is_some() {
            return Err(self.invalid(
                line,
                "csg: openscad",
                "`expr` and `openscad` cannot be used together: the OpenSCAD model is the whole solid; remove `expr`",
            ));
        }
        for (table, span) in [
            ("[[primitive]]", file.primitive.first().map(|t| t.span())),
            ("[[solid]]", file.solid.first().map(|t| t.span())),
            ("[[surface]]", file.surface.first().map(|t| t.span())),
        ] {
            if let Some(span) = span {
                return Err(self.invalid(
                    self.line(span),
                    table.trim_matches(['[', ']']),
                    format!("{table} cannot be used with [csg] openscad: the .csg file is the whole model; remove the table or the `openscad` key"),
                ));
            }
        }
        let skip = self.skip_unsupported || c.skip_unsupported.unwrap_or(false);
        let model = match self.inline_csg {
            Some(text) => super::openscad::model_from_str(text, self.path, skip)?,
            None => {
                let full = self.dir.join(rel);
                super::openscad::read_model(&full, skip).map_err(|e| match e {
                    SceneError::Read { path, source } => self.invalid(
                        line,
                        "csg: openscad",
                        format!(
                            "cannot read {}: {source} (the path is relative to the scene file's folder)",
                            path.display()
                        ),
                    ),
                    e => e,
                })?
            }
        };
        self.warnings.extend(model.warnings);
        let solids = vec![Solid {
            name: file.name.clone().unwrap_or_else(|| "csg".to_string()),
            expr: model.expr,
        }];
        self.finish(file, opts, model.primitives, solids, Vec::new(), true)
    }

    /// Render settings and the camera, then the scene. `openscad`: OpenSCAD's
    /// defaults (its view direction with Z up, field of view and background).
    fn finish(
        mut self,
        file: FileT,
        opts: &LoadOptions,
        primitives: Vec<Primitive>,
        solids: Vec<Solid>,
        surfaces: Vec<Surface>,
        openscad: bool,
    ) -> Result<Scene, SceneError> {
        // Render settings.
        let r = file
            .render
            .as_ref()
            .map(|r| (r.get_ref(), self.line(r.span())));
        let mut render = RenderSettings {
            width: r.and_then(|r| r.0.width).unwrap_or(800),
            height: r.and_then(|r| r.0.height).unwrap_or(800),
            background: r.and_then(|r| r.0.background).map_or(
                if openscad {
                    super::openscad::DEFAULT_BACKGROUND
                } else {
                    [0x20, 0x20, 0x20]
                },
                |c| c.0,
            ),
        };
        for (k, v) in [("width", render.width), ("height", render.height)] {
            if v == 0 || v > MAX_SIZE {
                return Err(self.invalid(
                    r.and_then(|r| r.1),
                    format!("render: {k}"),
                    format!("{v} is out of range: the image size must be 1 to {MAX_SIZE} pixels"),
                ));
            }
        }
        if let Some((w, h)) = opts.size {
            if w == 0 || h == 0 || w > MAX_SIZE || h > MAX_SIZE {
                return Err(self.invalid(
                    None,
                    "--size",
                    format!("{w}x{h} is out of range: each side must be 1 to {MAX_SIZE} pixels"),
                ));
            }
            render.width = w;
            render.height = h;
        }

        let mut appearance =
            self.appearance(&file, r.and_then(|r| r.0.alpha), r.and_then(|r| r.1))?;

        let drawn: Vec<&Mesh> = primitives
            .iter()
            .filter(|p| p.used)
            .map(|p| &p.mesh)
            .chain(surfaces.iter().map(|s| &s.mesh))
            .collect();
        let default = if openscad {
            CameraT {
                eye: Some(vector::raw(super::openscad::default_view_dir().to_array())),
                up: Some(vector::raw([0.0, 0.0, 1.0])),
                fov_y_deg: Some(super::openscad::DEFAULT_FOV_Y_DEG),
                ..CameraT::fitted_default()
            }
        } else {
            CameraT::fitted_default()
        };
        let camera = self.camera(file.camera.as_ref(), &default, &render, &drawn)?;
        if let Some(l) = &file.light {
            let light = super::light::resolve(l.get_ref(), drawn.iter().copied())
                .map_err(|(key, m)| self.invalid(self.line(l.span()), key, m))?;
            appearance.light = Some(light);
        }

        Ok(Scene {
            name: file.name,
            path: self.path.to_path_buf(),
            camera,
            render,
            primitives,
            solids,
            surfaces,
            warnings: self.warnings,
            appearance,
        })
    }

    fn parse_expr(
        &self,
        src: &str,
        prims: &HashMap<&str, u32>,
        line: Option<usize>,
        key: &str,
    ) -> Result<Expr, SceneError> {
        parse_expr(src, prims).map_err(|e| self.invalid(line, key, e))
    }

    fn check_bounded(
        &self,
        e: &Expr,
        line: Option<usize>,
        key: &str,
        src: &str,
    ) -> Result<(), SceneError> {
        if is_bounded(e) {
            return Ok(());
        }
        Err(self.invalid(
            line,
            key,
            format!(
                "\"{src}\" is unbounded (it contains every point far from all primitives, as `!A` or `!A + B` do); \
                 a solid must be bounded: use a complement only where it is intersected with a bounded term, \
                 e.g. `B !A` (= `B - A`)"
            ),
        ))
    }

    /// Adds a mesh's estimated bytes to the scene's and refuses the scene when the
    /// total exceeds the memory budget, before the mesh is built.
    fn charge(
        &self,
        line: Option<usize>,
        key: String,
        what: impl FnOnce() -> String,
        bytes: u64,
        fix: &str,
    ) -> Result<(), SceneError> {
        let total = self.mesh_bytes.get().saturating_add(bytes);
        self.mesh_bytes.set(total);
        crate::budget::current()
            .check(what, total, fix)
            .map_err(|e| self.invalid(line, key, e.to_string()))
    }

    /// A fixed-length vector key (`what` names its components in the fix), located
    /// at its own line.
    fn vec3(
        &self,
        raw: &RawVec,
        key: &str,
        what: &str,
        number_ok: bool,
    ) -> Result<DVec3, SceneError> {
        let line = self.line(raw.span());
        let v = if number_ok {
            vector::vec3_or_number(raw.get_ref(), what)
        } else {
            vector::vec3(raw.get_ref(), what)
        }
        .map_err(|m| self.invalid(line, key, m))?;
        self.finite3(v, line, key)
    }

    fn finite3(&self, v: [f64; 3], line: Option<usize>, key: &str) -> Result<DVec3, SceneError> {
        if v.iter().all(|x| x.is_finite()) {
            Ok(DVec3::from_array(v))
        } else {
            Err(self.invalid(line, key, format!("{v:?} must be finite numbers")))
        }
    }

    fn positive(
        &self,
        v: Option<f64>,
        line: Option<usize>,
        key: &str,
        shape: &str,
        what: &str,
    ) -> Result<f64, SceneError> {
        let v = v.ok_or_else(|| {
            self.invalid(
                line,
                key,
                format!(
                    "missing: a {shape} needs `{}` ({what})",
                    key.rsplit(' ').next().unwrap_or(key)
                ),
            )
        })?;
        if !(v.is_finite() && v > 0.0) {
            return Err(self.invalid(line, key, format!("{v} must be a positive finite number")));
        }
        Ok(v)
    }

    fn build_shape(
        &self,
        p: &ShapeT,
        key: &str,
        line: Option<usize>,
    ) -> Result<(Shape, Mesh, glam::DMat4), SceneError> {
        use ShapeKind as K;
        let kind = p.shape;
        let kname = format!("{kind:?}").to_lowercase();
        let allowed: &[&str] = match kind {
            K::Box => &["size"],
            K::Sphere => &["radius", "segments", "rings"],
            K::Cylinder | K::Cone => &["radius", "height", "segments"],
            K::Torus => &["radius", "minor_radius", "segments", "rings"],
            K::Mesh => &["path"],
        };
        for (k, present) in [
            ("size", p.size.is_some()),
            ("radius", p.radius.is_some()),
            ("minor_radius", p.minor_radius.is_some()),
            ("height", p.height.is_some()),
            ("segments", p.segments.is_some()),
            ("rings", p.rings.is_some()),
            ("path", p.path.is_some()),
        ] {
            if present && !allowed.contains(&k) {
                return Err(self.invalid(
                    line,
                    format!("{key}: {k}"),
                    format!(
                        "`{k}` does not apply to shape \"{kname}\" (it takes {}); remove it",
                        allowed.join(", ")
                    ),
                ));
            }
        }
        let k = |f: &str| format!("{key}: {f}");
        let segments = p.segments.unwrap_or(DEFAULT_SEGMENTS);
        if p.segments.is_some() && !(3..=MAX_DIVISIONS).contains(&segments) {
            return Err(self.invalid(
                line,
                k("segments"),
                format!("{segments} is out of range: use 3 to {MAX_DIVISIONS}"),
            ));
        }
        // The ring count, checked, and the grid's memory charged to the budget
        // before it is tessellated.
        let rings = |min: u32, counts: fn(u32, u32) -> (u64, u64)| -> Result<u32, SceneError> {
            let r = p.rings.unwrap_or_else(|| default_rings(segments, min));
            if !(min..=MAX_DIVISIONS).contains(&r) {
                return Err(self.invalid(
                    line,
                    k("rings"),
                    format!("{r} is out of range: a {kname} needs {min} to {MAX_DIVISIONS} rings"),
                ));
            }
            if segments as u64 * r as u64 > MAX_GRID {
                return Err(self.invalid(
                    line,
                    k("rings"),
                    format!(
                        "segments × rings = {} is too many vertices (at most {MAX_GRID})",
                        segments as u64 * r as u64
                    ),
                ));
            }
            let (v, t) = counts(segments, r);
            self.charge(
                line,
                k("segments"),
                || format!("this {kname} ({segments} segments × {r} rings: {v} vertices, {t} triangles) with the scene's other meshes"),
                cost::mesh_bytes(v, t),
                "lower `segments` and `rings` (64 × 32 already renders a smooth sphere)",
            )?;
            Ok(r)
        };
        let (shape, local) = match kind {
            K::Box => {
                let s = p.size.as_ref().ok_or_else(|| {
                    self.invalid(
                        line,
                        k("size"),
                        "missing: a box needs `size = [x, y, z]` (full extents)",
                    )
                })?;
                let s = self.vec3(s, &k("size"), "full extents x, y, z", false)?;
                if s.min_element() <= 0.0 {
                    return Err(self.invalid(
                        line,
                        k("size"),
                        format!("{s} has a component ≤ 0: every extent must be positive"),
                    ));
                }
                (Shape::Box { size: s }, shapes::make_box(s))
            }
            K::Sphere => {
                let r = self.positive(p.radius, line, &k("radius"), "sphere", "its radius")?;
                let m = rings(2, cost::sphere)?;
                (
                    Shape::Sphere {
                        radius: r,
                        segments,
                        rings: m,
                    },
                    shapes::make_sphere(r, segments, m),
                )
            }
            K::Cylinder | K::Cone => {
                let r = self.positive(p.radius, line, &k("radius"), &kname, "the base radius")?;
                let h =
                    self.positive(p.height, line, &k("height"), &kname, "the height along +Y")?;
                if kind == K::Cylinder {
                    (
                        Shape::Cylinder {
                            radius: r,
                            height: h,
                            segments,
                        },
                        shapes::make_cylinder(r, h, segments),
                    )
                } else {
                    (
                        Shape::Cone {
                            radius: r,
                            height: h,
                            segments,
                        },
                        shapes::make_cone(r, h, segments),
                    )
                }
            }
            K::Torus => {
                let big =
                    self.positive(p.radius, line, &k("radius"), "torus", "the major radius")?;
                let small = self.positive(
                    p.minor_radius,
                    line,
                    &k("minor_radius"),
                    "torus",
                    "the tube radius",
                )?;
                if small >= big {
                    return Err(self.invalid(
                        line,
                        k("minor_radius"),
                        format!("{small} must be less than radius = {big}, otherwise the torus intersects itself"),
                    ));
                }
                let m = rings(3, cost::torus)?;
                (
                    Shape::Torus {
                        radius: big,
                        minor_radius: small,
                        segments,
                        rings: m,
                    },
                    shapes::make_torus(big, small, segments, m),
                )
            }
            K::Mesh => {
                let rel = p.path.as_deref().ok_or_else(|| {
                    self.invalid(
                        line,
                        k("path"),
                        "missing: a mesh needs `path = \"file.obj\"` (relative to the scene file)",
                    )
                })?;
                let full = self.dir.join(rel);
                if let Ok(meta) = std::fs::metadata(&full) {
                    self.charge(
                        line,
                        k("path"),
                        || {
                            format!(
                                "the OBJ file ({} bytes) with the scene's other meshes",
                                meta.len()
                            )
                        },
                        cost::obj_bytes(meta.len()),
                        "simplify the mesh (fewer triangles)",
                    )?;
                }
                let mesh = load_obj(&full).map_err(|e| {
                    self.invalid(
                        line,
                        k("path"),
                        format!("{e} (the path is relative to the scene file's folder)"),
                    )
                })?;
                (Shape::Mesh { path: full }, mesh)
            }
        };
        let scale = match &p.scale {
            Some(s) => self.vec3(s, &k("scale"), "factors x, y, z", true)?,
            None => DVec3::ONE,
        };
        if scale.x == 0.0 || scale.y == 0.0 || scale.z == 0.0 {
            return Err(self.invalid(
                line,
                k("scale"),
                format!("{scale} has a zero component: the transform would flatten the {kname} (singular); use a non-zero scale"),
            ));
        }
        let rot = match &p.rotate_deg {
            Some(r) => self.vec3(r, &k("rotate_deg"), "degrees about x, y, z", false)?,
            None => DVec3::ZERO,
        };
        let tr = match &p.translate {
            Some(t) => self.vec3(t, &k("translate"), "offsets x, y, z", false)?,
            None => DVec3::ZERO,
        };
        let m = shapes::transform(scale, rot, tr);
        if !m.determinant().is_normal() {
            return Err(self.invalid(
                line,
                k("scale"),
                "the transform is singular (determinant 0); use a non-zero scale",
            ));
        }
        Ok((shape, local, m))
    }

    /// The camera of `[camera]`, or `default` without one (`default.up` is also
    /// the default `up` of a `[camera]` table).
    fn camera(
        &mut self,
        t: Option<&Spanned<CameraT>>,
        default: &CameraT,
        render: &RenderSettings,
        drawn: &[&Mesh],
    ) -> Result<Camera, SceneError> {
        let (c, line) = match t {
            Some(t) => (t.get_ref(), self.line(t.span())),
            None => (default, None),
        };
        let eye = match &c.eye {
            Some(e) => self.vec3(e, "camera: eye", "the eye position x, y, z", false)?,
            None => {
                return Err(self.invalid(
                    line,
                    "camera: eye",
                    "missing: give the eye position, e.g. eye = [3.0, 2.0, 4.0]",
                ))
            }
        };
        let target = match &c.target {
            Some(v) => self.vec3(v, "camera: target", "the point looked at x, y, z", false)?,
            None => DVec3::ZERO,
        };
        let up = match c.up.as_ref().or(default.up.as_ref()) {
            Some(v) => self.vec3(v, "camera: up", "the up direction x, y, z", false)?,
            None => DVec3::Y,
        };
        let dir = target - eye;
        if dir.length() == 0.0 || !dir.normalize().is_finite() {
            return Err(self.invalid(
                line,
                "camera: eye",
                format!("eye and target are the same point {eye}: the view direction is undefined; move the eye away from the target"),
            ));
        }
        if up.length() == 0.0 || dir.normalize().cross(up.normalize()).length() < 1e-9 {
            return Err(self.invalid(
                line,
                "camera: up",
                format!("up = {up} is parallel to the view direction {}: choose an up vector that is not, e.g. [0, 0, 1]", dir.normalize()),
            ));
        }
        let fov = c.fov_y_deg.unwrap_or(35.0);
        if !(fov.is_finite() && fov > 0.0 && fov < 180.0) {
            return Err(self.invalid(
                line,
                "camera: fov_y_deg",
                format!("{fov} is out of range: use an angle between 0 and 180 degrees"),
            ));
        }
        let fit = c.fit.unwrap_or(false);
        let projection = match c.projection.unwrap_or(ProjT::Perspective) {
            ProjT::Perspective => {
                if c.ortho_height.is_some() {
                    self.warnings.push(format!(
                        "{}: camera: ortho_height is ignored with projection = \"perspective\"",
                        self.path.display()
                    ));
                }
                Projection::Perspective { fov_y_deg: fov }
            }
            ProjT::Orthographic => {
                let h = match c.ortho_height {
                    Some(h) if h.is_finite() && h > 0.0 => h,
                    Some(h) => {
                        return Err(self.invalid(line, "camera: ortho_height", format!("{h} must be a positive finite number")))
                    }
                    None if fit => 1.0,
                    None => {
                        return Err(self.invalid(
                            line,
                            "camera: ortho_height",
                            "missing: an orthographic camera needs the world height of the view (or fit = true)",
                        ))
                    }
                };
                Projection::Orthographic { height: h }
            }
        };
        let persp = matches!(projection, Projection::Perspective { .. });
        for (k, v) in [("near", c.near), ("far", c.far)] {
            if let Some(v) = v {
                if !v.is_finite() || (persp && v <= 0.0) {
                    return Err(self.invalid(
                        line,
                        format!("camera: {k}"),
                        format!(
                            "{v} must be a {}finite number",
                            if persp { "positive " } else { "" }
                        ),
                    ));
                }
            }
        }
        if let (Some(n), Some(f)) = (c.near, c.far) {
            if n >= f {
                return Err(self.invalid(
                    line,
                    "camera: near",
                    format!("near = {n} must be less than far = {f}"),
                ));
            }
        }
        let mut cam = Camera {
            eye,
            target,
            up,
            projection,
            near: 0.0,
            far: 0.0,
        };
        if fit {
            if let Some((center, radius)) = fit::bounding_sphere(drawn.iter().copied()) {
                fit::fit(&mut cam, center, radius, render.width, render.height);
            }
        }
        let (n, f) = fit::near_far(&cam, drawn.iter().copied(), c.near, c.far);
        if n >= f {
            return Err(self.invalid(
                line,
                if c.near.is_some() { "camera: near" } else { "camera: far" },
                format!("near = {n} must be less than far = {f} (the other plane was chosen from the geometry)"),
            ));
        }
        cam.near = n;
        cam.far = f;
        Ok(cam)
    }
}

/// Parses a solid or trim expression over the primitive names. The one call site of
/// the expression parser.
pub fn parse_expr(src: &str, prims: &HashMap<&str, u32>) -> Result<Expr, String> {
    crate::csg::parse(src, &mut |n| prims.get(n).copied()).map_err(|e| e.to_string())
}

/// Whether the point set of `e` is bounded (primitives are bounded): decided on
/// the positive form, where a complemented leaf is the unbounded part.
pub fn is_bounded(e: &Expr) -> bool {
    crate::csg::PositiveExpr::from_expr(e).is_bounded()
}
