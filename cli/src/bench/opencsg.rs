//! The OpenCSG baseline (`peeltrim bench --baseline opencsg`):
//! each scene is also rendered by OpenCSG 1.5, driven as OpenSCAD's preview
//! drives it, on the same machine at the same size, and its frame time and error
//! against our reference go into the same tables as ours.
//!
//! OpenCSG is GPL, so it runs in a separate program, `tools/opencsg-bench/`
//! (C++, built by its `build.sh`), never linked into this library. This module
//! writes the exchange file it reads (documented in that program's header and
//! docs/bench.md), runs it, and reads its images back. The expression is
//! normalized here as OpenSCAD does ([`peeltrim::csg::normalize`]).
//!
//! OpenGL has no timestamp queries in this set-up: an OpenCSG row's GPU and CPU
//! times are both its `glFinish`-bracketed wall time per frame (median).
#![deny(unsafe_code)]

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

use glam::{DMat4, DVec4};
use serde::Serialize;

use super::report::error_figures;
use super::{median_iqr, Record, RunCounts};
use crate::output::Images;
use peeltrim::csg::normalize::{normalize, ScadProduct, OPENSCAD_NODE_LIMIT};
use peeltrim::plan::Prepared;
use peeltrim::scene::camera::{DepthConvention, Projection};
use peeltrim::scene::Scene;
use peeltrim_reference::compare::compare;

/// The variants the program runs: SCS and Goldfeather with occlusion queries,
/// and Automatic (OpenCSG's own choice, as OpenSCAD uses it).
pub const VARIANTS: [&str; 3] = ["scs", "goldfeather", "automatic"];

/// Prefix of the OpenCSG rows' `algo`.
pub const PREFIX: &str = "opencsg-";

/// Environment variable naming the program (overrides the search).
pub const ENV_PROGRAM: &str = "PEELTRIM_OPENCSG_BENCH";

/// What a missing program's row says.
pub const BUILD_HINT: &str =
    "opencsg-bench is not built: run tools/opencsg-bench/build.sh (or set PEELTRIM_OPENCSG_BENCH)";

/// "Correct" for the side-by-side table: interior coverage and primitive
/// mismatches each at most this fraction of the pixels (0.05%).
pub const CORRECT_FRAC: f64 = 5e-4;

/// How to run the baseline.
#[derive(Clone, Debug)]
pub struct OpenCsgBaseline {
    /// The program, when found.
    pub program: Option<PathBuf>,
    /// Give OpenCSG each primitive's NDC box (`setBoundingBox`): the fastest,
    /// fairest baseline. OpenSCAD does not set it.
    pub bounding_boxes: bool,
}

