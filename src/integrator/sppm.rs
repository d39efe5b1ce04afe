//! Stochastic progressive photon mapping (Hachisuka & Jensen 2009, "Stochastic Progressive
//! Photon Mapping"; pbrt-v3 §16.2, pbrt-v4 `SPPMIntegrator`): the estimator that renders
//! light no path tracer can sample, such as a caustic seen through glass or in a mirror
//! (specular–diffuse–specular paths), and converges as its passes add up.
//!
//! Each pass (one "sample per pixel" of the render loop):
//! 1. **Visible points.** Every pixel traces one camera path through delta lobes (mirror,
//!    smooth glass) and through BSDFs with glossy lobes only (metals, rough glass: photons
//!    gathered on a narrow lobe would be noise; pbrt-v4 does the same), path traced, to the
//!    first vertex with a diffuse lobe where its BSDF sample chose a non-delta lobe. On
//!    the way it adds what needs no photons: emission seen directly or through delta lobes,
//!    at every vertex with a non-delta lobe one light sample (next-event estimation), and
//!    at the visible point the emitter its own BSDF sample sees, the two weighted by the
//!    power heuristic as the path tracer weighs them (the photons leave direct light to
//!    them). Where the sample chose a delta lobe
//!    the path goes on; where it chose a non-delta one the vertex becomes the pixel's
//!    visible point, its throughput divided by the probability of that choice
//!    ([`GltfBsdf::non_delta_probability`]) so that the two branches together are unbiased.
//! 2. **Photons.** `photons` light paths, started as bidirectional path tracing starts its
//!    light subpaths (`super::bdpt::light_subpath_origin`: every light kind, the
//!    environment from a disk covering the scene) and walked with its importance transport
//!    (the adjoint BSDF and shading-normal factor, Veach 1997 §5.3). Each surface the walk
//!    reaches after its first bounce and that has a non-delta lobe stores a photon: the
//!    first hits are direct light, which step 1 took.
//! 3. **Grid.** The photons are sorted into a uniform hash grid by count, prefix sum and
//!    scatter ([`PhotonGrid`]): every photon lands in its cell's run, in photon order, so a
//!    gather reads the same photons in the same order on any thread count.
//! 4. **Update.** Each visible point gathers the photons within its pixel's radius r that
//!    arrived on the same side of their surface as the visible point's camera ray and that
//!    face it across the gap between their surfaces ([`facing_each_other`]), Φ = Σ β_p
//!    f(ω_o, ω_p) |ω_p·n_s| / |ω_p·n_g| (the last ratio turns flux per unit of geometric area
//!    into the shading normal's cosine), M of them. Where the surface the gather reads within
//!    r is less than the disk πr² (past a convex edge, at a silhouette) Φ is scaled by πr²
//!    over that area, measured exactly from the triangles ([`coverage_correction`],
//!    `super::gather_area`), so that it is flux over the disk as the update assumes. Then
//!    pbrt's update: N' = N + αM, r' = r √(N'/(N + M)), τ' = (τ + β Φ) r'²/r², with α = 2/3,
//!    or 0.75 for a pixel whose first gather's disk lay on one plane ([`radius_alpha`]).
//!
//! After n passes of N_p photons a pixel is L = Σ L_direct / n + τ / (n N_p π r²). Its bias
//! (the blur of the radius) falls as r shrinks; r² falls roughly as n^(α−1) where photons
//! are dense (Knaus & Zwicker 2011, "Progressive Photon Mapping: A Probabilistic Approach"),
//! for either α. The coverage correction shrinks with r too (it is 1 wherever the surface
//! within r is a plane), so the estimate stays consistent.
//!
//! **Variance channels.** A pixel's passes are not independent samples of one mean (they
//! share the radius and τ), so the film's Welford statistics are kept over each pass's own
//! estimate ℓ_k = L_direct,k + β_k Φ_k / (N_p π r_k²) with the radius it gathered at: their
//! spread across passes measures the noise, the film's mean is set to L above, and the
//! replicates (even and odd passes) keep their difference. The predicted error covers the
//! noise only, never the bias.
//!
//! **Initial radius.** `radius_pixels` pixel footprints at the pixel's first visible point
//! (the camera ray cone's width at the distance travelled): scale-free, as a world-space
//! radius is not ([`DEFAULT_SPPM_RADIUS_PIXELS`]). The footprint is one pixel's, not the
//! narrower cone the texture filter reads with many samples per pixel.
//!
//! **Random numbers.** The camera path draws from its pixel's [`PathSampler`] for sample
//! index k: pixel jitter (2-D), then per vertex [alpha], the light sample (2-D) and [alpha]
//! for its shadow ray where the BSDF has a non-delta lobe, lobe, direction (2-D), then at
//! the visible point [alpha] for the BSDF sample's ray, else [roulette]. Photon i of pass k draws from `Rng::new(i, PHOTON_STREAM, k, seed)` in
//! bidirectional path tracing's light-subpath order.
//!
//! **GPU twin** (`shaders/sppm.wgsl`): the same four steps as compute passes, from the same
//! streams, so the same camera paths, photons and photon counts per pixel; a cell's photons
//! are summed in the order the scatter's atomics placed them, so the images agree to
//! rounding (tests/gpu/sppm.rs). Its photon records live in a buffer sized before the
//! first pass ([`gpu_record_capacity`]).

use glam::Vec3;
use rayon::prelude::*;

use super::bdpt::{light_subpath_origin, BdptContext};
use super::gather_area::{gather_area, GatherRegion, MAX_COVERAGE_CORRECTION};
use super::interaction::{sides_agree, surface_interaction, SurfaceInteraction};
use super::mis::power_heuristic;
use super::path::next_event;
use super::roulette::{survival_probability, MAX_BOUNCES_GUARD, RR_ANY_BOUNCE_DEPTH};
use super::IntegratorSettings;
use crate::bsdf::{BsdfSample, GltfBsdf};
use crate::bvh::ClosestHit;
use crate::film::{film_add_sample, Film};
use crate::geometry::{spawn_ray, Ray};
use crate::light::{environment_lookup, triangle_light_pdf};
use crate::sampling::{replicate_of, PathSampler, Rng, SamplerKind};
use crate::scene::camera::{camera_ray_cone, generate_camera_ray};
use crate::scene::layout::{Camera, INVALID_INDEX, MATERIAL_DOUBLE_SIDED, MATERIAL_VOLUME};
use crate::scene::texture::{emitted_radiance, textured_material};
use crate::scene::FlatScene;

