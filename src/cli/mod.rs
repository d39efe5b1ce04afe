//! The `pathlight` command line: one module per command, each with its argument types; the
//! work itself is the library's ([`pathlight::session`], [`pathlight::bench`],
//! [`pathlight::viewer`], [`pathlight::film`]).

use std::path::PathBuf;

use clap::ValueEnum;

use pathlight::denoise::Denoiser;
use pathlight::film::AovSelection;
use pathlight::integrator::Integrator;
use pathlight::scene::LoadOptions;
use pathlight::session::{EnvironmentChoice, OutputOptions, SessionOptions};

/// `println!` for the command line's standard output: when the reader has gone away
/// (`pathlight info | head -3`) the process ends quietly with status 141, as a Unix tool
/// ended by SIGPIPE does, instead of panicking; never 0, so a `compare` verdict cannot be
/// misreported.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout(), $($arg)*) {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(141);
            }
            eprintln!("error: cannot write to standard output: {e}");
            std::process::exit(2);
        }
    }};
}

pub mod bench;
pub mod compare;
pub mod denoise;
pub mod info;
pub mod merge;
pub mod render;
pub mod view;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SamplerChoice {
    /// Owen-scrambled Sobol points: lower error at the same spp. The EXR's variance
    /// channels then over-state the error (a conservative z-test); the predicted error
    /// comes from two independent replicates and stays right.
    Sobol,
    /// Independent random numbers: the EXR's variance is exactly the mean's.
    Independent,
}

/// `--mlt-target` (`pathlight::integrator::mlt::MltTarget`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum MltTargetChoice {
    /// Each path's luminance weighed by its pixel's importance, 1 / √(Ī² + 0.01) with Ī the
    /// image so far (Hoberock & Hart 2010): mutations spread so that dim pixels' relative
    /// error falls with the bright ones'.
    Relative,
    /// Each path's luminance (Veach, pbrt-v4): mutations in proportion to brightness.
    Luminance,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BackendChoice {
    /// The fastest present: a hardware GPU if there is one; else (only a software Vulkan
    /// rasteriser such as lavapipe, or no Vulkan at all) the CPU backend, saying why.
    Auto,
    /// The WGSL megakernel on a Vulkan device, software rasterisers included.
    Gpu,
    /// The CPU reference renderer.
    Cpu,
}

