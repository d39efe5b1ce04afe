//! The sheen lobe of KHR_materials_sheen: the "Charlie" microfibre distribution (Estevez &
//! Kulla 2017, "Production Friendly Microfacet Sheen BRDF", eq. 2) with Ashikhmin's
//! visibility term (Ashikhmin & Premože 2007), the alternative the extension names to the
//! paper's fitted one:
//!
//! ```text
//! f_sheen = sheenColor · D(h) · V(wo, wi),   D = (2 + 1/α) sin^(1/α)θ_h / 2π,
//! V = 1 / (4 (cos θi + cos θo − cos θi cos θo)),   α = sheenRoughness²
//! ```
//!
//! The layer under the sheen is scaled by `1 − max(sheenColor) · E(μ)`, E the lobe's
//! directional albedo, as the extension's "albedo scaling" specifies; E comes from a table
//! computed once by quadrature ([`sheen_albedo_table`]) that both backends read.
//!
//! Sampling is cosine-weighted: the lobe is broad, and next-event estimation covers it by
//! MIS.
//!
//! WGSL twin: `shaders/bsdf.wgsl` (same names).

use std::sync::OnceLock;

use glam::Vec3;

/// Sheen roughness is clamped to at least this. Below it the lobe is a sliver at grazing
/// angles that no image resolves, and the albedo table's quadrature would no longer resolve
/// it either (the table is accurate to about 1% down to here; `albedo_table_matches_a_fine_quadrature`).
pub const MIN_SHEEN_ROUGHNESS: f32 = 0.07;

/// The albedo table has this many entries along μ = cos θ and along roughness.
pub const SHEEN_ALBEDO_SIZE: usize = 32;

/// Charlie α from perceptual sheen roughness.
pub fn sheen_alpha(roughness: f32) -> f32 {
    let r = roughness.clamp(MIN_SHEEN_ROUGHNESS, 1.0);
    r * r
}

/// The Charlie distribution at a half vector with `cos_theta_h` = n·h.
pub fn charlie_d(cos_theta_h: f32, alpha: f32) -> f32 {
    let inv_alpha = 1.0 / alpha;
    let sin2 = (1.0 - cos_theta_h * cos_theta_h).max(0.0);
    (2.0 + inv_alpha) * sin2.powf(0.5 * inv_alpha) * (0.5 * std::f32::consts::FRAC_1_PI)
}

/// Ashikhmin's visibility term (it includes the microfacet 1/(4 cos θi cos θo)).
pub fn ashikhmin_v(cos_o: f32, cos_i: f32) -> f32 {
    let s = cos_i + cos_o - cos_i * cos_o;
    if s > 0.0 {
        0.25 / s
    } else {
        0.0
    }
}

/// The sheen lobe for a white sheen colour, without the cosine; 0 outside the upper
/// hemisphere.
pub fn sheen_eval(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let Some(h) = (wo + wi).try_normalize() else { return 0.0 };
    charlie_d(h.z, alpha) * ashikhmin_v(wo.z, wi.z)
}

/// E(μ, roughness) for `SHEEN_ALBEDO_SIZE`² pairs: row `j` is roughness
/// `j / (SIZE − 1)`, column `i` is μ = `i / (SIZE − 1)`; evaluated through the clamped
/// [`sheen_alpha`], like the lobe itself.
pub fn sheen_albedo_table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| sheen_albedo_quadrature(SHEEN_ALBEDO_SIZE, 96, 48))
}

/// The directional albedo ∫ f_sheen cos θi dωi (white sheen) on a `size`² grid, by the
/// midpoint rule over θi (uniform in angle, which puts nodes near the horizon where the
/// lobe peaks) and φi ∈ [0, π] (the lobe is symmetric about the plane of wo).
pub fn sheen_albedo_quadrature(size: usize, theta_steps: usize, phi_steps: usize) -> Vec<f32> {
    let mut table = vec![0.0f32; size * size];
    let d_theta = std::f64::consts::FRAC_PI_2 / theta_steps as f64;
    let d_phi = std::f64::consts::PI / phi_steps as f64;
    for j in 0..size {
        let alpha = sheen_alpha(j as f32 / (size - 1) as f32) as f64;
        for i in 0..size {
            // μ = 0 exactly has no direction to integrate from: use a hair above it.
            let mu = (i as f64 / (size - 1) as f64).max(1e-4);
            let wo = [(1.0 - mu * mu).sqrt(), 0.0, mu];
            let mut sum = 0.0f64;
            for t in 0..theta_steps {
                let theta = (t as f64 + 0.5) * d_theta;
                let (sin_t, cos_t) = theta.sin_cos();
                for p in 0..phi_steps {
                    let phi = (p as f64 + 0.5) * d_phi;
                    let wi = [sin_t * phi.cos(), sin_t * phi.sin(), cos_t];
                    let h = [wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]];
                    let len = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
                    let cos_h = h[2] / len;
                    let sin2 = (1.0 - cos_h * cos_h).max(0.0);
                    let d = (2.0 + 1.0 / alpha) * sin2.powf(0.5 / alpha) / (2.0 * std::f64::consts::PI);
                    let v = 0.25 / (cos_t + mu - cos_t * mu);
                    sum += d * v * cos_t * sin_t;
                }
            }
            table[j * size + i] = (2.0 * sum * d_theta * d_phi) as f32;
        }
    }
    table
}