/// The radius update's α (Hachisuka & Jensen 2009, eq. 6; pbrt-v4's γ = 2/3): the fraction
/// of a pass's photons a pixel keeps. Smaller shrinks the radius faster (less bias, more
/// noise); 2/3 is the value Knaus & Zwicker 2011 show balances the two asymptotically.
/// On the 128² Cornell box at 20 s, 0.5 and 0.8 gave 2.3 and 1.06 times its relMSE
/// (bench/RESULTS.md, "Where SPPM's Cornell-box error comes from").
pub const SPPM_ALPHA: f32 = 2.0 / 3.0;

/// α for a pixel whose first gather's disk lies on its visible point's surface alone: the
/// area it draws its photons from is πr² of the initial radius, no edge, corner or other
/// surface within it ([`radius_alpha`]). There the radius's bias is only the irradiance's
/// curvature across the disk, small on walls and floors, so the radius may shrink more
/// slowly and keep more photons (less noise); pixels near edges and corners, whose bias is
/// what shrinking removes, keep [`SPPM_ALPHA`]. Any α below 1 keeps the estimate consistent
/// (Knaus & Zwicker 2011); choosing it per pixel by the bias each pixel can have is, in
/// coarse form, what adaptive progressive photon mapping does (Kaplanyan & Dachsbacher
/// 2013). What the area cannot see is the irradiance's own curvature: a caustic on a flat
/// floor blurs longer. On the 128² Cornell box at 20 s, 1.27× less relMSE than 2/3
/// everywhere; behind the glass pane 9% more (bench/RESULTS.md, "A slower radius, decided
/// once per pixel").
///
/// Decided once and kept in the pixel's state, not at every pass from that pass's area: a
/// radius that follows the area's `f32` rounding, which differs between the backends, gave
/// a same-seed CPU and GPU render different radii, and through them different photon sets
/// (bench/history/photon-mapping.md). One decision per pixel at its initial radius is
/// exposed to that rounding once, where the area's distance from the tolerance is spread
/// over the scene's geometry, not swept through it as the radius shrinks.
pub const SPPM_ALPHA_ONE_PLANE: f32 = 0.75;

/// The relative difference from πr² within which a pixel's first gather's area counts as
/// one plane ([`radius_alpha`]). A plane wider than the disk gives πr² to the area's
/// rounding, a few 10⁻⁶; a tessellated sphere bends it off by the facets' angle, which is
/// larger. 1% lets a gently curved surface count (the irradiance varies across it as
/// little) and sits four orders above the rounding, so that the backends decide alike but
/// where a pixel's area lies within rounding of it.
pub const ONE_PLANE_AREA_TOLERANCE: f32 = 0.01;

/// The row of [`Rng::new`] photons draw from: no pixel has it (fewer than 2²⁸ rows), and
/// the light tracer's paths have `LIGHT_PATH_STREAM` (u32::MAX).
pub const PHOTON_STREAM: u32 = u32::MAX - 1;

/// The initial radius in pixel footprints unless told otherwise (`--sppm-radius`): on the
/// 128² Cornell box at 9 s, 3 pixels had the least error of 1, 2, 3, 6 and 12.8 (relMSE
/// 9.5, 3.6, 2.9, 5.8 and 12.9 ·10⁻⁴: noise below 3, the blur's bias above), with one
/// photon per pixel per pass (the default then), whose passes find a few dozen photons in
/// most pixels' disks.
pub const DEFAULT_SPPM_RADIUS_PIXELS: f32 = 3.0;

/// Photons per pass per pixel unless told otherwise (`--photons`). On the 128² Cornell box
/// at 20 s (two seeds each, against a 4,096-spp path-traced reference) one, two and four
/// per pixel gave relMSE 1.20, 1.00 and 0.98 ·10⁻⁴; on the mirror-and-glass box behind its
/// pane 4.36, 4.38 and 4.53 ·10⁻⁴ (bench/RESULTS.md, "What the defaults were chosen by").
/// More photons per pass shrink the radius faster and leave fewer passes for the camera
/// paths; two is where the Cornell box gains and the glass scene does not lose.
pub const DEFAULT_SPPM_PHOTONS_PER_PIXEL: u32 = 2;

/// The most photons one pass may trace (`--photons`).
pub const MAX_PHOTONS_PER_PASS: u32 = 1 << 24;

/// The most photon records one pass keeps: 2²³ records of [`Photon`]'s 48 bytes, 384 MiB,
/// plus 4 bytes each and per grid slot for the grid. Records past it are dropped and
/// counted ([`SppmStats::dropped_photons`], reported by `render`): a dropped record
/// darkens its pixels, so it is never silent.
pub const MAX_PHOTON_RECORDS: usize = 1 << 23;

/// Photons of the pilot [`gpu_record_capacity`] traces: a few milliseconds on the host.
const PILOT_PHOTONS: u32 = 4096;

/// The pass index of the pilot's photon stream: past any pass a render reaches, and apart
/// from the photon maps' (`super::photon`, `u32::MAX` and `u32::MAX − 1`).
const PILOT_PASS: u32 = u32::MAX - 2;

/// The photon records a GPU pass of `photons` photons keeping the landings `kind` says has
/// room for, which must be allocated before any pass runs (the CPU backend grows its list
/// instead): 1.25 times the records per photon of a pilot of [`PILOT_PHOTONS`] photons
/// traced here, plus 4,096 for passes of few photons, at most [`MAX_PHOTON_RECORDS`]. A
/// pass of N photons stores a sum of N independent counts (each of standard deviation
/// about its mean m, the landings of a roulette-ended walk being near geometric), so it
/// exceeds N m by a few m √N: within the 4,096 below a few hundred photons, within N m / 4
/// above; the pilot's own mean is within 2% (one σ). Records past the capacity are dropped,
/// counted and reported as on the CPU backend. Landings per photon (SPPM's): 2.1 in the
/// Cornell box, 9.2 in the albedo-0.9 furnace.
pub fn gpu_record_capacity(ctx: &SppmContext, photons: u32, kind: PhotonKind) -> u32 {
    let (pilot, _) = trace_photons(ctx, PILOT_PASS, PILOT_PHOTONS, kind);
    let per_photon = pilot.len() as f64 / PILOT_PHOTONS as f64;
    let capacity = (1.25 * per_photon * photons as f64).ceil() + 4096.0;
    capacity.min(MAX_PHOTON_RECORDS as f64) as u32
}

/// Photons per rayon task: enough to amortise the task, few enough to balance the threads
/// of a 128² pass.
const PHOTONS_PER_TASK: usize = 1024;

