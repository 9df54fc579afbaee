//! The output files (docs/cli.md): `color.png` (RGBA8, opaque),
//! `depth.npy` (little-endian f32, `(height, width)`, view-space depth, `+inf` for
//! background), `prim.png` (16-bit grey, 1-based primitive index, 0 background)
//! and `stats.json`; and reading them back for `compare`.
#![deny(unsafe_code)]

pub use peeltrim::images::{shade, Images};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// Errors writing or reading the output files; each names the file.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: {source}")]
    Image {
        path: PathBuf,
        #[source]
        source: image::ImageError,
    },
    #[error("{path}: not a valid depth.npy: {msg}")]
    Npy { path: PathBuf, msg: String },
    #[error("{path}: {msg}")]
    Format { path: PathBuf, msg: String },
    #[error("{path}: size {got_w}x{got_h} differs from depth.npy's {want_w}x{want_h}")]
    SizeMismatch {
        path: PathBuf,
        got_w: u32,
        got_h: u32,
        want_w: u32,
        want_h: u32,
    },
    /// `--out` (or a folder above it) is an existing file.
    #[error(
        "{path} is a file, not a folder: {what} needs a folder to write into (created if missing); \
         give a folder name that is not a file, e.g. out/"
    )]
    NotAFolder { path: PathBuf, what: String },
    #[error("{path}: {source}")]
    Json {
        path: PathBuf,
        #[source]
        source: serde_json::Error,
    },
}

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn img_err(path: &Path) -> impl FnOnce(image::ImageError) -> OutputError + '_ {
    move |source| OutputError::Image {
        path: path.to_path_buf(),
        source,
    }
}

/// The `.npy` v1.0 header for a C-order little-endian f32 array of `(height, width)`,
/// padded with spaces and a newline so the data starts at a multiple of 64 bytes.
pub fn npy_header(height: u32, width: u32) -> Vec<u8> {
    npy_header_shape(&format!("({height}, {width})"))
}

/// [`npy_header`] for any shape, written as Python prints a tuple: `(2, 3, 3)`.
fn npy_header_shape(shape: &str) -> Vec<u8> {
    let dict = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {shape}, }}");
    let unpadded = 10 + dict.len() + 1;
    let total = unpadded.div_ceil(64) * 64;
    let mut h = Vec::with_capacity(total);
    h.extend_from_slice(b"\x93NUMPY\x01\x00");
    h.extend_from_slice(&((total - 10) as u16).to_le_bytes());
    h.extend_from_slice(dict.as_bytes());
    h.resize(total - 1, b' ');
    h.push(b'\n');
    h
}

/// `normal.npy` bytes: little-endian f32, shape `(height, width, 3)`.
pub fn encode_npy_normals(height: u32, width: u32, normals: &[[f32; 3]]) -> Vec<u8> {
    let mut out = npy_header_shape(&format!("({height}, {width}, 3)"));
    out.reserve(normals.len() * 12);
    for c in normals.iter().flatten() {
        out.extend_from_slice(&c.to_le_bytes());
    }
    out
}

/// Writes a layer's `normal.npy` (view-space unit normals, `(height, width, 3)`
/// f32, zero where the layer has no point) into `dir`.
pub fn write_normals(
    dir: impl AsRef<Path>,
    width: u32,
    height: u32,
    normals: &[[f32; 3]],
) -> Result<(), OutputError> {
    assert_eq!(
        normals.len(),
        width as usize * height as usize,
        "normal buffer size"
    );
    let path = dir.as_ref().join("normal.npy");
    std::fs::write(&path, encode_npy_normals(height, width, normals)).map_err(io_err(&path))
}

/// Writes a layer's `edges.png` (8-bit grey, 255 = edge, 0 elsewhere) into `dir`.
pub fn write_edges(
    dir: impl AsRef<Path>,
    width: u32,
    height: u32,
    edges: &[bool],
) -> Result<(), OutputError> {
    let path = dir.as_ref().join("edges.png");
    let px: Vec<u8> = edges.iter().map(|&e| if e { 255 } else { 0 }).collect();
    image::GrayImage::from_raw(width, height, px)
        .expect("edge map size matches the image")
        .save_with_format(&path, image::ImageFormat::Png)
        .map_err(img_err(&path))
}

