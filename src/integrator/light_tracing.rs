//! Caustic paths by light tracing: the light tracer that takes its half of path space
//! (`super::partition`) from the path tracer and connects each of its vertices to the camera.
//!
//! A path tracer finds a caustic only by chance: those rare, bright samples were 96% of the
//! glass Cornell box's variance (`bench/history/light-tracing.md`). A light tracer finds the
//! same paths the other way round: light → glass → floor, then a connection from the floor
//! to the camera, as the caustic photon map does (Jensen 1996, "Global Illumination using
//! Photon Maps") and as the t = 1 strategy of bidirectional path tracing does (Veach 1997
//! §10.2).
//!
//! Per sample index k, [`trace_caustic_pass`] traces one light path per pixel and returns
//! the image of their camera connections divided by that count: an unbiased estimate of
//! the light-traced half of every pixel, independent of the path-traced samples. Each
//! backend adds it to sample k of each pixel, so the film's per-pixel statistics still see
//! one independent estimate per sample (`film_add_sample`); an adaptive render sums the
//! passes into one image for the whole render instead ([`CausticSums`]). The GPU twin is
//! `shaders/light_tracing.wgsl`: the same paths from the same numbers, its splats summed
//! by atomic adds in the fixed point of [`caustic_to_fixed`], which both backends use so
//! that the sum does not depend on the order the splats arrive in.
//!
//! Light tracing transports importance, not radiance, so two factors differ from the path
//! tracer's (Veach 1997 §5.2–5.3; pbrt-v3 `CorrectShadingNormal`, pbrt-v4
//! `TransportMode::Importance`):
//! * refraction's radiance factor 1/η² is absent ([`BsdfSample::eta_scale`] takes it back);
//! * shading normals make the adjoint BSDF differ by |ωₗ·nₛ||ωₙ·n_g| / (|ωₗ·n_g||ωₙ·nₛ|)
//!   (ωₗ towards the light, ωₙ the sampled direction).
//!
//! Only scenes where it computes exactly what the path tracer drops use it
//! ([`super::partition::supports_light_tracing`]).

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::interaction::{sides_agree, surface_interaction, SurfaceInteraction};
use super::roulette::{survival_probability, MAX_BOUNCES_GUARD};
use super::IntegratorSettings;
use crate::bsdf::GltfBsdf;
use crate::bvh::ClosestHit;
use crate::geometry::{spawn_ray, spawn_ray_to, Frame, Ray, TriangleHit};
use crate::light::{choose_light, sample_triangle_point, triangle_light_normal_area};
use crate::sampling::{sample_cosine_hemisphere, Rng};
use crate::scene::camera::PinholeProjection;
use crate::scene::layout::{Camera, Light, LIGHT_TRIANGLE, MATERIAL_DOUBLE_SIDED, MATERIAL_VOLUME};
use crate::scene::texture::emitted_radiance;
use crate::scene::FlatScene;

/// Light paths per rayon task at most: enough to amortise the task, few enough to balance
/// two threads on a 256² pass (64 tasks).
const PATHS_PER_TASK: usize = 1024;
/// Light paths per rayon task at least. An adaptive render's late passes trace one path per
/// pixel still sampling, often a few hundred: they are cut into about four tasks per
/// thread, down to this size, rather than left to one thread.
const MIN_PATHS_PER_TASK: usize = 32;

/// Light-path vertices after which roulette may end a light path (the first is always the
/// delta vertex next to the light, the second the first surface the camera can see).
pub const LIGHT_RR_MIN_VERTICES: u32 = 2;

/// The row of [`Rng::new`] that light paths draw from: no pixel has it (an image has fewer
/// than 2²⁸ pixels, `crate::render::MAX_PIXELS`), so their streams never meet a pixel's.
pub const LIGHT_PATH_STREAM: u32 = u32::MAX;

/// Fraction bits of the fixed point the splats of a pass are summed in: a resolution of
/// 2⁻²⁰ ≈ 10⁻⁶, far below what relMSE's 10⁻² floor or a z-test can see, with 44 integer
/// bits above it.
pub const CAUSTIC_FRACTION_BITS: u32 = 20;

/// The largest splat, in units of 2⁻²⁰: 2⁴⁴ (1.7·10⁷ in radiance, after the division by the
/// number of paths). Larger ones are clamped to it so that 2²⁰ of them still sum within 64
/// bits; no scene that light tracing takes comes near it (one such splat outshines the
/// whole image by orders of magnitude).
pub const CAUSTIC_MAX_FIXED: f32 = 17_592_186_044_416.0;