/// One stored photon: where it landed, where it came from, and what it carries.
#[derive(Clone, Copy, Debug)]
pub struct Photon {
    pub p: Vec3,
    /// Unit world direction back along the photon's last segment (towards the light's side).
    pub wi: Vec3,
    /// Flux carried, before the division by the pass's photon count.
    pub beta: Vec3,
    /// The surface's unit geometric normal (winding side).
    pub n: Vec3,
}

/// A pixel's progressive state (pbrt-v4 `SPPMPixel`, without the visible point, which is
/// rebuilt every pass).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SppmPixel {
    /// The gather radius; 0 until the pixel's first visible point sets it.
    pub radius: f32,
    /// N: the photon count the radius stands for.
    pub photon_count: f32,
    /// τ: the flux gathered so far, scaled to the current radius.
    pub tau: Vec3,
    /// Σ over passes of the light that needs no photons.
    pub direct: Vec3,
    /// The radius update's α ([`radius_alpha`]); 0 until the pixel's first gather decides it.
    pub alpha: f32,
}

impl From<crate::scene::layout::SppmPixelGpu> for SppmPixel {
    fn from(p: crate::scene::layout::SppmPixelGpu) -> SppmPixel {
        SppmPixel {
            radius: p.radius,
            photon_count: p.photon_count,
            tau: Vec3::from(p.tau),
            direct: Vec3::from(p.direct),
            alpha: p.alpha,
        }
    }
}

/// What a render's photon passes counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SppmStats {
    pub passes: u64,
    /// Photons stored over all passes.
    pub stored_photons: u64,
    /// Photon records dropped because a pass reached its bound (`record_capacity`).
    pub dropped_photons: u64,
    /// Rays the photons traced.
    pub photon_rays: u64,
    /// The most records one pass keeps: [`MAX_PHOTON_RECORDS`] on the CPU backend, the
    /// buffer's capacity on the GPU backend ([`gpu_record_capacity`]).
    pub record_capacity: u64,
}

/// The settings of one render's photon passes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SppmSettings {
    /// Photons per pass.
    pub photons: u32,
    /// Initial radius in pixel footprints.
    pub radius_pixels: f32,
}

impl SppmSettings {
    /// The photon passes `settings` ask for (`RenderSettings::photons`, `sppm_radius`):
    /// [`DEFAULT_SPPM_PHOTONS_PER_PIXEL`] and [`DEFAULT_SPPM_RADIUS_PIXELS`] unless told
    /// otherwise.
    pub fn of_render(settings: &crate::render::RenderSettings) -> SppmSettings {
        let s = settings;
        SppmSettings {
            photons: s
                .photons
                .unwrap_or(s.width.saturating_mul(s.height).saturating_mul(DEFAULT_SPPM_PHOTONS_PER_PIXEL))
                .min(MAX_PHOTONS_PER_PASS),
            radius_pixels: s.sppm_radius.unwrap_or(DEFAULT_SPPM_RADIUS_PIXELS),
        }
    }
}

/// What is constant over a render's passes.
pub struct SppmContext<'a> {
    pub scene: &'a FlatScene,
    pub camera: &'a Camera,
    pub settings: &'a IntegratorSettings,
    pub sppm: SppmSettings,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    pub sampler: SamplerKind,
    /// Passes the render will take (the texture level of detail of its camera rays).
    pub passes: u32,
}

/// A pixel's visible point for one pass.
#[derive(Clone, Copy)]
pub(crate) struct VisiblePoint {
    pub(crate) si: SurfaceInteraction,
    pub(crate) bsdf: GltfBsdf,
    /// The camera path's throughput over the probability of the non-delta choice.
    pub(crate) beta: Vec3,
    /// The camera ray cone's width there: one pixel's footprint.
    pub(crate) footprint: f32,
}

/// One pixel's camera path of one pass: the light that needs no photons, and where the
/// photons are to be gathered.
pub(crate) struct CameraPath {
    pub(crate) direct: Vec3,
    pub(crate) visible: Option<VisiblePoint>,
}

/// Pass `k` of every pixel: adds its estimate to `film` (per-pass statistics, see the
/// module's "Variance channels") and updates `pixels`. `rays` counts each pixel's camera
/// and shadow rays; the photons' rays go to `stats`.
pub fn sppm_pass(
    ctx: &SppmContext,
    k: u32,
    pixels: &mut [SppmPixel],
    film: &mut Film,
    rays: &mut [u64],
    stats: &mut SppmStats,
) {
    let w = ctx.width as usize;
    // Indexed, so that rayon writes each path in its place in the vector once.
    let camera_paths: Vec<CameraPath> = rays
        .par_iter_mut()
        .enumerate()
        .map(|(i, rays)| {
            let emission = |si: &SurfaceInteraction,
                            bs: &BsdfSample,
                            beta: Vec3,
                            sampler: &mut PathSampler,
                            rays: &mut u64| {
                bsdf_sampled_emission(ctx.scene, si, bs, beta, sampler, rays)
            };
            camera_path(ctx, (i % w) as u32, (i / w) as u32, k, rays, &emission)
        })
        .collect();
    // A pixel's first visible point sets its radius.
    for (pixel, path) in pixels.iter_mut().zip(&camera_paths) {
        if let (0.0, Some(vp)) = (pixel.radius, &path.visible) {
            let footprint = vp.footprint.max(ctx.scene.scene_radius * 1e-6);
            pixel.radius = ctx.sppm.radius_pixels * footprint;
        }
    }
    let (photons, photon_stats) = trace_photons(ctx, k, ctx.sppm.photons, PhotonKind::Indirect);
    *stats += photon_stats;
    let mean_radius = {
        let (sum, n) = pixels
            .iter()
            .zip(&camera_paths)
            .filter(|(p, c)| c.visible.is_some() && p.radius > 0.0)
            .fold((0.0f64, 0u64), |(s, n), (p, _)| (s + p.radius as f64, n + 1));
        if n == 0 {
            0.0
        } else {
            (sum / n as f64) as f32
        }
    };
    let grid = PhotonGrid::build(&photons, 2.0 * mean_radius);
    let photon_count = ctx.sppm.photons as f32;
    pixels.par_iter_mut().zip(film.pixels.par_iter_mut()).zip(camera_paths.par_iter()).for_each(
        |((pixel, film_pixel), path)| {
            let mut estimate = path.direct;
            pixel.direct += path.direct;
            if let Some(vp) = &path.visible {
                let (phi, m) = grid.gather(&photons, &vp.si, &vp.bsdf, pixel.radius);
                let area = std::f32::consts::PI * pixel.radius * pixel.radius;
                let covered = gather_coverage_area(ctx.scene, &vp.si, &vp.bsdf, pixel.radius);
                let phi = phi * coverage_correction(area, covered);
                if pixel.alpha == 0.0 {
                    pixel.alpha = radius_alpha(area, covered);
                }
                estimate += vp.beta * phi / (photon_count * area);
                if m > 0 {
                    let n = pixel.photon_count + pixel.alpha * m as f32;
                    let radius = pixel.radius * (n / (pixel.photon_count + m as f32)).sqrt();
                    let shrink = (radius / pixel.radius) * (radius / pixel.radius);
                    pixel.tau = (pixel.tau + vp.beta * phi) * shrink;
                    pixel.photon_count = n;
                    pixel.radius = radius;
                }
            }
            film_add_sample(film_pixel, estimate, replicate_of(k));
        },
    );
    stats.passes += 1;
}

