//! The backend-independent render loop: progressive passes into a film, with progress
//! reporting and a stop flag, so an interrupted render keeps every finished sample.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use crate::error::Result;
use crate::film::Film;
use crate::integrator::Integrator;
use crate::sampling::SamplerKind;

/// What to render. Shared by both backends.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// The estimator ([`crate::integrator`]).
    pub integrator: Integrator,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    pub seed: u32,
    /// Most scattering events per path; `None`: unlimited (Russian roulette ends paths).
    pub max_depth: Option<u32>,
    /// Russian roulette starts once a path has this many non-delta scattering events
    /// (`crate::integrator::IntegratorSettings::rr_min_depth`).
    pub rr_min_depth: u32,
    /// Where the paths' random numbers come from.
    pub sampler: SamplerKind,
    /// Continuations per camera sample, split at its first vertex with a non-delta lobe
    /// (trajectory splitting, `crate::integrator::path::radiance`); 1: none. A sample costs
    /// more and varies less: `spp` counts camera samples.
    pub splits: u32,
    /// Let a light tracer take the caustic paths where the scene allows it
    /// (`crate::integrator::supports_light_tracing`), on either backend.
    pub light_tracing: bool,
    /// Bidirectional path tracing only: render strategy (s, t) alone, with weight 1 and
    /// every other strategy left out (`--bdpt-strategy`): it then converges to the image of
    /// the paths it can make, which tests its densities apart from the weights.
    pub bdpt_strategy: Option<(u32, u32)>,
    /// Bidirectional path tracing only: keep each strategy's weighted contribution as an
    /// image of its own (`--bdpt-strategies`, `Backend::strategy_images`).
    pub record_strategies: bool,
    /// Will the AOVs be asked for (`Backend::aovs`; `--aov`, `--denoise`)? The GPU backend
    /// then holds a buffer of 48 bytes per pixel for them.
    pub aovs: bool,
    /// Will per-pixel sample counts be set (`Backend::set_sample_budgets`, `--adaptive`)? The
    /// GPU backend then holds a buffer of 4 bytes per pixel for them.
    pub adaptive: bool,
    /// Photon mapping: photons per pass for `sppm`, photons of the global map for `photon`
    /// (`--photons`); `None`: `integrator::sppm::DEFAULT_SPPM_PHOTONS_PER_PIXEL` per pixel
    /// (`sppm`), `integrator::photon::default_map_photons` (`photon`).
    pub photons: Option<u32>,
    /// `photon` only: photons traced for the caustic map (`--caustic-photons`); `None`:
    /// `integrator::photon::default_map_photons`.
    pub caustic_photons: Option<u32>,
    /// `photon` only: the photons a global-map estimate averages over (`--gather-photons`);
    /// `None`: `integrator::photon::DEFAULT_GATHER_PHOTONS`.
    pub gather_photons: Option<u32>,
    /// Photon mapping only: the initial gather radius in pixel footprints (`--sppm-radius`);
    /// `None`: `integrator::sppm::DEFAULT_SPPM_RADIUS_PIXELS`.
    pub sppm_radius: Option<f32>,
    /// The path tracer's irradiance cache (`--irradiance-cache`,
    /// `integrator::irradiance_cache`); `None`: none.
    pub irradiance_cache: Option<crate::integrator::irradiance_cache::IrradianceCacheSettings>,
    /// Metropolis's settings (`--mutations-per-pixel`, `--bootstrap-samples`, `--chains`,
    /// `--large-step`); only `--integrator mlt` reads them, and others refuse any but the
    /// defaults.
    pub mlt: crate::integrator::mlt::MltSettings,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            integrator: Integrator::default(),
            width: 512,
            height: 512,
            spp: 64,
            seed: 0,
            max_depth: None,
            rr_min_depth: crate::integrator::DEFAULT_RR_MIN_DEPTH,
            sampler: SamplerKind::default(),
            splits: 1,
            light_tracing: false,
            bdpt_strategy: None,
            record_strategies: false,
            aovs: false,
            adaptive: false,
            photons: None,
            caustic_photons: None,
            gather_photons: None,
            sppm_radius: None,
            irradiance_cache: None,
            mlt: crate::integrator::mlt::MltSettings::default(),
        }
    }
}

