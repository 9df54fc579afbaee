//! Loading a scene file (docs/scene-format.md): TOML → validated [`Scene`] with
//! world-space meshes, parsed expressions, and a camera with definite near/far.
//!
//! Every user mistake is a [`SceneError`] naming the file, the line (TOML syntax and
//! type errors: line and column) or the key path (`primitive[3] "B": radius`, entries
//! counted from 1), and the fix. Loading only reads files.
//!
//! Defaults and choices of the format (also in docs/scene-format.md):
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
//!   the meshes' estimated memory (`scene::cost`) must fit the memory budget.
//! - Vectors are exactly 3 numbers (`vector.rs`); a file named `.scad` is
//!   refused as OpenSCAD source (`scene::kind`).
//! - Surface `keep` defaults to `"in"`, `paint_color` to `"#c02020"`; a `trim`
//!   may be unbounded (e.g. `!A`), a solid may not.
//! - Names share one namespace across primitives and surfaces; solid names are
//!   unique among solids.
//! - `LoadOptions::size` overrides `[render]` width/height before `fit`, and the
//!   final size is stored in `Scene::render`.
//! - Extension: `[csg] openscad = "model.csg"` makes an OpenSCAD model the whole
//!   scene (`super::openscad`), with OpenSCAD's camera and background defaults;
//!   a path ending in `.csg` is loaded as that scene with every default.
//!
//! Files: `toml_model` (the serde model of the file), `assemble` (the file to a
//! scene: names, primitives, solids, surfaces, `[render]`, `[light]`,
//! appearance, the OpenSCAD hand-off), `shape` (one shape table to a mesh),
//! `camera` (`[camera]` and `fit`), `values` (checked numbers, vectors,
//! expressions, the mesh memory charge), `error` ([`SceneError`]), `line_index`
//! (lines and columns of byte offsets, for errors).

mod assemble;
mod camera;
mod error;
mod line_index;
mod shape;
mod toml_model;
mod values;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::kind;
use super::Scene;
use crate::csg::Expr;

pub use error::SceneError;

/// Options from the command line that change how a scene is resolved.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// `--size WxH`: overrides `[render]` width and height (and so what `fit` frames).
    pub size: Option<(u32, u32)>,
}

/// Largest `segments` / `rings`, and of their product.
pub const MAX_DIVISIONS: u32 = 65536;
pub(crate) const MAX_GRID: u64 = 1 << 24;
/// Largest image side accepted from `[render]` or `--size`.
pub const MAX_SIZE: u32 = 16384;
/// Largest world-space coordinate of a drawn vertex: far inside `f32` (the
/// GPU's copies) with room for the camera fit's products in `f64`.
pub const MAX_COORD: f64 = 1e12;

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
    // The `.csg` file's own text stays `inline_csg`; the scene text is the virtual TOML.
    let csg_text = text;
    let text = virtual_toml.as_deref().unwrap_or(csg_text);
    Loader {
        path,
        text,
        lines: line_index::LineIndex::new(text),
        dir: path.parent().unwrap_or(Path::new(".")).to_path_buf(),
        warnings: Vec::new(),
        mesh_bytes: std::cell::Cell::new(0),
        skip_unsupported,
        inline_csg: virtual_toml.is_some().then_some(csg_text),
    }
    .run(opts)
}

struct Loader<'a> {
    path: &'a Path,
    text: &'a str,
    /// Line starts of `text`, for the lines and columns of error messages.
    lines: line_index::LineIndex,
    dir: PathBuf,
    warnings: Vec<String>,
    /// Estimated bytes of the meshes so far ([`super::cost`]), against the budget.
    mesh_bytes: std::cell::Cell<u64>,
    /// `--skip-unsupported` (or'ed with `[csg] skip_unsupported`).
    skip_unsupported: bool,
    /// The text of the `.csg` file this scene was made for (a `.csg` loaded
    /// directly), instead of reading `[csg] openscad` from disk.
    inline_csg: Option<&'a str>,
}

fn valid_name(s: &str) -> bool {
    let mut c = s.chars();
    matches!(c.next(), Some(f) if f.is_ascii_alphabetic() || f == '_')
        && c.all(|ch| ch.is_ascii_alphanumeric() || ch == '_')
}

impl Loader<'_> {
    fn line(&self, span: std::ops::Range<usize>) -> Option<usize> {
        Some(self.line_col(span.start).0)
    }

    /// 1-based line and column of byte `offset` of the file.
    fn line_col(&self, offset: usize) -> (usize, usize) {
        self.lines.line_col(self.text, offset)
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
