//! The built-in denoiser: the edge-avoiding à-trous wavelet filter of Dammertz et al. 2010
//! ("Edge-Avoiding À-Trous Wavelet Transform for fast Global Illumination Filtering", HPG),
//! with the variance-steered luminance weight of Schied et al. 2017 (SVGF, "Spatiotemporal
//! Variance-Guided Filtering", HPG, §4.4–4.5) in place of a fixed colour threshold.
//!
//! WGSL twin of each iteration: `atrous_iteration` in `shaders/denoise.wgsl`, run by
//! `crate::gpu::denoise`; [`prepare`] and [`finish`] run on the host for both.
//!
//! 1. **Demodulate** ([`prepare`]): the colour is divided by the albedo AOV (at least
//!    [`ALBEDO_DEMODULATION_MIN`], the same rule for every pixel, so that neighbours mix
//!    like with like), so the filter smooths irradiance and textures come back sharp when
//!    [`finish`] multiplies it back (SVGF §4.1); the variance is divided by its square.
//! 2. **Iterate** [`ITERATIONS`] times with the 5×5 B3-spline kernel h = (1, 4, 6, 4, 1)/16
//!    spread over taps `2^i` pixels apart: a footprint of 125 px after five, at 25 taps a
//!    pixel each. Each tap's weight is h times three edge-stopping functions (SVGF eq. 3–5):
//!    normals (cos^[`SIGMA_NORMAL`]), depth against its local gradient, and luminance against
//!    [`SIGMA_LUMINANCE`] standard deviations of the centre's noise, the variance prefiltered
//!    by a 3×3 Gaussian; and two of pathlight's own, because the guides cannot tell them
//!    apart otherwise: emission (an emitter and the ceiling around it have the same albedo,
//!    normal and depth, and a pixel on the emitter's edge has a large variance, so the
//!    luminance weight alone mixed them: the edge lost 90% of its brightness) and coverage (a
//!    silhouette pixel that sees the background through part of its footprint).
//!    A pixel's variance is filtered with the squared weights (SVGF eq. 2),
//!    so that later, wider iterations see the noise that is left and smooth less.
//! 3. **Remodulate** ([`finish`]).
//!
//! Deterministic: every pixel is a fixed sum in a fixed order, whatever the thread count.

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use super::DenoiseInput;

/// À-trous iterations: taps 1, 2, 4, 8 and 16 pixels apart (SVGF uses five).
pub const ITERATIONS: u32 = 5;
/// The luminance weight's width in standard deviations of the centre's noise (SVGF's σ_l).
pub const SIGMA_LUMINANCE: f32 = 4.0;
/// The normal weight's exponent (SVGF's σ_n): 128, a power of two, so that cos^σ_n is
/// [`SIGMA_NORMAL_SQUARINGS`] multiplications (a `powf` and two `exp`s a tap had been a
/// quarter of the filter's profile, `bench/history/denoising.md`).
pub const SIGMA_NORMAL: f32 = (1u32 << SIGMA_NORMAL_SQUARINGS) as f32;
/// How many times cos is squared for the normal weight: σ_n = 2^7.
pub const SIGMA_NORMAL_SQUARINGS: u32 = 7;
/// A tap whose weight is e^−x with x above this gets weight 0 without the exponential: e⁻⁴⁰
/// is 4·10⁻¹⁸, and the centre's own weight is at least h(0, 0) = 9/64, so such a tap moves
/// the weighted mean by under 3·10⁻¹⁷ of its value, far below an f32's rounding unless it
/// is 10⁹ times the centre's (and then its luminance weight is far past this anyway).
pub const WEIGHT_EXPONENT_CUTOFF: f32 = 40.0;
/// The depth weight's width in local depth gradients per pixel of offset (SVGF's σ_z).
pub const SIGMA_DEPTH: f32 = 1.0;
/// Below this albedo a channel is not demodulated (dividing by it would amplify its noise).
pub const ALBEDO_DEMODULATION_MIN: f32 = 0.01;
/// The depth a guide stores where no AOV ray hit a surface (depths are otherwise ≥ 0).
pub const MISS_DEPTH: f32 = -1.0;
/// The emission weight's width, relative to the larger of the two emissions: a pixel that
/// covers 10% less of an emitter than its neighbour weighs e⁻¹.
pub const SIGMA_EMISSION: f32 = 0.1;
/// The coverage weight's width: one AOV ray in 16 more or less weighs e⁻¹.
pub const SIGMA_COVERAGE: f32 = 1.0 / 16.0;

/// The 1-D B3-spline kernel's weights at offsets 0, ±1, ±2.
const KERNEL: [f32; 3] = [3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0];
/// The 3×3 Gaussian the variance is prefiltered with, at offsets 0 and ±1.
const GAUSSIAN: [f32; 2] = [1.0 / 4.0, 1.0 / 8.0];

