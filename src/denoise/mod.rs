//! Denoising: a clean image from few samples, guided by the auxiliary images
//! ([`crate::integrator::aov`]) and the variance every pathlight film carries.
//!
//! | denoiser | `--denoiser` | CPU | GPU |
//! |---|---|---|---|
//! | edge-avoiding à-trous wavelet filter, steered by each pixel's variance ([`atrous`]) | `atrous` (default) | [`atrous::denoise`] | `shaders/denoise.wgsl` ([`crate::gpu::denoise`]) |
//! | Intel Open Image Denoise's `RT` filter (the `oidn` cargo feature; `oidn.rs`) | `oidn` | its CPU device | its CUDA, HIP or SYCL device where one loads |
//!
//! A denoiser trades variance for bias: its output is no longer an unbiased estimate, so a
//! denoised image's error is measured against a converged reference, never predicted from
//! its variance channels (which keep describing the raw mean beside it).

pub mod atrous;
pub mod edges;
pub mod file;
#[cfg(feature = "oidn")]
pub mod oidn;

use glam::Vec3;

use crate::error::{Error, Result};
use crate::film::Aovs;

/// What a denoiser reads: the noisy mean, the variance of each pixel's mean, and the guides.
#[derive(Clone, Copy, Debug)]
pub struct DenoiseInput<'a> {
    pub width: u32,
    pub height: u32,
    /// Row-major from the top row, as the film.
    pub color: &'a [Vec3],
    /// The variance of each pixel's mean ([`crate::film::Film::variance_of_mean`]).
    pub variance: &'a [Vec3],
    pub aovs: &'a Aovs,
    /// Samples per pixel the colour averages (the mean over pixels where counts differ).
    pub spp: f32,
}

impl DenoiseInput<'_> {
    /// Fails unless every plane has one value per pixel and, when `needs_variance`, the
    /// variance is known somewhere (a render of one sample per pixel has none: nothing tells
    /// noise from detail).
    pub fn check(&self, needs_variance: bool) -> Result<()> {
        let n = self.width as usize * self.height as usize;
        let planes = [
            ("colour", self.color.len()),
            ("variance", self.variance.len()),
            ("albedo", self.aovs.albedo.len()),
            ("normal", self.aovs.normal.len()),
            ("depth", self.aovs.depth.len()),
        ];
        for (name, len) in planes {
            if len != n {
                return Err(Error::Settings(format!(
                    "denoising a {}×{} image: its {name} has {len} values",
                    self.width, self.height
                )));
            }
        }
        if needs_variance
            && self.variance.iter().all(|v| *v == Vec3::ZERO)
            && self.color.iter().any(|c| *c != Vec3::ZERO)
        {
            return Err(Error::Settings(
                "denoising needs each pixel's variance, and this image has none (rendered with one sample per pixel?): render at least 2".into(),
            ));
        }
        Ok(())
    }
}

/// Which denoiser (`--denoiser`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Denoiser {
    /// The built-in edge-avoiding à-trous filter ([`atrous`]).
    #[default]
    Atrous,
    /// Intel Open Image Denoise, in builds with the `oidn` feature; others refuse it by name.
    Oidn,
}

impl Denoiser {
    pub const ALL: [Denoiser; 2] = [Denoiser::Atrous, Denoiser::Oidn];

    pub fn name(self) -> &'static str {
        match self {
            Denoiser::Atrous => "atrous",
            Denoiser::Oidn => "oidn",
        }
    }

    /// Is it in this build? (`oidn` needs the `oidn` cargo feature.)
    pub fn available(self) -> bool {
        match self {
            Denoiser::Atrous => true,
            Denoiser::Oidn => cfg!(feature = "oidn"),
        }
    }

    /// Fails, saying how to get it, when the denoiser is not in this build: checked before a
    /// render, so that it is not found missing after one.
    pub fn check_available(self) -> Result<()> {
        if self.available() {
            return Ok(());
        }
        Err(Error::Settings(format!(
            "--denoiser {self}: this pathlight was built without Open Image Denoise; build it with \
             `--features oidn` (README, \"Denoising\")"
        )))
    }

    /// Does it read the depth AOV (Open Image Denoise reads albedo and normal only)?
    pub fn needs_depth(self) -> bool {
        self == Denoiser::Atrous
    }

    /// Does it read the variance (a film of one sample per pixel has none)?
    pub fn needs_variance(self) -> bool {
        self == Denoiser::Atrous
    }

    pub fn from_name(name: &str) -> Result<Denoiser> {
        Self::ALL.into_iter().find(|d| d.name() == name).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|d| d.name()).collect();
            Error::Settings(format!("unknown denoiser '{name}'; there are: {}", names.join(", ")))
        })
    }
}

impl std::fmt::Display for Denoiser {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Denoises `input` with `denoiser`, on the GPU of `gpu` where one is given, else on the CPU.
pub fn denoise(
    denoiser: Denoiser,
    input: &DenoiseInput,
    gpu: Option<&crate::gpu::GpuContext>,
) -> Result<Vec<Vec3>> {
    input.check(denoiser.needs_variance())?;
    match (denoiser, gpu) {
        (Denoiser::Atrous, None) => Ok(atrous::denoise(input)),
        (Denoiser::Atrous, Some(ctx)) => crate::gpu::denoise::denoise_atrous(ctx, input),
        #[cfg(feature = "oidn")]
        (Denoiser::Oidn, _) => oidn::denoise(input),
        #[cfg(not(feature = "oidn"))]
        (Denoiser::Oidn, _) => denoiser.check_available().map(|_| Vec::new()),
    }
}
