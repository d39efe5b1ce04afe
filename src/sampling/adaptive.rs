//! Adaptive sampling without bias: each pixel's sample count is decided from a pilot render
//! whose samples are independent of the ones its estimate is made of.
//!
//! A pixel that stops when its own samples look converged has a sample count that depends
//! on them, and its mean is then biased: under a relative-error rule a pixel whose first
//! samples came out bright looks converged sooner and stops high (bench/RESULTS.md,
//! "Adaptive sampling inside the renderer: its gain on the glass scene is bias", measured
//! such a bias; [`tests`] shows it on a synthetic pixel). Here the decision is made once,
//! from a pilot of [`AdaptiveSettings::min_spp`] samples per pixel drawn with another seed
//! ([`pilot_seed`]): the pilot's samples are independent of the render's, so, given the
//! pilot, each pixel's count N is fixed, and the mean of its N render samples is unbiased
//! whatever N is. The pilot's samples are then dropped (its cost is the price of the
//! independence); the render's samples are the indices 0..N of the usual stream, so a pixel
//! given the most samples is bit-for-bit the pixel of a uniform render.
//!
//! The count: the pilot's per-sample relative variance of the pixel,
//! v = mean over channels of s²_c / (μ²_c + 10⁻²) (the benchmark's relMSE denominator), is
//! raised to the largest in its 5 × 5 neighbourhood (a pilot of a few samples misses rare
//! bright paths, a caustic seen in a few of a pixel's samples, but they come in patches) and
//! to a quarter of the image's mean (a pixel that looks noiseless in the pilot may not be:
//! without this floor, 38% of the mirror-and-glass box's pixels got fewer samples than a
//! uniform render gives them and carried two thirds of the error). Then
//! N = √(v · v̄) / T², with v̄ the image's mean: samples in proportion to √v are the split
//! that minimises the image's relMSE for the samples spent (Σ v/N at fixed Σ N), while
//! equalising every pixel's error (N ∝ v, a per-pixel threshold taken literally) spends
//! samples exactly as uselessly as uniform sampling does on the image's mean relMSE. So T
//! is the relative standard error of a pixel of the image's mean noise; a pixel k times
//! noisier (in variance) ends at T·k^¼. N is clamped to [`AdaptiveSettings::min_spp`] ..=
//! the render's `--spp`.

/// The pilot's variance is taken as the largest within this many pixels (module
/// documentation).
pub const ADAPTIVE_NEIGHBOURHOOD: usize = 2;
/// No pixel's variance is taken below this share of the image's mean (module
/// documentation).
pub const ADAPTIVE_VARIANCE_FLOOR: f64 = 0.25;

use crate::film::Film;

/// The default relative standard error of a pixel of mean noise (`--adaptive-threshold`):
/// 5%, about 100 samples per pixel on the Cornell box, a clean preview
/// (`bench/RESULTS.md`, "Adaptive sampling").
pub const DEFAULT_ADAPTIVE_THRESHOLD: f32 = 0.05;
/// The default pilot size, which is also the fewest samples any pixel gets
/// (`--adaptive-min-spp`): 8 samples estimate a pixel's variance only to about ±50% (χ² with
/// 7 degrees of freedom), which the 5 × 5 neighbourhood makes up for; a larger pilot is
/// samples thrown away.
pub const DEFAULT_ADAPTIVE_MIN_SPP: u32 = 8;

/// `--adaptive`'s settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSettings {
    /// The relative standard error of a pixel's mean to stop at (module documentation).
    pub threshold: f32,
    /// Samples per pixel of the pilot, and the fewest any pixel is given.
    pub min_spp: u32,
}

impl Default for AdaptiveSettings {
    fn default() -> Self {
        AdaptiveSettings { threshold: DEFAULT_ADAPTIVE_THRESHOLD, min_spp: DEFAULT_ADAPTIVE_MIN_SPP }
    }
}

