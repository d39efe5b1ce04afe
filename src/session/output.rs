//! What a session writes beside the film's mean and variance: the auxiliary images
//! (`--aov`) and a denoised image (`--denoise`), and the writing of both into EXR and PNG.
//!
//! The AOVs depend only on the camera and the seed, so a session computes them once per
//! camera ([`AovCache`]); the denoised image depends on the film and is made anew for each
//! write.

use std::path::Path;
use std::time::Instant;

use glam::Vec3;

use crate::denoise::{DenoiseInput, Denoiser};
use crate::error::Result;
use crate::film::{
    write_exr_with, write_png, write_png_rgb, AovSelection, Aovs, ExrExtras, Film, RenderMetadata, Tonemap,
};

/// The extras a session's outputs carry (`SessionOptions::outputs`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OutputOptions {
    /// The AOV channels the EXR gets (`--aov`); none by default.
    pub aovs: AovSelection,
    /// Denoise with this (`--denoise`, `--denoiser`): the EXR's `R`, `G`, `B` and the PNG are
    /// then the denoised image.
    pub denoiser: Option<Denoiser>,
}

impl OutputOptions {
    /// Does writing need the AOV pass (AOVs written, or a denoiser guided by them)?
    pub fn needs_aovs(&self) -> bool {
        self.aovs.any() || self.denoiser.is_some()
    }
}

/// A session's AOVs for the camera they were rendered through.
#[derive(Default)]
pub(super) struct AovCache {
    pub aovs: Option<Aovs>,
}

/// What the last write's extras cost, for the user (`Session::extras_timing`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExtrasTiming {
    /// Seconds of the AOV pass (0 when cached or not needed).
    pub aov_seconds: f64,
    /// Seconds of the denoiser (0 without one).
    pub denoise_seconds: f64,
}

/// The extras of one write: the AOVs and the denoised image, both owned.
pub(super) struct Extras {
    pub aovs: Option<Aovs>,
    pub denoised: Option<(Vec<Vec3>, Denoiser)>,
}

/// Denoises `film`'s mean with `denoiser`, guided by `aovs`; the à-trous filter runs on `gpu`
/// where one is given.
pub fn denoise_film(
    film: &Film,
    aovs: &Aovs,
    denoiser: Denoiser,
    gpu: Option<&crate::gpu::GpuContext>,
) -> Result<Vec<Vec3>> {
    let color = film.mean();
    let variance = film.variance_of_mean();
    let input = DenoiseInput {
        width: film.width,
        height: film.height,
        color: &color,
        variance: &variance,
        aovs,
        spp: (film.total_samples() as f64 / film.pixels.len().max(1) as f64) as f32,
    };
    crate::denoise::denoise(denoiser, &input, gpu)
}

/// Makes the extras `options` ask for: the AOVs through `render_aovs` unless cached, then the
/// denoised image. Returns them with what they cost.
pub(super) fn make_extras(
    film: &Film,
    options: &OutputOptions,
    cache: &mut AovCache,
    render_aovs: impl FnOnce() -> Result<Aovs>,
    gpu: Option<&crate::gpu::GpuContext>,
) -> Result<(Extras, ExtrasTiming)> {
    let mut timing = ExtrasTiming::default();
    if !options.needs_aovs() {
        return Ok((Extras { aovs: None, denoised: None }, timing));
    }
    if cache.aovs.is_none() {
        let t = Instant::now();
        cache.aovs = Some(render_aovs()?);
        timing.aov_seconds = t.elapsed().as_secs_f64();
    }
    let aovs = cache.aovs.clone().expect("computed above");
    let denoised = match options.denoiser {
        Some(denoiser) => {
            let t = Instant::now();
            let image = denoise_film(film, &aovs, denoiser, gpu)?;
            timing.denoise_seconds = t.elapsed().as_secs_f64();
            Some((image, denoiser))
        }
        None => None,
    };
    Ok((Extras { aovs: Some(aovs), denoised }, timing))
}

/// Writes `film` to `path` by its extension, with `extras`: the EXR gets the AOVs `selection`
/// names and, when denoised, the denoised image as `R`, `G`, `B`; the PNG is the denoised image
/// when there is one.
pub(super) fn write_output_with(
    film: &Film,
    meta: &RenderMetadata,
    extras: &Extras,
    selection: AovSelection,
    path: &Path,
    tonemap: Tonemap,
    exposure: f32,
) -> Result<()> {
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        let exr_extras = ExrExtras {
            aovs: extras.aovs.as_ref().filter(|_| selection.any()).map(|a| (a, selection)),
            denoised: extras.denoised.as_ref().map(|(image, d)| (&image[..], *d)),
        };
        write_exr_with(film, meta, &exr_extras, path)
    } else {
        match &extras.denoised {
            Some((image, _)) => write_png_rgb(film.width, film.height, image, path, tonemap, exposure),
            None => write_png(film, path, tonemap, exposure),
        }
    }
}
