//! `peeltrim view`: a window showing one algorithm's render of a scene (feature
//! `viewer`). Drag orbits the camera around its target, the wheel zooms, keys
//! `1`..`8` switch algorithm (the command line's order), `R` resets the camera,
//! `S` saves `view.png`, `Esc`/`Q` quit. A frame is rendered only when something
//! changed; the window title shows scene, algorithm, median GPU time and draws.
//!
//! The viewer is the second host of the embedding API (docs/embedding.md; the
//! first is `examples/embed.rs`): a [`CsgScene`] made from the loaded scene
//! records peeltrim's CSG into each swapchain frame, through
//! [`peeltrim::vk::present::Presenter::present_recorded`], with
//! [`present::FRAMES_IN_FLIGHT`] frames in flight; orbiting only moves the
//! camera ([`CsgScene::set_camera`], no upload). The CPU reference's images are
//! copied to the window instead. `PEELTRIM_VIEW_FRAMES=N` renders N frames
//! (orbiting a little between them) and exits: a smoke test for machines with a
//! display.
//!
//! With `--watch` ([`crate::watch`]) a saved model is reloaded and re-planned
//! with the camera kept; stderr prints the time from the save to the new
//! frame. A model that fails to load leaves the last good picture, with the
//! error on stderr and in the window title. `PEELTRIM_VIEW_RELOADS=N` exits
//! after N reloads (for scripted measurements).
#![deny(unsafe_code)]

use std::collections::VecDeque;
use std::path::PathBuf;

use glam::{DQuat, DVec3};
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use crate::output::Images;
use crate::render::{self, DepthSetup, RenderError};
use peeltrim::embed::{CsgScene, EmbedDesc, EmbedError, LoopCounts};
use peeltrim::plan::Algo;
use peeltrim::scene::{fit, Camera, Projection, Scene};
use peeltrim::vk::{self, present, present::Presented, present::Presenter};

/// Radians of orbit per pixel dragged.
pub const ORBIT_RAD_PER_PX: f64 = 0.01;
/// Elevation limit of the orbit (radians from the plane normal to `up`), so the
/// view direction never becomes parallel to `up`.
pub const MAX_ELEVATION: f64 = 89.0 * std::f64::consts::PI / 180.0;
/// Distance factor per wheel notch.
pub const ZOOM_PER_STEP: f64 = 0.85;
/// Frame times kept for the title's median.
const TIMES_KEPT: usize = 9;

/// The algorithm of digit key `c`, in the command line's order (`'1'` =
/// reference … `'8'` = cst-g, `'9'` = blister-paper).
pub fn algo_for_key(c: char) -> Option<Algo> {
    let i = c.to_digit(10)? as usize;
    Algo::ALL.get(i.checked_sub(1)?).copied()
}

/// The eye after dragging `(dx, dy)` pixels: yaw about `up` and elevation change
/// around `target`, distance kept, elevation clamped to ±[`MAX_ELEVATION`].
/// Dragging right turns the scene right; dragging down shows it from higher up.
pub fn orbit(cam: &Camera, dx: f64, dy: f64) -> DVec3 {
    let up = cam.up.normalize();
    let off = cam.eye - cam.target;
    let r = off.length();
    if r == 0.0 || !r.is_finite() {
        return cam.eye;
    }
    let off = DQuat::from_axis_angle(up, -dx * ORBIT_RAD_PER_PX) * off;
    let along = off.dot(up) / r;
    let elevation = (along.clamp(-1.0, 1.0).asin() + dy * ORBIT_RAD_PER_PX)
        .clamp(-MAX_ELEVATION, MAX_ELEVATION);
    let horizontal = off - up * off.dot(up);
    let h = if horizontal.length() > 1e-12 * r {
        horizontal.normalize()
    } else {
        // Looking along `up`: any horizontal direction will do.
        up.any_orthonormal_vector()
    };
    cam.target + r * (h * elevation.cos() + up * elevation.sin())
}

