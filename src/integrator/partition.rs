//! The partition of path space between the path tracer and the light tracer.
//!
//! A path tracer finds a caustic (light reaching a diffuse surface through glass or a mirror)
//! only when a BSDF sample from the diffuse surface happens to pass through the delta chain
//! and hit the light: next-event estimation cannot see the light through a delta lobe. The
//! light tracer (`super::light_tracing`) finds the same paths the other way round. The two
//! share the work by a fixed partition, so no MIS weights are needed and each path is
//! counted exactly once. A path x₀ (camera) x₁ … x_{k−1} x_k (light) belongs to light
//! tracing when
//! * x₁ scattered by a non-delta lobe (the camera can be connected to it), and
//! * x_{k−1}, the vertex next to the light, scattered by a delta lobe (NEE cannot sample
//!   it, so the path tracer would only find it by chance),
//!
//! and to the path tracer otherwise ([`caustic_is_light_traced`] is the rule the path
//! tracer drops them by). Both halves are unbiased, so the sum is (Jensen 1996's caustic
//! partition; Veach 1997 §10.2's t = 1 strategy without its MIS weights).
//!
//! Only scenes where the light tracer computes exactly what the path tracer drops use it
//! ([`supports_light_tracing`]): a pinhole camera; materials that are either purely
//! Lambertian or purely delta (the adjoint of any other glTF layering, whose directional
//! albedo scalings are not reciprocal, is not the BSDF with its arguments swapped); no
//! textures or alpha; at least one emissive triangle and one delta material.
//!
//! WGSL twin: `shaders/partition.wgsl` (the rule; the kernel learns the scene's support
//! from `frame.light_traced_caustics`).

use glam::Vec3;

use crate::bsdf::GltfBsdf;
use crate::scene::layout::{Camera, INVALID_INDEX, LIGHT_TRIANGLE, PROJECTION_PERSPECTIVE};
use crate::scene::FlatScene;

/// Does the path tracer leave to the light tracer the emission it just met? `prev_delta`:
/// the last scattering (into the emitter) sampled a delta lobe; `first_vertex_smooth`: the
/// path's first vertex scattered by a non-delta lobe; `emitter`: the emitter index of the
/// triangle hit (`INVALID_INDEX` for emission that is no light, which the light tracer
/// never starts from). Only where caustics are light traced at all.
#[inline(always)]
pub fn caustic_is_light_traced(prev_delta: bool, first_vertex_smooth: bool, emitter: u32) -> bool {
    prev_delta && first_vertex_smooth && emitter != INVALID_INDEX
}

/// Can the light tracer take over the caustic paths of `scene` seen through `camera`?
/// See the module documentation for why each condition is there. Reads every triangle:
/// call it once per scene and camera.
pub fn supports_light_tracing(scene: &FlatScene, camera: &Camera) -> bool {
    camera_supports_light_tracing(camera) && scene_supports_light_tracing(scene)
}

/// The camera's half of [`supports_light_tracing`]: a pinhole (the connection's importance
/// is a pinhole's).
pub fn camera_supports_light_tracing(camera: &Camera) -> bool {
    camera.projection == PROJECTION_PERSPECTIVE
}

/// The scene's half of [`supports_light_tracing`].
pub fn scene_supports_light_tracing(scene: &FlatScene) -> bool {
    let f = &scene.features;
    if f.textures
        || f.alpha
        || f.normal_maps
        || f.clearcoat
        || f.sheen
        || !scene.lights.iter().any(|l| l.kind == LIGHT_TRIANGLE)
    {
        return false;
    }
    let mut any_delta = false;
    for (m, _) in scene.materials.iter().zip(&scene.used_materials).filter(|(_, used)| **used) {
        // Seen from either side: a refracting solid's BSDF depends on the side.
        let sides = [true, false].map(|front| GltfBsdf::new(m, Vec3::Z, front, Vec3::Z));
        // Lambertian, or black (no lobe at all: it scatters nothing either way).
        if sides.iter().all(|b| b.is_lambertian() || b.lobe_probabilities().iter().all(|&p| p == 0.0)) {
            continue;
        }
        if sides.iter().any(|b| b.has_non_delta()) {
            return false;
        }
        any_delta = true;
    }
    any_delta
}
