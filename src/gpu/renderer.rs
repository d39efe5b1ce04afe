//! The GPU backend: uploads a [`FlatScene`], accumulates samples in a GPU-resident film, and
//! reads back only when output is wanted.

use std::sync::Arc;
use std::time::{Duration, Instant};

use wgpu::util::DeviceExt;

use super::context::{GpuContext, Kernel};
use super::tables::{self, UniformTables};
use crate::error::{Error, Result};
use crate::film::Film;
use crate::integrator::aov::AOV_VARYING_SAMPLES;
use crate::integrator::bdpt::{BdptStats, BDPT_MAX_VERTICES};
use crate::integrator::{CausticSums, Integrator, CAUSTIC_SUM_WORDS};
use crate::render::{Backend, RenderSettings};
use crate::scene::layout::{FilmPixel, FirstHit, FrameParams, Light, PixelAov};
use crate::scene::FlatScene;

/// Each submit is sized to take about this long: long enough that per-submit overhead is
/// small, short enough that no desktop watchdog (typically 2 s) kills a dispatch and a
/// progress display stays live.
const TARGET_SUBMIT_SECONDS: f64 = 0.1;
/// Submits queued at once: one running while the next waits, so completions overlap work.
const MAX_IN_FLIGHT: usize = 2;
/// The most samples per pixel a band of rows gets in one submit on a device too slow for
/// the whole image: several, so that the kernel's path regeneration (`render` in
/// shaders/path.wgsl) has a next sample to start where a lane's path ends early.
const BAND_SAMPLES: u32 = 8;

/// On a software GPU, the longest one group of SIMD lanes may run in a dispatch. Lavapipe
/// (Mesa's gallivm) bounds every shader's loops with one counter per invocation group, set
/// to 65,535 (`LP_MAX_TGSI_LOOP_ITERATIONS`) when the shader starts and decremented by every
/// iteration of every loop, BVH traversal steps included; at zero each loop exits as if its
/// condition had failed. A group that runs longer silently stops: an 8 × 8 glass scene lost
/// up to 65% of 384 samples per pixel per dispatch, about 12 ms of work per group on this
/// VM, and a bidirectional path too long for the budget ends early (why same-seed BDPT parts
/// from the CPU's beyond about 35 bounces). A twelfth of that time keeps path-traced
/// dispatches inside the budget: time is only a proxy for the loop count, and with a quarter
/// (3 ms) the 8 × 8 glass scene once lost 30–60% of its samples in a dispatch far longer
/// than its measured rate predicted. Only small images come near the budget (a 32² image's
/// time-sized dispatch gives each group a few milliseconds); `tests/gpu` checks every sample
/// lands on an 8 × 8 image, and [`SOFTWARE_GPU_RETRY_SHRINK`] catches a call that did not.
const SOFTWARE_GPU_GROUP_SECONDS: f64 = 0.001;
/// Time is only a proxy for lavapipe's loop count, so on a software GPU each call of
/// [`Backend::render`] is checked: the film's per-pixel counts must have grown by exactly
/// the samples asked for. A pixel short of them means its group of lanes met the loop limit;
/// the call's samples are then taken again from the film and ray counts as they were, with
/// each group given this many times less time (`GpuBackend::software_group_seconds`). The
/// check misses only a group whose every lane was on the call's last sample when the limit
/// struck (each lane then finishes that sample with its loops cut short, and its count is
/// whole); a lane of the group short of its samples gives the others away. It covers the
/// path-tracing kernel's calls (path tracing, the photon map's final gather, the irradiance
/// cache), whose dispatches carry many samples per pixel; BDPT's and Metropolis's dispatches
/// are bounded by their own rules.
const SOFTWARE_GPU_RETRY_SHRINK: f64 = 4.0;
/// Tries of one call before a software GPU that still cuts samples short is an error.
const SOFTWARE_GPU_TRIES: u32 = 4;
/// Lavapipe's SIMD width in f32 lanes (256-bit AVX2): one group's invocations run together.
const SOFTWARE_GPU_LANES: f64 = 8.0;
/// Waiting longer than this for one submit means the GPU hung; report it rather than hang.
const SUBMIT_TIMEOUT: Duration = Duration::from_secs(120);
/// Compute workgroup edge (shaders/path.wgsl `@workgroup_size(8, 8, 1)`).
const WORKGROUP: u32 = 8;

pub struct GpuBackend {
    ctx: Arc<GpuContext>,
    kernel: Arc<Kernel>,
    bind_group: wgpu::BindGroup,
    /// The buffers of `bind_group`, binding i the i-th: the irradiance cache's (24 to 26, and
    /// its placement passes' 27 to 29) are replaced when a cache is placed, and the group made
    /// again.
    bind_buffers: Vec<wgpu::Buffer>,
    /// `FrameParams`' irradiance-cache fields: normal scale, gradients, table mask.
    ic_frame: (f32, u32, u32),
    /// The scene, kept where the settings ask for an irradiance cache: its records are
    /// placed again for each camera (`IrradianceCache::build_on_device` reads its bounds).
    ic_scene: Option<crate::scene::FlatScene>,
    /// The irradiance cache placed for the current camera (its statistics and records).
    irradiance_cache: Option<crate::integrator::irradiance_cache::IrradianceCache>,
    params: wgpu::Buffer,
    film: wgpu::Buffer,
    first_hits: wgpu::Buffer,
    /// The AOV pass's output: a `PixelAov` per pixel where `settings.aovs`, else one.
    aovs: wgpu::Buffer,
    /// The pixels the AOV pass refines (`aov_refine_list`), as many as pixels where
    /// `settings.aovs`, else one.
    aov_refine_list: wgpu::Buffer,
    /// Adaptive sampling's sample count per pixel where `settings.adaptive`, else one
    /// element, `u32::MAX` (every pixel takes every sample).
    budgets: wgpu::Buffer,
    /// The same counts sorted, on the host: how many pixels take a sample index.
    sorted_budgets: Option<Vec<u32>>,
    ray_counts: wgpu::Buffer,
    settings: RenderSettings,
    light_count: u32,
    camera: crate::scene::layout::Camera,
    camera_buffer: wgpu::Buffer,
    /// Rays counted before the per-pixel `u32` counters were last read and cleared, and the
    /// samples per pixel added since: the counters are folded into this 64-bit total before
    /// they could wrap (see [`crate::render::MAX_RAYS_PER_SAMPLE`]).
    rays_folded: u64,
    samples_since_fold: u64,
    /// Measured seconds per pixel-sample, steering submit sizes.
    seconds_per_sample: Option<f64>,
    /// An upper bound of the same, for [`Self::software_gpu_sample_cap`]: each submit's
    /// time from its submission to the host seeing it done, over its work. A submit runs
    /// within that span whatever else was queued or however late the host woke, so this
    /// never under-states the rate (the estimate above, timed from the previous submit's
    /// end as the host saw it, can: a host woken late, as on a busy machine, times the next
    /// submit short, and an 8 × 8 image then lost a third of its samples to lavapipe's
    /// loop limit).
    seconds_per_sample_bound: Option<f64>,
    /// Wall time of uploading the scene.
    pub upload_seconds: f64,
    /// The light tracer's image of one sample index (`caustics` in shaders/bindings.wgsl;
    /// one unused pixel unless the scene's caustics may be light traced).
    caustics: wgpu::Buffer,
    /// The light tracer's kernel, where the settings ask for light tracing and the scene
    /// allows it (`crate::integrator::scene_supports_light_tracing`).
    caustics_kernel: Option<Arc<wgpu::ComputePipeline>>,
    /// The sample index whose light-traced image `caustics` holds.
    caustic_pass: Option<u32>,
    /// Adaptive sampling with light-traced caustics: the render's caustic sums, kept in
    /// `caustics` after the pass's image.
    caustic_sums: Option<DeviceCausticSums>,
    /// The camera sees only delta surfaces: the light tracer's joins to it cannot
    /// contribute (`crate::integrator::delta_view`). Decided for the scene's camera; a
    /// camera set later keeps the light tracer (the backend holds no triangles to decide
    /// it again). Bidirectional path tracing skips its t = 1 joins by the same decision.
    camera_sees_only_delta: bool,
    /// On a software GPU, copies of `film` and `ray_counts` taken before each call of
    /// [`Backend::render`], to take its samples again if the device cut some short
    /// ([`SOFTWARE_GPU_RETRY_SHRINK`]); `None` on a hardware GPU.
    software_snapshot: Option<(wgpu::Buffer, wgpu::Buffer)>,
    /// The per-pixel sample budgets as last set (adaptive sampling), in pixel order: how
    /// many samples each pixel should hold after a call.
    pixel_budgets: Option<Vec<u32>>,
    /// The longest a group of lanes may run in one dispatch on a software GPU: starts at
    /// [`SOFTWARE_GPU_GROUP_SECONDS`], shrunk by every call taken again.
    software_group_seconds: f64,
    /// Samples per pixel every path-tracing dispatch takes, whatever the rate and the cap
    /// say, until a call comes back short ([`GpuBackend::force_software_dispatch_samples`]).
    forced_dispatch_samples: Option<u32>,
    /// Calls of [`Backend::render`] taken again because the device cut samples short.
    software_retries: u32,
    /// Bidirectional path tracing's per-pixel sums and truncation count (`bdpt_state` in
    /// shaders/bdpt.wgsl; one unused pixel for the path tracer).
    bdpt_state: wgpu::Buffer,
    /// The sample index whose bidirectional pass is traced into `bdpt_state` and
    /// `caustics` (its splats) but not yet wholly added to the film.
    bdpt_pass: Option<u32>,
    /// Light subpaths truncated, folded in from the device's 32-bit counter.
    bdpt_truncated: u64,
    /// The scene's bounding sphere (`FrameParams::scene_center`).
    scene_center: [f32; 3],
    scene_radius: f32,
    /// Photon mapping's buffers and passes (`--integrator sppm`), else None.
    sppm: Option<SppmState>,
    /// Metropolis's buffers and passes (`--integrator mlt`), else None.
    mlt: Option<MltState>,
}

/// Metropolis's state on the device (shaders/mlt.wgsl's bindings 27 to 31) and on the host.
struct MltState {
    plan: crate::integrator::mlt::PassPlan,
    /// `MltChainGpu` per chain.
    chains: wgpu::Buffer,
    /// `MLT_NUMBERS` `MltNumberGpu`s per chain.
    numbers: wgpu::Buffer,
    /// The bootstrap samples' targets.
    targets: wgpu::Buffer,
    /// Rays, accepted mutations and dropped samples as 64-bit totals.
    counters: wgpu::Buffer,
    /// The importance map, one weight per pixel (1 until the host makes one from the film:
    /// `crate::integrator::mlt::importance_map`).
    importance: wgpu::Buffer,
    /// The pass whose splats `caustics` holds, and the factor that makes them its image.
    pass: Option<(u32, f32)>,
    /// Passes traced, passes whose bootstrap found no light, and mutations proposed since
    /// the last reset.
    passes: u64,
    passes_without_light: u64,
    proposed: u64,
    /// Measured seconds per chain-mutation, and the bound [`GpuBackend::software_gpu_sample_cap`]
    /// keeps for pixel-samples (see `seconds_per_sample_bound`).
    seconds_per_mutation: Option<f64>,
    seconds_per_mutation_bound: Option<f64>,
}

impl MltState {
    /// Queues the importance map back to 1 everywhere (no map: the plain luminance target).
    fn clear_importance(&self, queue: &wgpu::Queue) {
        let ones = vec![1.0f32; (self.importance.size() / 4) as usize];
        queue.write_buffer(&self.importance, 0, bytemuck::cast_slice(&ones));
    }
}

/// Numbers a chain keeps room for: `MLT_NUMBERS_PER_STREAM` for each of the three streams
/// (`MLT_NUMBERS` in shaders/sampling.wgsl).
const MLT_NUMBERS: u64 = 3 * crate::integrator::mlt::MLT_NUMBERS_PER_STREAM as u64;

