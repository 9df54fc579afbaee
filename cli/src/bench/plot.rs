//! PNG plots of benchmark results (plotters, bitmap backend): time against error
//! per scene, time against the number of primitives for the scaling families,
//! per-pass time breakdowns, and every run against its rasterization floor. Text uses DejaVu Sans (Debian's
//! fonts-dejavu-core, installed by tools/setup.sh).
#![deny(unsafe_code)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::report::error_figures;
use super::{BenchError, Record};

/// DejaVu Sans, shipped in the repository (`assets/fonts/`, Bitstream Vera
/// licence beside it) so plots never depend on the fonts a machine has installed.
static FONT_TTF: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// Registers the embedded plot font once.
fn font() -> Result<(), BenchError> {
    static FONT: OnceLock<Result<(), String>> = OnceLock::new();
    FONT.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT_TTF)
            .map_err(|_| "the embedded DejaVu Sans font could not be loaded".to_string())
    })
    .clone()
    .map_err(BenchError::Other)
}

fn err(path: &Path, e: impl std::fmt::Display) -> BenchError {
    BenchError::Other(format!("plotting {}: {e}", path.display()))
}

/// A white drawing area of `size` pixels for the PNG at `path`.
fn canvas(
    path: &Path,
    size: (u32, u32),
) -> Result<DrawingArea<BitMapBackend<'_>, Shift>, BenchError> {
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(path, e))?;
    Ok(root)
}

/// Twenty colours told apart at a glance (Tableau's 20, dark and light of each
/// hue), for pass kinds and algorithms.
const PALETTE: [RGBColor; 20] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(174, 199, 232),
    RGBColor(255, 187, 120),
    RGBColor(152, 223, 138),
    RGBColor(255, 152, 150),
    RGBColor(197, 176, 213),
    RGBColor(196, 156, 148),
    RGBColor(247, 182, 210),
    RGBColor(199, 199, 199),
    RGBColor(219, 219, 141),
    RGBColor(158, 218, 229),
];

/// Our algorithms, each with its own colour and marker.
const ALGOS: [&str; 12] = [
    "blister",
    "cst-z",
    "cst-i",
    "cst-g",
    "goldfeather",
    "goldfeather-layered",
    "trickle",
    "reference",
    "kirsch",
    "scs",
    "blister-paper",
    "auto",
];

/// OpenCSG's variants: dark colours and markers of their own.
const OPENCSG_COLORS: [RGBColor; 4] = [
    RGBColor(0, 0, 0),
    RGBColor(90, 60, 0),
    RGBColor(0, 70, 90),
    RGBColor(110, 0, 70),
];

/// An algorithm's (or an OpenCSG variant's) colour and marker number.
fn algo_style(algo: &str) -> (RGBColor, usize) {
    if let Some(v) = algo.strip_prefix(super::opencsg::PREFIX) {
        let i = ["goldfeather", "scs", "automatic", "*"]
            .iter()
            .position(|x| *x == v)
            .unwrap_or(3);
        // Filled with a white centre: circle, triangle, square, diamond.
        return (OPENCSG_COLORS[i], 12 + i);
    }
    match ALGOS.iter().position(|a| *a == algo) {
        Some(i) => (PALETTE[i], i),
        None => (PALETTE[7], 7),
    }
}

