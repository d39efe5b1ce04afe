//! The glTF 2.0 BSDF: one file per lobe, each with `sample`, `eval` and `pdf`, combined by
//! `gltf.rs` as the specification's Appendix B and the KHR_materials_* extensions define.
//!
//! All lobes work in the local shading frame: the normal is +z and the outgoing direction
//! `wo` (towards the viewer) has `wo.z > 0`; `gltf.rs` arranges that by flipping the frame
//! for back-face hits. Values returned by `eval` exclude the cosine factor.
//!
//! WGSL twins: `shaders/bsdf.wgsl` (the lobes) and `shaders/bsdf_gltf.wgsl` (`gltf.rs`),
//! with the same function names.

pub mod fresnel;
mod gltf;
pub mod lambert;
pub mod microfacet;
pub mod reflection;
pub mod sheen;
pub mod thin_transmission;
pub mod transmission;

pub use gltf::{
    is_delta_only, BsdfSample, GltfBsdf, CLEARCOAT_F0, COAT_MIN_BASE_COSINE, LOBE_SELECTION_FLOOR,
};

/// Smallest GGX α used for a non-zero roughness. GGX's normalisation has α⁴ in its
/// denominator; below α ≈ 1e-4 that underflows f32 (and GPUs flush denormals), so rougher
/// than "exactly 0" but smoother than this is rendered at this α. Exactly 0 is a true delta.
pub const MIN_ALPHA: f32 = 1e-4;

/// GGX α from glTF perceptual roughness: α = roughness² (glTF 2.0 Appendix B), 0 for a
/// perfectly smooth surface (a delta lobe), else at least [`MIN_ALPHA`].
pub fn alpha_from_roughness(roughness: f32) -> f32 {
    let r = roughness.clamp(0.0, 1.0);
    if r == 0.0 {
        0.0
    } else {
        (r * r).max(MIN_ALPHA)
    }
}

/// Mirror `w` about the normal `n`.
pub fn reflect_about(w: glam::Vec3, n: glam::Vec3) -> glam::Vec3 {
    -w + 2.0 * w.dot(n) * n
}

/// Refract `wi` (pointing away from the surface, on `n`'s side) through a boundary with
/// relative index `eta` = η_transmitted / η_incident; `None` on total internal reflection
/// (pbrt-v4 `Refract`, eq. 9.4).
pub fn refract_through(wi: glam::Vec3, n: glam::Vec3, eta: f32) -> Option<glam::Vec3> {
    let cos_i = wi.dot(n);
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-wi / eta + (cos_i / eta - cos_t) * n)
}
