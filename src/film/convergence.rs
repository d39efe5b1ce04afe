//! Speed against error while rendering: at checkpoints, the error of the image so far
//! against a reference (when there is one) and the error its own variance predicts.
//!
//! relMSE follows the benchmark protocol: the mean over pixels and channels of
//! (x − ref)² / (ref² + 10⁻²). The predicted relMSE replaces (x − ref)² by its expectation
//! for an unbiased image, the variance of the pixel's mean, and ref by the pixel's own mean:
//! it needs no reference, so `--target-error` can stop on it. Under QMC sampling that
//! variance is measured from two independent replicates, not from the samples' spread.

use std::fmt::Write as _;

use super::image::LinearImage;

/// One checkpoint of a render.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvergenceRow {
    pub spp: u32,
    pub seconds: f64,
    /// Against the reference, when there is one.
    pub rmse: Option<f64>,
    pub relmse: Option<f64>,
    /// From the image's own variance.
    pub predicted_relmse: f64,
}

/// relMSE's denominator offset (benchmark protocol).
pub(crate) const RELMSE_EPSILON: f64 = 1e-2;

/// The predicted relMSE of an image with per-pixel variance (`None` without variance).
///
/// Reads the replicates' variance of the mean when the image has it (renders: right under
/// QMC sampling, see [`crate::film::Film::replicate_variance_of_mean`]), else the samples'
/// (files).
///
/// Heavy tails make it optimistic at low spp: a pixel that has not yet drawn its rare bright
/// paths under-estimates its own variance (measured on the Cornell box against a 1024-spp
/// reference, after removing the reference's own error: 0.78 of the actual relMSE at 16 spp,
/// 0.85 at 64). (A 3×3-neighbourhood mean in the denominator was tried and is worse: it
/// mixes the lamp into its dark surroundings.)
pub fn predicted_relmse(image: &LinearImage) -> Option<f64> {
    let variance = image.replicate_variance.as_ref().or(image.variance.as_ref())?;
    let n = (image.rgb.len() * 3) as f64;
    let sum: f64 =
        image.rgb.iter().zip(variance).flat_map(|(m, v)| (0..3).map(move |c| relmse_term(m[c], v[c]))).sum();
    Some(sum / n)
}

/// One pixel channel's share of the predicted relMSE: the variance of its mean over its
/// mean² + ε (also `Film::predicted_relmse`'s, so that both sum the same numbers).
pub(super) fn relmse_term(mean: f32, variance: f32) -> f64 {
    variance as f64 / ((mean as f64).powi(2) + RELMSE_EPSILON)
}

/// RMSE and relMSE of `image` against `reference` (same size).
pub fn error_against(image: &LinearImage, reference: &LinearImage) -> (f64, f64) {
    let (mut se, mut rel) = (0.0f64, 0.0f64);
    for (x, r) in image.rgb.iter().zip(&reference.rgb) {
        for c in 0..3 {
            let d = x[c] as f64 - r[c] as f64;
            se += d * d;
            rel += d * d / ((r[c] as f64).powi(2) + RELMSE_EPSILON);
        }
    }
    let n = (image.rgb.len() * 3) as f64;
    ((se / n).sqrt(), rel / n)
}

impl ConvergenceRow {
    pub fn new(
        image: &LinearImage,
        reference: Option<&LinearImage>,
        spp: u32,
        seconds: f64,
    ) -> ConvergenceRow {
        let errors = reference.map(|r| error_against(image, r));
        ConvergenceRow {
            spp,
            seconds,
            rmse: errors.map(|e| e.0),
            relmse: errors.map(|e| e.1),
            // Without variance (fewer than 2 spp) there is no prediction: infinite.
            predicted_relmse: predicted_relmse(image).unwrap_or(f64::INFINITY),
        }
    }
}

/// The log as CSV: a header, then one row per checkpoint (empty where unknown).
pub fn convergence_csv(rows: &[ConvergenceRow]) -> String {
    let mut out = String::from("spp,seconds,rmse,relmse,predicted_relmse\n");
    let opt = |v: Option<f64>| v.map(|v| format!("{v:e}")).unwrap_or_default();
    for r in rows {
        let predicted =
            if r.predicted_relmse.is_finite() { format!("{:e}", r.predicted_relmse) } else { String::new() };
        let _ = writeln!(out, "{},{:.6},{},{},{}", r.spp, r.seconds, opt(r.rmse), opt(r.relmse), predicted);
    }
    out
}

/// The log as JSON: an array of objects (null where unknown).
pub fn convergence_json(rows: &[ConvergenceRow]) -> serde_json::Value {
    let finite = |v: f64| if v.is_finite() { serde_json::json!(v) } else { serde_json::Value::Null };
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                serde_json::json!({"spp": r.spp, "seconds": r.seconds, "rmse": r.rmse, "relmse": r.relmse,
                    "predicted_relmse": finite(r.predicted_relmse)})
            })
            .collect(),
    )
}
