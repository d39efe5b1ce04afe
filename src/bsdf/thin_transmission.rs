//! Thin-walled transmission: light crosses both faces of an infinitely thin sheet, so it
//! leaves undeflected but roughened. Modelled as the GGX reflection lobe mirrored through
//! the surface plane (the glTF Sample Viewer's thin-walled model); at α = 0 it becomes
//! straight-through transmission.

use glam::{Vec2, Vec3};

use super::reflection::{reflection_eval, reflection_pdf, reflection_sample};

fn mirror(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

pub fn thin_transmission_sample(wo: Vec3, alpha: f32, u: Vec2) -> Option<Vec3> {
    reflection_sample(wo, alpha, u).map(mirror)
}

/// The half vector used for the Fresnel weight: that of the mirrored reflection pair.
pub fn thin_transmission_half_vector(wo: Vec3, wi: Vec3) -> Option<Vec3> {
    if wi.z >= 0.0 {
        return None;
    }
    super::reflection::reflection_half_vector(wo, mirror(wi))
}

pub fn thin_transmission_eval(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    if wi.z >= 0.0 {
        return 0.0;
    }
    reflection_eval(wo, mirror(wi), alpha)
}

pub fn thin_transmission_pdf(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    if wi.z >= 0.0 {
        return 0.0;
    }
    reflection_pdf(wo, mirror(wi), alpha)
}
