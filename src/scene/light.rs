//! The `[light]` table: one light that casts the solids' shadows (an optional
//! table of the scene format, docs/shadows.md; Rossignac & Wu's shadows from a CSG
//! depth buffer seen from the light). Parsing and checks, and the light's camera,
//! which the reference (shadow rays) and the GPU (the shadow map) share so that
//! both look from the same place.
#![deny(unsafe_code)]

use glam::DVec3;
use serde::Deserialize;

use super::vector::{self, RawVec};
use super::{fit, Camera, Mesh, Projection};

/// `[light]` as written: exactly one of the two keys.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LightT {
    direction: Option<RawVec>,
    position: Option<RawVec>,
}

/// A resolved light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Parallel light travelling along `direction` (unit; from the light towards
    /// the scene): an orthographic shadow map.
    Directional {
        /// The unit direction the light travels in.
        direction: DVec3,
    },
    /// Light from a point outside the drawn geometry's bounding sphere: a
    /// perspective shadow map.
    Point {
        /// The light's position in world space.
        position: DVec3,
    },
}

/// Margin around the bounding sphere in the light's view, so no silhouette
/// touches the shadow map's border.
const FRAME_MARGIN: f64 = 1.02;

impl Light {
    /// Human-readable description for `stats.json`.
    pub fn describe(&self) -> String {
        match self {
            Light::Directional { direction: d } => {
                format!("directional [{:.4}, {:.4}, {:.4}]", d.x, d.y, d.z)
            }
            Light::Point { position: p } => format!("point [{}, {}, {}]", p.x, p.y, p.z),
        }
    }

    /// The light's camera for `scene` ([`Light::camera`] around its drawn
    /// geometry: the primitives an expression names, and the surfaces).
    pub fn camera_for(&self, scene: &super::Scene) -> Camera {
        let drawn = || {
            scene
                .primitives
                .iter()
                .filter(|p| p.used)
                .map(|p| &p.mesh)
                .chain(scene.surfaces.iter().map(|s| &s.mesh))
        };
        let (c, r) = fit::bounding_sphere(drawn()).unwrap_or((DVec3::ZERO, 1.0));
        self.camera(c, r, drawn())
    }

    /// The camera that sees the sphere `(center, radius)` (the drawn geometry's
    /// bounding sphere) from the light, for a square image: orthographic along
    /// the direction, or perspective from the position, with tight near and far
    /// planes from `drawn`'s vertices.
    pub fn camera<'a>(
        &self,
        center: DVec3,
        radius: f64,
        drawn: impl IntoIterator<Item = &'a Mesh>,
    ) -> Camera {
        let r = if radius > 0.0 { radius } else { 1.0 } * FRAME_MARGIN;
        let (eye, projection) = match *self {
            Light::Directional { direction } => (
                center - direction * 2.0 * r,
                Projection::Orthographic { height: 2.0 * r },
            ),
            Light::Point { position } => {
                let dist = position.distance(center);
                assert!(
                    dist > r,
                    "point light inside the bounding sphere (checked at load)"
                );
                let fov = 2.0 * (r / dist).asin();
                (
                    position,
                    Projection::Perspective {
                        fov_y_deg: fov.to_degrees(),
                    },
                )
            }
        };
        let dir = (center - eye).normalize();
        let up = if dir.y.abs() < 0.9 {
            DVec3::Y
        } else {
            DVec3::X
        };
        let mut cam = Camera {
            eye,
            target: center,
            up,
            projection,
            near: 0.0,
            far: 0.0,
        };
        (cam.near, cam.far) = fit::near_far(&cam, drawn, None, None);
        cam
    }
}