/// The scene and render options `render` and `view` share.
#[derive(clap::Args)]
pub struct SceneArgs {
    /// The scene (.gltf or .glb).
    pub scene: PathBuf,
    /// Image width (default 512; derived from the camera's aspect ratio if only --height is given).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (default 512; derived from the camera's aspect ratio if only --width is given).
    #[arg(long)]
    pub height: Option<u32>,
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    pub backend: BackendChoice,
    /// GPU: use the first Vulkan adapter whose name contains this (case-insensitive).
    #[arg(long)]
    pub device: Option<String>,
    /// The estimator of the rendering equation (`src/integrator/` lists them).
    #[arg(long, default_value = "path", value_parser = parse_integrator())]
    pub integrator: Integrator,
    /// Random seed; the same seed gives the same image.
    #[arg(long, default_value_t = 0)]
    pub seed: u32,
    /// Most scattering events per path (default: unlimited; Russian roulette ends paths).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Where the paths' random numbers come from.
    #[arg(long, value_enum, default_value_t = SamplerChoice::Sobol)]
    pub sampler: SamplerChoice,
    // The help names the defaults from the constants that set them, so the two cannot drift.
    #[arg(long, help = splits_help())]
    pub splits: Option<u32>,
    /// Path trace the caustics too. By default both backends leave them (paths from a
    /// diffuse first hit that reach a light through glass or a mirror) to a light tracer
    /// where the scene allows it.
    #[arg(long)]
    pub no_light_tracing: bool,
    /// With --integrator bdpt: render strategy S,T alone (S light and T camera vertices),
    /// unweighted: it converges to the image of the paths it can make (a test of its
    /// densities).
    #[arg(long, value_name = "S,T", value_parser = parse_strategy)]
    pub bdpt_strategy: Option<(u32, u32)>,
    /// With --integrator sppm: photons traced per pass (default: two per pixel); with
    /// --integrator photon: photons traced for the global map (default: four per pixel, at
    /// least 262,144).
    #[arg(long, value_name = "N")]
    pub photons: Option<u32>,
    /// With --integrator photon: photons traced for the caustic map, of which its caustic
    /// landings are kept (default: four per pixel, at least 262,144).
    #[arg(long, value_name = "N")]
    pub caustic_photons: Option<u32>,
    /// With --integrator photon: the photons a global-map estimate averages over, which
    /// sets its radius (default 32).
    #[arg(long, value_name = "K")]
    pub gather_photons: Option<u32>,
    /// With --integrator sppm: the initial photon gather radius, in pixel footprints at
    /// each pixel's first visible point (default 3).
    #[arg(long, value_name = "PIXELS")]
    pub sppm_radius: Option<f32>,
    /// With --integrator path: give the first diffuse vertex's indirect light from an
    /// irradiance cache (records placed before the render, interpolated with gradients):
    /// biased, smooth long before path tracing stops being noisy. Records are placed on the
    /// host for either backend.
    #[arg(long)]
    pub irradiance_cache: bool,
    /// With --irradiance-cache: each record's validity radius is this times its radius (the
    /// harmonic mean distance of its gather rays, clamped between 3 pixels and a tenth of
    /// the image height); smaller is tighter and slower (default 1).
    #[arg(long, value_name = "A", requires = "irradiance_cache")]
    pub ic_accuracy: Option<f32>,
    /// With --irradiance-cache: gather rays per record, rounded to M × 3M strata (default
    /// 768, 16 × 48).
    #[arg(long, value_name = "N", requires = "irradiance_cache")]
    pub ic_rays: Option<u32>,
    /// With --irradiance-cache: interpolate without the rotational and translational
    /// gradients (for comparison).
    #[arg(long, requires = "irradiance_cache")]
    pub ic_no_gradients: bool,
    /// With --integrator mlt: Markov-chain mutations per pixel in each pass (each sample
    /// index is an independent pass with its own bootstrap and chains; default 4).
    #[arg(long, value_name = "N")]
    pub mutations_per_pixel: Option<u32>,
    /// With --integrator mlt: bootstrap samples per path depth in each pass, which estimate
    /// its normalisation and seed its chains (default: a quarter of the pass's mutations
    /// over the depths, at least 64).
    #[arg(long, value_name = "N")]
    pub bootstrap_samples: Option<u32>,
    /// With --integrator mlt: Markov chains per pass (default: one per 1024 mutations).
    #[arg(long, value_name = "N")]
    pub chains: Option<u32>,
    /// With --integrator mlt: the probability that a mutation is a large step, an
    /// independent sample (default 0.1).
    #[arg(long, value_name = "P")]
    pub large_step: Option<f32>,
    /// With --integrator mlt: what the chains' target weighs each path by (default:
    /// relative).
    #[arg(long, value_enum, value_name = "TARGET")]
    pub mlt_target: Option<MltTargetChoice>,
    /// Camera index in the file (default: the first camera, or one framing the scene).
    #[arg(long)]
    pub camera: Option<usize>,
    /// Let the scene's external files (buffers, images) be anywhere, not only inside its
    /// folder. Only for scenes you trust: see "Untrusted input" in the README.
    #[arg(long)]
    pub allow_any_path: bool,
    /// Environment light: an equirectangular .hdr or .exr map (+Y up, Mitsuba 3's convention).
    #[arg(long, conflicts_with = "background")]
    pub env: Option<PathBuf>,
    /// Scale of the environment map's radiance.
    #[arg(long, default_value_t = 1.0, requires = "env")]
    pub env_intensity: f32,
    /// Rotation of the environment map about +Y, in degrees.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, requires = "env")]
    pub env_rotation: f32,
    /// A constant environment of this linear radiance, e.g. 0.5,0.5,0.5.
    #[arg(long, value_parser = parse_rgb)]
    pub background: Option<glam::Vec3>,
    /// Auxiliary images in the EXR, comma-separated: albedo (albedo.R/G/B), normal
    /// (normal.X/Y/Z, world space), depth (depth.Z, distance from the camera), emission
    /// (emission.R/G/B and coverage.Y), or all.
    #[arg(long, value_name = "LIST", value_parser = parse_aovs)]
    pub aov: Option<AovSelection>,
    /// Denoise the image, guided by its albedo and normal: the EXR's R, G, B and the PNG are
    /// then the denoised image, the raw mean stays in raw.R/G/B beside its variance, and the
    /// AOVs that guided it (albedo, normal, depth, emission) are written too.
    #[arg(long)]
    pub denoise: bool,
    /// The denoiser --denoise runs: atrous (built in, on every machine) or oidn (Intel Open
    /// Image Denoise, in builds with the `oidn` feature).
    #[arg(long, default_value = "atrous", value_parser = parse_denoiser(), requires = "denoise")]
    pub denoiser: Denoiser,
}

