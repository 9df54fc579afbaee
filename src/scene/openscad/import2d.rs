//! `import()` of 2D outlines (DXF, SVG) into a region.

use std::path::Path;

use super::extrude::Region;
use super::parse::{Node, ValueKind};
use super::ScadError;

/// Whether `node` (an `import`) reads a 2D outline this reader draws.
pub fn is_2d(node: &Node) -> bool {
    let _ = node;
    false
}

/// The outline `node` imports, relative to `dir` (the `.csg` file's folder).
pub fn region(node: &Node, dir: &Path, warnings: &mut Vec<String>) -> Result<Region, ScadError> {
    let _ = (dir, warnings, ValueKind::Undef);
    Err(ScadError::new(
        node.pos,
        "`import` of 2D outlines is not supported",
    ))
}
