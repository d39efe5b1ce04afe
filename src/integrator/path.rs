//! Unidirectional path tracing with next-event estimation and multiple importance sampling
//! (Veach 1997, ch. 9; pbrt-v4 `PathIntegrator`).
//!
//! WGSL twin: `shaders/path.wgsl` (same function names and the same order of random
//! numbers, so that one seed gives the same paths on both backends up to rounding). The
//! kernel has no `radiance` or `trace`: its `render` runs their bounce loop itself, so that
//! a lane whose path ends can start its pixel's next sample, or its sample's next
//! continuation when the sample is split (path regeneration).
//!
//! Bounce semantics, shared by both backends: depth 0 is the camera ray; `depth` counts the
//! scattering events a path has had. Emission seen directly (depth 0) is always counted.
//! `max_depth` = D allows paths with at most D scattering events: D = 0 renders only
//! emitters seen directly, D = 1 direct lighting.

use glam::Vec3;

use super::interaction::{sides_agree, surface_interaction, unblocked_light_sample, SurfaceInteraction};
use super::irradiance_cache::IrradianceCache;
use super::mis::power_heuristic;
use super::partition::caustic_is_light_traced;
use super::roulette::{survival_probability, MAX_BOUNCES_GUARD, RR_ANY_BOUNCE_DEPTH};
use super::IntegratorSettings;
use crate::bsdf::GltfBsdf;
use crate::geometry::{spawn_ray, Ray};
use crate::light::{environment_lookup, triangle_light_pdf, LightArrays};
use crate::sampling::PathSampler;
use crate::scene::camera::RayCone;
use crate::scene::layout::{INVALID_INDEX, MATERIAL_DOUBLE_SIDED, MATERIAL_VOLUME};
use crate::scene::texture::{emitted_radiance, textured_material};
use crate::scene::FlatScene;

/// One camera sample's radiance estimate along camera ray `ray` (unit direction) with ray
/// cone `cone`. `rays` counts the rays traced (closest-hit and shadow), as the GPU kernel
/// counts them.
///
/// With `settings.splits` = k > 1 the path is split at its first vertex with a non-delta
/// lobe: after that vertex's next-event estimate, k continuations each sample the BSDF and
/// go on independently, and the estimate is the prefix's radiance plus the mean of theirs.
/// That is trajectory splitting (Arvo & Kirk 1990, "Particle Transport and Image
/// Synthesis"; pbrt-v3 §13.7.1): unbiased, as each continuation alone is, and cheaper
/// per unit of variance wherever the prefix (camera ray, first hit, its light sample) costs
/// a fair share of a path but adds little of its variance, as in the Cornell boxes, whose
/// noise is indirect light (`bench/history/splitting.md`). Continuation j draws its numbers from
/// [`PathSampler::split`].
///
/// With an irradiance cache the Lambertian lobe's indirect light at the path's first
/// Lambertian vertex comes from it ([`super::irradiance_cache`]); without one the path
/// tracer is unchanged, bit for bit.
pub fn radiance(
    scene: &FlatScene,
    settings: &IntegratorSettings,
    cache: Option<&IrradianceCache>,
    ray: Ray,
    cone: RayCone,
    rng: &mut PathSampler,
    rays: &mut u64,
) -> Vec3 {
    let path = PathState {
        ray,
        travelled: 0.0,
        beta: Vec3::ONE,
        direct_only_beta: Vec3::ZERO,
        depth: 0,
        prev_delta: true,
        prev_pdf: 0.0,
        eta_scale: 1.0,
        non_delta_depth: 0,
        first_vertex_smooth: false,
        cache_consulted: false,
    };
    let tracer = Tracer { scene, settings, lights: scene.light_arrays(), cache };
    trace(&tracer, path, cone, rng, rays, settings.splits).0
}

/// The radiance arriving along `ray` (unit direction, leaving a surface) less the emission
/// of lights that next-event estimation samples where the ray first lands, and the
/// distance to that first hit (infinite if it leaves the scene): one gather ray of an
/// irradiance-cache record ([`super::irradiance_cache`]). From its first hit on, the path is
/// the path tracer's, its next-event estimates included; its first hit weighs a sampled
/// light's emission by the MIS weight of a strategy with no density, 0.
pub(crate) fn indirect_radiance(
    scene: &FlatScene,
    settings: &IntegratorSettings,
    ray: Ray,
    cone: RayCone,
    rng: &mut PathSampler,
    rays: &mut u64,
) -> (Vec3, f32) {
    let path = PathState {
        ray,
        travelled: 0.0,
        beta: Vec3::ONE,
        direct_only_beta: Vec3::ZERO,
        depth: 1,
        prev_delta: false,
        prev_pdf: 0.0,
        eta_scale: 1.0,
        non_delta_depth: 1,
        first_vertex_smooth: true,
        cache_consulted: true,
    };
    let tracer = Tracer { scene, settings, lights: scene.light_arrays(), cache: None };
    trace(&tracer, path, cone, rng, rays, 1)
}