/// E(μ, roughness) from `table` (bilinear; both arguments clamped to [0, 1]).
pub fn sheen_albedo(table: &[f32], mu: f32, roughness: f32) -> f32 {
    let last = (SHEEN_ALBEDO_SIZE - 1) as f32;
    let x = mu.clamp(0.0, 1.0) * last;
    let y = roughness.clamp(0.0, 1.0) * last;
    let (x0, y0) = (x.floor().min(last - 1.0), y.floor().min(last - 1.0));
    let (tx, ty) = (x - x0, y - y0);
    let (x0, y0) = (x0 as usize, y0 as usize);
    let at = |i: usize, j: usize| table[j * SHEEN_ALBEDO_SIZE + i];
    let top = at(x0, y0) * (1.0 - tx) + at(x0 + 1, y0) * tx;
    let bottom = at(x0, y0 + 1) * (1.0 - tx) + at(x0 + 1, y0 + 1) * tx;
    top * (1.0 - ty) + bottom * ty
}

/// The albedo scaling of the layer under a sheen of colour `sheen_color` for directions
/// with cosines `mu_o`, `mu_i` (KHR_materials_sheen: min(1 − max(c)·E(μo), 1 − max(c)·E(μi))),
/// clamped to [0, 1] (E exceeds 1 at grazing angles for the smoothest sheens).
pub fn sheen_albedo_scaling(table: &[f32], sheen_color: Vec3, roughness: f32, mu_o: f32, mu_i: f32) -> f32 {
    let c = sheen_color.max_element();
    let e = sheen_albedo(table, mu_o, roughness).max(sheen_albedo(table, mu_i, roughness));
    (1.0 - c * e).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn charlie_is_normalised_over_projected_half_vectors() {
        // ∫ D(h) cos θh dωh = 1 for a microfacet distribution (Estevez & Kulla eq. 2 is
        // normalised this way); midpoint rule in θ, exact in φ.
        for r in [0.1f32, 0.3, 0.6, 1.0] {
            let alpha = sheen_alpha(r);
            let n = 20_000;
            let dt = std::f32::consts::FRAC_PI_2 / n as f32;
            let total: f32 = (0..n)
                .map(|k| {
                    let t = (k as f32 + 0.5) * dt;
                    charlie_d(t.cos(), alpha) * t.cos() * t.sin() * dt * 2.0 * std::f32::consts::PI
                })
                .sum();
            // Midpoint rule on a smooth integrand with 2·10⁴ nodes: error far below 1e-3.
            assert!((total - 1.0).abs() < 1e-3, "roughness {r}: {total}");
        }
    }

    #[test]
    fn albedo_table_matches_a_fine_quadrature() {
        let coarse = sheen_albedo_table();
        let fine = sheen_albedo_quadrature(SHEEN_ALBEDO_SIZE, 384, 192);
        for (k, (c, f)) in coarse.iter().zip(&fine).enumerate() {
            // 1% of the albedo (or 1e-3 absolute where it is tiny) is far below what the
            // scaling of the base layer can show.
            assert!((c - f).abs() <= 0.01 * f + 1e-3, "entry {k}: {c} vs {f}");
        }
    }

    #[test]
    fn albedo_table_matches_monte_carlo_integration() {
        // An independent estimator: cosine-weighted directions, E = mean(f · π).
        let table = sheen_albedo_table();
        let mut rng = Rng::new(7, 7, 7, 7);
        for (mu, r) in [(0.9f32, 0.3f32), (0.5, 0.5), (0.2, 0.8), (0.7, 1.0)] {
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let alpha = sheen_alpha(r);
            let n = 400_000;
            let mean: f64 = (0..n)
                .map(|_| {
                    let wi = crate::bsdf::lambert::lambert_sample(rng.next_2d());
                    (sheen_eval(wo, wi, alpha) * std::f32::consts::PI) as f64
                })
                .sum::<f64>()
                / n as f64;
            let e = sheen_albedo(table, mu, r) as f64;
            // 4e5 samples of a bounded integrand: the standard error is well under 0.5% of
            // E; bilinear interpolation between 32² nodes adds under 1%.
            assert!((mean - e).abs() < 0.02 * e + 2e-3, "mu {mu} r {r}: MC {mean} table {e}");
        }
    }
}