/// The grid words before its slots (`SPPM_HEADER_WORDS` in shaders/sppm.wgsl): this pass's
/// records, the cell edge, photon rays, stored and dropped records as 64-bit totals, and
/// from word [`SPPM_DISPATCH_WORD`] the record passes' workgroup counts.
pub(crate) const SPPM_HEADER_WORDS: u64 = 12;
pub(crate) const SPPM_DISPATCH_WORD: u64 = 8;
/// Slots per block of the grid's prefix sum (`SPPM_SCAN_BLOCK`).
pub(crate) const SPPM_SCAN_BLOCK: u32 = 256;

/// A photon-mapping render's state on the device (shaders/sppm.wgsl's bindings 27 to 31,
/// and the indirect dispatches' arguments) and its sizes.
struct SppmState {
    settings: crate::integrator::sppm::SppmSettings,
    /// `SppmPixelGpu` per pixel.
    pixels: wgpu::Buffer,
    /// `SppmVisiblePoint` per pixel.
    visible: wgpu::Buffer,
    /// `SppmPhoton` per record of a pass.
    photons: wgpu::Buffer,
    /// The header, a word per slot, a word per block of slots.
    grid: wgpu::Buffer,
    /// Record indices sorted by slot.
    order: wgpu::Buffer,
    /// The record passes' workgroup counts (an indirect dispatch's arguments), copied from
    /// the grid's header: not bound, since a dispatch may not read a buffer it binds for
    /// storage as its indirect arguments.
    dispatch: wgpu::Buffer,
    /// Grid slots per map: a power of two from 256 to 2²³, about two per photon.
    slots: u32,
    /// SPPM: the records a pass keeps; the photon-map integrator: the global map's.
    record_capacity: u32,
    /// SPPM's passes taken since the last reset.
    passes: u32,
    /// The photon-map integrator's two maps (`--integrator photon`), else None.
    maps: Option<PhotonMapsGpu>,
}

/// The photon-map integrator's maps in [`SppmState`]'s buffers, traced once: the global map
/// from record 0 and grid word 0, the caustic map after it.
struct PhotonMapsGpu {
    settings: crate::integrator::photon::PhotonMapSettings,
    caustic_capacity: u32,
    caustic_record_base: u32,
    caustic_grid_base: u32,
    /// The scene's surface area, for the global radius.
    scene_area: f64,
    /// The caustic map's cell edge (`integrator::photon::caustic_cell`).
    caustic_cell: f32,
    /// The global map's gather radius, once the maps are built.
    global_radius: Option<f32>,
}

/// A step of a compute pass: a pipeline and its workgroups, or None for as many as the map
/// being built stored records (an indirect dispatch).
type MapStep<'a> = (&'a wgpu::ComputePipeline, Option<(u32, u32, u32)>);

/// One photon map to build: what its build dispatches read.
struct MapBuild {
    pass: u32,
    kind: crate::integrator::sppm::PhotonKind,
    photons: u32,
    capacity: u32,
    grid_base: u32,
    record_base: u32,
}

/// An adaptive render's light-traced caustics on the device ([`CausticSums`]): the kernel
/// that adds each pass's image to the sums (`accumulate_caustic_sums`), and the passes'
/// totals; the sums themselves stay on the device until [`Backend::film`] reads them.
struct DeviceCausticSums {
    kernel: Arc<wgpu::ComputePipeline>,
    totals: CausticSums,
}

impl GpuBackend {
    /// Uploads `scene` and builds (or fetches from the cache) its specialised kernel.
    pub fn new(ctx: Arc<GpuContext>, scene: &FlatScene, settings: &RenderSettings) -> Result<GpuBackend> {
        Self::with_kernel(ctx.clone(), ctx.kernel_for_scene(scene, settings)?, scene, settings)
    }