/// What every bounce of a camera sample reads: the scene, the settings, and the scene's
/// light arrays, gathered once per sample (gathered for every light sample, they were 2% of
/// a Cornell-box render's instructions).
struct Tracer<'a> {
    scene: &'a FlatScene,
    settings: &'a IntegratorSettings,
    lights: LightArrays<'a>,
    cache: Option<&'a IrradianceCache>,
}

/// A path between bounces: what the next bounce needs of the ones before it (WGSL twin:
/// `PathState`, a local of the kernel's `render`).
#[derive(Clone, Copy)]
struct PathState {
    /// The ray to trace next (unit direction).
    ray: Ray,
    /// Distance travelled along the path before `ray`: the cone keeps its spread.
    travelled: f32,
    /// Throughput.
    beta: Vec3,
    /// Throughput for the sampled lights' emission at the next hit only: the Lambertian
    /// lobe's share of the last BSDF sample where an irradiance cache gave that lobe's
    /// indirect light (zero otherwise).
    direct_only_beta: Vec3,
    /// Scattering events so far (0 for the camera ray).
    depth: u32,
    /// Did the last scattering sample a delta lobe (or is this the camera ray)?
    prev_delta: bool,
    /// The last BSDF sample's solid-angle density, for MIS against light sampling.
    prev_pdf: f32,
    /// Product of η² over the refractions so far: beta × eta_scale is the throughput without
    /// the radiance factors 1/η² that entering and leaving a solid cancel (pbrt-v4 §14.1.4).
    eta_scale: f32,
    /// Bounces that sampled a non-delta lobe: where roulette starts ([`scatter`]).
    non_delta_depth: u32,
    /// Did the first vertex scatter by a non-delta lobe? (The light tracer's half of path
    /// space, `IntegratorSettings::caustics_by_light_tracing`, needs it.)
    first_vertex_smooth: bool,
    /// Has the path passed its first Lambertian vertex, where a cache is consulted once?
    cache_consulted: bool,
}

/// How a path goes on after [`scatter`].
enum Scatter {
    /// Along the new `path.ray`.
    Continue,
    /// It ends here (absorbed, killed by roulette, or no valid direction).
    End,
    /// Its throughput is no longer finite: the sample is poisoned, so that the film counts
    /// and rejects it.
    Poison,
}

