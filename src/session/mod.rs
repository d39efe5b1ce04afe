//! A render session: load a scene, choose a backend, add progressive passes to its film,
//! report progress and error, stop early, move the camera, write the outputs. The command
//! line's `render` and `view` and the tests all go through it; a Rust program embeds
//! pathlight the same way:
//!
//! ```no_run
//! use pathlight::session::{Session, SessionOptions};
//! let mut session = Session::open(&SessionOptions::new("scenes/cornell-box.gltf"))?;
//! session.render_to(16, &std::sync::atomic::AtomicBool::new(false), |_, _| Ok(false))?;
//! session.write(&["out.exr".into()], pathlight::film::Tonemap::Clamp, 0.0)?;
//! # Ok::<(), pathlight::Error>(())
//! ```
//!
//! A session keeps its samples: stopped (by the stop flag or a checkpoint) it can be
//! resumed, and the resumed film equals an uninterrupted one, because every sample's random
//! stream depends only on (pixel, sample index, seed).

mod job;
mod output;

pub use job::{check_outputs, check_target_error, JobEvent, JobReport, RenderJob};
pub use output::{denoise_film, ExtrasTiming, OutputOptions};

/// Part `i` of `n` of a render of `spp` samples per pixel (`--shard I/N`, a Kubernetes
/// completion index or a Slurm array task id): the sample indices ⌊i·spp/n⌋..⌊(i+1)·spp/n⌋,
/// empty when n > spp leaves the part none.
pub fn shard_samples(i: u32, n: u32, spp: u32) -> std::ops::Range<u32> {
    let at = |k: u32| (k as u64 * spp as u64 / n as u64) as u32;
    at(i)..at(i + 1)
}

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use crate::cpu::CpuBackend;
use crate::error::{Error, Result};
use crate::film::{write_exr, write_png, Aovs, Film, RenderMetadata, Tonemap};
use crate::gpu::{enumerate_adapters, GpuBackend, GpuContext};
use crate::integrator::Integrator;
use crate::light::EnvironmentDesc;
use crate::render::{render_progressive_from, Backend, RenderSettings, RenderStats};
use crate::sampling::adaptive::AdaptiveSettings;
use crate::sampling::SamplerKind;
use crate::scene::layout::Camera;
use crate::scene::{FlatScene, LoadOptions, Scene, ViewSettings};

/// Which backend renders.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BackendChoice {
    /// A hardware GPU if there is one; else the CPU backend (a software Vulkan rasteriser
    /// such as lavapipe is slower than it on the same cores).
    #[default]
    Auto,
    /// The WGSL megakernel on a Vulkan device, software rasterisers included.
    Gpu,
    /// The CPU reference renderer.
    Cpu,
}

/// The light around the scene, beyond its own.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum EnvironmentChoice {
    /// The scene's own lights (a default sky, with a warning, when it has none).
    #[default]
    None,
    /// An equirectangular map, scaled and turned about +Y.
    Map { path: PathBuf, intensity: f32, rotation_degrees: f32 },
    /// A constant radiance.
    Constant(glam::Vec3),
}

