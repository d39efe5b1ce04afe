//! Irradiance caching (Ward, Rubinstein & Clear 1988, "A Ray Tracing Solution for Diffuse
//! Interreflection"): the lecture's "indirect changes smoothly; cache irradiance;
//! interpolate". The path tracer's option `--irradiance-cache`.
//!
//! **What is cached.** A record at point p with normal n holds the irradiance E that arrives
//! there from everything but the light sources next-event estimation samples: light that
//! has bounced at least once, plus emitters light sampling cannot pick (an environment that
//! is not a light). It is computed by a stratified gather of M × 3M cosine-distributed
//! directions (Ward & Heckbert 1992, "Irradiance Gradients": θ_j = asin √((j + ξ)/M),
//! φ_k = 2π(k + ξ')/3M; 16 × 48 = 768 by default, `--ic-rays`), each traced on by the path
//! tracer itself ([`super::path::indirect_radiance`]): the ray's first hit adds no emission
//! of a sampled light, and from there on the path is the path tracer's.
//!
//! **Where it is used.** At the first vertex of a camera path with a Lambertian lobe (after
//! any chain of delta bounces; [`super::path`]): next-event estimation stays, the Lambertian
//! lobe's indirect light is ρ_d(ω_o) · E(p)/π from the cache ([`GltfBsdf::diffuse_albedo`];
//! exact for a matte surface, and for a layered one under light that is the same from every
//! direction), and the BSDF sample goes on for the rest: its first hit adds the sampled
//! lights' emission with the full BSDF (MIS-weighted, as always), and its path carries on
//! with the throughput of the lobes that are not Lambertian, (f − f_d) cos θ / pdf
//! (glossy and specular stay path traced). A point no record covers is path traced as
//! without the cache.
//!
//! **Validity radius and weight.** A record's radius R starts as the harmonic mean distance
//! of its gather rays (Ward et al. 1988), limited by its translational gradient,
//! R ≤ E/‖∇_t E‖ (Křivánek et al. 2006, "Making Radiance and Irradiance Caching
//! Practical: Adaptive Caching and Neighbor Clamping"), and by its neighbours, R_i ≤ R_j +
//! ‖p_i − p_j‖ both ways (neighbour clamping, the same paper). It is then clamped in screen
//! space (Tabellion & Lamorlette 2004, "An Approximate Global Illumination System for
//! Computer Generated Films"), between [`MIN_SPACING_PIXELS`] pixel footprints at the record
//! and [`MAX_SPACING_FRACTION`] of the image height, and scaled by the accuracy a
//! (`--ic-accuracy`; smaller is tighter, as Radiance's `-aa`). Record i is valid at (p, n) with the weight of Tabellion &
//! Lamorlette,
//!
//! ```text
//! ε_i = max(‖p − p_i‖ / (a R_i),  √(1 − n·n_i) / (a √(1 − cos 10°))),   w_i = 1 − ε_i > 0,
//! ```
//!
//! unless p lies in front of it ((p − p_i)·(n + n_i)/2 < −R_i a/20: Ward's test), and
//! E(p) = Σ w_i (E_i + (n_i × n)·∇_r E_i + (p − p_i)·∇_t E_i) / Σ w_i with Ward & Heckbert's
//! rotational and translational gradients (in Křivánek et al.'s corrected form, *Practical
//! Global Illumination with Irradiance Caching*, 2009, eq. 2.12 and 2.14).
//!
//! **Placement: an overture.** Records are placed before the image is rendered, so that the
//! image does not depend on the order pixels are rendered in or on the thread count
//! (Mitsuba 0.6's `irrcache` does the same): pixels are visited on grids of halving stride
//! (coarsest first, each level in three phases whose pixels are a stride apart); in each
//! phase every pixel finds its first Lambertian vertex and, where no record is valid there,
//! computes one (in parallel), and the phase's records join the cache in pixel order. After
//! the stride-1 level every pixel's own point is covered; samples that land where none is
//! valid (an accuracy below a pixel, or a path through glass) are path traced.
//!
//! **GPU.** The GPU backend places the records with device passes
//! ([`IrradianceCache::build_on_device`]): one pass finds every pixel's first Lambertian
//! vertex (`ic_first_vertex`), and each phase's gather rounds run one gather ray per
//! invocation through the path tracer's own bounce loop (`render`'s gather mode), from the
//! same streams as here. The host runs the phases around them: which pixels need a record,
//! each record's reduction of its rays, the neighbour clamping and the grid, uploaded as
//! [`IrradianceCacheTables`]. The kernel's twin of [`IrradianceCache::lookup`]
//! (`shaders/irradiance_cache.wgsl`) reads them in the host's order, so the two backends'
//! records and images agree to rounding.
//!
//! **Bias.** Interpolation error (the radius and gradients), the records' own noise (each
//! is one M × 3M gather, and a pixel reads the same records for all its samples) and, on
//! layered materials, the albedo approximation. More samples per pixel do not remove it;
//! a tighter accuracy and more gather rays do. The variance channels measure the samples'
//! noise given the cache.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::bdpt::vertex_material;
use super::interaction::{sides_agree, surface_interaction, SurfaceInteraction};
use super::path::indirect_radiance;
use super::IntegratorSettings;
use crate::bsdf::GltfBsdf;
use crate::geometry::{spawn_ray, Frame};
use crate::sampling::{PathSampler, Rng, SamplerKind};
use crate::scene::camera::{camera_ray_cone, generate_camera_ray, RayCone};
use crate::scene::layout::Camera;
use crate::scene::FlatScene;

/// What the EXR's variance channels measure under the cache (`pathlight.variance`).
pub const VARIANCE_MEANING: &str = "the sample variance of each pixel's samples given the irradiance cache: noise only; \
     the cache's bias (its interpolation and its records' own noise) is not in it, nor in the predicted error";

/// The accuracy unless told otherwise (`--ic-accuracy`): the validity radius is the record's
/// clamped radius times it.
pub const DEFAULT_IC_ACCURACY: f32 = 1.0;

/// Gather rays per record unless told otherwise (`--ic-rays`): 16 × 48, Ward & Heckbert's
/// stratification with three times as many azimuths as polar strata.
pub const DEFAULT_IC_GATHER_RAYS: u32 = 768;

/// `--ic-rays` bounds: 2 × 6 strata (the gradients need two strata each way) to 128 × 384.
pub const MIN_IC_GATHER_RAYS: u32 = 12;
pub const MAX_IC_GATHER_RAYS: u32 = 3 * 128 * 128;

