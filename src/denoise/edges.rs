//! The built-in denoiser's last step: pixels on a geometric edge, reconstructed by a local
//! first-order regression on the AOVs.
//!
//! The à-trous iterations cannot filter a pixel whose footprint straddles two surfaces: its
//! guides (an average of both sides' normals, albedos, depths, coverage and emission) match
//! neither side, so every edge-stopping weight rejects its neighbours and it keeps its raw
//! noise. At 128² that is a quarter of the Cornell box's pixels and, after the iterations,
//! nearly 90% of its error. But the AOVs are averaged over the same pixel footprint as the
//! colour, so across an edge both are the same blend of the two sides: the colour is an
//! affine function of the features there. Fitting c ≈ α + β·(f − f_p) over a window, by
//! least squares weighted with each neighbour's inverse variance, and taking α, gives the edge
//! pixel from its well-filtered neighbours on either side. Emitted radiance is taken out of
//! every colour first and the centre's own put back: how much of an emitter a pixel covers
//! is no function of the other features, and the AOV pass measures it finely on an
//! emitter's edge (`integrator::aov::AOV_REFINED_SAMPLES`), far better than 16 samples of a
//! bright emitter do. This is the first-order
//! feature regression of Bitterli et al. 2016 (NFOR, §4) and Moon et al. 2014, applied only
//! where the zero-order filter fails; their cross-validated bandwidth selection is replaced
//! by the à-trous output's own residual variance as the weight.
//!
//! The fit is not taken whole: it is blended with the pixel's raw value by how far apart the
//! two are against the raw value's noise ([`blend_with_raw`]).
//!
//! Runs on the host for both backends: `crate::gpu::denoise` calls [`reconstruct_edges`]
//! after the GPU's à-trous iterations.

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use super::atrous::{luminance, Prepared};
use super::DenoiseInput;

/// The regression window's radius: 7 × 7 pixels, enough for a side of an edge to hold a
/// dozen well-filtered pixels.
pub const EDGE_RADIUS: i32 = 3;
/// Unknowns of the regression: the intercept and 10 slopes (image position 2, albedo 3,
/// normal 3, relative depth, coverage). The position captures the gradients of light
/// across a surface (a contact shadow), which the other features cannot.
pub const EDGE_FEATURES: usize = 11;
/// Ridge weight on the slopes, relative to the summed weight: the features of two surfaces
/// span only a line, so the system is rank-deficient by design, and the ridge picks the
/// smallest slopes that fit.
pub const EDGE_RIDGE: f64 = 1e-3;
/// A neighbour's variance is floored at this share of (its luminance² + 10⁻²), the relMSE's
/// denominator: a filtered pixel is not infinitely certain, and its bias is not in its
/// variance.
pub const EDGE_VARIANCE_FLOOR: f32 = 1e-3;

/// Is pixel `i` on a geometric edge: does a 4-neighbour's albedo, normal, coverage or
/// emission differ from its own, or its coverage fall short of whole?
pub fn is_edge(input: &DenoiseInput, i: usize) -> bool {
    let (w, h) = (input.width as usize, input.height as usize);
    let a = input.aovs;
    let (x, y) = (i % w, i / w);
    let cov = a.coverage[i];
    if cov > 0.0 && cov < 1.0 {
        return true;
    }
    let neighbours =
        [(x > 0, i.wrapping_sub(1)), (x + 1 < w, i + 1), (y > 0, i.wrapping_sub(w)), (y + 1 < h, i + w)];
    neighbours.into_iter().any(|(inside, j)| {
        inside
            && ((a.albedo[j] - a.albedo[i]).abs().max_element() > 1e-3
                || (a.normal[j] - a.normal[i]).abs().max_element() > 1e-3
                || a.coverage[j] != cov
                || (a.emission[j] - a.emission[i]).abs().max_element() > 1e-3 * a.emission[i].max_element())
    })
}

/// The variance of pixel `p`'s mean from the share of its samples that see an emitter:
/// f (1 − f) E² / spp, with E the brightest emission (luminance) within the window and f
/// the pixel's own emission's share of it.
fn emitter_edge_variance(input: &DenoiseInput, p: usize) -> f32 {
    let (w, h) = (input.width as i32, input.height as i32);
    let (x, y) = (p as i32 % w, p as i32 / w);
    let mut brightest = 0.0f32;
    for qy in (y - EDGE_RADIUS).max(0)..=(y + EDGE_RADIUS).min(h - 1) {
        for qx in (x - EDGE_RADIUS).max(0)..=(x + EDGE_RADIUS).min(w - 1) {
            brightest = brightest.max(input.aovs.emission[(qy * w + qx) as usize].max_element());
        }
    }
    if brightest <= 0.0 {
        return 0.0;
    }
    let f = (input.aovs.emission[p].max_element() / brightest).clamp(0.0, 1.0);
    f * (1.0 - f) * brightest * brightest / input.spp.max(1.0)
}