/// Everything a session needs to know before it starts.
#[derive(Clone, Debug)]
pub struct SessionOptions {
    pub scene: PathBuf,
    pub load: LoadOptions,
    pub environment: EnvironmentChoice,
    /// Camera index in the file (`None`: the first, or one framing the scene).
    pub camera: Option<usize>,
    /// Image size; a missing side follows the camera's aspect ratio (512 when both are).
    pub width: Option<u32>,
    pub height: Option<u32>,
    /// Samples per pixel the session aims for (it also sizes the texture filter's cone).
    pub spp: u32,
    /// Render only these sample indices of the `spp` (a shard of the render, `--samples`,
    /// `--shard`); `None`: all of them. The shards of one render together are its samples:
    /// every sample's numbers depend only on (pixel, sample index, seed), and the cone stays
    /// the whole render's.
    pub samples: Option<std::ops::Range<u32>>,
    pub seed: u32,
    /// The estimator (`--integrator`).
    pub integrator: Integrator,
    pub max_depth: Option<u32>,
    /// Where the paths' random numbers come from.
    pub sampler: SamplerKind,
    /// Continuations per camera sample (`RenderSettings::splits`); `None`: the backend's
    /// default ([`crate::render::default_splits`]).
    pub splits: Option<u32>,
    /// Let a light tracer take the caustic paths where the scene allows it
    /// (`RenderSettings::light_tracing`).
    pub light_tracing: bool,
    /// `RenderSettings::bdpt_strategy` (`--bdpt-strategy`).
    pub bdpt_strategy: Option<(u32, u32)>,
    /// `RenderSettings::record_strategies` (`--bdpt-strategies`).
    pub record_strategies: bool,
    /// `RenderSettings::photons` (`--photons`).
    pub photons: Option<u32>,
    /// `RenderSettings::sppm_radius` (`--sppm-radius`).
    pub sppm_radius: Option<f32>,
    /// `RenderSettings::caustic_photons` (`--caustic-photons`).
    pub caustic_photons: Option<u32>,
    /// `RenderSettings::gather_photons` (`--gather-photons`).
    pub gather_photons: Option<u32>,
    /// `RenderSettings::irradiance_cache` (`--irradiance-cache`).
    pub irradiance_cache: Option<crate::integrator::irradiance_cache::IrradianceCacheSettings>,
    /// `RenderSettings::mlt` (`--mutations-per-pixel`, `--bootstrap-samples`, `--chains`,
    /// `--large-step`).
    pub mlt: crate::integrator::mlt::MltSettings,
    pub backend: BackendChoice,
    /// GPU: the first adapter whose name contains this (asks for the GPU backend).
    pub device: Option<String>,
    /// What the outputs carry beside the film: AOVs and a denoised image.
    pub outputs: OutputOptions,
    /// Adaptive sampling (`--adaptive`): each pixel's sample count, at most `spp`, decided
    /// after a pilot from its neighbours' samples, not its own (`crate::sampling::adaptive`).
    pub adaptive: Option<AdaptiveSettings>,
    /// Make the AOV pass available ([`Session::aovs`], [`Session::denoised`]) even where the
    /// outputs write none: the viewer's denoised view (the GPU backend then holds 48 bytes per
    /// pixel for it).
    pub aovs_available: bool,
}

impl SessionOptions {
    /// The defaults of `pathlight render` for `scene`.
    pub fn new(scene: impl Into<PathBuf>) -> SessionOptions {
        SessionOptions {
            scene: scene.into(),
            load: LoadOptions::default(),
            environment: EnvironmentChoice::None,
            camera: None,
            width: None,
            height: None,
            spp: 64,
            samples: None,
            seed: 0,
            integrator: Integrator::default(),
            max_depth: None,
            sampler: SamplerKind::default(),
            splits: None,
            light_tracing: true,
            bdpt_strategy: None,
            record_strategies: false,
            photons: None,
            sppm_radius: None,
            caustic_photons: None,
            gather_photons: None,
            irradiance_cache: None,
            mlt: crate::integrator::mlt::MltSettings::default(),
            backend: BackendChoice::Auto,
            device: None,
            outputs: OutputOptions::default(),
            adaptive: None,
            aovs_available: false,
        }
    }
}

/// An open session: the scene, its backend and the film so far.
pub struct Session {
    pub source: PathBuf,
    /// The scene as loaded (f64), for a viewer that frames it.
    pub scene: Scene,
    pub flat: Arc<FlatScene>,
    pub settings: RenderSettings,
    /// Warnings from loading and flattening the scene.
    pub warnings: Vec<String>,
    /// Why the backend was chosen, when `Auto` chose (for the user).
    pub backend_note: Option<String>,
    /// What opening the backend cost (the GPU kernel's build and the scene's upload).
    pub backend_detail: Option<String>,
    backend: Box<dyn Backend + Send>,
    gpu: Option<Arc<GpuContext>>,
    /// The GPU backend's film buffer (the trait object cannot be downcast to reach it).
    gpu_film: Option<wgpu::Buffer>,
    camera: Camera,
    /// The first sample index this session renders (0 unless it renders a shard).
    first_sample: u32,
    /// Does it render a shard (`SessionOptions::samples`)? Its EXR then carries the film's
    /// whole state, for `pathlight merge`.
    shard: bool,
    /// What the outputs carry beside the film (`SessionOptions::outputs`).
    output_options: OutputOptions,
    /// The AOVs of the current camera, once rendered.
    aov_cache: output::AovCache,
    /// What the last write's AOVs and denoiser cost.
    extras_timing: ExtrasTiming,
    /// Adaptive sampling's settings, and each pixel's sample count once the pilot decided it
    /// (for the current camera).
    adaptive: Option<AdaptiveSettings>,
    budgets: Option<Vec<u32>>,
    pilot_seconds: f64,
    /// The next sample index to render: samples `first_sample .. spp_done` are in the film.
    spp_done: u32,
    seconds: f64,
}

