//! `[camera]` to a [`Camera`]: eye, target, up, projection, and `fit` with
//! definite near/far (`super::super::fit`).

use glam::DVec3;

use super::toml_model::{CameraT, ProjT};
use super::{Loader, SceneError};
use crate::scene::fit;
use crate::scene::{Camera, Mesh, Projection, RenderSettings};
use toml::Spanned;

impl Loader<'_> {
    /// The camera of `[camera]`, or `default` without one (`default.up` is also
    /// the default `up` of a `[camera]` table).
    pub(super) fn camera(
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