/// One splat (finite, ≥ 0) in fixed point: rounded half to even to a multiple of 2⁻²⁰, as
/// the kernel's `round` does, so that both backends add the same integers.
pub fn caustic_to_fixed(v: f32) -> u64 {
    let x = (v * (1u32 << CAUSTIC_FRACTION_BITS) as f32).round_ties_even().min(CAUSTIC_MAX_FIXED);
    // x is an integer in [0, 2⁴⁴]: exact as u64.
    x as u64
}

/// A sum of splats back in radiance: the high and the low 32 bits converted apart, as the
/// kernel reads its two words (`caustic_radiance`).
pub fn caustic_from_fixed(x: u64) -> f32 {
    let high = (x >> 32) as u32 as f32 * (1u64 << (32 - CAUSTIC_FRACTION_BITS)) as f32;
    let low = x as u32 as f32 * (1.0 / (1u32 << CAUSTIC_FRACTION_BITS) as f32);
    high + low
}

/// The light-traced half of every pixel for sample index `pass`: `paths` light paths (one
/// per pixel, or under adaptive sampling one per pixel still taking samples: the light
/// tracer's effort then keeps its share of the camera paths'), the image of their camera
/// connections divided by their number (row-major, the film's layout), and the rays they
/// traced. Each pass's image is an unbiased estimate of the caustic light whatever `paths`
/// is. Deterministic: path i draws its numbers from
/// its own stream, and the connections are summed in fixed point, where order does not
/// matter.
pub fn trace_caustic_pass(
    scene: &FlatScene,
    camera: &Camera,
    settings: &IntegratorSettings,
    (width, height): (u32, u32),
    pass: u32,
    seed: u32,
    paths: usize,
) -> (Vec<Vec3>, u64) {
    let projection = PinholeProjection::new(camera, width, height);
    let pixels = width as usize * height as usize;
    // The splats are summed in fixed point, so how the paths are cut into tasks does not
    // change the image.
    let per_task = paths.div_ceil(4 * rayon::current_num_threads()).clamp(MIN_PATHS_PER_TASK, PATHS_PER_TASK);
    let tasks: Vec<(Vec<(usize, Vec3)>, u64)> = (0..paths.div_ceil(per_task))
        .into_par_iter()
        .map(|task| {
            let mut splats = Vec::new();
            let mut rays = 0;
            for i in task * per_task..((task + 1) * per_task).min(paths) {
                let mut rng = Rng::new(i as u32, LIGHT_PATH_STREAM, pass, seed);
                trace_light_path(scene, &projection, settings, &mut rng, &mut splats, &mut rays);
            }
            (splats, rays)
        })
        .collect();
    let mut rays = 0;
    let mut lists = Vec::with_capacity(tasks.len());
    for (splats, task_rays) in tasks {
        rays += task_rays;
        lists.push(splats);
    }
    let image = sum_splats(pixels, &lists, 1.0 / paths.max(1) as f32);
    (image, rays)
}

/// The image of `splats` (pixel, value) over `pixels` pixels, each value times `scale`,
/// summed in the fixed point of [`caustic_to_fixed`]: the same integers in any order, so the
/// image does not depend on how the splats were gathered (the kernel adds them atomically).
pub fn sum_splats(pixels: usize, splats: &[Vec<(usize, Vec3)>], scale: f32) -> Vec<Vec3> {
    let mut sums = vec![[0u64; 3]; pixels];
    for (pixel, value) in splats.iter().flatten() {
        let value = *value * scale;
        for (sum, v) in sums[*pixel].iter_mut().zip(value.to_array()) {
            // At most 2⁴⁴ per splat (`caustic_to_fixed`): 2²⁰ of them cannot wrap.
            *sum = sum.wrapping_add(caustic_to_fixed(v));
        }
    }
    sums.iter().map(|s| Vec3::from(s.map(caustic_from_fixed))).collect()
}

/// Where a light path leaves an emissive triangle ([`sample_triangle_emission`]).
pub struct TriangleEmission {
    /// The point on the triangle.
    pub point: Vec3,
    /// The normal of the side the path leaves from.
    pub normal: Vec3,
    /// The emitted radiance there.
    pub radiance: Vec3,
    /// The ray leaving it (unit direction).
    pub ray: Ray,
    /// Its throughput, Le cos θ / (pdf_point · pdf_direction).
    pub beta: Vec3,
    /// Density per unit area of the point, the light's choice included.
    pub pdf_area: f32,
    /// Density per solid angle of the direction.
    pub pdf_direction: f32,
}