/// A backend, its film on the device (GPU only), and what opening it cost (GPU only).
type OpenedBackend = (Box<dyn Backend + Send>, Option<wgpu::Buffer>, Option<String>);

/// A backend for `flat` at `settings`: the GPU one on `gpu` when given, else the CPU one.
fn make_backend(
    flat: &Arc<FlatScene>,
    settings: &RenderSettings,
    gpu: Option<&Arc<GpuContext>>,
) -> Result<OpenedBackend> {
    Ok(match gpu {
        Some(ctx) => {
            let backend = GpuBackend::new(ctx.clone(), flat, settings)?;
            // Where the film on the device is not the image, a display reads the image back.
            let film = backend.film_buffer_is_the_image().then(|| backend.film_buffer().clone());
            let detail = format!(
                "kernel specialised to [{}], {}, built in {:.2} s, scene uploaded in {:.3} s",
                flat.features.describe(),
                backend.tables().describe(),
                backend.kernel_build_seconds(),
                backend.upload_seconds
            );
            (Box::new(backend), film, Some(detail))
        }
        None => (Box::new(CpuBackend::shared(flat.clone(), settings)), None, None),
    })
}

/// Image size from the options and the camera's aspect ratio.
fn image_size(width: Option<u32>, height: Option<u32>, aspect: Option<f64>) -> (u32, u32) {
    let aspect = aspect.unwrap_or(1.0);
    match (width, height) {
        (Some(w), Some(h)) => (w, h),
        (Some(w), None) => (w, ((w as f64 / aspect).round() as u32).max(1)),
        (None, Some(h)) => (((h as f64 * aspect).round() as u32).max(1), h),
        (None, None) => (512, 512),
    }
}

impl Session {
    /// Loads the scene and opens the backend the options ask for.
    pub fn open(options: &SessionOptions) -> Result<Session> {
        Self::open_with(options, None)
    }

