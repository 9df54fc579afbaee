//! The `peeltrim` command line (docs/cli.md): render, blist, compare, bench,
//! plan, view. `anyhow` lives here only; the library reports typed errors.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context as _, Result};
use clap::{Parser, Subcommand, ValueEnum};

use peeltrim::plan::Algo;
use peeltrim::scene::{self, LoadOptions};
use peeltrim_cli::bench::{self, families, BenchConfig, BenchScene};
use peeltrim_cli::render::{self, DepthSetup, RenderOptions};

#[derive(Parser)]
#[command(
    name = "peeltrim",
    version,
    about = "CSG rendering by depth peeling and trimming on Vulkan, with an exact CPU reference"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
    /// Memory the run may plan for, e.g. 2G or 512M (default: half of the smaller
    /// of the physical memory and `ulimit -v`); work estimated above it is
    /// refused at once with the estimate
    #[arg(long, global = true, value_parser = peeltrim::budget::parse_size)]
    memory_budget: Option<u64>,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum DeviceArg {
    Auto,
    Cpu,
    Gpu,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum DepthFormatArg {
    D24s8,
    D32s8,
}

#[derive(clap::Args, Clone)]
struct GpuArgs {
    /// auto: a hardware GPU when present, else lavapipe; cpu: lavapipe; gpu: hardware only
    #[arg(long, value_enum, default_value = "auto")]
    device: DeviceArg,
    /// Depth-stencil format of the GPU algorithms [default: d32s8 with reversed Z,
    /// or d24s8 where the device cannot use d32s8]
    #[arg(long, value_enum)]
    depth_format: Option<DepthFormatArg>,
    /// Reversed depth (near = 1) in a floating-point depth buffer: the default
    /// with d32s8 (kept for scripts)
    #[arg(long, conflicts_with = "standard_z")]
    reversed_z: bool,
    /// Standard depth (near = 0) instead of reversed in a d32s8 buffer
    #[arg(long)]
    standard_z: bool,
    /// Run with the Vulkan validation layers (always on in debug builds)
    #[arg(long)]
    validation: bool,
    /// Trickle's depth tolerance in normalized depth (default 2^-19): larger
    /// loses shallower features, smaller lets coincident faces z-fight
    #[arg(long, value_parser = parse_eps)]
    trickle_eps: Option<f32>,
    /// Goldfeather's and Trickle's limit on the sum-of-products size
    #[arg(long, default_value_t = peeltrim::plan::goldfeather::DEFAULT_PRODUCT_LIMIT)]
    max_products: usize,
    /// Samples per pixel (antialiasing): 1, 2, 4 or 8 where the device
    /// supports it; each sample is classified, colour averaged, depth.npy and
    /// prim.png from sample 0 [default: the scene's `[render] samples`, 1]
    #[arg(long, value_parser = parse_samples)]
    samples: Option<u32>,
}

fn parse_samples(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(n) if peeltrim::vk::SAMPLE_COUNTS.contains(&n) => Ok(n),
        _ => Err(format!("'{s}' is not a sample count: use 1, 2, 4 or 8")),
    }
}

/// Layers of the solid and transparency.
#[derive(clap::Args, Clone)]
struct LayerArgs {
    /// Peel at most N layers of the solid (N >= 1; default: all)
    #[arg(long, value_name = "N", value_parser = parse_layers, allow_hyphen_values = true)]
    layers: Option<u32>,
    /// Stop peeling at the first layer covering fewer than N pixels
    #[arg(long, value_name = "N", default_value_t = 0)]
    layer_threshold: u64,
    /// Also write each layer into OUT/layers/01/, 02/, ... (color.png, depth.npy, prim.png,
    /// normal.npy, edges.png)
    #[arg(long)]
    layers_out: bool,
    /// Opacity in (0, 1] of everything without its own alpha (overrides [render] alpha);
    /// color.png becomes the front-to-back composite of the layers
    #[arg(long, value_parser = parse_alpha)]
    alpha: Option<f64>,
    /// Draw the trimmed faces of these primitives in a highlight colour, see-through
    /// where hidden (comma-separated primitive names)
    #[arg(long, value_name = "NAME[,NAME]", value_delimiter = ',')]
    highlight: Vec<String>,
    // Kirsch, Nienhaus & Döllner §7.
    /// How a union of products is layered: `solid` (the union peeled as one
    /// volume; the reference's default) or `products` (each product peeled on
    /// its own, as kirsch does)
    #[arg(long, value_name = "solid|products", value_parser = parse_reading)]
    layer_reading: Option<peeltrim_reference::LayerReading>,
    /// Assemblies: solids semi-transparent, where two solids intersect opaque in
    /// red; stats.json lists the interfering pairs (same as [render] interference = true)
    #[arg(long)]
    interference: bool,
    // Kirsch, Nienhaus & Döllner §5.
    /// How color.png shows the layers (overrides [render] style): opaque,
    /// transparent, blueprint, wireframe or blueprint-transparent
    #[arg(long, value_parser = peeltrim::scene::style::parse_style)]
    style: Option<peeltrim::scene::style::Style>,
    /// Edge rule: a depth jump larger than this fraction of the nearer depth is a
    /// silhouette edge
    #[arg(long, value_name = "FRACTION", default_value_t = 0.01)]
    edge_depth: f64,
    /// Edge rule: normals further apart than this many degrees make a crease edge
    #[arg(long, value_name = "DEGREES", default_value_t = 30.0)]
    edge_angle: f64,
}