    /// As [`Self::new`] but with an explicit kernel (e.g. the un-specialised one, to measure
    /// what specialisation buys).
    pub fn with_kernel(
        ctx: Arc<GpuContext>,
        kernel: Arc<Kernel>,
        scene: &FlatScene,
        settings: &RenderSettings,
    ) -> Result<GpuBackend> {
        let start = Instant::now();
        if kernel.key.integrator != settings.integrator {
            return Err(Error::Gpu(format!(
                "--integrator {}: this kernel is the {} integrator's",
                settings.integrator, kernel.key.integrator
            )));
        }
        if settings.splitting() && !kernel.key.splitting {
            return Err(Error::Settings(format!(
                "--splits {}: this kernel was built without splitting",
                settings.splits
            )));
        }
        if kernel.key.integrator == Integrator::Bdpt {
            // Debugging aids of the CPU twin only.
            if settings.record_strategies {
                return Err(Error::Settings(
                    "--bdpt-strategies: the GPU backend does not record strategies; render with --backend cpu".into(),
                ));
            }
            if let Some((s, t)) = settings.bdpt_strategy {
                return Err(Error::Settings(format!(
                    "--bdpt-strategy {s},{t}: the GPU backend renders every strategy; render with --backend cpu"
                )));
            }
        }
        if let Some(misfit) = kernel.key.tables.misfit(scene) {
            return Err(Error::Gpu(format!("{misfit} ({})", kernel.key.tables.describe())));
        }
        let device = &ctx.device;
        let max_groups = ctx.limits.max_compute_workgroups_per_dimension as u64 * WORKGROUP as u64;
        if settings.width as u64 > max_groups || settings.height as u64 > max_groups {
            return Err(Error::Gpu(format!(
                "{}×{} exceeds {}'s dispatch size ({} pixels per side)",
                settings.width, settings.height, ctx.info.name, max_groups
            )));
        }
        let max_binding = ctx.limits.max_storage_buffer_binding_size;
        let max_buffer = ctx.limits.max_buffer_size;
        let check = |what: &str, bytes: u64| -> Result<()> {
            let limit = max_binding.min(max_buffer);
            if bytes > limit {
                return Err(Error::Gpu(format!(
                    "the {what} needs {:.1} MiB but {} allows {:.1} MiB per storage buffer; the scene does not fit on this device (try --backend cpu)",
                    bytes as f64 / 1048576.0,
                    ctx.info.name,
                    limit as f64 / 1048576.0
                )));
            }
            Ok(())
        };
        let storage = |what: &str, bytes: &[u8], usage: wgpu::BufferUsages| -> Result<wgpu::Buffer> {
            check(what, bytes.len() as u64)?;
            Ok(device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(what),
                contents: bytes,
                usage,
            }))
        };
        let read_only = wgpu::BufferUsages::STORAGE;
        // One of the scene's small tables (binding `binding`), in the form the kernel reads
        // it: a storage buffer, or a uniform buffer padded to the declared array.
        let table = |what: &str, binding: u32, bytes: &[u8]| -> Result<wgpu::Buffer> {
            if kernel.key.tables.is_uniform(binding) {
                Ok(device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(what),
                    contents: &UniformTables::padded(bytes),
                    usage: wgpu::BufferUsages::UNIFORM,
                }))
            } else {
                storage(what, bytes, read_only)
            }
        };
        // A binding may not be empty; a scene without lights binds one unused record.
        let lights: Vec<Light> =
            if scene.lights.is_empty() { vec![Light::default()] } else { scene.lights.clone() };
        let scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let nodes = table("BVH node buffer", tables::NODES_BINDING, bytemuck::cast_slice(&scene.nodes))?;
        let triangles =
            table("triangle buffer", tables::TRIANGLES_BINDING, bytemuck::cast_slice(&scene.triangles))?;
        let normals = storage("normal buffer", bytemuck::cast_slice(&scene.normals), read_only)?;
        let materials =
            table("material buffer", tables::MATERIALS_BINDING, bytemuck::cast_slice(&scene.materials))?;
        let lights = table("light buffer", tables::LIGHTS_BINDING, bytemuck::cast_slice(&lights))?;
        let env = &scene.environment;
        let environment = storage("environment", bytemuck::bytes_of(&env.params), read_only)?;
        // Bindings may not be empty: without an environment, one unused element each.
        let env_texels = if env.texels.is_empty() { vec![[0.0f32; 4]] } else { env.texels.clone() };
        let env_cdf = if env.cdf.is_empty() { vec![0.0f32] } else { env.cdf.clone() };
        let environment_texels = storage("environment texels", bytemuck::cast_slice(&env_texels), read_only)?;
        let environment_cdf = storage("environment distribution", bytemuck::cast_slice(&env_cdf), read_only)?;
        // Textures: one unused element of each where a scene has none.
        fn or_one<T: bytemuck::Pod + Default>(v: &[T]) -> Vec<T> {
            if v.is_empty() {
                vec![T::default()]
            } else {
                v.to_vec()
            }
        }
        let texels =
            storage("texel buffer", bytemuck::cast_slice(&or_one(&scene.textures.texels)), read_only)?;
        let texture_infos =
            storage("texture descriptors", bytemuck::cast_slice(&or_one(&scene.textures.infos)), read_only)?;
        let texture_bindings =
            storage("texture bindings", bytemuck::cast_slice(&or_one(&scene.texture_bindings)), read_only)?;
        let texcoords =
            storage("texture coordinates", bytemuck::cast_slice(&or_one(&scene.texcoords)), read_only)?;
        let tangents = storage("tangents", bytemuck::cast_slice(&or_one(&scene.tangents)), read_only)?;
        // The sheen albedo table, computed on the host so that both backends read the same
        // numbers; one unused element for a scene without sheen.
        let sheen_table: &[f32] =
            if scene.features.sheen { crate::bsdf::sheen::sheen_albedo_table() } else { &[0.0] };
        let sheen_albedo = storage("sheen albedo table", bytemuck::cast_slice(sheen_table), read_only)?;
        let pixels = settings.width as u64 * settings.height as u64;
        let rw = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
        let zeroed = |what: &str, bytes: u64| -> Result<wgpu::Buffer> {
            check(what, bytes)?;
            Ok(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(what),
                size: bytes,
                usage: rw,
                mapped_at_creation: false,
            }))
        };
        let film = zeroed("film", pixels * std::mem::size_of::<FilmPixel>() as u64)?;
        let first_hits = zeroed("first-hit buffer", pixels * std::mem::size_of::<FirstHit>() as u64)?;
        let ray_counts = zeroed("ray-count buffer", pixels * 4)?;
        let aov_pixels = if settings.aovs { pixels } else { 1 };
        let aovs = zeroed("AOV buffer", aov_pixels * std::mem::size_of::<PixelAov>() as u64)?;
        let aov_refine_list = zeroed("AOV refinement list", aov_pixels * 4)?;
        // Adaptive sampling's per-pixel sample counts; without it one element, u32::MAX: the
        // kernel reads the last element for any pixel beyond the array (shaders/bindings.wgsl).
        let budget_pixels = if settings.adaptive { pixels } else { 1 };
        check("sample budgets", budget_pixels * 4)?;
        let budgets = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("sample budgets"),
            contents: bytemuck::cast_slice(&vec![u32::MAX; budget_pixels as usize]),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        // Light tracing as the CPU backend decides it (`CpuBackend::light_traces_caustics`).
        let bdpt = settings.integrator == Integrator::Bdpt;
        // Metropolis splats into the same image as BDPT's t = 1 strategies.
        let splats = bdpt || settings.integrator == Integrator::Mlt;
        // Under an irradiance cache the gathers see the caustics themselves (as on the CPU).
        let caustics_kernel = if settings.integrator == Integrator::Path
            && settings.irradiance_cache.is_none()
            && settings.light_tracing
            && crate::integrator::scene_supports_light_tracing(scene)
        {
            Some(ctx.caustics_kernel(scene.features, kernel.key.tables)?)
        } else {
            None
        };
        // Two words per channel (a 64-bit fixed-point sum) per pixel: the light tracer's
        // image, or bidirectional path tracing's t = 1 splats.
        let caustic_pixels = if caustics_kernel.is_some() || splats { pixels } else { 1 };
        // An adaptive render sums the light tracer's images apart (`CausticSums`): its sums
        // follow the image in the same buffer (`accumulate_caustic_sums`).
        let caustic_sums = match &caustics_kernel {
            Some(_) if settings.adaptive => Some(DeviceCausticSums {
                kernel: ctx.caustic_sums_kernel(scene.features, kernel.key.tables)?,
                totals: CausticSums::new(0),
            }),
            _ => None,
        };
        let sum_words = if caustic_sums.is_some() { pixels * CAUSTIC_SUM_WORDS as u64 } else { 0 };
        let caustics = zeroed("light-traced image", (caustic_pixels * 6 + sum_words) * 4)?;
        // The count (padded to 16 bytes), then a vec4 per pixel.
        let bdpt_state = zeroed("bidirectional pass", 16 + 16 * if bdpt { pixels } else { 1 })?;
        let camera = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("camera"),
            contents: bytemuck::bytes_of(&scene.camera),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        });
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame params"),
            size: std::mem::size_of::<FrameParams>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("out of GPU memory uploading the scene: {e}")));
        }
        // The irradiance cache's records, cells and indices: one unused element each until a
        // cache is placed (`ensure_irradiance_cache` binds its own).
        let ic_records = storage(
            "irradiance records",
            bytemuck::bytes_of(&crate::scene::layout::IrradianceRecordGpu::default()),
            read_only,
        )?;
        let ic_cells = storage(
            "irradiance cells",
            bytemuck::bytes_of(&crate::scene::layout::IrradianceCell::default()),
            read_only,
        )?;
        let ic_indices = storage("irradiance indices", bytemuck::bytes_of(&0u32), read_only)?;
        let photon_mapping = matches!(settings.integrator, Integrator::Sppm | Integrator::Photon);
        let sppm = if photon_mapping {
            use crate::integrator::sppm::{gpu_record_capacity, PhotonKind};
            let sppm = crate::integrator::sppm::SppmSettings::of_render(settings);
            let limit = max_binding.min(max_buffer);
            let record_bytes = std::mem::size_of::<crate::scene::layout::SppmPhoton>() as u64;
            let integrator = crate::integrator::IntegratorSettings {
                max_depth: settings.max_depth.unwrap_or(u32::MAX),
                rr_min_depth: settings.rr_min_depth,
                ..Default::default()
            };
            let pilot = crate::integrator::sppm::SppmContext {
                scene,
                camera: &scene.camera,
                settings: &integrator,
                sppm,
                width: settings.width,
                height: settings.height,
                seed: settings.seed,
                sampler: settings.sampler,
                passes: settings.spp,
            };
            // The records one binding holds: capacities past it are cut to it (the two maps'
            // in proportion), and what does not fit is dropped and reported.
            let room = limit / record_bytes;
            let capacity = |photons: u32, kind: PhotonKind| -> u64 {
                (gpu_record_capacity(&pilot, photons, kind) as u64).max(1)
            };
            let map_settings = crate::integrator::photon::PhotonMapSettings::of_render(settings);
            let (record_capacity, most_photons, maps) = if settings.integrator == Integrator::Photon {
                let (global, caustic) = (
                    capacity(map_settings.photons, PhotonKind::All),
                    capacity(map_settings.caustic_photons, PhotonKind::Caustic),
                );
                let scale = (room as f64 / (global + caustic) as f64).min(1.0);
                let cut = |n: u64| ((n as f64 * scale) as u64).max(1) as u32;
                let (global, caustic) = (cut(global), cut(caustic));
                let most = map_settings.photons.max(map_settings.caustic_photons);
                let maps = PhotonMapsGpu {
                    settings: map_settings,
                    caustic_capacity: caustic,
                    caustic_record_base: global,
                    caustic_grid_base: 0,
                    scene_area: crate::integrator::photon::scene_area(scene),
                    caustic_cell: crate::integrator::photon::caustic_cell(&pilot),
                    global_radius: None,
                };
                (global, most, Some(maps))
            } else {
                (capacity(sppm.photons, PhotonKind::Indirect).min(room) as u32, sppm.photons, None)
            };
            let slots = (2 * most_photons as u64).next_power_of_two().clamp(256, 1 << 23) as u32;
            let map_words = SPPM_HEADER_WORDS + slots as u64 + (slots / SPPM_SCAN_BLOCK) as u64;
            let maps = maps.map(|m| PhotonMapsGpu { caustic_grid_base: map_words as u32, ..m });
            let (grid_words, records) = match &maps {
                Some(m) => (2 * map_words, record_capacity as u64 + m.caustic_capacity as u64),
                None => (map_words, record_capacity as u64),
            };
            // The photon-map integrator keeps no per-pixel state: one unused element each.
            let state_pixels = if maps.is_some() { 1 } else { pixels };
            let scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
            let state = SppmState {
                settings: sppm,
                pixels: zeroed(
                    "photon-mapping pixels",
                    state_pixels * std::mem::size_of::<crate::scene::layout::SppmPixelGpu>() as u64,
                )?,
                visible: zeroed(
                    "visible points",
                    state_pixels * std::mem::size_of::<crate::scene::layout::SppmVisiblePoint>() as u64,
                )?,
                photons: zeroed("photon records", records * record_bytes)?,
                grid: zeroed("photon grid", grid_words * 4)?,
                order: zeroed("photon order", records * 4)?,
                dispatch: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("photon dispatch"),
                    size: 12,
                    usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::INDIRECT,
                    mapped_at_creation: false,
                }),
                slots,
                record_capacity,
                passes: 0,
                maps,
            };
            if let Some(e) = pollster::block_on(scope.pop()) {
                return Err(Error::Gpu(format!("out of GPU memory for the photon passes: {e}")));
            }
            Some(state)
        } else {
            None
        };
        let mlt = if settings.integrator == Integrator::Mlt {
            use crate::integrator::mlt::PassPlan;
            use crate::scene::layout::{MltChainGpu, MltNumberGpu};
            let plan = PassPlan::of(
                &settings.mlt,
                settings.max_depth_bound().unwrap_or(u32::MAX),
                settings.width,
                settings.height,
            );
            // A chain counts its iterations and its mutations in 32 bits (below the `set`
            // flag's bit), and the bootstrap's samples are indexed in 32 bits.
            let per_chain = plan.mutations.div_ceil(plan.chains);
            if per_chain >= 1 << 31 || plan.bootstrap > u32::MAX as u64 {
                return Err(Error::Settings(format!(
                    "--integrator mlt on the GPU: {per_chain} mutations per chain and {} bootstrap samples per pass; the GPU's chains count below 2³¹ mutations each (raise --chains or lower --mutations-per-pixel)",
                    plan.bootstrap
                )));
            }
            let chain_bytes = std::mem::size_of::<MltChainGpu>() as u64;
            let number_bytes = std::mem::size_of::<MltNumberGpu>() as u64;
            let scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
            let state = MltState {
                plan,
                chains: zeroed("Metropolis chains", plan.chains * chain_bytes)?,
                numbers: zeroed("Metropolis primary samples", plan.chains * MLT_NUMBERS * number_bytes)?,
                targets: zeroed("Metropolis bootstrap", plan.bootstrap * 4)?,
                counters: zeroed("Metropolis counters", 6 * 4)?,
                importance: zeroed("Metropolis importance", pixels * 4)?,
                pass: None,
                passes: 0,
                passes_without_light: 0,
                proposed: 0,
                seconds_per_mutation: None,
                seconds_per_mutation_bound: None,
            };
            if let Some(e) = pollster::block_on(scope.pop()) {
                return Err(Error::Gpu(format!("out of GPU memory for the Metropolis chains: {e}")));
            }
            Some(state)
        } else {
            None
        };
        let buffers = [
            &nodes,
            &triangles,
            &normals,
            &materials,
            &lights,
            &camera,
            &params,
            &film,
            &first_hits,
            &ray_counts,
            &environment,
            &environment_texels,
            &environment_cdf,
            &texels,
            &texture_infos,
            &texture_bindings,
            &texcoords,
            &tangents,
            &sheen_albedo,
            &caustics,
            &bdpt_state,
            &aovs,
            &budgets,
            &aov_refine_list,
            &ic_records,
            &ic_cells,
            &ic_indices,
        ];
        let mut bind_buffers: Vec<wgpu::Buffer> = buffers.iter().map(|b| (*b).clone()).collect();
        if let Some(state) = &sppm {
            bind_buffers.extend(
                [&state.pixels, &state.visible, &state.photons, &state.grid, &state.order].map(|b| b.clone()),
            );
        }
        if let Some(state) = &mlt {
            bind_buffers.extend(
                [&state.chains, &state.numbers, &state.targets, &state.counters, &state.importance]
                    .map(|b| b.clone()),
            );
            state.clear_importance(&ctx.queue);
        }
        if settings.integrator == Integrator::Path {
            // The irradiance cache's placement passes (27 to 29): one unused element each until
            // a cache is placed (`ensure_irradiance_cache` binds its own).
            use crate::scene::layout::{IcGatherResultGpu, IcVertexGpu};
            bind_buffers.extend([
                zeroed("irradiance vertices", std::mem::size_of::<IcVertexGpu>() as u64)?,
                zeroed("irradiance gather pixels", 4)?,
                zeroed("irradiance gather results", std::mem::size_of::<IcGatherResultGpu>() as u64)?,
            ]);
        }
        let bind_group = Self::make_bind_group(device, &kernel, &bind_buffers);
        let software_snapshot = if ctx.is_hardware() {
            None
        } else {
            Some((
                zeroed("film snapshot", pixels * std::mem::size_of::<FilmPixel>() as u64)?,
                zeroed("ray-count snapshot", pixels * 4)?,
            ))
        };
        ctx.check()?;
        Ok(GpuBackend {
            kernel,
            bind_group,
            params,
            film,
            first_hits,
            ray_counts,
            aovs,
            aov_refine_list,
            budgets,
            sorted_budgets: None,
            settings: settings.clone(),
            light_count: scene.lights.len() as u32,
            camera: scene.camera,
            camera_buffer: camera.clone(),
            rays_folded: 0,
            samples_since_fold: 0,
            seconds_per_sample: None,
            seconds_per_sample_bound: None,
            upload_seconds: start.elapsed().as_secs_f64(),
            caustics,
            software_snapshot,
            pixel_budgets: None,
            software_group_seconds: SOFTWARE_GPU_GROUP_SECONDS,
            forced_dispatch_samples: None,
            software_retries: 0,
            camera_sees_only_delta: (caustics_kernel.is_some() || splats)
                && crate::integrator::delta_view::camera_sees_only_delta_surfaces(scene, &scene.camera),
            bdpt_state,
            bdpt_pass: None,
            bdpt_truncated: 0,
            scene_center: scene.scene_center.to_array(),
            scene_radius: scene.scene_radius,
            caustics_kernel,
            caustic_pass: None,
            caustic_sums,
            bind_buffers,
            ic_frame: (0.0, 0, 0),
            ic_scene: settings.irradiance_cache.is_some().then(|| scene.clone()),
            irradiance_cache: None,
            sppm,
            mlt,
            ctx,
        })
    }

    /// The kernel's bind group over `buffers`, binding i the i-th.
    fn make_bind_group(device: &wgpu::Device, kernel: &Kernel, buffers: &[wgpu::Buffer]) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pathlight scene"),
            layout: &kernel.source.bind_group_layout,
            entries: &entries,
        })
    }

    /// The irradiance cache for the current camera, placed by the device's passes
    /// (`IrradianceCache::build_on_device`: the same records for a seed as the CPU backend's,
    /// up to rounding) and bound, if the settings ask for one and it is not yet.
    fn ensure_irradiance_cache(&mut self) -> Result<()> {
        let Some(settings) = self.settings.irradiance_cache else {
            return Ok(());
        };
        if self.irradiance_cache.is_some() {
            return Ok(());
        }
        let Some(scene) = self.ic_scene.take() else {
            return Ok(());
        };
        let camera = self.camera;
        let integrator = crate::integrator::irradiance_cache::gather_settings(&self.settings);
        let ctx = crate::integrator::irradiance_cache::IrradianceCacheContext {
            scene: &scene,
            camera: &camera,
            integrator: &integrator,
            settings,
            width: self.settings.width,
            height: self.settings.height,
            seed: self.settings.seed,
        };
        let built = crate::integrator::irradiance_cache::IrradianceCache::build_on_device(
            &ctx,
            &mut IcPlacement { backend: self },
        );
        self.ic_scene = Some(scene);
        let cache = built?;
        let tables = cache.gpu_tables();
        let device = &self.ctx.device;
        let upload = |what: &str, bytes: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(what),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        // A binding may not be empty: a cache without records binds one unused record.
        let records = if tables.records.is_empty() {
            vec![crate::scene::layout::IrradianceRecordGpu::default()]
        } else {
            tables.records
        };
        let scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        self.bind_buffers[24] = upload("irradiance records", bytemuck::cast_slice(&records));
        self.bind_buffers[25] = upload("irradiance cells", bytemuck::cast_slice(&tables.cells));
        self.bind_buffers[26] = upload("irradiance indices", bytemuck::cast_slice(&tables.indices));
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("out of GPU memory uploading the irradiance cache: {e}")));
        }
        self.bind_group = Self::make_bind_group(device, &self.kernel, &self.bind_buffers);
        self.ic_frame = (tables.normal_scale, tables.gradients as u32, tables.cells.len() as u32 - 1);
        self.irradiance_cache = Some(cache);
        Ok(())
    }

    /// Are the caustic paths light traced ([`RenderSettings::light_tracing`] asked for, and
    /// the scene and camera allow it)? As `CpuBackend::light_traces_caustics`.
    pub fn light_traces_caustics(&self) -> bool {
        self.caustics_kernel.is_some()
            && crate::integrator::camera_supports_light_tracing(&self.camera)
            && !self.camera_sees_only_delta
    }

    /// Samples' worth of rays one sample index may trace per pixel, for the bound on the
    /// ray counters (`fold_rays_before`): its sample and, when light traced, one light path,
    /// which traces at most as many rays.
    fn ray_bound_per_sample(&self) -> u64 {
        if self.settings.integrator == Integrator::Bdpt {
            // Per camera vertex a ray, a light sample and a join to each light vertex but the
            // first; the light subpath and its joins to the camera.
            let max = BDPT_MAX_VERTICES as u64;
            let rays = (max + 1) * crate::integrator::MAX_BOUNCES_GUARD as u64 + 2 * max;
            return rays.div_ceil(crate::render::MAX_RAYS_PER_SAMPLE);
        }
        1 + self.light_traces_caustics() as u64
    }

    /// Queues bidirectional path tracing's pass for sample index `pass` without waiting:
    /// the splat image cleared, then every pixel's sample traced in bands of `rows` rows.
    /// `bdpt_resolve` adds it to the film once all of it is queued.
    fn submit_bdpt_pass(&mut self, pass: u32, rows: u32) {
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("bdpt splats") });
        encoder.clear_buffer(&self.caustics, 0, None);
        self.ctx.queue.submit([encoder.finish()]);
        let h = self.settings.height;
        let mut row = 0;
        while row < h {
            let count = rows.max(1).min(h - row);
            self.submit(&self.kernel.render, self.frame_params(pass, 1, row, count));
            row += count;
        }
        self.bdpt_pass = Some(pass);
    }

    /// Queues the resolve of the traced pass `pass` over rows `rows`.
    fn submit_bdpt_resolve(&self, pass: u32, rows: std::ops::Range<u32>) -> wgpu::SubmissionIndex {
        let resolve = self.kernel.resolve.as_ref().expect("the bidirectional kernel has a resolve pass");
        self.submit(resolve, self.frame_params(pass, 1, rows.start, rows.end - rows.start))
    }

    /// Bidirectional path tracing's [`Backend::render`]: pass by pass, each traced in bands
    /// sized to about [`TARGET_SUBMIT_SECONDS`] and then resolved, up to [`MAX_IN_FLIGHT`]
    /// passes queued.
    fn render_bdpt(&mut self, sample_offset: u32, samples: u32) -> Result<()> {
        let (w, h) = (self.settings.width, self.settings.height);
        let mut in_flight: std::collections::VecDeque<(wgpu::SubmissionIndex, Instant)> = Default::default();
        for k in sample_offset..sample_offset + samples {
            let rows = match self.seconds_per_sample {
                None => h.min(WORKGROUP),
                Some(rate) => {
                    let rows = (TARGET_SUBMIT_SECONDS / (rate * w as f64)) as u32;
                    ((rows / WORKGROUP).max(1) * WORKGROUP).min(h)
                }
            };
            let submitted = Instant::now();
            self.submit_bdpt_pass(k, rows);
            in_flight.push_back((self.submit_bdpt_resolve(k, 0..h), submitted));
            self.bdpt_pass = None;
            let limit = if self.seconds_per_sample.is_none() { 1 } else { MAX_IN_FLIGHT };
            while in_flight.len() >= limit {
                let (index, submitted) = in_flight.pop_front().expect("non-empty");
                self.wait(index)?;
                // With passes queued back to back the last wait measures one pass.
                let rate =
                    submitted.elapsed().as_secs_f64() / (in_flight.len() + 1) as f64 / (w as f64 * h as f64);
                self.seconds_per_sample = Some(match self.seconds_per_sample {
                    Some(old) => 0.5 * old + 0.5 * rate,
                    None => rate,
                });
            }
        }
        while let Some((index, _)) = in_flight.pop_front() {
            self.wait(index)?;
        }
        Ok(())
    }

    /// Folds the device's truncation counter into [`Self::bdpt_truncated`] and clears it.
    fn fold_bdpt_truncated(&mut self) -> Result<()> {
        let words = self.read_back::<u32>(&self.bdpt_state)?;
        self.bdpt_truncated += words[0] as u64;
        let mut encoder =
            self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("clear") });
        encoder.clear_buffer(&self.bdpt_state, 0, Some(16));
        let index = self.ctx.queue.submit([encoder.finish()]);
        self.wait(index)
    }

    /// Queues the light tracer's pass for sample index `pass` (the image cleared, then
    /// light paths over bands of `rows` rows) without waiting: the queue runs it before
    /// any `render` submitted after it.
    fn submit_caustic_pass(&mut self, pass: u32, rows: u32) {
        let Some(pipeline) = self.caustics_kernel.clone() else { return };
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("caustics") });
        // The image only: an adaptive render's sums after it stay.
        encoder.clear_buffer(&self.caustics, 0, Some(self.caustic_image_bytes()));
        self.ctx.queue.submit([encoder.finish()]);
        // Path i is invocation (i mod width, i div width): the rows that hold the pass's paths.
        let paths = self.light_paths(pass);
        let h = paths.div_ceil(self.settings.width).min(self.settings.height);
        let mut row = 0;
        while row < h {
            let count = rows.max(1).min(h - row);
            self.submit(&pipeline, self.frame_params(pass, 1, row, count));
            row += count;
        }
        if let Some(sums) = self.caustic_sums.as_mut() {
            // Once per pass, whatever retakes or bands ask for its image again.
            if sums.totals.count_pass(pass, paths as usize) {
                let kernel = sums.kernel.clone();
                self.submit(&kernel, self.frame_params(pass, 1, 0, self.settings.height));
            }
        }
        self.caustic_pass = Some(pass);
    }

    /// Queues photon-mapping pass `k` (shaders/sppm.wgsl's steps, in one submit): the pass's
    /// record count and grid slots cleared, then visible points, photons, the grid, the
    /// gathers. The next pass's dispatches read what this one wrote, in queue order.
    fn submit_sppm_pass(&mut self, k: u32) -> Result<wgpu::SubmissionIndex> {
        let state = self.sppm.as_ref().expect("a photon-mapping backend has its state");
        let maps = self.kernel.photon_maps.as_ref().expect("the photon-mapping kernel has its map passes");
        let gather = self.kernel.resolve.as_ref().expect("the SPPM kernel has its gather");
        if k != state.passes {
            return Err(Error::Settings(format!(
                "photon-mapping pass {k} asked for after {} passes: its passes depend on the ones before and run in order",
                state.passes
            )));
        }
        let (w, h) = (self.settings.width, self.settings.height);
        let params = self.frame_params(k, 1, 0, h);
        self.ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("sppm pass") });
        Self::encode_clear_map(&mut encoder, state, 0);
        let image = (w.div_ceil(WORKGROUP), h.div_ceil(WORKGROUP), 1);
        let photons = self.item_groups(state.settings.photons);
        self.encode_steps(
            &mut encoder,
            &[(&self.kernel.render, Some(image)), (&maps.trace_photons, Some(photons))],
        );
        self.encode_grid(&mut encoder, state, maps, 0);
        self.encode_steps(&mut encoder, &[(gather, Some(image))]);
        let index = self.ctx.queue.submit([encoder.finish()]);
        self.sppm.as_mut().expect("checked above").passes += 1;
        Ok(index)
    }

    /// Encodes one compute pass of `steps`: each pipeline with its workgroups, or None: as
    /// many as the map being built stored records (`sppm_grid_setup` leaves the count in
    /// the grid's header, copied into the indirect arguments between compute passes).
    fn encode_steps(&self, encoder: &mut wgpu::CommandEncoder, steps: &[MapStep]) {
        let dispatch = self.sppm.as_ref().map(|s| &s.dispatch);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("photons"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        for &(pipeline, groups) in steps {
            pass.set_pipeline(pipeline);
            match (groups, dispatch) {
                (Some((x, y, z)), _) => pass.dispatch_workgroups(x, y, z),
                (None, Some(args)) => pass.dispatch_workgroups_indirect(args, 0),
                (None, None) => unreachable!("indirect steps belong to photon mapping"),
            }
        }
    }

    /// Clears the record count and the slot counts of the map whose first grid word is
    /// `grid_base`, before its photons are traced (the running totals stay).
    fn encode_clear_map(encoder: &mut wgpu::CommandEncoder, state: &SppmState, grid_base: u32) {
        let base = grid_base as u64 * 4;
        encoder.clear_buffer(&state.grid, base, Some(4));
        encoder.clear_buffer(&state.grid, base + SPPM_HEADER_WORDS * 4, Some(state.slots as u64 * 4));
    }

    /// The workgroups of a dispatch over `items` items (photons, or Metropolis's bootstrap
    /// samples and chains): rows of `width` items in workgroups of 8 rows, at most 65,535 in
    /// y and the rest in z layers (`sppm_trace_photons`, `mlt_item`).
    fn item_groups(&self, items: u32) -> (u32, u32, u32) {
        let w = self.settings.width;
        let row_groups = items.div_ceil(w).div_ceil(WORKGROUP).max(1);
        let y_groups = row_groups.min(65_535);
        (w.div_ceil(WORKGROUP), y_groups, row_groups.div_ceil(y_groups))
    }

    /// Encodes the grid of the map whose first grid word is `grid_base` (shaders/sppm.wgsl's
    /// steps 3 and 4) once its photons are traced: the setup, the copy of its dispatch
    /// arguments, then count, prefix sum and scatter.
    fn encode_grid(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        state: &SppmState,
        pipelines: &super::context::PhotonMapPipelines,
        grid_base: u32,
    ) {
        self.encode_steps(encoder, &[(&pipelines.grid_setup, Some((1, 1, 1)))]);
        let args = (grid_base as u64 + SPPM_DISPATCH_WORD) * 4;
        encoder.copy_buffer_to_buffer(&state.grid, args, &state.dispatch, 0, 12);
        let blocks = state.slots / SPPM_SCAN_BLOCK;
        self.encode_steps(
            encoder,
            &[
                (&pipelines.grid_count, None),
                (&pipelines.scan_blocks, Some((blocks, 1, 1))),
                (&pipelines.scan_totals, Some((1, 1, 1))),
                (&pipelines.scan_add, Some((blocks, 1, 1))),
                (&pipelines.grid_scatter, None),
            ],
        );
    }

    /// The photon-map integrator's maps, traced and sorted into their grids before its
    /// first sample (twin of `PhotonMaps::build`): each map's photons are traced, their
    /// count read back (the global radius follows from it), then its grid is built with
    /// the cell edge the CPU twin uses.
    fn build_photon_maps(&mut self) -> Result<()> {
        use crate::integrator::photon::{global_radius, CAUSTIC_MAP_PASS, GLOBAL_MAP_PASS};
        use crate::integrator::sppm::PhotonKind;
        let Some(maps) = self.sppm.as_ref().and_then(|s| s.maps.as_ref()) else { return Ok(()) };
        if maps.global_radius.is_some() {
            return Ok(());
        }
        let state = self.sppm.as_ref().expect("checked above");
        let builds = [
            MapBuild {
                pass: GLOBAL_MAP_PASS,
                kind: PhotonKind::All,
                photons: maps.settings.photons,
                capacity: state.record_capacity,
                grid_base: 0,
                record_base: 0,
            },
            MapBuild {
                pass: CAUSTIC_MAP_PASS,
                kind: PhotonKind::Caustic,
                photons: maps.settings.caustic_photons,
                capacity: maps.caustic_capacity,
                grid_base: maps.caustic_grid_base,
                record_base: maps.caustic_record_base,
            },
        ];
        let pipelines = self.kernel.photon_maps.as_ref().expect("the photon-map kernel has its map passes");
        let mut radius = 0.0;
        for build in builds {
            let params = FrameParams {
                sppm_photons: build.photons,
                sppm_record_capacity: build.capacity,
                photon_grid_base: build.grid_base,
                photon_record_base: build.record_base,
                photon_kind: build.kind.index(),
                ..self.frame_params(build.pass, 1, 0, self.settings.height)
            };
            let base = build.grid_base as u64 * 4;
            // Trace, then read back how many records it stored.
            let traced = {
                self.ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
                let mut encoder = self
                    .ctx
                    .device
                    .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("photon map") });
                Self::encode_clear_map(&mut encoder, state, build.grid_base);
                let groups = self.item_groups(build.photons);
                self.encode_steps(&mut encoder, &[(&pipelines.trace_photons, Some(groups))]);
                self.ctx.queue.submit([encoder.finish()])
            };
            self.wait(traced)?;
            let count = self.ctx.read_buffer_range::<u32>(&state.grid, base..base + 4, SUBMIT_TIMEOUT)?[0];
            let stored = count.min(build.capacity) as usize;
            let cell = if build.kind == PhotonKind::All {
                radius =
                    global_radius(maps.scene_area, self.scene_radius, stored, maps.settings.gather_photons);
                2.0 * radius
            } else {
                maps.caustic_cell
            };
            // The grid, with the host's cell edge.
            let params = FrameParams { photon_cell: cell, ..params };
            self.ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
            let mut encoder = self
                .ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("photon grid") });
            self.encode_grid(&mut encoder, state, pipelines, build.grid_base);
            let index = self.ctx.queue.submit([encoder.finish()]);
            self.wait(index)?;
        }
        if let Some(maps) = self.sppm.as_mut().and_then(|s| s.maps.as_mut()) {
            maps.global_radius = Some(radius);
        }
        Ok(())
    }

    /// Photon mapping's [`Backend::render`]: pass after pass, up to [`MAX_IN_FLIGHT`] queued.
    fn render_sppm(&mut self, sample_offset: u32, samples: u32) -> Result<()> {
        let mut in_flight: std::collections::VecDeque<wgpu::SubmissionIndex> = Default::default();
        for k in sample_offset..sample_offset + samples {
            in_flight.push_back(self.submit_sppm_pass(k)?);
            while in_flight.len() >= MAX_IN_FLIGHT {
                self.wait(in_flight.pop_front().expect("non-empty"))?;
            }
        }
        while let Some(index) = in_flight.pop_front() {
            self.wait(index)?;
        }
        Ok(())
    }

    /// Metropolis's pass `k` traced into `caustics` (shaders/mlt.wgsl's steps 1 to 3): the
    /// bootstrap (`mlt_render` with no mutations), its targets read back and the chains'
    /// starts drawn from them on the host (`chain_starts`, as the CPU backend draws them),
    /// then the chains' first states and their mutations in dispatches sized to about [`TARGET_SUBMIT_SECONDS`] (on a software
    /// GPU also to its loop budget, [`SOFTWARE_GPU_GROUP_SECONDS`]).
    fn trace_mlt_pass(&mut self, k: u32) -> Result<()> {
        use crate::integrator::mlt::chain_starts;
        use crate::scene::layout::MltChainGpu;
        let kernel = self.kernel.clone();
        let size = (self.settings.width, self.settings.height);
        let remade =
            crate::integrator::mlt::importance_before_pass(self.settings.mlt.target, k, size, || {
                self.read_back::<FilmPixel>(&self.film)
            })?;
        if let Some(map) = remade {
            let state = self.mlt.as_ref().expect("a Metropolis backend has its state");
            self.ctx.queue.write_buffer(&state.importance, 0, bytemuck::cast_slice(&map));
        }
        let state = self.mlt.as_ref().expect("a Metropolis backend has its state");
        let plan = state.plan;
        let base = self.frame_params(k, 1, 0, self.settings.height);
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("mlt splats") });
        encoder.clear_buffer(&self.caustics, 0, None);
        self.ctx.queue.submit([encoder.finish()]);
        let bootstrap = plan.bootstrap as u32;
        let index = self.submit_groups(
            &kernel.render,
            FrameParams { mlt_items: bootstrap, ..base },
            self.item_groups(bootstrap),
        );
        self.wait(index)?;
        let targets: Vec<f32> =
            self.ctx.read_buffer_range(&state.targets, 0..plan.bootstrap * 4, SUBMIT_TIMEOUT)?;
        let Some((b, starts)) = chain_starts(&plan, &targets, k, self.settings.seed) else {
            let state = self.mlt.as_mut().expect("checked above");
            state.passes += 1;
            state.passes_without_light += 1;
            state.pass = Some((k, 0.0));
            return Ok(());
        };
        let chains: Vec<MltChainGpu> = starts
            .iter()
            .map(|s| MltChainGpu {
                start: s.sample as u32,
                depth: s.depth,
                remaining: s.mutations as u32,
                ..Default::default()
            })
            .collect();
        self.ctx.queue.write_buffer(&state.chains, 0, bytemuck::cast_slice(&chains));
        let items = chains.len() as u32;
        let groups = self.item_groups(items);
        // Each chain's first dispatch starts it before its mutations.
        let mut left = starts.iter().map(|s| s.mutations).max().unwrap_or(0);
        while left > 0 {
            let m = self.mlt_mutations_per_dispatch(items).min(left);
            let submitted = Instant::now();
            let params = FrameParams { mlt_items: items, mlt_mutations: m as u32, ..base };
            let index = self.submit_groups(&kernel.render, params, groups);
            self.wait(index)?;
            let rate = submitted.elapsed().as_secs_f64() / (items as f64 * m as f64);
            let state = self.mlt.as_mut().expect("checked above");
            state.seconds_per_mutation =
                Some(state.seconds_per_mutation.map_or(rate, |old| 0.5 * old + 0.5 * rate));
            // Raised at once, lowered by halves, as `seconds_per_sample_bound`.
            state.seconds_per_mutation_bound = Some(match state.seconds_per_mutation_bound {
                Some(old) if rate < old => 0.5 * old + 0.5 * rate,
                _ => rate,
            });
            left -= m;
        }
        let state = self.mlt.as_mut().expect("checked above");
        state.passes += 1;
        state.proposed += plan.mutations;
        state.pass = Some((k, plan.image_scale(b) as f32));
        Ok(())
    }

    /// Mutations per chain in the next `mlt_mutate` dispatch over `chains` chains: one until
    /// a first is timed, then about [`TARGET_SUBMIT_SECONDS`] of them, and on a software GPU
    /// no more than a group of lanes runs in [`SOFTWARE_GPU_GROUP_SECONDS`] (each lane a
    /// chain, its mutations one after another; `software_gpu_sample_cap` explains the
    /// budget). Timed from its submission, the rate over-states a dispatch's time, which only
    /// makes the dispatches smaller.
    fn mlt_mutations_per_dispatch(&self, chains: u32) -> u64 {
        let state = self.mlt.as_ref().expect("a Metropolis backend has its state");
        let (Some(rate), Some(bound)) = (state.seconds_per_mutation, state.seconds_per_mutation_bound) else {
            return 1;
        };
        let mut m = (TARGET_SUBMIT_SECONDS / (rate * chains as f64)) as u64;
        if !self.ctx.is_hardware() {
            let threads = std::thread::available_parallelism().map_or(1, |n| n.get()) as f64;
            m = m.min((SOFTWARE_GPU_GROUP_SECONDS / (bound * threads * SOFTWARE_GPU_LANES)) as u64);
        }
        m.max(1)
    }

    /// Queues the resolve of Metropolis's traced pass `k` over rows `rows`.
    fn submit_mlt_resolve(&self, k: u32, rows: std::ops::Range<u32>) -> wgpu::SubmissionIndex {
        let resolve = self.kernel.resolve.as_ref().expect("the Metropolis kernel has a resolve pass");
        let scale =
            self.mlt.as_ref().and_then(|s| s.pass).filter(|(pass, _)| *pass == k).map_or(0.0, |(_, s)| s);
        let params = self.frame_params(k, 1, rows.start, rows.end - rows.start);
        self.submit(resolve, FrameParams { mlt_scale: scale, ..params })
    }

    /// Metropolis's [`Backend::render`]: pass after pass, each traced, then resolved.
    fn render_mlt(&mut self, sample_offset: u32, samples: u32) -> Result<()> {
        for k in sample_offset..sample_offset + samples {
            self.trace_mlt_pass(k)?;
            let index = self.submit_mlt_resolve(k, 0..self.settings.height);
            self.wait(index)?;
        }
        Ok(())
    }

    /// Metropolis's running totals (rays, accepted mutations, dropped samples) with the
    /// host's counts.
    fn mlt_totals(&self) -> Result<Option<crate::integrator::mlt::MltStats>> {
        let Some(state) = &self.mlt else { return Ok(None) };
        let words = self.ctx.read_buffer_range::<u32>(&state.counters, 0..24, SUBMIT_TIMEOUT)?;
        let total = |at: usize| words[at] as u64 | (words[at + 1] as u64) << 32;
        Ok(Some(crate::integrator::mlt::MltStats {
            passes: state.passes,
            proposed: state.proposed,
            accepted: total(2),
            passes_without_light: state.passes_without_light,
            rays: total(0),
            dropped_samples: total(4),
        }))
    }

    /// The grid's running totals: photon rays, stored and dropped records.
    fn sppm_totals(&self) -> Result<Option<crate::integrator::sppm::SppmStats>> {
        let Some(state) = &self.sppm else { return Ok(None) };
        let words =
            self.ctx.read_buffer_range::<u32>(&state.grid, 0..SPPM_HEADER_WORDS * 4, SUBMIT_TIMEOUT)?;
        let total = |at: usize| words[at] as u64 | (words[at + 1] as u64) << 32;
        Ok(Some(crate::integrator::sppm::SppmStats {
            passes: state.passes as u64,
            photon_rays: total(2),
            stored_photons: total(4),
            dropped_photons: total(6),
            record_capacity: state.record_capacity as u64,
        }))
    }

    /// Seconds it took to build this backend's kernel.
    pub fn kernel_build_seconds(&self) -> f64 {
        self.kernel.build_seconds
    }

    /// The forms its kernel reads the scene's small tables in.
    pub fn tables(&self) -> UniformTables {
        self.kernel.key.tables
    }

    /// The most samples per pixel a dispatch may add on a software GPU
    /// ([`SOFTWARE_GPU_GROUP_SECONDS`]): a group of lanes runs its pixels' samples one after
    /// another, `rate` seconds per pixel-sample spread over the host's threads, so it runs
    /// about spp · rate · threads · lanes seconds. Unbounded on a hardware GPU.
    fn software_gpu_sample_cap(&self) -> u32 {
        match self.seconds_per_sample_bound {
            Some(rate) if !self.ctx.is_hardware() => {
                let threads = std::thread::available_parallelism().map_or(1, |n| n.get()) as f64;
                let per_sample = rate * threads * SOFTWARE_GPU_LANES;
                ((self.software_group_seconds / per_sample.max(1e-12)) as u32).max(1)
            }
            _ => u32::MAX,
        }
    }

    /// Bytes of `caustics` that hold one pass's image (or splats), before an adaptive
    /// render's sums.
    fn caustic_image_bytes(&self) -> u64 {
        let pixels = self.settings.width as u64 * self.settings.height as u64;
        match self.caustic_sums {
            Some(_) => pixels * 6 * 4,
            None => self.caustics.size(),
        }
    }

    /// The light tracer's paths for sample index `k`: one per pixel that takes it
    /// (`trace_caustic_pass`).
    fn light_paths(&self, k: u32) -> u32 {
        match &self.sorted_budgets {
            Some(b) => (b.len() - b.partition_point(|&n| n <= k)) as u32,
            None => self.settings.width * self.settings.height,
        }
    }

    fn frame_params(&self, sample_offset: u32, samples: u32, row_offset: u32, row_count: u32) -> FrameParams {
        let cone =
            crate::scene::camera::camera_ray_cone(&self.camera, self.settings.height, self.settings.spp);
        // One pixel's cone: photon mapping's footprint (`integrator::sppm::camera_path`).
        let footprint = crate::scene::camera::camera_ray_cone(&self.camera, self.settings.height, 1);
        let maps = self.sppm.as_ref().and_then(|s| s.maps.as_ref());
        FrameParams {
            width: self.settings.width,
            height: self.settings.height,
            sample_offset,
            samples,
            seed: self.settings.seed,
            max_depth: self.settings.max_depth_bound().unwrap_or(u32::MAX),
            rr_min_depth: self.settings.rr_min_depth,
            light_count: self.light_count,
            row_offset,
            row_count,
            cone_width: cone.width,
            cone_spread: cone.spread,
            sampler_kind: self.settings.sampler.index(),
            splits: self.settings.splits,
            light_traced_caustics: match (self.light_traces_caustics(), self.caustic_sums.is_some()) {
                (false, _) => 0,
                (true, false) => crate::scene::layout::CAUSTICS_PER_SAMPLE,
                (true, true) => crate::scene::layout::CAUSTICS_APART,
            },
            camera_connections: !self.camera_sees_only_delta as u32,
            scene_center: self.scene_center,
            scene_radius: self.scene_radius,
            light_paths: self.light_paths(sample_offset),
            ic_normal_scale: self.ic_frame.0,
            ic_gradients: self.ic_frame.1,
            ic_table_mask: self.ic_frame.2,
            sppm_photons: match (&self.sppm, maps) {
                (_, Some(m)) => m.settings.photons,
                (Some(s), None) => s.settings.photons,
                (None, None) => 0,
            },
            sppm_radius_pixels: self.sppm.as_ref().map_or(0.0, |s| s.settings.radius_pixels),
            sppm_slot_mask: self.sppm.as_ref().map_or(0, |s| s.slots - 1),
            sppm_record_capacity: self.sppm.as_ref().map_or(0, |s| s.record_capacity),
            sppm_footprint_width: footprint.width,
            sppm_footprint_spread: footprint.spread,
            photon_grid_base: maps.map_or(0, |m| m.caustic_grid_base),
            photon_record_base: maps.map_or(0, |m| m.caustic_record_base),
            photon_kind: 0,
            photon_cell: 0.0,
            photon_global_radius: maps.and_then(|m| m.global_radius).unwrap_or(0.0),
            photon_caustic_photons: maps.map_or(0, |m| m.settings.caustic_photons),
            mlt_items: 0,
            mlt_mutations: 0,
            mlt_large_step: self.settings.mlt.large_step_probability,
            mlt_scale: 0.0,
            ic_gather_jobs: 0,
            ic_gather_job_offset: 0,
            ic_gather_round: 0,
            ic_gather_polar_strata: self
                .settings
                .irradiance_cache
                .map_or(0, |c| crate::integrator::irradiance_cache::gather_strata(c.gather_rays).0),
            aov_rays: 0,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        }
    }

    /// Encodes and submits one dispatch of `pipeline` over rows `[row_offset, row_offset +
    /// row_count)` without waiting. `queue.write_buffer` is ordered on the queue timeline, so
    /// one parameter buffer serves any number of submits in flight.
    fn submit(&self, pipeline: &wgpu::ComputePipeline, params: FrameParams) -> wgpu::SubmissionIndex {
        let groups = (params.width.div_ceil(WORKGROUP), params.row_count.div_ceil(WORKGROUP), 1);
        self.submit_groups(pipeline, params, groups)
    }

    /// [`Self::submit`] with `groups` workgroups.
    fn submit_groups(
        &self,
        pipeline: &wgpu::ComputePipeline,
        params: FrameParams,
        (x, y, z): (u32, u32, u32),
    ) -> wgpu::SubmissionIndex {
        self.ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("pathlight") });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("path tracing"),
                timestamp_writes: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.dispatch_workgroups(x, y, z);
        }
        self.ctx.queue.submit([encoder.finish()])
    }

    /// Submits one dispatch and waits for it.
    fn dispatch(&self, pipeline: &wgpu::ComputePipeline, params: FrameParams) -> Result<()> {
        let index = self.submit(pipeline, params);
        self.wait(index)
    }

    fn wait(&self, index: wgpu::SubmissionIndex) -> Result<()> {
        self.ctx.wait_for(index, SUBMIT_TIMEOUT)
    }

    /// Copies a GPU buffer back to the host.
    fn read_back<T: bytemuck::Pod>(&self, buffer: &wgpu::Buffer) -> Result<Vec<T>> {
        self.ctx.read_buffer(buffer, SUBMIT_TIMEOUT)
    }

    /// What the camera ray of sample 0 of every pixel hits.
    pub fn first_hits(&mut self) -> Result<Vec<FirstHit>> {
        // The first-hit AOV reads textures at a one-sample render's level of detail, as
        // `integrator::first_hit` does.
        let pipeline = self.ctx.first_hit_kernel(&self.kernel)?;
        self.dispatch(pipeline, self.one_pixel_cone_params())?;
        self.read_back(&self.first_hits)
    }

    /// The whole image's parameters with the camera rays' cone of a one-sample render (one
    /// pixel's footprint), which the first-hit pass and the irradiance cache's overture
    /// trace with.
    fn one_pixel_cone_params(&self) -> FrameParams {
        let params = self.frame_params(0, 1, 0, self.settings.height);
        FrameParams {
            cone_width: params.sppm_footprint_width,
            cone_spread: params.sppm_footprint_spread,
            ..params
        }
    }
}

