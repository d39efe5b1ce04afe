//! Noise-aware image comparison: error metrics, and a statistical test of "same expected
//! image" that uses the per-pixel variance of the mean stored in pathlight's EXRs.
//!
//! The test works on the difference of means d = test − reference, z = d / √(var_t + var_r).
//! Monte Carlo pixel means are heavy-tailed where caustics are (a rare glass path carries a
//! huge weight, and a render that has not drawn it yet also under-estimates its own
//! variance), so a per-pixel normal test raises false alarms on honest renders. The verdict
//! therefore rests on tests that pool pixels, at several scales, so that both a small sharp
//! difference (a missing object) and a large faint one (a wall 3% darker) are seen:
//!
//! * **blocks** of b×b pixels (4×4 by default), then 4b×4b, 16b×16b, … while a block is
//!   smaller than the image; per channel, Šidák-corrected over the blocks and channels of
//!   one scale. A block's variance is the larger of the files' own estimate (Σ var / n²) and
//!   the empirical spread of its pixel differences (s² / n): the second catches the heavy
//!   tails the first misses, and barely moves under a real, smooth difference (a darker wall
//!   shifts every d alike, which changes their mean, not their spread).
//! * **image mean**, per channel (Šidák over 3), with the same guard from the spread of the
//!   finest blocks' means.
//!
//! Each scale and the image mean get an equal share of α (Bonferroni across them).
//!
//! When both images say how many samples per pixel they hold, each image's variance is taken
//! as at least what the other's per-sample variance predicts for it (see `statistical_test`):
//! against a high-spp reference this is what keeps low-spp renders from false alarms.
//!
//! A per-pixel test is reported too (passing fraction), but does not decide. Threshold
//! options (RMSE, relMSE, FLIP, max |Δ|) add conditions; without variance in either image
//! they are the only judge.

use std::fmt;

use super::convergence::error_against;
use super::image::LinearImage;
use super::linear_to_srgb;
use crate::error::{Error, Result};
use crate::stats::{normal_two_sided_threshold, sidak_alpha};

/// What to test and how strictly.
#[derive(Clone, Debug, PartialEq)]
pub struct CompareOptions {
    /// Family-wise false-alarm rate of the statistical verdict.
    pub alpha: f64,
    /// Edge of the pooled blocks, in pixels.
    pub block: usize,
    pub max_rmse: Option<f64>,
    pub max_relmse: Option<f64>,
    pub max_flip: Option<f64>,
    pub max_abs: Option<f64>,
}

impl Default for CompareOptions {
    fn default() -> Self {
        CompareOptions {
            alpha: 0.01,
            block: 4,
            max_rmse: None,
            max_relmse: None,
            max_flip: None,
            max_abs: None,
        }
    }
}

/// Error metrics of test against reference, over every pixel and channel.
#[derive(Clone, Debug, PartialEq)]
pub struct Metrics {
    pub rmse: f64,
    /// Mean of (t − r)² / (r² + 10⁻²), the benchmark protocol's relative MSE.
    pub relmse: f64,
    /// Mean absolute error.
    pub mae: f64,
    /// 10 log₁₀(1 / MSE): peak signal 1, display white.
    pub psnr: f64,
    pub max_abs: f64,
    /// Per channel: mean of test / mean of reference (`None` where the reference mean is 0).
    pub mean_ratio: [Option<f64>; 3],
    /// Mean FLIP error (NVIDIA ꟻLIP, LDR) of both images clamped to [0, 1] and sRGB-encoded,
    /// at 67 pixels per degree.
    pub flip: f64,
}

/// A region of the image and its z-score.
#[derive(Clone, Debug, PartialEq)]
pub struct Region {
    pub x: usize,
    pub y: usize,
    pub width: usize,
    pub height: usize,
    /// 0, 1, 2 = R, G, B.
    pub channel: usize,
    pub z: f64,
}

/// One family of z-tests.
#[derive(Clone, Debug, PartialEq)]
pub struct ZTest {
    pub tests: usize,
    /// |z| beyond which one test fails (Šidák-corrected).
    pub threshold: f64,
    pub failed: usize,
}

