//! Rough refraction through a dielectric boundary (Walter, Marschner, Li & Torrance 2007,
//! "Microfacet Models for Refraction through Rough Surfaces"; pbrt-v4
//! `DielectricBxDF`), without its (1 − F) weight, which the glTF layering applies.
//!
//! `eta` is η_transmitted / η_incident, where the incident side is `wo`'s (+z).

use glam::{Vec2, Vec3};

use super::microfacet::{ggx_d, ggx_g2, sample_visible_normal, visible_normal_pdf};
use super::refract_through;

/// A refracted direction (below the surface) with density [`transmission_pdf`], or `None`
/// on total internal reflection.
pub fn transmission_sample(wo: Vec3, alpha: f32, eta: f32, u: Vec2) -> Option<Vec3> {
    let m = sample_visible_normal(wo, alpha, u);
    let wi = refract_through(wo, m, eta)?;
    (wi.z < 0.0).then_some(wi)
}

/// The generalised half vector of a refraction pair (Walter et al. eq. 16), oriented to +z,
/// or `None` if degenerate or if either direction sees the back of the microfacet.
pub fn transmission_half_vector(wo: Vec3, wi: Vec3, eta: f32) -> Option<Vec3> {
    if wo.z <= 0.0 || wi.z >= 0.0 {
        return None;
    }
    let mut m = (wi * eta + wo).try_normalize()?;
    if m.z < 0.0 {
        m = -m;
    }
    // Both directions must see the front of the microfacet: wo above it, wi below.
    if wo.dot(m) <= 0.0 || wi.dot(m) >= 0.0 {
        return None;
    }
    Some(m)
}

/// D G₂ |wi·m| |wo·m| / (|cos θi| |cos θo| (wi·m + wo·m/η)²) / η² (Walter et al. eq. 21,
/// the 1/η² for radiance transport as in pbrt-v4).
pub fn transmission_eval(wo: Vec3, wi: Vec3, alpha: f32, eta: f32) -> f32 {
    let Some(m) = transmission_half_vector(wo, wi, eta) else { return 0.0 };
    let wi_m = wi.dot(m);
    let wo_m = wo.dot(m);
    let denom = (wi_m + wo_m / eta).powi(2) * wi.z.abs() * wo.z;
    if denom == 0.0 {
        return 0.0;
    }
    ggx_d(m, alpha) * ggx_g2(wo, wi, alpha) * (wi_m * wo_m).abs() / denom / (eta * eta)
}

/// Density per solid angle: D_wo(m) |wi·m| / (wi·m + wo·m/η)² (Walter et al. eq. 17).
pub fn transmission_pdf(wo: Vec3, wi: Vec3, alpha: f32, eta: f32) -> f32 {
    let Some(m) = transmission_half_vector(wo, wi, eta) else { return 0.0 };
    let wi_m = wi.dot(m);
    let denom = (wi_m + wo.dot(m) / eta).powi(2);
    if denom == 0.0 {
        return 0.0;
    }
    visible_normal_pdf(wo, m, alpha) * wi_m.abs() / denom
}
