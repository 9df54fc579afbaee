//! The images a frame delivers: colour, view-space depth and primitive id, the
//! same for the GPU algorithms and the exact reference, so that they compare
//! pixel for pixel.

/// One rendered frame as every renderer (reference or GPU) delivers it.
/// Pixels are row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Images {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// RGBA8, alpha 255 everywhere.
    pub color: Vec<[u8; 4]>,
    /// View-space depth of the visible point; `f32::INFINITY` for background.
    pub depth: Vec<f32>,
    /// 1-based primitive index (primitives, then surfaces); 0 for background.
    pub prim: Vec<u16>,
}

/// The shading every renderer uses (the GPU shaders implement the same formula):
/// `rgb * (0.25 + 0.75 * cos)`, rounded, alpha 255, with `cos = |dot(normal, ray_dir)|`
/// for the unit geometric normal of the visible triangle and the unit ray direction.
pub fn shade(rgb: [u8; 3], cos: f64) -> [u8; 4] {
    let k = 0.25 + 0.75 * cos.abs().min(1.0);
    let c = |v: u8| (v as f64 * k).round().clamp(0.0, 255.0) as u8;
    [c(rgb[0]), c(rgb[1]), c(rgb[2]), 255]
}
