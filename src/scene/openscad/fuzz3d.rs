//! Hostile input for the 3D readers: byte-level mutations of STL (ASCII and
//! binary), OFF and height-map (`.dat`, PNG) files, and random point sets for
//! the convex hull (duplicates, collinear and coplanar sets, magnitudes from
//! 1e-300 to 1e300). Every case ends in bounded time without a panic, in a
//! mesh or an error; a mesh read is closed or refused by the caller, and a
//! hull is closed, outward and contains its points. Case counts honour
//! `PEELTRIM_FUZZ_CASES` as the other fuzz tests do.

use crate::fuzz_tests::runner;
use glam::DVec3;
use proptest::prelude::*;
use std::time::{Duration, Instant};

use super::{hull, mesh_import, surface};
use crate::scene::validate::{check_closed, signed_volume};

const LIMIT: Duration = Duration::from_secs(5);

/// A byte mutation: truncation, a flipped byte, junk spliced in, or a number
/// replaced by a hostile one.
fn mutated(src: Vec<u8>) -> impl Strategy<Value = Vec<u8>> {
    let len = src.len();
    (
        0u8..5,
        0..len.max(1),
        any::<u8>(),
        prop::collection::vec(any::<u8>(), 0..12),
        prop::sample::select(vec![
            "nan",
            "inf",
            "-1e999",
            "1e300",
            "99999999999",
            "-1",
            "0",
        ]),
    )
        .prop_map(move |(kind, at, b, junk, num)| {
            let mut v = src.clone();
            match kind {
                0 => v.truncate(at),
                1 => {
                    if let Some(x) = v.get_mut(at) {
                        *x ^= b | 1;
                    }
                }
                2 => {
                    let at = at.min(v.len());
                    v.splice(at..at, junk);
                }
                3 => {
                    // The number starting at or after `at`.
                    let start = (at..v.len()).find(|&i| v[i].is_ascii_digit());
                    if let Some(s) = start {
                        let e = (s..v.len())
                            .find(|&i| !(v[i].is_ascii_digit() || v[i] == b'.'))
                            .unwrap_or(v.len());
                        v.splice(s..e, num.bytes());
                    }
                }
                _ => {}
            }
            v
        })
}

fn timed<T>(what: &str, f: impl FnOnce() -> T) -> Result<T, TestCaseError> {
    let t = Instant::now();
    let r = f();
    prop_assert!(t.elapsed() < LIMIT, "{what} took {:?}", t.elapsed());
    Ok(r)
}

fn binary_of(ascii: &[u8]) -> Vec<u8> {
    let m = mesh_import::parse_stl(ascii).unwrap();
    let mut b = vec![0u8; 80];
    b.extend((m.triangles.len() as u32).to_le_bytes());
    for t in &m.triangles {
        b.extend([0u8; 12]);
        for &i in t {
            for c in m.positions[i as usize].to_array() {
                b.extend((c as f32).to_le_bytes());
            }
        }
        b.extend([0u8; 2]);
    }
    b
}

#[test]
fn fuzz_stl_readers() {
    let ascii = super::tests3d::cube_stl(0.0, 1.0).into_bytes();
    let binary = binary_of(&ascii);
    for src in [ascii, binary] {
        runner(300)
            .run(&mutated(src), |bytes| {
                if let Ok(m) = timed("STL", || mesh_import::parse_stl(&bytes))? {
                    prop_assert!(m.positions.iter().all(|p| p.is_finite()));
                    prop_assert!(m
                        .triangles
                        .iter()
                        .flatten()
                        .all(|&i| (i as usize) < m.positions.len()));
                    let _ = check_closed(&m);
                }
                Ok(())
            })
            .unwrap();
    }
}

#[test]
fn fuzz_off_reader() {
    let off = b"OFF\n8 6 12\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n\
        4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n"
        .to_vec();
    runner(400)
        .run(&mutated(off), |bytes| {
            let text = String::from_utf8_lossy(&bytes);
            if let Ok(m) = timed("OFF", || mesh_import::parse_off(&text))? {
                prop_assert!(m
                    .triangles
                    .iter()
                    .flatten()
                    .all(|&i| (i as usize) < m.positions.len()));
                let _ = check_closed(&m);
            }
            Ok(())
        })
        .unwrap();
}

#[test]
fn fuzz_height_maps() {
    let dat = b"# h\n1 2 3 4\n4 5 6.5 1\n0 0 1 2\n".to_vec();
    let mut png = Vec::new();
    image::RgbImage::from_fn(5, 4, |x, y| image::Rgb([x as u8 * 40, y as u8 * 60, 7]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    for src in [dat, png] {
        runner(300)
            .run(&(mutated(src), any::<bool>()), |(bytes, invert)| {
                if let Ok(h) = timed("height map", || surface::heights(&bytes, invert))? {
                    let cells: usize = h.z.iter().map(Vec::len).sum();
                    prop_assert!(cells <= bytes.len().max(64) * 64, "{cells} cells");
                    if let Some(m) = timed("surface mesh", || surface::mesh(&h, invert))? {
                        check_closed(&m).map_err(|p| TestCaseError::fail(p.describe(&m)))?;
                        prop_assert!(signed_volume(&m) > 0.0);
                    }
                }
                Ok(())
            })
            .unwrap();
    }
}

/// Point sets that stress a hull: random, duplicated, on a line, on a plane,
/// on a sphere's grid, at extreme magnitudes.
fn points() -> impl Strategy<Value = Vec<DVec3>> {
    let coord = prop_oneof![
        8 => -10.0f64..10.0,
        1 => prop::sample::select(vec![0.0, 1e-300, -1e-300, 1e300, -1e300, 0.1, 1.0 / 3.0]),
    ];
    let p = (coord.clone(), coord.clone(), coord).prop_map(|(x, y, z)| DVec3::new(x, y, z));
    (prop::collection::vec(p, 0..60), 0u8..5, 1usize..4).prop_map(|(mut v, shape, dup)| {
        match shape {
            0 => v.iter_mut().for_each(|q| *q = DVec3::splat(q.x)),
            1 => v.iter_mut().for_each(|q| q.z = 0.5),
            2 => {
                let n = v.len();
                v.extend((0..n).map(|i| {
                    let a = i as f64 * 0.7;
                    DVec3::new(a.cos(), a.sin(), (i % 3) as f64)
                }))
            }
            _ => {}
        }
        let copy = v.clone();
        for _ in 1..dup {
            v.extend(copy.iter().copied());
        }
        v
    })
}

#[test]
fn fuzz_convex_hull() {
    runner(300)
        .run(&points(), |pts| {
            if let Some(h) = timed("hull", || hull::convex_hull(&pts))? {
                check_closed(&h).map_err(|p| TestCaseError::fail(p.describe(&h)))?;
                let v = signed_volume(&h);
                prop_assert!(v > 0.0);
                // Every point inside or on the hull (relative to its size).
                let size = pts.iter().fold(0.0f64, |m, p| m.max(p.abs().max_element()));
                for p in &pts {
                    for t in &h.triangles {
                        let [a, b, c] = t.map(|i| h.positions[i as usize]);
                        let n = (b - a).cross(c - a);
                        let d = n.dot(*p - a) / n.length().max(f64::MIN_POSITIVE);
                        prop_assert!(!(d > 1e-9 * size.max(1e-300)), "{p} outside by {d}");
                    }
                }
            }
            Ok(())
        })
        .unwrap();
}