/// Zooms by `steps` wheel notches (positive: closer): the eye moves along the view
/// direction (an orthographic view also narrows). Returns the new camera without
/// near/far (see [`refit`]).
pub fn zoom(cam: &Camera, steps: f64) -> Camera {
    let mut c = *cam;
    let factor = ZOOM_PER_STEP.powf(steps);
    let off = cam.eye - cam.target;
    let r = off.length();
    let new_r = (r * factor).max(1e-9);
    if r > 0.0 && new_r.is_finite() {
        c.eye = cam.target + off * (new_r / r);
    }
    if let Projection::Orthographic { height } = &mut c.projection {
        let h = *height * factor;
        if h.is_finite() && h > 0.0 {
            *height = h;
        }
    }
    c
}

/// Near and far planes for the scene's current camera (always automatic).
pub fn refit(scene: &mut Scene) {
    let drawn = scene
        .primitives
        .iter()
        .filter(|p| p.used)
        .map(|p| &p.mesh)
        .chain(scene.surfaces.iter().map(|s| &s.mesh));
    let (n, f) = fit::near_far(&scene.camera, drawn, None, None);
    if n.is_finite() && f.is_finite() && n < f {
        scene.camera.near = n;
        scene.camera.far = f;
    }
}

/// Median of the values (0 for none).
pub fn median(values: impl IntoIterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.into_iter().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        (v[m - 1] + v[m]) * 0.5
    }
}

#[derive(Clone, Debug)]
pub struct ViewOptions {
    pub algo: Algo,
    pub device: vk::DeviceChoice,
    pub depth: DepthSetup,
    /// Fall back to D24S8 where the device cannot use `depth`'s D32S8 (no
    /// `--depth-format` given), as `render` does.
    pub depth_fallback: bool,
    pub validation: bool,
    /// Render this many frames and exit (`PEELTRIM_VIEW_FRAMES`); `None`: interactive.
    pub frames: Option<u32>,
    /// Samples per pixel of the CSG's frames (`--samples`); `None`: 4 where
    /// the device supports it and the scene has no light (shadows are
    /// composited single-sample), else 1.
    pub samples: Option<u32>,
}

