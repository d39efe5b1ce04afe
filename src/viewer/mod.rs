//! `pathlight view`: a window (winit + a wgpu surface) showing a render session converge.
//!
//! * Work per frame is bounded: each frame adds the next sample to a band of rows sized to
//!   about [`FRAME_WORK_SECONDS`] from the measured cost of a row, so the window answers
//!   input even on lavapipe, where one sample of a 512² image takes over a second.
//! * The GPU backend's accumulation buffer is drawn in place by the display pass; the CPU
//!   backend's film is uploaded at most every [`UPLOAD_INTERVAL`].
//! * Keys: `+`/`-` exposure, `T` tone map (clamp, ACES, false-colour relative error), `D`
//!   shows the denoised image (made again every [`DENOISE_INTERVAL`] while the film
//!   converges), `S` saves EXR and PNG, `R` restarts, `Esc` quits. Left drag orbits, right or middle drag
//!   pans, the wheel dollies; each restarts the accumulation.
//! * `--frames N` renders N whole passes (N samples per pixel, one per frame, for tests
//!   and pictures), writes `--screenshot` and the outputs, and exits.

mod display;
pub mod orbit;

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use crate::error::{Error, Result};
use crate::film::{predicted_relmse, LinearImage, Tonemap};
use crate::gpu::GpuContext;
use crate::scene::layout::{DISPLAY_ACES, DISPLAY_CLAMP, DISPLAY_RELATIVE_ERROR};
use crate::session::{Session, SessionOptions};
use display::Display;
use orbit::Orbit;

/// Rendering work per frame (seconds): about 30 frames a second with the display pass.
pub const FRAME_WORK_SECONDS: f64 = 0.03;
/// The CPU backend's film is uploaded for display at most this often.
pub const UPLOAD_INTERVAL: Duration = Duration::from_millis(100);
/// The denoised view is made again at most this often while the film converges: denoising a
/// 512² image takes about 0.4 s on this VM's two cores (`bench/RESULTS.md`, "Denoising").
pub const DENOISE_INTERVAL: Duration = Duration::from_secs(2);
/// The title's statistics (and the predicted error, which reads the film) refresh this often.
const TITLE_INTERVAL: Duration = Duration::from_millis(500);

/// What `view` was asked to do.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    pub session: SessionOptions,
    /// Stop accumulating once the relMSE predicted from the film's variance reaches this.
    pub target_error: Option<f64>,
    /// Render this many whole passes, save, and exit.
    pub frames: Option<u32>,
    /// Where `--frames` saves what the window shows (PNG).
    pub screenshot: Option<PathBuf>,
    /// Images written on exit (and by `S`; without any, `S` writes `pathlight-view.exr` and
    /// `.png` in the working folder).
    pub outputs: Vec<PathBuf>,
    pub exposure: f32,
    /// The starting tone map (`DISPLAY_*`).
    pub tonemap: u32,
    /// Start by showing the denoised image (`D` toggles it), made by `denoiser`; the session
    /// must make AOVs available (`SessionOptions::aovs_available`).
    pub show_denoised: bool,
    pub denoiser: crate::denoise::Denoiser,
}