impl SceneArgs {
    /// The session these options ask for, aiming at `spp` samples per pixel.
    pub fn session_options(&self, spp: u32) -> SessionOptions {
        SessionOptions {
            scene: self.scene.clone(),
            load: LoadOptions { allow_any_path: self.allow_any_path },
            environment: match (&self.env, self.background) {
                (Some(path), _) => EnvironmentChoice::Map {
                    path: path.clone(),
                    intensity: self.env_intensity,
                    rotation_degrees: self.env_rotation,
                },
                (None, Some(rgb)) => EnvironmentChoice::Constant(rgb),
                (None, None) => EnvironmentChoice::None,
            },
            camera: self.camera,
            width: self.width,
            height: self.height,
            spp,
            samples: None,
            seed: self.seed,
            integrator: self.integrator,
            max_depth: self.max_depth,
            splits: self.splits,
            light_tracing: !self.no_light_tracing,
            bdpt_strategy: self.bdpt_strategy,
            record_strategies: false,
            photons: self.photons,
            sppm_radius: self.sppm_radius,
            caustic_photons: self.caustic_photons,
            gather_photons: self.gather_photons,
            irradiance_cache: self.irradiance_cache.then(|| {
                let defaults = pathlight::integrator::irradiance_cache::IrradianceCacheSettings::default();
                pathlight::integrator::irradiance_cache::IrradianceCacheSettings {
                    accuracy: self.ic_accuracy.unwrap_or(defaults.accuracy),
                    gather_rays: self.ic_rays.unwrap_or(defaults.gather_rays),
                    gradients: !self.ic_no_gradients,
                }
            }),
            mlt: {
                let defaults = pathlight::integrator::mlt::MltSettings::default();
                pathlight::integrator::mlt::MltSettings {
                    mutations_per_pixel: self.mutations_per_pixel.unwrap_or(defaults.mutations_per_pixel),
                    bootstrap_samples: self.bootstrap_samples,
                    chains: self.chains,
                    large_step_probability: self.large_step.unwrap_or(defaults.large_step_probability),
                    target: match self.mlt_target {
                        None => defaults.target,
                        Some(MltTargetChoice::Relative) => pathlight::integrator::mlt::MltTarget::Relative,
                        Some(MltTargetChoice::Luminance) => pathlight::integrator::mlt::MltTarget::Luminance,
                    },
                }
            },
            sampler: match self.sampler {
                SamplerChoice::Sobol => pathlight::sampling::SamplerKind::Sobol,
                SamplerChoice::Independent => pathlight::sampling::SamplerKind::Independent,
            },
            backend: match self.backend {
                BackendChoice::Auto => pathlight::session::BackendChoice::Auto,
                BackendChoice::Gpu => pathlight::session::BackendChoice::Gpu,
                BackendChoice::Cpu => pathlight::session::BackendChoice::Cpu,
            },
            device: self.device.clone(),
            outputs: self.output_options(),
            adaptive: None,
            aovs_available: false,
        }
    }

    /// The AOVs and the denoiser the outputs carry: with --denoise, the albedo and normal
    /// that guided it are written too, so that the file can be denoised again.
    pub fn output_options(&self) -> OutputOptions {
        let mut aovs = self.aov.unwrap_or_default();
        if self.denoise {
            aovs = aovs.with(AovSelection::ALL);
        }
        OutputOptions { aovs, denoiser: self.denoise.then_some(self.denoiser) }
    }
}

/// Parses `--aov`'s list.
fn parse_aovs(s: &str) -> Result<AovSelection, String> {
    AovSelection::parse(s).map_err(|e| e.to_string())
}

/// `--denoiser`'s parser: the names of [`Denoiser::ALL`].
pub fn parse_denoiser() -> impl clap::builder::TypedValueParser<Value = Denoiser> {
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(Denoiser::ALL.map(Denoiser::name))
        .map(|name| Denoiser::from_name(&name).expect("one of the possible values"))
}

/// Parses `S,T`.
fn parse_strategy(s: &str) -> Result<(u32, u32), String> {
    let (a, b) = s.split_once(',').ok_or("expected S,T, e.g. 2,2")?;
    let parse = |x: &str| x.trim().parse::<u32>().map_err(|e| format!("'{x}': {e}"));
    Ok((parse(a)?, parse(b)?))
}

/// `--integrator`'s parser: the names of [`Integrator::ALL`], so that the list cannot drift.
fn parse_integrator() -> impl clap::builder::TypedValueParser<Value = Integrator> {
    use clap::builder::TypedValueParser as _;
    clap::builder::PossibleValuesParser::new(Integrator::ALL.map(Integrator::name))
        .map(|name| Integrator::from_name(&name).expect("one of the possible values"))
}

/// Parses `R,G,B` (three finite, non-negative numbers).
fn parse_rgb(s: &str) -> Result<glam::Vec3, String> {
    let parts: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>().map_err(|e| format!("'{p}': {e}")))
        .collect::<Result<_, _>>()?;
    match parts[..] {
        [r, g, b] if parts.iter().all(|v| v.is_finite() && *v >= 0.0) => Ok(glam::Vec3::new(r, g, b)),
        _ => Err("expected three non-negative numbers R,G,B".into()),
    }
}

/// `--splits`' help, with the backends' defaults read from the constants that set them.
fn splits_help() -> String {
    format!(
        "Continuations per camera sample, split at its first vertex with a non-delta lobe \
         (trajectory splitting; 1: none). --spp counts camera samples. Default: the backend's, \
         chosen by measured efficiency ({} on the CPU, {} on a software GPU such as lavapipe, {} on \
         a hardware GPU)",
        pathlight::render::CPU_DEFAULT_SPLITS,
        pathlight::render::SOFTWARE_GPU_DEFAULT_SPLITS,
        pathlight::render::HARDWARE_GPU_DEFAULT_SPLITS
    )
}
