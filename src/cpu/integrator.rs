//! Unidirectional path tracing with next-event estimation and multiple importance sampling
//! (Veach 1997, ch. 9; pbrt-v4 `PathIntegrator`).
//!
//! WGSL twin: `shaders/integrator.wgsl` (same function names and the same order of random
//! numbers, so that one seed gives the same paths on both backends up to rounding). The
//! kernel has no `radiance` or `trace`: its `render` runs their bounce loop itself, so that
//! a lane whose path ends can start its pixel's next sample, or its sample's next
//! continuation when the sample is split (path regeneration).
//!
//! Bounce semantics, shared by both backends: depth 0 is the camera ray; `depth` counts the
//! scattering events a path has had. Emission seen directly (depth 0) is always counted.
//! `max_depth` = D allows paths with at most D scattering events: D = 0 renders only
//! emitters seen directly, D = 1 direct lighting.

use glam::{Vec2, Vec3};

use crate::bsdf::GltfBsdf;
use crate::bvh::ClosestHit;
use crate::geometry::{spawn_ray, triangle_error_bound, Frame, Ray};
use crate::light::{environment_lookup, sample_light, triangle_light_pdf, LightArrays};
use crate::sampling::{power_heuristic, PathSampler, SamplerKind};
use crate::scene::camera::RayCone;
use crate::scene::layout::{
    FirstHit, INVALID_INDEX, MATERIAL_DOUBLE_SIDED, MATERIAL_VOLUME, TRIANGLE_HAS_NORMALS,
    TRIANGLE_HAS_TANGENTS,
};
use crate::scene::texture::{emitted_radiance, textured_material, LOD_FINEST};
use crate::scene::{oct_decode, FlatScene};

/// A hard stop against runaway paths (e.g. a non-finite throughput that defeats Russian
/// roulette). Roulette survival is at most 0.95 per bounce, so a path reaching this many
/// bounces carries at most 0.95^(1024 − rr_min_depth) ≈ 1e-23 of its weight: unreachable in
/// practice, and the truncation it introduces is far below any test's resolution.
pub const MAX_BOUNCES_GUARD: u32 = 1024;

/// Roulette survival probability is the path throughput's largest component, at most this.
pub const RR_MAX_SURVIVAL: f32 = 0.95;

/// Roulette applies from this many bounces of any kind on, however few of them scattered
/// (`IntegratorSettings::rr_min_depth` counts only those that did): a path between parallel
/// mirrors would otherwise never meet it. Long enough for the delta chains of glass objects
/// (8 kept the whole gain of 12 and 16 on the mirror-and-glass Cornell box, 6 lost most of
/// it), short enough that the mirror box renders in 1.17× the time of counting every
/// bounce, where 16 took 1.5×.
pub const RR_ANY_BOUNCE_DEPTH: u32 = 8;

/// Roulette's default start: after a path's fifth non-delta bounce (Mitsuba 3's default
/// too). Chosen by efficiency 1 / (relMSE × seconds) where the standard run works (256²,
/// 256 camera samples × 4 continuations, Sobol, CPU backend; `examples/rr_depth.rs`):
/// starts 3, 4, 5, 6 gave the Cornell box 474, 526, 568, 581 and the mirror-and-glass box
/// 71.9, 65.9, 59.1, 56.4. A later start lowers both scenes' error by the same amount
/// (relMSE −0.45·10⁻⁴ from 3 to 5) for the same +36% time, but the glass scene's error is
/// mostly its caustics, which roulette does not touch. 5 favours the Cornell box, the scene
/// nearest its time-to-error target against Mitsuba 3 (bench/RESULTS.md, twenty-fourth
/// session); the start was 3 while the measurement ran at 64² without splitting, where
/// starts 1–6 had been level.
pub const DEFAULT_RR_MIN_DEPTH: u32 = 5;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntegratorSettings {
    /// Most scattering events (`u32::MAX`: unlimited).
    pub max_depth: u32,
    /// Russian roulette starts once a path has this many non-delta scattering events
    /// (mirror and glass bounces do not count; see `scatter`), or [`RR_ANY_BOUNCE_DEPTH`]
    /// events of any kind.
    pub rr_min_depth: u32,
    /// Continuations per camera sample from its first vertex with a non-delta lobe (1: no
    /// splitting; [`radiance`]).
    pub splits: u32,
    /// Leave the caustic paths to the light tracer (`super::light_tracing`): a path whose
    /// first vertex scattered by a non-delta lobe and which reaches an emissive triangle
    /// through a delta lobe adds nothing here. Only for scenes the light tracer supports,
    /// and only with its pass added to every sample (the kernel's twin is
    /// `frame.light_traced_caustics`).
    pub caustics_by_light_tracing: bool,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        IntegratorSettings {
            max_depth: u32::MAX,
            rr_min_depth: DEFAULT_RR_MIN_DEPTH,
            splits: 1,
            caustics_by_light_tracing: false,
        }
    }
}

