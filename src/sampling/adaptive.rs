//! Adaptive sampling without bias: each pixel's sample count is decided from samples
//! independent of the ones its estimate is made of.
//!
//! A pixel that stops when its own samples look converged has a sample count that depends
//! on them, and its mean is then biased: under a relative-error rule a pixel whose first
//! samples came out bright looks converged sooner and stops high (bench/RESULTS.md,
//! "Adaptive sampling inside the renderer: its gain on the glass scene is bias", measured
//! such a bias; [`tests`] shows it on synthetic pixels). Here the decision is made once,
//! after a pilot: the render's own first [`AdaptiveSettings::min_spp`] samples of every
//! pixel. Pixel p's count is decided from its *neighbours'* pilot samples only, never from
//! its own ([`sample_budgets`] leaves p out of every statistic p's count reads, the image's
//! mean included). Each pixel's samples are drawn from its own scrambled stream, independent
//! of every other pixel's, so given the neighbours' pilots p's count N is fixed, and the
//! mean of p's N samples, its pilot among them, is unbiased whatever N is. The pilot's
//! samples are kept (until 2026-12-06 the pilot was a separate render with another seed,
//! thrown away: a sixth to a third of an adaptive render's samples), and a pixel given the
//! most samples is bit-for-bit the pixel of a uniform render.
//!
//! One coupling is left, and it is below any measurement: under light tracing, a pass's n
//! light paths (n = the pixels) land one pixel each, so a neighbour's light-traced splat
//! says that one path did not land on p, which moves p's expected light-traced share of
//! that pass by a part in n (1/16,384 at 128²).
//!
//! The count: a pixel's per-sample relative variance in the pilot,
//! v = mean over channels of s²_c / (μ²_c + 10⁻²) (the benchmark's relMSE denominator), is
//! taken as the largest in its 5 × 5 neighbourhood (p itself left out: a pilot of a few
//! samples misses rare bright paths, a caustic seen in a few of a pixel's samples, but they
//! come in patches) and raised to a quarter of the image's mean (a pixel that looks
//! noiseless in the pilot may not be: without this floor, 38% of the mirror-and-glass box's
//! pixels got fewer samples than a uniform render gives them and carried two thirds of the
//! error). Then N = √(v · v̄) / T², with v̄ the image's mean of those neighbourhood values:
//! samples in proportion to √v are the split that minimises the image's relMSE for the
//! samples spent (Σ v/N at fixed Σ N), while equalising every pixel's error (N ∝ v, a
//! per-pixel threshold taken literally) spends samples exactly as uselessly as uniform
//! sampling does on the image's mean relMSE. So T is the relative standard error of a
//! pixel of the image's mean noise; a pixel k times noisier (in variance) ends at T·k^¼. N
//! is clamped to [`AdaptiveSettings::min_spp`] ..= the render's `--spp`; a pixel with no
//! neighbour (a one-pixel image) has nothing to decide from and takes `--spp`.

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
/// (`--adaptive-min-spp`): 16. Since the pilot is kept, it costs only the samples the calm
/// pixels would not have needed, and 16 samples read a pixel's variance better than 8 (χ²
/// with 15 degrees of freedom, about ±35%): at equal time on this VM's CPU a 16-spp pilot
/// gained more than an 8-spp one in 5 of 6 runs at thresholds 0.1 and 0.05
/// (bench/RESULTS.md, "Adaptive sampling").
pub const DEFAULT_ADAPTIVE_MIN_SPP: u32 = 16;

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

/// Each pixel's sample count from `pilot`, a film holding at least the pilot's samples of
/// every pixel (module documentation): at least `settings.min_spp`, at most `max_spp`. Pixel
/// p's count does not depend on p's own samples.
pub fn sample_budgets(pilot: &Film, settings: &AdaptiveSettings, max_spp: u32) -> Vec<u32> {
    budgets_from_variance(
        &relative_variance(pilot),
        pilot.width as usize,
        pilot.height as usize,
        settings,
        max_spp,
        true,
    )
}