/// Pixels per submit of the AOV pass: 2¹⁸ pixels of its first 4 rays each, about 1 M rays;
/// the refinement's slices take at most 2¹⁸ × 16 rays, about 4 M, a few milliseconds on a
/// hardware GPU and about a second on lavapipe.
const AOV_BAND_PIXELS: u32 = 1 << 18;

impl GpuBackend {
    /// The AOV pass over the whole image (`integrator::aov`'s twin), read back.
    fn render_aovs(&mut self) -> Result<Vec<PixelAov>> {
        if !self.settings.aovs {
            return Err(Error::Settings(
                "AOVs were asked of a GPU render not set up for them (RenderSettings::aovs)".into(),
            ));
        }
        let kernels = self.ctx.aov_kernels(&self.kernel)?;
        // Textures at the render's level of detail, as on the CPU (`render_aovs`).
        let cone =
            crate::scene::camera::camera_ray_cone(&self.camera, self.settings.height, self.settings.spp);
        // In bands of at most AOV_BAND_PIXELS pixels (AOV_SAMPLES rays each), so that no
        // submit runs long; they are queued together and waited for once.
        let (width, height) = (self.settings.width, self.settings.height);
        let band_rows = (AOV_BAND_PIXELS / width).clamp(1, height);
        let mut last = None;
        for row_offset in (0..height).step_by(band_rows as usize) {
            let rows = band_rows.min(height - row_offset);
            let params = FrameParams {
                cone_width: cone.width,
                cone_spread: cone.spread,
                ..self.frame_params(0, 1, row_offset, rows)
            };
            last = Some(self.submit(&kernels.first, params));
        }
        if let Some(index) = last {
            self.wait(index)?;
        }
        // The second pass over the pixels the first one finds varying, on silhouettes and on
        // emitters' edges, decided on the host as on the CPU (`pixels_to_refine`).
        let first = self.read_back::<PixelAov>(&self.aovs)?;
        let refine = crate::integrator::aov::pixels_to_refine(width, height, &first);
        // One list on the device, its parts in `AovRefinement::lists`'s order.
        let list: Vec<u32> = refine.lists().iter().flat_map(|(part, _)| part.iter().copied()).collect();
        if !list.is_empty() {
            self.ctx.queue.write_buffer(&self.aov_refine_list, 0, bytemuck::cast_slice(&list));
        }
        let mut last = None;
        let mut first_entry = 0;
        for (part, rays) in refine.lists() {
            let entries = part.len() as u32;
            // Slices of at most AOV_BAND_PIXELS × AOV_VARYING_SAMPLES rays.
            let slice = AOV_BAND_PIXELS * AOV_VARYING_SAMPLES / rays;
            for start in (0..entries).step_by(slice as usize) {
                let count = slice.min(entries - start);
                let params = FrameParams {
                    cone_width: cone.width,
                    cone_spread: cone.spread,
                    aov_rays: rays,
                    ..self.frame_params(first_entry + start, count, 0, 1)
                };
                // `aov_refine`'s workgroups of 64 over the slice's list entries.
                last = Some(self.submit_groups(&kernels.refine, params, (count.div_ceil(64), 1, 1)));
            }
            first_entry += entries;
        }
        if let Some(index) = last {
            self.wait(index)?;
        }
        let aovs = self.read_back::<PixelAov>(&self.aovs)?;
        // Every pixel counts the rays it took (SOFTWARE_GPU_GROUP_SECONDS says why a device
        // might take fewer).
        let expected = |i: usize| refine.rays_of(i as u32);
        if let Some(i) = (0..aovs.len()).find(|&i| aovs[i].rays != expected(i)) {
            return Err(Error::Gpu(format!(
                "the AOV pass took {} of {} rays at pixel {i}: the device cut it short",
                aovs[i].rays,
                expected(i)
            )));
        }
        Ok(aovs)
    }