impl ZTest {
    pub fn passed_fraction(&self) -> f64 {
        1.0 - self.failed as f64 / self.tests.max(1) as f64
    }
    pub fn passed(&self) -> bool {
        self.failed == 0
    }
}

/// The statistical part of a comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct StatTest {
    /// Which images carried variance: "both", "test" or "reference".
    pub variance_from: &'static str,
    pub image_mean_z: [f64; 3],
    pub image_mean: ZTest,
    /// One test per scale, finest first: (block edge in pixels, its tests).
    pub blocks: Vec<(usize, ZTest)>,
    /// Informative only (heavy tails): not part of the verdict.
    pub pixels: ZTest,
    /// The blocks with the largest |z| relative to their scale's threshold, worst first.
    pub worst_blocks: Vec<Region>,
    /// Per pixel and channel: z = d / √(var_t + var_r) (±∞ where both variances are 0 and
    /// the values differ), for `--zmap` and `--diff`.
    pub pixel_z: Vec<[f32; 3]>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct CompareReport {
    pub width: usize,
    pub height: usize,
    pub alpha: f64,
    pub block: usize,
    pub metrics: Metrics,
    pub stat: Option<StatTest>,
    /// Why the images count as different; empty when they count as the same.
    pub failures: Vec<String>,
}

impl CompareReport {
    pub fn same(&self) -> bool {
        self.failures.is_empty()
    }
}

/// Compares `test` against `reference`. Errors (exit code 2 on the command line) are for
/// inputs that cannot be compared: different sizes, no way to judge.
pub fn compare_images(
    test: &LinearImage,
    reference: &LinearImage,
    options: &CompareOptions,
) -> Result<CompareReport> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(Error::Settings(format!(
            "the images differ in size: test {}×{}, reference {}×{}",
            test.width, test.height, reference.width, reference.height
        )));
    }
    if test.rgb.is_empty() {
        return Err(Error::Settings("the images have no pixels".into()));
    }
    if !(options.alpha > 0.0 && options.alpha < 1.0) || options.block == 0 {
        return Err(Error::Settings("--alpha must be in (0, 1) and --block at least 1".into()));
    }
    let has_threshold = options.max_rmse.is_some()
        || options.max_relmse.is_some()
        || options.max_flip.is_some()
        || options.max_abs.is_some();
    if test.variance.is_none() && reference.variance.is_none() && !has_threshold {
        return Err(Error::Settings(
            "neither image carries per-pixel variance (pathlight EXRs rendered with at least 2 spp do), so there is no statistical test; give a threshold: --max-rmse, --max-relmse, --max-flip or --max-abs".into(),
        ));
    }
    let metrics = metrics(test, reference);
    let stat = statistical_test(test, reference, options);
    let mut failures = Vec::new();
    if let Some(s) = &stat {
        if !s.image_mean.passed() {
            let z = s.image_mean_z.map(|z| format!("{z:.2}"));
            failures.push(format!(
                "image means differ: z = R {}, G {}, B {} (threshold {:.2})",
                z[0], z[1], z[2], s.image_mean.threshold
            ));
        }
        for (b, t) in s.blocks.iter().filter(|(_, t)| !t.passed()) {
            failures.push(format!(
                "{} of {} {b}×{b} block channels differ beyond |z| = {:.2}",
                t.failed, t.tests, t.threshold
            ));
        }
    }
    let mut limit = |name: &str, value: f64, max: Option<f64>| {
        if let Some(max) = max {
            if value > max || value.is_nan() {
                failures.push(format!("{name} {value:.6} exceeds {max}"));
            }
        }
    };
    limit("RMSE", metrics.rmse, options.max_rmse);
    limit("relMSE", metrics.relmse, options.max_relmse);
    limit("FLIP", metrics.flip, options.max_flip);
    limit("max |Δ|", metrics.max_abs, options.max_abs);
    Ok(CompareReport {
        width: test.width,
        height: test.height,
        alpha: options.alpha,
        block: options.block,
        metrics,
        stat,
        failures,
    })
}

