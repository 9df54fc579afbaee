//! The camera of the scene file (docs/scene-format.md): look-at view, perspective or
//! orthographic projection, pixel-centre rays, and near/far planes.
//!
//! Conventions: view space has the eye at the origin looking down −Z with +Y up.
//! Pixel `(x, y)` has y downward and samples the ray through `(x + 0.5, y + 0.5)`.
//! Both the GPU projection and the reference rays are derived here so the two agree.

use glam::{DMat4, DVec3};

#[derive(Clone, Copy, Debug, PartialEq)]
/// How the camera projects.
pub enum Projection {
    /// A pinhole camera with this vertical field of view.
    Perspective {
        /// Vertical field of view, degrees.
        fov_y_deg: f64,
    },
    /// Parallel rays; the view is `height` world units tall.
    Orthographic {
        /// Height of the view in world units.
        height: f64,
    },
}

/// A resolved camera (after `fit`, with definite near/far).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Position of the eye (world).
    pub eye: DVec3,
    /// The point looked at (world).
    pub target: DVec3,
    /// The world direction shown upwards.
    pub up: DVec3,
    /// Perspective or orthographic.
    pub projection: Projection,
    /// Distance of the near plane along the view direction.
    pub near: f64,
    /// Distance of the far plane along the view direction.
    pub far: f64,
}

/// A ray in world space: `origin + t * dir`, `dir` of unit length, so `t` along a
/// perspective ray is distance, not view depth (see [`Camera::view_depth`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts (the eye, or a point of the orthographic eye plane).
    pub origin: DVec3,
    /// The unit direction.
    pub dir: DVec3,
}

/// How normalized device depth is laid out in the depth buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum DepthConvention {
    /// near → 0, far → 1
    #[default]
    Standard,
    /// near → 1, far → 0 (for floating-point depth buffers)
    Reversed,
}

impl Camera {
    /// Unit view direction (eye towards target).
    pub fn forward(&self) -> DVec3 {
        (self.target - self.eye).normalize()
    }

    /// World → view (right-handed look-at; the eye at the origin looking down −Z).
    pub fn view(&self) -> DMat4 {
        DMat4::look_at_rh(self.eye, self.target, self.up)
    }

    /// View → Vulkan clip space for an image of `aspect = width / height`.
    /// Clip y points down (row 0 at the top) and depth follows `depth`.
    pub fn proj(&self, aspect: f64, depth: DepthConvention) -> DMat4 {
        let (n, f) = (self.near, self.far);
        match self.projection {
            Projection::Perspective { fov_y_deg } => {
                let t = 1.0 / (fov_y_deg.to_radians() * 0.5).tan();
                // z_ndc = -a + b / d with d = -z_view.
                let (a, b) = match depth {
                    DepthConvention::Standard => (f / (n - f), n * f / (n - f)),
                    DepthConvention::Reversed => (n / (f - n), n * f / (f - n)),
                };
                DMat4::from_cols_array(&[
                    t / aspect,
                    0.0,
                    0.0,
                    0.0, //
                    0.0,
                    -t,
                    0.0,
                    0.0, //
                    0.0,
                    0.0,
                    a,
                    -1.0, //
                    0.0,
                    0.0,
                    b,
                    0.0,
                ])
            }
            Projection::Orthographic { height } => {
                let (sz, oz) = match depth {
                    // z_ndc = (d - n) / (f - n) with d = -z_view
                    DepthConvention::Standard => (-1.0 / (f - n), -n / (f - n)),
                    DepthConvention::Reversed => (1.0 / (f - n), f / (f - n)),
                };
                DMat4::from_cols_array(&[
                    2.0 / (height * aspect),
                    0.0,
                    0.0,
                    0.0, //
                    0.0,
                    -2.0 / height,
                    0.0,
                    0.0, //
                    0.0,
                    0.0,
                    sz,
                    0.0, //
                    0.0,
                    0.0,
                    oz,
                    1.0,
                ])
            }
        }
    }