    /// The film on the device (`FilmPixel` per pixel, row-major): a viewer's display pass
    /// reads it in place where [`Self::film_buffer_is_the_image`].
    pub fn film_buffer(&self) -> &wgpu::Buffer {
        &self.film
    }

    /// Does the film on the device hold the image? Not under photon mapping (it holds the
    /// per-pass estimates, `integrator::sppm`) nor under adaptive sampling with light-traced
    /// caustics (the camera paths alone, `CausticSums`): [`Backend::film`] makes the image.
    pub fn film_buffer_is_the_image(&self) -> bool {
        self.settings.integrator != Integrator::Sppm && self.caustic_sums.is_none()
    }

    /// Folds the per-pixel ray counters into the 64-bit total when `samples` more samples
    /// per pixel could make one wrap.
    fn fold_rays_before(&mut self, samples: u64) -> Result<()> {
        let limit = u32::MAX as u64 / crate::render::MAX_RAYS_PER_SAMPLE;
        if self.samples_since_fold + samples > limit {
            self.fold_rays()?;
        }
        self.samples_since_fold += samples;
        Ok(())
    }

    fn fold_rays(&mut self) -> Result<()> {
        self.rays_folded += self.read_back::<u32>(&self.ray_counts)?.iter().map(|&c| c as u64).sum::<u64>();
        let mut encoder =
            self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("clear") });
        encoder.clear_buffer(&self.ray_counts, 0, None);
        let index = self.ctx.queue.submit([encoder.finish()]);
        self.wait(index)?;
        self.samples_since_fold = 0;
        Ok(())
    }

    /// The path-tracing kernel's samples `sample_offset .. sample_offset + samples` for every
    /// pixel, in submits sized as [`Backend::render`] says.
    fn render_samples(&mut self, sample_offset: u32, samples: u32) -> Result<()> {
        let (w, h) = (self.settings.width, self.settings.height);
        // (submission, pixel-samples of work, time submitted)
        let mut in_flight: std::collections::VecDeque<(wgpu::SubmissionIndex, f64, Instant)> =
            Default::default();
        let mut last_done: Option<Instant> = None;
        let mut done = 0u32;
        while done < samples {
            let remaining = samples - done;
            let (spp, rows) = match self.seconds_per_sample {
                // Probe with a small band until a first measurement exists.
                None => (1, h.min(WORKGROUP)),
                Some(rate) => {
                    let full_image = rate * w as f64 * h as f64;
                    if full_image <= TARGET_SUBMIT_SECONDS {
                        (((TARGET_SUBMIT_SECONDS / full_image) as u32).clamp(1, remaining), h)
                    } else {
                        // Bands of whole workgroup rows, each with up to BAND_SAMPLES samples
                        // per pixel (a partial workgroup row runs idle lanes).
                        let row = rate * w as f64;
                        let spp = ((TARGET_SUBMIT_SECONDS / (row * WORKGROUP as f64)) as u32)
                            .clamp(1, remaining.min(BAND_SAMPLES));
                        let rows = (TARGET_SUBMIT_SECONDS / (row * spp as f64)) as u32;
                        (spp, ((rows / WORKGROUP).max(1) * WORKGROUP).min(h))
                    }
                }
            };
            let spp = match self.forced_dispatch_samples {
                Some(forced) => forced.min(remaining),
                None => spp.min(self.software_gpu_sample_cap()),
            };
            let spp = if self.light_traces_caustics() {
                if self.caustic_pass != Some(sample_offset + done) {
                    self.submit_caustic_pass(sample_offset + done, rows);
                }
                1
            } else {
                spp
            };
            let mut row = 0;
            while row < h {
                let count = rows.min(h - row);
                let params = self.frame_params(sample_offset + done, spp, row, count);
                // Timed from before the submit: the submit can return after the device has
                // run the work (lavapipe with tests side by side on two cores timed a 2-ms
                // dispatch at 2 µs from its return), and so understated, the rate let the
                // next call run 128 samples in one dispatch and lose them to the loop limit
                // four tries in a row.
                let submitted = Instant::now();
                let index = self.submit(&self.kernel.render, params);
                // The pixel-samples this dispatch computes: under adaptive sampling only the
                // pixels still sampling (counted over the image, shared out by rows), so that
                // the rate is that of a working pixel and the software-GPU bound holds.
                let pixels = self.light_paths(sample_offset + done) as f64 * count as f64 / h as f64;
                in_flight.push_back((index, pixels.max(1.0) * spp as f64, submitted));
                let limit = if self.seconds_per_sample.is_none() { 1 } else { MAX_IN_FLIGHT };
                while in_flight.len() >= limit {
                    let (index, work, submitted) = in_flight.pop_front().expect("non-empty");
                    self.wait(index)?;
                    last_done = Some(self.time_submit(work, submitted, last_done));
                }
                row += count;
            }
            done += spp;
        }
        // The submits still queued are timed too: a call done in one dispatch (a cap the
        // rate allows) must still measure it.
        while let Some((index, work, submitted)) = in_flight.pop_front() {
            self.wait(index)?;
            last_done = Some(self.time_submit(work, submitted, last_done));
        }
        Ok(())
    }

    /// Updates the rates from a path-tracing submit seen done now, `work` pixel-samples
    /// submitted at `submitted`, the one before it done at `last_done`; returns now.
    fn time_submit(&mut self, work: f64, submitted: Instant, last_done: Option<Instant>) -> Instant {
        let now = Instant::now();
        // The device ran this submit from when it was submitted or when the one before it
        // finished, whichever was later.
        let began = match last_done {
            Some(t) if t > submitted => t,
            _ => submitted,
        };
        let rate = now.duration_since(began).as_secs_f64() / work;
        self.seconds_per_sample = Some(match self.seconds_per_sample {
            Some(old) => 0.5 * old + 0.5 * rate,
            None => rate,
        });
        let bound = now.duration_since(submitted).as_secs_f64() / work;
        // A slower submit raises the bound at once, a faster one lowers it by halves: a
        // device shared with other work (tests running side by side on one lavapipe) must
        // not let one quick submit cut the bound and the next, larger dispatch meet
        // lavapipe's loop limit (the lamp room lost 7% of its samples so, once in four runs
        // of tests/gpu beside the cache's test).
        self.seconds_per_sample_bound = Some(match self.seconds_per_sample_bound {
            Some(old) if bound >= old => bound,
            Some(old) => 0.5 * old + 0.5 * bound,
            None => bound,
        });
        now
    }

    /// Copies the film and the ray counts into the software GPU's snapshot (`save`), or
    /// back from it.
    fn copy_film_and_ray_counts(&self, save: bool) {
        let Some((film_copy, rays_copy)) = &self.software_snapshot else { return };
        let mut encoder = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("snapshot") });
        for (live, copy) in [(&self.film, film_copy), (&self.ray_counts, rays_copy)] {
            let (from, to) = if save { (live, copy) } else { (copy, live) };
            encoder.copy_buffer_to_buffer(from, 0, to, 0, None);
        }
        self.ctx.queue.submit([encoder.finish()]);
    }

    /// How many pixels gained fewer samples than sample indices `sample_offset ..
    /// sample_offset + samples` give them (all of those, or those below the pixel's budget
    /// under adaptive sampling), the film compared with its snapshot. Non-finite samples
    /// count: they were taken, and rejected.
    fn pixels_short_of(&self, sample_offset: u32, samples: u32) -> Result<usize> {
        let Some((film_copy, _)) = &self.software_snapshot else { return Ok(0) };
        let after = self.read_back::<FilmPixel>(&self.film)?;
        let before = self.read_back::<FilmPixel>(film_copy)?;
        let taken = |p: &FilmPixel| p.count as u64 + p.rejected as u64;
        let budget = |i: usize| self.pixel_budgets.as_ref().map_or(u32::MAX, |b| b[i]);
        let expected = |i: usize| {
            let b = budget(i);
            (sample_offset.saturating_add(samples).min(b) - sample_offset.min(b)) as u64
        };
        Ok((0..after.len()).filter(|&i| taken(&after[i]) < taken(&before[i]) + expected(i)).count())
    }

    /// Calls of [`Backend::render`] taken again because a software GPU cut samples short
    /// ([`SOFTWARE_GPU_RETRY_SHRINK`]).
    pub fn software_retries(&self) -> u32 {
        self.software_retries
    }

    /// Makes every path-tracing dispatch take `samples` samples per pixel (or the call's
    /// remainder), as a device that misjudged its rate would, until a call on a software
    /// GPU comes back short; its retries are then sized by time again. A test sets it far
    /// past lavapipe's loop limit to see the lost samples taken again: a size set through
    /// the time budget depends on the rate measured, which a machine busy with other tests
    /// inflates until no dispatch meets the limit.
    pub fn force_software_dispatch_samples(&mut self, samples: u32) {
        self.forced_dispatch_samples = Some(samples.max(1));
    }
}