impl OpenCsgBaseline {
    /// Finds the program: `explicit` (`--opencsg-bench`), else
    /// `$PEELTRIM_OPENCSG_BENCH`, else `tools/opencsg-bench/opencsg-bench` under the
    /// current directory, next to the executable's tree (`target/<profile>/../../`)
    /// or in this source tree. A path the user names is the only one tried.
    pub fn locate(explicit: Option<PathBuf>, bounding_boxes: bool) -> Self {
        let rel = Path::new("tools/opencsg-bench/opencsg-bench");
        let named = explicit.or_else(|| std::env::var_os(ENV_PROGRAM).map(PathBuf::from));
        let candidates: Vec<PathBuf> = match named {
            Some(p) => vec![p],
            None => {
                let mut c = vec![rel.to_path_buf()];
                if let Ok(exe) = std::env::current_exe() {
                    c.extend(exe.ancestors().skip(1).take(4).map(|d| d.join(rel)));
                }
                c.push(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/..")).join(rel));
                c
            }
        };
        OpenCsgBaseline {
            program: candidates.into_iter().find(|p| p.is_file()),
            bounding_boxes,
        }
    }
}

fn mat_gl(m: &DMat4) -> String {
    m.to_cols_array()
        .iter()
        .map(|v| format!("{}", *v as f32))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The OpenGL projection of the scene's camera (depth −1..1, y up); its window
/// depth equals our standard Vulkan depth, so one conversion serves both.
pub fn gl_projection(scene: &Scene, aspect: f64) -> DMat4 {
    let (n, f) = (scene.camera.near, scene.camera.far);
    match scene.camera.projection {
        Projection::Perspective { fov_y_deg } => {
            DMat4::perspective_rh_gl(fov_y_deg.to_radians(), aspect, n, f)
        }
        Projection::Orthographic { height } => {
            let (hw, hh) = (0.5 * height * aspect, 0.5 * height);
            DMat4::orthographic_rh_gl(-hw, hw, -hh, hh, n, f)
        }
    }
}

/// The NDC box of a mesh's vertices; the whole cube when a vertex is at or
/// behind the eye plane (its projection would wrap).
fn ndc_box(clip: &DMat4, positions: &[glam::DVec3]) -> [f64; 6] {
    let mut b: [f64; 6] = [1.0, 1.0, 1.0, -1.0, -1.0, -1.0];
    for p in positions {
        let c: DVec4 = *clip * p.extend(1.0);
        if c.w <= 1e-12 {
            return [-1.0, -1.0, -1.0, 1.0, 1.0, 1.0];
        }
        let v = [c.x / c.w, c.y / c.w, c.z / c.w];
        for k in 0..3 {
            b[k] = b[k].min(v[k].clamp(-1.0, 1.0));
            b[k + 3] = b[k + 3].max(v[k].clamp(-1.0, 1.0));
        }
    }
    b
}

/// The exchange file for `tools/opencsg-bench` (format in its header).
/// `convex[prim]`: known convex (convexity 1); others are measured there.
pub fn export(scene: &Scene, w: u32, h: u32, products: &[ScadProduct], convex: &[bool]) -> String {
    let view = scene.camera.view();
    let proj = gl_projection(scene, w as f64 / h as f64);
    let clip = proj * view;
    let mut s = String::new();
    let _ = writeln!(s, "peeltrim-opencsg 1\nsize {w} {h}");
    let _ = writeln!(s, "view {}\nproj {}", mat_gl(&view), mat_gl(&proj));
    let _ = writeln!(s, "prims {}", scene.primitives.len());
    for (i, p) in scene.primitives.iter().enumerate() {
        let convexity = if convex.get(i).copied().unwrap_or(false) {
            1
        } else {
            0
        };
        let [r, g, b] = p.color;
        let bx = ndc_box(&clip, &p.mesh.positions);
        let _ = write!(s, "prim {convexity} {r} {g} {b}");
        for v in bx {
            let _ = write!(s, " {}", v as f32);
        }
        let _ = writeln!(s, " {}", p.mesh.triangles.len());
        for t in &p.mesh.triangles {
            for &v in t {
                let q = p.mesh.positions[v as usize];
                let _ = write!(s, "{} {} {} ", q.x as f32, q.y as f32, q.z as f32);
            }
        }
        s.push('\n');
    }
    let _ = writeln!(s, "products {}", products.len());
    for q in products {
        let _ = write!(s, "product {} {}", q.intersected.len(), q.subtracted.len());
        for i in q.intersected.iter().chain(&q.subtracted) {
            let _ = write!(s, " {i}");
        }
        s.push('\n');
    }
    s
}

/// One variant's line of `results.txt`.
#[derive(Clone, Debug, PartialEq)]
struct VariantResult {
    name: String,
    frames: u32,
    median_ms: f64,
    min_ms: f64,
    max_ms: f64,
    renderer: String,
}

fn parse_results(text: &str) -> Result<(Vec<u32>, Vec<VariantResult>), String> {
    let mut convexity = Vec::new();
    let mut out = Vec::new();
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("convexity") => {
                convexity = words
                    .map(|w| w.parse().map_err(|_| format!("bad convexity '{w}'")))
                    .collect::<Result<_, _>>()?;
            }
            Some("variant") => {
                let (head, renderer) = line.split_once(" renderer ").unwrap_or((line, ""));
                let f: Vec<&str> = head.split_whitespace().collect();
                let num = |k: &str| -> Result<f64, String> {
                    let i = f
                        .iter()
                        .position(|w| *w == k)
                        .ok_or(format!("no {k} in '{line}'"))?;
                    f.get(i + 1)
                        .and_then(|v| v.parse().ok())
                        .ok_or(format!("bad {k} in '{line}'"))
                };
                out.push(VariantResult {
                    name: f.get(1).unwrap_or(&"?").to_string(),
                    frames: num("frames")? as u32,
                    median_ms: num("median_ms")?,
                    min_ms: num("min_ms")?,
                    max_ms: num("max_ms")?,
                    renderer: renderer.trim().trim_matches('"').to_string(),
                });
            }
            _ => {}
        }
    }
    Ok((convexity, out))
}

