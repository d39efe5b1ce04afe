//! The integrators: the estimators of the rendering equation that turn a scene into pixel
//! values, and what they share.
//!
//! | integrator | `--integrator` | CPU half | WGSL twin |
//! |---|---|---|---|
//! | unidirectional path tracing with next-event estimation and MIS, its caustics optionally left to a light tracer | `path` | [`path`], [`light_tracing`] | `shaders/path.wgsl`, `shaders/light_tracing.wgsl` |
//! | bidirectional path tracing, every strategy weighted by MIS | `bdpt` | [`bdpt`] | `shaders/bdpt.wgsl` |
//! | stochastic progressive photon mapping (biased, consistent) | `sppm` | [`sppm`] | none yet: the GPU backend refuses it |
//! | photon mapping: caustic and global maps, final gather (biased) | `photon` | [`photon`] | none yet: the GPU backend refuses it |
//! | Metropolis light transport over BDPT's strategies, multiplexed (primary sample space) | `mlt` | [`mlt`] | none yet: the GPU backend refuses it |
//! | the path tracer with an irradiance cache for the first Lambertian vertex's indirect light (biased) | `path --irradiance-cache` | [`irradiance_cache`] | `shaders/irradiance_cache.wgsl`: the lookup and the placement passes (first vertices, gather rays) |
//!
//! What every integrator shares lives beside them, each with a WGSL twin of the same name:
//! * [`interaction`]: the surface record built at every path vertex and the side test of a
//!   sampled direction (`shaders/interaction.wgsl`);
//! * [`mis`]: multiple importance sampling weights (`shaders/mis.wgsl`);
//! * [`roulette`]: Russian roulette and the bounce limits (`shaders/roulette.wgsl`);
//! * [`partition`]: which paths the path tracer leaves to the light tracer
//!   (`shaders/partition.wgsl`);
//! * [`aov`]: the auxiliary images (albedo, normal, depth) a denoiser and a compositor read,
//!   the same whichever integrator renders (`shaders/aov.wgsl`).
//!
//! A new integrator (bidirectional path tracing, Metropolis, photon mapping, irradiance
//! caching, …) adds a variant to [`Integrator`], its CPU half as one file here, and its WGSL
//! twin as one file in `shaders/` with the same name, listed by
//! `crate::gpu::shader::integrator_files`: the GPU kernel is composed and cached per
//! integrator as it is specialised per scene feature. Both backends dispatch on
//! [`crate::RenderSettings::integrator`].

pub mod aov;
pub mod bdpt;
pub mod delta_view;
pub mod gather_area;
pub mod interaction;
pub mod irradiance_cache;
pub mod light_tracing;
pub mod mis;
pub mod mlt;
pub mod partition;
pub mod path;
pub mod photon;
pub mod roulette;
pub mod sppm;

pub use interaction::{first_hit, sides_agree, surface_interaction, SurfaceInteraction};
pub use light_tracing::{
    caustic_from_fixed, caustic_to_fixed, trace_caustic_pass, CausticSums, CAUSTIC_FRACTION_BITS,
    CAUSTIC_MAX_FIXED, CAUSTIC_SUM_WORDS, LIGHT_PATH_STREAM, LIGHT_RR_MIN_VERTICES,
};
pub use mis::power_heuristic;
pub use partition::{camera_supports_light_tracing, scene_supports_light_tracing, supports_light_tracing};
pub use path::radiance;
pub use roulette::{DEFAULT_RR_MIN_DEPTH, MAX_BOUNCES_GUARD, RR_ANY_BOUNCE_DEPTH, RR_MAX_SURVIVAL};

/// Which estimator renders the image (`--integrator`, [`crate::RenderSettings::integrator`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Integrator {
    /// Unidirectional path tracing with next-event estimation and MIS (Veach 1997, ch. 9),
    /// its caustics left to a light tracer where the scene allows it
    /// (`crate::RenderSettings::light_tracing`).
    #[default]
    Path,
    /// Bidirectional path tracing with every strategy weighted by MIS (Veach 1997, ch. 10;
    /// [`bdpt`]).
    Bdpt,
    /// Stochastic progressive photon mapping (Hachisuka & Jensen 2009; [`sppm`]): biased,
    /// its bias shrinking with the passes; CPU only so far.
    Sppm,
    /// Photon mapping with a caustic map, a global map and a final gather (Jensen 1996;
    /// [`photon`]): biased, its maps fixed for the render; CPU only so far.
    Photon,
    /// Multiplexed Metropolis light transport over the bidirectional strategies (Kelemen et
    /// al. 2002; Hachisuka et al. 2014; [`mlt`]): consistent, paths up to a depth bound;
    /// CPU only so far.
    Mlt,
}

