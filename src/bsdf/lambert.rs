//! The Lambertian lobe, 1/π, sampled by the cosine-weighted hemisphere.

use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

use crate::sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere};

pub fn lambert_sample(u: Vec2) -> Vec3 {
    sample_cosine_hemisphere(u)
}

/// 1/π for directions on the same side as `wo` (which is +z), else 0.
pub fn lambert_eval(wi: Vec3) -> f32 {
    if wi.z > 0.0 {
        FRAC_1_PI
    } else {
        0.0
    }
}

pub fn lambert_pdf(wi: Vec3) -> f32 {
    cosine_hemisphere_pdf(wi.z)
}