/// The most pixels an image may have: 2²⁸ (e.g. 16384²), a film of 8 GiB. Beyond that a
/// mistyped size would exhaust memory instead of failing clearly.
pub const MAX_PIXELS: u64 = 1 << 28;

/// The CPU backend's splitting factor unless told otherwise (`RenderSettings::splits`,
/// `--splits`), chosen by efficiency, 1 / (relMSE × seconds) at equal time, on the bundled
/// scenes (`bench/history/splitting.md`).
pub const CPU_DEFAULT_SPLITS: u32 = 4;

/// The GPU backend's splitting factor on a software rasteriser (lavapipe) unless told
/// otherwise, chosen by efficiency on the Cornell box (`bench/history/lavapipe.md`, "the
/// scene's small tables in uniform buffers").
pub const SOFTWARE_GPU_DEFAULT_SPLITS: u32 = 4;

/// The GPU backend's splitting factor on a hardware GPU unless told otherwise: not yet
/// measured on one. Continuation rays are as incoherent as bounce rays while camera rays
/// are coherent, so a GPU may lose rays per second to them; whether it gains is for a
/// session lent one to measure.
pub const HARDWARE_GPU_DEFAULT_SPLITS: u32 = 1;

/// What a render runs on, for the defaults that depend on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderDevice {
    Cpu,
    /// A Vulkan adapter that is a software rasteriser (adapter type CPU, such as lavapipe).
    SoftwareGpu,
    HardwareGpu,
}

impl RenderDevice {
    /// The CPU backend without a GPU context, else the context's kind of adapter.
    pub fn of(gpu: Option<&crate::gpu::GpuContext>) -> RenderDevice {
        match gpu {
            None => RenderDevice::Cpu,
            Some(ctx) if ctx.is_hardware() => RenderDevice::HardwareGpu,
            Some(_) => RenderDevice::SoftwareGpu,
        }
    }
}

/// The splitting factor a backend renders with unless told otherwise: the one place that
/// picks between [`CPU_DEFAULT_SPLITS`], [`SOFTWARE_GPU_DEFAULT_SPLITS`] and
/// [`HARDWARE_GPU_DEFAULT_SPLITS`], for `pathlight render` and the bench alike.
pub fn default_splits(device: RenderDevice) -> u32 {
    match device {
        RenderDevice::Cpu => CPU_DEFAULT_SPLITS,
        RenderDevice::SoftwareGpu => SOFTWARE_GPU_DEFAULT_SPLITS,
        RenderDevice::HardwareGpu => HARDWARE_GPU_DEFAULT_SPLITS,
    }
}

/// The most continuations a camera sample may be split into. More would rarely pay (the
/// prefix a split saves is one camera ray and its first vertex), and a mistyped count would
/// make one sample cost as much as a whole render.
pub const MAX_SPLITS: u32 = 64;

impl RenderSettings {
    /// Are samples split (`splits` > 1)? A GPU kernel must then be built able to split
    /// (`crate::gpu::Kernel::splitting`).
    pub fn splitting(&self) -> bool {
        self.splits > 1
    }

    /// The depth bound paths are rendered with: `max_depth`, or where none is given the
    /// integrator's own (Metropolis keeps one depth per chain, so it has one:
    /// `integrator::mlt::DEFAULT_MLT_MAX_DEPTH`); `None`: unlimited.
    pub fn max_depth_bound(&self) -> Option<u32> {
        self.max_depth
            .or((self.integrator == Integrator::Mlt).then_some(crate::integrator::mlt::DEFAULT_MLT_MAX_DEPTH))
    }