/// Opens the window and runs until it is closed (or `--frames` are done).
pub fn run(options: ViewOptions) -> Result<()> {
    if let Some(path) = &options.screenshot {
        crate::film::check_writable(path)?;
    }
    for o in &options.outputs {
        crate::film::check_writable(o)?;
    }
    let event_loop = EventLoop::new().map_err(|e| Error::Settings(format!("cannot open a window: {e}")))?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App { options, state: None, error: None };
    event_loop
        .run_app(&mut app)
        .map_err(|e| Error::Settings(format!("the window's event loop failed: {e}")))?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

struct App {
    options: ViewOptions,
    state: Option<State>,
    error: Option<Error>,
}

struct State {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    ctx: Arc<GpuContext>,
    session: Session,
    display: Display,
    /// The CPU backend's film on the device, and when it was last uploaded.
    upload: Option<(wgpu::Buffer, Instant)>,
    orbit: Orbit,
    /// Next row of the pass in progress, and the measured seconds per row.
    next_row: u32,
    row_seconds: Option<f64>,
    frames: u32,
    exposure: f32,
    tonemap: u32,
    drag: Option<(MouseButton, (f64, f64))>,
    cursor: (f64, f64),
    title_at: Instant,
    predicted: Option<f64>,
    /// Accumulation stopped (--spp or --target-error reached).
    converged: bool,
    saves: u32,
    /// `D`: the denoised image is shown, from this buffer (a `FilmPixel` per pixel, the
    /// denoised value as its mean), made at the sample count and time it records.
    show_denoised: bool,
    denoiser: crate::denoise::Denoiser,
    denoised: Option<(wgpu::Buffer, u32, Instant)>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.state.is_some() {
            return;
        }
        match State::new(event_loop, &self.options) {
            Ok(s) => self.state = Some(s),
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(state) = self.state.as_mut() else { return };
        let result = match event {
            WindowEvent::CloseRequested => {
                event_loop.exit();
                state.write_outputs(&self.options)
            }
            WindowEvent::Resized(size) => state.resize(size.width, size.height),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                match event.logical_key.as_ref() {
                    Key::Named(NamedKey::Escape) => {
                        event_loop.exit();
                        state.write_outputs(&self.options)
                    }
                    Key::Character("+") | Key::Character("=") => {
                        state.exposure += 0.5;
                        Ok(())
                    }
                    Key::Character("-") | Key::Character("_") => {
                        state.exposure -= 0.5;
                        Ok(())
                    }
                    Key::Character(c) if c.eq_ignore_ascii_case("t") => {
                        state.tonemap = match state.tonemap {
                            DISPLAY_CLAMP => DISPLAY_ACES,
                            DISPLAY_ACES => DISPLAY_RELATIVE_ERROR,
                            _ => DISPLAY_CLAMP,
                        };
                        Ok(())
                    }
                    Key::Character(c) if c.eq_ignore_ascii_case("d") => {
                        state.show_denoised = !state.show_denoised;
                        Ok(())
                    }
                    Key::Character(c) if c.eq_ignore_ascii_case("r") => state.restart(),
                    Key::Character(c) if c.eq_ignore_ascii_case("s") => state.save(&self.options),
                    _ => Ok(()),
                }
            }
            WindowEvent::MouseInput { state: pressed, button, .. } => {
                state.drag = (pressed == ElementState::Pressed).then_some((button, state.cursor));
                Ok(())
            }
            WindowEvent::CursorMoved { position, .. } => {
                state.cursor = (position.x, position.y);
                match state.drag {
                    Some((button, last)) => {
                        let (dx, dy) = (position.x - last.0, position.y - last.1);
                        state.drag = Some((button, state.cursor));
                        match button {
                            MouseButton::Left => state.orbit.rotate(dx, dy),
                            _ => state.orbit.pan(dx, dy),
                        }
                        state.camera_moved()
                    }
                    None => Ok(()),
                }
            }
            WindowEvent::MouseWheel { delta, .. } => {
                let steps = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y as f64,
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                state.orbit.zoom(steps);
                state.camera_moved()
            }
            WindowEvent::RedrawRequested => state.frame(&self.options).map(|done| {
                if done {
                    event_loop.exit();
                }
            }),
            _ => Ok(()),
        };
        if let Err(e) = result {
            self.error = Some(e);
            event_loop.exit();
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if let Some(state) = &self.state {
            // Converged: redraw only when something asks for it.
            if state.converged && self.options.frames.is_none() {
                event_loop
                    .set_control_flow(ControlFlow::WaitUntil(Instant::now() + Duration::from_millis(100)));
            }
            state.window.request_redraw();
        }
    }
}

impl State {
    fn new(event_loop: &ActiveEventLoop, options: &ViewOptions) -> Result<State> {
        let instance = crate::gpu::context::instance();
        // The session is opened first (to know the image size), on a device that can
        // present to the window: the window and its surface come first, the device from an
        // adapter compatible with them.
        let size_hint = (options.session.width.unwrap_or(640), options.session.height.unwrap_or(480));
        let attributes = Window::default_attributes()
            .with_title("pathlight")
            .with_inner_size(winit::dpi::PhysicalSize::new(size_hint.0, size_hint.1));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .map_err(|e| Error::Settings(format!("cannot open a window: {e}")))?,
        );
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| Error::Gpu(format!("cannot draw into the window: {e}")))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: Some(&surface),
            apply_limit_buckets: false,
        }))
        .map_err(|e| Error::Gpu(format!("no Vulkan adapter can present to the window: {e}")))?;
        let ctx = Arc::new(GpuContext::from_adapter(adapter.clone())?);
        let size = window.inner_size();
        let mut session_options = options.session.clone();
        session_options.width = Some(size.width.max(1));
        session_options.height = Some(size.height.max(1));
        let session = Session::open_with(&session_options, Some(ctx.clone()))?;
        for w in &session.warnings {
            eprintln!("warning: {}: {w}", session.source.display());
        }
        eprintln!("{}", session.describe());
        for note in session.backend_note.iter().chain(&session.backend_detail) {
            eprintln!("{note}");
        }
        eprintln!("display on {}", ctx.name());
        let mut config = surface
            .get_default_config(&adapter, size.width.max(1), size.height.max(1))
            .ok_or_else(|| Error::Gpu("the window's surface is not supported by the adapter".into()))?;
        // A plain (non-sRGB) format when there is one: the display pass encodes sRGB itself,
        // exactly as the PNG writer does.
        let caps = surface.get_capabilities(&adapter);
        if let Some(f) = caps.formats.iter().find(|f| !f.is_srgb()) {
            config.format = *f;
        }
        config.present_mode = wgpu::PresentMode::AutoNoVsync;
        surface.configure(&ctx.device, &config);
        let display = Display::new(&ctx, config.format)?;
        let bounds = session.scene.bounds().unwrap_or((glam::DVec3::ZERO, glam::DVec3::ONE));
        let orbit = Orbit::new(&session.flat.camera_desc, bounds, session.flat.camera_desc.position);
        let upload = session.gpu_film_buffer().is_none().then(|| {
            let pixels = (session.settings.width * session.settings.height) as usize;
            (display::upload_buffer(&ctx, pixels), Instant::now() - UPLOAD_INTERVAL)
        });
        Ok(State {
            window,
            surface,
            config,
            ctx,
            session,
            display,
            upload,
            orbit,
            next_row: 0,
            row_seconds: None,
            frames: 0,
            exposure: options.exposure,
            tonemap: options.tonemap,
            drag: None,
            cursor: (0.0, 0.0),
            title_at: Instant::now() - TITLE_INTERVAL,
            predicted: None,
            converged: false,
            saves: 0,
            show_denoised: options.show_denoised,
            denoiser: options.denoiser,
            denoised: None,
        })
    }

    fn restart(&mut self) -> Result<()> {
        self.session.restart()?;
        self.next_row = 0;
        self.converged = false;
        self.predicted = None;
        self.denoised = None;
        Ok(())
    }

    fn camera_moved(&mut self) -> Result<()> {
        let aspect = self.session.settings.width as f64 / self.session.settings.height as f64;
        self.session.set_camera(&self.orbit.camera(aspect))?;
        self.restart()
    }

    fn resize(&mut self, width: u32, height: u32) -> Result<()> {
        if width == 0 || height == 0 {
            return Ok(()); // minimised
        }
        self.config.width = width;
        self.config.height = height;
        self.surface.configure(&self.ctx.device, &self.config);
        if (width, height) != (self.session.settings.width, self.session.settings.height) {
            self.session.resize(width, height)?;
            if self.upload.is_some() {
                self.upload = Some((
                    display::upload_buffer(&self.ctx, (width * height) as usize),
                    Instant::now() - UPLOAD_INTERVAL,
                ));
            }
            self.restart()?;
        }
        Ok(())
    }

    /// Adds bounded work, draws, and reports whether `--frames` are done.
    fn frame(&mut self, options: &ViewOptions) -> Result<bool> {
        let height = self.session.settings.height;
        let goal = options.frames.unwrap_or(self.session.settings.spp);
        if !self.converged {
            if options.frames.is_some() {
                // One whole pass per frame: N frames are exactly N samples per pixel.
                self.session.render_rows(0..height)?;
            } else {
                let start = Instant::now();
                while start.elapsed().as_secs_f64() < FRAME_WORK_SECONDS {
                    let rows = match self.row_seconds {
                        None => 1,
                        Some(r) => ((FRAME_WORK_SECONDS / r.max(1e-9)) as u32).clamp(1, height),
                    };
                    let end = (self.next_row + rows).min(height);
                    let t = Instant::now();
                    self.session.render_rows(self.next_row..end)?;
                    let per_row = t.elapsed().as_secs_f64() / (end - self.next_row) as f64;
                    self.row_seconds = Some(match self.row_seconds {
                        None => per_row,
                        Some(r) => 0.7 * r + 0.3 * per_row,
                    });
                    self.next_row = if end == height { 0 } else { end };
                    if self.next_row == 0 && self.session.spp() >= goal {
                        break;
                    }
                }
            }
            if self.session.spp() >= goal {
                self.converged = true;
            }
        }
        self.frames += 1;
        let title_due = self.title_at.elapsed() >= TITLE_INTERVAL;
        // The predicted error needs the film on the host: read it at the title's rate only,
        // and not again once accumulation has stopped. It feeds the title and --target-error.
        if title_due && (self.predicted.is_none() || !self.converged) {
            self.predicted = predicted_relmse(&LinearImage::from_film(&self.session.film()?));
            let reached = options.target_error.is_some_and(|e| self.predicted.is_some_and(|p| p <= e));
            if reached && self.next_row == 0 {
                self.converged = true;
            }
        }
        self.draw()?;
        if title_due {
            self.update_title()?;
        }
        if let Some(n) = options.frames {
            if self.frames >= n {
                self.finish(options)?;
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// The film buffer the display pass reads, uploading the CPU film when due.
    fn film_buffer(&mut self, force: bool) -> Result<wgpu::Buffer> {
        if let Some(buffer) = self.session.gpu_film_buffer() {
            return Ok(buffer.clone());
        }
        let (buffer, at) = self.upload.as_mut().expect("the CPU backend has an upload buffer");
        if force || at.elapsed() >= UPLOAD_INTERVAL {
            let film = self.session.film()?;
            self.ctx.queue.write_buffer(buffer, 0, bytemuck::cast_slice(&film.pixels));
            *at = Instant::now();
        }
        Ok(buffer.clone())
    }

    /// The denoised image as a film buffer for the display pass, made again when the film
    /// has more samples and [`DENOISE_INTERVAL`] has passed (or accumulation has stopped).
    fn denoised_buffer(&mut self) -> Result<wgpu::Buffer> {
        let spp = self.session.spp();
        let stale = match &self.denoised {
            None => true,
            Some((_, at_spp, at)) => *at_spp != spp && (self.converged || at.elapsed() >= DENOISE_INTERVAL),
        };
        if stale {
            let (image, _) = self.session.denoised(self.denoiser)?;
            let pixels: Vec<crate::scene::layout::FilmPixel> = image
                .iter()
                .map(|v| crate::scene::layout::FilmPixel {
                    mean: v.to_array(),
                    count: 1,
                    ..Default::default()
                })
                .collect();
            let buffer = match self.denoised.take() {
                Some((b, _, _)) if b.size() as usize == std::mem::size_of_val(&pixels[..]) => b,
                _ => display::upload_buffer(&self.ctx, pixels.len()),
            };
            self.ctx.queue.write_buffer(&buffer, 0, bytemuck::cast_slice(&pixels));
            self.denoised = Some((buffer, spp, Instant::now()));
        }
        Ok(self.denoised.as_ref().expect("made above").0.clone())
    }

    fn draw(&mut self) -> Result<()> {
        // The denoised view needs a pass of samples with a variance (two samples per pixel).
        let film = if self.show_denoised && self.session.spp() >= 2 {
            self.denoised_buffer()?
        } else {
            self.film_buffer(self.converged)?
        };
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.ctx.device, &self.config);
                return Ok(());
            }
            // Occluded, timed out: skip this frame.
            _ => return Ok(()),
        };
        let view = frame.texture.create_view(&Default::default());
        let s = &self.session.settings;
        self.display.draw(
            &self.ctx,
            &film,
            (s.width, s.height),
            &view,
            (self.config.width, self.config.height),
            self.tonemap,
            self.exposure,
        );
        self.window.pre_present_notify();
        self.ctx.queue.present(frame);
        Ok(())
    }

    fn update_title(&mut self) -> Result<()> {
        self.title_at = Instant::now();
        let s = &self.session.settings;
        let seconds = self.session.seconds();
        let rate = self.session.spp() as f64 * s.width as f64 * s.height as f64 / seconds.max(1e-9) / 1e6;
        let tonemap = match self.tonemap {
            DISPLAY_ACES => "ACES",
            DISPLAY_RELATIVE_ERROR => "relative error",
            _ => "clamp",
        };
        self.window.set_title(&format!(
            "pathlight — {} — {} spp{}, {rate:.2} Msamples/s, {seconds:.1} s, predicted relMSE {}, {tonemap}{}, exposure {:+.1}",
            self.session.source.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            self.session.spp(),
            if self.converged { " (done)" } else { "" },
            self.predicted.map_or("–".to_string(), |p| format!("{p:.2e}")),
            if self.show_denoised { format!(", denoised ({})", self.denoiser) } else { String::new() },
            self.exposure
        ));
        Ok(())
    }

    fn tonemap(&self) -> Tonemap {
        if self.tonemap == DISPLAY_ACES {
            Tonemap::Aces
        } else {
            Tonemap::Clamp
        }
    }

    /// `S`: the film as EXR (with variance) and PNG.
    fn save(&mut self, options: &ViewOptions) -> Result<()> {
        let outputs = if options.outputs.is_empty() {
            self.saves += 1;
            let stem = format!("pathlight-view-{}", self.saves);
            vec![PathBuf::from(format!("{stem}.exr")), PathBuf::from(format!("{stem}.png"))]
        } else {
            options.outputs.clone()
        };
        self.session.write(&outputs, self.tonemap(), self.exposure)?;
        for o in &outputs {
            eprintln!("saved {} ({} spp)", o.display(), self.session.spp());
        }
        Ok(())
    }

    fn write_outputs(&mut self, options: &ViewOptions) -> Result<()> {
        if options.outputs.is_empty() {
            return Ok(());
        }
        self.session.write(&options.outputs, self.tonemap(), self.exposure)
    }

    /// `--frames`: the screenshot of what the window shows, and the outputs.
    fn finish(&mut self, options: &ViewOptions) -> Result<()> {
        if let Some(path) = &options.screenshot {
            let film = if self.show_denoised && self.session.spp() >= 2 {
                self.denoised_buffer()?
            } else {
                self.film_buffer(true)?
            };
            let s = &self.session.settings;
            let image = display::screenshot(
                &self.ctx,
                &self.display_for_screenshot()?,
                &film,
                (s.width, s.height),
                (self.config.width, self.config.height),
                self.tonemap,
                self.exposure,
            )?;
            crate::film::write_atomically(path, |tmp| {
                image
                    .save_with_format(tmp, image::ImageFormat::Png)
                    .map_err(|e| Error::output(path, format!("cannot write PNG: {e}")))
            })?;
            eprintln!("screenshot {} ({} spp)", path.display(), self.session.spp());
        }
        self.write_outputs(options)
    }

    /// The display pipeline for the screenshot's RGBA8 target (the window's format may
    /// differ, e.g. BGRA).
    fn display_for_screenshot(&self) -> Result<Display> {
        Display::new(&self.ctx, wgpu::TextureFormat::Rgba8Unorm)
    }
}