/// The film of a render of `passes` passes of `photons` photons: each pixel's mean is the
/// progressive estimate Σ L_direct / n + τ / (n N_p π r²), its variance and replicates
/// those of its per-pass estimates in `per_pass` (moved by the same amount, so that their
/// spread is kept).
pub fn sppm_film(per_pass: &Film, pixels: &[SppmPixel], passes: u32, photons: u32) -> Film {
    let mut film = per_pass.clone();
    let n = passes.max(1) as f32;
    for (p, s) in film.pixels.iter_mut().zip(pixels) {
        let area = std::f32::consts::PI * s.radius * s.radius;
        let photon_light = if area > 0.0 { s.tau / (n * photons as f32 * area) } else { Vec3::ZERO };
        let value = s.direct / n + photon_light;
        let shift = value - Vec3::from(p.mean);
        if !shift.is_finite() {
            continue;
        }
        p.mean = value.to_array();
        if p.odd_count > 0 {
            p.odd_mean = (Vec3::from(p.odd_mean) + shift).to_array();
        }
    }
    film
}

/// Pixel (x, y)'s camera path of pass `k` (the module's step 1).
///
/// `at_visible_point` adds what the visible point's own BSDF sample `bs` finds along its
/// ray, drawing from the same sampler: [`bsdf_sampled_emission`] for SPPM, a final
/// gather for the photon-map integrator (`super::photon`).
pub(crate) fn camera_path(
    ctx: &SppmContext,
    x: u32,
    y: u32,
    k: u32,
    rays: &mut u64,
    at_visible_point: &dyn Fn(&SurfaceInteraction, &BsdfSample, Vec3, &mut PathSampler, &mut u64) -> Vec3,
) -> CameraPath {
    let scene = ctx.scene;
    let lights = scene.light_arrays();
    let mut sampler = PathSampler::new(ctx.sampler, x, y, k, ctx.seed);
    let mut ray = generate_camera_ray(ctx.camera, ctx.width, ctx.height, x, y, sampler.next_2d());
    let cone = camera_ray_cone(ctx.camera, ctx.height, ctx.passes);
    // One pixel's cone, for the radius: the texture cone above narrows with the samples
    // per pixel (a texture filter's footprint is the samples', not the pixel's).
    let pixel_cone = camera_ray_cone(ctx.camera, ctx.height, 1);
    let mut beta = Vec3::ONE;
    let mut eta_scale = 1.0f32;
    let mut travelled = 0.0f32;
    let mut direct = Vec3::ZERO;
    // The last bounce: a delta lobe (or the camera ray), else its density for MIS.
    let mut prev_delta = true;
    let mut prev_pdf = 0.0f32;
    let mut non_delta_depth = 0u32;
    for depth in 0..=MAX_BOUNCES_GUARD {
        *rays += 1;
        let alpha_seed = if scene.features.alpha { sampler.next_u32() } else { 0 };
        let Some(hit) = scene.intersect_closest(&ray, alpha_seed) else {
            let env = &scene.environment;
            if env.params.present != 0 {
                let (le, pdf_solid_angle) = environment_lookup(&env.params, &env.texels, ray.direction);
                let weight = if prev_delta || env.params.light_index == INVALID_INDEX {
                    1.0
                } else {
                    power_heuristic(
                        prev_pdf,
                        scene.lights[env.params.light_index as usize].pmf * pdf_solid_angle,
                    )
                };
                direct += beta * le * weight;
            }
            break;
        };
        let si = surface_interaction(scene, &ray, &hit, cone.width_at(travelled + hit.hit.t));
        travelled += si.distance;
        let untextured = &scene.materials[si.material as usize];
        let textured;
        let material = if scene.features.textures {
            textured = textured_material(untextured, &scene.texture_arrays(), si.uv, si.lod);
            &textured
        } else {
            untextured
        };
        if material.flags & MATERIAL_VOLUME != 0 && !si.front_face {
            beta *= (-Vec3::from(material.attenuation_coefficient) * si.distance).exp();
        }
        // Emission: in full when seen directly or through a delta lobe, else weighted
        // against the light sample of the glossy vertex before, as the path tracer does.
        if Vec3::from(untextured.emission).max_element() > 0.0
            && (si.front_face || material.flags & MATERIAL_DOUBLE_SIDED != 0)
        {
            if prev_delta || si.emitter == INVALID_INDEX {
                direct += beta * Vec3::from(material.emission);
            } else {
                let light = &scene.lights[si.emitter as usize];
                let b = Vec3::new(hit.hit.b0, hit.hit.b1, hit.hit.b2);
                let le = emitted_radiance(&scene.texture_arrays(), untextured, hit.triangle as usize, b);
                direct += beta * le * power_heuristic(prev_pdf, triangle_light_pdf(light, ray.origin, si.p));
            }
        }
        if depth == MAX_BOUNCES_GUARD {
            break;
        }
        let bsdf = GltfBsdf::new(material, si.wo, si.front_face, si.coat_normal);
        if bsdf.has_non_delta() {
            direct += next_event(scene, lights, &si, &bsdf, beta, &mut sampler, rays);
        }
        let u_lobe = if bsdf.chooses_a_lobe() {
            sampler.next_1d()
        } else {
            sampler.skip_1d();
            0.0
        };
        let u_dir = sampler.next_direction_2d();
        let Some(bs) = bsdf.sample(si.wo, u_lobe, u_dir) else { break };
        if !bs.is_delta && bsdf.has_diffuse_lobe() {
            direct += at_visible_point(&si, &bs, beta, &mut sampler, rays);
            let footprint = pixel_cone.width_at(travelled);
            let visible = VisiblePoint { si, bsdf, beta: beta / bsdf.non_delta_probability(), footprint };
            return CameraPath { direct, visible: beta.is_finite().then_some(visible) };
        }
        // A delta lobe, or a BSDF with glossy lobes only (a metal, a rough glass): the
        // camera path goes on, path traced (pbrt-v4's SPPM does the same): photons
        // gathered on a narrow lobe would be noise.
        let wi_world = si.frame.from_local(bs.wi).normalize();
        if !sides_agree(&si, wi_world, bs.wi) {
            break;
        }
        beta *= bs.weight;
        eta_scale *= bs.eta_scale;
        if !beta.is_finite() {
            return CameraPath { direct: Vec3::splat(f32::NAN), visible: None };
        }
        prev_delta = bs.is_delta;
        prev_pdf = bs.pdf_solid_angle;
        if !bs.is_delta {
            non_delta_depth += 1;
        }
        ray = spawn_ray(si.p, si.p_error, si.n_geometric, wi_world);
        // Roulette as the path tracer plays it (`super::roulette`).
        if non_delta_depth >= ctx.settings.rr_min_depth || depth + 1 >= RR_ANY_BOUNCE_DEPTH {
            let q = survival_probability(beta, eta_scale);
            if q <= 0.0 || sampler.next_1d() >= q {
                break;
            }
            beta /= q;
        }
    }
    CameraPath { direct, visible: None }
}

