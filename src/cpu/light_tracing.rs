//! Caustic paths by light tracing: a partition of path space between the path tracer and a
//! light tracer that connects to the camera.
//!
//! A path tracer finds a caustic (light reaching a diffuse surface through glass or a mirror)
//! only when a BSDF sample from the diffuse surface happens to pass through the delta
//! chain and hit the light: next-event estimation cannot see the light through a delta
//! lobe. Those rare, bright samples were 96% of the glass Cornell box's variance
//! (bench/RESULTS.md, thirteenth session). A light tracer finds the same paths the other
//! way round: light → glass → floor, then a connection from the floor to the camera, as
//! the caustic photon map does (Jensen 1996, "Global Illumination using Photon Maps") and
//! as the t = 1 strategy of bidirectional path tracing does (Veach 1997 §10.2).
//!
//! The two estimators share the work by a fixed partition, so no MIS weights are needed
//! and each path is counted exactly once. A path x₀ (camera) x₁ … x_{k−1} x_k (light)
//! belongs to light tracing when
//! * x₁ scattered by a non-delta lobe (the camera can be connected to it), and
//! * x_{k−1}, the vertex next to the light, scattered by a delta lobe (NEE cannot sample
//!   it, so the path tracer would only find it by chance),
//!
//! and to the path tracer otherwise (`IntegratorSettings::caustics_by_light_tracing` drops
//! exactly these paths there). Both halves are unbiased, so the sum is.
//!
//! Per sample index k, [`trace_caustic_pass`] traces one light path per pixel and returns
//! the image of their camera connections divided by that count: an unbiased estimate of
//! the light-traced half of every pixel, independent of the path-traced samples. The CPU
//! backend adds it to sample k of each pixel, so the film's per-pixel statistics still see
//! one independent estimate per sample (`film_add_sample`).
//!
//! Light tracing transports importance, not radiance, so two factors differ from the path
//! tracer's (Veach 1997 §5.2–5.3; pbrt-v3 `CorrectShadingNormal`, pbrt-v4
//! `TransportMode::Importance`):
//! * refraction's radiance factor 1/η² is absent ([`BsdfSample::eta_scale`] takes it back);
//! * shading normals make the adjoint BSDF differ by |ωₗ·nₛ||ωₙ·n_g| / (|ωₗ·n_g||ωₙ·nₛ|)
//!   (ωₗ towards the light, ωₙ the sampled direction).
//!
//! Only scenes where the light tracer computes exactly what the path tracer drops use it
//! ([`supports_light_tracing`]): a pinhole camera; materials that are either purely
//! Lambertian or purely delta (the adjoint of any other glTF layering, whose directional
//! albedo scalings are not reciprocal, is not the BSDF with its arguments swapped); no
//! textures or alpha; at least one emissive triangle and one delta material.

use glam::Vec3;
use rayon::prelude::*;

use super::integrator::{sides_agree, surface_interaction, IntegratorSettings, MAX_BOUNCES_GUARD};
use crate::bsdf::GltfBsdf;
use crate::bvh::ClosestHit;
use crate::geometry::{spawn_ray, spawn_ray_to, Frame, Ray, TriangleHit};
use crate::light::{choose_light, sample_triangle_point, triangle_light_normal_area};
use crate::sampling::{sample_cosine_hemisphere, Rng};
use crate::scene::camera::PinholeProjection;
use crate::scene::layout::{
    Camera, LIGHT_TRIANGLE, MATERIAL_DOUBLE_SIDED, MATERIAL_VOLUME, PROJECTION_PERSPECTIVE,
};
use crate::scene::texture::emitted_radiance;
use crate::scene::FlatScene;

/// Light paths per rayon task: enough to amortise the task, few enough to balance two
/// threads on a 256² pass (64 tasks).
const PATHS_PER_TASK: usize = 1024;

/// Light-path vertices after which roulette may end a light path (the first is always the
/// delta vertex next to the light, the second the first surface the camera can see).
const LIGHT_RR_MIN_VERTICES: u32 = 2;

/// The row of [`Rng::new`] that light paths draw from: no pixel has it (an image has fewer
/// than 2²⁸ pixels, `crate::render::MAX_PIXELS`), so their streams never meet a pixel's.
const LIGHT_PATH_STREAM: u32 = u32::MAX;