/// A usage error (a bad flag or value): exit status 2, as clap's own.
#[derive(Debug)]
struct Usage(String);

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// Returns a [`Usage`] error from the enclosing function.
macro_rules! usage {
    ($($t:tt)*) => {
        return Err(Usage(format!($($t)*)).into())
    };
}

/// `--algo`: one algorithm, or `auto` (picked per scene).
#[derive(Clone, Copy, Debug, PartialEq)]
enum AlgoArg {
    Auto,
    One(Algo),
}

impl AlgoArg {
    /// The algorithm: the one given, or auto's pick for `scene` (drawn in
    /// layers when `layered`), printed on stderr.
    fn resolve(
        self,
        scene: &scene::Scene,
        layered: bool,
        build: &peeltrim::plan::BuildOptions,
    ) -> (Algo, Option<peeltrim_cli::auto::AutoPick>) {
        match self {
            AlgoArg::One(a) => (a, None),
            AlgoArg::Auto => match peeltrim::plan::Prepared::new(scene) {
                Ok(prep) => {
                    let p = peeltrim_cli::auto::pick(
                        scene,
                        &prep,
                        scene.render.width,
                        scene.render.height,
                        layered,
                        build,
                    );
                    eprintln!("peeltrim: auto: {} ({})", p.picked, p.reason);
                    (p.algo(), Some(p))
                }
                // The scene cannot be prepared: CST-I reports why.
                Err(_) => (Algo::CstI, None),
            },
        }
    }
}

fn parse_algo_arg(s: &str) -> Result<AlgoArg, String> {
    if s == "auto" {
        return Ok(AlgoArg::Auto);
    }
    parse_algo(s).map(AlgoArg::One)
}

/// A whole number of at least 1, for `what`.
fn positive(s: &str, what: &str) -> Result<u32, String> {
    match s.trim().parse::<u64>() {
        Ok(n) if (1..=u32::MAX as u64).contains(&n) => Ok(n as u32),
        _ => Err(format!(
            "'{s}' is not a number of {what}: give a whole number of at least 1, e.g. 3"
        )),
    }
}

fn parse_layers(s: &str) -> Result<u32, String> {
    positive(s, "layers")
}

fn parse_frames(s: &str) -> Result<u32, String> {
    positive(s, "frames")
}

fn parse_reading(s: &str) -> Result<peeltrim_reference::LayerReading, String> {
    peeltrim_reference::LayerReading::parse(s)
        .ok_or_else(|| format!("unknown layer reading '{s}'; choose solid or products"))
}

/// `--highlight` names as 0-based primitive indices; an unknown name is an error
/// listing the scene's primitives.
fn highlight_indices(scene: &scene::Scene, names: &[String]) -> Result<Vec<u32>> {
    names
        .iter()
        .map(|n| {
            let n = n.trim();
            scene
                .primitives
                .iter()
                .position(|p| p.name == n)
                .map(|i| i as u32)
                .with_context(|| {
                    let all: Vec<&str> = scene.primitives.iter().map(|p| p.name.as_str()).collect();
                    format!(
                        "--highlight: the scene has no primitive named '{n}'; its primitives are: {}",
                        all.join(", ")
                    )
                })
        })
        .collect()
}

fn parse_alpha(s: &str) -> Result<f64, String> {
    let a: f64 = s
        .parse()
        .map_err(|_| format!("'{s}' is not an opacity: give a number in (0, 1], e.g. 0.4"))?;
    peeltrim::scene::appearance::check_alpha(a)
}

/// Options for OpenSCAD `.csg` models.
#[derive(clap::Args, Clone, Copy)]
struct ScadArgs {
    /// OpenSCAD models: drop nodes peeltrim cannot draw (text, offset,
    /// projection, Booleans below hull/minkowski/resize, ...) with a warning
    /// listing each, instead of failing
    #[arg(long)]
    skip_unsupported: bool,
}

fn parse_eps(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(e) if e.is_finite() && (0.0..0.1).contains(&e) => Ok(e),
        _ => Err(format!(
            "'{s}' is not a depth tolerance: give a number in [0, 0.1), e.g. 2e-6"
        )),
    }
}