/// The radius clamp at the record, before the accuracy scales it: no record covers less
/// than [`MIN_SPACING_PIXELS`] pixel footprints (each costs hundreds of paths), and none
/// more than [`MAX_SPACING_FRACTION`] of the image's height in pixel footprints (where
/// nothing nearby bounds it, as on an open floor; a caustic on a ceiling far from
/// everything varies faster than the harmonic mean distance says).
pub const MIN_SPACING_PIXELS: f32 = 3.0;
pub const MAX_SPACING_FRACTION: f32 = 0.1;

/// Normals within this angle (at accuracy 1) share records (Tabellion & Lamorlette 2004).
pub const MAX_NORMAL_DEVIATION_DEGREES: f32 = 10.0;

/// The row of [`Rng::new`] gather rays draw from: no pixel has it, and the light tracer's,
/// photons' and pilot streams have `u32::MAX`, `u32::MAX − 1`.
pub const IC_STREAM: u32 = u32::MAX - 2;

/// How far past its validity radius (in units of it) a record still serves a camera sample
/// that no record is valid for ([`IrradianceCache::lookup`]).
pub const FALLBACK_REACH: f32 = 2.0;

/// A record's gather is repeated, in fresh rounds of M × 3M rays, while the relative
/// standard error of its irradiance is above this times the accuracy, up to
/// [`MAX_GATHER_ROUNDS`] rounds (Radiance's ambient super-samples spend extra rays where the
/// variance is high in the same spirit). A plain Cornell-box wall is below it after one
/// round; a room lit through a lampshade's opening needs all of them.
pub const GATHER_RELATIVE_ERROR: f32 = 0.04;
pub const MAX_GATHER_ROUNDS: u32 = 8;

/// The seed salt of the overture's camera paths (kept apart from the render's samples).
const OVERTURE_SALT: u32 = 0x1c0f_fee5;

/// The most delta bounces a camera path follows to its first Lambertian vertex.
const MAX_DELTA_CHAIN: u32 = 16;

/// The coarsest stride of the overture, in pixels.
const COARSEST_STRIDE: u32 = 32;

/// Rec. 709 luminance weights, for the gradient limit of the radius.
const LUMINANCE: Vec3 = Vec3::new(0.2126, 0.7152, 0.0722);

/// The cache's settings (`--ic-accuracy`, `--ic-rays`, `--ic-no-gradients`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IrradianceCacheSettings {
    /// a: the validity radius is a × the clamped radius, and the normal limit a × 10°.
    pub accuracy: f32,
    /// Gather rays per record (rounded to M × 3M, [`gather_strata`]).
    pub gather_rays: u32,
    /// Interpolate with the rotational and translational gradients.
    pub gradients: bool,
}

impl Default for IrradianceCacheSettings {
    fn default() -> Self {
        IrradianceCacheSettings {
            accuracy: DEFAULT_IC_ACCURACY,
            gather_rays: DEFAULT_IC_GATHER_RAYS,
            gradients: true,
        }
    }
}

impl IrradianceCacheSettings {
    /// Checks the settings, with a message naming the option that is wrong.
    pub fn validate(&self) -> crate::Result<()> {
        if !(self.accuracy.is_finite() && self.accuracy > 0.0 && self.accuracy <= 100.0) {
            return Err(crate::Error::Settings(format!(
                "--ic-accuracy scales each record's validity radius: a number in (0, 100], not {}",
                self.accuracy
            )));
        }
        if !(MIN_IC_GATHER_RAYS..=MAX_IC_GATHER_RAYS).contains(&self.gather_rays) {
            return Err(crate::Error::Settings(format!(
                "--ic-rays is the number of gather rays per record: {MIN_IC_GATHER_RAYS} to {MAX_IC_GATHER_RAYS}, not {}",
                self.gather_rays
            )));
        }
        Ok(())
    }
}

/// The polar and azimuthal strata (M, 3M) of `rays` gather rays: M = round(√(rays/3)), at
/// least 2.
pub fn gather_strata(rays: u32) -> (u32, u32) {
    let m = ((rays as f32 / 3.0).sqrt().round() as u32).max(2);
    (m, 3 * m)
}

/// One cached irradiance value and what its interpolation needs.
#[derive(Clone, Copy, Debug)]
pub struct IrradianceRecord {
    pub p: Vec3,
    /// Unit shading normal on the side the camera path arrived from.
    pub n: Vec3,
    /// Irradiance from everything but the sampled lights seen directly.
    pub e: Vec3,
    /// The radius before the pixel clamp and the accuracy: harmonic mean distance, limited by
    /// the gradient and the neighbours (world units).
    pub radius: f32,
    /// The pixel clamp ([`MIN_SPACING_PIXELS`], [`MAX_SPACING_FRACTION`]) in world units.
    pub bounds: (f32, f32),
    /// Rotational gradient, one world vector per colour channel.
    pub rotational: [Vec3; 3],
    /// Translational gradient, one world vector per colour channel.
    pub translational: [Vec3; 3],
    /// The pixel whose camera path placed it.
    pub pixel: (u32, u32),
}

impl IrradianceRecord {
    /// The radius clamped to the pixel bounds, before the accuracy.
    fn clamped_radius(&self) -> f32 {
        self.radius.clamp(self.bounds.0, self.bounds.1)
    }
}

/// What building a cache counted.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IrradianceCacheStats {
    pub records: usize,
    /// Rays the gathers traced (closest-hit and shadow).
    pub gather_rays: u64,
    /// Rays the overture's camera paths traced to find where records are needed.
    pub overture_rays: u64,
    /// Bytes the records and their index hold.
    pub bytes: usize,
    /// Seconds spent building.
    pub seconds: f64,
}

/// A multiplicative hash for the grids' integer keys (the standard SipHash costs more than a
/// lookup's arithmetic, and the keys are not adversarial).
#[derive(Default)]
struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_i32(&mut self, i: i32) {
        self.write_u64(i as u32 as u64);
    }
    fn write_u64(&mut self, i: u64) {
        self.0 = (self.0.rotate_left(5) ^ i).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
}

type Cells = HashMap<[i32; 4], Vec<u32>, BuildHasherDefault<CellHasher>>;

/// Records by validity radius: a record of radius r lives at level ℓ = ⌈log₂ 2r⌉, listed in
/// every cell of side 2^ℓ ≥ 2r that its sphere's bounding box overlaps (one to eight). A
/// point within r of the record is in one of those cells, so a lookup reads one cell per
/// level.
#[derive(Default)]
struct LevelGrid {
    cells: Cells,
    /// Levels present, and the records at each.
    levels: Vec<(i32, Vec<u32>)>,
}

impl LevelGrid {
    fn level_of(radius: f32) -> i32 {
        (2.0 * radius).max(f32::MIN_POSITIVE).log2().ceil() as i32
    }