impl Backend for GpuBackend {
    fn name(&self) -> String {
        let caustics = if self.light_traces_caustics() { ", caustics light-traced" } else { "" };
        format!("gpu ({}{caustics})", self.ctx.name())
    }

    /// Adds samples in submits of about [`TARGET_SUBMIT_SECONDS`]: several samples per pixel
    /// per dispatch on a fast device, bands of rows on a slow one. Up to [`MAX_IN_FLIGHT`]
    /// submits are queued so the device never idles while the host waits for a completion
    /// (on lavapipe each wake-up costs tens of milliseconds). Each sample's random stream
    /// depends only on (pixel, sample index, seed), so the image does not depend on how the
    /// work was split. With light-traced caustics each sample index is one dispatch, after
    /// the light tracer's pass for that index.
    fn render(&mut self, sample_offset: u32, samples: u32) -> Result<()> {
        self.ensure_irradiance_cache()?;
        self.fold_rays_before(self.ray_bound_per_sample() * samples as u64)?;
        if self.settings.integrator == Integrator::Bdpt {
            return self.render_bdpt(sample_offset, samples);
        }
        if self.settings.integrator == Integrator::Sppm {
            return self.render_sppm(sample_offset, samples);
        }
        if self.settings.integrator == Integrator::Mlt {
            return self.render_mlt(sample_offset, samples);
        }
        self.build_photon_maps()?;
        if self.software_snapshot.is_none() {
            return self.render_samples(sample_offset, samples);
        }
        for _ in 0..SOFTWARE_GPU_TRIES {
            self.copy_film_and_ray_counts(true);
            let rates = (self.seconds_per_sample, self.seconds_per_sample_bound);
            self.render_samples(sample_offset, samples)?;
            let short = self.pixels_short_of(sample_offset, samples)?;
            if short == 0 {
                return Ok(());
            }
            // A group met lavapipe's loop limit: its pixels lost samples, and a lane on its
            // last sample may have finished it with a traversal cut short. Every sample of
            // the call is taken again, from the film as it was. The call's timings are
            // dropped too: a dispatch whose groups stopped early ran in less time than its
            // samples take, so its rate understates theirs, and kept, it would raise the
            // sample cap as fast as the shrink below lowers it (CI once ran out of tries
            // so, on a machine busy with other tests).
            self.seconds_per_sample = rates.0;
            self.seconds_per_sample_bound = rates.1;
            self.copy_film_and_ray_counts(false);
            self.software_group_seconds /= SOFTWARE_GPU_RETRY_SHRINK;
            self.forced_dispatch_samples = None;
            self.software_retries += 1;
        }
        Err(Error::Gpu(format!(
            "the software GPU cut samples {sample_offset}..{} short in {SOFTWARE_GPU_TRIES} tries, down to {:.3} ms per group of lanes (lavapipe's loop limit)",
            sample_offset + samples,
            self.software_group_seconds * 1e3
        )))
    }

