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
    /// Vertex positions (world space once loaded).
    pub positions: Vec<DVec3>,
    /// Triangles as indices into `positions`, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// The corner with the smallest coordinates.
    pub min: DVec3,
    /// The corner with the largest coordinates.
    pub max: DVec3,
}

/// Which `shape` a primitive or surface was built from.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// A `box` centred at the origin.
    Box {
        /// Edge lengths along x, y and z.
        size: DVec3,
    },
    /// A `sphere` centred at the origin, tessellated by longitude and latitude (UV).
    Sphere {
        /// The radius.
        radius: f64,
        /// Segments around the axis (longitude).
        segments: u32,
        /// Latitude bands from pole to pole.
        rings: u32,
    },
    /// A capped `cylinder` along +Y, centred at the origin.
    Cylinder {
        /// The radius.
        radius: f64,
        /// The height.
        height: f64,
        /// Segments around the axis.
        segments: u32,
    },
    /// A `cone` along +Y: base disc at `y = -height/2`, apex at `y = height/2`.
    Cone {
        /// The base radius.
        radius: f64,
        /// The height.
        height: f64,
        /// Segments around the axis.
        segments: u32,
    },
    /// A `torus` around Y.
    Torus {
        /// Distance from the axis to the tube's centre.
        radius: f64,
        /// The tube's radius.
        minor_radius: f64,
        /// Segments around the axis.
        segments: u32,
        /// Divisions of the tube.
        rings: u32,
    },
    /// A triangle mesh read from a file (OBJ).
    Mesh {
        /// The file, relative to the scene file's directory.
        path: PathBuf,
    },
    /// A primitive node of an OpenSCAD `.csg` file ([`openscad`]): its kind
    /// (`cube`, `sphere`, `cylinder`, `polyhedron`), line, and RGBA colour (the
    /// alpha is kept for transparency; drawn opaque for now).
    OpenScad {
        /// The node kind.
        node: String,
        /// The line of the node in the `.csg` file.
        line: usize,
        /// The node's colour (RGBA, components 0 to 1).
        rgba: [f32; 4],
    },
}

/// A `[[primitive]]`: a closed, consistently oriented solid (checked at load when an
/// expression uses it).
#[derive(Clone, Debug, PartialEq)]
pub struct Primitive {
    /// The primitive's name, as expressions refer to it.
    pub name: String,
    /// What it was built from.
    pub shape: Shape,
    /// `M = T * Rz * Ry * Rx * S` (docs/scene-format.md).
    pub transform: glam::DMat4,
    /// World-space mesh (the transform already applied).
    pub mesh: Mesh,
    /// Its colour (sRGB), shaded where it is the visible surface.
    pub color: [u8; 3],
    /// Named by at least one solid expression or surface `trim`; unused primitives
    /// are not drawn (a warning is printed at load).
    pub used: bool,
}

/// One solid of the scene: `[csg]` (named after the scene, or `"csg"`) or a `[[solid]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Solid {
    /// The solid's name.
    pub name: String,
    /// The Boolean expression over primitive indices.
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
    /// The surface's name.
    pub name: String,
    /// What it was built from.
    pub shape: Shape,
    /// `M = T * Rz * Ry * Rx * S`, as a primitive's.
    pub transform: glam::DMat4,
    /// World-space mesh (the transform already applied); need not be closed.
    pub mesh: Mesh,
    /// Its colour (sRGB).
    pub color: [u8; 3],
    /// The trimming volume V: a Boolean expression over the primitives.
    pub trim: Expr,
    /// Which part of the surface CST keeps.
    pub keep: Keep,
    /// The colour of the part inside V, for [`Keep::Paint`].
    pub paint_color: [u8; 3],
}

/// `[render]` defaults, overridden by command-line flags.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Background colour (sRGB) of pixels no solid covers.
    pub background: [u8; 3],
    /// Samples per pixel (1, 2, 4 or 8; `[render] samples`, `--samples`):
    /// above 1 the GPU classifies every sample and averages the colour.
    pub samples: u32,
}

/// A loaded, validated scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The scene's name (`[scene] name`), if given.
    pub name: Option<String>,
    /// The scene file it was loaded from (meshes are relative to its directory).
    pub path: PathBuf,
    /// The camera, with definite near and far planes.
    pub camera: Camera,
    /// The `[render]` settings.
    pub render: RenderSettings,
    /// All `[[primitive]]`s in file order; index + 1 is the primitive index of the
    /// outputs.
    pub primitives: Vec<Primitive>,
    /// All solids in file order; the scene draws their union.
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
