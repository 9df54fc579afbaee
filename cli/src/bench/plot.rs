//! PNG plots of benchmark results (plotters, bitmap backend): time against error
//! per scene, time against the number of primitives for the scaling families,
//! and per-pass time breakdowns. Text uses DejaVu Sans (Debian's
//! fonts-dejavu-core, installed by tools/setup.sh).
#![deny(unsafe_code)]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

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

/// The chart of a one-panel plot on `root`: captioned with the title and the
/// depth set-up, room for both axes' labels.
fn one_panel<'a, 'b>(
    root: &'a DrawingArea<BitMapBackend<'b>, Shift>,
    title: &str,
    depth: &str,
) -> ChartBuilder<'a, 'b, BitMapBackend<'b>> {
    let mut chart = ChartBuilder::on(root);
    chart
        .caption(format!("{title} ({depth})"), ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70);
    chart
}

/// Draws `chart`'s series labels at `at` on a translucent white box.
fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    path: &Path,
    at: SeriesLabelPosition,
) -> Result<(), BenchError> {
    chart
        .configure_series_labels()
        .position(at)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(path, e))
}

const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(23, 190, 207),
    RGBColor(188, 189, 34),
];

fn algo_color(algo: &str) -> RGBColor {
    let order = [
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
    ];
    PALETTE[order.iter().position(|a| *a == algo).unwrap_or(7)]
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
        time_vs_error(&p, &format!("{scene} {w}x{h}: GPU time vs error"), &rows)?;
        files.push(p);
        let p = dir.join(format!("passes_{scene}_{w}x{h}.png"));
        pass_breakdown(&p, &format!("{scene} {w}x{h}: GPU time per pass"), &rows)?;
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
            &format!("{fam}: GPU time vs number of primitives"),
            &rows,
        )?;
        files.push(p);
    }
    Ok(files)
}

/// Marker of a depth set-up in the time-vs-error plot (colour is the algorithm).
fn depth_marker<DB: DrawingBackend, C: Clone + 'static>(
    depth: &str,
    at: C,
    color: RGBColor,
) -> DynElement<'static, DB, C> {
    match depth {
        "d24s8" => Circle::new(at, 5, color.filled()).into_dyn(),
        "d32s8" => TriangleMarker::new(at, 7, color.filled()).into_dyn(),
        _ => Cross::new(at, 6, color.stroke_width(2)).into_dyn(),
    }
}

/// A percentage for an axis label: `10%`, `0.5%`, `1e-3%`.
fn percent(v: f64) -> String {
    if v >= 1.0 {
        format!("{v:.0}%")
    } else if v >= 0.01 {
        format!(
            "{}%",
            format!("{v:.2}")
                .trim_end_matches('0')
                .trim_end_matches('.')
        )
    } else {
        format!("{v:.0e}%")
    }
}