/// The program's raw images as ours: window depth → view depth, index → colour.
fn read_images(dir: &Path, variant: &str, scene: &Scene, w: u32, h: u32) -> Result<Images, String> {
    let n = w as usize * h as usize;
    let read = |ext: &str, bytes: usize| -> Result<Vec<u8>, String> {
        let p = dir.join(format!("{variant}.{ext}"));
        let v = std::fs::read(&p).map_err(|e| format!("{}: {e}", p.display()))?;
        if v.len() != bytes {
            return Err(format!(
                "{}: {} bytes, expected {bytes}",
                p.display(),
                v.len()
            ));
        }
        Ok(v)
    };
    let depth_raw = read("depth", 4 * n)?;
    let prim_raw = read("prim", 2 * n)?;
    let prim: Vec<u16> = prim_raw
        .chunks_exact(2)
        .map(|c| u16::from_le_bytes([c[0], c[1]]))
        .collect();
    let depth: Vec<f32> = depth_raw
        .chunks_exact(4)
        .zip(&prim)
        .map(|(c, &id)| {
            let d = f32::from_le_bytes([c[0], c[1], c[2], c[3]]) as f64;
            if id == 0 || d >= 1.0 {
                f32::INFINITY
            } else {
                scene
                    .camera
                    .view_depth_from_ndc(d, DepthConvention::Standard) as f32
            }
        })
        .collect();
    let bg = scene.render.background;
    let color = prim
        .iter()
        .map(|&id| {
            let [r, g, b] = scene
                .primitives
                .get((id as usize).wrapping_sub(1))
                .map(|p| p.color)
                .unwrap_or(bg);
            [r, g, b, 255]
        })
        .collect();
    Ok(Images {
        width: w,
        height: h,
        color,
        depth,
        prim,
    })
}

