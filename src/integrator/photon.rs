//! Photon mapping with a caustic map, a global map and a final gather (Jensen 1996, "Global
//! Illumination using Photon Maps"; Jensen 2001, *Realistic Image Synthesis Using Photon
//! Mapping*, ch. 9): the lecture's "shoot photons and record their hit points; shoot
//! viewing rays and collect the nearest photons".
//!
//! Before the first sample two maps are built once (`super::sppm`'s photon tracing and
//! hash grid):
//! * the **global map**: `photons` photons from the lights by power, stored at every
//!   landing on a surface with a non-delta lobe, direct light included;
//! * the **caustic map**: `caustic_photons` more, of which only the landings reached from
//!   the light through delta bounces alone are kept (L S+ D).
//!
//! Each sample then traces its pixel's camera path as SPPM does (through delta and
//! glossy-only surfaces, path traced, with next-event estimation and MIS) to its visible
//! point, and adds there
//! * the caustics: a density estimate of the caustic map within a radius of
//!   [`CAUSTIC_RADIUS_PIXELS`] pixel footprints;
//! * the rest of the indirect light by a **final gather**: the visible point's own BSDF
//!   sample is traced (through delta surfaces, whose emitters it ignores: the caustic map
//!   has those paths) to a surface with a non-delta lobe, where the global map's density
//!   estimate within `global_radius` gives the radiance that came back along it. Where
//!   the sample's first hit is an emitter, its emission is weighted against the light
//!   sample by the power heuristic, as SPPM weighs it.
//!
//! The maps never change, so the image converges, as samples add up, to the photon-map
//! solution: biased by the two radii (blur) and the global map's noise (blotches), neither
//! of which more samples remove. The variance channels are those of the samples, given the
//! maps: noise only. `sppm` is the consistent method; this one is quick where its bias is
//! acceptable.
//!
//! **GPU twin** (`shaders/photon.wgsl`): the maps are traced and sorted into their grids
//! once on the device by SPPM's photon and grid passes (`shaders/sppm.wgsl`), each map in
//! its own part of the shared buffers, sized by a pilot
//! ([`super::sppm::gpu_record_capacity`]); its count is read back between the tracing and
//! the grid, since the global radius follows from it. A sample is then this module's, from
//! the same streams (tests/gpu/sppm.rs).

use glam::Vec3;

use super::bdpt::vertex_material;
use super::interaction::{sides_agree, surface_interaction, SurfaceInteraction};
use super::sppm::{
    camera_path, mis_weighted_emission, trace_photons, Photon, PhotonGrid, PhotonKind, SppmContext, SppmStats,
};
use crate::bsdf::{BsdfSample, GltfBsdf};
use crate::geometry::spawn_ray;
use crate::sampling::PathSampler;
use crate::scene::layout::MATERIAL_VOLUME;
use crate::scene::FlatScene;

/// The caustic estimate's radius in pixel footprints at the visible point: caustics are
/// seen directly, so their blur is kept to about a pixel on each side.
pub const CAUSTIC_RADIUS_PIXELS: f32 = 2.0;

/// The photons a global-map estimate averages over unless told otherwise
/// (`--gather-photons`); its radius follows from it ([`global_radius`]). Below Jensen's
/// usual 50–100: the final gather averages the estimates of many nearby points, so their
/// noise matters less than their blur (on a 24² Cornell box with 2¹⁸ photons the image
/// mean was 0.15% low at 16, 0.5% at 64).
pub const DEFAULT_GATHER_PHOTONS: u32 = 32;

/// Photons per map unless told otherwise (`--photons`, `--caustic-photons`): four per
/// pixel, and at least 2¹⁸ (a third of a second here), which small images need: the maps'
/// blur is in world space, and a 24² Cornell box with 2,304 photons was 5% dark at its
/// corners and edges.
pub fn default_map_photons(width: u32, height: u32) -> u32 {
    width.saturating_mul(height).saturating_mul(4).clamp(1 << 18, super::sppm::MAX_PHOTONS_PER_PASS)
}