/// The emitter (or the environment) the visible point's own non-delta BSDF sample `bs`
/// sees, weighted by the power heuristic against [`next_event`]: direct light reflected
/// by a glossy visible point is found by whichever strategy suits it, as the path tracer
/// finds it. One ray per visible point.
pub(crate) fn bsdf_sampled_emission(
    scene: &FlatScene,
    si: &SurfaceInteraction,
    bs: &BsdfSample,
    beta: Vec3,
    sampler: &mut PathSampler,
    rays: &mut u64,
) -> Vec3 {
    let wi_world = si.frame.from_local(bs.wi).normalize();
    if !sides_agree(si, wi_world, bs.wi) {
        return Vec3::ZERO;
    }
    let ray = spawn_ray(si.p, si.p_error, si.n_geometric, wi_world);
    *rays += 1;
    let alpha_seed = if scene.features.alpha { sampler.next_u32() } else { 0 };
    let hit = scene.intersect_closest(&ray, alpha_seed);
    beta * bs.weight * mis_weighted_emission(scene, &ray, hit.as_ref(), bs.pdf_solid_angle)
}

/// The emission a BSDF-sampled ray (`ray`, its hit `hit`, sampled with density
/// `pdf_bsdf`) sees, weighted by the power heuristic against the light sample that could
/// have found the same light: an emitter's front (or either side of a double-sided one), or
/// the environment where it leaves the scene.
pub(crate) fn mis_weighted_emission(
    scene: &FlatScene,
    ray: &Ray,
    hit: Option<&ClosestHit>,
    pdf_bsdf: f32,
) -> Vec3 {
    let Some(hit) = hit else {
        let env = &scene.environment;
        if env.params.present == 0 {
            return Vec3::ZERO;
        }
        let (le, pdf_solid_angle) = environment_lookup(&env.params, &env.texels, ray.direction);
        let weight = if env.params.light_index == INVALID_INDEX {
            1.0
        } else {
            power_heuristic(pdf_bsdf, scene.lights[env.params.light_index as usize].pmf * pdf_solid_angle)
        };
        return le * weight;
    };
    let hit_si = surface_interaction(scene, ray, hit, 0.0);
    let material = &scene.materials[hit_si.material as usize];
    if Vec3::from(material.emission).max_element() <= 0.0
        || !(hit_si.front_face || material.flags & MATERIAL_DOUBLE_SIDED != 0)
    {
        return Vec3::ZERO;
    }
    let b = Vec3::new(hit.hit.b0, hit.hit.b1, hit.hit.b2);
    let le = emitted_radiance(&scene.texture_arrays(), material, hit.triangle as usize, b);
    let weight = if hit_si.emitter == INVALID_INDEX {
        1.0
    } else {
        let light = &scene.lights[hit_si.emitter as usize];
        power_heuristic(pdf_bsdf, triangle_light_pdf(light, ray.origin, hit_si.p))
    };
    le * weight
}

/// Which of a photon's landings are stored (WGSL twins `PHOTONS_*` in shaders/sppm.wgsl).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhotonKind {
    /// From the second bounce on: light that is not direct (SPPM's photons).
    Indirect,
    /// Every landing: direct light too (the photon-map integrator's global map).
    All,
    /// Landings reached from the light through delta bounces only, at least one (L S+ D,
    /// the caustic map).
    Caustic,
}

impl PhotonKind {
    /// The kernel's number for it (`FrameParams::photon_kind`).
    pub fn index(self) -> u32 {
        match self {
            PhotonKind::Indirect => 0,
            PhotonKind::All => 1,
            PhotonKind::Caustic => 2,
        }
    }
}

/// `count` photons of pass `pass` (the module's step 2), the landings `kind` keeps, in
/// photon order.
pub(crate) fn trace_photons(
    ctx: &SppmContext,
    pass: u32,
    count: u32,
    kind: PhotonKind,
) -> (Vec<Photon>, SppmStats) {
    let count = count as usize;
    let k = pass;
    let bdpt = BdptContext::new(ctx.scene, ctx.camera, ctx.settings, ctx.width, ctx.height);
    let tasks: Vec<(Vec<Photon>, u64)> = (0..count.div_ceil(PHOTONS_PER_TASK))
        .into_par_iter()
        .map(|task| {
            let mut photons = Vec::new();
            let mut rays = 0;
            for i in task * PHOTONS_PER_TASK..((task + 1) * PHOTONS_PER_TASK).min(count) {
                let mut rng = Rng::new(i as u32, PHOTON_STREAM, k, ctx.seed);
                trace_photon(&bdpt, &mut rng, kind, &mut photons, &mut rays);
            }
            (photons, rays)
        })
        .collect();
    let mut stats = SppmStats { record_capacity: MAX_PHOTON_RECORDS as u64, ..SppmStats::default() };
    let mut photons =
        Vec::with_capacity(tasks.iter().map(|(p, _)| p.len()).sum::<usize>().min(MAX_PHOTON_RECORDS));
    for (list, rays) in tasks {
        stats.photon_rays += rays;
        let room = MAX_PHOTON_RECORDS - photons.len();
        stats.dropped_photons += list.len().saturating_sub(room) as u64;
        photons.extend(list.into_iter().take(room));
    }
    stats.stored_photons = photons.len() as u64;
    (photons, stats)
}