fn metrics(test: &LinearImage, reference: &LinearImage) -> Metrics {
    let (rmse, relmse) = error_against(test, reference);
    let (mut ae, mut max_abs) = (0.0f64, 0.0f64);
    let (mut sum_t, mut sum_r) = ([0.0f64; 3], [0.0f64; 3]);
    for (t, r) in test.rgb.iter().zip(&reference.rgb) {
        for c in 0..3 {
            let (t, r) = (t[c] as f64, r[c] as f64);
            ae += (t - r).abs();
            max_abs = max_abs.max((t - r).abs());
            sum_t[c] += t;
            sum_r[c] += r;
        }
    }
    let n = (test.rgb.len() * 3) as f64;
    let mse = rmse * rmse;
    Metrics {
        rmse,
        relmse,
        mae: ae / n,
        psnr: if mse > 0.0 { -10.0 * mse.log10() } else { f64::INFINITY },
        max_abs,
        mean_ratio: [0, 1, 2].map(|c| (sum_r[c] > 0.0).then(|| sum_t[c] / sum_r[c])),
        flip: flip_mean(test, reference),
    }
}

/// 8-bit sRGB of an image clamped to [0, 1], the input LDR-FLIP expects.
fn srgb8(image: &LinearImage) -> Vec<u8> {
    image.rgb.iter().flatten().map(|&v| (linear_to_srgb(v) * 255.0 + 0.5) as u8).collect()
}