/// Pass indices of the maps' photon streams: past any sample index a render can reach
/// (`--spp` is a `u32` of samples, and the maps are traced once).
pub(crate) const GLOBAL_MAP_PASS: u32 = u32::MAX;
pub(crate) const CAUSTIC_MAP_PASS: u32 = u32::MAX - 1;

/// The most delta bounces a final-gather ray follows before it gives up.
pub const GATHER_DELTA_BOUNCES: u32 = 16;

/// A render's two photon maps.
pub struct PhotonMaps {
    global: Vec<Photon>,
    global_grid: PhotonGrid,
    /// Photons traced for the global map (the estimate's divisor).
    global_emitted: u32,
    global_radius: f32,
    caustic: Vec<Photon>,
    caustic_grid: PhotonGrid,
    caustic_emitted: u32,
    /// What tracing them counted.
    pub stats: SppmStats,
}

/// The settings of the photon-map integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonMapSettings {
    /// Photons traced for the global map.
    pub photons: u32,
    /// Photons traced for the caustic map (only their caustic landings kept).
    pub caustic_photons: u32,
    /// Photons a global estimate averages over.
    pub gather_photons: u32,
}

/// The scene's surface area, for [`global_radius`].
pub fn scene_area(scene: &FlatScene) -> f64 {
    scene
        .triangles
        .iter()
        .map(|t| {
            let (p0, p1, p2) = (Vec3::from(t.p0), Vec3::from(t.p1), Vec3::from(t.p2));
            0.5 * (p1 - p0).cross(p2 - p0).length() as f64
        })
        .sum()
}

/// The global map's radius: where `photons` stored photons spread evenly over the scene's
/// surface area A ([`scene_area`]), a disk of radius r holds `gather` of them:
/// r = √(gather · A / (π n)). Photons crowd where light falls, so lit regions average more
/// and dark ones fewer.
pub fn global_radius(area: f64, scene_radius: f32, photons: usize, gather: u32) -> f32 {
    let r = (gather as f64 * area / (std::f64::consts::PI * photons.max(1) as f64)).sqrt() as f32;
    if r.is_finite() && r > 0.0 {
        r
    } else {
        scene_radius * 1e-2
    }
}

/// The caustic map's grid cell: about the caustic radius at a typical visible point (a
/// pixel's footprint at the scene's radius), so a gather reads a few cells.
pub fn caustic_cell(ctx: &SppmContext) -> f32 {
    let camera_cone = crate::scene::camera::camera_ray_cone(ctx.camera, ctx.height, ctx.passes);
    2.0 * CAUSTIC_RADIUS_PIXELS * camera_cone.width_at(ctx.scene.scene_radius)
}

impl PhotonMapSettings {
    /// The maps `settings` ask for (`--photons`, `--caustic-photons`, `--gather-photons`),
    /// [`default_map_photons`] and [`DEFAULT_GATHER_PHOTONS`] unless told otherwise.
    pub fn of_render(settings: &crate::render::RenderSettings) -> PhotonMapSettings {
        let default = default_map_photons(settings.width, settings.height);
        PhotonMapSettings {
            photons: settings.photons.unwrap_or(default),
            caustic_photons: settings.caustic_photons.unwrap_or(default),
            gather_photons: settings.gather_photons.unwrap_or(DEFAULT_GATHER_PHOTONS),
        }
    }
}

impl PhotonMaps {
    /// Traces both maps (the module's first step).
    pub fn build(ctx: &SppmContext, settings: &PhotonMapSettings) -> PhotonMaps {
        let (global, mut stats) = trace_photons(ctx, GLOBAL_MAP_PASS, settings.photons, PhotonKind::All);
        let (caustic, caustic_stats) =
            trace_photons(ctx, CAUSTIC_MAP_PASS, settings.caustic_photons, PhotonKind::Caustic);
        stats += caustic_stats;
        let global_radius = global_radius(
            scene_area(ctx.scene),
            ctx.scene.scene_radius,
            global.len(),
            settings.gather_photons,
        );
        let caustic_cell = caustic_cell(ctx);
        PhotonMaps {
            global_grid: PhotonGrid::build(&global, 2.0 * global_radius),
            global,
            global_emitted: settings.photons,
            global_radius,
            caustic_grid: PhotonGrid::build(&caustic, caustic_cell),
            caustic,
            caustic_emitted: settings.caustic_photons,
            stats,
        }
    }