    /// [`Session::open`] on a GPU context the caller already holds (a viewer whose window
    /// shares the device); `gpu` is used when the backend is the GPU one.
    pub fn open_with(options: &SessionOptions, gpu: Option<Arc<GpuContext>>) -> Result<Session> {
        let (mut scene, mut warnings) = crate::scene::load_with(&options.scene, &options.load)?;
        match &options.environment {
            EnvironmentChoice::None => {}
            EnvironmentChoice::Map { path, intensity, rotation_degrees } => {
                if !intensity.is_finite() || *intensity < 0.0 || !rotation_degrees.is_finite() {
                    return Err(Error::Settings(
                        "--env-intensity must be ≥ 0 and --env-rotation finite".into(),
                    ));
                }
                let mut env = EnvironmentDesc::load(path)?;
                env.intensity = *intensity;
                env.rotation_degrees = *rotation_degrees;
                scene.environment = Some(env);
            }
            EnvironmentChoice::Constant(rgb) => scene.environment = Some(EnvironmentDesc::constant(*rgb)),
        }
        let camera_aspect = match options.camera {
            Some(i) => scene.cameras.get(i).and_then(|c| c.aspect_ratio()),
            None => scene.cameras.first().and_then(|c| c.aspect_ratio()),
        };
        let (width, height) = image_size(options.width, options.height, camera_aspect);
        let mut settings = RenderSettings {
            width,
            height,
            spp: options.spp,
            seed: options.seed,
            integrator: options.integrator,
            max_depth: options.max_depth,
            sampler: options.sampler,
            // A count asked for is checked here, before any work; without one the chosen
            // backend's default replaces this below.
            splits: options.splits.unwrap_or(1),
            bdpt_strategy: options.bdpt_strategy,
            record_strategies: options.record_strategies,
            photons: options.photons,
            sppm_radius: options.sppm_radius,
            caustic_photons: options.caustic_photons,
            gather_photons: options.gather_photons,
            irradiance_cache: options.irradiance_cache,
            mlt: options.mlt,
            aovs: options.outputs.needs_aovs() || options.aovs_available,
            adaptive: options.adaptive.is_some(),
            ..RenderSettings::default()
        };
        settings.validate()?;
        if let Some(adaptive) = &options.adaptive {
            adaptive.validate(options.spp)?;
            if options.samples.is_some() {
                return Err(Error::Settings(
                    "--adaptive renders whole images: a part (--samples, --shard) cannot take it yet".into(),
                ));
            }
        }
        if options.integrator == Integrator::Sppm
            && options.samples.as_ref().is_some_and(|r| *r != (0..options.spp))
        {
            return Err(Error::Settings(
                "--integrator sppm renders whole images: its passes shrink radii the next pass reads, \
                 so a part (--samples, --shard) cannot be rendered apart or merged"
                    .into(),
            ));
        }
        if let Some(denoiser) = options.outputs.denoiser {
            denoiser.check_available()?;
        }
        let samples = options.samples.clone().unwrap_or(0..options.spp);
        if samples.start >= samples.end || samples.end > options.spp {
            return Err(Error::Settings(format!(
                "--samples {}..{}: a range of sample indices A..B with A < B ≤ --spp ({})",
                samples.start, samples.end, options.spp
            )));
        }
        let view = ViewSettings { camera: options.camera, aspect: width as f64 / height as f64 };
        let flat = Arc::new(FlatScene::build(&scene, &view)?);
        warnings.extend(flat.warnings());

        // --device names an adapter, so it asks for the GPU backend.
        let mut backend_note = None;
        let choice = match (options.backend, &options.device) {
            (BackendChoice::Auto, Some(_)) => BackendChoice::Gpu,
            (BackendChoice::Auto, None) if options.record_strategies || options.bdpt_strategy.is_some() => {
                backend_note = Some(
                    "backend auto: strategies are recorded or isolated on the CPU backend only; rendering on the CPU backend"
                        .to_string(),
                );
                BackendChoice::Cpu
            }
            (BackendChoice::Auto, None) if !options.integrator.has_gpu_kernel() => {
                backend_note = Some(format!(
                    "backend auto: the GPU backend has no {} kernel yet; rendering on the CPU backend",
                    options.integrator
                ));
                BackendChoice::Cpu
            }
            (BackendChoice::Auto, None) => match &gpu {
                Some(ctx) if ctx.is_hardware() => BackendChoice::Gpu,
                _ => {
                    let adapters = enumerate_adapters();
                    if crate::gpu::hardware_adapter(&adapters).is_some() {
                        BackendChoice::Gpu
                    } else {
                        let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
                        backend_note = Some(if names.is_empty() {
                            "backend auto: no Vulkan adapter found; rendering on the CPU backend".to_string()
                        } else {
                            format!(
                                "backend auto: the only Vulkan adapter ({}) is a software rasteriser, slower here than the CPU backend; rendering on the CPU backend (--backend gpu forces it)",
                                names.join(", ")
                            )
                        });
                        BackendChoice::Cpu
                    }
                }
            },
            (other, _) => other,
        };
        let gpu = match choice {
            BackendChoice::Gpu => Some(match gpu {
                Some(ctx) => ctx,
                None => Arc::new(GpuContext::new(options.device.as_deref())?),
            }),
            _ => None,
        };
        let device = crate::render::RenderDevice::of(gpu.as_deref());
        // The irradiance cache takes the place of the splits at the first vertex.
        let default_splits =
            if settings.irradiance_cache.is_some() { 1 } else { crate::render::default_splits(device) };
        settings.splits = options.splits.unwrap_or(default_splits);
        settings.light_tracing = options.light_tracing;
        let (backend, gpu_film, backend_detail) = make_backend(&flat, &settings, gpu.as_ref())?;
        Ok(Session {
            backend_detail,
            source: options.scene.clone(),
            scene,
            camera: flat.camera,
            flat,
            settings,
            warnings,
            backend_note,
            backend,
            gpu,
            gpu_film,
            first_sample: samples.start,
            shard: options.samples.is_some(),
            output_options: options.outputs,
            aov_cache: Default::default(),
            extras_timing: ExtrasTiming::default(),
            adaptive: options.adaptive,
            budgets: None,
            pilot_seconds: 0.0,
            spp_done: samples.start,
            seconds: 0.0,
        })
    }