/// A light path's start on emissive-triangle light `light`: a point uniform by area
/// (`u_point`), the side it leaves from (the front, the winding's side, or either, by the
/// coin `u_side`, for a double-sided material), and a cosine-weighted direction
/// (`u_direction`). `None` for a degenerate triangle. The light tracer and bidirectional
/// path tracing both start their light paths here.
pub fn sample_triangle_emission(
    scene: &FlatScene,
    light: &Light,
    u_point: Vec2,
    u_side: f32,
    u_direction: Vec2,
) -> Option<TriangleEmission> {
    let tri = &scene.triangles[light.triangle as usize];
    let material = &scene.materials[tri.material as usize];
    let (n_light, area) = triangle_light_normal_area(light);
    if area == 0.0 {
        return None;
    }
    let (b, q, q_error) = sample_triangle_point(tri, u_point);
    let double_sided = material.flags & MATERIAL_DOUBLE_SIDED != 0;
    let sides = if double_sided { 2.0 } else { 1.0 };
    let normal = if double_sided && u_side < 0.5 { -n_light } else { n_light };
    let radiance = emitted_radiance(&scene.texture_arrays(), material, light.triangle as usize, b);
    let local = sample_cosine_hemisphere(u_direction);
    let direction = Frame::from_z(normal).from_local(local);
    // Point density pmf / area, cosine-weighted direction density cos θ / π (per side):
    // β = Le cos θ / (pdf_point pdf_direction) = Le π area sides / pmf.
    Some(TriangleEmission {
        point: q,
        normal,
        radiance,
        ray: spawn_ray(q, q_error, normal, direction),
        beta: radiance * (std::f32::consts::PI * area * sides / light.pmf),
        pdf_area: light.pmf / area,
        pdf_direction: local.z / (std::f32::consts::PI * sides),
    })
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
    let Some(emission) = sample_triangle_emission(scene, light, u_point, u_side, u_direction) else { return };
    let mut beta = emission.beta;
    if !beta.is_finite() || beta.max_element() <= 0.0 {
        return;
    }
    let roulette_scale = 1.0 / beta.max_element();
    let mut ray = emission.ray;

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
            let survival = survival_probability(beta, roulette_scale);
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
    si: &SurfaceInteraction,
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

/// Words (`f32`) per pixel of [`CausticSums::sums`]: Σ P_k·c_k for even and for odd sample
/// indices (three channels each), then Σ P_k·c_k² (three). The GPU keeps them after the
/// pass's fixed-point image in its `caustics` buffer (`accumulate_caustic_sums` in
/// shaders/light_tracing.wgsl reads and writes these word offsets).
pub const CAUSTIC_SUM_WORDS: usize = 9;

/// An adaptive render's light-traced caustics: one image for the whole render, made of
/// every pass's light paths, in place of one pass's image added to each sample.
///
/// Under adaptive sampling pass k traces P_k paths, one per pixel still taking samples, so
/// the late passes are sparse. Added sample by sample, as a uniform render adds them, a
/// pixel that takes many samples gets most of its caustic estimate from those sparse
/// passes (each with P_k paths' noise), and a pixel that stops early never sees the paths
/// traced after it stopped: on the mirror-and-glass box that cost adaptive sampling about
/// a fifth of its error (`bench/history/sampling.md`). Here every light path counts for
/// every pixel: pass k's image c_k is an unbiased estimate of the caustic with variance
/// s²/P_k (s² a path's variance at the pixel), and the render's estimate is the
/// inverse-variance combination Σ P_k c_k / Σ P_k, whose variance s²/Σ P_k is what a
/// uniform render of the same samples has. The film then holds the camera paths alone and
/// [`Self::fold_into`] adds the caustics when the film is read. The pilot's counts read
/// that folded film too, so they see the caustic's noise as before.
#[derive(Clone, Debug, Default)]
pub struct CausticSums {
    /// Per pixel, [`CAUSTIC_SUM_WORDS`] words (row-major, the film's layout); empty where
    /// the GPU keeps them ([`Self::fold_sums_into`]).
    sums: Vec<f32>,
    /// Σ P_k over the passes of even and of odd sample index.
    paths: [f64; 2],
    /// The passes added, by sample index (a pass is added once, whatever asks for it again).
    passes: std::collections::BTreeSet<u32>,
}

impl CausticSums {
    pub fn new(pixels: usize) -> CausticSums {
        CausticSums { sums: vec![0.0; pixels * CAUSTIC_SUM_WORDS], ..CausticSums::default() }
    }

    /// Counts pass `k`, of `paths` light paths, into the totals; `false` if it was counted
    /// already (then its image must not be added again).
    pub fn count_pass(&mut self, k: u32, paths: usize) -> bool {
        if !self.passes.insert(k) {
            return false;
        }
        self.paths[crate::sampling::replicate_of(k) as usize] += paths as f64;
        true
    }

    /// Adds pass `k`'s image (`paths` light paths, [`trace_caustic_pass`]) to the sums, in
    /// the order and `f32` arithmetic of the GPU twin.
    pub fn add_pass(&mut self, k: u32, image: &[Vec3], paths: usize) {
        if !self.count_pass(k, paths) {
            return;
        }
        let r = crate::sampling::replicate_of(k) as usize;
        let p = paths as f32;
        // Most pixels receive no splat in a pass: adding zero would change nothing.
        for (sums, c) in
            self.sums.chunks_exact_mut(CAUSTIC_SUM_WORDS).zip(image).filter(|(_, c)| **c != Vec3::ZERO)
        {
            for (ch, c) in c.to_array().into_iter().enumerate() {
                sums[3 * r + ch] += p * c;
                sums[6 + ch] += p * c * c;
            }
        }
    }

    /// Passes counted.
    pub fn passes(&self) -> usize {
        self.passes.len()
    }

    /// `film` (camera paths alone) with the caustics added: each replicate r gets
    /// C_r = Σ_{k ≡ r} P_k c_k / Σ_{k ≡ r} P_k, so the two stay independent and unbiased, and
    /// the pixel's mean is their sample-weighted mean. Its variance grows by that of the
    /// caustic estimate, s²·(n₀²/P₀ + n₁²/P₁)/n², with s² estimated from the passes as
    /// (Σ P_k c_k² − (Σ P_k c_k)²/Σ P_k)/(K − 1) (E[P_k (c_k − μ)²] = s² for every pass; one
    /// degree of freedom goes to μ): the film's sample variance then still estimates the
    /// variance of the pixel's mean.
    pub fn fold_into(&self, film: &crate::film::Film) -> crate::film::Film {
        self.fold_sums_into(&self.sums, film)
    }

    /// [`Self::fold_into`] with the sums kept elsewhere: read back from the GPU
    /// (`accumulate_caustic_sums`), [`CAUSTIC_SUM_WORDS`] per pixel.
    pub fn fold_sums_into(&self, sums: &[f32], film: &crate::film::Film) -> crate::film::Film {
        let mut out = film.clone();
        let total = self.paths[0] + self.paths[1];
        if total == 0.0 {
            return out;
        }
        let k = self.passes.len();
        for (p, sums) in out.pixels.iter_mut().zip(sums.chunks_exact(CAUSTIC_SUM_WORDS)) {
            let n = p.count;
            if n == 0 {
                continue;
            }
            let a = [Vec3::from_slice(&sums[0..3]), Vec3::from_slice(&sums[3..6])];
            let squares = Vec3::from_slice(&sums[6..9]);
            // Each replicate's Σ P_k c_k and Σ P_k; one with no pass yet (a single pass
            // rendered) takes both replicates' passes.
            let replicate =
                [0, 1]
                    .map(|r| if self.paths[r] > 0.0 { (a[r], self.paths[r]) } else { (a[0] + a[1], total) });
            let c = replicate.map(|(sum, paths)| sum / paths as f32);
            let (n1, n0) = (p.odd_count as f32, (p.count - p.odd_count) as f32);
            let nf = n as f32;
            p.mean = (Vec3::from(p.mean) + (n0 * c[0] + n1 * c[1]) / nf).to_array();
            if p.odd_count > 0 {
                p.odd_mean = (Vec3::from(p.odd_mean) + c[1]).to_array();
            }
            if k >= 2 && n >= 2 {
                let sum = a[0] + a[1];
                let s2 = ((squares - sum * sum / total as f32) / (k - 1) as f32).max(Vec3::ZERO);
                let shares = n0 * n0 / replicate[0].1 as f32 + n1 * n1 / replicate[1].1 as f32;
                let variance = s2 * shares / (nf * nf);
                p.m2 = (Vec3::from(p.m2) + variance * nf * (nf - 1.0)).to_array();
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An adaptive render's caustic estimate ([`CausticSums::fold_into`]): passes of 64 down
    /// to 4 paths, each path contributing an exponential variate (mean 2, variance 4) to the
    /// one pixel, whose camera samples add nothing. Over 4,000 renders the folded mean and
    /// each replicate's must be unbiased, the mean's variance must be s²/Σ P_k (what every
    /// path counting for the pixel gives), and the film's variance channel must estimate it.
    #[test]
    fn summed_caustics_are_unbiased_and_their_variance_is_estimated() {
        let (mu, s2) = (2.0f64, 4.0f64);
        let paths = [64usize, 64, 48, 32, 16, 8, 8, 4];
        let total: usize = paths.iter().sum();
        let trials = 4000;
        let (mut means, mut odd_means, mut estimated) = (Vec::new(), Vec::new(), 0.0f64);
        for trial in 0..trials {
            let mut rng = Rng::new(trial, 0, 0, 17);
            let mut sums = CausticSums::new(1);
            for (k, &p) in paths.iter().enumerate() {
                let c: f64 = (0..p).map(|_| -mu * (1.0 - rng.next_1d() as f64).ln()).sum::<f64>() / p as f64;
                sums.add_pass(k as u32, &[Vec3::splat(c as f32)], p);
                // A pass asked for again is not counted twice.
                sums.add_pass(k as u32, &[Vec3::splat(1e3)], p);
            }
            let mut film = crate::film::Film::new(1, 1);
            for k in 0..32 {
                crate::film::film_add_sample(
                    &mut film.pixels[0],
                    Vec3::ZERO,
                    crate::sampling::replicate_of(k),
                );
            }
            let folded = sums.fold_into(&film);
            means.push(folded.pixels[0].mean[0] as f64);
            odd_means.push(folded.pixels[0].odd_mean[0] as f64);
            estimated += folded.variance_of_mean()[0].x as f64 / trials as f64;
        }
        let mean_and_variance = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            (m, v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64)
        };
        let (mean, variance) = mean_and_variance(&means);
        let (odd_mean, odd_variance) = mean_and_variance(&odd_means);
        // 4σ of the trials' mean.
        assert!((mean - mu).abs() < 4.0 * (variance / trials as f64).sqrt(), "mean {mean}, expected {mu}");
        assert!(
            (odd_mean - mu).abs() < 4.0 * (odd_variance / trials as f64).sqrt(),
            "odd replicate's mean {odd_mean}"
        );
        // The replicates split the paths in near halves, so the mean's variance is within a
        // few percent of s²/Σ P_k; the trials' sample variance is within ±9% (4σ of a
        // variance from 4,000 near-Gaussian trials).
        let ideal = s2 / total as f64;
        assert!(
            (variance / ideal - 1.0).abs() < 0.12,
            "variance {variance}, every path counting gives {ideal}"
        );
        // The estimate from the passes (8 passes: 7 degrees of freedom, unbiased on average).
        assert!(
            (estimated / variance - 1.0).abs() < 0.12,
            "estimated variance {estimated}, measured {variance}"
        );
    }

    #[test]
    fn caustic_fixed_point_rounds_to_its_resolution_and_clamps() {
        let resolution = 1.0 / (1u32 << CAUSTIC_FRACTION_BITS) as f64;
        for v in [0.0f32, 1e-9, 3e-7, 0.5, 1.0, 0.1234567, 17.25, 4096.0 + 1e-3, 1.5e6, 1.6e7] {
            let back = caustic_from_fixed(caustic_to_fixed(v)) as f64;
            // Half the fixed point's step from rounding, then the f32 of the result.
            let bound = 0.5 * resolution + back.abs() * f32::EPSILON as f64;
            assert!((back - v as f64).abs() <= bound, "{v}: {back}");
        }
        // Half-way values round to even multiples of the step, as the kernel's `round`.
        assert_eq!(caustic_to_fixed(2.5 / (1u32 << CAUSTIC_FRACTION_BITS) as f32), 2);
        assert_eq!(caustic_to_fixed(3.5 / (1u32 << CAUSTIC_FRACTION_BITS) as f32), 4);
        assert_eq!(caustic_to_fixed(1e30), CAUSTIC_MAX_FIXED as u64);
        // Sums carry across the low word as the kernel's two-word adds do.
        let x = caustic_to_fixed(4095.9) * 3;
        assert!((caustic_from_fixed(x) - 3.0 * 4095.9).abs() < 1e-3);
    }
}
