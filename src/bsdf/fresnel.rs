//! Fresnel reflectance.

use glam::Vec3;

/// Schlick's approximation with an explicit grazing value, `F₀ + (F₉₀ − F₀)(1 − cos)⁵`
/// (Schlick 1994; the form KHR_materials_specular uses).
pub fn fresnel_schlick(f0: Vec3, f90: f32, cos_theta: f32) -> Vec3 {
    let m = (1.0 - cos_theta.clamp(0.0, 1.0)).powi(5);
    f0 + (Vec3::splat(f90) - f0) * m
}

/// Exact unpolarised Fresnel reflectance of a dielectric boundary (pbrt-v4 `FrDielectric`,
/// eq. 9.5). `cos_theta_i` is measured on the incident side's normal; `eta` =
/// η_transmitted / η_incident. Returns 1 under total internal reflection.
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> f32 {
    let mut cos_i = cos_theta_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_i = 1.0 - cos_i * cos_i;
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    (r_parl * r_parl + r_perp * r_perp) / 2.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_fresnel_known_values() {
        // Normal incidence: ((η−1)/(η+1))², 0.04 for glass.
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        // Brewster's angle: tan θ_B = η, where the parallel term vanishes and the
        // perpendicular one is sin²(θi−θt)/sin²(θi+θt)...; the total is 0.0740 for η = 1.5.
        let theta_b = 1.5f32.atan();
        assert!((fresnel_dielectric(theta_b.cos(), 1.5) - 0.07396).abs() < 1e-4);
        // Total internal reflection beyond the critical angle from inside glass.
        let critical = (1.0f32 / 1.5).asin();
        assert_eq!(fresnel_dielectric((critical + 0.01).cos(), 1.0 / 1.5), 1.0);
        assert!(fresnel_dielectric((critical - 0.01).cos(), 1.0 / 1.5) < 1.0);
        // Grazing incidence reflects everything.
        assert!((fresnel_dielectric(0.0, 1.5) - 1.0).abs() < 1e-6);
        // Approaching from the other side is the same boundary.
        assert_eq!(fresnel_dielectric(-0.5, 1.5), fresnel_dielectric(0.5, 1.0 / 1.5));
    }
}
