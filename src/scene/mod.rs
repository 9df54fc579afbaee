//! The scene (docs/scene-format.md): TOML loading, exact tessellation, OBJ meshes,
//! mesh validation (closed, consistently oriented), and the camera.
//!
//! Everything here is geometry in `f64`; the GPU gets `f32` copies. A loaded
//! [`Scene`] is fully resolved: world-space triangles, parsed expressions, and a
//! camera with definite near/far planes.
#![deny(unsafe_code)]

pub mod appearance;
pub mod camera;
pub(crate) mod cost;
pub mod fit;
pub mod fixtures;
pub mod light;
pub mod load;
pub(crate) mod obj;
pub mod openscad;
pub mod shapes;
pub mod style;
// TEMPORARY: replaced by `csg::parse` at merge (see `load::parse_expr`).
pub(crate) mod kind;
pub(crate) mod validate;
mod vector;
pub use appearance::Appearance;
pub use camera::{Camera, Projection};
pub use load::{is_bounded, load, load_str, load_with, LoadOptions, SceneError};

use glam::DVec3;
use std::path::PathBuf;

use crate::csg::Expr;

/// An indexed triangle mesh in world space. Triangles are wound counter-clockwise
/// seen from outside (outward normals).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: DVec3,
    pub max: DVec3,
}

/// Which `shape` a primitive or surface was built from.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    Box {
        size: DVec3,
    },
    Sphere {
        radius: f64,
        segments: u32,
        rings: u32,
    },
    Cylinder {
        radius: f64,
        height: f64,
        segments: u32,
    },
    Cone {
        radius: f64,
        height: f64,
        segments: u32,
    },
    Torus {
        radius: f64,
        minor_radius: f64,
        segments: u32,
        rings: u32,
    },
    Mesh {
        path: PathBuf,
    },
    /// A primitive node of an OpenSCAD `.csg` file ([`openscad`]): its kind
    /// (`cube`, `sphere`, `cylinder`, `polyhedron`), line, and RGBA colour (the
    /// alpha is kept for transparency; drawn opaque for now).
    OpenScad {
        node: String,
        line: usize,
        rgba: [f32; 4],
    },
}

/// A `[[primitive]]`: a closed, consistently oriented solid (checked at load when an
/// expression uses it).
#[derive(Clone, Debug, PartialEq)]
pub struct Primitive {
    pub name: String,
    pub shape: Shape,
    /// `M = T * Rz * Ry * Rx * S` (docs/scene-format.md).
    pub transform: glam::DMat4,
    /// World-space mesh (the transform already applied).
    pub mesh: Mesh,
    pub color: [u8; 3],
    /// Named by at least one solid expression or surface `trim`; unused primitives
    /// are not drawn (a warning is printed at load).
    pub used: bool,
}

/// One solid of the scene: `[csg]` (named after the scene, or `"csg"`) or a `[[solid]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Solid {
    pub name: String,
    pub expr: Expr,
}

/// What CST keeps of a trimmed surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Keep {
    /// CST(S, V)
    In,
    /// CST(S, !V)
    Out,
    /// all of S, the part in V drawn in `paint_color`
    Paint,
}

/// A `[[surface]]`: a possibly open mesh trimmed by the volume `trim`.
#[derive(Clone, Debug, PartialEq)]
pub struct Surface {
    pub name: String,
    pub shape: Shape,
    pub transform: glam::DMat4,
    pub mesh: Mesh,
    pub color: [u8; 3],
    pub trim: Expr,
    pub keep: Keep,
    pub paint_color: [u8; 3],
}

/// `[render]` defaults, overridden by command-line flags.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub background: [u8; 3],
}

/// A loaded, validated scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    pub name: Option<String>,
    /// The scene file it was loaded from (meshes are relative to its directory).
    pub path: PathBuf,
    pub camera: Camera,
    pub render: RenderSettings,
    /// All `[[primitive]]`s in file order; index + 1 is the primitive index of the
    /// outputs.
    pub primitives: Vec<Primitive>,
    pub solids: Vec<Solid>,
    /// Surfaces continue the primitive index count after the primitives.
    pub surfaces: Vec<Surface>,
    /// Non-fatal remarks from loading (unused primitives, ignored keys), one line each.
    pub warnings: Vec<String>,
    /// Opacities (extension: `alpha` keys); default opaque.
    pub appearance: Appearance,
}

#[cfg(test)]
mod load_tests;

impl Scene {
    /// Mesh names in mesh-index order: primitives, then surfaces.
    pub fn mesh_names(&self) -> Vec<String> {
        self.primitives
            .iter()
            .map(|p| p.name.clone())
            .chain(self.surfaces.iter().map(|s| s.name.clone()))
            .collect()
    }
}