/// The counts from each pixel's relative variance `v` (row-major, `w` × `h`). With
/// `leave_own_out` false a pixel's own v counts too: the biased rule, kept for the test
/// that shows its bias.
fn budgets_from_variance(
    v: &[f32],
    w: usize,
    h: usize,
    settings: &AdaptiveSettings,
    max_spp: u32,
    leave_own_out: bool,
) -> Vec<u32> {
    let r = ADAPTIVE_NEIGHBOURHOOD;
    let window = |i: usize| {
        let (x, y) = (i % w, i / w);
        (y.saturating_sub(r)..=(y + r).min(h - 1))
            .flat_map(move |qy| (x.saturating_sub(r)..=(x + r).min(w - 1)).map(move |qx| qy * w + qx))
    };
    // Each pixel's neighbourhood: its largest v, where it is, and the largest without it
    // (what the neighbourhood reads when that pixel is left out).
    let top: Vec<(f64, usize, f64)> = (0..w * h)
        .map(|i| {
            let (mut first, mut at, mut second) = (f64::NEG_INFINITY, usize::MAX, f64::NEG_INFINITY);
            for q in window(i) {
                let x = v[q] as f64;
                if x > first {
                    (second, first, at) = (first, x, q);
                } else if x > second {
                    second = x;
                }
            }
            (first, at, second)
        })
        .collect();
    // The image's mean over the finite neighbourhood values: their sum and count.
    let finite = |x: f64| x.is_finite().then_some(x);
    let (sum, count) =
        top.iter().filter_map(|t| finite(t.0)).fold((0.0f64, 0usize), |(s, n), x| (s + x, n + 1));
    let t2 = (settings.threshold as f64).powi(2);
    (0..w * h)
        .map(|p| {
            let (variance, mean) = if leave_own_out {
                // The largest v around p without p; and the image's mean as it would be
                // without p: the neighbourhoods p lies in (those of the pixels in p's own, the
                // window being symmetric) read their largest without it.
                let neighbours =
                    window(p).filter(|&q| q != p).map(|q| v[q] as f64).fold(f64::NEG_INFINITY, f64::max);
                let (mut s, mut n) = (sum, count as f64);
                for q in window(p) {
                    let (first, at, second) = top[q];
                    let without = if at == p { second } else { first };
                    if let Some(x) = finite(first) {
                        (s, n) = (s - x, n - 1.0);
                    }
                    if let Some(x) = finite(without) {
                        (s, n) = (s + x, n + 1.0);
                    }
                }
                (neighbours, if n > 0.0 { s / n } else { f64::NAN })
            } else {
                (top[p].0, sum / count.max(1) as f64)
            };
            let variance = variance.max(ADAPTIVE_VARIANCE_FLOOR * mean);
            let needed = ((variance * mean).sqrt() / t2).ceil();
            if !needed.is_finite() || needed >= max_spp as f64 {
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

    /// A pixel sample that is 0 with probability 0.9 and 10 otherwise (mean 1): the
    /// heavy-tailed kind of pixel adaptive sampling is for.
    fn draw(rng: &mut Rng) -> f32 {
        if rng.next_1d() < 0.1 {
            10.0
        } else {
            0.0
        }
    }

    /// A row of four such pixels, each with its own stream: a pilot of 8 samples each, the
    /// counts decided with or without each pixel's own pilot, every pixel taken on to its
    /// count with its pilot kept (as `Session` renders). The row's mean estimate.
    fn row_estimate(trial: u32, leave_own_out: bool) -> f64 {
        let settings = AdaptiveSettings { threshold: 0.3, min_spp: 8 };
        let (w, max_spp) = (4usize, 256);
        let mut rngs: Vec<Rng> = (0..w as u32).map(|x| Rng::new(x, 0, trial, 7)).collect();
        let mut film = Film::new(w as u32, 1);
        for (pixel, rng) in film.pixels.iter_mut().zip(&mut rngs) {
            for k in 0..settings.min_spp {
                film_add_sample(pixel, Vec3::splat(draw(rng)), k & 1);
            }
        }
        let v = relative_variance(&film);
        let budgets = budgets_from_variance(&v, w, 1, &settings, max_spp, leave_own_out);
        for ((pixel, rng), budget) in film.pixels.iter_mut().zip(&mut rngs).zip(budgets) {
            while pixel.count < budget {
                let k = pixel.count;
                film_add_sample(pixel, Vec3::splat(draw(rng)), k & 1);
            }
        }
        film.pixels.iter().map(|p| p.mean[0] as f64).sum::<f64>() / w as f64
    }

    fn mean_and_standard_error(leave_own_out: bool) -> (f64, f64) {
        let trials = 40_000u32;
        let xs: Vec<f64> = (0..trials).map(|t| row_estimate(t, leave_own_out)).collect();
        let mean = xs.iter().sum::<f64>() / trials as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (trials - 1) as f64;
        (mean, (var / trials as f64).sqrt())
    }

    /// The rule is unbiased with the pilot kept, and the test can tell: counting each
    /// pixel's own pilot in its count is measurably biased on the same pixels (a row whose
    /// pilots saw no bright sample reads as noiseless and stops at 8 samples, all of them 0).
    #[test]
    fn counts_from_the_neighbours_leave_the_mean_unbiased_and_own_samples_do_not() {
        let (mean, se) = mean_and_standard_error(true);
        // 4σ: a false alarm once in 16,000 runs.
        assert!((mean - 1.0).abs() < 4.0 * se, "own samples left out: mean {mean} ± {se}, expected 1");
        let (naive, naive_se) = mean_and_standard_error(false);
        assert!(
            (naive - 1.0).abs() > 8.0 * naive_se,
            "counting a pixel's own samples should be biased: {naive} ± {naive_se}"
        );
    }

    /// A 16 × 12 pilot of varied pixels (deterministic).
    fn varied_pilot() -> Film {
        let mut film = Film::new(16, 12);
        for (i, pixel) in film.pixels.iter_mut().enumerate() {
            let mut rng = Rng::new(i as u32, 3, 0, 11);
            let spread = (i % 7) as f32 * 0.3;
            for k in 0..8 {
                film_add_sample(pixel, Vec3::splat(1.0 + spread * (rng.next_1d() - 0.5)), k & 1);
            }
        }
        film
    }

    /// The property the unbiasedness rests on, pixel by pixel: whatever a pixel's own pilot
    /// samples are (calm, a firefly, or too few for a variance), its count is the same;
    /// counting its own samples (the naive rule) would not leave it so.
    #[test]
    fn a_pixels_own_samples_never_change_its_count() {
        let settings = AdaptiveSettings { threshold: 0.05, min_spp: 8 };
        let pilot = varied_pilot();
        let budgets = sample_budgets(&pilot, &settings, 4096);
        let (w, h) = (16, 12);
        let mut naive_changed = 0;
        for p in [0usize, 5, 17, 40, 100, 191] {
            for own in [&[1.0f32; 8][..], &[0.0, 0.0, 0.0, 500.0, 0.0, 0.0, 0.0, 0.0], &[3.0]] {
                let mut film = pilot.clone();
                film.pixels[p] = Default::default();
                for (k, &x) in own.iter().enumerate() {
                    film_add_sample(&mut film.pixels[p], Vec3::splat(x), k as u32 & 1);
                }
                let changed = sample_budgets(&film, &settings, 4096);
                assert_eq!(changed[p], budgets[p], "pixel {p}'s count moved with its own samples {own:?}");
                let naive =
                    |f: &Film| budgets_from_variance(&relative_variance(f), w, h, &settings, 4096, false)[p];
                naive_changed += (naive(&film) != naive(&pilot)) as usize;
            }
        }
        assert!(naive_changed >= 6, "the naive rule should follow a pixel's own firefly: {naive_changed}");
    }

    #[test]
    fn budgets_follow_the_variance_within_their_bounds() {
        // A row of 12 pixels, all of mean 1: pixels 8, 9 and 10 alternate 1 ± `noisy`
        // (relative variance v ≈ 1 per sample at noisy = 1), the others are constant.
        let pilot_of = |noisy: f32| {
            let mut pilot = Film::new(12, 1);
            for (i, p) in pilot.pixels.iter_mut().enumerate() {
                for k in 0..16 {
                    let sign = if k % 2 == 0 { -1.0 } else { 1.0 };
                    let x = if (8..=10).contains(&i) { 1.0 + sign * noisy } else { 1.0 };
                    film_add_sample(p, Vec3::splat(x), k & 1);
                }
            }
            pilot
        };
        let settings = AdaptiveSettings { threshold: 0.1, min_spp: 16 };
        let budgets = sample_budgets(&pilot_of(1.0), &settings, 1024);
        // Pixels 6..=11 have a noisy pixel within 2 besides themselves and take v; the
        // image's mean of the neighbourhoods' largest is then 6v/12 = v/2, which floors
        // pixels 0..=5 at v/8. So the noisy side gets √(v · v/2)/T² and the calm side
        // √(v/8 · v/2)/T² = v/(4T²), 4/√2 ≈ 2.83 times fewer (each rounded up). Pixel 8
        // alone differs: without it pixel 6's neighbourhood is calm, so the mean it reads
        // is 5v/12.
        assert!(budgets[..6].iter().all(|&n| n == budgets[0]), "{budgets:?}");
        for i in [6, 7, 9, 10, 11] {
            assert_eq!(budgets[i], budgets[9], "{budgets:?}");
        }
        let ratio = budgets[9] as f64 / budgets[0] as f64;
        assert!((2.7..2.9).contains(&ratio), "noisy ÷ calm = {ratio}: {budgets:?}");
        assert!(budgets[8] < budgets[9] && budgets[8] > budgets[0], "{budgets:?}");
        assert!(budgets[0] >= settings.min_spp);
        // Far noisier pixels take the render's most.
        let budgets = sample_budgets(&pilot_of(1e3), &settings, 1024);
        assert_eq!(budgets[9], 1024, "{budgets:?}");
        assert!(budgets.iter().all(|&n| (16..=1024).contains(&n)), "{budgets:?}");
        // A pixel with no neighbour has nothing to decide from.
        let mut lone = Film::new(1, 1);
        for k in 0..16 {
            film_add_sample(&mut lone.pixels[0], Vec3::ONE, k & 1);
        }
        assert_eq!(sample_budgets(&lone, &settings, 1024), vec![1024]);
        assert!(AdaptiveSettings { threshold: 0.0, min_spp: 16 }.validate(64).is_err());
        assert!(AdaptiveSettings { threshold: 0.1, min_spp: 1 }.validate(64).is_err());
        assert!(AdaptiveSettings { threshold: 0.1, min_spp: 128 }.validate(64).is_err());
    }
}