#[derive(Subcommand)]
enum Cmd {
    /// Render a scene with one algorithm into color.png, depth.npy, prim.png, stats.json
    Render {
        /// The scene: a .toml scene file, an OpenSCAD model exported as .csg
        /// (File > Export > Export as CSG), or an OpenSCAD source .scad
        /// (exported by `openscad` into a cache)
        scene: PathBuf,
        /// The algorithm: auto (per scene, the one expected to be fastest among
        /// the speckle-free ones; stats.json says which and why), reference (the
        /// exact CPU ray caster), or a GPU algorithm: goldfeather,
        /// goldfeather-layered, trickle, blister, cst-z, cst-i, cst-g,
        /// blister-paper, kirsch, scs
        #[arg(long, default_value = "auto", value_parser = parse_algo_arg)]
        algo: AlgoArg,
        /// Image size WxH (overrides [render] width/height)
        #[arg(long, value_parser = parse_size, allow_hyphen_values = true)]
        size: Option<(u32, u32)>,
        /// The folder to write color.png, depth.npy, prim.png and stats.json into
        #[arg(long, default_value = "out")]
        out: PathBuf,
        #[command(flatten)]
        gpu: GpuArgs,
        #[command(flatten)]
        layers: LayerArgs,
        #[command(flatten)]
        scad: ScadArgs,
    },
    /// Print the Blist of an expression or of a scene's solid(s) as JSON
    Blist {
        /// An expression such as "(A+B)(C-(D-E))", or a scene file
        input: String,
        #[command(flatten)]
        scad: ScadArgs,
    },
    /// Compare two render output directories (depth.npy and prim.png)
    Compare {
        /// A folder `render` wrote
        a: PathBuf,
        /// Another folder `render` wrote, of the same size
        b: PathBuf,
    },
    /// Time algorithms on scenes (speed against error); writes results.json,
    /// results.csv, summary.md, plots/ and images/ into --out
    Bench {
        /// Scene files, .toml, OpenSCAD .csg or .scad (default: every scenes/*.toml and
        /// scenes/openscad/*.csg of the source tree)
        scenes: Vec<PathBuf>,
        /// Comma-separated algorithms, or "all"; the tables mark the row
        /// `--algo auto` would pick for each scene
        #[arg(long, default_value = "all")]
        algos: String,
        /// Image size WxH (overrides each scene's [render] size; default 400x400)
        #[arg(long, value_parser = parse_size, allow_hyphen_values = true)]
        size: Option<(u32, u32)>,
        /// Timed frames per run (after warm-up), at least 1
        #[arg(long, default_value = "10", value_parser = parse_frames, allow_hyphen_values = true)]
        frames: u32,
        /// Untimed warm-up frames per run
        #[arg(long, default_value_t = 1)]
        warmup: u32,
        /// A run whose warm-up frame takes longer than this many seconds is timed
        /// on one frame only
        #[arg(long, default_value_t = 20.0)]
        budget_s: f64,
        /// Skip a run whose frame the plan estimates (counts × lavapipe's costs) at
        /// more than this many seconds; reported as skipped with the estimate.
        /// 0 runs everything
        #[arg(long, default_value_t = bench::estimate::DEFAULT_MAX_EST_S)]
        max_est_s: f64,
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Run every depth set-up (d24s8, d32s8, d32s8 reversed) instead of the one the flags pick
        #[arg(long)]
        all_depths: bool,
        /// Scaling families to generate, e.g. "block-spheres:4,16,64" (repeatable);
        /// families: block-spheres, union-boxes, deep-tree, nonconvex-k
        #[arg(long = "family")]
        families: Vec<String>,
        /// Also time the layered modes (opaque, transparent, the blueprint styles, highlight) of CST-Z/I/G and kirsch with their layers and CSTs (modes.csv, modes.md)
        #[arg(long)]
        modes: bool,
        /// Add the numerical-stability hard cases (coincident faces, thin walls, grazing views, 1e7 near/far)
        #[arg(long)]
        hard: bool,
        /// Do not write each run's images
        #[arg(long)]
        no_images: bool,
        /// Also render each scene with a baseline renderer: "opencsg" (OpenCSG 1.5
        /// through tools/opencsg-bench, a separate program built by its build.sh)
        #[arg(long, value_parser = ["opencsg"])]
        baseline: Option<String>,
        /// The opencsg-bench program (default: $PEELTRIM_OPENCSG_BENCH, else
        /// tools/opencsg-bench/opencsg-bench)
        #[arg(long)]
        opencsg_bench: Option<PathBuf>,
        /// Do not give OpenCSG the primitives' screen boxes (as OpenSCAD; slower)
        #[arg(long)]
        opencsg_no_bbox: bool,
        /// Also time every GPU run through the embedding path (recorded into an
        /// off-screen host's frames): embedded_frame_ms_median and embedded_ratio
        #[arg(long)]
        embedded: bool,
        #[command(flatten)]
        gpu: GpuArgs,
    },
    /// Open a window showing the scene: drag orbits, wheel zooms, 1-9 switch
    /// algorithm (reference, goldfeather, goldfeather-layered, trickle, blister,
    /// cst-z, cst-i, cst-g, blister-paper), R resets the camera, S saves view.png, Esc/Q quit.
    /// PEELTRIM_VIEW_FRAMES=N renders N frames and exits.
    View {
        /// The scene: a .toml scene file, an OpenSCAD model exported as .csg
        /// (File > Export > Export as CSG), or an OpenSCAD source .scad
        /// (exported by `openscad` into a cache)
        scene: PathBuf,
        /// The algorithm: auto (per scene, the one expected to be fastest among
        /// the speckle-free ones; stats.json says which and why), reference (the
        /// exact CPU ray caster), or a GPU algorithm: goldfeather,
        /// goldfeather-layered, trickle, blister, cst-z, cst-i, cst-g,
        /// blister-paper, kirsch, scs
        #[arg(long, default_value = "auto", value_parser = parse_algo_arg)]
        algo: AlgoArg,
        /// Initial window size WxH (overrides [render] width/height)
        #[arg(long, value_parser = parse_size, allow_hyphen_values = true)]
        size: Option<(u32, u32)>,
        /// Reload the model when its file changes (a .scad file is exported
        /// again), keeping the camera; a model that fails to load leaves the
        /// last good picture and shows the error
        #[arg(long)]
        watch: bool,
        #[command(flatten)]
        gpu: GpuArgs,
        #[command(flatten)]
        scad: ScadArgs,
    },
    /// Print an algorithm's plan (the steps it records) for a scene
    Plan {
        /// The scene: a .toml scene file, an OpenSCAD model exported as .csg
        /// (File > Export > Export as CSG), or an OpenSCAD source .scad
        /// (exported by `openscad` into a cache)
        scene: PathBuf,
        /// The algorithm: auto (per scene, the one expected to be fastest among
        /// the speckle-free ones; stats.json says which and why), reference (the
        /// exact CPU ray caster), or a GPU algorithm: goldfeather,
        /// goldfeather-layered, trickle, blister, cst-z, cst-i, cst-g,
        /// blister-paper, kirsch, scs
        #[arg(long, default_value = "auto", value_parser = parse_algo_arg)]
        algo: AlgoArg,
        /// The device profile the plan passes decide for: "device" (the
        /// Vulkan device's own, PEELTRIM_DEVICE_PROFILE applied), "cpu" (a CPU
        /// rasterizer such as lavapipe: unsnapped depth) or "hardware" (a GPU
        /// that snaps vertices to 8 subpixel bits). The last two need no device.
        #[arg(long, value_name = "PROFILE", default_value = "device")]
        device_profile: String,
        #[command(flatten)]
        scad: ScadArgs,
    },
}