/// Everything about a ray's hit the integrator needs.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceInteraction {
    pub p: Vec3,
    /// Conservative absolute error of `p`.
    pub p_error: Vec3,
    /// Unit geometric normal from the winding (front face side).
    pub n_geometric: Vec3,
    /// Shading frame, flipped to face the incoming ray.
    pub frame: Frame,
    /// Outgoing direction (towards the ray origin) in the shading frame; `wo.z > 0` unless
    /// the hit is exactly edge-on.
    pub wo: Vec3,
    /// The same direction in world space.
    pub wo_world: Vec3,
    /// Did the ray arrive on the geometric front side?
    pub front_face: bool,
    pub material: u32,
    pub emitter: u32,
    /// Distance along the ray (unit direction).
    pub distance: f32,
    /// UV sets 0 and 1 at the hit (zero without textures).
    pub uv: (Vec2, Vec2),
    /// Texture level-of-detail bases per UV set (`texture::lod_bases`).
    pub lod: Vec2,
    /// The clear coat's normal in the shading frame (+z without a coat).
    pub coat_normal: Vec3,
}

/// Builds the interaction for `hit` of `ray` (`ray.direction` unit length), whose ray cone
/// is `cone_width` wide at the hit (texture level of detail, `src/scene/texture.rs`).
///
/// Inlined, so that the fields a scene does not use are never stored (out of line, the
/// call and its 150-byte result were 2.2% of a Cornell-box render's instructions).
#[inline(always)]
pub fn surface_interaction(
    scene: &FlatScene,
    ray: &Ray,
    hit: &ClosestHit,
    cone_width: f32,
) -> SurfaceInteraction {
    let tri = &scene.triangles[hit.triangle as usize];
    let (p0, p1, p2) = (Vec3::from(tri.p0), Vec3::from(tri.p1), Vec3::from(tri.p2));
    let h = &hit.hit;
    let p = h.b0 * p0 + h.b1 * p1 + h.b2 * p2;
    let p_error = triangle_error_bound(h, p0, p1, p2);
    let n_geometric = (p1 - p0).cross(p2 - p0).normalize();
    let wo_world = -ray.direction;
    let front_face = wo_world.dot(n_geometric) > 0.0;
    let ng_facing = if front_face { n_geometric } else { -n_geometric };
    let b = Vec3::new(h.b0, h.b1, h.b2);
    let textures = scene.texture_arrays();
    let (uv, lod) = if scene.features.textures {
        let cos_theta = wo_world.dot(n_geometric);
        (textures.uv(hit.triangle, b), textures.lod_bases(hit.triangle, [p0, p1, p2], cone_width, cos_theta))
    } else {
        ((Vec2::ZERO, Vec2::ZERO), Vec2::splat(LOD_FINEST))
    };
    // The shading normal on the geometric front side: interpolated vertex normals, then the
    // normal map in their tangent frame (glTF 2.0 §3.9.3: n = T·x + B·y + N·z with
    // B = (N × T)·w, the map's x and y scaled by normalTexture.scale).
    let mut n_front = n_geometric;
    if tri.flags & TRIANGLE_HAS_NORMALS != 0 {
        let n = &scene.normals[hit.triangle as usize];
        let interpolated = h.b0 * oct_decode(n.n0) + h.b1 * oct_decode(n.n1) + h.b2 * oct_decode(n.n2);
        if let Some(s) = interpolated.try_normalize() {
            // The file's normals may disagree with its winding: put them on the front side.
            n_front = if s.dot(n_geometric) < 0.0 { -s } else { s };
        }
    }
    let material = &scene.materials[tri.material as usize];
    // The tangent frame (front side) where a normal map will read it.
    let tangent_frame = if tri.flags & TRIANGLE_HAS_TANGENTS != 0 {
        let t = &scene.tangents[hit.triangle as usize];
        let tangent = h.b0 * oct_decode(t.t0) + h.b1 * oct_decode(t.t1) + h.b2 * oct_decode(t.t2);
        let sign = if t.signs & 1 != 0 { -1.0 } else { 1.0 };
        // Gram–Schmidt: the interpolated tangent is only nearly orthogonal to N.
        (tangent - n_front * n_front.dot(tangent))
            .try_normalize()
            .map(|tangent| (tangent, n_front.cross(tangent) * sign))
    } else {
        None
    };
    let map_normal = |texture: u32, scale: f32| -> Option<Vec3> {
        let (tangent, bitangent) = tangent_frame?;
        let texel = textures.lookup_lod(texture, uv, lod, false)?;
        let m = texel.truncate() * 2.0 - Vec3::ONE;
        let mapped = (tangent * (m.x * scale) + bitangent * (m.y * scale) + n_front * m.z).try_normalize()?;
        Some(if mapped.dot(n_geometric) < 0.0 { n_front } else { mapped })
    };
    // Most materials have no normal map: no call of the closure for them (0.8% of a
    // Cornell-box render's instructions).
    let n_mapped = if material.normal_texture == INVALID_INDEX {
        n_front
    } else {
        map_normal(material.normal_texture, material.normal_scale).unwrap_or(n_front)
    };
    // Face the incoming ray, and fall back where the shading normal would put the viewer
    // below its hemisphere (silhouettes of coarse meshes, steep normal-map texels): first to
    // the interpolated normal, then to the geometric one. This is the usual shading-normal
    // guard (Veach 1997 §5.3 discusses why such normals are asymmetric), not a microfacet
    // normal-mapping model (Schüßler et al. 2017).
    let flip = |n: Vec3| if front_face { n } else { -n };
    let facing =
        |n: Vec3| [flip(n), flip(n_front)].into_iter().find(|n| n.dot(wo_world) > 0.0).unwrap_or(ng_facing);
    let frame = Frame::from_z(facing(n_mapped));
    // The clear coat's own normal: its normal map, else the interpolated normal (never the
    // base's normal map), under the same guard.
    let coat_normal = if material.clearcoat > 0.0 {
        let n =
            map_normal(material.clearcoat_normal_texture, material.clearcoat_normal_scale).unwrap_or(n_front);
        frame.to_local(facing(n)).normalize()
    } else {
        Vec3::Z
    };
    SurfaceInteraction {
        p,
        p_error,
        n_geometric,
        frame,
        wo: frame.to_local(wo_world),
        wo_world,
        front_face,
        material: tri.material,
        emitter: tri.emitter,
        distance: h.t,
        uv,
        lod,
        coat_normal,
    }
}