/// The regression features of pixel `q` relative to pixel `p` (module documentation).
fn features(input: &DenoiseInput, p: usize, q: usize) -> [f64; EDGE_FEATURES] {
    let a = input.aovs;
    let (zp, zq) = (a.depth[p], a.depth[q]);
    // Depth relative to the centre's, where both see a surface (coverage takes the rest).
    let dz = if zp.is_finite() && zq.is_finite() && zp > 0.0 { ((zq - zp) / zp) as f64 } else { 0.0 };
    let da = a.albedo[q] - a.albedo[p];
    let dn = a.normal[q] - a.normal[p];
    let (w, r) = (input.width as i64, EDGE_RADIUS as f64);
    let (dx, dy) = ((q as i64 % w - p as i64 % w) as f64 / r, (q as i64 / w - p as i64 / w) as f64 / r);
    [
        1.0,
        dx,
        dy,
        da.x as f64,
        da.y as f64,
        da.z as f64,
        dn.x as f64,
        dn.y as f64,
        dn.z as f64,
        dz,
        (a.coverage[q] - a.coverage[p]) as f64,
    ]
}

/// Solves the symmetric positive-definite system `m x = b` in place by Cholesky
/// decomposition; `None` if it is not positive definite.
#[allow(clippy::needless_range_loop)] // reason: a matrix factorisation reads as its indices
fn cholesky_solve(
    m: &mut [[f64; EDGE_FEATURES]; EDGE_FEATURES],
    b: &mut [[f64; 3]; EDGE_FEATURES],
) -> Option<()> {
    let n = EDGE_FEATURES;
    for j in 0..n {
        let mut d = m[j][j];
        for k in 0..j {
            d -= m[j][k] * m[j][k];
        }
        if d <= 0.0 || !d.is_finite() {
            return None;
        }
        let d = d.sqrt();
        m[j][j] = d;
        for i in j + 1..n {
            let mut s = m[i][j];
            for k in 0..j {
                s -= m[i][k] * m[j][k];
            }
            m[i][j] = s / d;
        }
    }
    for c in 0..3 {
        for i in 0..n {
            let mut s = b[i][c];
            for k in 0..i {
                s -= m[i][k] * b[k][c];
            }
            b[i][c] = s / m[i][i];
        }
        for i in (0..n).rev() {
            let mut s = b[i][c];
            for k in i + 1..n {
                s -= m[k][i] * b[k][c];
            }
            b[i][c] = s / m[i][i];
        }
    }
    Some(())
}

/// The edge pixel `p`'s regressed colour from the window around it: each neighbour's
/// filtered colour `filtered` with its residual luminance variance `filtered_variance`
/// (remodulated), the centre's own raw colour and variance. `None` where the system is
/// singular (the caller keeps the filtered value).
#[allow(clippy::needless_range_loop)] // reason: the normal equations' sums read as their indices
fn regress(input: &DenoiseInput, p: usize, filtered: &[Vec3], filtered_variance: &[f32]) -> Option<Vec3> {
    let (w, h) = (input.width as i32, input.height as i32);
    let (x, y) = (p as i32 % w, p as i32 / w);
    let mut m = [[0.0f64; EDGE_FEATURES]; EDGE_FEATURES];
    let mut b = [[0.0f64; 3]; EDGE_FEATURES];
    let mut weight_sum = 0.0f64;
    for dy in -EDGE_RADIUS..=EDGE_RADIUS {
        for dx in -EDGE_RADIUS..=EDGE_RADIUS {
            let (qx, qy) = (x + dx, y + dy);
            if qx < 0 || qy < 0 || qx >= w || qy >= h {
                continue;
            }
            let q = (qy * w + qx) as usize;
            let (color, variance) = if q == p {
                let raw_var = super::atrous::luminance_variance(input.variance[p]);
                (input.color[p], raw_var)
            } else {
                (filtered[q], filtered_variance[q])
            };

            // What the surface seen emits is taken out here and the centre's own put back
            // below (module documentation).
            let color = color - input.aovs.emission[q];
            let l = luminance(color);
            let weight = 1.0 / (variance.max(EDGE_VARIANCE_FLOOR * (l * l + 1e-2)) as f64);
            let f = features(input, p, q);
            // Whole rows, though only the lower triangle is kept (the upper one is mirrored
            // below): a row of fixed length vectorises where a triangle's varying one did
            // not. Each kept entry is the same product, summed in the same order.
            for i in 0..EDGE_FEATURES {
                let wf = weight * f[i];
                for j in 0..EDGE_FEATURES {
                    m[i][j] += wf * f[j];
                }
                for c in 0..3 {
                    b[i][c] += wf * color[c] as f64;
                }
            }
            weight_sum += weight;
        }
    }
    for i in 0..EDGE_FEATURES {
        for j in 0..i {
            m[j][i] = m[i][j];
        }
    }
    for (i, row) in m.iter_mut().enumerate().skip(1) {
        row[i] += EDGE_RIDGE * weight_sum;
    }
    cholesky_solve(&mut m, &mut b)?;
    let out = Vec3::new(b[0][0] as f32, b[0][1] as f32, b[0][2] as f32) + input.aovs.emission[p];
    out.is_finite().then_some(out)
}