/// One photon's walk: a photon at every surface with a non-delta lobe that `kind` keeps.
///
/// BDPT's light subpath walk by its surface-level steps
/// ([`super::bdpt::Walk::trace_surface`], [`super::bdpt::Walk::scatter_surface`]): a photon
/// keeps no vertex and needs no reverse density, and copying BDPT's 576-byte vertices, two
/// or three times a bounce, was 14% of the photons' time in a profile (bench/RESULTS.md,
/// "Photon mapping"). Draws the same numbers in the same order as BDPT's walk, so the
/// kernel's twin still agrees.
fn trace_photon(
    ctx: &BdptContext,
    rng: &mut Rng,
    kind: PhotonKind,
    photons: &mut Vec<Photon>,
    rays: &mut u64,
) {
    let Some((_, mut walk)) = light_subpath_origin(ctx.scene, rng) else { return };
    // Every bounce so far was by a delta lobe.
    let mut delta_so_far = true;
    for here in 1.. {
        let Some(surface) = walk.trace_surface(ctx, rng, rays) else { return };
        let kept = match kind {
            PhotonKind::Indirect => here >= 2,
            PhotonKind::All => true,
            PhotonKind::Caustic => here >= 2 && delta_so_far,
        };
        let beta = walk.beta();
        if kept && surface.bsdf.has_non_delta() && beta.is_finite() {
            let si = &surface.si;
            photons.push(Photon { p: si.p, wi: si.wo_world, beta, n: si.n_geometric });
        }
        match walk.scatter_surface(ctx, rng, &surface, here, false) {
            Some(scattered) if scattered.goes_on => delta_so_far &= scattered.delta,
            _ => return,
        }
        if kind == PhotonKind::Caustic && !delta_so_far {
            // No later landing can be a caustic's.
            return;
        }
    }
}

/// The photons of a pass in a uniform hash grid (the module's step 3): cell (i, j, k) of
/// edge `cell` holds the photons whose position falls in it, found through its hash's slot;
/// cells that share a slot share its run (a gather tests every photon's distance anyway).
pub(crate) struct PhotonGrid {
    cell: f32,
    /// Slots: a power of two, about one per photon.
    mask: u32,
    /// Run of slot s: `order[starts[s]..starts[s + 1]]`.
    starts: Vec<u32>,
    /// Photon indices sorted by slot, each slot's in photon order.
    order: Vec<u32>,
}

impl PhotonGrid {
    pub(crate) fn build(photons: &[Photon], cell: f32) -> PhotonGrid {
        let cell = if cell.is_finite() && cell > 0.0 { cell } else { 1.0 };
        let slots = photons.len().next_power_of_two().max(1);
        let mask = (slots - 1) as u32;
        let mut grid = PhotonGrid { cell, mask, starts: vec![0; slots + 1], order: vec![0; photons.len()] };
        let keys: Vec<u32> = photons.iter().map(|p| grid.slot(grid.cell_of(p.p))).collect();
        // Count, exclusive prefix sum, scatter (stable: photon order within each slot).
        for &s in &keys {
            grid.starts[s as usize + 1] += 1;
        }
        for s in 0..slots {
            grid.starts[s + 1] += grid.starts[s];
        }
        let mut next = grid.starts.clone();
        for (i, &s) in keys.iter().enumerate() {
            grid.order[next[s as usize] as usize] = i as u32;
            next[s as usize] += 1;
        }
        grid
    }

    fn cell_of(&self, p: Vec3) -> [i32; 3] {
        let c = (p / self.cell).floor();
        // Far outside any scene's float range a cell index saturates: still a valid cell.
        [c.x as i32, c.y as i32, c.z as i32]
    }

    /// The slot of cell `c` (Teschner et al. 2003's spatial hash).
    fn slot(&self, c: [i32; 3]) -> u32 {
        let h = (c[0] as u32).wrapping_mul(73_856_093)
            ^ (c[1] as u32).wrapping_mul(19_349_663)
            ^ (c[2] as u32).wrapping_mul(83_492_791);
        h & self.mask
    }

    /// Φ = Σ β_p f(ω_o, ω_p) |ω_p·n_s| / |ω_p·n_g| and M over the photons within `radius`
    /// of the surface point `si` whose BSDF is `bsdf` (the module's step 4).
    pub(crate) fn gather(
        &self,
        photons: &[Photon],
        si: &SurfaceInteraction,
        bsdf: &GltfBsdf,
        radius: f32,
    ) -> (Vec3, u32) {
        let (mut phi, mut m) = (Vec3::ZERO, 0u32);
        if photons.is_empty() || radius <= 0.0 {
            return (phi, m);
        }
        let lo = self.cell_of(si.p - Vec3::splat(radius));
        let hi = self.cell_of(si.p + Vec3::splat(radius));
        let r2 = radius * radius;
        let ng = si.n_geometric;
        let transmits = bsdf.has_rough_transmission();
        // The slots of the cells the sphere overlaps, each once (cells may share a slot);
        // a range with more cells than there are slots reads every slot.
        let cells: i64 = (0..3).map(|a| (hi[a] as i64 - lo[a] as i64 + 1).max(1)).product();
        let slots: Vec<u32> = if cells > self.mask as i64 {
            (0..=self.mask).collect()
        } else {
            let mut slots = Vec::with_capacity(cells as usize);
            for cz in lo[2]..=hi[2] {
                for cy in lo[1]..=hi[1] {
                    for cx in lo[0]..=hi[0] {
                        slots.push(self.slot([cx, cy, cz]));
                    }
                }
            }
            slots.sort_unstable();
            slots.dedup();
            slots
        };
        for s in slots {
            let run = self.starts[s as usize] as usize..self.starts[s as usize + 1] as usize;
            for &i in &self.order[run] {
                let photon = &photons[i as usize];
                let d = photon.p - si.p;
                if d.length_squared() > r2 {
                    continue;
                }
                // Photons on other surfaces count where each side could see the other
                // ([`facing_each_other`]): within one radius of an edge the disk πr² reaches
                // past the visible point's surface, and the photons on the surface meeting it
                // there stand in for that part.
                if !transmits && !facing_each_other(d, si, photon, radius) {
                    continue;
                }
                // Back-facing photons: one that arrived on the other side of its own surface
                // than the visible point's (the inside of a thin lampshade's next facet, seen
                // from outside) is light the point cannot receive. Each is judged by its own
                // surface's normal: a direction can be on the point's side of the point's
                // plane and still have reached the far side of a facet meeting it.
                // A surface that transmits (rough glass) receives light from both sides.
                if !transmits && (photon.wi.dot(photon.n) > 0.0) != (si.wo_world.dot(ng) > 0.0) {
                    continue;
                }
                let wi = si.frame.to_local(photon.wi);
                if !sides_agree(si, photon.wi, wi) {
                    continue;
                }
                let cos_geometric = photon.wi.dot(ng).abs();
                if cos_geometric <= 0.0 {
                    continue;
                }
                let f = bsdf.eval(si.wo, wi);
                phi += photon.beta * f * (wi.z.abs() / cos_geometric);
                m += 1;
            }
        }
        (phi, m)
    }
}