/// Traces `path` to its end, adding the radiance it gathers, and returns it with the length
/// of the path's first segment; with `splits` > 1 it is split at its first vertex with a
/// non-delta lobe ([`radiance`]).
fn trace(
    tracer: &Tracer,
    mut path: PathState,
    cone: RayCone,
    rng: &mut PathSampler,
    rays: &mut u64,
    splits: u32,
) -> (Vec3, f32) {
    let (scene, settings) = (tracer.scene, tracer.settings);
    let mut l = Vec3::ZERO;
    let mut first_distance = None;
    loop {
        *rays += 1;
        // Scenes with alpha-tested materials draw one number per traversal for stochastic
        // transparency; others draw none, keeping their random streams.
        let alpha_seed = if scene.features.alpha { rng.next_u32() } else { 0 };
        let hit = scene.intersect_closest(&path.ray, alpha_seed);
        first_distance.get_or_insert(hit.as_ref().map_or(f32::INFINITY, |h| h.hit.t));
        let Some(hit) = hit else {
            // The ray leaves the scene: the environment's radiance, MIS-weighted against
            // next-event estimation when NEE could have sampled this direction.
            let env = &scene.environment;
            if env.params.present != 0 {
                let (le, pdf_solid_angle) = environment_lookup(&env.params, &env.texels, path.ray.direction);
                if path.depth == 0 || path.prev_delta || env.params.light_index == INVALID_INDEX {
                    l += path.beta * le;
                } else {
                    let light_pdf = scene.lights[env.params.light_index as usize].pmf * pdf_solid_angle;
                    l += (path.beta + path.direct_only_beta) * le * power_heuristic(path.prev_pdf, light_pdf);
                }
            }
            break;
        };
        let si = surface_interaction(scene, &path.ray, &hit, cone.width_at(path.travelled + hit.hit.t));
        path.travelled += si.distance;
        // Untextured scenes skip the per-hit copy (the kernel's FEATURE_TEXTURES does the same).
        let untextured = &scene.materials[si.material as usize];
        let textured;
        let material = if scene.features.textures {
            textured = textured_material(untextured, &scene.texture_arrays(), si.uv, si.lod);
            &textured
        } else {
            untextured
        };

        // Beer–Lambert absorption inside a refracting solid: a ray reaching a back face has
        // travelled through the medium (closed, outward-facing meshes, as KHR_materials_volume
        // requires).
        if material.flags & MATERIAL_VOLUME != 0 && !si.front_face {
            let sigma = Vec3::from(material.attenuation_coefficient);
            let transmittance = (-sigma * si.distance).exp();
            path.beta *= transmittance;
            path.direct_only_beta *= transmittance;
        }

        // Emission, one-sided unless the material is double-sided. Counted in full it is read
        // at the cone's level of detail; weighted against light sampling it is read at level
        // 0, the radiance light sampling sees, so the two estimators share one integrand.
        if Vec3::from(untextured.emission).max_element() > 0.0
            && (si.front_face || material.flags & MATERIAL_DOUBLE_SIDED != 0)
        {
            if path.depth == 0 || path.prev_delta || si.emitter == INVALID_INDEX {
                let light_traced = settings.caustics_by_light_tracing
                    && caustic_is_light_traced(path.prev_delta, path.first_vertex_smooth, si.emitter);
                if !light_traced {
                    l += path.beta * Vec3::from(material.emission);
                }
            } else {
                let light = &scene.lights[si.emitter as usize];
                let light_pdf = triangle_light_pdf(light, path.ray.origin, si.p);
                let b = Vec3::new(hit.hit.b0, hit.hit.b1, hit.hit.b2);
                let emission =
                    emitted_radiance(&scene.texture_arrays(), untextured, hit.triangle as usize, b);
                l += (path.beta + path.direct_only_beta)
                    * emission
                    * power_heuristic(path.prev_pdf, light_pdf);
            }
        }
        if path.direct_only_beta != Vec3::ZERO {
            // The cache had the Lambertian lobe's light from here on; what other lobes
            // sent this way goes on.
            path.direct_only_beta = Vec3::ZERO;
            if path.beta == Vec3::ZERO {
                break;
            }
        }

        if path.depth >= settings.max_depth || path.depth >= MAX_BOUNCES_GUARD {
            break;
        }
        let bsdf = GltfBsdf::new(material, si.wo, si.front_face, si.coat_normal);
        l += next_event(scene, tracer.lights, &si, &bsdf, path.beta, rng, rays);
        let mut cached_lambert = false;
        if let Some(cache) = tracer.cache {
            if !path.cache_consulted && path.non_delta_depth == 0 && bsdf.has_lambert_lobe() {
                path.cache_consulted = true;
                if let Some(e) = cache.lookup(si.p, si.frame.z) {
                    l += path.beta * bsdf.diffuse_albedo(si.wo) * e * std::f32::consts::FRAC_1_PI;
                    cached_lambert = true;
                }
            }
        }

        if splits > 1 && bsdf.has_non_delta() {
            // The continuations, each from a copy of the path and its own numbers. A poisoned
            // one poisons the sample at once, as the kernel does.
            let mut sum = Vec3::ZERO;
            for j in 0..splits {
                let mut continuation = path;
                let mut rng = rng.split(j, splits);
                match scatter(settings, &si, &bsdf, &mut continuation, &mut rng, cached_lambert) {
                    Scatter::Continue => {
                        let (lj, _) = trace(tracer, continuation, cone, &mut rng, rays, 1);
                        if lj.is_nan() {
                            return (lj, first_distance.unwrap_or(f32::INFINITY));
                        }
                        sum += lj;
                    }
                    Scatter::End => {}
                    Scatter::Poison => {
                        return (Vec3::splat(f32::NAN), first_distance.unwrap_or(f32::INFINITY))
                    }
                }
            }
            return (l + sum / splits as f32, first_distance.unwrap_or(f32::INFINITY));
        }
        match scatter(settings, &si, &bsdf, &mut path, rng, cached_lambert) {
            Scatter::Continue => {}
            Scatter::End => break,
            Scatter::Poison => {
                l = Vec3::splat(f32::NAN);
                break;
            }
        }
    }
    (l, first_distance.unwrap_or(f32::INFINITY))
}