impl AdaptiveSettings {
    /// Checks the settings against the render's most samples per pixel `spp`.
    pub fn validate(&self, spp: u32) -> crate::Result<()> {
        if !(self.threshold > 0.0 && self.threshold.is_finite()) {
            return Err(crate::Error::Settings(format!(
                "--adaptive-threshold must be positive and finite, not {}",
                self.threshold
            )));
        }
        if self.min_spp < 2 {
            return Err(crate::Error::Settings(format!(
                "--adaptive-min-spp must be at least 2 (a variance needs two samples), not {}",
                self.min_spp
            )));
        }
        if self.min_spp > spp {
            return Err(crate::Error::Settings(format!(
                "--adaptive-min-spp {} exceeds --spp {spp}, the most any pixel is given",
                self.min_spp
            )));
        }
        Ok(())
    }
}

/// The seed of the pilot render for a render of seed `seed`: another stream of the same
/// sampler, so that the pilot's samples are independent of the render's.
pub fn pilot_seed(seed: u32) -> u32 {
    super::hash_u32(seed ^ 0xad4f_7e11)
}

/// Each pixel's per-sample relative variance in `pilot` (module documentation), row-major.
pub fn relative_variance(pilot: &Film) -> Vec<f32> {
    pilot
        .pixels
        .iter()
        .map(|p| {
            if p.count < 2 {
                return f32::INFINITY;
            }
            let n = p.count as f32;
            (0..3).map(|c| p.m2[c] / (n - 1.0) / (p.mean[c] * p.mean[c] + 1e-2)).sum::<f32>() / 3.0
        })
        .collect()
}