/// Runs `body` with `mk`, a function from a position to marker `n` (of 12:
/// filled and hollow circles, triangles, squares and diamonds, crosses,
/// pluses) in `color`. A macro: each marker is an element type of its own.
macro_rules! with_marker {
    ($n:expr, $color:expr, |$mk:ident| $body:expr) => {{
        let n: usize = $n;
        let color: RGBColor = $color;
        let line = color.stroke_width(2);
        // 0-5 filled, 6-11 hollow, 12-17 filled with a white centre.
        let style = if (n / 6) % 3 == 1 {
            line
        } else {
            color.filled()
        };
        let dot = if (n / 6) % 3 == 2 {
            WHITE.filled()
        } else {
            TRANSPARENT.filled()
        };
        match n % 6 {
            0 => {
                let $mk = |p| {
                    EmptyElement::at(p)
                        + Circle::new((0, 0), 5, style)
                        + Circle::new((0, 0), 2, dot)
                };
                $body
            }
            1 => {
                let $mk = |p| {
                    EmptyElement::at(p)
                        + TriangleMarker::new((0, 0), 7, style)
                        + Circle::new((0, 1), 2, dot)
                };
                $body
            }
            2 => {
                let $mk = |p| {
                    EmptyElement::at(p)
                        + Rectangle::new([(-5, -5), (5, 5)], style)
                        + Circle::new((0, 0), 2, dot)
                };
                $body
            }
            3 => {
                let $mk = |p| {
                    EmptyElement::at(p)
                        + Polygon::new(vec![(0, -7), (7, 0), (0, 7), (-7, 0)], style)
                        + Circle::new((0, 0), 2, dot)
                };
                $body
            }
            4 => {
                let $mk = |p| EmptyElement::at(p) + Cross::new((0, 0), 5, line);
                $body
            }
            _ => {
                let $mk = |p| {
                    EmptyElement::at(p)
                        + PathElement::new(vec![(-7, 0), (7, 0)], line)
                        + PathElement::new(vec![(0, -7), (0, 7)], line)
                };
                $body
            }
        }
    }};
}

/// A legend entry's mark: a marker number, a colour swatch, or a line.
#[derive(Clone, Copy)]
enum Mark {
    Marker(usize),
    Swatch,
    Line(usize),
}

/// Draws a legend of `entries` (mark, colour, text) down `area`, beside the
/// data, under `heading`.
fn side_legend(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    path: &Path,
    heading: &str,
    entries: &[(Mark, RGBColor, String)],
) -> Result<(), BenchError> {
    area.draw(&Text::new(
        heading.to_string(),
        (10, 30),
        ("sans-serif", 15).into_font(),
    ))
    .map_err(|e| err(path, e))?;
    for (i, (mark, color, text)) in entries.iter().enumerate() {
        let y = 60 + 22 * i as i32;
        match *mark {
            Mark::Marker(n) => with_marker!(n, *color, |mk| area.draw(&mk((20, y)))),
            Mark::Swatch => area.draw(&Rectangle::new([(13, y - 7), (27, y + 7)], color.filled())),
            Mark::Line(n) => area
                .draw(&PathElement::new(
                    vec![(8, y), (32, y)],
                    color.stroke_width(2),
                ))
                .and_then(|_| with_marker!(n, *color, |mk| area.draw(&mk((20, y))))),
        }
        .map_err(|e| err(path, e))?;
        area.draw(&Text::new(
            text.clone(),
            (40, y - 8),
            ("sans-serif", 14).into_font(),
        ))
        .map_err(|e| err(path, e))?;
    }
    Ok(())
}