    fn film(&mut self) -> Result<Film> {
        let pixels = self.read_back::<FilmPixel>(&self.film)?;
        let film = Film { width: self.settings.width, height: self.settings.height, pixels };
        if let Some(sums) = self.caustic_sums.as_ref().filter(|s| s.totals.passes() > 0) {
            let start = self.caustic_image_bytes();
            let bytes = film.pixels.len() as u64 * CAUSTIC_SUM_WORDS as u64 * 4;
            let words =
                self.ctx.read_buffer_range::<f32>(&self.caustics, start..start + bytes, SUBMIT_TIMEOUT)?;
            return Ok(sums.totals.fold_sums_into(&words, &film));
        }
        let Some(state) = self.sppm.as_ref().filter(|s| s.maps.is_none()) else { return Ok(film) };
        // The film holds the per-pass estimates; the image is the progressive estimate.
        let states: Vec<crate::integrator::sppm::SppmPixel> = self
            .read_back::<crate::scene::layout::SppmPixelGpu>(&state.pixels)?
            .into_iter()
            .map(Into::into)
            .collect();
        Ok(crate::integrator::sppm::sppm_film(&film, &states, state.passes, state.settings.photons))
    }

    fn rays_traced(&mut self) -> Result<u64> {
        self.fold_rays()?;
        // The cache's gathers were traced on the host.
        let cache_rays =
            self.irradiance_cache.as_ref().map_or(0, |c| c.stats.gather_rays + c.stats.overture_rays);
        let photon_rays = self.sppm_totals()?.map_or(0, |s| s.photon_rays);
        let mlt_rays = self.mlt_totals()?.map_or(0, |s| s.rays);
        Ok(self.rays_folded + cache_rays + photon_rays + mlt_rays)
    }