/// Resolves `[light]` against the drawn geometry. Errors are `(key, message)`
/// for the loader to place.
pub(super) fn resolve<'a>(
    raw: &LightT,
    drawn: impl IntoIterator<Item = &'a Mesh> + Clone,
) -> Result<Light, (String, String)> {
    let vec = |key: &str, v: &RawVec, what: &str| {
        let a = vector::vec3(v.get_ref(), what).map_err(|m| (format!("light: {key}"), m))?;
        if a.iter().all(|x| x.is_finite()) {
            Ok(DVec3::from_array(a))
        } else {
            Err((
                format!("light: {key}"),
                format!("{a:?} must be finite numbers"),
            ))
        }
    };
    match (&raw.direction, &raw.position) {
        (Some(_), Some(_)) => Err((
            "light".into(),
            "has both `direction` and `position`: give `direction` for a directional light \
             or `position` for a point light, not both"
                .into(),
        )),
        (None, None) => Err((
            "light".into(),
            "is empty: give `direction = [x, y, z]` (a directional light, the way its rays \
             travel) or `position = [x, y, z]` (a point light)"
                .into(),
        )),
        (Some(d), None) => {
            let d = vec("direction", d, "the way the light travels")?;
            let len = d.length();
            if !(len > 1e-12) {
                return Err((
                    "light: direction".into(),
                    "is the zero vector: give the way the light travels, e.g. [-1, -2, -1]".into(),
                ));
            }
            Ok(Light::Directional { direction: d / len })
        }
        (None, Some(p)) => {
            let p = vec("position", p, "the light's world position")?;
            // As `Light::camera` will frame it (a unit sphere when nothing is drawn).
            let (c, r) = fit::bounding_sphere(drawn).unwrap_or((DVec3::ZERO, 1.0));
            let r = if r > 0.0 { r } else { 1.0 };
            if p.distance(c) <= r * FRAME_MARGIN {
                return Err((
                    "light: position".into(),
                    format!(
                        "[{}, {}, {}] lies within the drawn geometry's bounding sphere \
                         (centre [{:.3}, {:.3}, {:.3}], radius {:.3}): a point light must \
                         be farther than {:.3} from the centre (or use `direction`)",
                        p.x,
                        p.y,
                        p.z,
                        c.x,
                        c.y,
                        c.z,
                        r,
                        r * FRAME_MARGIN
                    ),
                ));
            }
            Ok(Light::Point { position: p })
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::{load_str, LoadOptions};
    use std::path::Path;

    const HEAD: &str =
        "[[primitive]]\nname = \"A\"\nshape = \"box\"\nsize = [2, 2, 2]\n[csg]\nexpr = \"A\"\n";

    fn load(light: &str) -> Result<crate::scene::Scene, String> {
        load_str(
            &format!("{HEAD}[light]\n{light}\n"),
            Path::new("t.toml"),
            &LoadOptions::default(),
        )
        .map_err(|e| e.to_string())
    }

    #[test]
    fn directional_is_normalized_and_point_kept() {
        use super::Light;
        let s = load("direction = [0, -2, 0]").unwrap();
        assert_eq!(
            s.appearance.light,
            Some(Light::Directional {
                direction: glam::DVec3::NEG_Y
            })
        );
        let s = load("position = [0, 10, 0]").unwrap();
        assert_eq!(
            s.appearance.light,
            Some(Light::Point {
                position: glam::DVec3::new(0.0, 10.0, 0.0)
            })
        );
        let s = load_str(HEAD, Path::new("t.toml"), &LoadOptions::default()).unwrap();
        assert_eq!(s.appearance.light, None);
    }

    #[test]
    fn bad_lights_name_the_key() {
        for (src, want) in [
            (
                "direction = [0, 0, 0]",
                "light: direction: is the zero vector",
            ),
            ("direction = [0, 1]", "light: direction: has 2 elements"),
            ("position = \"up\"", "light: position: found the string"),
            (
                "position = [0.5, 0, 0]",
                "light: position: [0.5, 0, 0] lies within",
            ),
            (
                "direction = [0, 1, 0]\nposition = [0, 9, 0]",
                "light: has both",
            ),
            ("", "light: is empty"),
            ("colour = 1", "unknown field `colour`"),
        ] {
            let e = load(src).unwrap_err();
            assert!(e.contains(want), "{src}: {e}");
            assert!(e.starts_with("t.toml"), "{e}");
        }
    }

    /// The light's camera frames the bounding sphere and its planes hold it.
    #[test]
    fn light_camera_sees_everything() {
        let s = load("position = [3, 8, 2]").unwrap();
        let light = s.appearance.light.unwrap();
        let meshes = || s.primitives.iter().map(|p| &p.mesh);
        let (c, r) = crate::scene::fit::bounding_sphere(meshes()).unwrap();
        for l in [
            light,
            super::Light::Directional {
                direction: glam::DVec3::new(0.0, -1.0, 0.0),
            },
        ] {
            let cam = l.camera(c, r, meshes());
            for p in meshes().flat_map(|m| m.positions.iter()) {
                let (px, py) = cam.pixel_of(*p, 100, 100);
                assert!(
                    (0.0..100.0).contains(&px) && (0.0..100.0).contains(&py),
                    "{px} {py}"
                );
                let d = cam.view_depth(*p);
                assert!(d > cam.near && d < cam.far);
            }
        }
    }
}