/// Writes all plots; returns the files written.
pub fn write_all(out: &Path, records: &[Record]) -> Result<Vec<PathBuf>, BenchError> {
    font()?;
    let dir = out.join("plots");
    std::fs::create_dir_all(&dir).map_err(|source| BenchError::Io {
        path: dir.clone(),
        source,
    })?;
    let mut files = Vec::new();
    let mut scenes: Vec<(String, u32, u32)> = records
        .iter()
        .filter(|r| r.family.is_none())
        .map(|r| (r.scene.clone(), r.width, r.height))
        .collect();
    scenes.dedup();
    for (scene, w, h) in scenes {
        let rows: Vec<&Record> = records
            .iter()
            .filter(|r| {
                r.scene == scene
                    && r.width == w
                    && r.height == h
                    && r.ran()
                    && r.algo != "reference"
            })
            .collect();
        if rows.is_empty() {
            continue;
        }
        let p = dir.join(format!("time_vs_error_{scene}_{w}x{h}.png"));
        time_vs_error(&p, &format!("{scene} {w}x{h}: frame time vs error"), &rows)?;
        files.push(p);
        let p = dir.join(format!("passes_{scene}_{w}x{h}.png"));
        pass_breakdown(
            &p,
            &format!("{scene} {w}x{h}: GPU time per pass, one frame timed at every pass"),
            &rows,
        )?;
        files.push(p);
    }
    let floor_rows: Vec<&Record> = records
        .iter()
        .filter(|r| r.family.is_none() && super::floor::multiple(r).is_some())
        .collect();
    if !floor_rows.is_empty() {
        let p = dir.join("floor.png");
        floor_multiples(&p, &floor_rows)?;
        files.push(p);
    }
    let mut families: Vec<String> = records.iter().filter_map(|r| r.family.clone()).collect();
    families.sort();
    families.dedup();
    for fam in families {
        let rows: Vec<&Record> = records
            .iter()
            .filter(|r| r.family.as_deref() == Some(&fam) && r.ran() && r.algo != "reference")
            .collect();
        if rows.is_empty() {
            continue;
        }
        let p = dir.join(format!("scaling_{fam}.png"));
        scaling(
            &p,
            &format!("{fam}: frame time vs number of primitives"),
            &rows,
        )?;
        files.push(p);
    }
    Ok(files)
}

/// A log axis's tick: `0.1`, `1`, `1000`, `1e-4`.
fn tick(v: f64) -> String {
    if (1e-3..1e6).contains(&v) {
        format!("{}", (v * 1e3).round() / 1e3)
    } else {
        format!("{v:.0e}")
    }
}

/// A percentage for an axis label: `10%`, `0.5%`, `0.001%`, `1e-4%`.
fn percent(v: f64) -> String {
    if v >= 1.0 {
        format!("{v:.0}%")
    } else if v >= 0.000_999 {
        format!(
            "{}%",
            format!("{v:.3}")
                .trim_end_matches('0')
                .trim_end_matches('.')
        )
    } else {
        format!("{v:.0e}%")
    }
}

/// The depth set-ups of `rows`: one goes into the title, several into each
/// legend entry.
fn depth_title(rows: &[&Record]) -> (Option<String>, bool) {
    let mut d: Vec<&str> = rows
        .iter()
        .filter(|r| !r.algo.starts_with(super::opencsg::PREFIX))
        .map(|r| r.depth_setup.as_str())
        .collect();
    d.sort();
    d.dedup();
    match d[..] {
        [one] => (Some(one.to_string()), false),
        _ => (None, true),
    }
}