    /// A session around a backend of the caller's own (any [`Backend`]: a custom device, or
    /// a test's failing one) for `flat` at `settings`.
    pub fn with_backend(
        source: PathBuf,
        scene: Scene,
        flat: Arc<FlatScene>,
        settings: RenderSettings,
        backend: Box<dyn Backend + Send>,
    ) -> Session {
        Session {
            source,
            scene,
            camera: flat.camera,
            flat,
            settings,
            warnings: Vec::new(),
            backend_note: None,
            backend_detail: None,
            backend,
            gpu: None,
            gpu_film: None,
            first_sample: 0,
            shard: false,
            output_options: OutputOptions::default(),
            aov_cache: Default::default(),
            extras_timing: ExtrasTiming::default(),
            adaptive: None,
            budgets: None,
            pilot_seconds: 0.0,
            spp_done: 0,
            seconds: 0.0,
        }
    }

    /// A one-line summary of the scene (triangles, lights, BVH, kernel features).
    pub fn describe(&self) -> String {
        let f = &self.flat;
        format!(
            "{}: {} triangles, {} lights, BVH {} nodes built in {:.3} s (SAH cost {:.2}), features: {}",
            self.source.display(),
            f.triangles.len(),
            f.lights.len(),
            f.bvh_stats.nodes,
            f.bvh_stats.build_seconds,
            f.bvh_stats.sah_cost,
            f.features.describe()
        )
    }

    /// The backend's name, as outputs record it.
    pub fn backend_name(&self) -> String {
        self.backend.name()
    }

    /// The GPU backend's device, when the session renders on one.
    pub fn gpu_context(&self) -> Option<&Arc<GpuContext>> {
        self.gpu.as_ref()
    }

    /// The film on the device when the backend is the GPU one (for a display pass).
    pub fn gpu_film_buffer(&self) -> Option<&wgpu::Buffer> {
        self.gpu_film.as_ref()
    }

    /// The camera rendering now.
    pub fn camera(&self) -> Camera {
        self.camera
    }

    /// Renders at a new image size from now on (a resized window): the camera keeps its
    /// vertical field of view and follows the new aspect ratio; the film restarts.
    pub fn resize(&mut self, width: u32, height: u32) -> Result<()> {
        let settings = RenderSettings { width, height, ..self.settings.clone() };
        settings.validate()?;
        let (backend, gpu_film, _) = make_backend(&self.flat, &settings, self.gpu.as_ref())?;
        self.backend = backend;
        self.gpu_film = gpu_film;
        self.settings = settings;
        self.aov_cache = Default::default();
        self.budgets = None;
        let mut camera = self.camera;
        camera.half_width = camera.half_height * width as f32 / height as f32;
        self.set_camera(&camera)
    }

    /// The next sample index to render: every pixel holds samples
    /// [`Session::first_sample`]` .. spp()` (all of `0 .. spp()` unless a shard).
    pub fn spp(&self) -> u32 {
        self.spp_done
    }

    /// The first sample index this session renders (0 unless it renders a shard).
    pub fn first_sample(&self) -> u32 {
        self.first_sample
    }

    /// Seconds spent rendering so far.
    pub fn seconds(&self) -> f64 {
        self.seconds
    }

    /// Renders progressive passes until `spp` samples per pixel, `stop` is set, or
    /// `checkpoint(film_source, done, seconds)` returns true; resumes where the film is.
    pub fn render_to(
        &mut self,
        spp: u32,
        stop: &AtomicBool,
        mut checkpoint: impl FnMut(&mut dyn Backend, u32) -> Result<bool>,
    ) -> Result<RenderStats> {
        // Adaptive sampling: the pilot decides each pixel's count before the first pass
        // after it (its time is counted in `decide_sample_counts`), and the render ends
        // where the most-sampled pixel does.
        let mut spp = spp;
        if self.adaptive.is_some() {
            if !self.decide_sample_counts(stop)? {
                return Ok(RenderStats { spp: self.spp_done, seconds: self.seconds, interrupted: true });
            }
            let most = self.budgets.as_ref().and_then(|b| b.iter().copied().max()).unwrap_or(spp);
            spp = spp.min(most);
        }
        let before = self.seconds;
        let start = std::time::Instant::now();
        // Passes completed, kept even when a later pass fails (a GPU fault or timeout): the
        // film still holds them, and the caller may write them out.
        let mut completed = self.spp_done;
        let result =
            render_progressive_from(self.backend.as_mut(), self.spp_done, spp, stop, |b, done, _| {
                completed = done;
                checkpoint(b, done)
            });
        self.spp_done = completed;
        self.seconds = before + start.elapsed().as_secs_f64();
        let stats = result?;
        Ok(RenderStats { seconds: self.seconds, ..stats })
    }

