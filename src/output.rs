//! The contract's output files (CONTRACT.md §4): `color.png` (RGBA8, opaque),
//! `depth.npy` (little-endian f32, `(height, width)`, view-space depth, `+inf` for
//! background), `prim.png` (16-bit grey, 1-based primitive index, 0 background)
//! and `stats.json`; and reading them back for `compare`.
#![deny(unsafe_code)]

/// One rendered frame as every renderer (reference or GPU) delivers it.
/// Pixels are row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Images {
    pub width: u32,
    pub height: u32,
    /// RGBA8, alpha 255 everywhere.
    pub color: Vec<[u8; 4]>,
    /// View-space depth of the visible point; `f32::INFINITY` for background.
    pub depth: Vec<f32>,
    /// 1-based primitive index (primitives, then surfaces); 0 for background.
    pub prim: Vec<u16>,
}