    /// Checks the settings are renderable, with a message naming the one that is not.
    pub fn validate(&self) -> Result<()> {
        if self.width == 0 || self.height == 0 {
            return Err(crate::Error::Settings("--width and --height must be at least 1".into()));
        }
        if self.width as u64 * self.height as u64 > MAX_PIXELS {
            return Err(crate::Error::Settings(format!(
                "{}×{} is {} pixels; at most {MAX_PIXELS} are supported",
                self.width,
                self.height,
                self.width as u64 * self.height as u64
            )));
        }
        if self.spp == 0 {
            return Err(crate::Error::Settings("--spp must be at least 1".into()));
        }
        if self.integrator != Integrator::Bdpt && (self.bdpt_strategy.is_some() || self.record_strategies) {
            return Err(crate::Error::Settings(format!(
                "--bdpt-strategy and --bdpt-strategies are options of --integrator bdpt, not of --integrator {}",
                self.integrator
            )));
        }
        if let Some((s, t)) = self.bdpt_strategy {
            if t == 0 || (s, t) == (1, 1) {
                return Err(crate::Error::Settings(format!(
                    "--bdpt-strategy {s},{t}: strategies have t ≥ 1 camera vertices, and (1, 1) is not one of bdpt's"
                )));
            }
        }
        let photon_mapping = matches!(self.integrator, Integrator::Sppm | Integrator::Photon);
        if !photon_mapping && self.photons.is_some() {
            return Err(crate::Error::Settings(format!(
                "--photons is an option of --integrator sppm and photon, not of --integrator {}",
                self.integrator
            )));
        }
        if self.integrator != Integrator::Sppm && self.sppm_radius.is_some() {
            return Err(crate::Error::Settings(format!(
                "--sppm-radius is an option of --integrator sppm, not of --integrator {}",
                self.integrator
            )));
        }
        if self.integrator != Integrator::Photon
            && (self.caustic_photons.is_some() || self.gather_photons.is_some())
        {
            return Err(crate::Error::Settings(format!(
                "--caustic-photons and --gather-photons are options of --integrator photon, not of --integrator {}",
                self.integrator
            )));
        }
        for (name, n) in [("--photons", self.photons), ("--caustic-photons", self.caustic_photons)] {
            if let Some(n) = n {
                if !(1..=crate::integrator::sppm::MAX_PHOTONS_PER_PASS).contains(&n) {
                    return Err(crate::Error::Settings(format!(
                        "{name} must be between 1 and {}, not {n}",
                        crate::integrator::sppm::MAX_PHOTONS_PER_PASS
                    )));
                }
            }
        }
        if let Some(k) = self.gather_photons {
            if !(1..=4096).contains(&k) {
                return Err(crate::Error::Settings(format!(
                    "--gather-photons is how many photons a global-map estimate averages: 1 to 4096, not {k}"
                )));
            }
        }
        if let Some(r) = self.sppm_radius {
            if !(r.is_finite() && r > 0.0 && r <= 1e4) {
                return Err(crate::Error::Settings(format!(
                    "--sppm-radius is the initial gather radius in pixel footprints: a number in (0, 10000], not {r}"
                )));
            }
        }
        if photon_mapping && self.max_depth.is_some() {
            return Err(crate::Error::Settings(format!(
                "--max-depth is not supported by --integrator {} yet: its camera paths and photons \
                 split a path's bounces between them",
                self.integrator
            )));
        }
        if self.adaptive && self.integrator != Integrator::Path {
            return Err(crate::Error::Settings(format!(
                "--adaptive renders with --integrator path only, not {}: a bidirectional pass \
                 normalises its light-to-camera splats by one light subpath per pixel, and photon \
                 mapping's passes share photons among all pixels, which a pixel that stops would \
                 take away",
                self.integrator
            )));
        }
        if let Some(cache) = &self.irradiance_cache {
            if self.integrator != Integrator::Path {
                return Err(crate::Error::Settings(format!(
                    "--irradiance-cache is an option of --integrator path, not of --integrator {}",
                    self.integrator
                )));
            }
            cache.validate()?;
            if self.max_depth.is_some() {
                return Err(crate::Error::Settings(
                    "--max-depth is not supported with --irradiance-cache: a record's gather is shared by \
                     camera paths of any depth"
                        .into(),
                ));
            }
            if self.splits > 1 {
                return Err(crate::Error::Settings(format!(
                    "--splits {} with --irradiance-cache: the cache already gives the first Lambertian \
                     vertex's indirect light, so its path is not split (--splits 1)",
                    self.splits
                )));
            }
            if self.adaptive {
                return Err(crate::Error::Settings(
                    "--adaptive with --irradiance-cache: the cache's error is bias, which more samples in a pixel do not remove".into(),
                ));
            }
        }
        if self.integrator == Integrator::Mlt {
            self.mlt.validate()?;
            let most = crate::integrator::mlt::MAX_MLT_DEPTH;
            if self.max_depth.is_some_and(|d| d > most) {
                return Err(crate::Error::Settings(format!(
                    "--max-depth {} with --integrator mlt: each Markov chain keeps one path depth, \
                     and depths above {most} are not supported (a light subpath holds at most {} vertices)",
                    self.max_depth.unwrap_or(0),
                    crate::integrator::bdpt::BDPT_MAX_VERTICES
                )));
            }
        } else if self.mlt != crate::integrator::mlt::MltSettings::default() {
            return Err(crate::Error::Settings(format!(
                "--mutations-per-pixel, --bootstrap-samples, --chains, --large-step and --mlt-target are \
                 options of --integrator mlt, not of --integrator {}",
                self.integrator
            )));
        }
        if !(1..=MAX_SPLITS).contains(&self.splits) {
            return Err(crate::Error::Settings(format!(
                "--splits must be between 1 and {MAX_SPLITS}, not {}",
                self.splits
            )));
        }
        Ok(())
    }
}