fn parse_algo(s: &str) -> Result<Algo, String> {
    Algo::parse(s).ok_or_else(|| {
        let names: Vec<&str> = Algo::ALL.iter().map(|a| a.name()).collect();
        format!(
            "unknown algorithm '{s}'; choose one of {}",
            names.join(", ")
        )
    })
}

/// `--algos`: a list (`auto` in it is dropped: every table marks auto's row).
fn parse_algos(s: &str) -> Result<Vec<Algo>> {
    if s.trim() == "all" {
        return Ok(Algo::ALL.to_vec());
    }
    let mut v = Vec::new();
    for a in s.split(',').map(str::trim).filter(|a| *a != "auto") {
        match parse_algo(a) {
            Ok(a) => v.push(a),
            Err(e) => usage!("--algos: {e}"),
        }
    }
    if v.is_empty() {
        usage!("--algos names no algorithm to run; e.g. --algos cst-i,blister");
    }
    Ok(v)
}

/// "block-spheres:4,16,64" -> ("block-spheres", [4, 16, 64])
fn parse_family(s: &str) -> Result<(String, Vec<u32>)> {
    let (name, ns) = s.split_once(':').unwrap_or((s, "4,16,64"));
    let ns = ns
        .split(',')
        .map(|n| {
            n.trim()
                .parse::<u32>()
                .ok()
                .filter(|&n| n >= 1 && n <= 65536)
        })
        .collect::<Option<Vec<u32>>>()
        .ok_or_else(|| {
            Usage(format!(
                "--family '{s}': sizes must be positive integers, e.g. block-spheres:4,16,64"
            ))
        })?;
    Ok((name.to_string(), ns))
}

/// The shipped scenes (`scenes/*.toml`, then `scenes/openscad/*.csg`) next to the
/// binary's source tree, or under ./scenes.
fn shipped_scenes() -> Result<Vec<PathBuf>> {
    let dir = [
        PathBuf::from("scenes"),
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/..")).join("scenes"),
    ]
    .into_iter()
    .find(|d| d.is_dir())
    .context("no scene given and no scenes/ directory here: pass scene files")?;
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    v.sort();
    // The OpenSCAD models, loaded as they are.
    if let Ok(models) = std::fs::read_dir(dir.join("openscad")) {
        let mut m: Vec<PathBuf> = models
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "csg"))
            .collect();
        m.sort();
        v.extend(m);
    }
    Ok(v)
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let err = || format!("size '{s}' is not WxH with positive integers, e.g. 800x600");
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(err)?;
    let (w, h): (u32, u32) = (
        w.trim().parse().map_err(|_| err())?,
        h.trim().parse().map_err(|_| err())?,
    );
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("size '{s}' must be between 1x1 and 16384x16384"));
    }
    Ok((w, h))
}