    /// The cell of side `size` (a power of two) holding p: p times the exact reciprocal,
    /// the same bits in the kernel's twin.
    fn cell_of(p: Vec3, size: f32) -> [i32; 3] {
        let c = (p * (1.0 / size)).floor();
        [c.x as i32, c.y as i32, c.z as i32]
    }

    fn insert(&mut self, index: u32, p: Vec3, radius: f32) {
        let level = Self::level_of(radius);
        let size = (level as f32).exp2();
        let lo = Self::cell_of(p - Vec3::splat(radius), size);
        let hi = Self::cell_of(p + Vec3::splat(radius), size);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    self.cells.entry([level, x, y, z]).or_default().push(index);
                }
            }
        }
        match self.levels.iter_mut().find(|(l, _)| *l == level) {
            Some((_, records)) => records.push(index),
            None => self.levels.push((level, vec![index])),
        }
    }

    /// Calls `f` with every record whose validity sphere may contain `p`, each once.
    fn for_each_near(&self, p: Vec3, mut f: impl FnMut(u32)) {
        for &(level, _) in &self.levels {
            let [x, y, z] = Self::cell_of(p, (level as f32).exp2());
            if let Some(records) = self.cells.get(&[level, x, y, z]) {
                records.iter().for_each(|&i| f(i));
            }
        }
    }

    /// Calls `f` with every record whose validity sphere may overlap the sphere (p, r),
    /// perhaps more than once: the cells its bounding box overlaps, or a level's whole list
    /// where that is fewer.
    fn for_each_overlapping(&self, p: Vec3, r: f32, mut f: impl FnMut(u32)) {
        for (level, records) in &self.levels {
            let size = (*level as f32).exp2();
            let lo = Self::cell_of(p - Vec3::splat(r), size);
            let hi = Self::cell_of(p + Vec3::splat(r), size);
            let cells: u64 = (0..3).map(|a| (hi[a] - lo[a] + 1) as u64).product();
            if cells as usize > records.len() {
                records.iter().for_each(|&i| f(i));
                continue;
            }
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    for x in lo[0]..=hi[0] {
                        if let Some(records) = self.cells.get(&[*level, x, y, z]) {
                            records.iter().for_each(|&i| f(i));
                        }
                    }
                }
            }
        }
    }
}

/// The hash of a grid cell's key (level, x, y, z) in the kernel's table of cells; the WGSL
/// twin `ic_cell_hash` computes the same bits.
pub fn cell_hash(key: [i32; 4]) -> u32 {
    let mut h = (key[0] as u32).wrapping_mul(0x9e37_79b1);
    h = (h ^ (key[1] as u32).wrapping_mul(0x85eb_ca77)).rotate_left(13);
    h = (h ^ (key[2] as u32).wrapping_mul(0xc2b2_ae3d)).rotate_left(13);
    h ^= (key[3] as u32).wrapping_mul(0x27d4_eb2f);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^ (h >> 12)
}

/// A cache as the kernel reads it (`shaders/irradiance_cache.wgsl`): the records, an
/// open-addressing hash table of the grid's cells (at most half full, linear probing), and
/// the levels then each cell's record indices, in the host's order, so that the kernel sums
/// the same records in the same order.
pub struct IrradianceCacheTables {
    pub records: Vec<crate::scene::layout::IrradianceRecordGpu>,
    pub cells: Vec<crate::scene::layout::IrradianceCell>,
    pub indices: Vec<u32>,
    /// `FrameParams::ic_normal_scale`.
    pub normal_scale: f32,
    pub gradients: bool,
}

/// A render's irradiance cache.
pub struct IrradianceCache {
    records: Vec<IrradianceRecord>,
    grid: LevelGrid,
    settings: IrradianceCacheSettings,
    /// 1 − cos 10°, under its square root: the normal term's unit.
    normal_unit: f32,
    pub stats: IrradianceCacheStats,
}

/// The path tracer's settings the gathers trace with, on either backend: the render's
/// depth and roulette, no splitting and no light-traced caustics (the cache refuses the
/// first and turns the second off: its gathers see the caustics).
pub fn gather_settings(settings: &crate::RenderSettings) -> IntegratorSettings {
    IntegratorSettings {
        max_depth: settings.max_depth.unwrap_or(u32::MAX),
        rr_min_depth: settings.rr_min_depth,
        ..IntegratorSettings::default()
    }
}

/// What building a cache reads.
pub struct IrradianceCacheContext<'a> {
    pub scene: &'a FlatScene,
    pub camera: &'a Camera,
    /// The path tracer's settings: the gathers' paths are its paths.
    pub integrator: &'a IntegratorSettings,
    pub settings: IrradianceCacheSettings,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
}

/// A pixel's first Lambertian vertex as a device's pass finds it
/// ([`IrradianceCache::build_on_device`]).
pub struct DeviceVertex {
    pub p: Vec3,
    /// The shading frame (z the normal on the side the camera path arrived from).
    pub frame: Frame,
    /// One pixel's footprint there.
    pub footprint: f32,
}

/// What a device's first-vertex pass reports for one pixel: its vertex, if it has one, and
/// the rays its overture path traced.
pub struct DeviceFirstVertex {
    pub found: Option<DeviceVertex>,
    pub rays: u32,
}

/// One gather ray as a device traced it: its radiance (finite: a poisoned path reports
/// none), its first hit's distance (infinite where it left the scene or was not traced) and
/// the rays its path traced.
pub struct DeviceGatherRay {
    pub radiance: Vec3,
    pub distance: f32,
    pub rays: u32,
}

/// A record a phase of [`IrradianceCache::build_on_device`] is gathering.
struct PendingRecord<'v> {
    pixel: (u32, u32),
    vertex: &'v DeviceVertex,
    gather: RecordGather,
}

/// The passes a device runs for [`IrradianceCache::build_on_device`].
pub trait GatherDevice {
    /// Every pixel's first Lambertian vertex, row after row, as `first_lambertian_vertex`
    /// finds it (the same numbers).
    fn first_vertices(&mut self) -> crate::Result<Vec<DeviceFirstVertex>>;
    /// Round `round` of the gathers of the records that pixels `pixel_indices` (y · width + x)
    /// place: M × 3M rays per record ([`gather_strata`]), record after record and stratum
    /// (j · 3M + k) after stratum, with the numbers `compute_record` draws.
    fn gather_round(&mut self, pixel_indices: &[u32], round: u32) -> crate::Result<Vec<DeviceGatherRay>>;
}

/// Where a camera path meets its first Lambertian lobe.
#[derive(Clone, Copy)]
struct CacheVertex {
    si: SurfaceInteraction,
    footprint: f32,
}