/// Next-event estimation at `si`: one light sample, MIS-weighted against the BSDF's
/// sampling (Veach 1997 §9.2), times the throughput `beta`. Photon mapping's camera paths
/// take the same sample (`super::sppm`).
#[inline(always)]
pub(crate) fn next_event(
    scene: &FlatScene,
    lights: LightArrays,
    si: &SurfaceInteraction,
    bsdf: &GltfBsdf,
    beta: Vec3,
    rng: &mut PathSampler,
    rays: &mut u64,
) -> Vec3 {
    if !bsdf.has_non_delta() || scene.lights.is_empty() {
        return Vec3::ZERO;
    }
    // One 2-D point chooses the light and the point on it (`choose_light_reusing`).
    let u_light = rng.next_2d();
    let Some((ls, wi, f)) = unblocked_light_sample(scene, lights, si, bsdf, u_light, || rng.next_u32(), rays)
    else {
        return Vec3::ZERO;
    };
    let contribution = beta * f * wi.z.abs() * ls.radiance;
    if ls.is_delta {
        contribution / ls.pdf
    } else {
        let w = power_heuristic(ls.pdf, bsdf.pdf(si.wo, wi));
        contribution * w / ls.pdf
    }
}

/// Continues `path` from `si` by sampling the BSDF, then plays Russian roulette. With
/// `cached_lambert` (an irradiance cache gave the Lambertian lobe's indirect light here) the
/// Lambertian lobe's share of the sample's weight, f_d cos θ / pdf, carries only the sampled
/// lights' emission at the next hit ([`PathState::direct_only_beta`]).
#[inline(always)]
fn scatter(
    settings: &IntegratorSettings,
    si: &SurfaceInteraction,
    bsdf: &GltfBsdf,
    path: &mut PathState,
    rng: &mut PathSampler,
    cached_lambert: bool,
) -> Scatter {
    // The lobe-choice number is a dimension of the stream whether or not the BSDF reads it
    // (the kernel always draws it).
    let u_lobe = if bsdf.chooses_a_lobe() {
        rng.next_1d()
    } else {
        rng.skip_1d();
        0.0
    };
    let u_dir = rng.next_direction_2d();
    let Some(bs) = bsdf.sample(si.wo, u_lobe, u_dir) else { return Scatter::End };
    let wi_world = si.frame.from_local(bs.wi).normalize();
    if !sides_agree(si, wi_world, bs.wi) {
        return Scatter::End;
    }
    if cached_lambert && !bs.is_delta {
        let lambert = (bsdf.eval_diffuse(si.wo, bs.wi) * (bs.wi.z.abs() / bs.pdf_solid_angle)).min(bs.weight);
        path.direct_only_beta = path.beta * lambert;
        path.beta *= (bs.weight - lambert).max(Vec3::ZERO);
    } else {
        path.beta *= bs.weight;
    }
    if !path.beta.is_finite() || !path.direct_only_beta.is_finite() {
        // Checked here, before roulette, so roulette only ever sees a finite throughput.
        return Scatter::Poison;
    }
    if path.depth == 0 {
        path.first_vertex_smooth = !bs.is_delta;
    }
    path.prev_delta = bs.is_delta;
    path.prev_pdf = bs.pdf_solid_angle;
    path.eta_scale *= bs.eta_scale;
    path.depth += 1;
    path.ray = spawn_ray(si.p, si.p_error, si.n_geometric, wi_world);

    // Russian roulette on the throughput without its refraction factors, from the path's
    // `rr_min_depth`-th non-delta bounce (`super::roulette` explains both choices).
    if !bs.is_delta {
        path.non_delta_depth += 1;
    }
    if path.non_delta_depth >= settings.rr_min_depth || path.depth >= RR_ANY_BOUNCE_DEPTH {
        let q = survival_probability(path.beta + path.direct_only_beta, path.eta_scale);
        if q <= 0.0 || rng.next_1d() >= q {
            return Scatter::End;
        }
        path.beta /= q;
        path.direct_only_beta /= q;
    }
    Scatter::Continue
}