impl Integrator {
    /// Every integrator, in the order `--integrator` lists them.
    pub const ALL: [Integrator; 5] =
        [Integrator::Path, Integrator::Bdpt, Integrator::Sppm, Integrator::Photon, Integrator::Mlt];

    /// The name `--integrator` takes and outputs record.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Path => "path",
            Integrator::Bdpt => "bdpt",
            Integrator::Sppm => "sppm",
            Integrator::Photon => "photon",
            Integrator::Mlt => "mlt",
        }
    }

    /// Does the GPU backend have a kernel for it? Where it has none the GPU backend refuses
    /// it and `--backend auto` renders it on the CPU.
    pub fn has_gpu_kernel(self) -> bool {
        match self {
            Integrator::Path | Integrator::Bdpt | Integrator::Sppm | Integrator::Photon | Integrator::Mlt => {
                true
            }
        }
    }

    /// Does it join light paths to the camera (t = 1), so that a camera seeing only delta
    /// surfaces has it skip them (`super::delta_view`)?
    pub fn joins_camera(self) -> bool {
        matches!(self, Integrator::Bdpt | Integrator::Mlt)
    }

    /// Is it unbiased? A biased integrator's variance channels measure its noise, not its
    /// error; its bias is stated where it is built.
    pub fn is_unbiased(self) -> bool {
        match self {
            Integrator::Path | Integrator::Bdpt => true,
            Integrator::Sppm | Integrator::Photon | Integrator::Mlt => false,
        }
    }

    /// What the EXR's variance channels measure under this integrator
    /// (`pathlight.variance`).
    pub fn variance_meaning(self) -> &'static str {
        match self {
            Integrator::Path | Integrator::Bdpt => "the sample variance of each pixel's independent samples",
            Integrator::Sppm => {
                "the spread of each pixel's per-pass estimates (each at its pass's photon radius): noise only; \
                 the bias of the radius is not in it, nor in the predicted error"
            }
            Integrator::Mlt => mlt::VARIANCE_MEANING,
            Integrator::Photon => {
                "the sample variance of each pixel's samples given the render's photon maps: noise only; \
                 the maps' bias (their radii and their own noise) is not in it, nor in the predicted error"
            }
        }
    }

    /// The integrator called `name`, or an error listing those there are.
    pub fn from_name(name: &str) -> crate::Result<Integrator> {
        Self::ALL.into_iter().find(|i| i.name() == name).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|i| i.name()).collect();
            crate::Error::Settings(format!("unknown integrator '{name}'; there are: {}", names.join(", ")))
        })
    }
}

impl std::fmt::Display for Integrator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What one sample of an integrator needs to know of the render settings, per backend.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntegratorSettings {
    /// Most scattering events (`u32::MAX`: unlimited).
    pub max_depth: u32,
    /// Russian roulette starts once a path has this many non-delta scattering events
    /// (mirror and glass bounces do not count; [`roulette`]), or [`RR_ANY_BOUNCE_DEPTH`]
    /// events of any kind.
    pub rr_min_depth: u32,
    /// Continuations per camera sample from its first vertex with a non-delta lobe (1: no
    /// splitting; [`path::radiance`]).
    pub splits: u32,
    /// Leave the caustic paths to the light tracer ([`partition`]): a path whose
    /// first vertex scattered by a non-delta lobe and which reaches an emissive triangle
    /// through a delta lobe adds nothing here. Only for scenes the light tracer supports,
    /// and only with its pass added to every sample (the kernel's twin is
    /// `frame.light_traced_caustics`).
    pub caustics_by_light_tracing: bool,
    /// Bidirectional path tracing: strategy (s, t) alone, unweighted
    /// (`crate::RenderSettings::bdpt_strategy`).
    pub only_strategy: Option<(u32, u32)>,
    /// Bidirectional path tracing joins light vertices to the camera (t = 1): false where
    /// the camera sees only delta surfaces and no such join can contribute
    /// ([`delta_view`]).
    pub camera_connections: bool,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        IntegratorSettings {
            max_depth: u32::MAX,
            rr_min_depth: DEFAULT_RR_MIN_DEPTH,
            splits: 1,
            caustics_by_light_tracing: false,
            only_strategy: None,
            camera_connections: true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Integrator;

    #[test]
    fn integrators_are_found_by_name_and_unknown_names_list_the_known_ones() {
        for i in Integrator::ALL {
            assert_eq!(Integrator::from_name(i.name()).unwrap(), i);
        }
        let e = Integrator::from_name("bdpt-typo").unwrap_err().to_string();
        assert!(e.contains("unknown integrator 'bdpt-typo'") && e.contains("path"), "{e}");
    }
}