/// x: median frame time (ms, first submission to idle; OpenCSG's: its wall
/// time to glFinish); y: interior coverage + primitive mismatches (% of
/// pixels) on a log scale of at least two whole decades, with exact results
/// (error 0, which a log axis cannot show) in a strip of their own below it.
/// Each variant (algorithm, and depth set-up when several ran) has its own
/// colour and marker, named in a legend beside the plot.
fn time_vs_error(path: &Path, title: &str, rows: &[&Record]) -> Result<(), BenchError> {
    let (depth, per_depth) = depth_title(rows);
    let opencsg = rows
        .iter()
        .any(|r| r.algo.starts_with(super::opencsg::PREFIX));
    let multisampled = rows.iter().any(|r| r.samples > 1);
    let pts: Vec<(f64, f64, &str, &str)> = rows
        .iter()
        .map(|r| {
            let (c, p, _) = error_figures(r);
            // Multisampled: the coverage error at the edges (pixels whose
            // coverage fraction is off by more than 1/8) for the interior's.
            let c = match (&r.coverage, multisampled) {
                (Some(s), true) => s.coverage_off_by_eighth_frac,
                _ => c,
            };
            let e = (c.max(0.0) + p.max(0.0)) * 100.0;
            (
                r.frame_ms_median,
                if e.is_finite() { e } else { 0.0 },
                r.algo.as_str(),
                r.depth_setup.as_str(),
            )
        })
        .collect();
    let xmax = pts.iter().map(|p| p.0).fold(0.0, f64::max) * 1.1 + 1e-3;
    let nonzero = pts.iter().map(|p| p.1).filter(|&e| e > 0.0);
    let (ymin, ymax) = nonzero.fold((f64::INFINITY, 0.0f64), |(a, b), e| (a.min(e), b.max(e)));
    let (ylo, yhi) = if ymax > 0.0 {
        let lo = 10f64.powf(ymin.log10().floor());
        // At least two decades, so the axis has three labelled ticks.
        (lo, 10f64.powf(ymax.log10().ceil()).max(lo * 100.0))
    } else {
        (1e-3, 1.0)
    };
    // A hair wider, so rounding leaves the end decades' ticks inside.
    let (ylo, yhi) = (ylo * 0.999, yhi * 1.001);
    let mut series: Vec<(&str, &str)> = pts.iter().map(|p| (p.2, p.3)).collect();
    series.sort_by_key(|&(a, d)| (algo_style(a).1, d));
    series.dedup();
    let root = canvas(path, (1150, 650))?;
    let full_title = match &depth {
        Some(d) => format!("{title} (depth set-up {d})"),
        None => title.to_string(),
    };
    let root = root
        .titled(&full_title, ("sans-serif", 22))
        .map_err(|e| err(path, e))?;
    let (plot, legend_area) = root.split_horizontally(880);
    let (top, bottom) = plot.split_vertically(470);
    let mut chart = ChartBuilder::on(&top)
        .margin(15)
        .margin_bottom(0)
        .x_label_area_size(0)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..xmax, (ylo..yhi).log_scale())
        .map_err(|e| err(path, e))?;
    chart
        .configure_mesh()
        .y_desc(match multisampled {
            true => "edge coverage off by >1/8 + primitive mismatches (% of pixels, log)",
            false => "coverage + primitive mismatches (% of pixels, log)",
        })
        .y_label_formatter(&|v| percent(*v))
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(|e| err(path, e))?;
    let mut zero = ChartBuilder::on(&bottom)
        .margin(15)
        .margin_top(5)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..xmax, -1.0..1.0)
        .map_err(|e| err(path, e))?;
    zero.configure_mesh()
        .disable_y_mesh()
        .y_labels(1)
        .y_label_formatter(&|_| "0 (exact)".to_string())
        .label_style(("sans-serif", 13))
        .x_desc(if opencsg {
            "median frame time (ms, submission to idle; OpenCSG: to glFinish)"
        } else {
            "median frame time (ms, submission to idle)"
        })
        .draw()
        .map_err(|e| err(path, e))?;
    let mut entries = Vec::new();
    for (i, &(algo, d)) in series.iter().enumerate() {
        let (c, m) = algo_style(algo);
        // Several depth set-ups: the same algorithm's set-ups differ in marker.
        let m = if per_depth { m + 16 * i } else { m };
        let mine = || pts.iter().filter(move |p| p.2 == algo && p.3 == d);
        with_marker!(m, c, |mk| zero
            .draw_series(mine().filter(|p| p.1 == 0.0).map(|p| mk((p.0, 0.0))))
            .map(|_| ())
            .map_err(|e| err(path, e)))?;
        with_marker!(m, c, |mk| chart
            .draw_series(mine().filter(|p| p.1 > 0.0).map(|p| mk((p.0, p.1))))
            .map(|_| ())
            .map_err(|e| err(path, e)))?;
        let text = if per_depth && !algo.starts_with(super::opencsg::PREFIX) {
            format!("{algo}, {d}")
        } else {
            algo.to_string()
        };
        entries.push((Mark::Marker(m), c, text));
    }
    side_legend(&legend_area, path, "algorithm", &entries)?;
    root.present().map_err(|e| err(path, e))?;
    Ok(())
}