fn render_options(algo: Algo, g: &GpuArgs) -> Result<RenderOptions> {
    // Reversed Z unless asked otherwise; only the default falls back to d24s8.
    let depth = match (g.depth_format, g.reversed_z) {
        (Some(DepthFormatArg::D24s8), true) => {
            usage!("--reversed-z needs a floating-point depth buffer: use --depth-format d32s8")
        }
        (Some(DepthFormatArg::D24s8), false) => DepthSetup::D24S8,
        (_, _) if g.standard_z => DepthSetup::D32S8,
        (_, _) => DepthSetup::D32S8Reversed,
    };
    let device = match g.device {
        DeviceArg::Auto => peeltrim::vk::DeviceChoice::Auto,
        DeviceArg::Cpu => peeltrim::vk::DeviceChoice::Cpu,
        DeviceArg::Gpu => peeltrim::vk::DeviceChoice::Gpu,
    };
    if g.max_products == 0 {
        usage!("--max-products must be at least 1");
    }
    let mut build = peeltrim::plan::BuildOptions {
        trickle_eps: g.trickle_eps,
        ..Default::default()
    };
    build.products.limit = g.max_products;
    Ok(RenderOptions {
        algo,
        device,
        depth,
        depth_fallback: g.depth_format.is_none(),
        validation: g.validation || cfg!(debug_assertions),
        build,
    })
}

fn load(path: &Path, size: Option<(u32, u32)>, scad: ScadArgs) -> Result<scene::Scene> {
    load_shown(path, size, scad, false)
}

/// [`load`]; with `background`, an OpenSCAD model's `%` parts are drawn
/// (see-through, by an algorithm that draws transparency).
fn load_shown(
    path: &Path,
    size: Option<(u32, u32)>,
    scad: ScadArgs,
    background: bool,
) -> Result<scene::Scene> {
    let csg = peeltrim_cli::scad::csg_for(path).map_err(anyhow::Error::msg)?;
    let mut scene = scene::load_with(&csg, &LoadOptions { size }, scad.skip_unsupported)?;
    if background {
        scene::openscad::background::show(&mut scene);
    }
    for w in &scene.warnings {
        eprintln!("peeltrim: warning: {w}");
    }
    Ok(scene)
}