/// Each pixel's sample count from `pilot` (module documentation): at least
/// `settings.min_spp`, at most `max_spp`.
pub fn sample_budgets(pilot: &Film, settings: &AdaptiveSettings, max_spp: u32) -> Vec<u32> {
    let (w, h) = (pilot.width as usize, pilot.height as usize);
    let v = relative_variance(pilot);
    let r = ADAPTIVE_NEIGHBOURHOOD;
    let smoothed: Vec<f64> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let mut most = 0.0f64;
            for qy in y.saturating_sub(r)..=(y + r).min(h - 1) {
                for qx in x.saturating_sub(r)..=(x + r).min(w - 1) {
                    most = most.max(v[qy * w + qx] as f64);
                }
            }
            most
        })
        .collect();
    let finite: Vec<f64> = smoothed.iter().copied().filter(|x| x.is_finite()).collect();
    let mean = finite.iter().sum::<f64>() / finite.len().max(1) as f64;
    let t2 = (settings.threshold as f64).powi(2);
    smoothed
        .iter()
        .map(|&variance| {
            let variance = variance.max(ADAPTIVE_VARIANCE_FLOOR * mean);
            let needed = ((variance * mean).sqrt() / t2).ceil();
            if needed.is_nan() || needed >= max_spp as f64 {
                max_spp
            } else {
                (needed as u32).clamp(settings.min_spp, max_spp)
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::film_add_sample;
    use crate::sampling::Rng;
    use glam::Vec3;

    /// A pixel whose samples are 0 with probability 0.9 and 10 otherwise (mean 1): the
    /// heavy-tailed kind of pixel adaptive sampling is for.
    fn draw(rng: &mut Rng) -> f32 {
        if rng.next_1d() < 0.1 {
            10.0
        } else {
            0.0
        }
    }

    /// One pixel's estimate, with its count decided either from its own first samples
    /// (naive) or from an independent pilot (pathlight's rule).
    fn estimate(trial: u32, independent: bool) -> f64 {
        let settings = AdaptiveSettings { threshold: 0.3, min_spp: 8 };
        let max_spp = 256;
        let mut pilot_rng = Rng::new(trial, 1, 0, 7);
        let mut render_rng = Rng::new(trial, 2, 0, 7);
        let mut pilot = Film::new(1, 1);
        let mut film = Film::new(1, 1);
        for k in 0..settings.min_spp {
            let rng = if independent { &mut pilot_rng } else { &mut render_rng };
            let x = draw(rng);
            film_add_sample(&mut pilot.pixels[0], Vec3::splat(x), k & 1);
            if !independent {
                // The naive rule keeps the samples it decided from.
                film_add_sample(&mut film.pixels[0], Vec3::splat(x), k & 1);
            }
        }
        let budget = sample_budgets(&pilot, &settings, max_spp)[0];
        while film.pixels[0].count < budget {
            let k = film.pixels[0].count;
            film_add_sample(&mut film.pixels[0], Vec3::splat(draw(&mut render_rng)), k & 1);
        }
        film.pixels[0].mean[0] as f64
    }

    fn mean_and_standard_error(independent: bool) -> (f64, f64) {
        let trials = 40_000u32;
        let xs: Vec<f64> = (0..trials).map(|t| estimate(t, independent)).collect();
        let mean = xs.iter().sum::<f64>() / trials as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (trials - 1) as f64;
        (mean, (var / trials as f64).sqrt())
    }

    /// The rule is unbiased, and the test can tell: deciding from a pixel's own samples is
    /// measurably biased on the same pixel (a pilot that saw no bright sample reads as
    /// noiseless and stops at 8 samples, all of them 0).
    #[test]
    fn counts_from_an_independent_pilot_leave_the_mean_unbiased_and_own_samples_do_not() {
        let (mean, se) = mean_and_standard_error(true);
        // 4σ: a false alarm once in 16,000 runs.
        assert!((mean - 1.0).abs() < 4.0 * se, "independent pilot: mean {mean} ± {se}, expected 1");
        let (naive, naive_se) = mean_and_standard_error(false);
        assert!(
            (naive - 1.0).abs() > 8.0 * naive_se,
            "the naive rule should be biased: {naive} ± {naive_se}"
        );
    }

    #[test]
    fn budgets_follow_the_variance_within_their_bounds() {
        // A row of 12 pixels, all of mean 1: pixel 9 alternates 0 and 2 (relative variance
        // v ≈ 1 per sample), the others are constant.
        let pilot_of = |noisy: f32| {
            let mut pilot = Film::new(12, 1);
            for (i, p) in pilot.pixels.iter_mut().enumerate() {
                for k in 0..16 {
                    let x = if i == 9 {
                        if k % 2 == 0 {
                            1.0 - noisy
                        } else {
                            1.0 + noisy
                        }
                    } else {
                        1.0
                    };
                    film_add_sample(p, Vec3::splat(x), k & 1);
                }
            }
            pilot
        };
        let settings = AdaptiveSettings { threshold: 0.1, min_spp: 16 };
        let budgets = sample_budgets(&pilot_of(1.0), &settings, 1024);
        // Pixels 7..=11 lie within 2 of the noisy one and take its v; the image's mean is
        // then 5v/12, which floors pixels 0..=6 at v̄/4. So the noisy five get
        // √(v·v̄)/T² and the calm seven √(v̄/4·v̄)/T² = v̄/(2T²), √(12/5)/(1/2) ≈ 3.1 times
        // fewer (each rounded up).
        assert!(budgets[..7].iter().all(|&n| n == budgets[0]), "{budgets:?}");
        assert!(budgets[7..].iter().all(|&n| n == budgets[9]), "{budgets:?}");
        let ratio = budgets[9] as f64 / budgets[0] as f64;
        assert!((3.0..3.2).contains(&ratio), "noisy ÷ calm = {ratio}: {budgets:?}");
        assert!(budgets[0] >= settings.min_spp);
        // A far noisier pixel takes the render's most.
        let budgets = sample_budgets(&pilot_of(1e3), &settings, 1024);
        assert_eq!(budgets[9], 1024, "{budgets:?}");
        assert!(budgets.iter().all(|&n| (16..=1024).contains(&n)), "{budgets:?}");
        assert!(AdaptiveSettings { threshold: 0.0, min_spp: 16 }.validate(64).is_err());
        assert!(AdaptiveSettings { threshold: 0.1, min_spp: 1 }.validate(64).is_err());
        assert!(AdaptiveSettings { threshold: 0.1, min_spp: 128 }.validate(64).is_err());
    }
}