#[derive(Debug, thiserror::Error)]
pub enum ViewerError {
    #[error("cannot open a window: {0} (is DISPLAY or WAYLAND_DISPLAY set?)")]
    Window(String),
    /// No display to open a window on (no X server or Wayland compositor).
    #[error("view opens a window and found no display to open it on ({0}); write images with `peeltrim render` instead, or run `xvfb-run peeltrim view ...` for scripted use")]
    NoDisplay(String),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Vk(#[from] vk::VkError),
    #[error(transparent)]
    Embed(#[from] EmbedError),
    #[error("saving {path}: {message}")]
    Save { path: PathBuf, message: String },
}

/// The device, window surface and the embedded CSG. Field order is drop order.
struct Gpu {
    csg: Option<CsgScene>,
    /// With a `[light]`: what the shadow pass's parameters need (the map and
    /// the pass live in the CSG's embedder).
    light: Option<render::shadow::LightView>,
    presenter: Presenter,
    ctx: vk::Context,
}

impl Drop for Gpu {
    fn drop(&mut self) {
        // The CSG's images go first: no frame may still use them. A failed wait
        // (a lost device) leaves nothing pending either.
        let _ = self.presenter.wait_frames();
    }
}

struct App {
    // Dropped before the window whose surface it presents to.
    gpu: Option<Gpu>,
    window: Option<Window>,
    scene: Scene,
    home: Camera,
    opts: ViewOptions,
    algo: Algo,
    /// The reference's images; `None` while the GPU algorithms are shown.
    last: Option<Images>,
    /// CPU time of the last frames (recording and submission; the GPU runs
    /// behind, `FRAMES_IN_FLIGHT` frames deep).
    frame_ms: VecDeque<f64>,
    /// The algorithm whose plan failed (shown once, not retried every frame).
    failed: Option<Algo>,
    cpu_ms: f64,
    draws: u64,
    dirty: bool,
    dragging: bool,
    cursor: Option<(f64, f64)>,
    frames_left: Option<u32>,
    error: Option<ViewerError>,
    /// `--watch`: the model file, polled.
    watch: Option<crate::watch::Watch>,
    /// The last reload's error, shown in the title until a good one.
    load_error: Option<String>,
    /// A reloaded scene's save time and load time, until its frame is shown.
    reloaded: Option<(std::time::SystemTime, f64)>,
    /// `PEELTRIM_VIEW_RELOADS`: exit after this many more reloads.
    reloads_left: Option<u32>,
}

/// The display variables as set, for the no-display message.
pub fn display_vars() -> String {
    let var = |k: &str| match std::env::var(k) {
        Ok(v) if !v.is_empty() => format!("{k}={v}"),
        _ => format!("{k} unset"),
    };
    format!("{}, {}", var("DISPLAY"), var("WAYLAND_DISPLAY"))
}

/// Opens the window and runs until it is closed.
pub fn run(
    scene: Scene,
    opts: ViewOptions,
    watch: Option<crate::watch::Watch>,
) -> Result<(), ViewerError> {
    // winit's error names its own source file, which tells a user nothing.
    let event_loop = EventLoop::new().map_err(|_| ViewerError::NoDisplay(display_vars()))?;
    event_loop.set_control_flow(ControlFlow::Wait);
    let mut app = App {
        gpu: None,
        window: None,
        home: scene.camera,
        scene,
        algo: opts.algo,
        frames_left: opts.frames,
        opts,
        last: None,
        frame_ms: VecDeque::new(),
        failed: None,
        cpu_ms: 0.0,
        draws: 0,
        dirty: true,
        dragging: false,
        cursor: None,
        error: None,
        watch,
        load_error: None,
        reloaded: None,
        reloads_left: std::env::var("PEELTRIM_VIEW_RELOADS")
            .ok()
            .and_then(|v| v.trim().parse().ok()),
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| ViewerError::Window(e.to_string()))?;
    // Release the swapchain before the window goes.
    app.gpu = None;
    app.window = None;
    match app.error.take() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

impl App {
    fn open(&mut self, el: &ActiveEventLoop) -> Result<(), ViewerError> {
        let size = PhysicalSize::new(self.scene.render.width, self.scene.render.height);
        let attrs = Window::default_attributes()
            .with_title(self.title())
            .with_inner_size(size);
        let window = el
            .create_window(attrs)
            .map_err(|e| ViewerError::Window(e.to_string()))?;
        let display = window
            .display_handle()
            .map_err(|e| ViewerError::Window(e.to_string()))?
            .as_raw();
        let handle = window
            .window_handle()
            .map_err(|e| ViewerError::Window(e.to_string()))?
            .as_raw();
        let inner = window.inner_size();
        let desc = vk::ContextDesc {
            device: self.opts.device,
            validation: self.opts.validation,
        };
        let (ctx, mut presenter) =
            Presenter::new(&desc, display, handle, [inner.width, inner.height])?;
        let lit = self.scene.appearance.light.is_some();
        let samples = match self.opts.samples {
            Some(n) => {
                ctx.check_samples(n)?;
                if n > 1 && lit {
                    return Err(vk::VkError::Unsupported(format!(
                        "{n} samples per pixel with the scene's [light]: shadows are \
                         composited single-sample; use --samples 1"
                    ))
                    .into());
                }
                n
            }
            None if !lit && ctx.supported_samples().contains(&4) => 4,
            None => 1,
        };
        presenter.set_samples(samples);
        let (depth, why) = self.opts.depth.resolve_on(&ctx, self.opts.depth_fallback);
        if let Some(why) = why {
            eprintln!("peeltrim: warning: {why}");
        }
        self.opts.depth = depth;
        eprintln!(
            "peeltrim view: {} on {}, {samples} sample(s) per pixel",
            self.scene.path.display(),
            ctx.device_name()
        );
        self.gpu = Some(Gpu {
            csg: None,
            light: None,
            presenter,
            ctx,
        });
        self.set_size(inner.width, inner.height);
        window.request_redraw();
        self.window = Some(window);
        Ok(())
    }

    fn set_size(&mut self, w: u32, h: u32) {
        if w > 0 && h > 0 && [w, h] != [self.scene.render.width, self.scene.render.height] {
            self.scene.render.width = w;
            self.scene.render.height = h;
            self.dirty = true;
        }
    }

    fn title(&self) -> String {
        let name = self.scene.name.as_deref().unwrap_or("scene");
        let time = if self.algo == Algo::Reference {
            format!("{:.0} ms CPU", self.cpu_ms)
        } else {
            format!(
                "{:.2} ms/frame CPU, {} draws",
                median(self.frame_ms.iter().copied()),
                self.draws
            )
        };
        if let Some(e) = &self.load_error {
            let first = e.lines().next().unwrap_or("");
            return format!("peeltrim: {name} | ERROR (last good picture shown): {first}");
        }
        format!(
            "peeltrim: {name} | {} | {time} | {}x{}",
            self.algo, self.scene.render.width, self.scene.render.height
        )
    }

    /// `--watch`: reloads a changed model, keeping the camera and window size.
    fn poll_watch(&mut self, el: &ActiveEventLoop) -> Result<(), ViewerError> {
        let Some(r) = self.watch.as_mut().and_then(|w| w.poll()) else {
            return Ok(());
        };
        match r.result {
            Ok(mut scene) => {
                scene.camera = self.scene.camera;
                (scene.render.width, scene.render.height) =
                    (self.scene.render.width, self.scene.render.height);
                self.home = scene.camera;
                self.scene = scene;
                if let Some(gpu) = self.gpu.as_mut() {
                    // A new plan: no frame in flight may use the old images.
                    gpu.presenter.wait_frames()?;
                    gpu.csg = None;
                    gpu.light = None;
                }
                self.last = None;
                self.failed = None;
                self.load_error = None;
                self.reloaded = Some((r.saved, r.load_ms));
                self.changed();
            }
            Err(e) => {
                eprintln!("peeltrim view: reload failed (the last good picture stays): {e}");
                self.load_error = Some(e);
                if let Some(w) = &self.window {
                    w.set_title(&self.title());
                }
                self.count_reload(el);
            }
        }
        Ok(())
    }

    /// `PEELTRIM_VIEW_RELOADS`: one reload done.
    fn count_reload(&mut self, el: &ActiveEventLoop) {
        if let Some(n) = self.reloads_left {
            let n = n.saturating_sub(1);
            self.reloads_left = Some(n);
            if n == 0 {
                el.exit();
            }
        }
    }

    /// Shows the CPU reference's image of the current state.
    fn show_reference(&mut self, size: [u32; 2]) -> Result<Presented, ViewerError> {
        if self.dirty || self.last.is_none() {
            let mut f = render::render_reference(&self.scene);
            if let Some(light) = &self.scene.appearance.light {
                let (w, h) = (f.images.width, f.images.height);
                let rays = peeltrim_reference::shadow::shadow_rays(&self.scene, light, w, h);
                render::shadow::apply(&mut f.images.color, &rays, light);
            }
            self.cpu_ms = f.stats.exec.cpu_ms;
            self.last = Some(f.images);
        }
        let (Some(gpu), Some(img)) = (self.gpu.as_mut(), &self.last) else {
            return Ok(Presented::Skipped);
        };
        Ok(gpu
            .presenter
            .present(img, self.scene.render.background, size)?)
    }

    /// Records the CSG into the next swapchain frame, as an embedding host does.
    fn show_csg(&mut self, size: [u32; 2]) -> Result<Presented, ViewerError> {
        self.last = None;
        let (_, reversed_z) = self.opts.depth.exec_format();
        let Some(gpu) = self.gpu.as_mut() else {
            return Ok(Presented::Skipped);
        };
        let extent = gpu.presenter.extent();
        if extent[0] == 0 || extent[1] == 0 {
            return Ok(Presented::Skipped);
        }
        let fits = gpu.csg.as_ref().is_some_and(|c| c.extent() == extent);
        let mut attach = false;
        if fits {
            let csg = gpu.csg.as_mut().expect("fits");
            if csg.algo() != self.algo {
                gpu.presenter.wait_frames()?;
                csg.set_algo(self.algo)?;
                attach = true;
            }
            // Orbit and zoom: the camera only (no upload); a new plan's images
            // may replace those the frames in flight use, so wait for them then.
            if csg.set_camera(&self.scene.camera)? {
                gpu.presenter.wait_frames()?;
            }
        } else {
            // New size (or first frame): a new scene at the swapchain's size.
            gpu.presenter.wait_frames()?;
            gpu.csg = None;
            let desc = EmbedDesc {
                extent,
                reversed_z,
                frames_in_flight: present::FRAMES_IN_FLIGHT,
                algo: self.algo,
                loop_counts: LoopCounts::Estimate,
                internal_depth: self.opts.depth.exec_format().0,
                samples: gpu.presenter.samples(),
            };
            gpu.csg = Some(CsgScene::from_scene(&gpu.ctx, &self.scene, &desc)?);
            attach = true;
        }
        if attach {
            self.attach_shadows(extent)?;
        }
        let Some(gpu) = self.gpu.as_mut() else {
            return Ok(Presented::Skipped);
        };
        let csg = gpu.csg.as_mut().expect("made above");
        // The light is world-fixed: its map stays; the pass follows the camera.
        if let (Some(lv), Some(sh)) = (&gpu.light, csg.recorder().shadow_mut()) {
            sh.params = lv.params(&self.scene.camera, (extent[0], extent[1]));
        }
        // A multisampled frame draws only the direct path: say so before
        // acquiring a frame, rather than fail inside it.
        let ms = gpu.presenter.samples();
        if ms > 1 && csg.recorder().next_host_path() != Some(vk::embed::HostPath::Direct) {
            return Err(vk::VkError::Unsupported(format!(
                "its plan is composited single-sample (no final shade into the \
                 host's targets), and the view runs {ms} samples per pixel: \
                 use --samples 1"
            ))
            .into());
        }
        let far = if reversed_z { 0.0 } else { 1.0 };
        let bg = self.scene.render.background;
        let start = std::time::Instant::now();
        let (shown, stats) = gpu
            .presenter
            .present_recorded(bg, far, size, csg.recorder())?;
        match stats {
            Some(st) => {
                self.draws = st.counts.draws;
                self.frame_ms.push_back(start.elapsed().as_secs_f64() * 1e3);
                while self.frame_ms.len() > TIMES_KEPT {
                    self.frame_ms.pop_front();
                }
            }
            None if shown == Presented::Shown => {
                // Drawn without the CSG (size change): draw again.
                self.dirty = true;
                return Ok(Presented::Skipped);
            }
            None => {}
        }
        Ok(shown)
    }

    /// With a `[light]`: the light's map rendered once for the current
    /// algorithm (the light does not move with the camera) and the shadow pass
    /// handed to the CSG's embedder, which then records it after every frame.
    /// Called with no frame of the CSG pending.
    fn attach_shadows(&mut self, extent: [u32; 2]) -> Result<(), ViewerError> {
        let (Some(light), Some(gpu)) = (&self.scene.appearance.light, self.gpu.as_mut()) else {
            return Ok(());
        };
        let Some(csg) = gpu.csg.as_mut() else {
            return Ok(());
        };
        let mut sized = self.scene.clone();
        (sized.render.width, sized.render.height) = (extent[0], extent[1]);
        let view = render::shadow::embed_shadows(
            csg.recorder(),
            &gpu.ctx,
            self.opts.depth,
            &sized,
            light,
            self.algo,
        )?;
        gpu.light = Some(view);
        Ok(())
    }

    fn redraw(&mut self, el: &ActiveEventLoop) -> Result<(), ViewerError> {
        let rendered = self.dirty;
        let size = self
            .window
            .as_ref()
            .map(|w| w.inner_size())
            .unwrap_or_default();
        let size = [size.width, size.height];
        let shown = if self.algo == Algo::Reference {
            self.show_reference(size)?
        } else if self.failed == Some(self.algo) {
            Presented::Shown
        } else {
            match self.show_csg(size) {
                Ok(s) => s,
                // An algorithm this frame cannot draw (a plan it cannot make,
                // or the composite path at several samples per pixel).
                Err(ViewerError::Vk(e @ vk::VkError::Unsupported(_))) => {
                    eprintln!(
                        "peeltrim: warning: {} cannot draw this scene: {e}",
                        self.algo
                    );
                    self.failed = Some(self.algo);
                    Presented::Shown
                }
                Err(ViewerError::Embed(e @ (EmbedError::Plan(_) | EmbedError::Algo(_)))) => {
                    eprintln!(
                        "peeltrim: warning: {} cannot draw this scene: {e}",
                        self.algo
                    );
                    self.failed = Some(self.algo);
                    Presented::Shown
                }
                Err(e) => return Err(e),
            }
        };
        if shown == Presented::Skipped {
            if let Some(w) = &self.window {
                w.request_redraw();
            }
            return Ok(());
        }
        self.dirty = false;
        if rendered {
            if let Some(w) = &self.window {
                w.set_title(&self.title());
            }
            if let Some((saved, load_ms)) = self.reloaded.take() {
                let path = self.watch.as_ref().map(|w| w.path().to_path_buf());
                eprintln!(
                    "peeltrim view: reloaded {}: {:.0} ms from save to new frame ({load_ms:.0} ms of it loading)",
                    path.unwrap_or_else(|| self.scene.path.clone()).display(),
                    crate::watch::ms_since(saved)
                );
                self.count_reload(el);
            }
            if let Some(n) = self.frames_left {
                eprintln!("peeltrim view: frame: {}", self.title());
                let n = n.saturating_sub(1);
                self.frames_left = Some(n);
                if n == 0 {
                    el.exit();
                } else {
                    // Smoke mode: orbit a little and render again.
                    self.scene.camera.eye = orbit(&self.scene.camera, 20.0, 0.0);
                    refit(&mut self.scene);
                    self.changed();
                }
            }
        }
        Ok(())
    }

    fn changed(&mut self) {
        self.dirty = true;
        if let Some(w) = &self.window {
            w.request_redraw();
        }
    }

    fn save(&mut self) -> Result<(), ViewerError> {
        let path = PathBuf::from("view.png");
        // A GPU frame is read back only now, when its pixels are wanted: the CSG
        // images of the last recorded frame, once every frame completed.
        let gpu_img = match (&self.last, self.gpu.as_mut()) {
            (None, Some(gpu)) => match gpu.csg.as_mut() {
                Some(csg) => {
                    gpu.presenter.wait_frames()?;
                    Some(csg.recorder().read_back()?)
                }
                None => None,
            },
            _ => None,
        };
        let Some(img) = self.last.as_ref().or(gpu_img.as_ref()) else {
            return Ok(());
        };
        let bytes: Vec<u8> = img.color.iter().flatten().copied().collect();
        image::save_buffer(
            &path,
            &bytes,
            img.width,
            img.height,
            image::ExtendedColorType::Rgba8,
        )
        .map_err(|e| ViewerError::Save {
            path: path.clone(),
            message: e.to_string(),
        })?;
        eprintln!("peeltrim view: saved {}", path.display());
        Ok(())
    }

    fn key(&mut self, el: &ActiveEventLoop, key: &Key) -> Result<(), ViewerError> {
        match key {
            Key::Named(NamedKey::Escape) => el.exit(),
            Key::Character(s) => {
                let Some(c) = s.chars().next() else {
                    return Ok(());
                };
                match c.to_ascii_lowercase() {
                    'q' => el.exit(),
                    'r' => {
                        self.scene.camera = self.home;
                        self.changed();
                    }
                    's' => self.save()?,
                    c => {
                        if let Some(a) = algo_for_key(c) {
                            if a != self.algo {
                                self.algo = a;
                                self.frame_ms.clear();
                                self.changed();
                            }
                        }
                    }
                }
            }
            _ => {}
        }
        Ok(())
    }

    fn event(&mut self, el: &ActiveEventLoop, event: WindowEvent) -> Result<(), ViewerError> {
        match event {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::Resized(size) => {
                if let Some(gpu) = self.gpu.as_mut() {
                    gpu.presenter.resized();
                }
                self.set_size(size.width, size.height);
                if let Some(w) = &self.window {
                    w.request_redraw();
                }
            }
            WindowEvent::RedrawRequested => self.redraw(el)?,
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                self.key(el, &event.logical_key)?
            }
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Left,
                ..
            } => self.dragging = state == ElementState::Pressed,
            WindowEvent::CursorMoved { position, .. } => {
                let p = (position.x, position.y);
                if let (true, Some(c)) = (self.dragging, self.cursor) {
                    let (dx, dy) = (p.0 - c.0, p.1 - c.1);
                    if dx != 0.0 || dy != 0.0 {
                        self.scene.camera.eye = orbit(&self.scene.camera, dx, dy);
                        refit(&mut self.scene);
                        self.changed();
                    }
                }
                self.cursor = Some(p);
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y as f64,
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                if steps != 0.0 {
                    self.scene.camera = zoom(&self.scene.camera, steps);
                    refit(&mut self.scene);
                    self.changed();
                }
            }
            _ => {}
        }
        Ok(())
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        if let Err(e) = self.open(el) {
            self.error = Some(e);
            el.exit();
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        if let Err(e) = self.event(el, event) {
            self.error = Some(e);
            el.exit();
        }
    }

    fn about_to_wait(&mut self, el: &ActiveEventLoop) {
        if self.watch.is_none() || self.window.is_none() {
            return;
        }
        if let Err(e) = self.poll_watch(el) {
            self.error = Some(e);
            el.exit();
        }
        el.set_control_flow(ControlFlow::WaitUntil(
            std::time::Instant::now() + crate::watch::POLL,
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera {
            eye: DVec3::new(2.5, 4.0, 5.0),
            target: DVec3::new(0.5, -1.0, 0.0),
            up: DVec3::Y,
            projection: Projection::Perspective { fov_y_deg: 40.0 },
            near: 1.0,
            far: 10.0,
        }
    }

    #[test]
    fn keys_follow_the_command_line_order() {
        let got: Vec<Algo> = ('1'..='9').filter_map(algo_for_key).collect();
        // kirsch, the tenth, has no key.
        assert_eq!(got, Algo::ALL[..9].to_vec());
        assert_eq!(algo_for_key('7'), Algo::parse("cst-i"));
        assert_eq!(algo_for_key('9'), Algo::parse("blister-paper"));
        assert_eq!(algo_for_key('0'), None);
        assert_eq!(algo_for_key('x'), None);
    }

    #[test]
    fn orbit_keeps_distance_and_target() {
        let c = cam();
        let r = (c.eye - c.target).length();
        for (dx, dy) in [(10.0, 0.0), (0.0, 25.0), (-300.0, 80.0), (5000.0, -5000.0)] {
            let e = orbit(&c, dx, dy);
            assert!(((e - c.target).length() - r).abs() < 1e-9 * r, "{dx} {dy}");
        }
        // No motion, no change.
        assert!((orbit(&c, 0.0, 0.0) - c.eye).length() < 1e-9);
    }

    #[test]
    fn horizontal_drag_keeps_height_and_vertical_drag_clamps() {
        let c = cam();
        let e = orbit(&c, 100.0, 0.0);
        assert!((e.y - c.eye.y).abs() < 1e-9);
        assert!((e - c.eye).length() > 0.1);
        // Dragging down a lot: just short of straight above, never over the pole.
        let e = orbit(&c, 0.0, 1e4);
        let el = ((e - c.target).normalize().dot(DVec3::Y)).asin();
        assert!((el - MAX_ELEVATION).abs() < 1e-9);
        let e = orbit(&c, 0.0, -1e4);
        let el = ((e - c.target).normalize().dot(DVec3::Y)).asin();
        assert!((el + MAX_ELEVATION).abs() < 1e-9);
        // Dragging down raises the eye.
        assert!(orbit(&c, 0.0, 10.0).y > c.eye.y);
    }

    #[test]
    fn zoom_moves_along_the_view_direction() {
        let c = cam();
        let z = zoom(&c, 1.0);
        let r0 = (c.eye - c.target).length();
        let r1 = (z.eye - z.target).length();
        assert!((r1 - r0 * ZOOM_PER_STEP).abs() < 1e-9);
        assert!((z.forward() - c.forward()).length() < 1e-12);
        let back = zoom(&z, -1.0);
        assert!((back.eye - c.eye).length() < 1e-9);
        let mut o = c;
        o.projection = Projection::Orthographic { height: 4.0 };
        match zoom(&o, 2.0).projection {
            Projection::Orthographic { height } => {
                assert!((height - 4.0 * ZOOM_PER_STEP * ZOOM_PER_STEP).abs() < 1e-12)
            }
            p => panic!("{p:?}"),
        }
    }

    #[test]
    fn median_of_odd_even_and_empty() {
        assert_eq!(median([3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median([4.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(median([]), 0.0);
    }
}