    /// Adaptive sampling: renders the pilot and sets each pixel's sample count, unless done
    /// for this camera already (`render_to` does it first; a caller that wants the counts
    /// before the first pass, for its progress display, may call it itself). `false` when
    /// `stop` ended the pilot; `true` without adaptive sampling.
    pub fn decide_sample_counts(&mut self, stop: &AtomicBool) -> Result<bool> {
        let Some(adaptive) = self.adaptive else { return Ok(true) };
        if self.budgets.is_some() {
            return Ok(true);
        }
        let t = std::time::Instant::now();
        let pilot = self.pilot(&adaptive, stop);
        self.pilot_seconds = t.elapsed().as_secs_f64();
        self.seconds += self.pilot_seconds;
        match pilot? {
            Some(budgets) => {
                self.backend.set_sample_budgets(Some(&budgets))?;
                self.budgets = Some(budgets);
                Ok(true)
            }
            None => Ok(false),
        }
    }

    /// Seconds the last adaptive pilot took (0 without one).
    pub fn pilot_seconds(&self) -> f64 {
        self.pilot_seconds
    }

    /// Adaptive sampling's pilot (`crate::sampling::adaptive`): the render's own first
    /// `min_spp` samples of every pixel (kept: each pixel's count is decided from its
    /// neighbours' samples, not its own), and the counts they give; `None` when `stop`
    /// ended it first.
    fn pilot(&mut self, adaptive: &AdaptiveSettings, stop: &AtomicBool) -> Result<Option<Vec<u32>>> {
        if self.spp_done < adaptive.min_spp {
            // Every pixel takes the pilot's samples, whatever counts an earlier camera had.
            self.backend.set_sample_budgets(None)?;
            let mut completed = self.spp_done;
            let result = render_progressive_from(
                self.backend.as_mut(),
                self.spp_done,
                adaptive.min_spp,
                stop,
                |_, done, _| {
                    completed = done;
                    Ok(false)
                },
            );
            self.spp_done = completed;
            if result?.interrupted {
                return Ok(None);
            }
        }
        let film = self.backend.film()?;
        Ok(Some(crate::sampling::adaptive::sample_budgets(&film, adaptive, self.settings.spp)))
    }

    /// Adaptive sampling: the share of pixels that take sample index `index` (`None` without
    /// adaptive sampling, or before the pilot decided).
    pub fn active_share(&self, index: u32) -> Option<f64> {
        let budgets = self.budgets.as_ref()?;
        Some(budgets.iter().filter(|&&b| b > index).count() as f64 / budgets.len().max(1) as f64)
    }

    /// Adaptive sampling: each pixel's sample count, once the pilot has decided them.
    pub fn sample_budgets(&self) -> Option<&[u32]> {
        self.budgets.as_deref()
    }

    /// Adds the next sample to rows `rows` (bounded work for a viewer); when the band ends
    /// at the last row the pass is complete and [`Session::spp`] counts it.
    pub fn render_rows(&mut self, rows: std::ops::Range<u32>) -> Result<()> {
        let t = std::time::Instant::now();
        let end = rows.end.min(self.settings.height);
        self.backend.render_rows(self.spp_done, rows)?;
        if end == self.settings.height {
            self.spp_done += 1;
        }
        self.seconds += t.elapsed().as_secs_f64();
        Ok(())
    }

    /// The film so far.
    pub fn film(&mut self) -> Result<Film> {
        self.backend.film()
    }

    /// Rays traced so far.
    pub fn rays_traced(&mut self) -> Result<u64> {
        self.backend.rays_traced()
    }

    /// Bidirectional path tracing's per-strategy images (`--bdpt-strategies`).
    pub fn strategy_images(&mut self) -> Result<Option<crate::integrator::bdpt::StrategyImages>> {
        self.backend.strategy_images()
    }

    /// What bidirectional path tracing counted (`None` for other integrators).
    pub fn bdpt_stats(&mut self) -> Option<crate::integrator::bdpt::BdptStats> {
        self.backend.bdpt_stats()
    }

    /// What Metropolis's passes counted (`None` for other integrators).
    pub fn mlt_stats(&mut self) -> Option<crate::integrator::mlt::MltStats> {
        self.backend.mlt_stats()
    }

    /// What the photon passes counted (`None` for other integrators).
    pub fn sppm_stats(&mut self) -> Option<crate::integrator::sppm::SppmStats> {
        self.backend.sppm_stats()
    }