impl IrradianceCache {
    /// An empty cache (every lookup misses).
    pub fn empty(settings: IrradianceCacheSettings) -> IrradianceCache {
        IrradianceCache {
            records: Vec::new(),
            grid: LevelGrid::default(),
            settings,
            normal_unit: (1.0 - MAX_NORMAL_DEVIATION_DEGREES.to_radians().cos()).sqrt(),
            stats: IrradianceCacheStats::default(),
        }
    }

    /// The records, in the order they were placed.
    pub fn records(&self) -> &[IrradianceRecord] {
        &self.records
    }

    /// Places the records for a camera (the module's overture).
    pub fn build(ctx: &IrradianceCacheContext) -> IrradianceCache {
        let start = std::time::Instant::now();
        let mut cache = IrradianceCache::empty(ctx.settings);
        for pixels in overture_phases(ctx.width, ctx.height) {
            cache.place_phase(ctx, &pixels);
        }
        cache.finish_stats(start);
        cache
    }

    /// Places the records for a camera with a device's passes (the GPU backend's): the
    /// device finds every pixel's first Lambertian vertex in one pass and traces each
    /// phase's gather rounds, one ray per invocation; the host runs the overture's phases
    /// as [`Self::build`] does — which pixels need a record (a lookup in the records so far),
    /// each record's reduction of its rays ([`RecordGather`]: the same sums in the same
    /// order), the neighbour clamping and the grid. Those are a few operations per ray or
    /// record against a path per ray, and the phases must see each other's records in
    /// order, so they stay on the host. With the same numbers the records are the CPU
    /// backend's up to the devices' rounding.
    pub fn build_on_device(
        ctx: &IrradianceCacheContext,
        device: &mut dyn GatherDevice,
    ) -> crate::Result<IrradianceCache> {
        let start = std::time::Instant::now();
        let mut cache = IrradianceCache::empty(ctx.settings);
        let vertices = device.first_vertices()?;
        cache.stats.overture_rays = vertices.iter().map(|v| v.rays as u64).sum();
        for pixels in overture_phases(ctx.width, ctx.height) {
            // The phase's pixels whose vertex no record covers yet, each with its gather, in
            // pixel order (the lookups and, below, the reductions run on the host's cores).
            let cache_so_far = &cache;
            let mut gathering: Vec<PendingRecord> = pixels
                .par_iter()
                .filter_map(|&(x, y)| {
                    let vertex = vertices[(y * ctx.width + x) as usize].found.as_ref()?;
                    cache_so_far.irradiance(vertex.p, vertex.frame.z).is_none().then(|| PendingRecord {
                        pixel: (x, y),
                        vertex,
                        gather: RecordGather::new(ctx.settings),
                    })
                })
                .collect();
            let mut done = Vec::with_capacity(gathering.len());
            // Every record still gathering is at the same round.
            let mut round = 0;
            while !gathering.is_empty() {
                let pixel_indices: Vec<u32> =
                    gathering.iter().map(|r| r.pixel.1 * ctx.width + r.pixel.0).collect();
                let results = device.gather_round(&pixel_indices, round)?;
                cache.stats.gather_rays += results.iter().map(|r| r.rays as u64).sum::<u64>();
                let count = gathering[0].gather.count();
                let again: Vec<bool> = gathering
                    .par_iter_mut()
                    .zip(results.par_chunks(count as usize))
                    .zip(pixel_indices.par_iter())
                    .map(|((record, rays), &pixel_index)| {
                        let gather = &mut record.gather;
                        gather.begin_round();
                        for (stratum, r) in (0..count).zip(rays) {
                            let u = gather_sampler(pixel_index, round, stratum, count, ctx.seed).next_2d();
                            // A ray the device did not trace (below the surface) reports no
                            // light and no hit: adding it changes no sum, as the CPU's
                            // skipping it.
                            gather.add(stratum, gather.direction(stratum, u), r.radiance, r.distance);
                        }
                        gather.end_round()
                    })
                    .collect();
                let (still, finished): (Vec<_>, Vec<_>) =
                    gathering.into_iter().zip(again).partition(|(_, a)| *a);
                gathering = still.into_iter().map(|(r, _)| r).collect();
                done.extend(finished.into_iter().map(|(r, _)| r));
                round += 1;
            }
            // In the phase's order, row by row, as the CPU adds them (neighbour clamping
            // depends on it).
            done.sort_by_key(|r| (r.pixel.1, r.pixel.0));
            for PendingRecord { pixel, vertex, gather } in done {
                cache.add(gather.record(ctx, vertex.p, &vertex.frame, vertex.footprint, pixel));
            }
        }
        cache.finish_stats(start);
        Ok(cache)
    }

    fn finish_stats(&mut self, start: std::time::Instant) {
        self.stats.records = self.records.len();
        self.stats.bytes = self.memory_bytes();
        self.stats.seconds = start.elapsed().as_secs_f64();
    }

    /// The cache in the kernel's form ([`IrradianceCacheTables`]).
    pub fn gpu_tables(&self) -> IrradianceCacheTables {
        use crate::scene::layout::{IrradianceCell, IrradianceRecordGpu};
        let a = self.settings.accuracy;
        let records = self
            .records
            .iter()
            .map(|r| IrradianceRecordGpu {
                p: r.p.to_array(),
                radius: a * r.clamped_radius(),
                n: r.n.to_array(),
                e: r.e.to_array(),
                rotational: r.rotational.map(|g| g.extend(0.0).to_array()),
                translational: r.translational.map(|g| g.extend(0.0).to_array()),
                ..IrradianceRecordGpu::default()
            })
            .collect();
        let mut indices = vec![self.grid.levels.len() as u32];
        indices.extend(self.grid.levels.iter().map(|(level, _)| *level as u32));
        let slots = (2 * self.grid.cells.len()).max(1).next_power_of_two();
        let mut cells = vec![IrradianceCell::default(); slots];
        // In key order, so that the table does not depend on the hash map's iteration order.
        let mut keys: Vec<&[i32; 4]> = self.grid.cells.keys().collect();
        keys.sort();
        for key in keys {
            let list = &self.grid.cells[key];
            let mut slot = cell_hash(*key) as usize & (slots - 1);
            while cells[slot].count != 0 {
                slot = (slot + 1) & (slots - 1);
            }
            cells[slot] = IrradianceCell {
                key: *key,
                start: indices.len() as u32,
                count: list.len() as u32,
                ..IrradianceCell::default()
            };
            indices.extend(list);
        }
        IrradianceCacheTables {
            records,
            cells,
            indices,
            normal_scale: a * self.normal_unit,
            gradients: self.settings.gradients,
        }
    }