/// Reads `dir/edges.png` (any grey PNG; a pixel at 128 or more is an edge) as
/// `(width, height, map)`.
pub fn read_edges(dir: impl AsRef<Path>) -> Result<(u32, u32, Vec<bool>), OutputError> {
    let path = dir.as_ref().join("edges.png");
    let g = image::open(&path).map_err(img_err(&path))?.into_luma8();
    let (w, h) = (g.width(), g.height());
    Ok((w, h, g.into_raw().into_iter().map(|v| v >= 128).collect()))
}

/// Writes `depth` as `depth.npy` bytes.
pub fn encode_npy(height: u32, width: u32, depth: &[f32]) -> Vec<u8> {
    let mut out = npy_header(height, width);
    out.reserve(depth.len() * 4);
    for d in depth {
        out.extend_from_slice(&d.to_le_bytes());
    }
    out
}

/// Parses `.npy` bytes of a 2D little-endian f32 C-order array: `(height, width, data)`.
pub fn decode_npy(bytes: &[u8]) -> Result<(u32, u32, Vec<f32>), String> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err("missing the \\x93NUMPY magic".into());
    }
    let (hlen, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(format!("unsupported format version {v}")),
    };
    let header = bytes.get(start..start + hlen).ok_or("truncated header")?;
    let header = std::str::from_utf8(header).map_err(|_| "header is not text")?;
    let compact: String = header.chars().filter(|c| !c.is_whitespace()).collect();
    let field = |key: &str| -> Option<&str> {
        let k = format!("'{key}':");
        let i = compact.find(&k)? + k.len();
        Some(&compact[i..])
    };
    let descr = field("descr").ok_or("no 'descr'")?;
    if !descr.starts_with("'<f4'") {
        return Err(format!(
            "dtype must be '<f4' (little-endian float32), header: {header}"
        ));
    }
    let fortran = field("fortran_order").ok_or("no 'fortran_order'")?;
    if !fortran.starts_with("False") {
        return Err("fortran_order must be False (C order)".into());
    }
    let shape = field("shape").ok_or("no 'shape'")?;
    let shape = shape
        .strip_prefix('(')
        .and_then(|s| s.split(')').next())
        .ok_or("malformed 'shape'")?;
    let dims: Vec<u64> = shape
        .split(',')
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<u64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("malformed shape ({shape})"))?;
    let [h, w] = dims[..] else {
        return Err(format!("shape must be (height, width), got ({shape})"));
    };
    let (h, w) = (
        u32::try_from(h).map_err(|_| "height too large")?,
        u32::try_from(w).map_err(|_| "width too large")?,
    );
    let n = h as usize * w as usize;
    let data = &bytes[start + hlen..];
    if data.len() != n * 4 {
        return Err(format!(
            "expected {} data bytes for ({h}, {w}), found {}",
            n * 4,
            data.len()
        ));
    }
    let depth = data
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    Ok((h, w, depth))
}

/// Checks before any work that `dir` can be an output folder: neither it nor a
/// folder above it is an existing file (which `create_dir_all` would report only
/// as "File exists"). `what` names it for the user, e.g. `--out`.
pub fn check_out_dir(dir: impl AsRef<Path>, what: &str) -> Result<(), OutputError> {
    for a in dir.as_ref().ancestors() {
        match std::fs::metadata(a) {
            Ok(m) if m.is_dir() => return Ok(()),
            Ok(_) => {
                return Err(OutputError::NotAFolder {
                    path: a.to_path_buf(),
                    what: what.to_string(),
                })
            }
            Err(_) => {}
        }
    }
    Ok(())
}

/// `create_dir_all`, with a file in the way reported as [`OutputError::NotAFolder`].
pub fn create_out_dir(dir: impl AsRef<Path>, what: &str) -> Result<(), OutputError> {
    let dir = dir.as_ref();
    check_out_dir(dir, what)?;
    std::fs::create_dir_all(dir).map_err(io_err(dir))
}