/// Rec. 709 luminance.
pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// The variance of the luminance of a colour whose channels have variances `variance` and
/// are independent.
pub fn luminance_variance(variance: Vec3) -> f32 {
    let weights = Vec3::new(0.2126, 0.7152, 0.0722);
    (weights * weights).dot(variance)
}

/// What the iterations read and write, per pixel.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// Demodulated colour (xyz) and the variance of its luminance (w): what each iteration
    /// filters.
    pub signal: Vec<Vec4>,
    /// Unit normal (xyz; zero where no AOV ray hit) and depth (w; [`MISS_DEPTH`] where none
    /// hit): the guides.
    pub guide: Vec<Vec4>,
    /// The other guides: emission luminance (x), coverage (y), and the depth gradient (z, the
    /// largest depth step to a 4-neighbour that hit too); w is 1 where the pixel is kept as
    /// it is ([`is_kept`]), else 0.
    pub aux: Vec<Vec4>,
    /// What [`finish`] multiplies the filtered colour by: the albedo, 1 where it is black.
    pub modulation: Vec<Vec3>,
}

/// Step 1 (module documentation): demodulation and the guides.
pub fn prepare(input: &DenoiseInput) -> Prepared {
    let (w, h) = (input.width as usize, input.height as usize);
    let aovs = input.aovs;
    let modulation: Vec<Vec3> =
        aovs.albedo.iter().map(|a| a.max(Vec3::splat(ALBEDO_DEMODULATION_MIN))).collect();
    let signal = (0..w * h)
        .map(|i| {
            let m = modulation[i];
            (input.color[i] / m).extend(luminance_variance(input.variance[i] / (m * m)))
        })
        .collect();
    let guide: Vec<Vec4> = (0..w * h)
        .map(|i| {
            let n = aovs.normal[i].try_normalize().unwrap_or(Vec3::ZERO);
            let z = aovs.depth[i];
            n.extend(if z.is_finite() { z } else { MISS_DEPTH })
        })
        .collect();
    let aux = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let z = guide[i].w;
            let mut g = 0.0f32;
            if z >= 0.0 {
                let neighbours = [
                    (x > 0, i.wrapping_sub(1)),
                    (x + 1 < w, i + 1),
                    (y > 0, i.wrapping_sub(w)),
                    (y + 1 < h, i + w),
                ];
                for (inside, j) in neighbours {
                    if inside && guide[j].w >= 0.0 {
                        g = g.max((guide[j].w - z).abs());
                    }
                }
            }
            let kept = if is_kept(aovs.depth[i], input.color[i], input.variance[i]) { 1.0 } else { 0.0 };
            Vec4::new(luminance(aovs.emission[i]), aovs.coverage[i], g, kept)
        })
        .collect();
    Prepared { signal, guide, aux, modulation }
}

/// A pixel no AOV ray of which met a surface, and whose relative variance is below this
/// (its standard error under 1% of its value, or of 0.1 where it is darker), is kept as it
/// is ([`is_kept`]).
pub const KEPT_MISS_RELATIVE_VARIANCE: f32 = 1e-4;

/// Is the pixel of AOV depth `depth` (+∞ where no AOV ray met a surface), colour `color` and
/// variance `variance` kept as it is by every iteration? Only a miss can be: no pixel that
/// sees a surface reads one that does not (the edge-stopping functions give such a tap
/// weight 0, and the variance prefilter leaves it out), so keeping misses changes no
/// surface pixel's output. A miss sees the
/// environment (or black) straight through the pixel, noisy only by where the pixel's
/// samples fall on the map: once that noise is negligible in the relMSE (below
/// [`KEPT_MISS_RELATIVE_VARIANCE`]) filtering only blurs the map. On DamagedHelmet, whose
/// helmet covers 17% of the image, the iterations had spent most of their time on the
/// studio map behind it. A miss whose samples did see something the AOV rays did not (an
/// alpha-blended surface all of whose AOV rays passed through) is noisy, and is filtered
/// with the misses around it as before.
pub fn is_kept(depth: f32, color: Vec3, variance: Vec3) -> bool {
    let l = luminance(color);
    !depth.is_finite() && luminance_variance(variance) < KEPT_MISS_RELATIVE_VARIANCE * (l * l + 1e-2)
}

/// Step 3 (module documentation): the filtered signal times the albedo.
pub fn finish(prepared: &Prepared, signal: &[Vec4]) -> Vec<Vec3> {
    signal.iter().zip(&prepared.modulation).map(|(s, m)| s.truncate() * *m).collect()
}