    /// Inverse of the depth mapping of [`Camera::proj`]: normalized device depth →
    /// view-space depth (positive, scene units).
    pub fn view_depth_from_ndc(&self, z: f64, depth: DepthConvention) -> f64 {
        let (n, f) = (self.near, self.far);
        match (self.projection, depth) {
            (Projection::Perspective { .. }, DepthConvention::Standard) => {
                n * f / (f - z * (f - n))
            }
            (Projection::Perspective { .. }, DepthConvention::Reversed) => {
                n * f / (n + z * (f - n))
            }
            (Projection::Orthographic { .. }, DepthConvention::Standard) => n + z * (f - n),
            (Projection::Orthographic { .. }, DepthConvention::Reversed) => f - z * (f - n),
        }
    }

    /// View-space depth of a world point: its distance along the view direction.
    pub fn view_depth(&self, p: DVec3) -> f64 {
        (p - self.eye).dot(self.forward())
    }

    /// The image point `(px, py)` (pixel units, y downward; pixel centres at
    /// `x + 0.5`) of a `width × height` image that world point `p` projects to: the
    /// inverse of [`Camera::ray`].
    pub fn pixel_of(&self, p: DVec3, width: u32, height: u32) -> (f64, f64) {
        let m = self.proj(width as f64 / height as f64, DepthConvention::Standard) * self.view();
        let c = m * p.extend(1.0);
        (
            (c.x / c.w + 1.0) * 0.5 * width as f64,
            (c.y / c.w + 1.0) * 0.5 * height as f64,
        )
    }

    /// The world-space ray through image point `(px, py)` (pixel centres are at
    /// `x + 0.5, y + 0.5`; y downward) of a `width × height` image.
    pub fn ray(&self, px: f64, py: f64, width: u32, height: u32) -> Ray {
        let aspect = width as f64 / height as f64;
        let nx = 2.0 * px / width as f64 - 1.0;
        let ny = 2.0 * py / height as f64 - 1.0;
        let inv_view = self.view().inverse();
        match self.projection {
            Projection::Perspective { fov_y_deg } => {
                let th = (fov_y_deg.to_radians() * 0.5).tan();
                let d_view = DVec3::new(nx * th * aspect, -ny * th, -1.0);
                Ray {
                    origin: self.eye,
                    dir: inv_view.transform_vector3(d_view).normalize(),
                }
            }
            Projection::Orthographic { height } => {
                let o_view = DVec3::new(nx * height * aspect * 0.5, -ny * height * 0.5, 0.0);
                Ray {
                    origin: inv_view.transform_point3(o_view),
                    dir: self.forward(),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cams() -> Vec<Camera> {
        let base = Camera {
            eye: DVec3::new(3.0, 2.0, 4.0),
            target: DVec3::new(0.1, -0.2, 0.3),
            up: DVec3::Y,
            projection: Projection::Perspective { fov_y_deg: 35.0 },
            near: 0.5,
            far: 20.0,
        };
        vec![
            base,
            Camera {
                projection: Projection::Orthographic { height: 4.0 },
                ..base
            },
        ]
    }

    /// A point on a pixel ray projects back to that pixel, and its NDC depth maps
    /// back to its view depth, for both depth conventions.
    #[test]
    fn ray_and_projection_agree() {
        for cam in cams() {
            for conv in [DepthConvention::Standard, DepthConvention::Reversed] {
                let (w, h) = (640u32, 480u32);
                let m = cam.proj(w as f64 / h as f64, conv) * cam.view();
                for &(px, py, t) in &[(0.5, 0.5, 3.0), (320.5, 100.5, 5.0), (639.5, 479.5, 7.0)] {
                    let r = cam.ray(px, py, w, h);
                    let p = r.origin + r.dir * t;
                    let c = m * p.extend(1.0);
                    let ndc = c.truncate() / c.w;
                    let sx = (ndc.x + 1.0) * 0.5 * w as f64;
                    let sy = (ndc.y + 1.0) * 0.5 * h as f64;
                    assert!(
                        (sx - px).abs() < 1e-9 && (sy - py).abs() < 1e-9,
                        "{sx},{sy} vs {px},{py}"
                    );
                    let d = cam.view_depth_from_ndc(ndc.z, conv);
                    assert!((d - cam.view_depth(p)).abs() < 1e-9);
                }
                let near_ndc = m * (cam.eye + cam.forward() * cam.near).extend(1.0);
                let z = near_ndc.z / near_ndc.w;
                let expect = if conv == DepthConvention::Standard {
                    0.0
                } else {
                    1.0
                };
                assert!((z - expect).abs() < 1e-12);
            }
        }
    }
}