    /// What placing the irradiance cache counted (`None` without one).
    pub fn irradiance_cache_stats(
        &mut self,
    ) -> Option<crate::integrator::irradiance_cache::IrradianceCacheStats> {
        self.backend.irradiance_cache_stats()
    }

    /// The pixels whose camera paths placed the irradiance cache's records (`None` without
    /// one).
    pub fn irradiance_record_pixels(&mut self) -> Option<Vec<(u32, u32)>> {
        self.backend.irradiance_record_pixels()
    }

    /// Forgets every sample (the camera or the scene changed).
    pub fn restart(&mut self) -> Result<()> {
        self.backend.reset()?;
        self.spp_done = self.first_sample;
        self.seconds = 0.0;
        Ok(())
    }

    /// Moves the camera and restarts.
    pub fn set_camera(&mut self, camera: &Camera) -> Result<()> {
        self.backend.set_camera(camera)?;
        self.camera = *camera;
        self.aov_cache = Default::default();
        self.budgets = None;
        self.restart()
    }

    /// What an EXR records about this render.
    pub fn metadata(&mut self) -> Result<RenderMetadata> {
        let rejected = self.backend.film()?.total_rejected();
        let cache_stats = self.backend.irradiance_cache_stats();
        let mlt_stats = self.backend.mlt_stats();
        Ok(RenderMetadata {
            mlt: mlt_stats.map(|stats| {
                let m = &self.settings.mlt;
                format!(
                    "{} mutations per pixel per pass, bootstrap {} per depth, chains {}, large-step probability {}, target {}, acceptance rate {:.3}, {} of {} passes found no light",
                    m.mutations_per_pixel,
                    m.bootstrap_samples.map_or("default".into(), |n| n.to_string()),
                    m.chains.map_or("default".into(), |n| n.to_string()),
                    m.large_step_probability,
                    match m.target {
                        crate::integrator::mlt::MltTarget::Luminance => "luminance",
                        crate::integrator::mlt::MltTarget::Relative => "relative",
                    },
                    stats.acceptance_rate(),
                    stats.passes_without_light,
                    stats.passes
                )
            }),
            irradiance_cache: self.settings.irradiance_cache.map(|c| {
                let (m, n) = crate::integrator::irradiance_cache::gather_strata(c.gather_rays);
                format!(
                    "accuracy {}, {} gather rays per round ({m} × {n} strata), gradients {}, {} records",
                    c.accuracy,
                    m * n,
                    if c.gradients { "on" } else { "off" },
                    cache_stats.map_or(0, |s| s.records)
                )
            }),
            scene: self.source.display().to_string(),
            backend: self.backend.name(),
            samples: self.first_sample..self.spp_done,
            total_spp: self.settings.spp,
            light_tracing: self.settings.light_tracing,
            rays: self.backend.rays_traced()?,
            // Only a part is merged, so only a part pays for hashing the scene.
            scene_digest: self.shard.then(|| scene_digest(&self.flat)),
            merged: Vec::new(),
            film_state: self.shard,
            seed: self.settings.seed,
            integrator: self.settings.integrator,
            max_depth: self.settings.max_depth_bound(),
            sampler: self.settings.sampler,
            splits: self.settings.splits,
            render_seconds: self.seconds,
            rejected_samples: rejected,
            adaptive: self.adaptive.map(|a| {
                let mean = self.budgets.as_ref().map_or(0.0, |b| {
                    b.iter().map(|&n| n.min(self.spp_done) as f64).sum::<f64>() / b.len().max(1) as f64
                });
                format!(
                    "threshold {} (relative standard error per pixel), pilot of {} spp (the render's first samples of every pixel, kept; each pixel's count decided from its neighbours' pilot samples, not its own), mean {mean:.1} spp per pixel; sample counts per pixel in channel sampleCount",
                    a.threshold, a.min_spp,
                )
            }),
        })
    }

    /// Writes the film to each of `outputs` (.exr: linear with variance; .png: tone-mapped),
    /// with the AOVs and the denoised image the session's [`OutputOptions`] ask for.
    pub fn write(&mut self, outputs: &[PathBuf], tonemap: Tonemap, exposure: f32) -> Result<()> {
        let film = self.backend.film()?;
        let meta = self.metadata()?;
        let options = self.output_options;
        let (extras, timing) = self.extras(&film, &options)?;
        self.extras_timing = timing;
        for o in outputs {
            output::write_output_with(&film, &meta, &extras, options.aovs, o, tonemap, exposure)?;
        }
        Ok(())
    }