    fn sppm_stats(&mut self) -> Option<crate::integrator::sppm::SppmStats> {
        // A read-back failure is reported by the next render or read of the film.
        self.sppm_totals().ok().flatten()
    }

    fn render_rows(&mut self, sample_index: u32, rows: std::ops::Range<u32>) -> Result<()> {
        self.ensure_irradiance_cache()?;
        let rows = rows.start.min(self.settings.height)..rows.end.min(self.settings.height);
        if rows.is_empty() {
            return Ok(());
        }
        // One sample per pixel of the band; counted once per full pass for the fold bound.
        if rows.start == 0 {
            self.fold_rays_before(self.ray_bound_per_sample())?;
        }
        self.build_photon_maps()?;
        if let Some(state) = self.sppm.as_ref().filter(|s| s.maps.is_none()) {
            // The whole pass is taken for its first band (its photons land anywhere); the
            // other bands of the same pass have nothing left to do.
            if sample_index + 1 == state.passes {
                return Ok(());
            }
            let index = self.submit_sppm_pass(sample_index)?;
            return self.wait(index);
        }
        if self.settings.integrator == Integrator::Mlt {
            // As BDPT's: the whole pass is traced for its first band, each band resolved alone.
            if self.mlt.as_ref().and_then(|s| s.pass).map(|(pass, _)| pass) != Some(sample_index) {
                self.trace_mlt_pass(sample_index)?;
            }
            let index = self.submit_mlt_resolve(sample_index, rows);
            return self.wait(index);
        }
        if self.settings.integrator == Integrator::Bdpt {
            // The whole pass is traced for its first band (its splats land anywhere), in
            // bands of this band's height; each band is then resolved alone.
            if self.bdpt_pass != Some(sample_index) {
                self.submit_bdpt_pass(sample_index, rows.end - rows.start);
            }
            let index = self.submit_bdpt_resolve(sample_index, rows);
            return self.wait(index);
        }
        if self.light_traces_caustics() && self.caustic_pass != Some(sample_index) {
            // In bands of this band's height: a device slow enough to need bands would take
            // as long over a whole image's light paths in one dispatch.
            self.submit_caustic_pass(sample_index, rows.end - rows.start);
        }
        let params = self.frame_params(sample_index, 1, rows.start, rows.end - rows.start);
        self.dispatch(&self.kernel.render, params)
    }

    fn reset(&mut self) -> Result<()> {
        let mut encoder =
            self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("reset") });
        encoder.clear_buffer(&self.film, 0, None);
        encoder.clear_buffer(&self.ray_counts, 0, None);
        encoder.clear_buffer(&self.bdpt_state, 0, Some(16));
        // SPPM's passes start again; the photon-map integrator's maps stay as traced.
        if let Some(state) = self.sppm.as_mut().filter(|s| s.maps.is_none()) {
            encoder.clear_buffer(&state.pixels, 0, None);
            encoder.clear_buffer(&state.grid, 0, Some(SPPM_HEADER_WORDS * 4));
            state.passes = 0;
        }
        let image_bytes = self.caustic_image_bytes();
        if let Some(sums) = self.caustic_sums.as_mut() {
            encoder.clear_buffer(&self.caustics, image_bytes, None);
            sums.totals = CausticSums::new(0);
            // A pass the sums no longer hold is traced again when next asked for.
            self.caustic_pass = None;
        }
        if let Some(state) = self.mlt.as_mut() {
            encoder.clear_buffer(&state.counters, 0, None);
            state.clear_importance(&self.ctx.queue);
            state.pass = None;
            state.passes = 0;
            state.passes_without_light = 0;
            state.proposed = 0;
        }
        let index = self.ctx.queue.submit([encoder.finish()]);
        self.wait(index)?;
        self.rays_folded = 0;
        self.samples_since_fold = 0;
        self.bdpt_pass = None;
        self.bdpt_truncated = 0;
        Ok(())
    }

    fn irradiance_cache_stats(
        &mut self,
    ) -> Option<crate::integrator::irradiance_cache::IrradianceCacheStats> {
        self.irradiance_cache.as_ref().map(|c| c.stats)
    }

    fn irradiance_record_pixels(&mut self) -> Option<Vec<(u32, u32)>> {
        self.irradiance_cache.as_ref().map(|c| c.records().iter().map(|r| r.pixel).collect())
    }

    fn mlt_stats(&mut self) -> Option<crate::integrator::mlt::MltStats> {
        // A read-back failure is reported by the next render or read of the film.
        self.mlt_totals().ok().flatten()
    }

    fn bdpt_stats(&mut self) -> Option<BdptStats> {
        if self.settings.integrator != Integrator::Bdpt {
            return None;
        }
        // A read-back failure is reported by the next render or read of the film.
        self.fold_bdpt_truncated().ok()?;
        Some(BdptStats { truncated: self.bdpt_truncated })
    }

    fn aovs(&mut self) -> Result<Vec<PixelAov>> {
        self.render_aovs()
    }

    fn set_sample_budgets(&mut self, budgets: Option<&[u32]>) -> Result<()> {
        let pixels = self.settings.width as usize * self.settings.height as usize;
        self.pixel_budgets = budgets.map(<[u32]>::to_vec);
        self.sorted_budgets = budgets.map(|b| {
            let mut sorted = b.to_vec();
            sorted.sort_unstable();
            sorted
        });
        if !self.settings.adaptive {
            return Err(Error::Settings(
                "sample budgets for a GPU render not set up for them (RenderSettings::adaptive)".into(),
            ));
        }
        let unlimited;
        let budgets = match budgets {
            Some(b) if b.len() == pixels => b,
            Some(_) => return Err(Error::Settings(format!("sample budgets for {pixels} pixels expected"))),
            None => {
                unlimited = vec![u32::MAX; pixels];
                &unlimited
            }
        };
        self.ctx.queue.write_buffer(&self.budgets, 0, bytemuck::cast_slice(budgets));
        Ok(())
    }

    fn set_camera(&mut self, camera: &crate::scene::layout::Camera) -> Result<()> {
        self.camera = *camera;
        self.camera_sees_only_delta = false;
        self.caustic_pass = None;
        self.bdpt_pass = None;
        self.ctx.queue.write_buffer(&self.camera_buffer, 0, bytemuck::bytes_of(camera));
        // Records are placed where this camera's paths land.
        self.irradiance_cache = None;
        Ok(())
    }
}

/// The irradiance cache's placement passes on the device ([`IrradianceCache::build_on_device`]
/// runs the overture on the host around them).
///
/// [`IrradianceCache::build_on_device`]: crate::integrator::irradiance_cache::IrradianceCache::build_on_device
struct IcPlacement<'a> {
    backend: &'a mut GpuBackend,
}

/// Gather rays per dispatch: on lavapipe a few seconds of paths, on a GPU a small fraction
/// of a second (one path each, a few bounces).
const IC_GATHER_JOBS_PER_DISPATCH: u32 = 1 << 18;

impl IcPlacement<'_> {
    /// Binds `buffer` at `binding` (27 to 29) and makes the bind group again.
    fn bind(&mut self, binding: usize, buffer: wgpu::Buffer) {
        let b = &mut *self.backend;
        b.bind_buffers[binding] = buffer;
        b.bind_group = GpuBackend::make_bind_group(&b.ctx.device, &b.kernel, &b.bind_buffers);
    }

    /// A storage buffer of `bytes` for `binding`, checked against the device's limits.
    fn buffer(&self, what: &str, bytes: u64) -> Result<wgpu::Buffer> {
        let ctx = &self.backend.ctx;
        if bytes > ctx.limits.max_storage_buffer_binding_size || bytes > ctx.limits.max_buffer_size {
            return Err(Error::Gpu(format!(
                "the irradiance cache's {what} need {bytes} bytes, more than this device binds; \
                 lower --ic-rays or the image size"
            )));
        }
        Ok(ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(what),
            size: bytes.max(4),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        }))
    }
}

impl crate::integrator::irradiance_cache::GatherDevice for IcPlacement<'_> {
    fn first_vertices(&mut self) -> Result<Vec<crate::integrator::irradiance_cache::DeviceFirstVertex>> {
        use crate::integrator::irradiance_cache::{DeviceFirstVertex, DeviceVertex};
        use crate::scene::layout::{IcVertexGpu, INVALID_INDEX};
        let pixels = self.backend.settings.width as u64 * self.backend.settings.height as u64;
        let vertices = self.buffer("first vertices", pixels * std::mem::size_of::<IcVertexGpu>() as u64)?;
        self.bind(27, vertices);
        let b = &*self.backend;
        // One pixel's cone, as the CPU's overture (`first_lambertian_vertex`).
        let pipeline = b.ctx.ic_first_vertex_kernel(&b.kernel)?;
        b.dispatch(pipeline, b.one_pixel_cone_params())?;
        let found: Vec<IcVertexGpu> = b.read_back(&b.bind_buffers[27])?;
        Ok(found
            .iter()
            .map(|v| DeviceFirstVertex {
                found: (v.triangle != INVALID_INDEX).then(|| DeviceVertex {
                    p: v.p.into(),
                    frame: crate::geometry::Frame {
                        x: v.frame_x.into(),
                        y: v.frame_y.into(),
                        z: v.frame_z.into(),
                    },
                    footprint: v.footprint,
                }),
                rays: v.rays,
            })
            .collect())
    }

    fn gather_round(
        &mut self,
        pixel_indices: &[u32],
        round: u32,
    ) -> Result<Vec<crate::integrator::irradiance_cache::DeviceGatherRay>> {
        use crate::integrator::irradiance_cache::DeviceGatherRay;
        use crate::scene::layout::IcGatherResultGpu;
        let base = FrameParams {
            ic_gather_round: round,
            // The gathers' paths: no splitting, nothing light traced (`gather_settings`).
            splits: 1,
            light_traced_caustics: 0,
            ..self.backend.frame_params(0, 1, 0, self.backend.settings.height)
        };
        let m = base.ic_gather_polar_strata as u64;
        let jobs = pixel_indices.len() as u64 * m * 3 * m;
        if jobs > u32::MAX as u64 {
            return Err(Error::Gpu(format!("{jobs} irradiance-cache gather rays in one round: too many")));
        }
        // The bound buffers grow to the largest round so far.
        let pixel_bytes = std::mem::size_of_val(pixel_indices) as u64;
        if pixel_bytes > self.backend.bind_buffers[28].size() {
            let buffer = self.buffer("gather pixels", pixel_bytes)?;
            self.bind(28, buffer);
        }
        let result_bytes = jobs * std::mem::size_of::<IcGatherResultGpu>() as u64;
        if result_bytes > self.backend.bind_buffers[29].size() {
            let buffer = self.buffer("gather results", result_bytes)?;
            self.bind(29, buffer);
        }
        let b = &*self.backend;
        b.ctx.queue.write_buffer(&b.bind_buffers[28], 0, bytemuck::cast_slice(pixel_indices));
        let mut offset = 0u32;
        let mut last = None;
        while (offset as u64) < jobs {
            let count = (jobs - offset as u64).min(IC_GATHER_JOBS_PER_DISPATCH as u64) as u32;
            let params = FrameParams { ic_gather_jobs: count, ic_gather_job_offset: offset, ..base };
            last = Some(b.submit_groups(&b.kernel.render, params, b.item_groups(count)));
            offset += count;
        }
        if let Some(index) = last {
            b.wait(index)?;
        }
        let results: Vec<IcGatherResultGpu> =
            b.ctx.read_buffer_range(&b.bind_buffers[29], 0..result_bytes, SUBMIT_TIMEOUT)?;
        Ok(results
            .iter()
            .map(|r| DeviceGatherRay {
                radiance: r.radiance.into(),
                distance: if r.distance >= 0.0 { r.distance } else { f32::INFINITY },
                rays: r.rays,
            })
            .collect())
    }
}