/// x: median GPU ms; y: interior coverage + primitive mismatches (% of pixels) on
/// a log scale (whole decades), with exact results (error 0, which a log axis
/// cannot show) in a strip of their own below it. A legend beside the plot
/// (colour: algorithm, marker: depth set-up) instead of a label at each point,
/// which overlapped.
fn time_vs_error(path: &Path, title: &str, rows: &[&Record]) -> Result<(), BenchError> {
    let pts: Vec<(f64, f64, &str, &str)> = rows
        .iter()
        .map(|r| {
            let (c, p, _) = error_figures(r);
            let e = (c.max(0.0) + p.max(0.0)) * 100.0;
            (
                r.gpu_ms_median,
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
        (lo, 10f64.powf(ymax.log10().ceil()).max(lo * 10.0))
    } else {
        (1e-3, 1.0)
    };
    let mut series: Vec<(&str, &str)> = pts.iter().map(|p| (p.2, p.3)).collect();
    series.sort();
    series.dedup();
    let root = canvas(path, (1150, 650))?;
    let root = root
        .titled(title, ("sans-serif", 22))
        .map_err(|e| err(path, e))?;
    let (plot, legend) = root.split_horizontally(900);
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
        .y_desc("interior coverage + primitive mismatches (% of pixels, log)")
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
        .x_desc("median GPU time per frame (ms; OpenCSG: wall time)")
        .draw()
        .map_err(|e| err(path, e))?;
    for (i, &(algo, depth)) in series.iter().enumerate() {
        // OpenCSG's rows (a baseline, timed by wall clock) are black.
        let c = if algo.starts_with(super::opencsg::PREFIX) {
            BLACK
        } else {
            algo_color(algo)
        };
        let mine = || pts.iter().filter(move |p| p.2 == algo && p.3 == depth);
        zero.draw_series(
            mine()
                .filter(|p| p.1 == 0.0)
                .map(|p| depth_marker(depth, (p.0, 0.0), c)),
        )
        .map_err(|e| err(path, e))?;
        chart
            .draw_series(
                mine()
                    .filter(|p| p.1 > 0.0)
                    .map(|p| depth_marker(depth, (p.0, p.1), c)),
            )
            .map_err(|e| err(path, e))?;
        let y = 40 + 20 * i as i32;
        legend
            .draw(&depth_marker(depth, (12, y), c))
            .map_err(|e| err(path, e))?;
        legend
            .draw(&Text::new(
                format!("{algo} {depth}"),
                (26, y - 7),
                ("sans-serif", 14).into_font(),
            ))
            .map_err(|e| err(path, e))?;
    }
    root.present().map_err(|e| err(path, e))?;
    Ok(())
}

/// Stacked bars: for each algorithm (first depth set-up), its passes' GPU ms.
fn pass_breakdown(path: &Path, title: &str, rows: &[&Record]) -> Result<(), BenchError> {
    let depth = rows[0].depth_setup.clone();
    let rows: Vec<&&Record> = rows.iter().filter(|r| r.depth_setup == depth).collect();
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
        * 1.2
        + 1e-3;
    let n = bars.len().max(1);
    let root = canvas(path, (900, 600))?;
    let mut chart = one_panel(&root, title, &depth)
        .build_cartesian_2d(0.0..n as f64, 0.0..ymax)
        .map_err(|e| err(path, e))?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .disable_x_axis()
        .y_desc("GPU ms (median frame)")
        .draw()
        .map_err(|e| err(path, e))?;
    // Each bar is labelled with its algorithm and total above it.
    for (i, (algo, m)) in bars.iter().enumerate() {
        let total: f64 = m.values().sum();
        chart
            .draw_series(std::iter::once(Text::new(
                format!("{algo} ({total:.1})"),
                (i as f64 + 0.15, total + ymax * 0.03),
                ("sans-serif", 15).into_font(),
            )))
            .map_err(|e| err(path, e))?;
    }
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
        chart
            .draw_series(rects)
            .map_err(|e| err(path, e))?
            .label(pass.clone())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 10, y + 5)], color.filled()));
    }
    legend(&mut chart, path, SeriesLabelPosition::MiddleRight)?;
    root.present().map_err(|e| err(path, e))?;
    Ok(())
}

/// Log-log lines: median GPU ms against n, one line per algorithm (first depth set-up).
fn scaling(path: &Path, title: &str, rows: &[&Record]) -> Result<(), BenchError> {
    let depth = rows[0].depth_setup.clone();
    let mut lines: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.depth_setup == depth) {
        let n = r.n.unwrap_or(r.prims as u32) as f64;
        lines
            .entry(r.algo.clone())
            .or_default()
            .push((n.max(1.0), r.gpu_ms_median.max(1e-3)));
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
    let root = canvas(path, (900, 600))?;
    let mut chart = one_panel(&root, title, &depth)
        .build_cartesian_2d(
            (xmin * 0.8..xmax * 1.25).log_scale(),
            (ymin * 0.8..ymax * 1.25).log_scale(),
        )
        .map_err(|e| err(path, e))?;
    chart
        .configure_mesh()
        .x_desc("n (primitives)")
        .y_desc("median GPU ms per frame")
        .draw()
        .map_err(|e| err(path, e))?;
    for (algo, pts) in &lines {
        let c = algo_color(algo);
        chart
            .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
            .map_err(|e| err(path, e))?
            .label(algo.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
        chart
            .draw_series(pts.iter().map(|&(x, y)| Circle::new((x, y), 3, c.filled())))
            .map_err(|e| err(path, e))?;
    }
    legend(&mut chart, path, SeriesLabelPosition::UpperLeft)?;
    root.present().map_err(|e| err(path, e))?;
    Ok(())
}