    /// Writes the film alone to each of `outputs`, without AOVs or denoising: what a failed
    /// render keeps (the AOV pass could fail the same way the render did).
    pub fn write_plain(&mut self, outputs: &[PathBuf], tonemap: Tonemap, exposure: f32) -> Result<()> {
        let film = self.backend.film()?;
        let meta = self.metadata()?;
        for o in outputs {
            write_output(&film, &meta, o, tonemap, exposure)?;
        }
        Ok(())
    }

    /// What the outputs carry beside the film.
    pub fn output_options(&self) -> OutputOptions {
        self.output_options
    }

    /// Changes what the outputs carry (a viewer that starts showing the denoised image). The
    /// GPU backend renders AOVs only when opened for them (`SessionOptions::outputs`).
    pub fn set_output_options(&mut self, options: OutputOptions) -> Result<()> {
        if options.needs_aovs() && !self.settings.aovs {
            return Err(Error::Settings(
                "this session was opened without AOVs: open it with SessionOptions::outputs asking for them"
                    .into(),
            ));
        }
        self.output_options = options;
        Ok(())
    }

    /// The AOVs through the current camera (rendered once per camera).
    pub fn aovs(&mut self) -> Result<Aovs> {
        if self.aov_cache.aovs.is_none() {
            let (w, h) = (self.settings.width, self.settings.height);
            let pixels = self.backend.aovs()?;
            self.aov_cache.aovs = Some(Aovs::from_pixels(w, h, &pixels));
        }
        Ok(self.aov_cache.aovs.clone().expect("set above"))
    }

    /// The film's mean denoised by `denoiser` (on a hardware GPU when the session renders
    /// on one, else on the CPU), and the seconds the AOVs and the denoiser took.
    pub fn denoised(
        &mut self,
        denoiser: crate::denoise::Denoiser,
    ) -> Result<(Vec<glam::Vec3>, ExtrasTiming)> {
        let film = self.backend.film()?;
        let options = OutputOptions { aovs: Default::default(), denoiser: Some(denoiser) };
        let (extras, timing) = self.extras(&film, &options)?;
        Ok((extras.denoised.expect("asked for").0, timing))
    }

    /// What the last [`Session::write`]'s AOVs and denoiser cost.
    pub fn extras_timing(&self) -> ExtrasTiming {
        self.extras_timing
    }

    /// The extras `options` ask for, for `film`.
    fn extras(&mut self, film: &Film, options: &OutputOptions) -> Result<(output::Extras, ExtrasTiming)> {
        let (w, h) = (self.settings.width, self.settings.height);
        let backend = &mut self.backend;
        // The à-trous iterations are image-sized passes: a hardware GPU runs them in
        // milliseconds, a software one (lavapipe) no faster than the CPU.
        let gpu = self.gpu.as_deref().filter(|g| g.is_hardware());
        output::make_extras(
            film,
            options,
            &mut self.aov_cache,
            || Ok(Aovs::from_pixels(w, h, &backend.aovs()?)),
            gpu,
        )
    }
}

/// Writes `film` to `path` by its extension.
pub fn write_output(
    film: &Film,
    meta: &RenderMetadata,
    path: &Path,
    tonemap: Tonemap,
    exposure: f32,
) -> Result<()> {
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        write_exr(film, meta, path)
    } else {
        write_png(film, path, tonemap, exposure)
    }
}

/// A digest of what a render of `flat` depends on (its triangles, normals, texture
/// coordinates, materials, lights, environment and camera): 64-bit FNV-1a over their bytes.
/// `pathlight merge` refuses parts whose digests differ, so shards of different scenes (or of
/// the same file seen through another camera or environment) are never merged.
pub fn scene_digest(flat: &FlatScene) -> u64 {
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            hash = (hash ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    eat(bytemuck::cast_slice(&flat.triangles));
    eat(bytemuck::cast_slice(&flat.normals));
    eat(bytemuck::cast_slice(&flat.texcoords));
    eat(bytemuck::cast_slice(&flat.materials));
    eat(bytemuck::cast_slice(&flat.lights));
    eat(bytemuck::bytes_of(&flat.environment.params));
    eat(bytemuck::cast_slice(&flat.environment.texels));
    eat(bytemuck::bytes_of(&flat.camera));
    hash
}