/// Can the light tracer take over the caustic paths of `scene` seen through `camera`?
/// See the module documentation for why each condition is there. Reads every triangle:
/// call it once per scene and camera.
pub fn supports_light_tracing(scene: &FlatScene, camera: &Camera) -> bool {
    let f = &scene.features;
    if camera.projection != PROJECTION_PERSPECTIVE
        || f.textures
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

/// The light-traced half of every pixel for sample index `pass`: one light path per pixel,
/// the image of their camera connections divided by the number of paths (row-major, the
/// film's layout), and the rays they traced. Deterministic: path i draws its numbers from
/// its own stream, and the connections are summed in path order.
pub fn trace_caustic_pass(
    scene: &FlatScene,
    camera: &Camera,
    settings: &IntegratorSettings,
    width: u32,
    height: u32,
    pass: u32,
    seed: u32,
) -> (Vec<Vec3>, u64) {
    let projection = PinholeProjection::new(camera, width, height);
    let paths = width as usize * height as usize;
    let tasks: Vec<(Vec<(usize, Vec3)>, u64)> = (0..paths.div_ceil(PATHS_PER_TASK))
        .into_par_iter()
        .map(|task| {
            let mut splats = Vec::new();
            let mut rays = 0;
            for i in task * PATHS_PER_TASK..((task + 1) * PATHS_PER_TASK).min(paths) {
                let mut rng = Rng::new(i as u32, LIGHT_PATH_STREAM, pass, seed);
                trace_light_path(scene, &projection, settings, &mut rng, &mut splats, &mut rays);
            }
            (splats, rays)
        })
        .collect();
    let mut image = vec![Vec3::ZERO; paths];
    let mut rays = 0;
    let scale = 1.0 / paths as f32;
    for (splats, task_rays) in tasks {
        rays += task_rays;
        for (pixel, value) in splats {
            image[pixel] += value * scale;
        }
    }
    (image, rays)
}

/// Traces one light path and pushes its camera connections as (pixel, value) before the
/// division by the number of paths.
fn trace_light_path(
    scene: &FlatScene,
    camera: &PinholeProjection,
    settings: &IntegratorSettings,
    rng: &mut Rng,
    splats: &mut Vec<(usize, Vec3)>,
    rays: &mut u64,
) {
    // The light and a point on it, chosen as next-event estimation chooses them: a
    // non-triangle light (point, environment) has no path here, which keeps the estimate
    // unbiased for the triangle lights (the light tracer's share of the others is zero).
    let light = &scene.lights[choose_light(&scene.lights, rng.next_2d())];
    let u_point = rng.next_2d();
    let u_side = rng.next_1d();
    let u_direction = rng.next_2d();
    if light.kind != LIGHT_TRIANGLE || light.pmf <= 0.0 {
        return;
    }
    let tri = &scene.triangles[light.triangle as usize];
    let material = &scene.materials[tri.material as usize];
    let (n_light, area) = triangle_light_normal_area(light);
    if area == 0.0 {
        return;
    }
    let (b, q, q_error) = sample_triangle_point(tri, u_point);
    // Emission leaves the front (the winding's side), or either side, chosen by a coin,
    // for a double-sided material.
    let double_sided = material.flags & MATERIAL_DOUBLE_SIDED != 0;
    let sides = if double_sided { 2.0 } else { 1.0 };
    let n_emit = if double_sided && u_side < 0.5 { -n_light } else { n_light };
    let le = emitted_radiance(&scene.texture_arrays(), material, light.triangle as usize, b);
    // Point density pmf / area, cosine-weighted direction density cos θ / π (per side):
    // β = Le cos θ / (pdf_point pdf_direction) = Le π area sides / pmf.
    let mut beta = le * (std::f32::consts::PI * area * sides / light.pmf);
    if !beta.is_finite() || beta.max_element() <= 0.0 {
        return;
    }
    let roulette_scale = 1.0 / beta.max_element();
    let direction = Frame::from_z(n_emit).from_local(sample_cosine_hemisphere(u_direction));
    let mut ray = spawn_ray(q, q_error, n_emit, direction);

    // Vertex j of the light path is the j-th scattering event of the finished path.
    for j in 1..=MAX_BOUNCES_GUARD {
        *rays += 1;
        let Some(hit) = scene.intersect_closest(&ray, 0) else { return };
        let si = surface_interaction(scene, &ray, &hit, 0.0);
        let material = &scene.materials[si.material as usize];
        if material.flags & MATERIAL_VOLUME != 0 && !si.front_face {
            beta *= (-Vec3::from(material.attenuation_coefficient) * si.distance).exp();
        }
        let bsdf = GltfBsdf::new(material, si.wo, si.front_face, si.coat_normal);
        if j >= 2 && bsdf.has_non_delta() {
            if let Some(splat) = connect_to_camera(scene, camera, &si, &hit, beta, rays) {
                splats.push(splat);
            }
        }
        if j >= settings.max_depth {
            return;
        }
        let u_lobe = rng.next_1d();
        let u = rng.next_2d();
        let Some(bs) = bsdf.sample(si.wo, u_lobe, u) else { return };
        // The vertex next to the light must be a delta event: other paths are the path
        // tracer's.
        if j == 1 && !bs.is_delta {
            return;
        }
        let wi_world = si.frame.from_local(bs.wi).normalize();
        if !sides_agree(&si, wi_world, bs.wi) {
            return;
        }
        // The adjoint's shading-normal factor |ωₗ·nₛ||ωₙ·n_g| / (|ωₗ·n_g||ωₙ·nₛ|), exactly 1
        // where the shading normal is the geometric one.
        let ng = si.n_geometric;
        let shading = if si.frame.z == ng || si.frame.z == -ng {
            1.0
        } else {
            (si.wo.z * wi_world.dot(ng).abs()) / (si.wo_world.dot(ng).abs() * bs.wi.z.abs())
        };
        beta *= bs.weight * (bs.eta_scale * shading);
        if !beta.is_finite() {
            return;
        }
        if j >= LIGHT_RR_MIN_VERTICES {
            let survival = (beta.max_element() * roulette_scale).min(super::RR_MAX_SURVIVAL);
            // `beta` is finite here, so `survival` is a number.
            if survival <= 0.0 || rng.next_1d() >= survival {
                return;
            }
            beta /= survival;
        }
        ray = spawn_ray(si.p, si.p_error, ng, wi_world);
    }
}

/// The contribution of light-path vertex `si` (hit `hit`, throughput `beta`) to the pixel
/// it projects into, or `None` if it is outside the image, faces away or is occluded.
///
/// With the camera ray through that pixel meeting `si`, the path tracer would weigh the
/// light from ωₗ by f(ω_cam, ωₗ) |ωₗ·nₛ|; in area measure that is
/// f |ωₗ·nₛ| / |ωₗ·n_g| times G·W = |ω_cam·n_g| / (A_pixel cos³θ d²) for a pinhole whose
/// box pixel has area A_pixel on the plane at distance 1 (θ off the view axis, d the
/// distance; pbrt-v3 `PerspectiveCamera::We`).
fn connect_to_camera(
    scene: &FlatScene,
    camera: &PinholeProjection,
    si: &super::SurfaceInteraction,
    hit: &ClosestHit,
    beta: Vec3,
    rays: &mut u64,
) -> Option<(usize, Vec3)> {
    let (pixel, cos_theta, direction, distance2) = camera.project(si.p)?;
    // The surface as the camera ray through the pixel would see it: the same point, its
    // shading frame facing the camera, and the BSDF built for ω_cam.
    let camera_ray = Ray { origin: camera.position, direction, t_max: f32::MAX };
    let camera_hit =
        ClosestHit { triangle: hit.triangle, hit: TriangleHit { t: distance2.sqrt(), ..hit.hit } };
    let seen = surface_interaction(scene, &camera_ray, &camera_hit, 0.0);
    let material = &scene.materials[seen.material as usize];
    let bsdf = GltfBsdf::new(material, seen.wo, seen.front_face, seen.coat_normal);
    let w_light = si.wo_world;
    let wi = seen.frame.to_local(w_light);
    if !sides_agree(&seen, w_light, wi) {
        return None;
    }
    let f = bsdf.eval(seen.wo, wi);
    // A non-finite `f` is caught by the last line's test.
    if f.max_element() <= 0.0 {
        return None;
    }
    let ng = si.n_geometric;
    let cos_light_geometric = w_light.dot(ng).abs();
    if cos_light_geometric == 0.0 {
        return None;
    }
    *rays += 1;
    if scene.intersect_any(&spawn_ray_to(si.p, si.p_error, ng, camera.position), 0) {
        return None;
    }
    let value = beta * f * (wi.z.abs() * direction.dot(ng).abs())
        / (cos_light_geometric * camera.pixel_area * cos_theta * cos_theta * cos_theta * distance2);
    value.is_finite().then_some((pixel, value))
}