    /// Bytes held: the records, and the grid's cells (key, list header, indices) and
    /// per-level lists.
    fn memory_bytes(&self) -> usize {
        let cell = std::mem::size_of::<[i32; 4]>() + std::mem::size_of::<Vec<u32>>();
        self.records.capacity() * std::mem::size_of::<IrradianceRecord>()
            + self.grid.cells.values().map(|v| cell + 4 * v.capacity()).sum::<usize>()
            + self.grid.levels.iter().map(|(_, v)| 4 * v.capacity()).sum::<usize>()
    }

    /// One phase of the overture: the pixels' first Lambertian vertices, a record computed
    /// wherever none is valid, the new records added in pixel order.
    fn place_phase(&mut self, ctx: &IrradianceCacheContext, pixels: &[(u32, u32)]) {
        type Placed = (Option<IrradianceRecord>, u64, u64);
        let placed: Vec<Placed> = pixels
            .par_iter()
            .map(|&(x, y)| {
                let mut overture_rays = 0;
                let Some(v) = first_lambertian_vertex(ctx, x, y, &mut overture_rays) else {
                    return (None, overture_rays, 0);
                };
                if self.irradiance(v.si.p, v.si.frame.z).is_some() {
                    return (None, overture_rays, 0);
                }
                let mut gather_rays = 0;
                let record = compute_record(ctx, &v, (x, y), &mut gather_rays);
                (Some(record), overture_rays, gather_rays)
            })
            .collect();
        for (record, overture_rays, gather_rays) in placed {
            self.stats.overture_rays += overture_rays;
            self.stats.gather_rays += gather_rays;
            if let Some(record) = record {
                self.add(record);
            }
        }
    }

    /// Adds a record after clamping its radius and its neighbours' (Křivánek et al. 2006,
    /// neighbour clamping: R_i ≤ R_j + ‖p_i − p_j‖ for every record j whose validity sphere
    /// overlaps its own, and the same for j).
    fn add(&mut self, mut record: IrradianceRecord) {
        let a = self.settings.accuracy;
        let r_new = a * record.clamped_radius();
        let mut neighbours = Vec::new();
        self.grid.for_each_overlapping(record.p, r_new, |j| neighbours.push(j));
        for j in neighbours {
            let other = &mut self.records[j as usize];
            let d = other.p.distance(record.p);
            if d >= r_new + a * other.clamped_radius() {
                continue;
            }
            record.radius = record.radius.min(other.radius + d);
            other.radius = other.radius.min(record.radius + d);
        }
        let index = self.records.len() as u32;
        self.grid.insert(index, record.p, FALLBACK_REACH * a * record.clamped_radius());
        self.records.push(record);
    }

    /// The interpolated irradiance at p (normal n, unit), or `None` where no record is
    /// valid: the overture's test of whether p needs a record.
    pub fn irradiance(&self, p: Vec3, n: Vec3) -> Option<Vec3> {
        let [(sum, weights), _] = self.interpolate(p, n);
        (weights > 0.0).then(|| (sum / weights).max(Vec3::ZERO))
    }

    /// The irradiance a camera sample reads at p (normal n, unit): the interpolation of the
    /// records valid there; where none is (a sample's path through glass, or a point a
    /// pixel's width from where the overture's path landed when the accuracy makes records
    /// smaller than a pixel), the records within [`FALLBACK_REACH`] times their validity
    /// radius, weighted by FALLBACK_REACH − ε. `None` only where even those are absent: the
    /// point is then path traced.
    pub fn lookup(&self, p: Vec3, n: Vec3) -> Option<Vec3> {
        let [(sum, weights), (near_sum, near_weights)] = self.interpolate(p, n);
        if weights > 0.0 {
            Some((sum / weights).max(Vec3::ZERO))
        } else {
            (near_weights > 0.0).then(|| (near_sum / near_weights).max(Vec3::ZERO))
        }
    }

    /// The weighted sums and weights of the records valid at (p, n), and of those within
    /// the fallback reach.
    fn interpolate(&self, p: Vec3, n: Vec3) -> [(Vec3, f32); 2] {
        let a = self.settings.accuracy;
        let mut valid = (Vec3::ZERO, 0.0f32);
        let mut near = (Vec3::ZERO, 0.0f32);
        self.grid.for_each_near(p, |i| {
            let r = &self.records[i as usize];
            let radius = a * r.clamped_radius();
            let offset = p - r.p;
            let d = offset.length();
            if d >= FALLBACK_REACH * radius {
                return;
            }
            // Ward's test: a point in front of the record's surface (a crease's other side)
            // does not see what the record saw.
            if offset.dot(n + r.n) * 0.5 < -0.05 * radius {
                return;
            }
            let normal_term = (1.0 - n.dot(r.n)).max(0.0).sqrt() / (a * self.normal_unit);
            let epsilon = (d / radius).max(normal_term);
            if epsilon >= FALLBACK_REACH {
                return;
            }
            let mut e = r.e;
            if self.settings.gradients {
                let turn = r.n.cross(n);
                for c in 0..3 {
                    e[c] += turn.dot(r.rotational[c]) + offset.dot(r.translational[c]);
                }
            }
            if epsilon < 1.0 {
                let w = 1.0 - epsilon;
                valid.0 += w * e;
                valid.1 += w;
            } else if valid.1 == 0.0 {
                let w = FALLBACK_REACH - epsilon;
                near.0 += w * e;
                near.1 += w;
            }
        });
        [valid, near]
    }
}

/// The overture's phases, in order: the pixels on grids of halving stride, coarsest first
/// (its whole grid), then each finer level in three phases, the pixels one stride apart
/// within cells of two strides (offsets (1, 0), (0, 1), (1, 1)). Every pixel is in one phase.
fn overture_phases(width: u32, height: u32) -> Vec<Vec<(u32, u32)>> {
    let coarsest = COARSEST_STRIDE.min(width.max(height).next_power_of_two());
    let mut phases = Vec::new();
    let mut stride = coarsest;
    loop {
        let offsets: &[(u32, u32)] = if stride == coarsest { &[(0, 0)] } else { &[(1, 0), (0, 1), (1, 1)] };
        let step = if stride == coarsest { stride } else { 2 * stride };
        for &(ox, oy) in offsets {
            phases.push(
                (oy * stride..height)
                    .step_by(step as usize)
                    .flat_map(|y| (ox * stride..width).step_by(step as usize).map(move |x| (x, y)))
                    .collect(),
            );
        }
        if stride == 1 {
            break;
        }
        stride /= 2;
    }
    phases
}