fn run(cli: Cli) -> Result<ExitCode> {
    if let Some(bytes) = cli.memory_budget {
        peeltrim::budget::set(bytes);
    }
    match cli.cmd {
        Cmd::Render {
            scene,
            algo,
            size,
            out,
            gpu,
            layers,
            scad,
        } => {
            let mut opts = render_options(Algo::Reference, &gpu)?;
            peeltrim_cli::output::check_out_dir(&out, "--out")?;
            let background = match algo {
                AlgoArg::Auto => true,
                AlgoArg::One(a) => render::layers::draws_transparency(a),
            };
            let mut scene = load_shown(&scene, size, scad, background)?;
            if let Some(n) = gpu.samples {
                scene.render.samples = n;
            }
            if layers.alpha.is_some() {
                scene.appearance.alpha = layers.alpha;
            }
            scene.appearance.interference |= layers.interference;
            if let Some(style) = layers.style {
                scene.appearance.style = style;
            }
            let edge_rule = render::edges::EdgeRule {
                depth_rel: layers.edge_depth,
                angle_deg: layers.edge_angle,
            }
            .check()
            .map_err(anyhow::Error::msg)?;
            let lopts = render::layers::LayerOptions {
                edge_rule,
                max_layers: layers.layers,
                threshold: layers.layer_threshold,
                write_layers: layers.layers_out,
                highlight: highlight_indices(&scene, &layers.highlight)?,
                reading: layers.layer_reading,
            };
            let (algo, auto) = algo.resolve(&scene, lopts.wanted(&scene), &opts.build);
            opts.algo = algo;
            if lopts.wanted(&scene) && scene.appearance.light.is_some() {
                eprintln!("peeltrim: warning: [light] is ignored with layers, transparency, highlight or interference: shadows are drawn on opaque renders");
            }
            if let Ok(prep) = peeltrim::plan::Prepared::new(&scene) {
                for w in prep.warnings(opts.algo) {
                    eprintln!("peeltrim: warning: {w}");
                }
            }
            let (mut frame, layer_images) = match if lopts.wanted(&scene) {
                render::layers::render_layered(&scene, &opts, &lopts)
                    .map(|l| (l.frame.clone(), Some(l)))
            } else {
                render::render(&scene, &opts).map(|f| (f, None))
            } {
                Err(
                    e @ (render::RenderError::Plan(peeltrim::plan::PlanError::NotImplemented(_))
                    | render::RenderError::Unsupported { .. }
                    | render::RenderError::Multisampled(_)),
                ) => {
                    eprintln!("peeltrim: error: {e}");
                    return Ok(ExitCode::from(2));
                }
                r => r?,
            };
            frame.stats.auto = auto;
            if frame.images.prim.iter().all(|&p| p == 0) {
                eprintln!("{}", empty_image_warning(&scene));
            }
            if let (true, Some(l)) = (lopts.write_layers, &layer_images) {
                render::layers::write_layers(&out, l)
                    .with_context(|| format!("writing layers into {}", out.display()))?;
            }
            peeltrim_cli::output::write_images(&out, &frame.images)
                .with_context(|| format!("writing images into {}", out.display()))?;
            peeltrim_cli::output::write_stats(&out, &frame.stats)
                .with_context(|| format!("writing stats.json into {}", out.display()))?;
            let coverage_png = out.join("coverage.png");
            match &frame.coverage {
                Some(c) => peeltrim_cli::output::write_coverage(
                    &out,
                    frame.images.width,
                    frame.images.height,
                    c,
                )
                .with_context(|| format!("writing coverage.png into {}", out.display()))?,
                // A single-sample render leaves no stale coverage beside it.
                None if coverage_png.exists() => std::fs::remove_file(&coverage_png)
                    .with_context(|| format!("removing {}", coverage_png.display()))?,
                None => {}
            }
            eprintln!(
                "{}: {}x{} with {} in {:.1} ms (gpu {:.2} ms) -> {}",
                scene.path.display(),
                frame.images.width,
                frame.images.height,
                algo,
                frame.stats.exec.cpu_ms,
                frame.stats.exec.gpu_ms,
                out.display()
            );
        }
        Cmd::Blist { input, scad } => {
            let json = blist_json(&input, scad)?;
            emit(&format!("{}\n", serde_json::to_string_pretty(&json)?))?;
        }
        Cmd::Compare { a, b } => {
            let ia = peeltrim_cli::output::read_images(&a)?;
            let ib = peeltrim_cli::output::read_images(&b)?;
            let report = peeltrim_reference::compare::compare(&ia, &ib)?;
            /// `compare`'s output: the metrics of docs/cli.md, and with an
            /// `edges.png` in both folders (layer folders) the edge maps' agreement.
            #[derive(serde::Serialize)]
            struct Out {
                #[serde(flatten)]
                report: peeltrim_reference::compare::CompareReport,
                #[serde(skip_serializing_if = "Option::is_none")]
                edges: Option<peeltrim_reference::edge_compare::EdgeAgreement>,
                /// With a `coverage.png` in both folders (multisampled
                /// renders): coverage fractions and resolved colours.
                #[serde(skip_serializing_if = "Option::is_none")]
                samples: Option<peeltrim_reference::compare::SampleReport>,
            }
            let edges = if a.join("edges.png").exists() && b.join("edges.png").exists() {
                let (w, h, ea) = peeltrim_cli::output::read_edges(&a)?;
                let (wb, hb, eb) = peeltrim_cli::output::read_edges(&b)?;
                if (w, h) != (wb, hb) {
                    bail!("edges.png sizes differ: {w}x{h} against {wb}x{hb}");
                }
                Some(peeltrim_reference::edge_compare::compare_edges(
                    &ea, &eb, w, h,
                ))
            } else {
                None
            };
            let cov = (
                peeltrim_cli::output::read_coverage(&a)?,
                peeltrim_cli::output::read_coverage(&b)?,
            );
            let samples = match cov {
                (Some((_, _, ca)), Some((_, _, cb))) => Some(
                    peeltrim_reference::compare::compare_samples(&ia, &ca, &ib, &cb)?,
                ),
                (Some(_), None) | (None, Some(_)) => bail!(
                    "only one folder has a coverage.png: compare two renders with the same --samples"
                ),
                (None, None) => None,
            };
            let out = Out {
                report,
                edges,
                samples,
            };
            emit(&format!("{}\n", serde_json::to_string_pretty(&out)?))?;
        }
        Cmd::Bench {
            scenes,
            algos,
            size,
            frames,
            warmup,
            budget_s,
            max_est_s,
            out,
            all_depths,
            families,
            hard,
            modes,
            no_images,
            baseline,
            opencsg_bench,
            opencsg_no_bbox,
            embedded,
            gpu,
        } => {
            let algos = parse_algos(&algos)?;
            let opts = render_options(Algo::Reference, &gpu)?;
            peeltrim_cli::output::check_out_dir(&out, "--out")?;
            let mut list: Vec<BenchScene> = Vec::new();
            let scene_files = if scenes.is_empty() && families.is_empty() && !hard {
                shipped_scenes()?
            } else {
                scenes
            };
            list.extend(scene_files.into_iter().map(|path| BenchScene {
                path,
                family: None,
                n: None,
            }));
            let gen_dir = out.join("scenes");
            for f in &families {
                let (name, ns) = parse_family(f)?;
                list.extend(families::generate(&name, &ns, &gen_dir)?);
            }
            if hard {
                list.extend(families::generate_hard(&gen_dir)?);
            }
            let cfg = BenchConfig {
                algos,
                sizes: vec![size.unwrap_or((400, 400))],
                depth_setups: if all_depths {
                    DepthSetup::ALL.to_vec()
                } else {
                    vec![opts.depth]
                },
                depth_fallback: opts.depth_fallback && !all_depths,
                frames,
                warmup,
                budget_ms: budget_s * 1e3,
                max_est_s,
                device: opts.device,
                validation: opts.validation,
                build: opts.build.clone(),
                out: out.clone(),
                save_images: !no_images,
                progress: true,
                baseline: baseline.map(|_| {
                    bench::opencsg::OpenCsgBaseline::locate(opencsg_bench, !opencsg_no_bbox)
                }),
                embedded,
                samples: gpu.samples,
            };
            let records = bench::run_and_report(&cfg, &list)?;
            emit(&bench::report::summary(&records))?;
            if modes {
                let m = bench::layer_modes::run(&cfg, &list)?;
                bench::layer_modes::write(&out, &m)?;
                emit(&bench::layer_modes::table(&m))?;
            }
            eprintln!(
                "results in {}/ (results.json, results.csv, summary.md, plots/, images/)",
                out.display()
            );
        }
        Cmd::View {
            scene,
            algo,
            size,
            watch,
            gpu,
            scad,
        } => return view(&scene, algo, size, watch, &gpu, scad),
        Cmd::Plan {
            scene,
            algo,
            device_profile,
            scad,
        } => {
            let scene = load(&scene, None, scad)?;
            let (algo, _) = algo.resolve(&scene, false, &Default::default());
            let prep = peeltrim::plan::Prepared::new(&scene)?;
            for w in prep.warnings(algo) {
                eprintln!("peeltrim: warning: {w}");
            }
            if algo == Algo::Reference {
                usage!("the reference ray caster has no GPU plan; choose a GPU algorithm or auto");
            }
            let plan = match peeltrim::plan::build(algo, &prep) {
                Err(e @ peeltrim::plan::PlanError::NotImplemented(_)) => {
                    eprintln!("peeltrim: error: {e}");
                    return Ok(ExitCode::from(2));
                }
                r => r?,
            };
            let profile = plan_profile(&device_profile)?;
            let mut text = peeltrim::plan::print::print(&plan, &prep, &scene.mesh_names());
            text.push_str(&print_passes(&plan, &scene, &profile));
            emit(&text)?;
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// The profile `peeltrim plan --device-profile` names.
fn plan_profile(name: &str) -> Result<peeltrim::vk::DeviceProfile> {
    use peeltrim::vk::profile::{DepthFormats, DeviceFacts, ProfileChoice};
    let facts = |cpu| DeviceFacts {
        cpu,
        unsnapped_depth: cpu,
        subpixel_bits: 8,
        depth_formats: DepthFormats {
            d32s8: true,
            d24s8: true,
            d32: true,
        },
        sample_depth: true,
    };
    Ok(match name {
        "cpu" => peeltrim::vk::DeviceProfile::from_facts(facts(true), ProfileChoice::Device),
        "hardware" => peeltrim::vk::DeviceProfile::from_facts(facts(false), ProfileChoice::Device),
        "device" => {
            let ctx = peeltrim::vk::Context::new(&peeltrim::vk::ContextDesc {
                device: peeltrim::vk::DeviceChoice::Auto,
                validation: false,
            })?;
            *ctx.profile()
        }
        other => usage!("--device-profile '{other}': use device, cpu or hardware"),
    })
}

/// The plan passes' result (`plan::passes`): each draw as it is recorded
/// under `profile` with the default depth set-up (D32S8, reversed Z), and
/// what each clear and copy reaches.
fn print_passes(
    plan: &peeltrim::plan::Plan,
    scene: &peeltrim::scene::Scene,
    profile: &peeltrim::vk::DeviceProfile,
) -> String {
    use std::fmt::Write as _;
    let facts = profile.pass_facts(peeltrim::vk::DepthFormat::D32S8);
    let (w, h) = (scene.render.width, scene.render.height);
    let lowered = peeltrim::plan::passes::lower_plan(plan, scene, w, h, true, &facts);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "\n# After the plan passes: {:?} profile, {} subpixel bits, depth-equal shades {}, {w}x{h}, D32S8 reversed\n",
        profile.kind,
        facts.subpixel_bits,
        if facts.depth_equal_shades { "on" } else { "off" },
    );
    let mut pass = None;
    for d in &lowered {
        if pass != Some(&d.pass) {
            let _ = writeln!(out, "{}", d.pass);
            pass = Some(&d.pass);
        }
        let kind = match d.kind {
            peeltrim::plan::passes::StepKind::Draw => "draw ",
            peeltrim::plan::passes::StepKind::Clear => "clear",
            peeltrim::plan::passes::StepKind::Copy => "copy ",
        };
        let _ = writeln!(out, "  {kind} {:3}: {}", d.index, d.recorded);
    }
    out
}

#[cfg(feature = "viewer")]
fn view(
    path: &Path,
    algo: AlgoArg,
    size: Option<(u32, u32)>,
    watch: bool,
    gpu: &GpuArgs,
    scad: ScadArgs,
) -> Result<ExitCode> {
    let opts = render_options(Algo::Reference, gpu)?;
    // No display at all: say so before loading anything.
    if ["DISPLAY", "WAYLAND_DISPLAY"]
        .iter()
        .all(|k| std::env::var_os(k).is_none_or(|v| v.is_empty()))
    {
        return Err(peeltrim_cli::viewer::ViewerError::NoDisplay(
            peeltrim_cli::viewer::display_vars(),
        )
        .into());
    }
    let scene = load(path, size, scad)?;
    let (algo, _) = algo.resolve(&scene, false, &opts.build);
    let frames = match std::env::var("PEELTRIM_VIEW_FRAMES") {
        Ok(v) => Some(
            v.trim()
                .parse::<u32>()
                .ok()
                .filter(|&n| n > 0)
                .context("PEELTRIM_VIEW_FRAMES must be a positive integer")?,
        ),
        Err(_) => None,
    };
    let watch = watch.then(|| {
        peeltrim_cli::watch::Watch::new(
            path,
            Box::new(move |p: &Path| load(p, size, scad).map_err(|e| format!("{e:#}"))),
        )
    });
    peeltrim_cli::viewer::run(
        scene,
        peeltrim_cli::viewer::ViewOptions {
            algo,
            device: opts.device,
            depth: opts.depth,
            depth_fallback: opts.depth_fallback,
            validation: opts.validation,
            frames,
            samples: gpu.samples,
        },
        watch,
    )?;
    Ok(ExitCode::SUCCESS)
}

#[cfg(not(feature = "viewer"))]
fn view(
    path: &Path,
    _algo: AlgoArg,
    size: Option<(u32, u32)>,
    _watch: bool,
    _gpu: &GpuArgs,
    scad: ScadArgs,
) -> Result<ExitCode> {
    load(path, size, scad)?;
    eprintln!(
        "peeltrim: error: this build has no viewer (built without the `viewer` feature); \
         rebuild with `cargo build --features viewer` (on by default), or use \
         `peeltrim render` and open color.png"
    );
    Ok(ExitCode::from(2))
}

/// `blist EXPR` names its own primitives; `blist SCENE.toml` uses the scene's.
fn blist_json(input: &str, scad: ScadArgs) -> Result<serde_json::Value> {
    use peeltrim::csg::{Blist, PositiveExpr};
    let path = Path::new(input);
    let (expr, names) = if input.ends_with(".toml")
        || input.ends_with(".csg")
        || input.ends_with(".scad")
        || path.is_file()
    {
        let scene = load(path, None, scad)?;
        let expr = peeltrim::plan::union_of_solids(&scene)
            .with_context(|| format!("{}: the scene has no [csg] or [[solid]]", path.display()))?;
        (
            expr,
            scene
                .primitives
                .iter()
                .map(|p| p.name.clone())
                .collect::<Vec<_>>(),
        )
    } else {
        let mut names: Vec<String> = Vec::new();
        let expr = peeltrim::csg::parse(input, &mut |n: &str| {
            Some(match names.iter().position(|x| x == n) {
                Some(i) => i as u32,
                None => {
                    names.push(n.to_string());
                    names.len() as u32 - 1
                }
            })
        })
        .map_err(|e| anyhow::anyhow!("{e}"))?;
        (expr, names)
    };
    let positive = PositiveExpr::from_expr(&expr);
    if !positive.is_bounded() {
        eprintln!(
            "peeltrim: warning: the expression is unbounded (a scene would refuse it as a solid)"
        );
    }
    let blist = Blist::new(&positive);
    Ok(blist.to_json(&names))
}

/// The error and its causes, skipping a cause whose text the message already
/// carries (the library's errors name their source in their own message).
fn chain(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if !out.contains(&text) {
            if !out.is_empty() {
                out.push_str(": ");
            }
            out.push_str(&text);
        }
    }
    out
}

/// Writes a command's result to standard output. A reader that closed the pipe
/// early (`peeltrim plan … | head`) has all it wanted: that is not an error, and
/// must not become the panic `print!` would raise.
fn emit(text: &str) -> std::io::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        r => r,
    }
}

