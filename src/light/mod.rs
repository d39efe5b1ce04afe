//! Light sampling for next-event estimation: one light chosen by power from the alias
//! table, then a point on it (emissive triangles: uniform by area; punctual lights: their
//! position or direction).
//!
//! WGSL twin: `shaders/light.wgsl` (same function names).

mod environment;

pub use environment::{
    atan2_polynomial, environment_direction, environment_lookup, environment_uv, find_interval,
    sample_environment, EnvironmentDesc, FlatEnvironment,
};

use glam::{Vec2, Vec3};

use crate::geometry::{gamma, offset_ray_origin, spawn_ray, spawn_ray_to, Ray};
use crate::sampling::sample_uniform_triangle;
use crate::scene::layout::{
    Environment, Light, Material, Triangle, LIGHT_DIRECTIONAL, LIGHT_ENVIRONMENT, LIGHT_POINT, LIGHT_SPOT,
    LIGHT_TRIANGLE, MATERIAL_DOUBLE_SIDED,
};

/// The flat arrays light sampling reads.
#[derive(Clone, Copy)]
pub struct LightArrays<'a> {
    pub lights: &'a [Light],
    pub triangles: &'a [Triangle],
    pub materials: &'a [Material],
    pub environment: &'a Environment,
    pub environment_texels: &'a [[f32; 4]],
    pub environment_cdf: &'a [f32],
    /// For emissive textures.
    pub textures: crate::scene::texture::TextureArrays<'a>,
}

#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub wi: Vec3,
    /// Incident radiance (area lights) or irradiance-per-unit-solid-angle equivalent
    /// (delta lights: intensity / distance², or directional irradiance).
    pub radiance: Vec3,
    /// Area lights: density per solid angle at the shading point, including the choice of
    /// the light. Delta lights: the probability of choosing the light.
    pub pdf: f32,
    pub is_delta: bool,
    /// The visibility test: unoccluded iff it hits nothing.
    pub shadow_ray: Ray,
    /// The light's index in the light array (bidirectional path tracing weighs the sample
    /// against its other strategies with the light's own densities).
    pub light_index: u32,
    /// The point sampled on the light (emissive triangle), or the light's position (point
    /// and spot); unused for the environment and directional lights, which lie at infinity.
    pub position: Vec3,
}

/// Chooses a light with probability `pmf` using two uniforms (column, coin).
pub fn choose_light(lights: &[Light], u: Vec2) -> usize {
    let n = lights.len();
    let i = ((u.x * n as f32) as usize).min(n - 1);
    if u.y < lights[i].alias_probability {
        i
    } else {
        lights[i].alias_index as usize
    }
}

/// The largest f32 below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// Chooses a light with probability `pmf` from the single uniform `u`, and returns it with
/// `u` rescaled to a uniform of its own in [0, 1): the column is ⌊u·n⌋ and the coin the
/// fraction left, which is then stretched over whichever side of the coin it fell on.
/// Given the light, the rescaled number is uniform and independent of every other number,
/// so the light's point may be drawn from it (Mitsuba 3's `Scene::sample_emitter` reuses
/// its sample so). Drawing the point's first coordinate and the choice from one 2-D point
/// keeps that point stratified across the lights it lands on: the Cornell box's lamp is two
/// triangles, and choosing between them by a number of its own had left each triangle's
/// points only partly stratified (`bench/history/sampling.md`, "One 2-D point chooses the
/// light"). WGSL twin: `choose_light_reusing` in shaders/light.wgsl.
pub fn choose_light_reusing(lights: &[Light], u: f32) -> (usize, f32) {
    let n = lights.len();
    let x = u * n as f32;
    let column = (x as usize).min(n - 1);
    let coin = (x - column as f32).clamp(0.0, ONE_MINUS_EPSILON);
    let p = lights[column].alias_probability;
    // coin < p implies p > 0, and coin ≥ p that p < 1: neither division is by zero.
    let (index, rescaled) = if coin < p {
        (column, coin / p)
    } else {
        (lights[column].alias_index as usize, (coin - p) / (1.0 - p))
    };
    (index, rescaled.min(ONE_MINUS_EPSILON))
}

/// Unit geometric normal (winding) and area of a triangle.
pub fn triangle_normal_area(t: &Triangle) -> (Vec3, f32) {
    let c = (Vec3::from(t.p1) - Vec3::from(t.p0)).cross(Vec3::from(t.p2) - Vec3::from(t.p0));
    let len = c.length();
    if len == 0.0 {
        (Vec3::Z, 0.0)
    } else {
        (c / len, 0.5 * len)
    }
}

/// KHR_lights_punctual's recommended spot falloff: a squared linear ramp in cos θ between
/// the outer and inner cone.
pub fn spot_falloff(light: &Light, cos_theta: f32) -> f32 {
    let t = ((cos_theta - light.cos_outer) * light.spot_scale).clamp(0.0, 1.0);
    t * t
}