/// The first vertex with a Lambertian lobe of pixel (x, y)'s overture camera path (through
/// delta bounces only; `None` where the path leaves, meets a glossy-only surface first, or
/// ends).
fn first_lambertian_vertex(
    ctx: &IrradianceCacheContext,
    x: u32,
    y: u32,
    rays: &mut u64,
) -> Option<CacheVertex> {
    let scene = ctx.scene;
    let mut sampler = PathSampler::new(SamplerKind::Independent, x, y, 0, ctx.seed ^ OVERTURE_SALT);
    let mut ray = generate_camera_ray(ctx.camera, ctx.width, ctx.height, x, y, sampler.next_2d());
    let pixel_cone = camera_ray_cone(ctx.camera, ctx.height, 1);
    let mut travelled = 0.0;
    for _ in 0..=MAX_DELTA_CHAIN {
        *rays += 1;
        let alpha_seed = if scene.features.alpha { sampler.next_u32() } else { 0 };
        let hit = scene.intersect_closest(&ray, alpha_seed)?;
        let si = surface_interaction(scene, &ray, &hit, pixel_cone.width_at(travelled + hit.hit.t));
        travelled += si.distance;
        let material = vertex_material(scene, &si);
        let bsdf = GltfBsdf::new(&material, si.wo, si.front_face, si.coat_normal);
        if bsdf.has_lambert_lobe() {
            return Some(CacheVertex { si, footprint: pixel_cone.width_at(travelled) });
        }
        let u_lobe = sampler.next_1d();
        let bs = bsdf.sample(si.wo, u_lobe, sampler.next_2d())?;
        if !bs.is_delta {
            return None;
        }
        let wi = si.frame.from_local(bs.wi).normalize();
        if !sides_agree(&si, wi, bs.wi) {
            return None;
        }
        ray = spawn_ray(si.p, si.p_error, si.n_geometric, wi);
    }
    None
}

/// A record at `v`: the stratified gather, its irradiance, harmonic mean distance and
/// gradients (Ward & Heckbert 1992, as Křivánek et al. 2009 write them, eq. 2.12 and 2.14).
fn compute_record(
    ctx: &IrradianceCacheContext,
    v: &CacheVertex,
    pixel: (u32, u32),
    rays: &mut u64,
) -> IrradianceRecord {
    let si = &v.si;
    let pixel_index = pixel.1 * ctx.width + pixel.0;
    let cone = RayCone { width: v.footprint, spread: 0.0 };
    let mut gather = RecordGather::new(ctx.settings);
    loop {
        gather.begin_round();
        for stratum in 0..gather.count() {
            let mut sampler = gather_sampler(pixel_index, gather.rounds, stratum, gather.count(), ctx.seed);
            let local = gather.direction(stratum, sampler.next_2d());
            let world = si.frame.from_local(local).normalize();
            if !sides_agree(si, world, local) {
                continue;
            }
            let ray = spawn_ray(si.p, si.p_error, si.n_geometric, world);
            let (l, d) = indirect_radiance(ctx.scene, ctx.integrator, ray, cone, &mut sampler, rays);
            // A poisoned path (non-finite throughput) counts as no light, as the film
            // rejects it.
            gather.add(stratum, local, if l.is_finite() { l } else { Vec3::ZERO }, d);
        }
        if !gather.end_round() {
            break;
        }
    }
    gather.record(ctx, si.p, &si.frame, v.footprint, pixel)
}

/// The numbers of gather ray `stratum` of round `round` of the record placed by pixel
/// `pixel_index`: `Rng::new(pixel, IC_STREAM, round · strata + stratum, seed)`, the first
/// pair choosing the direction within the stratum (WGSL twin: `ic_gather_start`).
fn gather_sampler(pixel_index: u32, round: u32, stratum: u32, strata: u32, seed: u32) -> PathSampler {
    PathSampler::Independent(Rng::new(pixel_index, IC_STREAM, round * strata + stratum, seed))
}

/// One record's gather as its rounds come in, on either backend: the stratified sums of
/// Ward & Heckbert (irradiance, harmonic mean distance, rotational and translational
/// gradients) and the estimate's error, which decides whether another round is traced.
struct RecordGather {
    /// Polar and azimuthal strata (M, 3M).
    m: u32,
    n: u32,
    /// Rounds added so far.
    rounds: u32,
    /// Another round while the relative standard error is above this.
    target: f32,
    /// Per stratum (j, k), j polar and k azimuthal: radiance and first-hit distance of the
    /// round in hand.
    radiance: Vec<Vec3>,
    distance: Vec<f32>,
    rotational: [Vec3; 3],
    translational: [Vec3; 3],
    inverse_distances: f64,
    sum: Vec3,
    /// Σ L² in luminance over every ray, for the estimate's standard error.
    sum_squares: f64,
}

impl RecordGather {
    fn new(settings: IrradianceCacheSettings) -> RecordGather {
        let (m, n) = gather_strata(settings.gather_rays);
        RecordGather {
            m,
            n,
            rounds: 0,
            target: GATHER_RELATIVE_ERROR * settings.accuracy,
            radiance: vec![Vec3::ZERO; (m * n) as usize],
            distance: vec![f32::INFINITY; (m * n) as usize],
            rotational: [Vec3::ZERO; 3],
            translational: [Vec3::ZERO; 3],
            inverse_distances: 0.0,
            sum: Vec3::ZERO,
            sum_squares: 0.0,
        }
    }

    /// Rays per round, M × 3M.
    fn count(&self) -> u32 {
        self.m * self.n
    }