/// Writes `color.png`, `depth.npy` and `prim.png` into `dir` (created if missing).
pub fn write_images(dir: impl AsRef<Path>, img: &Images) -> Result<(), OutputError> {
    let dir = dir.as_ref();
    create_out_dir(dir, "the output")?;
    let n = img.width as usize * img.height as usize;
    assert!(
        img.color.len() == n && img.depth.len() == n && img.prim.len() == n,
        "Images buffers do not match {}x{}",
        img.width,
        img.height
    );
    let path = dir.join("color.png");
    let rgba: Vec<u8> = img
        .color
        .iter()
        .flat_map(|c| [c[0], c[1], c[2], 255])
        .collect();
    image::RgbaImage::from_raw(img.width, img.height, rgba)
        .expect("buffer size checked")
        .save_with_format(&path, image::ImageFormat::Png)
        .map_err(img_err(&path))?;

    let path = dir.join("depth.npy");
    let mut f = std::fs::File::create(&path).map_err(io_err(&path))?;
    f.write_all(&encode_npy(img.height, img.width, &img.depth))
        .map_err(io_err(&path))?;

    let path = dir.join("prim.png");
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_raw(
        img.width,
        img.height,
        img.prim.clone(),
    )
    .expect("buffer size checked")
    .save_with_format(&path, image::ImageFormat::Png)
    .map_err(img_err(&path))?;
    Ok(())
}

/// Writes `coverage.png` (8-bit greyscale: each pixel's covered samples
/// ×255 over the samples) of a multisampled render into `dir`.
pub fn write_coverage(
    dir: impl AsRef<Path>,
    width: u32,
    height: u32,
    coverage: &[u8],
) -> Result<(), OutputError> {
    let path = dir.as_ref().join("coverage.png");
    image::GrayImage::from_raw(width, height, coverage.to_vec())
        .expect("one byte per pixel")
        .save_with_format(&path, image::ImageFormat::Png)
        .map_err(img_err(&path))
}

/// Reads `dir`'s `coverage.png` when there is one (a multisampled render).
pub fn read_coverage(dir: impl AsRef<Path>) -> Result<Option<(u32, u32, Vec<u8>)>, OutputError> {
    let path = dir.as_ref().join("coverage.png");
    if !path.exists() {
        return Ok(None);
    }
    let g = image::open(&path).map_err(img_err(&path))?.into_luma8();
    Ok(Some((g.width(), g.height(), g.into_raw())))
}

/// Writes `stats.json` (pretty-printed) into `dir` (created if missing).
pub fn write_stats(
    dir: impl AsRef<Path>,
    stats: &impl serde::Serialize,
) -> Result<(), OutputError> {
    let dir = dir.as_ref();
    create_out_dir(dir, "the output")?;
    let path = dir.join("stats.json");
    let text = serde_json::to_string_pretty(stats).map_err(|source| OutputError::Json {
        path: path.clone(),
        source,
    })?;
    std::fs::write(&path, text + "\n").map_err(io_err(&path))
}