/// One à-trous iteration of pixel `(x, y)` with taps `step` pixels apart: its filtered
/// signal (WGSL twin: `atrous_pixel`).
#[inline]
pub fn atrous_pixel(
    (width, height): (u32, u32),
    step: i32,
    (x, y): (i32, i32),
    signal: &[Vec4],
    guide: &[Vec4],
    aux: &[Vec4],
) -> Vec4 {
    let (w, h) = (width as i32, height as i32);
    let at = |x: i32, y: i32| (y * w + x) as usize;
    let centre = at(x, y);
    let (s_p, g_p, a_p) = (signal[centre], guide[centre], aux[centre]);
    if a_p.w != 0.0 {
        return s_p;
    }
    // The centre's noise: its luminance variance prefiltered by a 3×3 Gaussian (SVGF §4.5),
    // taps outside the image, and taps that see a surface where the centre sees none or the
    // other way round (a miss's noise says nothing of a surface's; and so no pixel ever
    // reads one of the other kind, which [`is_kept`] rests on), left out and the rest
    // renormalised.
    let p_hit = g_p.w >= 0.0;
    let mut var_sum = 0.0f32;
    let mut var_weight = 0.0f32;
    for dy in -1i32..=1 {
        for dx in -1i32..=1 {
            let (qx, qy) = (x + dx, y + dy);
            if qx < 0 || qy < 0 || qx >= w || qy >= h || (guide[at(qx, qy)].w >= 0.0) != p_hit {
                continue;
            }
            let k = GAUSSIAN[dx.unsigned_abs() as usize] * GAUSSIAN[dy.unsigned_abs() as usize] * 4.0;
            var_sum += k * signal[at(qx, qy)].w;
            var_weight += k;
        }
    }
    let sigma = SIGMA_LUMINANCE * (var_sum / var_weight).max(0.0).sqrt();
    let l_p = luminance(s_p.truncate());
    // What every tap divides by, taken once a pixel: the luminance tolerance, and the depth
    // weight's width at each Manhattan offset (1 to 4 taps of `step` pixels).
    let centre_weights = CentreWeights {
        inv_sigma: 1.0 / (sigma + 1e-10),
        inv_depth_width: std::array::from_fn(|k| {
            1.0 / (SIGMA_DEPTH * a_p.z * ((k as i32 + 1) * step) as f32 + 1e-6 * g_p.w + 1e-12)
        }),
    };
    let mut sum = Vec3::ZERO;
    let mut var = 0.0f32;
    let mut weight_sum = 0.0f32;
    for dy in -2i32..=2 {
        for dx in -2i32..=2 {
            let (qx, qy) = (x + dx * step, y + dy * step);
            if qx < 0 || qy < 0 || qx >= w || qy >= h {
                continue;
            }
            let q = at(qx, qy);
            let (s_q, g_q) = (signal[q], guide[q]);
            let h_q = KERNEL[dx.unsigned_abs() as usize] * KERNEL[dy.unsigned_abs() as usize];
            let weight = if q == centre {
                h_q
            } else {
                let offset = (dx.abs() + dy.abs()) as usize;
                h_q * edge_stopping((g_p, a_p), (g_q, aux[q]), offset, l_p, s_q, &centre_weights)
            };
            sum += weight * s_q.truncate();
            var += weight * weight * s_q.w;
            weight_sum += weight;
        }
    }
    // The centre's own tap keeps weight_sum ≥ h(0, 0) > 0.
    (sum / weight_sum).extend(var / (weight_sum * weight_sum))
}

/// The reciprocals a pixel's taps divide by ([`edge_stopping`]).
struct CentreWeights {
    /// 1 / the luminance tolerance.
    inv_sigma: f32,
    /// 1 / the depth weight's width at a Manhattan offset of 1, 2, 3 and 4 taps.
    inv_depth_width: [f32; 4],
}

/// The product of SVGF's three edge-stopping functions (eq. 3–5) and the emission and
/// coverage weights (module documentation) between the centre (guides `g_p`, `a_p`,
/// luminance `l_p`, its reciprocal widths `centre`) and tap `q` (guides `g_q`, `a_q`,
/// signal `s_q`) `offset` taps away (Manhattan, 1 to 4).
#[inline]
fn edge_stopping(
    (g_p, a_p): (Vec4, Vec4),
    (g_q, a_q): (Vec4, Vec4),
    offset: usize,
    l_p: f32,
    s_q: Vec4,
    centre: &CentreWeights,
) -> f32 {
    let (p_hit, q_hit) = (g_p.w >= 0.0, g_q.w >= 0.0);
    if p_hit != q_hit {
        return 0.0;
    }
    // The weights' exponents are summed and taken once: e^−a·e^−b = e^−(a+b).
    let mut normal = 1.0;
    let mut exponent = 0.0;
    if p_hit {
        normal = g_p.truncate().dot(g_q.truncate()).max(0.0);
        for _ in 0..SIGMA_NORMAL_SQUARINGS {
            normal *= normal;
        }
        exponent += (g_p.w - g_q.w).abs() * centre.inv_depth_width[offset - 1];
    }
    if a_p.x != a_q.x {
        exponent += (a_p.x - a_q.x).abs() / (SIGMA_EMISSION * a_p.x.max(a_q.x) + 1e-12);
    }
    let l_q = luminance(s_q.truncate());
    exponent += (l_p - l_q).abs() * centre.inv_sigma + (a_p.y - a_q.y).abs() * (1.0 / SIGMA_COVERAGE);
    if normal == 0.0 || exponent > WEIGHT_EXPONENT_CUTOFF {
        return 0.0;
    }
    normal * (-exponent).exp()
}