/// The warning for an image with nothing in it: whether the camera sees none
/// of the scene's meshes, or sees them and the solid is empty there.
fn empty_image_warning(scene: &scene::Scene) -> String {
    let seen = peeltrim::plan::Prepared::new(scene).is_ok_and(|prep| {
        let c = peeltrim_cli::bench::estimate::SceneCosts::new(
            scene,
            &prep,
            scene.render.width,
            scene.render.height,
        );
        let all: Vec<u32> = (0..(scene.primitives.len() + scene.surfaces.len()) as u32).collect();
        c.layers(&all) > 0
    });
    if seen {
        "peeltrim: warning: the image is empty: the camera sees the primitives but the solid \
         has nothing there (check the expression, e.g. a difference that removes everything)"
            .into()
    } else {
        "peeltrim: warning: the image is empty: nothing of the scene is in view of the camera; \
         check the [camera] eye, target and fov, or leave [camera] out to fit it to the scene"
            .into()
    }
}

/// clap's error in this program's voice: `peeltrim: error: ...` and exit 2
/// for a usage error; help and version go to stdout with exit 0.
fn clap_exit(e: clap::Error) -> ExitCode {
    use clap::error::ErrorKind;
    match e.kind() {
        ErrorKind::DisplayHelp | ErrorKind::DisplayVersion => {
            let _ = e.print();
            ExitCode::SUCCESS
        }
        _ => {
            let text = e.render().to_string();
            let text = text.trim_end();
            let text = text.strip_prefix("error: ").unwrap_or(text);
            eprintln!("peeltrim: error: {text}");
            ExitCode::from(2)
        }
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => return clap_exit(e),
    };
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("peeltrim: error: {}", chain(&e));
            if e.downcast_ref::<Usage>().is_some() {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}