/// A uniformly distributed point on triangle `t` (density 1 / area): its barycentrics, the
/// point, and the point's error bound as an interpolated point (pbrt-v4
/// `Triangle::Sample`). WGSL twin: `sample_triangle_point` in shaders/light.wgsl.
#[inline(always)]
pub fn sample_triangle_point(t: &Triangle, u: Vec2) -> (Vec3, Vec3, Vec3) {
    let (p0, p1, p2) = (Vec3::from(t.p0), Vec3::from(t.p1), Vec3::from(t.p2));
    let b = sample_uniform_triangle(u);
    let q = b.x * p0 + b.y * p1 + b.z * p2;
    let q_error = gamma(6) * ((b.x * p0).abs() + (b.y * p1).abs() + (b.z * p2).abs());
    (b, q, q_error)
}

/// Samples incident light at surface point `p` (error bound `p_error`, geometric normal
/// `n_geometric`, used only to offset the shadow ray). `u_point.x` also chooses the light
/// ([`choose_light_reusing`]).
#[inline(always)]
pub fn sample_light(
    arrays: LightArrays,
    p: Vec3,
    p_error: Vec3,
    n_geometric: Vec3,
    u_point: Vec2,
) -> Option<LightSample> {
    if arrays.lights.is_empty() {
        return None;
    }
    let (index, u_x) = choose_light_reusing(arrays.lights, u_point.x);
    let u_point = Vec2::new(u_x, u_point.y);
    let light = &arrays.lights[index];
    let pmf = light.pmf;
    // Built by the host from finite powers: never NaN.
    if pmf <= 0.0 {
        return None;
    }
    match light.kind {
        LIGHT_TRIANGLE => {
            let tri = &arrays.triangles[light.triangle as usize];
            let material = &arrays.materials[tri.material as usize];
            let (b, q, q_error) = sample_triangle_point(tri, u_point);
            let (n_light, area) = triangle_light_normal_area(light);
            let to_light = q - p;
            let dist2 = to_light.length_squared();
            if dist2 == 0.0 || area == 0.0 {
                return None;
            }
            let wi = to_light / dist2.sqrt();
            let cos_light = -wi.dot(n_light);
            let double_sided = material.flags & MATERIAL_DOUBLE_SIDED != 0;
            if cos_light == 0.0 || (!double_sided && cos_light < 0.0) {
                return None;
            }
            let pdf = pmf * dist2 / (area * cos_light.abs());
            let q_off = offset_ray_origin(q, q_error, n_light, -wi);
            Some(LightSample {
                wi,
                radiance: crate::scene::texture::emitted_radiance(
                    &arrays.textures,
                    material,
                    light.triangle as usize,
                    b,
                ),
                pdf,
                is_delta: false,
                shadow_ray: spawn_ray_to(p, p_error, n_geometric, q_off),
                light_index: index as u32,
                position: q,
            })
        }
        LIGHT_POINT | LIGHT_SPOT => {
            let pos = Vec3::from(light.position);
            let to_light = pos - p;
            let dist2 = to_light.length_squared();
            if dist2 == 0.0 {
                return None;
            }
            let wi = to_light / dist2.sqrt();
            let mut radiance = Vec3::from(light.intensity) / dist2;
            if light.kind == LIGHT_SPOT {
                radiance *= spot_falloff(light, -wi.dot(Vec3::from(light.direction)));
            }
            Some(LightSample {
                wi,
                radiance,
                pdf: pmf,
                is_delta: true,
                shadow_ray: spawn_ray_to(p, p_error, n_geometric, pos),
                light_index: index as u32,
                position: pos,
            })
        }
        LIGHT_ENVIRONMENT => {
            let (wi, radiance, pdf) = sample_environment(
                arrays.environment,
                arrays.environment_texels,
                arrays.environment_cdf,
                u_point,
            )?;
            Some(LightSample {
                wi,
                radiance,
                pdf: pmf * pdf,
                is_delta: false,
                shadow_ray: spawn_ray(p, p_error, n_geometric, wi),
                light_index: index as u32,
                position: Vec3::ZERO,
            })
        }
        LIGHT_DIRECTIONAL => {
            let wi = -Vec3::from(light.direction);
            Some(LightSample {
                wi,
                radiance: Vec3::from(light.intensity),
                pdf: pmf,
                is_delta: true,
                shadow_ray: spawn_ray(p, p_error, n_geometric, wi),
                light_index: index as u32,
                position: Vec3::ZERO,
            })
        }
        _ => None,
    }
}

/// The unit normal and area of emissive-triangle light `light`, stored when the scene was
/// flattened ([`Light::direction`], [`Light::intensity`]): recomputing them from the
/// vertices for every light sample was 1.6% of a Cornell-box render's instructions.
#[inline(always)]
pub fn triangle_light_normal_area(light: &Light) -> (Vec3, f32) {
    (Vec3::from(light.direction), light.intensity[0])
}

/// Density per solid angle with which [`sample_light`] would have produced the direction of
/// a ray from `origin` that hit emissive-triangle light `light` at `hit_point`:
/// `pmf · distance² / (area · |cos θ_light|)`.
pub fn triangle_light_pdf(light: &Light, origin: Vec3, hit_point: Vec3) -> f32 {
    let (n_light, area) = triangle_light_normal_area(light);
    let d = hit_point - origin;
    let dist2 = d.length_squared();
    if dist2 == 0.0 || area == 0.0 {
        return 0.0;
    }
    let cos_light = (d / dist2.sqrt()).dot(n_light).abs();
    if cos_light == 0.0 {
        return 0.0;
    }
    light.pmf * dist2 / (area * cos_light)
}