/// One iteration over the whole image, rows in parallel.
pub fn iterate(width: u32, height: u32, step: i32, prepared: &Prepared, signal: &[Vec4]) -> Vec<Vec4> {
    let mut out = vec![Vec4::ZERO; signal.len()];
    out.par_chunks_mut(width as usize).enumerate().for_each(|(y, row)| {
        for (x, v) in row.iter_mut().enumerate() {
            *v = atrous_pixel(
                (width, height),
                step,
                (x as i32, y as i32),
                signal,
                &prepared.guide,
                &prepared.aux,
            );
        }
    });
    out
}

/// The whole filter on the CPU (module documentation).
pub fn denoise(input: &DenoiseInput) -> Vec<Vec3> {
    let prepared = prepare(input);
    let mut signal = prepared.signal.clone();
    for i in 0..ITERATIONS {
        signal = iterate(input.width, input.height, 1 << i, &prepared, &signal);
    }
    let filtered = finish(&prepared, &signal);
    super::edges::reconstruct_edges(input, &prepared, &signal, &filtered)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Aovs;

    /// A 16 × 8 image: columns 0–7 see a wall (depth 1 + x/10, noisy), columns 8–15 see the
    /// environment; the environment's rows 0–3 are calm (kept), rows 4–7 noisy (filtered).
    fn half_wall() -> (Vec<Vec3>, Vec<Vec3>, Aovs) {
        let (w, h) = (16usize, 8usize);
        let mut rng = crate::sampling::Rng::new(1, 2, 3, 4);
        let (mut color, mut variance) = (Vec::new(), Vec::new());
        let mut aovs = Aovs { width: w as u32, height: h as u32, ..Aovs::default() };
        for i in 0..w * h {
            let (x, y) = (i % w, i / w);
            let wall = x < 8;
            let noisy = wall || y >= 4;
            color.push(Vec3::new(0.5, 0.4, 0.3) * if noisy { 0.5 + rng.next_1d() } else { 1.0 });
            variance.push(Vec3::splat(if noisy { 0.02 } else { 1e-9 }));
            aovs.albedo.push(if wall { Vec3::splat(0.5) } else { Vec3::ZERO });
            aovs.normal.push(if wall { Vec3::Z } else { Vec3::ZERO });
            aovs.depth.push(if wall { 1.0 + x as f32 / 10.0 } else { f32::INFINITY });
            aovs.emission.push(Vec3::ZERO);
            aovs.coverage.push(if wall { 1.0 } else { 0.0 });
        }
        (color, variance, aovs)
    }

    /// Keeping the calm misses as they are changes no surface pixel's output, bit for bit: a
    /// surface pixel never reads a miss. (The noisy misses read the kept ones, now unfiltered.)
    #[test]
    fn keeping_calm_misses_changes_no_other_pixel() {
        let (color, variance, aovs) = half_wall();
        let input =
            DenoiseInput { width: 16, height: 8, color: &color, variance: &variance, aovs: &aovs, spp: 16.0 };
        let kept = prepare(&input);
        let mut filtered_all = kept.clone();
        for a in &mut filtered_all.aux {
            a.w = 0.0;
        }
        let kept_count = kept.aux.iter().filter(|a| a.w != 0.0).count();
        assert_eq!(kept_count, 8 * 4, "the calm misses, and only they, are kept");
        let (mut a, mut b) = (kept.signal.clone(), filtered_all.signal.clone());
        for i in 0..ITERATIONS {
            a = iterate(16, 8, 1 << i, &kept, &a);
            b = iterate(16, 8, 1 << i, &filtered_all, &b);
        }
        for (p, (x, y)) in a.iter().zip(&b).enumerate() {
            if kept.aux[p].w != 0.0 {
                assert_eq!(*x, kept.signal[p], "pixel {p} kept");
            } else if p % 16 < 8 {
                assert_eq!(x, y, "pixel {p}");
            }
        }
        // The noisy misses were filtered, not kept.
        assert!((4 * 16..8 * 16).filter(|&p| p % 16 >= 8).any(|p| a[p] != kept.signal[p]));
    }
}
