//! Turning the bytes copied back from the GPU into the output [`Images`]:
//! colour with alpha 255, primitive ids as `u16`, depth-buffer values converted to
//! view depth. Pure (the copies themselves are recorded by the executor's
//! `read_back`).

use super::conv::DepthFormat;
use crate::images::Images;
use crate::scene::camera::DepthConvention;
use crate::scene::Camera;

/// The three planes as copied: RGBA8 colour, R32_UINT primitive ids, and the depth
/// aspect (`D32S8`: `f32`; `D24S8`: 24-bit unorm in the low bits of a `u32`), each
/// tightly packed, row 0 at the top, native byte order.
pub struct Raw<'a> {
    pub width: u32,
    pub height: u32,
    pub color: &'a [u8],
    pub prim: &'a [u8],
    pub depth: &'a [u8],
}

/// Normalized depth-buffer value of one texel.
pub fn depth_texel(word: u32, format: DepthFormat) -> f64 {
    match format {
        DepthFormat::D32S8 => f32::from_bits(word) as f64,
        DepthFormat::D24S8 => (word & 0x00ff_ffff) as f64 / 16_777_215.0,
    }
}

/// Pixels with primitive id 0 get the background colour and depth `+inf`.
pub fn decode(
    raw: Raw<'_>,
    format: DepthFormat,
    camera: &Camera,
    convention: DepthConvention,
    background: [u8; 3],
) -> Images {
    let n = raw.width as usize * raw.height as usize;
    let word = |plane: &[u8], i: usize| {
        u32::from_ne_bytes([
            plane[i * 4],
            plane[i * 4 + 1],
            plane[i * 4 + 2],
            plane[i * 4 + 3],
        ])
    };
    let mut images = Images {
        width: raw.width,
        height: raw.height,
        color: Vec::with_capacity(n),
        depth: Vec::with_capacity(n),
        prim: Vec::with_capacity(n),
    };
    for i in 0..n {
        let prim = word(raw.prim, i);
        if prim == 0 {
            images
                .color
                .push([background[0], background[1], background[2], 255]);
            images.depth.push(f32::INFINITY);
            images.prim.push(0);
        } else {
            let c = &raw.color[i * 4..i * 4 + 3];
            images.color.push([c[0], c[1], c[2], 255]);
            let z = depth_texel(word(raw.depth, i), format);
            images
                .depth
                .push(camera.view_depth_from_ndc(z, convention) as f32);
            images.prim.push(prim.min(u16::MAX as u32) as u16);
        }
    }
    images
}

/// The normal buffer as copied (RGBA32F, xyz a world-oriented unit normal, 0 on
/// background) rotated into view space by `view` (world → view); zero stays zero.
pub fn decode_normals(bytes: &[u8], view: &glam::DMat4) -> Vec<[f32; 3]> {
    bytes
        .chunks_exact(16)
        .map(|t| {
            let f = |k: usize| f32::from_ne_bytes([t[k], t[k + 1], t[k + 2], t[k + 3]]) as f64;
            let n = glam::DVec3::new(f(0), f(4), f(8));
            if n == glam::DVec3::ZERO {
                [0.0; 3]
            } else {
                view.transform_vector3(n).normalize().as_vec3().to_array()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Projection;
    use glam::DVec3;

    #[test]
    fn d24_ignores_stencil_bits_and_background_is_infinite() {
        assert_eq!(depth_texel(0xab_ff_ff_ff, DepthFormat::D24S8), 1.0);
        assert_eq!(depth_texel(0.5f32.to_bits(), DepthFormat::D32S8), 0.5);
        let cam = Camera {
            eye: DVec3::new(0.0, 0.0, 5.0),
            target: DVec3::ZERO,
            up: DVec3::Y,
            projection: Projection::Orthographic { height: 2.0 },
            near: 1.0,
            far: 11.0,
        };
        let color = [1u8, 2, 3, 0, 4, 5, 6, 7];
        let prim: Vec<u8> = [0u32, 3].iter().flat_map(|v| v.to_ne_bytes()).collect();
        let depth: Vec<u8> = [0.0f32, 0.5].iter().flat_map(|v| v.to_ne_bytes()).collect();
        let raw = Raw {
            width: 2,
            height: 1,
            color: &color,
            prim: &prim,
            depth: &depth,
        };
        let im = decode(
            raw,
            DepthFormat::D32S8,
            &cam,
            DepthConvention::Reversed,
            [9, 9, 9],
        );
        assert_eq!(im.color, vec![[9, 9, 9, 255], [4, 5, 6, 255]]);
        assert_eq!(im.prim, vec![0, 3]);
        assert_eq!(im.depth[0], f32::INFINITY);
        assert_eq!(im.depth[1], 6.0);
    }
}