    /// Stratum (j, k)'s direction in the record's shading frame for the pair `u`:
    /// θ_j = asin √((j + u.x)/M), φ_k = 2π(k + u.y)/3M (cosine-distributed strata).
    fn direction(&self, stratum: u32, u: Vec2) -> Vec3 {
        let (j, k) = (stratum / self.n, stratum % self.n);
        let sin2 = (j as f32 + u.x) / self.m as f32;
        let (sin_theta, cos_theta) = (sin2.sqrt(), (1.0 - sin2).max(0.0).sqrt());
        let phi = std::f32::consts::TAU * (k as f32 + u.y) / self.n as f32;
        let (sin_phi, cos_phi) = phi.sin_cos();
        Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta)
    }

    /// Starts a round: every stratum without light and without a hit until added.
    fn begin_round(&mut self) {
        self.radiance.fill(Vec3::ZERO);
        self.distance.fill(f32::INFINITY);
    }

    /// Stratum `stratum`'s ray of this round: direction `local`, radiance `l` (finite),
    /// first-hit distance `d` (infinite where it left the scene). A stratum whose
    /// direction is below the geometric surface is not added.
    fn add(&mut self, stratum: u32, local: Vec3, l: Vec3, d: f32) {
        self.radiance[stratum as usize] = l;
        self.distance[stratum as usize] = d;
        self.sum += l;
        self.sum_squares += (l.dot(LUMINANCE) as f64).powi(2);
        if d.is_finite() && d > 0.0 {
            self.inverse_distances += 1.0 / d as f64;
        }
        rotational_add(&mut self.rotational, local, l);
    }

    /// Ends a round; true where another is wanted: the estimate's relative standard error
    /// (the strata taken as independent samples; stratification only lowers it) is above
    /// the target and fewer than [`MAX_GATHER_ROUNDS`] were traced.
    fn end_round(&mut self) -> bool {
        let round = translational_gradient(&self.radiance, &self.distance, self.m, self.n);
        for (total, g) in self.translational.iter_mut().zip(round) {
            *total += g;
        }
        self.rounds += 1;
        let samples = (self.rounds * self.count()) as f64;
        let mean = self.sum.dot(LUMINANCE) as f64 / samples;
        let variance = (self.sum_squares / samples - mean * mean).max(0.0) / samples;
        let converged = mean <= 0.0 || variance.sqrt() <= self.target as f64 * mean;
        !converged && self.rounds < MAX_GATHER_ROUNDS
    }

    /// The record at point `p` with shading frame `frame` and pixel footprint `footprint`.
    fn record(
        mut self,
        ctx: &IrradianceCacheContext,
        p: Vec3,
        frame: &Frame,
        footprint: f32,
        pixel: (u32, u32),
    ) -> IrradianceRecord {
        let samples = (self.rounds * self.count()) as f32;
        let e = self.sum * (std::f32::consts::PI / samples);
        for g in &mut self.rotational {
            *g *= std::f32::consts::PI / samples;
        }
        for g in &mut self.translational {
            *g /= self.rounds as f32;
        }
        let harmonic = if self.inverse_distances > 0.0 {
            (samples as f64 / self.inverse_distances) as f32
        } else {
            f32::INFINITY
        };
        // The gradient limit: E changes by no more than itself across the radius.
        let e_lum = e.dot(LUMINANCE);
        let translational = self.translational;
        let grad_lum = (translational[0] * LUMINANCE.x
            + translational[1] * LUMINANCE.y
            + translational[2] * LUMINANCE.z)
            .length();
        let gradient_limit = if grad_lum > 0.0 && e_lum > 0.0 { e_lum / grad_lum } else { f32::INFINITY };
        let to_world = |g: Vec3| frame.from_local(g);
        let footprint = footprint.max(ctx.scene.scene_radius * 1e-6);
        let mut record = IrradianceRecord {
            p,
            n: frame.z,
            e,
            radius: harmonic.min(gradient_limit),
            bounds: (
                MIN_SPACING_PIXELS * footprint,
                (MAX_SPACING_FRACTION * ctx.height as f32).max(MIN_SPACING_PIXELS) * footprint,
            ),
            rotational: self.rotational.map(to_world),
            translational: translational.map(to_world),
            pixel,
        };
        // The pixel clamp can raise the radius past the gradient limit (a record in a corner,
        // whose gather rays' short hits make its gradient large and noisy): the gradient is then
        // scaled down so that across the radius it still changes E by at most E. Neighbour
        // clamping only shrinks the radius later, so the bound holds at every lookup.
        let clamped = record.clamped_radius();
        if clamped > gradient_limit {
            let scale = gradient_limit / clamped;
            for g in &mut record.translational {
                *g *= scale;
            }
        }
        // Likewise the rotational gradient across the normals a record serves (|n_i × n| up to
        // sin 10° at accuracy 1): its tan θ weights make one grazing gather ray dominate it.
        let turn_limit = MAX_NORMAL_DEVIATION_DEGREES.to_radians().sin();
        let rot_lum = (record.rotational[0] * LUMINANCE.x
            + record.rotational[1] * LUMINANCE.y
            + record.rotational[2] * LUMINANCE.z)
            .length();
        if rot_lum * turn_limit > e_lum {
            let scale = if rot_lum > 0.0 { e_lum / (rot_lum * turn_limit) } else { 0.0 };
            for g in &mut record.rotational {
                *g *= scale;
            }
        }
        record
    }
}

/// Adds one gather sample (local direction ω, radiance L) to the rotational gradient
/// (Ward & Heckbert 1992; Křivánek et al. 2009, eq. 2.12), to be scaled by π/(MN). Tilting
/// the normal by a small angle β about a tangent axis a changes ω's cosine by β (a × z)·ω,
/// so with cosine-distributed samples ∂E/∂β = π/(MN) Σ L (a × z)·ω / cos θ; as a vector
/// over axes that is π/(MN) Σ L tan θ v, with v = (−sin φ, cos φ, 0) ⟂ the sample's azimuth,
/// and the interpolation reads it as (n_i × n)·∇_r E. (Written with −tan θ, as some
/// statements of the formula have it, the tilt's sign is reversed: the unit test below.)
fn rotational_add(gradient: &mut [Vec3; 3], local: Vec3, l: Vec3) {
    let v = Vec3::new(-local.y, local.x, 0.0) / local.z.max(1e-4);
    for c in 0..3 {
        gradient[c] += v * l[c];
    }
}

