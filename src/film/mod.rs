//! The film: per-pixel running mean and variance (and the replicates' error), and image
//! output.
//!
//! WGSL twin of the accumulation: `film_add_sample` in `shaders/film.wgsl`.

mod aov;
pub mod compare;
pub(crate) mod convergence;
mod diff_image;
mod exr_io;
mod image;
pub mod merge;
mod png_io;
pub mod state;
mod tonemap;

use glam::Vec3;

pub use aov::{aov_channels, aovs_from_channels, AovSelection, Aovs};
pub use compare::{compare_images, CompareOptions, CompareReport};
pub use convergence::{convergence_csv, convergence_json, error_against, predicted_relmse, ConvergenceRow};
pub use diff_image::{write_diff_png, write_zmap_exr};
pub use exr_io::{
    read_exr, write_denoised_copy, write_exr, write_exr_with, write_rgb_exr, ExrExtras, ExrImage,
    RenderMetadata, PREDICTED_RELMSE_ATTRIBUTE,
};
pub use image::LinearImage;
pub use merge::{merge_files, merge_parts, MergeReport};
pub use png_io::{write_png, write_png_rgb};
pub use state::{read_film, read_film_file, read_film_header, FilmFile, FilmHeader};
pub use tonemap::{linear_to_srgb, Tonemap};

use crate::scene::layout::FilmPixel;