/// An edge pixel's output from its raw value `raw` (an unbiased mean of variance
/// `raw_variance`, the largest channel's) and its regression's `fit`.
///
/// The fit assumes the colour affine in the features over the window. Where that fails, it
/// is biased, and one way above all: its weights are the neighbours' inverse variances, so
/// dark, nearly noiseless neighbours outweigh bright ones by orders of magnitude, and a
/// highlight the features cannot explain (a glossy reflection of a small bright light) is
/// fitted from the dark surface around it. With the fit's own variance small beside the
/// raw value's, the blend raw + w (fit − raw) that minimises the expected squared error is
/// w = σ² / (σ² + b²), b the fit's bias; b² estimated as d² − σ² from their difference d
/// (the raw value's noise taken out, and never below zero) gives w = min(1, σ² / d²), d the
/// largest channel's. A fit within the raw value's noise is taken whole; one k standard
/// deviations away moves the pixel by 1/k² of the way.
///
/// This replaced taking the fit whole within 2σ and the raw value beyond: a highlight's raw
/// value has a large variance in absolute terms, so fits 2σ below it were taken, and the
/// built-in filter lost 5.8% of DamagedHelmet's light at 256², 16 spp (pixels of 14.8 in
/// the reference, 17.3 raw, came out 0.12). The blend took the helmet's raw ÷ denoised relMSE
/// from 0.94–1.15× to 1.46–1.73×, and the Cornell box's from 7.5–7.7× to 8.2–8.3× (seeds 2,
/// 3 and 7; `bench/history/denoising.md`). Radiance is not
/// negative, and neither is the result.
pub fn blend_with_raw(raw: Vec3, fit: Vec3, raw_variance: f32) -> Vec3 {
    let d = fit - raw;
    let d2 = d.abs().max_element().powi(2);
    let w = if d2 <= raw_variance { 1.0 } else { raw_variance / d2 };
    (raw + w * d).max(Vec3::ZERO)
}

/// Step 4 of the built-in denoiser: `filtered` (the remodulated à-trous output of
/// `prepared`) with every edge pixel replaced by its regression (module documentation).
/// Deterministic: each pixel's sums run in a fixed order.
pub fn reconstruct_edges(
    input: &DenoiseInput,
    prepared: &Prepared,
    signal: &[Vec4],
    filtered: &[Vec3],
) -> Vec<Vec3> {
    let weights = Vec3::new(0.2126, 0.7152, 0.0722);
    // The residual luminance variance, remodulated: the iterations track it demodulated.
    let filtered_variance: Vec<f32> =
        signal.iter().zip(&prepared.modulation).map(|(s, m)| s.w * weights.dot(*m).powi(2)).collect();
    (0..filtered.len())
        .into_par_iter()
        .map(|p| {
            if is_edge(input, p) {
                let Some(fit) = regress(input, p, filtered, &filtered_variance) else { return filtered[p] };
                // A pixel on an emitter's edge sees the emitter in a share of its samples:
                // its own variance estimate misses that when no sample happened to (module
                // documentation), so the share's binomial variance is added.
                let raw_variance = input.variance[p].max_element() + emitter_edge_variance(input, p);
                blend_with_raw(input.color[p], fit, raw_variance)
            } else {
                filtered[p]
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fit within the raw value's noise is taken whole; one 2σ away moves the pixel a
    /// quarter of the way, 10σ away a hundredth; nothing comes out negative.
    #[test]
    fn a_fit_is_blended_with_the_raw_value_by_its_distance_in_standard_deviations() {
        let raw = Vec3::new(4.0, 2.0, 1.0);
        let fit = Vec3::new(3.5, 2.1, 1.2);
        assert_eq!(blend_with_raw(raw, fit, 1.0), fit);
        let far = raw - Vec3::new(4.0, 0.0, 0.0);
        let out = blend_with_raw(raw, far, 4.0);
        assert!((out - Vec3::new(3.0, 2.0, 1.0)).abs().max_element() < 1e-6, "{out}");
        let highlight = Vec3::splat(17.3);
        let out = blend_with_raw(highlight, Vec3::splat(0.1), (17.2f32 / 10.0).powi(2));
        assert!((out - Vec3::splat(17.3 - 0.172)).abs().max_element() < 1e-4, "{out}");
        let below_zero = blend_with_raw(Vec3::new(0.01, 0.5, 0.5), Vec3::new(-0.3, 0.5, 0.5), 1.0);
        assert_eq!(below_zero, Vec3::new(0.0, 0.5, 0.5));
    }
}
