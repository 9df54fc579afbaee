//! One `[[primitive]]` or `[[surface]]` table to a world-space mesh: the shape's
//! keys, its tessellation, transform and colour (`super::super::shapes`,
//! `obj`, `validate`).

use glam::DVec3;

use super::toml_model::{ShapeKind, ShapeT};
use super::{Loader, SceneError, MAX_DIVISIONS, MAX_GRID};
use crate::scene::cost;
use crate::scene::obj::load_obj;
use crate::scene::shapes::{self, default_rings, DEFAULT_SEGMENTS};
use crate::scene::{Mesh, Shape};

impl Loader<'_> {
    pub(super) fn build_shape(
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
}
