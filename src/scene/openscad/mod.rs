//! OpenSCAD `.csg` files (OpenSCAD's CSG export: every module, loop and variable
//! already evaluated) as scenes, so a model renders as OpenSCAD's preview would
//! draw it — without OpenCSG's z-fighting or its term limit.
//!
//! - `lex` and `parse`: the file into a tree of nodes (iterative, located
//!   errors `file:line:col`).
//! - `tessellate`: OpenSCAD 2021.01's exact facets of cube, sphere, cylinder
//!   and polyhedron.
//! - `extrude`: the 2D shapes `circle`, `square`, `polygon` and their
//!   `linear_extrude` / `rotate_extrude`, each 2D primitive extruded to its own
//!   closed mesh so 2D Booleans become 3D ones (why that is exact: its doc).
//! - `convert`: the tree into primitives and one CSG expression (OpenSCAD's
//!   CSG-tree semantics: operators, transforms, colours, modifiers).
//!
//! [`read_model`] gives the primitives and expression; `scene::load` makes a
//! [`Scene`](super::Scene) of them, for a `.csg` given directly (with
//! OpenSCAD's default camera) or named by a TOML scene (`[csg] openscad = ...`).
//! The geometry is OpenSCAD's: Z up, millimetres as written.
#![deny(unsafe_code)]

pub(crate) mod args;
pub mod background;
pub(crate) mod convert;
pub(crate) mod dxf;
pub(crate) mod extrude;
#[cfg(test)]
mod fuzz3d;
pub(crate) mod hull;
pub(crate) mod import2d;
pub(crate) mod lex;
pub(crate) mod mesh_import;
pub(crate) mod orient;
pub(crate) mod outline;
pub(crate) mod parse;
pub(crate) mod pieces;
pub(crate) mod surface;
pub(crate) mod svg;
pub(crate) mod tessellate;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests2d;
#[cfg(test)]
mod tests3d;
pub(crate) mod text;

use glam::DMat4;
use std::collections::HashMap;
use std::path::Path;

use super::load::SceneError;
use super::{Mesh, Primitive, Shape};
use crate::csg::Expr;

/// OpenSCAD's default view (`$vpr = [55, 0, 25]`): the direction from the target
/// to the eye, `(sin 25° sin 55°, −cos 25° sin 55°, cos 55°)`, with Z up.
pub fn default_view_dir() -> glam::DVec3 {
    let (rx, rz) = (55f64.to_radians(), 25f64.to_radians());
    glam::DVec3::new(rz.sin() * rx.sin(), -rz.cos() * rx.sin(), rx.cos())
}
/// OpenSCAD's default field of view (degrees; it is the vertical one at the
/// default square-ish window).
pub const DEFAULT_FOV_Y_DEG: f64 = 22.5;
/// OpenSCAD's (Cornfield) background colour.
pub const DEFAULT_BACKGROUND: [u8; 3] = [0xff, 0xff, 0xe5];

/// A 1-based line and column.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Pos {
    /// The line, from 1.
    pub line: usize,
    /// The column in characters, from 1.
    pub col: usize,
}

/// A mistake in a `.csg` file, at a place in it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}:{}: {message}", pos.line, pos.col)]
pub struct ScadError {
    /// Where in the file.
    pub pos: Pos,
    /// What is wrong.
    pub message: String,
}

impl ScadError {
    pub(crate) fn new(pos: Pos, message: impl Into<String>) -> Self {
        ScadError {
            pos,
            message: message.into(),
        }
    }
}

/// One tessellated, placed primitive of the model.
#[derive(Clone, Debug, PartialEq)]
pub struct ScadPrimitive {
    /// The node kind (`cube`, `sphere`, ...).
    pub node: String,
    /// The node's line in the file.
    pub line: usize,
    /// World space: the composed `multmatrix` applied.
    pub mesh: Mesh,
    /// The composed `multmatrix` from the file's root to the node.
    pub matrix: DMat4,
    /// From `color()` (alpha kept for transparency), `#`, or OpenSCAD's defaults.
    pub rgba: [f32; 4],
}