/// The area a gather at `si` within `radius` draws its photons from ([`gather_area`]): the
/// triangles inside the gather's sphere that its tests accept (step 4 of the module).
pub(crate) fn gather_coverage_area(
    scene: &FlatScene,
    si: &SurfaceInteraction,
    bsdf: &GltfBsdf,
    radius: f32,
) -> f32 {
    // +1 where the camera ray came from the front of the point's winding.
    let winding_side = if si.wo_world.dot(si.n_geometric) > 0.0 { 1.0 } else { -1.0 };
    let (tolerance, step) = plane_tolerances(radius, si.p.abs().max_element());
    let region = GatherRegion {
        center: si.p,
        n_point: si.n_geometric * winding_side,
        radius,
        tolerance,
        step,
        winding_side,
        transmits: bsdf.has_rough_transmission(),
    };
    gather_area(&scene.nodes, &scene.triangles, &scene.materials, &region)
}

/// The factor that turns the flux a gather over the disk of area `disk` found into flux over
/// the disk (step 4 of the module), given the `area` it draws its photons from
/// ([`gather_coverage_area`]): the disk over the area, where that area is smaller than the
/// disk, at most [`MAX_COVERAGE_CORRECTION`]; else 1.
///
/// Where the area is larger, at a concave edge or corner (the disk's part past the edge is
/// less than the part of the meeting surface within r, which the gather also reads), the
/// factor stays 1: taking it below 1 there made the Cornell box's room edges 0.5–1% dark
/// (irradiance falls towards a concave corner, and all of the meeting surface's part lies
/// within r of it, so its photons weigh the average towards the dark corner), where the
/// uncorrected estimate is within ±0.6% (bench/RESULTS.md, "Photon mapping").
pub(crate) fn coverage_correction(disk: f32, area: f32) -> f32 {
    disk / area.clamp(disk / MAX_COVERAGE_CORRECTION, disk)
}

/// A pixel's radius-update α, decided once, in the pass that sets its radius, from the
/// `area` its first gather draws from against the `disk` πr² of its initial radius:
/// [`SPPM_ALPHA_ONE_PLANE`] where they agree within [`ONE_PLANE_AREA_TOLERANCE`] (the disk
/// lies on the visible point's surface alone), else [`SPPM_ALPHA`].
pub(crate) fn radius_alpha(disk: f32, area: f32) -> f32 {
    if (area / disk - 1.0).abs() <= ONE_PLANE_AREA_TOLERANCE {
        SPPM_ALPHA_ONE_PLANE
    } else {
        SPPM_ALPHA
    }
}

/// The share of the gather radius by which a photon may lie behind the visible point's
/// tangent plane, or the point behind the photon's, and still count: a point within r of
/// another on a sphere of radius R lies within r²/2R of its tangent plane, so 0.1 admits
/// every curvature radius above 5r, as the radius shrinks every surface's.
pub const PLANE_TOLERANCE: f32 = 0.1;
/// The share of the gather radius by which one of the two may lie behind the other's plane
/// while the other lies in front of its own: a step between parallel surfaces, not a bend.
pub const STEP_TOLERANCE: f32 = 1e-3;
/// The plane tests' float error, in units of the larger coordinate's magnitude: two hit
/// points on one plane each carry a few ulps of their coordinates. Far from the origin, as
/// in the `cornell-far` scenes, it reaches [`PLANE_TOLERANCE`] of the radius, and the step
/// test gives way to the plane test alone.
pub const PLANE_POSITION_ERROR: f32 = 32.0 * f32::EPSILON;

/// Can photon `photon`, `d` from the visible point `si` gathering within `radius`, light
/// it? Each must lie in front of the other's surface, as seen from the side each was
/// reached from, within [`PLANE_TOLERANCE`] of the radius. A photon on a wall meeting the
/// floor at a visible point's edge does; one on the far side of a thin wall, or on a box's
/// top seen from the floor beside it, does not. Until 2026-12-05 this gather kept only
/// photons on surfaces whose normals were within 60° of the point's: every edge and corner
/// was darker by the part of the disk past its surface, on the 64² Cornell box at 2,048
/// passes 2·10⁻⁴ of a relMSE of 2.5·10⁻⁴; with this test the relMSE is 1.2·10⁻⁴
/// (bench/RESULTS.md, "SPPM against pbrt-v4's sppm"). Keeping every photon, as pbrt-v4
/// does, gave 0.9·10⁻⁴ there but let light through thin walls: the lamp room's mean 5%
/// bright (+1.5% with the test).
///
/// Where a surface bends, the two lie on the same side of each other's planes: in front of
/// both at a concave bend (a room's corner), behind both at a convex one (a box's edge, a
/// sphere), where the tolerance lets the photons on the far face stand in for the part of
/// the disk past the edge. One in front and the other behind is a step between parallel
/// surfaces, or light through a thin wall: a point on the slit room's floor, beside its
/// lamp box, is in front of the photons on the box's floor inside, 1 mm above its own, and
/// behind their plane; and in front of the photons on the box's inner walls, behind theirs.
/// Such a pair counts only within [`STEP_TOLERANCE`] of the radius, or the positions' float
/// error ([`PLANE_POSITION_ERROR`]) where that is larger. Until
/// 2026-12-06 it counted within [`PLANE_TOLERANCE`], and the slit room was +114% bright
/// at 24² and 256 passes; now +18%. What is left is beyond any plane test: a point on the
/// floor outside the box is in front of the inner faces of its far walls and lid, and they
/// in front of it, with the near wall between them (only a ray could tell; the bias
/// shrinks with the radius, `tests/photon_mapping.rs`).
fn facing_each_other(d: Vec3, si: &SurfaceInteraction, photon: &Photon, radius: f32) -> bool {
    let ng = si.n_geometric;
    let n_point = if si.wo_world.dot(ng) > 0.0 { ng } else { -ng };
    let n_photon = if photon.wi.dot(photon.n) > 0.0 { photon.n } else { -photon.n };
    let magnitude = si.p.abs().max_element().max(photon.p.abs().max_element());
    in_front_of_each_other(d, n_point, n_photon, magnitude, radius)
}