/// A renderer that adds samples to its own film.
pub trait Backend {
    /// Human-readable name (recorded in outputs).
    fn name(&self) -> String;
    /// Adds samples `sample_offset .. sample_offset + samples` to every pixel.
    fn render(&mut self, sample_offset: u32, samples: u32) -> Result<()>;
    /// The film as accumulated so far.
    fn film(&mut self) -> Result<Film>;
    /// Rays traced so far (camera and bounce rays, and shadow rays), for throughput.
    fn rays_traced(&mut self) -> Result<u64>;
    /// Bidirectional path tracing's per-strategy images, when the settings asked for them
    /// ([`RenderSettings::record_strategies`]).
    fn strategy_images(&mut self) -> Result<Option<crate::integrator::bdpt::StrategyImages>> {
        Ok(None)
    }
    /// Every pixel's auxiliary images (`crate::integrator::aov`), row-major from the top row,
    /// through the current camera.
    fn aovs(&mut self) -> Result<Vec<crate::scene::layout::PixelAov>>;
    /// What the photon passes counted (`None` for other integrators).
    fn sppm_stats(&mut self) -> Option<crate::integrator::sppm::SppmStats> {
        None
    }
    /// What placing the irradiance cache counted (`None` without one).
    fn irradiance_cache_stats(
        &mut self,
    ) -> Option<crate::integrator::irradiance_cache::IrradianceCacheStats> {
        None
    }
    /// The pixels whose camera paths placed the irradiance cache's records
    /// (`--ic-show-records`; `None` without a cache).
    fn irradiance_record_pixels(&mut self) -> Option<Vec<(u32, u32)>> {
        None
    }
    /// What bidirectional path tracing counted (`None` for other integrators).
    fn bdpt_stats(&mut self) -> Option<crate::integrator::bdpt::BdptStats> {
        None
    }
    /// What Metropolis's passes counted (`None` for other integrators).
    fn mlt_stats(&mut self) -> Option<crate::integrator::mlt::MltStats> {
        None
    }
    /// Adds sample `sample_index` to the pixels of image rows `rows` only: bounded work, for
    /// a viewer that must stay responsive (a pixel's samples stay in order, so rendering
    /// every row for each index in turn gives the same film as [`Backend::render`]).
    fn render_rows(&mut self, sample_index: u32, rows: std::ops::Range<u32>) -> Result<()>;
    /// Forgets every sample: the film and the ray counts return to zero.
    fn reset(&mut self) -> Result<()>;
    /// From now on, pixel i takes sample indices below `budgets[i]` only (adaptive sampling,
    /// `crate::sampling::adaptive`); `None`: every pixel takes every sample. A backend must
    /// have been opened with [`RenderSettings::adaptive`].
    fn set_sample_budgets(&mut self, budgets: Option<&[u32]>) -> Result<()> {
        let _ = budgets;
        Err(crate::Error::Settings(format!("the {} backend does not do adaptive sampling", self.name())))
    }
    /// Renders from now on through `camera` (callers [`Backend::reset`] as well).
    fn set_camera(&mut self, camera: &crate::scene::layout::Camera) -> Result<()>;
}