/// A `.csg` model: primitives in order of appearance, named `sphere_L12`
/// (node kind and line; `_2`, `_3`, ... for more on one line), the solid over
/// them, and warnings (`file:line:col: text`).
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The primitives, in order of appearance.
    pub primitives: Vec<Primitive>,
    /// The solid: the file's CSG tree over the primitives.
    pub expr: Expr,
    /// Non-fatal remarks (`file:line:col: text`), one line each.
    pub warnings: Vec<String>,
    /// The `%` background parts, kept apart from the solid
    /// ([`background::show`] adds them to a scene).
    pub background: Vec<background::Background>,
}

/// Reads and converts the `.csg` file at `path`.
pub fn read_model(path: &Path, skip_unsupported: bool) -> Result<Model, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    model_from_str(&text, path, skip_unsupported)
}

/// Converts `.csg` text; `path` names it in errors and warnings.
pub fn model_from_str(
    text: &str,
    path: &Path,
    skip_unsupported: bool,
) -> Result<Model, SceneError> {
    let located = |e: ScadError| located_error(text, path, e);
    let tree = parse::parse(text).map_err(located)?;
    let base = path.parent().unwrap_or(Path::new(""));
    let c = convert::convert(&tree, skip_unsupported, base).map_err(located)?;
    let mut warnings: Vec<String> = c
        .warnings
        .iter()
        .map(|w| format!("{}:{w}", path.display()))
        .collect();
    let Some(expr) = c.expr else {
        return Err(located(ScadError::new(
            Pos { line: 1, col: 1 },
            "the model has no solid to draw (every part is empty, disabled with `*`, background `%`, or skipped); \
             add a primitive such as `cube(size = [1, 1, 1]);`",
        )));
    };
    // Names are unique over the solid's and the background parts' primitives.
    let mut seen: HashMap<String, u32> = HashMap::new();
    let mut named = |prims: Vec<ScadPrimitive>| -> Vec<Primitive> {
        prims
            .into_iter()
            .map(|p| {
                let base = format!("{}_L{}", p.node, p.line);
                let k = seen.entry(base.clone()).or_insert(0);
                *k += 1;
                let name = if *k == 1 { base } else { format!("{base}_{k}") };
                Primitive {
                    name,
                    color: [p.rgba[0], p.rgba[1], p.rgba[2]].map(|c| (c * 255.0).round() as u8),
                    shape: Shape::OpenScad {
                        node: p.node,
                        line: p.line,
                        rgba: p.rgba,
                    },
                    transform: p.matrix,
                    mesh: p.mesh,
                    used: true,
                }
            })
            .collect()
    };
    let primitives = named(c.primitives);
    let background: Vec<background::Background> = c
        .background
        .into_iter()
        .map(|b| background::Background::new(path, b.node, b.pos, named(b.primitives), b.expr))
        .collect();
    warnings.extend(background.iter().map(|b| b.warning.clone()));
    Ok(Model {
        primitives,
        expr,
        warnings,
        background,
    })
}

/// `file:line:col: message` with the source line and a caret under the column.
fn located_error(text: &str, path: &Path, e: ScadError) -> SceneError {
    let src = text.lines().nth(e.pos.line.saturating_sub(1)).unwrap_or("");
    let g = e.pos.line.to_string().len();
    let caret: String = src
        .chars()
        .take(e.pos.col.saturating_sub(1))
        .map(|c| if c == '\t' { '\t' } else { ' ' })
        .collect();
    SceneError::Syntax {
        path: path.to_path_buf(),
        line: e.pos.line,
        column: e.pos.col,
        message: e.message,
        snippet: format!("{:g$} |\n{} | {src}\n{:g$} | {caret}^", "", e.pos.line, ""),
    }
}
