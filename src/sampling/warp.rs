//! Warps from [0,1)² to the domains a path tracer samples, each with its density.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI};

/// Concentric map from the square to the unit disk (Shirley & Chiu 1997).
pub fn sample_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted hemisphere about +z by Malley's method.
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = sample_uniform_disk_concentric(u);
    let z = (1.0 - d.x * d.x - d.y * d.y).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`sample_cosine_hemisphere`] per unit solid angle.
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the unit sphere.
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform point on a triangle as barycentrics `(b0, b1, b2)`, by Heitz's low-distortion
/// map (Heitz 2019, "A Low-Distortion Map Between Triangle and Square"; pbrt-v4
/// `SampleUniformTriangle`). Density: 1 / area.
pub fn sample_uniform_triangle(u: Vec2) -> Vec3 {
    let (b0, b1) = if u.x < u.y {
        let b0 = u.x / 2.0;
        (b0, u.y - b0)
    } else {
        let b1 = u.y / 2.0;
        (u.x - b1, b1)
    };
    Vec3::new(b0, b1, 1.0 - b0 - b1)
}

/// The power heuristic with β = 2 for two strategies of one sample each (Veach 1997,
/// §9.2.4): pdf_this² / (pdf_this² + pdf_other²), evaluated through the ratio of the smaller
/// density to the larger so that nothing is squared past f32's range (tiny bright lights
/// have solid-angle densities above 1e19).
pub fn power_heuristic(pdf_this: f32, pdf_other: f32) -> f32 {
    if pdf_this <= 0.0 {
        return 0.0;
    }
    if pdf_this >= pdf_other {
        let r = pdf_other / pdf_this;
        1.0 / (1.0 + r * r)
    } else {
        let r = pdf_this / pdf_other;
        r * r / (1.0 + r * r)
    }
}

#[cfg(test)]
mod tests {
    use super::power_heuristic;

    #[test]
    fn power_heuristic_is_stable_at_extremes() {
        assert_eq!(power_heuristic(0.0, 1.0), 0.0);
        assert!((power_heuristic(1.0, 1.0) - 0.5).abs() < 1e-7);
        assert!((power_heuristic(2.0, 1.0) - 0.8).abs() < 1e-7);
        assert!((power_heuristic(1e30, 1e29) + power_heuristic(1e29, 1e30) - 1.0).abs() < 1e-6);
        assert_eq!(power_heuristic(1.0, 0.0), 1.0);
    }
}
