//! OpenSCAD's `%` (background) modifier: a subtree that is never part of the
//! solid, which OpenSCAD's preview draws see-through in grey
//! (`convert::BACKGROUND_COLOR`, alpha 128/255). Each `%` subtree is
//! converted to a set of its own ([`Background`]) and kept beside the scene
//! (`Appearance::background`); [`show`] adds the parts as solids of their own
//! with that alpha where the algorithm composites transparent layers
//! (Hable & Rossignac §6: each solid's boundary counted on its own, so a part's faces
//! blend over and through the solid). Elsewhere they stay out of the picture, and the
//! loader's warning says so.
#![deny(unsafe_code)]

use std::path::Path;

use super::convert::BACKGROUND_COLOR;
use super::Pos;
use crate::csg::{Expr, Node};
use crate::scene::{fit, Primitive, Scene, Solid};

/// One `%` subtree: its primitives (named as the model's) and its set over them
/// (leaf `prim` indexes `primitives`).
#[derive(Clone, Debug, PartialEq)]
pub struct Background {
    /// `background_<node>_L<line>`, the solid's name once shown.
    pub name: String,
    pub(crate) primitives: Vec<Primitive>,
    pub(crate) expr: Expr,
    /// The warning the scene carries while the part is left out.
    pub warning: String,
}

impl Background {
    pub(crate) fn new(
        path: &Path,
        node: String,
        pos: Pos,
        primitives: Vec<Primitive>,
        expr: Expr,
    ) -> Self {
        let warning = format!(
            "{}:{}:{}: `%{node}` (background) is left out of the picture: background parts are drawn see-through in grey, \
             as OpenSCAD draws them, only by `render` with an algorithm that draws transparency (reference, cst-z, cst-i, cst-g, kirsch); \
             they are never part of the solid",
            path.display(),
            pos.line,
            pos.col
        );
        Background {
            name: format!("background_{node}_L{}", pos.line),
            primitives,
            expr,
            warning,
        }
    }
}

/// OpenSCAD's background alpha, as the solids' `alpha`.
pub fn alpha() -> f64 {
    BACKGROUND_COLOR[3] as f64
}

/// Adds `scene`'s background parts as solids of their own, after its
/// primitives and solids, see-through at [`alpha`]; their warnings go, and the
/// camera's depth range widens to hold them. Returns the number of parts added.
pub fn show(scene: &mut Scene) -> usize {
    let parts = std::mem::take(&mut scene.appearance.background);
    if parts.is_empty() {
        return 0;
    }
    // Mesh indices run primitives, then surfaces: a model has no surfaces, so
    // the parts' primitives can follow the model's without renumbering any.
    assert!(
        scene.surfaces.is_empty(),
        "background parts come from .csg models, which have no surfaces"
    );
    let solids = scene.solids.len();
    scene.appearance.solid_alpha.resize(solids, None);
    for part in &parts {
        let offset = scene.primitives.len() as u32;
        let mut expr = part.expr.clone();
        for n in &mut expr.nodes {
            if let Node::Leaf { prim } = n {
                *prim += offset;
            }
        }
        scene.primitives.extend(part.primitives.iter().cloned());
        scene.solids.push(Solid {
            name: part.name.clone(),
            expr,
        });
        scene.appearance.solid_alpha.push(Some(alpha()));
        scene.warnings.retain(|w| w != &part.warning);
    }
    // Near and far hold the parts too (widened only: the solid keeps its range).
    let drawn = scene.primitives.iter().filter(|p| p.used).map(|p| &p.mesh);
    let (n, f) = fit::near_far(&scene.camera, drawn, None, None);
    let c = &mut scene.camera;
    if n.is_finite() && f.is_finite() && n < f {
        c.near = c.near.min(n);
        c.far = c.far.max(f);
    }
    parts.len()
}
