//! The GGX microfacet reflection lobe D·G₂ / (4 cos θo cos θi), without its Fresnel weight
//! (the glTF layering applies that per half vector), sampled by visible normals.

use glam::{Vec2, Vec3};

use super::microfacet::{ggx_d, ggx_g2, sample_visible_normal, visible_normal_pdf};
use super::reflect_about;

/// A direction with density [`reflection_pdf`], or `None` when the mirrored direction falls
/// below the surface.
pub fn reflection_sample(wo: Vec3, alpha: f32, u: Vec2) -> Option<Vec3> {
    let m = sample_visible_normal(wo, alpha, u);
    let wi = reflect_about(wo, m);
    (wi.z > 0.0).then_some(wi)
}

/// The half vector of a reflection pair, or `None` if degenerate or below the surface.
pub fn reflection_half_vector(wo: Vec3, wi: Vec3) -> Option<Vec3> {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return None;
    }
    (wo + wi).try_normalize()
}

pub fn reflection_eval(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    let Some(m) = reflection_half_vector(wo, wi) else { return 0.0 };
    ggx_d(m, alpha) * ggx_g2(wo, wi, alpha) / (4.0 * wo.z * wi.z)
}

/// Density per solid angle: D_wo(m) / (4 |wo·m|) (the reflection Jacobian, Walter et al.
/// 2007, eq. 14).
pub fn reflection_pdf(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    let Some(m) = reflection_half_vector(wo, wi) else { return 0.0 };
    let wo_m = wo.dot(m).abs();
    if wo_m == 0.0 {
        return 0.0;
    }
    visible_normal_pdf(wo, m, alpha) / (4.0 * wo_m)
}