/// Reads `depth.npy` and `prim.png` (required) and `color.png` (if present; else
/// black) from `dir`.
pub fn read_images(dir: impl AsRef<Path>) -> Result<Images, OutputError> {
    let dir = dir.as_ref();
    let path = dir.join("depth.npy");
    let mut bytes = vec![];
    std::fs::File::open(&path)
        .and_then(|mut f| f.read_to_end(&mut bytes))
        .map_err(io_err(&path))?;
    let (height, width, depth) = decode_npy(&bytes).map_err(|msg| OutputError::Npy {
        path: path.clone(),
        msg,
    })?;
    let check = |path: &Path, w: u32, h: u32| {
        if (w, h) != (width, height) {
            Err(OutputError::SizeMismatch {
                path: path.to_path_buf(),
                got_w: w,
                got_h: h,
                want_w: width,
                want_h: height,
            })
        } else {
            Ok(())
        }
    };

    let path = dir.join("prim.png");
    let dynimg = image::open(&path).map_err(img_err(&path))?;
    let prim = match dynimg {
        image::DynamicImage::ImageLuma16(p) => p,
        image::DynamicImage::ImageLuma8(p) => image::DynamicImage::ImageLuma8(p).into_luma16(),
        other => {
            return Err(OutputError::Format {
                path,
                msg: format!("expected a 16-bit greyscale PNG, found {:?}", other.color()),
            })
        }
    };
    check(&path, prim.width(), prim.height())?;
    let prim = prim.into_raw();

    let path = dir.join("color.png");
    let color = if path.exists() {
        let c = image::open(&path).map_err(img_err(&path))?.into_rgba8();
        check(&path, c.width(), c.height())?;
        c.into_raw()
            .chunks_exact(4)
            .map(|p| [p[0], p[1], p[2], p[3]])
            .collect()
    } else {
        vec![[0, 0, 0, 255]; width as usize * height as usize]
    };
    Ok(Images {
        width,
        height,
        color,
        depth,
        prim,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(w: u32, h: u32) -> Images {
        let n = (w * h) as usize;
        Images {
            width: w,
            height: h,
            color: (0..n).map(|i| [i as u8, (i * 7) as u8, 3, 255]).collect(),
            depth: (0..n)
                .map(|i| {
                    if i % 5 == 0 {
                        f32::INFINITY
                    } else {
                        i as f32 * 0.25 + 0.1
                    }
                })
                .collect(),
            prim: (0..n)
                .map(|i| {
                    if i % 5 == 0 {
                        0
                    } else {
                        (i * 977 % 65535) as u16
                    }
                })
                .collect(),
        }
    }

    #[test]
    fn shade_formula() {
        assert_eq!(shade([200, 100, 0], 1.0), [200, 100, 0, 255]);
        assert_eq!(shade([200, 100, 0], 0.0), [50, 25, 0, 255]);
        assert_eq!(shade([255, 255, 255], 0.5), [159, 159, 159, 255]); // 255*0.625=159.375
        assert_eq!(shade([10, 10, 10], -1.0), [10, 10, 10, 255]);
    }

    /// The header numpy's `format.read_array_header_1_0` accepts: magic, version 1.0,
    /// little-endian length, a dict literal, space padding, newline, 64-byte alignment.
    #[test]
    fn npy_header_bytes() {
        for (h, w) in [(1u32, 1u32), (480, 640), (100000, 3), (7, 123456)] {
            let hd = npy_header(h, w);
            assert_eq!(&hd[..8], b"\x93NUMPY\x01\x00");
            let len = u16::from_le_bytes([hd[8], hd[9]]) as usize;
            assert_eq!(hd.len(), 10 + len);
            assert_eq!(hd.len() % 64, 0);
            assert_eq!(*hd.last().unwrap(), b'\n');
            let text = std::str::from_utf8(&hd[10..]).unwrap();
            let dict = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({h}, {w}), }}");
            assert!(text.starts_with(&dict), "{text}");
            assert!(text[dict.len()..text.len() - 1].bytes().all(|b| b == b' '));
        }
        // Known-good bytes, as numpy 1.x writes them for np.zeros((2, 3), '<f4').
        let expect =
            b"\x93NUMPY\x01\x00v\x00{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }";
        assert_eq!(&npy_header(2, 3)[..expect.len()], &expect[..]);
    }

    #[test]
    fn npy_round_trip_and_errors() {
        let img = sample(13, 7);
        let bytes = encode_npy(7, 13, &img.depth);
        let (h, w, d) = decode_npy(&bytes).unwrap();
        assert_eq!((h, w), (7, 13));
        assert_eq!(
            d.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            img.depth.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        assert!(decode_npy(&bytes[..bytes.len() - 1])
            .unwrap_err()
            .contains("data bytes"));
        let mut x = bytes.clone();
        x[10..128].copy_from_slice(
            std::str::from_utf8(&bytes[10..128])
                .unwrap()
                .replace("<f4", ">f4")
                .as_bytes(),
        );
        assert!(decode_npy(&x).unwrap_err().contains("<f4"));
        assert!(decode_npy(b"hello world").is_err());
    }

    #[test]
    fn files_round_trip() {
        let dir = std::env::temp_dir().join(format!("peeltrim_out_{}", std::process::id()));
        let sub = dir.join("nested/out");
        let img = sample(37, 21);
        write_images(&sub, &img).unwrap();
        write_stats(&sub, &serde_json::json!({"algo": "reference", "width": 37})).unwrap();
        let back = read_images(&sub).unwrap();
        assert_eq!(back.width, 37);
        assert_eq!(back.prim, img.prim);
        assert_eq!(back.color, img.color);
        assert_eq!(
            back.depth.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            img.depth.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        let stats: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(sub.join("stats.json")).unwrap())
                .unwrap();
        assert_eq!(stats["algo"], "reference");
        // The error names the missing file.
        std::fs::remove_file(sub.join("prim.png")).unwrap();
        let err = read_images(&sub).unwrap_err().to_string();
        assert!(err.contains("prim.png"), "{err}");
        let err = read_images(dir.join("nope")).unwrap_err().to_string();
        assert!(err.contains("depth.npy"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