/// The translational gradient (Ward & Heckbert 1992; Křivánek et al. 2009, eq. 2.14) in the
/// record's local frame, per colour channel: for each azimuthal stratum k, the change across
/// the walls between polar strata (along u_k, the stratum's azimuth) and across the wall
/// between azimuthal strata k − 1 and k (along v_k−, perpendicular to it), each wall moving
/// as the nearer of its two strata's hits seen from a displaced point, and each weighted by
/// the projected solid angle it sweeps (cosine-distributed strata carry equal irradiance).
fn translational_gradient(radiance: &[Vec3], distance: &[f32], m: u32, n: u32) -> [Vec3; 3] {
    let at = |j: u32, k: u32| (j * n + k) as usize;
    let theta_minus = |j: u32| (j as f32 / m as f32).sqrt().asin();
    let mut gradient = [Vec3::ZERO; 3];
    for k in 0..n {
        let phi_center = std::f32::consts::TAU * (k as f32 + 0.5) / n as f32;
        let u_k = Vec3::new(phi_center.cos(), phi_center.sin(), 0.0);
        let phi_wall = std::f32::consts::TAU * k as f32 / n as f32;
        let v_k = Vec3::new(-phi_wall.sin(), phi_wall.cos(), 0.0);
        let k_prev = (k + n - 1) % n;
        for j in 0..m {
            // Across the wall between polar strata j − 1 and j.
            if j > 0 {
                let d = distance[at(j, k)].min(distance[at(j - 1, k)]);
                if d.is_finite() && d > 0.0 {
                    let t = theta_minus(j);
                    let factor = std::f32::consts::TAU / n as f32 * t.sin() * t.cos() * t.cos() / d;
                    let delta = radiance[at(j, k)] - radiance[at(j - 1, k)];
                    for c in 0..3 {
                        gradient[c] += u_k * (factor * delta[c]);
                    }
                }
            }
            // Across the wall between azimuthal strata k − 1 and k: the wall turns by
            // δ/(d sin θ) per unit of motion δ, sweeping the projected solid angle
            // ∫ cos θ sin θ dθ = (sin² θ_j+ − sin² θ_j−)/2 = 1/(2M) of the stratum per
            // radian. (Written with ∫ sin θ dθ = cos θ_j− − cos θ_j+, the solid angle, the
            // term overstates a ramp's gradient by half again: the unit test below.)
            let d = distance[at(j, k)].min(distance[at(j, k_prev)]);
            if d.is_finite() && d > 0.0 {
                let t_center = ((j as f32 + 0.5) / m as f32).sqrt().asin();
                let factor = 1.0 / (2.0 * m as f32 * t_center.sin() * d);
                let delta = radiance[at(j, k)] - radiance[at(j, k_prev)];
                for c in 0..3 {
                    gradient[c] += v_k * (factor * delta[c]);
                }
            }
        }
    }
    gradient
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_overture_visits_every_pixel_once() {
        for (w, h) in [(1, 1), (7, 3), (64, 64), (100, 37)] {
            let mut seen = vec![0; (w * h) as usize];
            for phase in overture_phases(w, h) {
                for (x, y) in phase {
                    seen[(y * w + x) as usize] += 1;
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "{w}×{h}: {seen:?}");
        }
    }

    #[test]
    fn gather_strata_are_m_by_3m() {
        assert_eq!(gather_strata(768), (16, 48));
        assert_eq!(gather_strata(12), (2, 6));
        assert_eq!(gather_strata(1), (2, 6));
        assert_eq!(gather_strata(3000), (32, 96));
    }

    #[test]
    fn the_level_grid_finds_every_record_whose_sphere_holds_a_point() {
        // Records of many radii; every point within a record's radius must be offered it.
        let mut grid = LevelGrid::default();
        let mut rng = Rng::new(1, 2, 3, 4);
        let mut records = Vec::new();
        for i in 0..300u32 {
            let p = Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 10.0 - 5.0;
            let r = 0.01 * (1.0 + 400.0 * rng.next_1d() * rng.next_1d());
            grid.insert(i, p, r);
            records.push((p, r));
        }
        for _ in 0..2000 {
            let q = Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 12.0 - 6.0;
            let mut offered = vec![0; records.len()];
            grid.for_each_near(q, |i| offered[i as usize] += 1);
            let mut overlapping = vec![false; records.len()];
            grid.for_each_overlapping(q, 0.3, |i| overlapping[i as usize] = true);
            for (i, &(p, r)) in records.iter().enumerate() {
                if p.distance(q) < r {
                    assert_eq!(offered[i], 1, "record {i} at {p} radius {r} not offered once at {q}");
                }
                if p.distance(q) < r + 0.3 {
                    assert!(overlapping[i], "record {i} overlapping {q} not offered");
                }
            }
        }
    }

    /// A distant radiance field L(ω) = 1 + 0.2 ω_x ω_z (it fades at the horizon, where the
    /// estimator's tan θ weights would make a finite gather's estimate heavy-tailed):
    /// tilting the normal from z towards x by β raises the irradiance by
    /// 0.2 ∫ ω_x² ω_z dω · β = 0.2 π/4 · β, and the gradient must predict it.
    #[test]
    fn the_rotational_gradient_predicts_a_tilted_normals_irradiance() {
        let (m, n) = (16u32, 48u32);
        let mut gradient = [Vec3::ZERO; 3];
        for j in 0..m {
            for k in 0..n {
                let sin2 = (j as f32 + 0.5) / m as f32;
                let (s, c) = (sin2.sqrt(), (1.0 - sin2).sqrt());
                let phi = std::f32::consts::TAU * (k as f32 + 0.5) / n as f32;
                let local = Vec3::new(s * phi.cos(), s * phi.sin(), c);
                rotational_add(&mut gradient, local, Vec3::splat(1.0 + 0.2 * local.x * local.z));
            }
        }
        let scale = std::f32::consts::PI / (m * n) as f32;
        let beta = 0.05f32;
        let tilted = Vec3::new(beta.sin(), 0.0, beta.cos());
        let predicted = Vec3::Z.cross(tilted).dot(gradient[0] * scale);
        let exact = 0.2 * std::f32::consts::FRAC_PI_4 * beta.sin();
        // With midpoint strata the sum is exact for this field up to rounding; the bound allows
        // 2% (a sign error would be 200%).
        assert!((predicted - exact).abs() < 0.02 * exact, "predicted {predicted}, exact {exact}");
    }

    /// A gather of a radiance field that is linear in the record's position, L(x + s ω) for
    /// hits on a plane at height h: the translational gradient must point the way the
    /// irradiance grows.
    #[test]
    fn the_translational_gradient_of_a_radiance_ramp_is_its_irradiance_slope() {
        let (m, n) = (16, 48);
        let h = 1.0;
        // Radiance on a ceiling at height h that grows along +x: L = 1 + 0.2 x.
        let mut radiance = vec![Vec3::ZERO; (m * n) as usize];
        let mut distance = vec![0.0; (m * n) as usize];
        let mut e = 0.0;
        for j in 0..m {
            for k in 0..n {
                let sin2 = (j as f32 + 0.5) / m as f32;
                let (s, c) = (sin2.sqrt(), (1.0 - sin2).sqrt());
                let phi = std::f32::consts::TAU * (k as f32 + 0.5) / n as f32;
                let t = h / c;
                let x = t * s * phi.cos();
                let l = 1.0 + 0.2 * x;
                radiance[(j * n + k) as usize] = Vec3::splat(l);
                distance[(j * n + k) as usize] = t;
                e += l;
            }
        }
        let e = e * std::f32::consts::PI / (m * n) as f32;
        let g = translational_gradient(&radiance, &distance, m, n);
        // E(x_record) = ∫ (1 + 0.2 (x_record + t sin θ cos φ)) cos θ dω = π (1 + 0.2 x_record):
        // the slope is 0.2 π. The strata's midpoints leave it 0.5% off (measured); the bound
        // allows 2%.
        let expected = 0.2 * std::f32::consts::PI;
        assert!((g[0].x - expected).abs() < 0.02 * expected, "gradient {:?}, expected x {expected}", g[0]);
        assert!(g[0].y.abs() < 0.05 * expected && g[0].z == 0.0, "{:?}", g[0]);
        assert!(e > 0.0);
    }
}