/// Rays one sample can trace at most: a closest-hit and a shadow ray per bounce up to
/// `integrator::MAX_BOUNCES_GUARD`, and the camera ray. It bounds how many samples a per-pixel
/// `u32` ray counter can take before it must be folded into a 64-bit total.
pub const MAX_RAYS_PER_SAMPLE: u64 = 2 * crate::integrator::MAX_BOUNCES_GUARD as u64 + 1;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderStats {
    /// Samples per pixel completed.
    pub spp: u32,
    pub seconds: f64,
    /// Stopped early by the stop flag.
    pub interrupted: bool,
}

/// Passes are sized to take about this long, so progress and interruption stay responsive
/// without per-pass overhead dominating.
const TARGET_PASS_SECONDS: f64 = 0.5;

/// Renders `spp` samples per pixel in progressive passes. `progress(done)` is called after
/// each pass; when `stop` becomes true the loop ends after the pass in flight.
pub fn render_progressive(
    backend: &mut dyn Backend,
    spp: u32,
    stop: &AtomicBool,
    mut progress: impl FnMut(u32),
) -> Result<RenderStats> {
    render_progressive_with(backend, spp, stop, |_, done, _| {
        progress(done);
        Ok(false)
    })
}

/// [`render_progressive`] with a checkpoint after every pass: `checkpoint(backend, done,
/// seconds)` may read the film and returns `true` to stop (a time limit or an error target
/// reached). Passes end exactly at 1, 2, 4, 8, … samples per pixel, so a convergence log can
/// be taken there; the image does not depend on how the work is split.
pub fn render_progressive_with(
    backend: &mut dyn Backend,
    spp: u32,
    stop: &AtomicBool,
    checkpoint: impl FnMut(&mut dyn Backend, u32, f64) -> Result<bool>,
) -> Result<RenderStats> {
    render_progressive_from(backend, 0, spp, stop, checkpoint)
}

/// [`render_progressive_with`] for a film that already holds `start` samples per pixel
/// (a session resumed after an interruption): renders samples `start .. spp`.
pub fn render_progressive_from(
    backend: &mut dyn Backend,
    start_spp: u32,
    spp: u32,
    stop: &AtomicBool,
    mut checkpoint: impl FnMut(&mut dyn Backend, u32, f64) -> Result<bool>,
) -> Result<RenderStats> {
    let start = Instant::now();
    let mut done = start_spp;
    let mut pass = 1u32;
    while done < spp {
        if stop.load(Ordering::Relaxed) {
            return Ok(RenderStats { spp: done, seconds: start.elapsed().as_secs_f64(), interrupted: true });
        }
        let next_power_of_two = (done + 1).next_power_of_two();
        let n = pass.min(spp - done).min(next_power_of_two - done);
        let t = Instant::now();
        backend.render(done, n)?;
        done += n;
        if checkpoint(backend, done, start.elapsed().as_secs_f64())? {
            // Stopped by the caller's own criterion: not an interruption.
            return Ok(RenderStats { spp: done, seconds: start.elapsed().as_secs_f64(), interrupted: false });
        }
        let per_sample = t.elapsed().as_secs_f64() / n as f64;
        // Grow at most 2× per pass so one slow pass cannot overshoot badly.
        let ideal = if per_sample > 0.0 { TARGET_PASS_SECONDS / per_sample } else { f64::MAX };
        pass = (ideal as u32).clamp(1, pass.saturating_mul(2));
    }
    Ok(RenderStats { spp: done, seconds: start.elapsed().as_secs_f64(), interrupted: false })
}