fn flip_mean(test: &LinearImage, reference: &LinearImage) -> f64 {
    let (w, h) = (test.width as u32, test.height as u32);
    let error = nv_flip::flip(
        nv_flip::FlipImageRgb8::with_data(w, h, &srgb8(reference)),
        nv_flip::FlipImageRgb8::with_data(w, h, &srgb8(test)),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    nv_flip::FlipPool::from_image(&error).mean() as f64
}

/// z of a difference `d` with variance `var`: 0 when both are 0 (two noiseless pixels that
/// agree), ±∞ when only the variance is 0 (they disagree with certainty).
fn z_score(d: f64, var: f64) -> f64 {
    if var > 0.0 {
        d / var.sqrt()
    } else if d == 0.0 {
        0.0
    } else {
        d.signum() * f64::INFINITY
    }
}

/// The variance of a pooled mean of differences: the larger of the model's `model_var` and
/// the empirical s²/n of the `n` differences with sum `sum` and sum of squares `sum_sq`.
fn pooled_variance(model_var: f64, sum: f64, sum_sq: f64, n: usize) -> f64 {
    if n < 2 {
        return model_var;
    }
    let nf = n as f64;
    let s2 = ((sum_sq - sum * sum / nf) / (nf - 1.0)).max(0.0);
    model_var.max(s2 / nf)
}

fn statistical_test(
    test: &LinearImage,
    reference: &LinearImage,
    options: &CompareOptions,
) -> Option<StatTest> {
    let variance_from = match (&test.variance, &reference.variance) {
        (Some(_), Some(_)) => "both",
        (Some(_), None) => "test",
        (None, Some(_)) => "reference",
        (None, None) => return None,
    };
    let (w, h, b) = (test.width, test.height, options.block);
    // Under the hypothesis tested both images are renders of one scene by one renderer, so
    // their pixels share a per-sample variance, and the image with more samples estimates it
    // far better: a 16-spp render that has not yet drawn a pixel's rare bright paths
    // under-estimates its own variance exactly where its mean is off. So each image's
    // variance of the mean is at least the other's per-sample variance over its own spp
    // (var_other · spp_other / spp_self). It only ever raises a variance: conservative.
    let per_sample_scale = match (test.spp, reference.spp) {
        (Some(t), Some(r)) if t > 0 && r > 0 => Some((r as f64 / t as f64, t as f64 / r as f64)),
        _ => None,
    };
    let var_at = |i: usize, c: usize| -> f64 {
        let vt = test.variance.as_ref().map(|v| v[i][c] as f64);
        let vr = reference.variance.as_ref().map(|v| v[i][c] as f64);
        match (vt, vr, per_sample_scale) {
            (Some(vt), Some(vr), Some((r_over_t, t_over_r))) => vt.max(vr * r_over_t) + vr.max(vt * t_over_r),
            _ => vt.unwrap_or(0.0) + vr.unwrap_or(0.0),
        }
    };
    let diff_at = |i: usize, c: usize| test.rgb[i][c] as f64 - reference.rgb[i][c] as f64;

    // Pixels (informative).
    let pixel_threshold = normal_two_sided_threshold(sidak_alpha(options.alpha, w * h * 3));
    let mut pixel_z = Vec::with_capacity(w * h);
    let mut pixel_failed = 0;
    for i in 0..w * h {
        let z = [0, 1, 2].map(|c| z_score(diff_at(i, c), var_at(i, c)));
        pixel_failed += z.iter().filter(|z| z.abs() > pixel_threshold).count();
        pixel_z.push(z.map(|z| z as f32));
    }

    // Scales: b, 4b, 16b, … while a block is smaller than the image.
    let mut edges = vec![b];
    let mut edge = b;
    while edge * 4 < w.max(h) {
        edge *= 4;
        edges.push(edge);
    }
    let share = options.alpha / (edges.len() + 1) as f64;
    let mut blocks = Vec::new();
    let mut worst: Vec<(f64, Region)> = Vec::new();
    // Over the finest blocks, per channel: their count, Σ mean and Σ mean², for the guard.
    let mut finest = (0usize, [0.0f64; 3], [0.0f64; 3]);
    for (level, &edge) in edges.iter().enumerate() {
        let (bx, by) = (w.div_ceil(edge), h.div_ceil(edge));
        let threshold = normal_two_sided_threshold(sidak_alpha(share, bx * by * 3));
        let mut failed = 0;
        for j in 0..by {
            for i in 0..bx {
                let (x0, y0) = (i * edge, j * edge);
                let (x1, y1) = ((x0 + edge).min(w), (y0 + edge).min(h));
                let n = (x1 - x0) * (y1 - y0);
                let nf = n as f64;
                for c in 0..3 {
                    let (mut sum, mut sum_sq, mut var) = (0.0, 0.0, 0.0);
                    for y in y0..y1 {
                        for x in x0..x1 {
                            let d = diff_at(y * w + x, c);
                            sum += d;
                            sum_sq += d * d;
                            var += var_at(y * w + x, c);
                        }
                    }
                    let z = z_score(sum / nf, pooled_variance(var / (nf * nf), sum, sum_sq, n));
                    if z.abs() > threshold {
                        failed += 1;
                    }
                    let region = Region { x: x0, y: y0, width: x1 - x0, height: y1 - y0, channel: c, z };
                    worst.push((z.abs() / threshold, region));
                    if level == 0 {
                        finest.1[c] += sum / nf;
                        finest.2[c] += (sum / nf) * (sum / nf);
                    }
                }
                if level == 0 {
                    finest.0 += 1;
                }
            }
            // Keep only the few worst, so memory stays small on large images.
            if worst.len() > 64 {
                worst.sort_by(|a, b| b.0.total_cmp(&a.0));
                worst.truncate(5);
            }
        }
        blocks.push((edge, ZTest { tests: bx * by * 3, threshold, failed }));
    }
    worst.sort_by(|a, b| b.0.total_cmp(&a.0));
    let worst_blocks = worst.into_iter().take(5).map(|(_, r)| r).collect();

    // Image mean per channel.
    let n = w * h;
    let mean_threshold = normal_two_sided_threshold(sidak_alpha(share, 3));
    let image_mean_z = [0, 1, 2].map(|c| {
        let sum: f64 = (0..n).map(|i| diff_at(i, c)).sum();
        let model: f64 = (0..n).map(|i| var_at(i, c)).sum::<f64>() / (n as f64 * n as f64);
        // Guard from the spread of the finest block means (of roughly equal weight).
        let guard = pooled_variance(0.0, finest.1[c], finest.2[c], finest.0);
        z_score(sum / n as f64, model.max(guard))
    });
    let mean_failed = image_mean_z.iter().filter(|z| z.abs() > mean_threshold).count();

    Some(StatTest {
        variance_from,
        image_mean_z,
        image_mean: ZTest { tests: 3, threshold: mean_threshold, failed: mean_failed },
        blocks,
        pixels: ZTest { tests: n * 3, threshold: pixel_threshold, failed: pixel_failed },
        worst_blocks,
        pixel_z,
    })
}

const CHANNEL: [&str; 3] = ["R", "G", "B"];

impl CompareReport {
    /// Every number, for CI tools.
    pub fn to_json(&self) -> serde_json::Value {
        use serde_json::json;
        let finite = |v: f64| if v.is_finite() { json!(v) } else { json!(v.to_string()) };
        let m = &self.metrics;
        let ztest = |t: &ZTest| {
            json!({"tests": t.tests, "threshold": t.threshold, "failed": t.failed,
                   "passed_fraction": t.passed_fraction(), "passed": t.passed()})
        };
        let stat = self.stat.as_ref().map(|s| {
            json!({
                "variance_from": s.variance_from,
                "image_mean": {"z": s.image_mean_z.map(finite), "test": ztest(&s.image_mean)},
                "blocks": s.blocks.iter().map(|(b, t)| {
                    let mut v = ztest(t);
                    v["block"] = json!(b);
                    v
                }).collect::<Vec<_>>(),
                "pixels": ztest(&s.pixels),
                "worst_blocks": s.worst_blocks.iter().map(|r| json!({
                    "x": r.x, "y": r.y, "width": r.width, "height": r.height,
                    "channel": CHANNEL[r.channel], "z": finite(r.z)})).collect::<Vec<_>>(),
            })
        });
        json!({
            "verdict": if self.same() { "same" } else { "different" },
            "width": self.width,
            "height": self.height,
            "alpha": self.alpha,
            "block": self.block,
            "metrics": {
                "rmse": m.rmse, "relmse": m.relmse, "mae": m.mae, "psnr": finite(m.psnr),
                "max_abs": m.max_abs, "mean_ratio": m.mean_ratio, "flip": m.flip,
            },
            "statistical_test": stat,
            "failures": self.failures,
        })
    }
}

impl fmt::Display for CompareReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = &self.metrics;
        let ratio = |r: Option<f64>| r.map_or("-".to_string(), |r| format!("{r:.4}"));
        writeln!(f, "{}×{} pixels", self.width, self.height)?;
        writeln!(
            f,
            "  RMSE {:.6}  relMSE {:.6}  MAE {:.6}  PSNR {:.2} dB  max |Δ| {:.6}  FLIP {:.4}",
            m.rmse, m.relmse, m.mae, m.psnr, m.max_abs, m.flip
        )?;
        writeln!(
            f,
            "  mean ratio test/reference: R {}  G {}  B {}",
            ratio(m.mean_ratio[0]),
            ratio(m.mean_ratio[1]),
            ratio(m.mean_ratio[2])
        )?;
        match &self.stat {
            None => writeln!(f, "  no variance in either image: thresholds only")?,
            Some(s) => {
                writeln!(f, "  z-test (variance from {}, family-wise α = {}):", s.variance_from, self.alpha)?;
                let z = s.image_mean_z;
                writeln!(
                    f,
                    "    image mean: z = R {:.2}, G {:.2}, B {:.2} (threshold {:.2}) {}",
                    z[0],
                    z[1],
                    z[2],
                    s.image_mean.threshold,
                    if s.image_mean.passed() { "pass" } else { "FAIL" }
                )?;
                for (b, t) in &s.blocks {
                    writeln!(
                        f,
                        "    {b}×{b} blocks: {} tests, {:.3}% pass (threshold {:.2}) {}",
                        t.tests,
                        100.0 * t.passed_fraction(),
                        t.threshold,
                        if t.passed() { "pass" } else { "FAIL" },
                    )?;
                }
                writeln!(f, "    worst blocks:")?;
                for r in &s.worst_blocks {
                    writeln!(
                        f,
                        "      x {}..{}, y {}..{}, {}: z = {:.2}",
                        r.x,
                        r.x + r.width,
                        r.y,
                        r.y + r.height,
                        CHANNEL[r.channel],
                        r.z
                    )?;
                }
                writeln!(
                    f,
                    "    pixels (informative; heavy-tailed): {:.3}% pass (threshold {:.2})",
                    100.0 * s.pixels.passed_fraction(),
                    s.pixels.threshold
                )?;
            }
        }
        if self.same() {
            write!(f, "verdict: same")
        } else {
            write!(f, "verdict: different: {}", self.failures.join("; "))
        }
    }
}