/// Adds sample `x` of replicate `replicate` (0 or 1, [`crate::sampling::replicate_of`]) to
/// a pixel by Welford's update (Welford 1962): stable in f32 for millions of samples because
/// it accumulates deviations from the running mean, not raw sums. Non-finite samples are
/// never accumulated; they are counted in `rejected`.
pub fn film_add_sample(p: &mut FilmPixel, x: Vec3, replicate: u32) {
    if !x.is_finite() {
        p.rejected += 1;
        return;
    }
    p.count += 1;
    let n = p.count as f32;
    let mean = Vec3::from(p.mean);
    let delta = x - mean;
    let mean = mean + delta / n;
    let m2 = Vec3::from(p.m2) + delta * (x - mean);
    p.mean = mean.to_array();
    p.m2 = m2.to_array();
    if replicate == 1 {
        p.odd_count += 1;
        let odd_mean = Vec3::from(p.odd_mean);
        p.odd_mean = (odd_mean + (x - odd_mean) / p.odd_count as f32).to_array();
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first.
    pub pixels: Vec<FilmPixel>,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Film {
        Film { width, height, pixels: vec![FilmPixel::default(); width as usize * height as usize] }
    }

    pub fn pixel(&self, x: u32, y: u32) -> &FilmPixel {
        &self.pixels[(y * self.width + x) as usize]
    }

    /// Mean radiance per pixel.
    pub fn mean(&self) -> Vec<Vec3> {
        self.pixels.iter().map(|p| Vec3::from(p.mean)).collect()
    }

    /// Estimated variance of each pixel's mean: sample variance / n = M2 / ((n − 1) n).
    /// Zero where fewer than two samples were taken (no estimate exists).
    pub fn variance_of_mean(&self) -> Vec<Vec3> {
        self.pixels.iter().map(pixel_variance_of_mean).collect()
    }

    /// The variance of each pixel's mean measured from its two replicates, or `None` while
    /// some pixel lacks a sample of either.
    ///
    /// With replicate means A (n_A samples) and B (n_B), independent and unbiased, and the
    /// pixel's mean M = (n_A·A + n_B·B)/n: E[(A − B)²] = Var A + Var B, and with each
    /// variance falling as 1/n_r, Var M = (A − B)²·n_A·n_B/n² (= (A − B)²/4 for equal
    /// halves). One degree of freedom per pixel: far too noisy for a per-pixel test, but
    /// unbiased, so its mean over an image predicts the image's error. Unlike the sample
    /// variance it stays right when the samples of a pixel are stratified (QMC), where the
    /// sample variance over-states the error.
    pub fn replicate_variance_of_mean(&self) -> Option<Vec<Vec3>> {
        self.pixels.iter().map(pixel_replicate_variance_of_mean).collect()
    }

    /// The image's predicted relMSE, as [`predicted_relmse`] gives it for
    /// [`LinearImage::from_film`] (the same numbers in the same order), without building
    /// that image: a film may hold 2²⁸ pixels, and the image would be three more arrays of
    /// its size. From the replicates where every pixel has both, else from the sample
    /// variance where every pixel has two samples; `None` otherwise.
    pub fn predicted_relmse(&self) -> Option<f64> {
        let sample_variance = |p: &FilmPixel| (p.count >= 2).then(|| pixel_variance_of_mean(p));
        let sum =
            self.relmse_sum(pixel_replicate_variance_of_mean).or_else(|| self.relmse_sum(sample_variance))?;
        Some(sum / (self.pixels.len() * 3) as f64)
    }

    /// Σ over pixels and channels of the relMSE term with each pixel's `variance` of its
    /// mean, added in [`predicted_relmse`]'s order; `None` at the first pixel without one.
    fn relmse_sum(&self, variance: impl Fn(&FilmPixel) -> Option<Vec3>) -> Option<f64> {
        self.pixels.iter().try_fold(0.0f64, |mut sum, p| {
            let v = variance(p)?;
            for c in 0..3 {
                sum += convergence::relmse_term(p.mean[c], v[c]);
            }
            Some(sum)
        })
    }

    /// Samples accumulated over all pixels.
    pub fn total_samples(&self) -> u64 {
        self.pixels.iter().map(|p| p.count as u64).sum()
    }

    /// Non-finite samples dropped over all pixels.
    pub fn total_rejected(&self) -> u64 {
        self.pixels.iter().map(|p| p.rejected as u64).sum()
    }
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, then a rename, so a
/// reader never sees a half-written image and an old image survives a failed write.
pub fn write_atomically(
    path: &std::path::Path,
    write: impl FnOnce(&std::path::Path) -> crate::Result<()>,
) -> crate::Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let result = write(&tmp).and_then(|_| std::fs::rename(&tmp, path).map_err(|e| crate::Error::io(path, e)));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Fails unless an image can be written to `path` the way [`write_atomically`] will: its
/// folder exists and takes a new file, and `path` is not a folder. Called before rendering,
/// so that a typo in `-o` costs nothing.
pub fn check_writable(path: &std::path::Path) -> crate::Result<()> {
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(std::path::Path::new("."));
    if !dir.is_dir() {
        return Err(crate::Error::Settings(format!(
            "{}: cannot write there: the folder {} does not exist",
            path.display(),
            dir.display()
        )));
    }
    if path.is_dir() {
        return Err(crate::Error::Settings(format!("{}: is a folder, not an image file", path.display())));
    }
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let probe = dir.join(format!(".{name}.probe-{}", std::process::id()));
    match std::fs::OpenOptions::new().write(true).create_new(true).open(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(crate::Error::Settings(format!("{}: cannot write there: {e}", path.display()))),
    }
}

/// [`Film::variance_of_mean`] of one pixel.
fn pixel_variance_of_mean(p: &FilmPixel) -> Vec3 {
    if p.count < 2 {
        Vec3::ZERO
    } else {
        let n = p.count as f32;
        Vec3::from(p.m2) / ((n - 1.0) * n)
    }
}

/// [`Film::replicate_variance_of_mean`] of one pixel.
fn pixel_replicate_variance_of_mean(p: &FilmPixel) -> Option<Vec3> {
    let (n_odd, n) = (p.odd_count as f32, p.count as f32);
    let n_even = n - n_odd;
    if n_odd == 0.0 || n_even == 0.0 {
        return None;
    }
    let odd = Vec3::from(p.odd_mean);
    let even = (Vec3::from(p.mean) * n - odd * n_odd) / n_even;
    let d = even - odd;
    Some(d * d * (n_even * n_odd / (n * n)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welford_matches_two_pass_statistics() {
        let mut p = FilmPixel::default();
        let xs: Vec<f32> = (0..1000).map(|i| 1000.0 + (i as f32 * 0.37).sin()).collect();
        for (i, &x) in xs.iter().enumerate() {
            film_add_sample(&mut p, Vec3::splat(x), i as u32 & 1);
        }
        film_add_sample(&mut p, Vec3::new(f32::NAN, 0.0, 0.0), 1);
        film_add_sample(&mut p, Vec3::splat(f32::INFINITY), 1);
        let n = xs.len() as f64;
        let mean = xs.iter().map(|&x| x as f64).sum::<f64>() / n;
        let m2: f64 = xs.iter().map(|&x| (x as f64 - mean).powi(2)).sum();
        assert_eq!(p.count, 1000);
        assert_eq!(p.rejected, 2);
        // f32 Welford keeps the mean to a few ulps of 1000 (≈ 6e-5 each) ...
        assert!((p.mean[0] as f64 - mean).abs() < 1e-3);
        // ... and M2 (≈ 500 here) to well under a percent, where the naive Σx² − n·mean²
        // in f32 would lose every digit (Σx² ≈ 1e9, ulp 64).
        assert!((p.m2[0] as f64 - m2).abs() / m2 < 1e-3, "{} vs {m2}", p.m2[0]);
        let odd: Vec<f64> = xs.iter().skip(1).step_by(2).map(|&x| x as f64).collect();
        assert_eq!(p.odd_count, 500);
        assert!((p.odd_mean[0] as f64 - odd.iter().sum::<f64>() / 500.0).abs() < 1e-3);
    }

    /// The replicates' variance of the mean is unbiased: over many pixels of independent
    /// unit-variance samples its mean is 1/n. With 20,000 pixels of one-degree-of-freedom
    /// estimates the relative standard error is √(2/20000) = 1%, so 5% is 5σ.
    #[test]
    fn replicate_variance_is_unbiased() {
        let n = 16;
        let mut film = Film::new(200, 100);
        let mut rng = crate::sampling::Rng::new(1, 2, 3, 4);
        for p in &mut film.pixels {
            for k in 0..n {
                // Uniform on [0, √12): variance 1.
                let x = rng.next_1d() * 12f32.sqrt();
                film_add_sample(p, Vec3::splat(x), k & 1);
            }
        }
        let v = film.replicate_variance_of_mean().unwrap();
        let mean = v.iter().map(|v| v.x as f64).sum::<f64>() / v.len() as f64;
        assert!((mean * n as f64 - 1.0).abs() < 0.05, "{}", mean * n as f64);
        assert!(Film::new(2, 2).replicate_variance_of_mean().is_none());
    }

    /// The film's own predicted relMSE is the image's, bit for bit, whichever variance it
    /// rests on: both replicates in every pixel, one replicate only (the sample variance),
    /// or a pixel with a single sample (none).
    #[test]
    fn film_predicts_the_relmse_its_image_does() {
        let mut rng = crate::sampling::Rng::new(5, 6, 7, 8);
        for (samples, replicates) in [(6, 2), (6, 1), (1, 2)] {
            let mut film = Film::new(13, 7);
            for p in &mut film.pixels {
                for k in 0..samples {
                    let x = Vec3::new(rng.next_1d(), 3.0 * rng.next_1d(), 0.01 * rng.next_1d());
                    film_add_sample(p, x, k % replicates);
                }
            }
            let want = predicted_relmse(&LinearImage::from_film(&film));
            assert_eq!(
                film.predicted_relmse().map(f64::to_bits),
                want.map(f64::to_bits),
                "{samples} {replicates}"
            );
            assert_eq!(want.is_some(), samples > 1, "{samples} {replicates}");
        }
    }
}