/// Runs the baseline on one scene; one record per variant (or one failed
/// record saying why it could not run). `base` carries the scene's fields;
/// `work` is a directory for the exchange file and the raw images.
pub fn run_scene(
    baseline: &OpenCsgBaseline,
    scene: &Scene,
    reference: &Images,
    base: Record,
    frames: u32,
    warmup: u32,
    work: &Path,
) -> Vec<(Record, Option<Images>)> {
    let fail = |why: String| {
        let mut r = base.clone();
        r.algo = format!("{PREFIX}*");
        r.failure = Some(why);
        vec![(r, None)]
    };
    let Some(program) = &baseline.program else {
        return fail(BUILD_HINT.into());
    };
    let prep = match Prepared::new(scene) {
        Ok(p) => p,
        Err(e) => return fail(e.to_string()),
    };
    let Some(expr) = &prep.expr else {
        return fail("the scene has no solid (OpenCSG draws solids only)".into());
    };
    let boxes: Vec<_> = prep
        .mesh_bounds
        .iter()
        .map(|b| (b.min.to_array(), b.max.to_array()))
        .collect();
    let products = match normalize(expr, &boxes, OPENSCAD_NODE_LIMIT) {
        Ok(p) => p,
        Err(e) => return fail(format!("OpenSCAD's normalization: {e}")),
    };
    let (w, h) = (reference.width, reference.height);
    if let Err(e) = std::fs::create_dir_all(work) {
        return fail(format!("{}: {e}", work.display()));
    }
    let input = work.join("scene.txt");
    if let Err(e) = std::fs::write(&input, export(scene, w, h, &products, &prep.mesh_convex)) {
        return fail(format!("{}: {e}", input.display()));
    }
    let mut cmd = Command::new(program);
    cmd.arg(&input)
        .arg(work)
        .args(["--frames", &frames.max(1).to_string()])
        .args(["--warmup", &warmup.to_string()])
        .args(["--variants", &VARIANTS.join(",")]);
    if !baseline.bounding_boxes {
        cmd.arg("--no-bbox");
    }
    let out = match cmd.output() {
        Ok(o) => o,
        Err(e) => return fail(format!("{}: {e}", program.display())),
    };
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return fail(format!(
            "{} failed ({}): {}",
            program.display(),
            out.status,
            err.lines().last().unwrap_or("")
        ));
    }
    let results = std::fs::read_to_string(work.join("results.txt"))
        .map_err(|e| e.to_string())
        .and_then(|t| parse_results(&t));
    let (convexity, variants) = match results {
        Ok(r) => r,
        Err(e) => {
            return fail(format!(
                "reading {}: {e}",
                work.join("results.txt").display()
            ))
        }
    };
    let single = products
        .iter()
        .filter(|q| q.intersected.len() == 1 && q.subtracted.is_empty())
        .count();
    let literals: usize = products
        .iter()
        .map(|q| q.intersected.len() + q.subtracted.len())
        .sum();
    let mut rows = Vec::new();
    for v in variants {
        let mut r = base.clone();
        r.algo = format!("{PREFIX}{}", v.name);
        r.depth_setup = if baseline.bounding_boxes {
            "gl-d24s8".into()
        } else {
            "gl-d24s8-nobbox".into()
        };
        r.device = format!("{} (OpenGL, OpenCSG 1.5)", v.renderer);
        r.frames = v.frames;
        r.gpu_ms_median = v.median_ms;
        r.gpu_ms_min = v.min_ms;
        r.gpu_ms_max = v.max_ms;
        r.cpu_ms_median = v.median_ms;
        // Its wall time per frame (to glFinish) fills the frame fields as our
        // runs' submission-to-idle time does.
        r.frame_ms_median = v.median_ms;
        r.frame_cpu_ms_median = v.median_ms;
        r.counts = Some(RunCounts::OpenCsg(ProductCounts {
            products: products.len(),
            single_primitive_products: single,
            product_literals: literals,
            max_convexity: convexity.iter().copied().max().unwrap_or(0),
        }));
        match read_images(work, &v.name, scene, w, h).and_then(|img| {
            compare(reference, &img)
                .map(|c| (c, img))
                .map_err(|e| e.to_string())
        }) {
            Ok((c, img)) => {
                r.error = Some(c);
                rows.push((r, Some(img)));
            }
            Err(e) => {
                r.failure = Some(e);
                rows.push((r, None));
            }
        }
    }
    rows
}

/// The counts of a baseline run: the normalized expression OpenCSG draws.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ProductCounts {
    /// Products of the normalized expression.
    pub products: usize,
    /// Products of one primitive and no subtraction.
    pub single_primitive_products: usize,
    /// Primitives over all products, each counted per product it appears in.
    pub product_literals: usize,
    /// The largest convexity (front faces a ray may cross) of a primitive,
    /// as the program took it (given convex, or measured).
    pub max_convexity: u32,
}
/// One scene's two baseline runs, made before and after our timed rounds, as
/// one: per variant the median of the two runs' medians (their mean), the
/// extremes of both, the frames of both; errors and images from the later run
/// (the images are the same). A variant that ran only once keeps that run.
pub fn merge_runs(
    before: Vec<(Record, Option<Images>)>,
    after: Vec<(Record, Option<Images>)>,
) -> Vec<(Record, Option<Images>)> {
    let mut before = before;
    let mut out = Vec::new();
    for (mut r, images) in after {
        let earlier = before
            .iter()
            .position(|(b, _)| b.algo == r.algo)
            .map(|i| before.remove(i).0);
        match earlier {
            Some(b) if b.ran() && r.ran() => {
                let (ms, _, _, spread) = median_iqr(&mut [b.gpu_ms_median, r.gpu_ms_median]);
                r.gpu_ms_min = r.gpu_ms_min.min(b.gpu_ms_min);
                r.gpu_ms_max = r.gpu_ms_max.max(b.gpu_ms_max);
                (r.gpu_ms_median, r.cpu_ms_median, r.gpu_ms_iqr) = (ms, ms, spread);
                (r.frame_ms_median, r.frame_cpu_ms_median, r.frame_ms_iqr) = (ms, ms, spread);
                r.frames += b.frames;
            }
            Some(b) if b.ran() => {
                out.push((b, None));
                continue;
            }
            _ => {}
        }
        out.push((r, images));
    }
    out.extend(before);
    out
}