/// Does direction `wi` (world `wi_world`, shading frame `wi_local`) leave the surface on the
/// side its shading says? Reflection in the shading frame (`wi_local.z > 0`, as `wo.z > 0`)
/// must also be reflection about the geometric normal, and transmission transmission.
/// Where smooth normals tilt far from the faces (averaged corner normals of a box), a
/// direction can be reflected for the BSDF yet pass through the geometric surface; its ray
/// would be spawned on the far side and carry light through a closed wall (issue 11's sealed
/// room). Such directions are dropped, as pbrt-v3's `BSDF::f` does by classifying
/// reflection with the geometric normal (Veach 1997 §5.3 discusses these normals).
pub(super) fn sides_agree(si: &SurfaceInteraction, wi_world: Vec3, wi_local: Vec3) -> bool {
    let wo_side = si.wo_world.dot(si.n_geometric);
    let reflected_geometrically = wi_world.dot(si.n_geometric) * wo_side > 0.0;
    reflected_geometrically == (wi_local.z > 0.0)
}

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
/// noise is indirect light (bench/RESULTS.md). Continuation j draws its numbers from
/// [`PathSampler::split`].
pub fn radiance(
    scene: &FlatScene,
    settings: &IntegratorSettings,
    ray: Ray,
    cone: RayCone,
    rng: &mut PathSampler,
    rays: &mut u64,
) -> Vec3 {
    let path = PathState {
        ray,
        travelled: 0.0,
        beta: Vec3::ONE,
        depth: 0,
        prev_delta: true,
        prev_pdf: 0.0,
        eta_scale: 1.0,
        non_delta_depth: 0,
        first_vertex_smooth: false,
    };
    let tracer = Tracer { scene, settings, lights: scene.light_arrays() };
    trace(&tracer, path, cone, rng, rays, settings.splits)
}