/// [`facing_each_other`] with the normals turned to the sides the point and the photon
/// were reached from, and `magnitude` the largest coordinate of either position.
pub(crate) fn in_front_of_each_other(
    d: Vec3,
    n_point: Vec3,
    n_photon: Vec3,
    magnitude: f32,
    radius: f32,
) -> bool {
    let photon_height = d.dot(n_point);
    let point_height = -d.dot(n_photon);
    let (lower, upper) = (photon_height.min(point_height), photon_height.max(point_height));
    let (tolerance, step) = plane_tolerances(radius, magnitude);
    lower >= -step || (lower >= -tolerance && upper <= step)
}

/// The plane tests' two bounds for a gather within `radius` where the larger coordinate's
/// magnitude is `magnitude`: ([`PLANE_TOLERANCE`] of the radius, [`STEP_TOLERANCE`] of it
/// or the positions' float error, whichever is larger, at most the first).
fn plane_tolerances(radius: f32, magnitude: f32) -> (f32, f32) {
    let tolerance = PLANE_TOLERANCE * radius;
    let step = (STEP_TOLERANCE * radius).max(PLANE_POSITION_ERROR * magnitude).min(tolerance);
    (tolerance, step)
}

impl std::ops::AddAssign for SppmStats {
    fn add_assign(&mut self, o: SppmStats) {
        self.passes += o.passes;
        self.stored_photons += o.stored_photons;
        self.dropped_photons += o.dropped_photons;
        self.photon_rays += o.photon_rays;
        self.record_capacity = self.record_capacity.max(o.record_capacity);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn photon_at(p: Vec3) -> Photon {
        Photon { p, wi: Vec3::Z, beta: Vec3::ONE, n: Vec3::Z }
    }

    /// A pixel's α where the Cornell box camera's central ray meets the back wall: within a
    /// thousandth of the scene's radius the disk lies on the wall alone (the slower α, no
    /// flux correction but rounding); within the scene's whole radius it reaches past the
    /// wall's edges onto the surfaces meeting it (the update's own α).
    #[test]
    fn a_disk_on_one_plane_shrinks_more_slowly_than_one_across_an_edge() {
        let scene = crate::scene::bundled_flat_scene("cornell-box.gltf");
        let ray = generate_camera_ray(&scene.camera, 64, 64, 32, 32, glam::Vec2::splat(0.5));
        let hit = scene.intersect_closest(&ray, 0).expect("the central ray meets the box");
        let si = surface_interaction(&scene, &ray, &hit, 0.0);
        let material = &scene.materials[si.material as usize];
        let bsdf = GltfBsdf::new(material, si.wo, si.front_face, si.coat_normal);
        let alpha_and_correction = |radius: f32| {
            let disk = std::f32::consts::PI * radius * radius;
            let area = gather_coverage_area(&scene, &si, &bsdf, radius);
            (radius_alpha(disk, area), coverage_correction(disk, area), area / disk)
        };
        let (alpha, correction, share) = alpha_and_correction(1e-3 * scene.scene_radius);
        assert_eq!(alpha, SPPM_ALPHA_ONE_PLANE, "area / disk {share}");
        // The area's f32 rounding, summed from triangle pieces: a few 1e-6 of the disk.
        assert!((correction - 1.0).abs() < 1e-4, "{correction}");
        let (alpha, _, share) = alpha_and_correction(scene.scene_radius);
        assert_eq!(alpha, SPPM_ALPHA, "area / disk {share}");
    }

    /// The plane tests, a visible point at the origin on a floor facing +z, gathering
    /// within 0.6 (the slit room's radius at 24²).
    #[test]
    fn photons_count_across_bends_and_edges_but_not_across_a_step() {
        let (up, r) = (Vec3::Z, 0.6);
        let counts = |d: Vec3, n_photon: Vec3| in_front_of_each_other(d, up, n_photon, 1.0, r);
        // On the same floor, and on a wall meeting it (facing the point): a concave bend.
        assert!(counts(Vec3::new(0.3, 0.0, 0.0), up));
        assert!(counts(Vec3::new(0.3, 0.0, 0.1), -Vec3::X));
        // On the side of a box whose top the point is on, 5 cm from the edge and 3 cm down,
        // and on a sphere whose normal has turned by 15° 0.3 away, 5 cm down (one of radius
        // 0.9 bends so): convex bends, each behind the other's plane, within 0.06.
        assert!(counts(Vec3::new(0.05, 0.0, -0.03), Vec3::X));
        let turned = Vec3::new(15f32.to_radians().sin(), 0.0, 15f32.to_radians().cos());
        assert!(counts(Vec3::new(0.3, 0.0, -0.05), turned));
        // Steps: a parallel floor 1 mm above (the slit room's lamp box) or below, 5 cm
        // below, and a box's top 5 cm above the floor beside it.
        assert!(!counts(Vec3::new(0.3, 0.0, 0.001), up));
        assert!(!counts(Vec3::new(0.3, 0.0, -0.001), up));
        assert!(!counts(Vec3::new(0.3, 0.0, -0.05), up));
        assert!(!counts(Vec3::new(0.3, 0.0, 0.05), up));
        // Through a thin wall 5 cm away: a photon on its far face, facing away from the
        // point (the lamp box's inner wall), and the far side of a rod 0.1 thick.
        assert!(!counts(Vec3::new(0.05, 0.0, 0.1), Vec3::X));
        assert!(!counts(Vec3::new(0.0, 0.0, -0.1), -up));
        // Far from the origin the positions' own error is tolerated (coordinates of 10⁶
        // carry 0.06 per ulp): a photon 1 cm off the point's plane there still counts.
        assert!(in_front_of_each_other(Vec3::new(0.03, 0.0, -0.01), up, up, 1e6, r));
    }

    #[test]
    fn the_grid_holds_every_photon_once_in_photon_order_within_a_slot() {
        let photons: Vec<Photon> = (0..1000)
            .map(|i| {
                let t = i as f32 * 0.618_034;
                photon_at(Vec3::new(t.fract() * 4.0 - 2.0, (t * 7.0).fract(), (t * 13.0).fract() * 0.5))
            })
            .collect();
        let grid = PhotonGrid::build(&photons, 0.1);
        let mut all = grid.order.clone();
        all.sort_unstable();
        assert_eq!(all, (0..1000).collect::<Vec<u32>>());
        for s in 0..grid.starts.len() - 1 {
            let run = &grid.order[grid.starts[s] as usize..grid.starts[s + 1] as usize];
            assert!(run.windows(2).all(|w| w[0] < w[1]), "slot {s} out of order");
            for &i in run {
                assert_eq!(grid.slot(grid.cell_of(photons[i as usize].p)), s as u32);
            }
        }
    }
}