/// Wall time per frame of a run: what the side-by-side compares.
pub fn wall_ms(r: &Record) -> f64 {
    r.cpu_ms_median
}

/// A run within [`CORRECT_FRAC`] interior coverage and primitive mismatches.
pub fn is_correct(r: &Record) -> bool {
    let (cov, prim, _) = error_figures(r);
    r.ran() && cov <= CORRECT_FRAC && prim <= CORRECT_FRAC
}

fn best<'a>(rows: impl Iterator<Item = &'a Record>) -> Option<&'a Record> {
    rows.filter(|r| is_correct(r))
        .min_by(|a, b| wall_ms(a).total_cmp(&wall_ms(b)))
}

/// Markdown: per scene and size with OpenCSG rows, our best correct run
/// against OpenCSG's best correct variant (wall ms per frame), with the ratio.
pub fn side_by_side(records: &[Record]) -> String {
    let mut keys: Vec<(String, u32, u32)> = records
        .iter()
        .filter(|r| r.algo.starts_with(PREFIX))
        .map(|r| (r.scene.clone(), r.width, r.height))
        .collect();
    keys.dedup();
    if keys.is_empty() {
        return String::new();
    }
    let mut s = String::from("## peeltrim against OpenCSG\n\n");
    s.push_str(&format!(
        "Wall ms per frame (median). Correct: interior coverage and primitive mismatches each ≤ {}% of pixels. Ratio: peeltrim / OpenCSG (below 1: peeltrim is faster).\n\n",
        CORRECT_FRAC * 100.0
    ));
    s.push_str("| scene | size | peeltrim best correct | ms | OpenCSG best correct | ms | ratio | OpenCSG variants (ms, cov. % / prim. %) |\n|---|---|---|---|---|---|---|---|\n");
    for (scene, w, h) in keys {
        let rows: Vec<&Record> = records
            .iter()
            .filter(|r| r.scene == scene && r.width == w && r.height == h)
            .collect();
        let ours = best(
            rows.iter()
                .copied()
                .filter(|r| !r.algo.starts_with(PREFIX) && r.algo != "reference"),
        );
        let theirs = best(rows.iter().copied().filter(|r| r.algo.starts_with(PREFIX)));
        let name = |r: Option<&Record>| {
            r.map(|r| (r.algo.clone(), format!("{:.1}", wall_ms(r))))
                .unwrap_or(("none".into(), "-".into()))
        };
        let ratio = match (ours, theirs) {
            (Some(a), Some(b)) if wall_ms(b) > 0.0 => format!("{:.2}", wall_ms(a) / wall_ms(b)),
            _ => "-".into(),
        };
        let variants: Vec<String> = rows
            .iter()
            .filter(|r| r.algo.starts_with(PREFIX))
            .map(|r| match &r.failure {
                Some(f) => format!("{}: not run ({})", r.algo, f.replace('|', "/")),
                None => {
                    let (cov, prim, _) = error_figures(r);
                    format!(
                        "{} {:.1} ({:.3} / {:.3})",
                        r.algo.trim_start_matches(PREFIX),
                        wall_ms(r),
                        cov * 100.0,
                        prim * 100.0
                    )
                }
            })
            .collect();
        let (a, am) = name(ours);
        let (b, bm) = name(theirs);
        let _ = writeln!(
            s,
            "| {scene} | {w}×{h} | {a} | {am} | {b} | {bm} | {ratio} | {} |",
            variants.join("; ")
        );
    }
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(toml: &str) -> Scene {
        peeltrim::scene::load_str(toml, Path::new("t.toml"), &Default::default())
            .expect("test scene loads")
    }

    #[test]
    fn baseline_runs_merge_to_the_median_of_both() {
        let run = |algo: &str, ms: f64| {
            let mut r = Record::blank(algo, "gl-d24s8");
            (r.gpu_ms_median, r.gpu_ms_min, r.gpu_ms_max, r.frames) = (ms, ms - 1.0, ms + 1.0, 5);
            r.cpu_ms_median = ms;
            (r, None)
        };
        let mut failed = run("opencsg-scs", 0.0);
        failed.0.failure = Some("crashed".into());
        let merged = merge_runs(
            vec![run("opencsg-goldfeather", 10.0), run("opencsg-scs", 4.0)],
            vec![run("opencsg-goldfeather", 14.0), failed],
        );
        let gf = &merged[0].0;
        assert_eq!(
            (gf.algo.as_str(), gf.gpu_ms_median),
            ("opencsg-goldfeather", 12.0)
        );
        assert_eq!(
            (gf.cpu_ms_median, gf.gpu_ms_min, gf.gpu_ms_max),
            (12.0, 9.0, 15.0)
        );
        assert_eq!((gf.frames, gf.gpu_ms_iqr), (10, 2.0));
        // The frame fields hold the same wall time as for our runs.
        assert_eq!((gf.frame_ms_median, gf.frame_ms_iqr), (12.0, 2.0));
        // The later run failed: the earlier one's figures stand.
        let scs = &merged[1].0;
        assert_eq!((scs.algo.as_str(), scs.gpu_ms_median), ("opencsg-scs", 4.0));
        assert!(scs.failure.is_none() && merged.len() == 2);
    }

    #[test]
    fn results_file_parses() {
        let (c, v) = parse_results(
            "convexity 1 3\nvariant scs frames 5 median_ms 6.5 min_ms 6 max_ms 7 renderer \"llvmpipe (LLVM 15)\"\n",
        )
        .unwrap();
        assert_eq!(c, vec![1, 3]);
        assert_eq!(v[0].name, "scs");
        assert_eq!(v[0].median_ms, 6.5);
        assert_eq!(v[0].renderer, "llvmpipe (LLVM 15)");
        assert!(parse_results("variant scs frames x").is_err());
    }

    #[test]
    fn gl_window_depth_is_our_standard_depth() {
        let sc = scene(
            "[camera]\neye=[0,0,5]\nnear=1\nfar=10\n[[primitive]]\nname='A'\nshape='box'\nsize=[1,1,1]\n[csg]\nexpr='A'\n",
        );
        let proj = gl_projection(&sc, 1.0);
        for d in [1.0, 2.5, 9.0] {
            let c = proj * DVec4::new(0.0, 0.0, -d, 1.0);
            let window = 0.5 * (c.z / c.w) + 0.5;
            let back = sc
                .camera
                .view_depth_from_ndc(window, DepthConvention::Standard);
            assert!((back - d).abs() < 1e-9, "{d} -> {window} -> {back}");
        }
    }

    #[test]
    fn export_lists_every_primitive_and_product() {
        let sc = scene(
            "[camera]\neye=[0,0,5]\n[[primitive]]\nname='A'\nshape='box'\nsize=[1,1,1]\n[[primitive]]\nname='B'\nshape='sphere'\nradius=0.6\nsegments=8\n[csg]\nexpr='A - B'\n",
        );
        let prods = vec![ScadProduct {
            intersected: vec![0],
            subtracted: vec![1],
        }];
        let s = export(&sc, 64, 32, &prods, &[true, false]);
        assert!(s.starts_with("peeltrim-opencsg 1\nsize 64 32\n"));
        let prims: Vec<&str> = s.lines().filter(|l| l.starts_with("prim ")).collect();
        assert_eq!(prims.len(), 2);
        assert!(prims[0].starts_with("prim 1 ") && prims[0].ends_with(" 12"));
        assert!(prims[1].starts_with("prim 0 "));
        assert!(s.contains("\nproducts 1\nproduct 1 1 0 1\n"));
    }
}