/// What every bounce of a camera sample reads: the scene, the settings, and the scene's
/// light arrays, gathered once per sample (gathered for every light sample, they were 2% of
/// a Cornell-box render's instructions).
struct Tracer<'a> {
    scene: &'a FlatScene,
    settings: &'a IntegratorSettings,
    lights: LightArrays<'a>,
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

/// Traces `path` to its end, adding the radiance it gathers; with `splits` > 1 it is split
/// at its first vertex with a non-delta lobe ([`radiance`]).
fn trace(
    tracer: &Tracer,
    mut path: PathState,
    cone: RayCone,
    rng: &mut PathSampler,
    rays: &mut u64,
    splits: u32,
) -> Vec3 {
    let (scene, settings) = (tracer.scene, tracer.settings);
    let mut l = Vec3::ZERO;
    loop {
        *rays += 1;
        // Scenes with alpha-tested materials draw one number per traversal for stochastic
        // transparency; others draw none, keeping their random streams.
        let alpha_seed = if scene.features.alpha { rng.next_u32() } else { 0 };
        let Some(hit) = scene.intersect_closest(&path.ray, alpha_seed) else {
            // The ray leaves the scene: the environment's radiance, MIS-weighted against
            // next-event estimation when NEE could have sampled this direction.
            let env = &scene.environment;
            if env.params.present != 0 {
                let (le, pdf_solid_angle) = environment_lookup(&env.params, &env.texels, path.ray.direction);
                if path.depth == 0 || path.prev_delta || env.params.light_index == INVALID_INDEX {
                    l += path.beta * le;
                } else {
                    let light_pdf = scene.lights[env.params.light_index as usize].pmf * pdf_solid_angle;
                    l += path.beta * le * power_heuristic(path.prev_pdf, light_pdf);
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
            path.beta *= (-sigma * si.distance).exp();
        }

        // Emission, one-sided unless the material is double-sided. Counted in full it is read
        // at the cone's level of detail; weighted against light sampling it is read at level
        // 0, the radiance light sampling sees, so the two estimators share one integrand.
        if Vec3::from(untextured.emission).max_element() > 0.0
            && (si.front_face || material.flags & MATERIAL_DOUBLE_SIDED != 0)
        {
            if path.depth == 0 || path.prev_delta || si.emitter == INVALID_INDEX {
                let light_traced = settings.caustics_by_light_tracing
                    && path.prev_delta
                    && path.first_vertex_smooth
                    && si.emitter != INVALID_INDEX;
                if !light_traced {
                    l += path.beta * Vec3::from(material.emission);
                }
            } else {
                let light = &scene.lights[si.emitter as usize];
                let light_pdf = triangle_light_pdf(light, path.ray.origin, si.p);
                let b = Vec3::new(hit.hit.b0, hit.hit.b1, hit.hit.b2);
                let emission =
                    emitted_radiance(&scene.texture_arrays(), untextured, hit.triangle as usize, b);
                l += path.beta * emission * power_heuristic(path.prev_pdf, light_pdf);
            }
        }

        if path.depth >= settings.max_depth || path.depth >= MAX_BOUNCES_GUARD {
            break;
        }
        let bsdf = GltfBsdf::new(material, si.wo, si.front_face, si.coat_normal);
        l += next_event(tracer, &si, &bsdf, path.beta, rng, rays);

        if splits > 1 && bsdf.has_non_delta() {
            // The continuations, each from a copy of the path and its own numbers. A poisoned
            // one poisons the sample at once, as the kernel does.
            let mut sum = Vec3::ZERO;
            for j in 0..splits {
                let mut continuation = path;
                let mut rng = rng.split(j, splits);
                match scatter(settings, &si, &bsdf, &mut continuation, &mut rng) {
                    Scatter::Continue => {
                        let lj = trace(tracer, continuation, cone, &mut rng, rays, 1);
                        if lj.is_nan() {
                            return lj;
                        }
                        sum += lj;
                    }
                    Scatter::End => {}
                    Scatter::Poison => return Vec3::splat(f32::NAN),
                }
            }
            return l + sum / splits as f32;
        }
        match scatter(settings, &si, &bsdf, &mut path, rng) {
            Scatter::Continue => {}
            Scatter::End => break,
            Scatter::Poison => return Vec3::splat(f32::NAN),
        }
    }
    l
}

/// Next-event estimation at `si`: one light sample, MIS-weighted against the BSDF's
/// sampling (Veach 1997 §9.2), times the throughput `beta`.
#[inline(always)]
fn next_event(
    tracer: &Tracer,
    si: &SurfaceInteraction,
    bsdf: &GltfBsdf,
    beta: Vec3,
    rng: &mut PathSampler,
    rays: &mut u64,
) -> Vec3 {
    let scene = tracer.scene;
    if !bsdf.has_non_delta() || scene.lights.is_empty() {
        return Vec3::ZERO;
    }
    // One 2-D point chooses the light and the point on it (`choose_light_reusing`).
    let u_light = rng.next_2d();
    let Some(ls) = sample_light(tracer.lights, si.p, si.p_error, si.n_geometric, u_light) else {
        return Vec3::ZERO;
    };
    let wi = si.frame.to_local(ls.wi);
    let f = if sides_agree(si, ls.wi, wi) { bsdf.eval(si.wo, wi) } else { Vec3::ZERO };
    let unoccluded = f.max_element() > 0.0 && {
        *rays += 1;
        let alpha_seed = if scene.features.alpha { rng.next_u32() } else { 0 };
        !scene.intersect_any(&ls.shadow_ray, alpha_seed)
    };
    if !unoccluded {
        return Vec3::ZERO;
    }
    let contribution = beta * f * wi.z.abs() * ls.radiance;
    if ls.is_delta {
        contribution / ls.pdf
    } else {
        let w = power_heuristic(ls.pdf, bsdf.pdf(si.wo, wi));
        contribution * w / ls.pdf
    }
}

/// Continues `path` from `si` by sampling the BSDF, then plays Russian roulette.
#[inline(always)]
fn scatter(
    settings: &IntegratorSettings,
    si: &SurfaceInteraction,
    bsdf: &GltfBsdf,
    path: &mut PathState,
    rng: &mut PathSampler,
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
    path.beta *= bs.weight;
    if !path.beta.is_finite() {
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

    // Russian roulette (unbiased: survivors are divided by the survival probability),
    // judged on the throughput with the refraction factors taken out: inside glass beta is
    // scaled by 1/η², which leaving undoes, so a path there is as valuable as outside. It
    // starts after the path's first `rr_min_depth` non-delta bounces: a mirror or glass
    // bounce only redirects the path, and counting it would make roulette thin out caustic
    // paths (floor → glass → glass → light) at their last step, where each survivor carries
    // 1/q of a rare, bright contribution. Any survival probability fixed before the coin is
    // drawn keeps the estimator unbiased (Arvo & Kirk 1990, "Particle Transport and Image
    // Synthesis"; pbrt-v4 §2.2.4). Efficiency (1 / (relMSE × time)) against counting every
    // bounce: 1.2× on the mirror-and-glass Cornell box, 1.16× on `glass-smooth`, 1.12× on
    // `glossy-metal`, 1.9× on `env-objects` (bench/RESULTS.md); scenes without delta lobes
    // render the same bits.
    if !bs.is_delta {
        path.non_delta_depth += 1;
    }
    if path.non_delta_depth >= settings.rr_min_depth || path.depth >= RR_ANY_BOUNCE_DEPTH {
        let q = (path.beta * path.eta_scale).max_element().min(RR_MAX_SURVIVAL);
        if q <= 0.0 || rng.next_1d() >= q {
            return Scatter::End;
        }
        path.beta /= q;
    }
    Scatter::Continue
}

/// What the camera ray of sample 0 of pixel `(x, y)` hits (the first-hit AOV), its jitter
/// drawn by the independent sampler on both backends.
/// The first-hit AOV reads textures at the level of detail of a one-sample render.
pub fn first_hit(scene: &FlatScene, width: u32, height: u32, x: u32, y: u32, seed: u32) -> FirstHit {
    let mut rng = PathSampler::new(SamplerKind::Independent, x, y, 0, seed);
    let ray = crate::scene::camera::generate_camera_ray(&scene.camera, width, height, x, y, rng.next_2d());
    let cone = crate::scene::camera::camera_ray_cone(&scene.camera, height, 1);
    match scene.intersect_closest(&ray, 0) {
        Some(hit) => {
            let si = surface_interaction(scene, &ray, &hit, cone.width_at(hit.hit.t));
            FirstHit {
                normal: si.frame.z.to_array(),
                distance: si.distance,
                albedo: textured_material(
                    &scene.materials[si.material as usize],
                    &scene.texture_arrays(),
                    si.uv,
                    si.lod,
                )
                .base_color,
                triangle: hit.triangle,
            }
        }
        None => FirstHit { triangle: INVALID_INDEX, ..Default::default() },
    }
}