/// Dots: every run's frame as a multiple of its scene's rasterization floor
/// (log), scenes along x, one colour and marker per algorithm, the floor
/// itself the line at 1.
fn floor_multiples(path: &Path, rows: &[&Record]) -> Result<(), BenchError> {
    // Scenes by name alone when every run has one size, else with the size.
    let one_size = rows
        .iter()
        .all(|r| (r.width, r.height) == (rows[0].width, rows[0].height));
    let name = |r: &Record| match one_size {
        true => r.scene.clone(),
        false => format!("{} {}x{}", r.scene, r.width, r.height),
    };
    let mut scenes: Vec<String> = Vec::new();
    for r in rows {
        if !scenes.contains(&name(r)) {
            scenes.push(name(r));
        }
    }
    let pts: Vec<(usize, f64, &str)> = rows
        .iter()
        .filter_map(|r| {
            let x = scenes.iter().position(|t| *t == name(r))?;
            Some((x, super::floor::multiple(r)?, r.algo.as_str()))
        })
        .collect();
    let (lo, hi) = pts
        .iter()
        .fold((1.0f64, 10.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
    let (ylo, yhi) = (
        10f64.powf(lo.log10().floor()) * 0.999,
        10f64.powf(hi.log10().ceil()) * 1.001,
    );
    let mut algos: Vec<&str> = pts.iter().map(|p| p.2).collect();
    algos.sort_by_key(|a| algo_style(a).1);
    algos.dedup();
    let n = scenes.len().max(1);
    let size = match one_size {
        true => format!(", {}x{}", rows[0].width, rows[0].height),
        false => String::new(),
    };
    let whole = canvas(path, (1150, 650))?;
    let root = whole
        .titled(
            &format!("frame time as a multiple of the rasterization floor (one z-buffered draw of all triangles{size})"),
            ("sans-serif", 18),
        )
        .map_err(|e| err(path, e))?;
    let (plot, legend_area) = root.split_horizontally(880);
    let mut chart = ChartBuilder::on(&plot)
        .margin(15)
        .x_label_area_size(60)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..n as f64, (ylo..yhi).log_scale())
        .map_err(|e| err(path, e))?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .y_desc("frame time / floor (log)")
        .y_label_formatter(&|v| format!("{}×", tick(*v)))
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(|e| err(path, e))?;
    // The floor, and a light line between scenes.
    chart
        .draw_series(std::iter::once(PathElement::new(
            vec![(0.0, 1.0), (n as f64, 1.0)],
            BLACK.stroke_width(2),
        )))
        .map_err(|e| err(path, e))?;
    chart
        .draw_series(
            (1..n)
                .map(|i| PathElement::new(vec![(i as f64, ylo), (i as f64, yhi)], BLACK.mix(0.15))),
        )
        .map_err(|e| err(path, e))?;
    let centred = ("sans-serif", 13)
        .into_font()
        .into_text_style(&whole)
        .pos(Pos::new(HPos::Center, VPos::Top));
    for (i, s) in scenes.iter().enumerate() {
        // Every other name one line lower, so long neighbours never overlap.
        let (x, y) = chart.backend_coord(&(i as f64 + 0.5, ylo));
        let below = 8 + 18 * (i as i32 % 2);
        whole
            .draw(&Text::new(s.clone(), (x, y + below), centred.clone()))
            .map_err(|e| err(path, e))?;
    }
    let mut entries = Vec::new();
    for (k, &algo) in algos.iter().enumerate() {
        let (c, m) = algo_style(algo);
        // Each algorithm a little apart within its scene's column.
        let dx = 0.1 + 0.8 * (k as f64 + 0.5) / algos.len() as f64;
        let mine = pts.iter().filter(|p| p.2 == algo);
        with_marker!(m, c, |mk| chart
            .draw_series(mine.map(|p| mk((p.0 as f64 + dx, p.1))))
            .map(|_| ())
            .map_err(|e| err(path, e)))?;
        entries.push((Mark::Marker(m), c, algo.to_string()));
    }
    side_legend(&legend_area, path, "algorithm", &entries)?;
    root.present().map_err(|e| err(path, e))?;
    Ok(())
}

/// Stacked bars: for each algorithm (first depth set-up), the GPU ms of its
/// passes in one frame timed with a timestamp at every pass (a frame of its
/// own: its total is not the table's median frame).
fn pass_breakdown(path: &Path, title: &str, rows: &[&Record]) -> Result<(), BenchError> {
    let depth = rows[0].depth_setup.clone();
    let rows: Vec<&&Record> = rows
        .iter()
        .filter(|r| r.depth_setup == depth && r.per_pass.is_some())
        .collect();
    let mut pass_names: Vec<String> = Vec::new();
    let mut bars: Vec<(String, BTreeMap<String, f64>)> = Vec::new();
    for r in &rows {
        let mut m = BTreeMap::new();
        for p in r.per_pass.iter().flatten() {
            if !pass_names.contains(&p.name) {
                pass_names.push(p.name.clone());
            }
            *m.entry(p.name.clone()).or_insert(0.0) += p.gpu_ms;
        }
        bars.push((r.algo.clone(), m));
    }
    let ymax = bars
        .iter()
        .map(|(_, m)| m.values().sum::<f64>())
        .fold(0.0, f64::max)
        * 1.15
        + 1e-3;
    let n = bars.len().max(1);
    let whole = canvas(path, (1100, 650))?;
    let root = whole
        .titled(
            &format!("{title} (depth set-up {depth})"),
            ("sans-serif", 20),
        )
        .map_err(|e| err(path, e))?;
    let (plot, legend_area) = root.split_horizontally(820);
    let mut chart = ChartBuilder::on(&plot)
        .margin(15)
        .x_label_area_size(60)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..n as f64, 0.0..ymax)
        .map_err(|e| err(path, e))?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .y_desc("GPU ms in the timestamped frame")
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(|e| err(path, e))?;
    // Each bar: its total above it, its algorithm under the axis.
    let centred = |size: u32| {
        ("sans-serif", size)
            .into_font()
            .into_text_style(&whole)
            .pos(Pos::new(HPos::Center, VPos::Top))
    };
    for (i, (algo, m)) in bars.iter().enumerate() {
        let total: f64 = m.values().sum();
        let (x, y) = chart.backend_coord(&(i as f64 + 0.5, total));
        whole
            .draw(&Text::new(format!("{total:.1}"), (x, y - 20), centred(14)))
            .map_err(|e| err(path, e))?;
        // Every other name one line lower, so long neighbours never overlap.
        let (x, y) = chart.backend_coord(&(i as f64 + 0.5, 0.0));
        let below = 8 + 20 * (i as i32 % 2);
        whole
            .draw(&Text::new(algo.clone(), (x, y + below), centred(14)))
            .map_err(|e| err(path, e))?;
    }
    let mut entries = Vec::new();
    for (pi, pass) in pass_names.iter().enumerate() {
        let color = PALETTE[pi % PALETTE.len()];
        let rects: Vec<Rectangle<(f64, f64)>> = bars
            .iter()
            .enumerate()
            .map(|(i, (_, m))| {
                let below: f64 = pass_names[..pi]
                    .iter()
                    .map(|p| m.get(p).copied().unwrap_or(0.0))
                    .sum();
                let h = m.get(pass).copied().unwrap_or(0.0);
                Rectangle::new(
                    [(i as f64 + 0.15, below), (i as f64 + 0.85, below + h)],
                    color.filled(),
                )
            })
            .collect();
        chart.draw_series(rects).map_err(|e| err(path, e))?;
        entries.push((Mark::Swatch, color, pass.clone()));
    }
    // The first pass at the bottom of each bar: the legend lists top down.
    entries.reverse();
    side_legend(&legend_area, path, "pass (top of the bar first)", &entries)?;
    root.present().map_err(|e| err(path, e))?;
    Ok(())
}