    /// Photons stored in the two maps.
    pub fn stored(&self) -> (usize, usize) {
        (self.global.len(), self.caustic.len())
    }
}

/// Sample `k` of pixel (x, y) (the module's second step).
pub fn photon_map_sample(
    ctx: &SppmContext,
    maps: &PhotonMaps,
    x: u32,
    y: u32,
    k: u32,
    rays: &mut u64,
) -> Vec3 {
    let gather =
        |si: &SurfaceInteraction, bs: &BsdfSample, beta: Vec3, sampler: &mut PathSampler, rays: &mut u64| {
            final_gather(ctx.scene, maps, si, bs, beta, sampler, rays)
        };
    let path = camera_path(ctx, x, y, k, rays, &gather);
    let Some(vp) = path.visible else { return path.direct };
    let radius = CAUSTIC_RADIUS_PIXELS * vp.footprint.max(ctx.scene.scene_radius * 1e-6);
    let (phi, _) = maps.caustic_grid.gather(&maps.caustic, &vp.si, &vp.bsdf, radius);
    let area = std::f32::consts::PI * radius * radius;
    path.direct + vp.beta * phi / (maps.caustic_emitted.max(1) as f32 * area)
}

/// The final gather along the visible point's BSDF sample `bs` (throughput `beta` before
/// it): the emitter it hits first, MIS-weighted, or the global map's radiance at the first
/// surface with a non-delta lobe past any delta bounces.
fn final_gather(
    scene: &FlatScene,
    maps: &PhotonMaps,
    si: &SurfaceInteraction,
    bs: &BsdfSample,
    beta: Vec3,
    sampler: &mut PathSampler,
    rays: &mut u64,
) -> Vec3 {
    let mut wi_world = si.frame.from_local(bs.wi).normalize();
    if !sides_agree(si, wi_world, bs.wi) {
        return Vec3::ZERO;
    }
    let mut beta = beta * bs.weight;
    let mut ray = spawn_ray(si.p, si.p_error, si.n_geometric, wi_world);
    let mut emission = Vec3::ZERO;
    for bounce in 0..GATHER_DELTA_BOUNCES {
        *rays += 1;
        let alpha_seed = if scene.features.alpha { sampler.next_u32() } else { 0 };
        let hit = scene.intersect_closest(&ray, alpha_seed);
        if bounce == 0 {
            // An emitter seen along the sample itself; past a delta bounce the caustic map
            // has it.
            emission = beta * mis_weighted_emission(scene, &ray, hit.as_ref(), bs.pdf_solid_angle);
        }
        let Some(hit) = hit else { return emission };
        let here = surface_interaction(scene, &ray, &hit, 0.0);
        let material = vertex_material(scene, &here);
        if material.flags & MATERIAL_VOLUME != 0 && !here.front_face {
            beta *= (-Vec3::from(material.attenuation_coefficient) * here.distance).exp();
        }
        let bsdf = GltfBsdf::new(&material, here.wo, here.front_face, here.coat_normal);
        if bsdf.has_non_delta() {
            let (phi, _) = maps.global_grid.gather(&maps.global, &here, &bsdf, maps.global_radius);
            let area = std::f32::consts::PI * maps.global_radius * maps.global_radius;
            return emission + beta * phi / (maps.global_emitted.max(1) as f32 * area);
        }
        // A delta surface: follow it.
        let u_lobe = if bsdf.chooses_a_lobe() { sampler.next_1d() } else { 0.0 };
        let Some(next) = bsdf.sample(here.wo, u_lobe, sampler.next_2d()) else { return emission };
        wi_world = here.frame.from_local(next.wi).normalize();
        if !sides_agree(&here, wi_world, next.wi) {
            return emission;
        }
        beta *= next.weight;
        if !beta.is_finite() {
            return emission;
        }
        ray = spawn_ray(here.p, here.p_error, here.n_geometric, wi_world);
    }
    emission
}