/// Log-log lines: median frame ms against n, one line per algorithm (first
/// depth set-up), each with its own colour and marker.
fn scaling(path: &Path, title: &str, rows: &[&Record]) -> Result<(), BenchError> {
    let depth = rows[0].depth_setup.clone();
    let mut lines: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.depth_setup == depth) {
        let n = r.n.unwrap_or(r.prims as u32) as f64;
        lines
            .entry(r.algo.clone())
            .or_default()
            .push((n.max(1.0), r.frame_ms_median.max(1e-3)));
    }
    for v in lines.values_mut() {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let xs = lines.values().flatten().map(|p| p.0);
    let (xmin, xmax) = xs
        .clone()
        .fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
    let ys = lines.values().flatten().map(|p| p.1);
    let (ymin, ymax) = ys.fold((f64::INFINITY, 0.0f64), |(a, b), y| (a.min(y), b.max(y)));
    // Whole decades, at least two on each axis, so every axis has labelled ticks.
    let decades = |lo: f64, hi: f64| {
        let l = 10f64.powf(lo.log10().floor());
        // A hair wider, so rounding leaves the end decades' ticks inside.
        (
            l * 0.999,
            10f64.powf(hi.log10().ceil()).max(l * 100.0) * 1.001,
        )
    };
    let (x0, x1) = decades(xmin, xmax);
    let (y0, y1) = decades(ymin, ymax);
    let root = canvas(path, (1100, 650))?;
    let root = root
        .titled(
            &format!("{title} (depth set-up {depth})"),
            ("sans-serif", 20),
        )
        .map_err(|e| err(path, e))?;
    let (plot, legend_area) = root.split_horizontally(850);
    let mut chart = ChartBuilder::on(&plot)
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|e| err(path, e))?;
    chart
        .configure_mesh()
        .x_desc("n (primitives, log)")
        .y_desc("median frame ms (log)")
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(|e| err(path, e))?;
    let mut entries = Vec::new();
    let mut algos: Vec<&String> = lines.keys().collect();
    algos.sort_by_key(|a| algo_style(a).1);
    for algo in algos {
        let pts = &lines[algo];
        let (c, m) = algo_style(algo);
        chart
            .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
            .map_err(|e| err(path, e))?;
        with_marker!(m, c, |mk| chart
            .draw_series(pts.iter().map(|&(x, y)| mk((x, y))))
            .map(|_| ())
            .map_err(|e| err(path, e)))?;
        entries.push((Mark::Line(m), c, algo.clone()));
    }
    side_legend(&legend_area, path, "algorithm", &entries)?;
    root.present().map_err(|e| err(path, e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every algorithm and OpenCSG variant has a marker of its own and a
    /// colour of its own.
    #[test]
    fn each_variant_has_its_own_marker_and_colour() {
        let mut names: Vec<String> = ALGOS.iter().map(|a| a.to_string()).collect();
        for v in ["goldfeather", "scs", "automatic"] {
            names.push(format!("{}{v}", super::super::opencsg::PREFIX));
        }
        let styles: Vec<(RGBColor, usize)> = names.iter().map(|n| algo_style(n)).collect();
        for (i, a) in styles.iter().enumerate() {
            for (j, b) in styles.iter().enumerate().skip(i + 1) {
                assert_ne!(a.1, b.1, "{} and {} share a marker", names[i], names[j]);
                assert_ne!(a.0, b.0, "{} and {} share a colour", names[i], names[j]);
            }
        }
        assert!(styles.iter().all(|s| s.1 < 18), "18 markers");
    }

    #[test]
    fn log_ticks_read_short() {
        assert_eq!(tick(0.1 * 1.0000001), "0.1");
        assert_eq!(tick(1000.0), "1000");
        assert_eq!(tick(1e-5), "1e-5");
    }
}
