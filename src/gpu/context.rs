//! Adapter discovery and the device, with the kernel cache.
//!
//! Only the Vulkan backend is used (`Backends::VULKAN`): it runs on real GPUs and on Mesa's
//! lavapipe alike, and skipping GL saves a second adapter and a second of start-up.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use crate::error::{Error, Result};
use crate::integrator::Integrator;
use crate::scene::{FlatScene, SceneFeatures};

use super::shader;
use super::tables::UniformTables;

/// The instance pathlight uses: Vulkan only; debug/validation flags follow the build and the
/// `WGPU_DEBUG` / `WGPU_VALIDATION` environment variables.
pub fn instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    desc.flags = wgpu::InstanceFlags::from_build_config().with_env();
    wgpu::Instance::new(desc)
}

/// Every Vulkan adapter on this machine.
pub fn enumerate_adapters() -> Vec<wgpu::Adapter> {
    pollster::block_on(instance().enumerate_adapters(wgpu::Backends::VULKAN))
}

/// A multi-line description of an adapter and the limits that matter to the renderer.
pub fn describe_adapter(adapter: &wgpu::Adapter) -> String {
    let info = adapter.get_info();
    let l = adapter.limits();
    let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
    format!(
        "{} ({:?}, {:?})\n  driver: {} {}\n  max storage buffer binding: {:.0} MiB, max buffer: {:.0} MiB, storage buffers per stage: {}\n  max uniform buffer binding: {} KiB, uniform buffers per stage: {}\n  max workgroup size: {}×{}×{} ({} invocations), workgroups per dimension: {}",
        info.name,
        info.device_type,
        info.backend,
        info.driver,
        info.driver_info,
        mib(l.max_storage_buffer_binding_size),
        mib(l.max_buffer_size),
        l.max_storage_buffers_per_shader_stage,
        l.max_uniform_buffer_binding_size / 1024,
        l.max_uniform_buffers_per_shader_stage,
        l.max_compute_workgroup_size_x,
        l.max_compute_workgroup_size_y,
        l.max_compute_workgroup_size_z,
        l.max_compute_invocations_per_workgroup,
        l.max_compute_workgroups_per_dimension,
    )
}

/// The adapter `--backend auto` renders on: the best hardware one (discrete, integrated,
/// virtual or other), or `None` when every adapter is a software rasteriser (device type CPU,
/// such as Mesa's lavapipe, which is several times slower than the CPU backend on the same
/// cores) or there is none.
pub fn hardware_adapter(adapters: &[wgpu::Adapter]) -> Option<wgpu::AdapterInfo> {
    adapters
        .iter()
        .map(|a| a.get_info())
        .filter(|i| i.device_type != wgpu::DeviceType::Cpu)
        .min_by_key(|i| type_rank(i.device_type))
}

fn type_rank(t: wgpu::DeviceType) -> u32 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

/// What a kernel is specialised to and cached under: the integrator whose WGSL it is
/// composed of, the scene features it keeps, whether it can split samples, its traversal's
/// short-stack limit and the forms it reads the scene's small tables in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct KernelKey {
    pub integrator: Integrator,
    pub features: SceneFeatures,
    /// Can it split samples (`RenderSettings::splits` > 1)? Built without, the kernel has
    /// no split vertex to keep live across its loop.
    pub splitting: bool,
    /// Deferred children the traversal keeps before it restarts from the root (`traverse`
    /// in shaders/bvh.wgsl); [`crate::bvh::SHORT_STACK_SIZE`] unless a test lowers it (the
    /// image must not depend on it).
    pub short_stack_limit: u32,
    pub tables: UniformTables,
    /// Does the path tracer read an irradiance cache (`RenderSettings::irradiance_cache`)?
    /// Built without, its lookup folds away.
    pub irradiance_cache: bool,
}

impl KernelKey {
    /// `integrator`'s kernel for scenes with `features`, able to split if `splitting`,
    /// reading every table from a storage buffer (so any scene with those features).
    pub fn new(integrator: Integrator, features: SceneFeatures, splitting: bool) -> KernelKey {
        KernelKey {
            integrator,
            features,
            splitting,
            short_stack_limit: crate::bvh::SHORT_STACK_SIZE as u32,
            tables: UniformTables::default(),
            irradiance_cache: false,
        }
    }
}

/// The compiled kernels for one [`KernelKey`].
pub struct Kernel {
    pub key: KernelKey,
    /// Each pass's per-pixel work: the path tracer's samples, bidirectional path tracing's
    /// traced pass, SPPM's visible points (`sppm_visible`), the photon-map integrator's
    /// samples (`photon_render`), Metropolis's bootstrap and chains (`mlt_render`).
    pub render: wgpu::ComputePipeline,
    /// Built on first use ([`GpuContext::first_hit_kernel`]).
    pub first_hit: std::sync::OnceLock<wgpu::ComputePipeline>,
    /// The irradiance cache's first-vertex pass (`ic_first_vertex`), built on first use
    /// ([`GpuContext::ic_first_vertex_kernel`]).
    pub ic_first_vertex: std::sync::OnceLock<wgpu::ComputePipeline>,
    /// The second pass that adds a traced pass to the film: bidirectional path tracing's
    /// (`bdpt_resolve` in shaders/bdpt.wgsl: the pass and its splats), SPPM's (`sppm_gather`
    /// in shaders/sppm.wgsl: the visible points' gathers), Metropolis's (`mlt_resolve`: the
    /// pass's splats). None for the others.
    pub resolve: Option<wgpu::ComputePipeline>,
    /// Photon mapping's map passes (SPPM's every pass, the photon-map integrator's once).
    pub photon_maps: Option<PhotonMapPipelines>,
    /// Wall time to build the `render` pipeline (override specialisation, SPIR-V generation
    /// and the driver's compile).
    pub build_seconds: f64,
    /// The module and layouts of `key.tables`' forms (a scene's bind group must match them).
    pub(crate) source: Arc<KernelModule>,
}

/// An integrator's shader module for one [`UniformTables`], with the bind-group and pipeline
/// layouts whose bindings 0, 1, 3 and 4 take the matching buffer types.
pub(crate) struct KernelModule {
    module: wgpu::ShaderModule,
    pub(crate) bind_group_layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
}

/// The bindings every kernel has, 0 to 26 of group 0 (shaders/bindings.wgsl,
/// src/gpu/tables.rs, 20, `bdpt_state` in shaders/bdpt.wgsl, which only that kernel
/// declares, and 21 and 23, `aovs` and `aov_refine_list` in shaders/aov.wgsl; 24 to 26 the
/// irradiance cache).
const KERNEL_BINDINGS: u32 = 27;

/// Photon mapping's own bindings, after those: 27 to 31 (shaders/sppm.wgsl).
const SPPM_BINDINGS: u32 = 5;

/// Metropolis's own bindings, after those: 27 to 31 (shaders/mlt.wgsl).
const MLT_BINDINGS: u32 = 5;

/// The path tracer's own, after those: 27 to 29, the irradiance cache's placement passes
/// (shaders/irradiance_cache.wgsl).
const IC_PLACEMENT_BINDINGS: u32 = 3;

/// The bindings of `integrator`'s kernel.
pub(crate) fn kernel_bindings(integrator: Integrator) -> u32 {
    match integrator {
        Integrator::Sppm | Integrator::Photon => KERNEL_BINDINGS + SPPM_BINDINGS,
        Integrator::Mlt => KERNEL_BINDINGS + MLT_BINDINGS,
        Integrator::Path => KERNEL_BINDINGS + IC_PLACEMENT_BINDINGS,
        Integrator::Bdpt => KERNEL_BINDINGS,
    }
}

/// Photon mapping's passes that trace photons into a map and build its grid, in the order
/// they run (shaders/sppm.wgsl explains each).
pub struct PhotonMapPipelines {
    pub trace_photons: wgpu::ComputePipeline,
    pub grid_setup: wgpu::ComputePipeline,
    pub grid_count: wgpu::ComputePipeline,
    pub scan_blocks: wgpu::ComputePipeline,
    pub scan_totals: wgpu::ComputePipeline,
    pub scan_add: wgpu::ComputePipeline,
    pub grid_scatter: wgpu::ComputePipeline,
}

/// The AOV passes' pipelines (shaders/aov.wgsl): the first pass over bands of the image, and
/// the refinement of a list of pixels.
#[derive(Clone)]
pub struct AovKernels {
    pub first: Arc<wgpu::ComputePipeline>,
    pub refine: Arc<wgpu::ComputePipeline>,
}

/// A device ready to render, with its compiled kernels.
pub struct GpuContext {
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// Errors wgpu reported outside any error scope (kept, then returned by `check`).
    uncaptured: Arc<Mutex<Vec<String>>>,
    /// Each integrator's module and layouts per table forms, made on first use.
    modules: BuiltOnce<(Integrator, UniformTables), Arc<KernelModule>>,
    kernels: BuiltOnce<KernelKey, Arc<Kernel>>,
    /// The light tracer's kernels (`trace_caustics`), by the scene features and table forms
    /// they were built for: built only for scenes whose caustics are light traced.
    caustic_kernels: BuiltOnce<(SceneFeatures, UniformTables), Arc<wgpu::ComputePipeline>>,
    /// Adaptive sampling's `accumulate_caustic_sums`, keyed as `caustic_kernels`.
    caustic_sum_kernels: BuiltOnce<(SceneFeatures, UniformTables), Arc<wgpu::ComputePipeline>>,
    /// The AOV passes (`aov` and `aov_refine` in shaders/aov.wgsl) per kernel, built on
    /// first use: a render that writes no AOVs never compiles one.
    aov_kernels: BuiltOnce<KernelKey, AovKernels>,
}

/// Things built on first use and kept, each key built once: a thread that asks for a key
/// another thread is building waits for that build, while builds of other keys go on beside
/// it. A kernel's build is single-threaded and takes seconds to a minute on lavapipe; with
/// one lock over the whole map (as until 2026-12-07) every build waited for every other, on
/// any number of cores. On this project's 2-core CI machine it gains little: there the other
/// test thread's lavapipe dispatches keep the second core busy anyway (the GPU tests with an
/// empty shader cache took 1,017 s against 1,098 s before, within the VM's spread;
/// `bench/history/lavapipe.md`). wgpu keeps error scopes per thread, so builds on two
/// threads do not see each other's errors. A build that fails keeps nothing: the next
/// caller tries again.
struct BuiltOnce<K, V> {
    slots: Mutex<HashMap<K, Arc<Mutex<Option<V>>>>>,
}

impl<K: std::hash::Hash + Eq + Copy, V: Clone> BuiltOnce<K, V> {
    fn new() -> Self {
        BuiltOnce { slots: Mutex::new(HashMap::new()) }
    }

    /// `key`'s value, built by `build` if no caller has built it yet.
    fn get_or_build(&self, key: K, build: impl FnOnce() -> Result<V>) -> Result<V> {
        // The map's lock is held only to find the key's slot; the slot's, through the build.
        let slot = self.slots.lock().unwrap_or_else(|p| p.into_inner()).entry(key).or_default().clone();
        let mut value = slot.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(v) = value.as_ref() {
            return Ok(v.clone());
        }
        let v = build()?;
        *value = Some(v.clone());
        Ok(v)
    }
}

/// The override values of the kernel `key` names: its scene features, its traversal's
/// short-stack limit, splitting, and (the path tracer's files only declare it) the
/// irradiance cache.
fn kernel_constants(key: KernelKey) -> Vec<(&'static str, f64)> {
    let mut constants = feature_constants(key.features);
    constants.push(("SHORT_STACK_LIMIT", key.short_stack_limit as f64));
    constants.push(("SPLITTING", if key.splitting { 1.0 } else { 0.0 }));
    if key.integrator == Integrator::Path {
        // Declared by the path tracer's files only (shaders/irradiance_cache.wgsl).
        constants.push(("IRRADIANCE_CACHE", if key.irradiance_cache { 1.0 } else { 0.0 }));
    }
    if key.integrator == Integrator::Mlt {
        // The samplers read a chain's primary sample (shaders/sampling.wgsl).
        constants.push(("MLT_SAMPLER", 1.0));
    }
    constants
}

/// The scene-feature overrides of shaders/features.wgsl for `features`.
fn feature_constants(features: SceneFeatures) -> Vec<(&'static str, f64)> {
    features.pipeline_constants().iter().map(|(name, on)| (*name, if *on { 1.0 } else { 0.0 })).collect()
}

impl GpuContext {
    /// Opens the best Vulkan adapter, or the first whose name contains `device_filter`
    /// (case-insensitive). Fails with a clear message when there is none.
    pub fn new(device_filter: Option<&str>) -> Result<GpuContext> {
        let mut adapters = enumerate_adapters();
        if adapters.is_empty() {
            return Err(Error::Gpu("no Vulkan adapter found".into()));
        }
        if let Some(filter) = device_filter {
            let want = filter.to_lowercase();
            let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
            adapters.retain(|a| a.get_info().name.to_lowercase().contains(&want));
            if adapters.is_empty() {
                return Err(Error::Gpu(format!(
                    "no Vulkan adapter matches --device '{filter}'; available: {}",
                    names.join(", ")
                )));
            }
        }
        adapters.sort_by_key(|a| type_rank(a.get_info().device_type));
        Self::from_adapter(adapters.into_iter().next().expect("non-empty"))
    }

    /// Opens `adapter` (a viewer picks one that can present to its window).
    pub fn from_adapter(adapter: wgpu::Adapter) -> Result<GpuContext> {
        let info = adapter.get_info();
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("pathlight"),
            required_features: wgpu::Features::empty(),
            // Everything the adapter offers: scenes may need its largest storage bindings.
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| Error::Gpu(format!("cannot open {}: {e}", info.name)))?;
        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        {
            let sink = uncaptured.clone();
            device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
                sink.lock().unwrap_or_else(|p| p.into_inner()).push(e.to_string());
            }));
        }

        let ctx = GpuContext {
            info,
            limits,
            device,
            queue,
            uncaptured,
            modules: BuiltOnce::new(),
            kernels: BuiltOnce::new(),
            caustic_kernels: BuiltOnce::new(),
            caustic_sum_kernels: BuiltOnce::new(),
            aov_kernels: BuiltOnce::new(),
        };
        // The path tracer's all-storage module now, so that a kernel the driver rejects
        // fails here.
        ctx.module(Integrator::Path, UniformTables::default())?;
        Ok(ctx)
    }

    /// `integrator`'s module and layouts reading the tables in the forms `tables`, made on
    /// first use.
    fn module(&self, integrator: Integrator, tables: UniformTables) -> Result<Arc<KernelModule>> {
        if !integrator.has_gpu_kernel() {
            return Err(Error::Settings(format!(
                "--integrator {integrator}: the GPU backend has no kernel for it yet; render it with --backend cpu"
            )));
        }
        self.modules.get_or_build((integrator, tables), || self.build_module(integrator, tables))
    }

    /// Builds `integrator`'s module and layouts for the table forms `tables` ([`Self::module`]).
    fn build_module(&self, integrator: Integrator, tables: UniformTables) -> Result<Arc<KernelModule>> {
        let device = &self.device;
        let source = shader::kernel_source(integrator, tables);
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("pathlight megakernel"),
            source: wgpu::ShaderSource::Wgsl(source.as_str().into()),
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            // wgpu parsed the composed source; naga again only to name the shader file and
            // line of the problem.
            let at = shader::parse_and_validate(&source, &shader::kernel_files(integrator))
                .err()
                .unwrap_or_default();
            return Err(Error::Gpu(format!("kernel rejected by wgpu: {e} {at}")));
        }

        let buffer = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
            count: None,
        };
        // Binding numbers as declared in shaders/bindings.wgsl and src/gpu/tables.rs. The
        // per-dispatch ones are storage buffers: lavapipe recompiles the kernel for every
        // re-bound uniform that steers its branches (see shaders/bindings.wgsl).
        // `film`, `first_hits`, `ray_counts`, `caustics`, `bdpt_state` and `aovs`, which the
        // kernels write, and each integrator's own (photon mapping's, Metropolis's, the
        // irradiance cache's placement).
        let read_write = [7, 8, 9, 19, 20, 21, 27, 28, 29, 30, 31];
        let entries: Vec<wgpu::BindGroupLayoutEntry> = (0..kernel_bindings(integrator))
            .map(|binding| {
                let ty = if tables.is_uniform(binding) {
                    wgpu::BufferBindingType::Uniform
                } else {
                    wgpu::BufferBindingType::Storage { read_only: !read_write.contains(&binding) }
                };
                buffer(binding, ty)
            })
            .collect();
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("pathlight bindings"),
            entries: &entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("pathlight"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        Ok(Arc::new(KernelModule { module, bind_group_layout, pipeline_layout }))
    }

    /// Does this adapter read small tables faster from uniform buffers than from storage
    /// buffers? Software rasterisers (lavapipe) do; on hardware GPUs storage buffers are the
    /// fast path (src/gpu/tables.rs explains both).
    pub fn prefers_uniform_tables(&self) -> bool {
        !self.is_hardware()
            && self.limits.max_uniform_buffer_binding_size >= super::tables::UNIFORM_TABLE_BYTES as u64
            && self.limits.max_uniform_buffers_per_shader_stage >= super::tables::TABLE_COUNT as u32
    }

    /// The table forms this adapter reads `scene` with: each table that fits in a uniform
    /// buffer where the adapter gains by it, the rest from storage buffers.
    pub fn tables_for(&self, scene: &FlatScene) -> UniformTables {
        if self.prefers_uniform_tables() {
            UniformTables::fitting(scene)
        } else {
            UniformTables::default()
        }
    }

    /// The key of the kernel `scene` renders with under `settings`: their integrator,
    /// specialised to the scene's features, reading its tables in the forms this adapter
    /// prefers ([`Self::tables_for`]), able to split if the settings split.
    pub fn kernel_key(&self, scene: &FlatScene, settings: &crate::RenderSettings) -> KernelKey {
        KernelKey {
            tables: self.tables_for(scene),
            irradiance_cache: settings.irradiance_cache.is_some(),
            ..KernelKey::new(settings.integrator, scene.features, settings.splitting())
        }
    }

    /// The kernels `scene` renders with under `settings` ([`Self::kernel_key`]).
    pub fn kernel_for_scene(
        &self,
        scene: &FlatScene,
        settings: &crate::RenderSettings,
    ) -> Result<Arc<Kernel>> {
        self.kernel(self.kernel_key(scene, settings))
    }

    /// The kernels for `key`, built on first use and cached.
    pub fn kernel(&self, key: KernelKey) -> Result<Arc<Kernel>> {
        self.kernels.get_or_build(key, || self.build_kernel(key))
    }

    /// Builds the kernels for `key` ([`Self::kernel`]).
    fn build_kernel(&self, key: KernelKey) -> Result<Arc<Kernel>> {
        let source = self.module(key.integrator, key.tables)?;
        let constants = kernel_constants(key);
        let render_entry = match key.integrator {
            Integrator::Sppm => "sppm_visible",
            Integrator::Photon => "photon_render",
            Integrator::Mlt => "mlt_render",
            Integrator::Path | Integrator::Bdpt => "render",
        };
        let (render, build_seconds) = self.build_pipeline(&source, render_entry, &constants)?;
        let build = |entry: &str| self.build_pipeline(&source, entry, &constants).map(|(p, _)| p);
        let resolve = match key.integrator {
            Integrator::Bdpt => Some(build("bdpt_resolve")?),
            Integrator::Sppm => Some(build("sppm_gather")?),
            Integrator::Mlt => Some(build("mlt_resolve")?),
            Integrator::Path | Integrator::Photon => None,
        };
        let photon_maps = match key.integrator {
            Integrator::Sppm | Integrator::Photon => Some(PhotonMapPipelines {
                trace_photons: build("sppm_trace_photons")?,
                grid_setup: build("sppm_grid_setup")?,
                grid_count: build("sppm_grid_count")?,
                scan_blocks: build("sppm_scan_blocks")?,
                scan_totals: build("sppm_scan_totals")?,
                scan_add: build("sppm_scan_add")?,
                grid_scatter: build("sppm_grid_scatter")?,
            }),
            Integrator::Path | Integrator::Bdpt | Integrator::Mlt => None,
        };
        let first_hit = std::sync::OnceLock::new();
        let ic_first_vertex = std::sync::OnceLock::new();
        Ok(Arc::new(Kernel {
            key,
            render,
            first_hit,
            ic_first_vertex,
            resolve,
            photon_maps,
            build_seconds,
            source,
        }))
    }

    /// `kernel`'s first-hit pass (`first_hit` in shaders/interaction.wgsl), built on first
    /// use: only tests and the first-hit AOV read it, and a render that does not need it
    /// should not wait for its build (on lavapipe a pipeline takes a second or more).
    pub fn first_hit_kernel<'k>(&self, kernel: &'k Kernel) -> Result<&'k wgpu::ComputePipeline> {
        self.built_on_first_use(kernel, &kernel.first_hit, "first_hit")
    }

    /// `kernel`'s irradiance-cache first-vertex pass (`ic_first_vertex` in
    /// shaders/irradiance_cache.wgsl; the path tracer's kernels only), built on first use:
    /// only a render with a cache runs it.
    pub fn ic_first_vertex_kernel<'k>(&self, kernel: &'k Kernel) -> Result<&'k wgpu::ComputePipeline> {
        self.built_on_first_use(kernel, &kernel.ic_first_vertex, "ic_first_vertex")
    }

    /// The pipeline of `kernel`'s entry point `entry`, kept in `cell` once built.
    fn built_on_first_use<'k>(
        &self,
        kernel: &Kernel,
        cell: &'k std::sync::OnceLock<wgpu::ComputePipeline>,
        entry: &str,
    ) -> Result<&'k wgpu::ComputePipeline> {
        if let Some(pipeline) = cell.get() {
            return Ok(pipeline);
        }
        let (pipeline, _) = self.build_pipeline(&kernel.source, entry, &kernel_constants(kernel.key))?;
        // Two threads may both build it; the first to finish is kept.
        let _ = cell.set(pipeline);
        Ok(cell.get().expect("set above"))
    }

    /// The light tracer's kernel (`trace_caustics` in shaders/light_tracing.wgsl)
    /// specialised to `features`, reading the tables in the forms `tables`, built on first
    /// use and cached.
    pub fn caustics_kernel(
        &self,
        features: SceneFeatures,
        tables: UniformTables,
    ) -> Result<Arc<wgpu::ComputePipeline>> {
        self.light_tracing_kernel(&self.caustic_kernels, "trace_caustics", features, tables)
    }

    /// Adaptive sampling's `accumulate_caustic_sums` (shaders/light_tracing.wgsl), built
    /// and cached as [`Self::caustics_kernel`].
    pub fn caustic_sums_kernel(
        &self,
        features: SceneFeatures,
        tables: UniformTables,
    ) -> Result<Arc<wgpu::ComputePipeline>> {
        self.light_tracing_kernel(&self.caustic_sum_kernels, "accumulate_caustic_sums", features, tables)
    }

    fn light_tracing_kernel(
        &self,
        cache: &BuiltOnce<(SceneFeatures, UniformTables), Arc<wgpu::ComputePipeline>>,
        entry: &str,
        features: SceneFeatures,
        tables: UniformTables,
    ) -> Result<Arc<wgpu::ComputePipeline>> {
        cache.get_or_build((features, tables), || {
            // The light tracer is the path tracer's partner: its entry points are in that kernel.
            let source = self.module(Integrator::Path, tables)?;
            let (pipeline, _) = self.build_pipeline(&source, entry, &feature_constants(features))?;
            Ok(Arc::new(pipeline))
        })
    }

    /// The AOV passes of `kernel`'s module, specialised to its features, built on first use
    /// and cached.
    pub fn aov_kernels(&self, kernel: &Kernel) -> Result<AovKernels> {
        self.aov_kernels.get_or_build(kernel.key, || {
            let constants = feature_constants(kernel.key.features);
            let (first, _) = self.build_pipeline(&kernel.source, "aov", &constants)?;
            let (refine, _) = self.build_pipeline(&kernel.source, "aov_refine", &constants)?;
            Ok(AovKernels { first: Arc::new(first), refine: Arc::new(refine) })
        })
    }

    /// Builds entry point `entry` of the kernel module `source` with the override values
    /// `constants`; returns it and the seconds it took.
    fn build_pipeline(
        &self,
        source: &KernelModule,
        entry: &str,
        constants: &[(&str, f64)],
    ) -> Result<(wgpu::ComputePipeline, f64)> {
        let start = Instant::now();
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let pipeline = self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&source.pipeline_layout),
            module: &source.module,
            entry_point: Some(entry),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                zero_initialize_workgroup_memory: false,
            },
            cache: None,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("building the {entry} kernel failed: {e}")));
        }
        Ok((pipeline, start.elapsed().as_secs_f64()))
    }

    /// Waits for submission `index`, then returns any error wgpu reported.
    pub(crate) fn wait_for(&self, index: wgpu::SubmissionIndex, timeout: std::time::Duration) -> Result<()> {
        self.device
            .poll(wgpu::PollType::Wait { submission_index: Some(index), timeout: Some(timeout) })
            .map_err(|e| Error::Gpu(format!("waiting for the GPU failed: {e}")))?;
        self.check()
    }

    /// Copies a GPU buffer back to the host.
    pub(crate) fn read_buffer<T: bytemuck::Pod>(
        &self,
        buffer: &wgpu::Buffer,
        timeout: std::time::Duration,
    ) -> Result<Vec<T>> {
        self.read_buffer_range(buffer, 0..buffer.size(), timeout)
    }

    /// Bytes `range` of a GPU buffer (multiples of 4), copied back to the host.
    pub(crate) fn read_buffer_range<T: bytemuck::Pod>(
        &self,
        buffer: &wgpu::Buffer,
        range: std::ops::Range<u64>,
        timeout: std::time::Duration,
    ) -> Result<Vec<T>> {
        let size = range.end - range.start;
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder =
            self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
        encoder.copy_buffer_to_buffer(buffer, range.start, &staging, 0, size);
        let index = self.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait_for(index, timeout)?;
        rx.recv_timeout(timeout)
            .map_err(|_| Error::Gpu("reading back from the GPU timed out".into()))?
            .map_err(|e| Error::Gpu(format!("reading back from the GPU failed: {e}")))?;
        let data = staging
            .slice(..)
            .get_mapped_range()
            .map_err(|e| Error::Gpu(format!("cannot map the readback buffer: {e}")))?;
        let out = bytemuck::cast_slice::<u8, T>(&data).to_vec();
        drop(data);
        staging.unmap();
        Ok(out)
    }

    /// Returns any error wgpu reported asynchronously since the last check.
    pub fn check(&self) -> Result<()> {
        let mut errors = self.uncaptured.lock().unwrap_or_else(|p| p.into_inner());
        if errors.is_empty() {
            Ok(())
        } else {
            let all = errors.join("; ");
            errors.clear();
            Err(Error::Gpu(all))
        }
    }

    /// A human-readable name: adapter and driver.
    pub fn name(&self) -> String {
        format!("{} ({} {})", self.info.name, self.info.driver, self.info.driver_info)
    }

    /// A hardware device, not a software rasteriser such as lavapipe (adapter type CPU).
    pub fn is_hardware(&self) -> bool {
        self.info.device_type != wgpu::DeviceType::Cpu
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicU32, Ordering};
    use std::sync::mpsc;
    use std::time::Duration;

    /// Two keys build at the same time: each build waits to hear that the other has begun,
    /// which it would never hear (and so time out and fail, not hang) were builds serialised.
    #[test]
    fn builds_of_different_keys_run_side_by_side() {
        let cache = BuiltOnce::<u32, u32>::new();
        let (to_b, from_a) = mpsc::channel();
        let (to_a, from_b) = mpsc::channel();
        let build = |me: u32, tell: mpsc::Sender<()>, hear: mpsc::Receiver<()>| {
            move || {
                tell.send(()).unwrap();
                hear.recv_timeout(Duration::from_secs(10))
                    .map(|_| me * 10)
                    .map_err(|_| Error::Gpu("the other key's build never began beside this one".into()))
            }
        };
        let (a, b) = std::thread::scope(|s| {
            let a = s.spawn(|| cache.get_or_build(1, build(1, to_b, from_b)));
            let b = s.spawn(|| cache.get_or_build(2, build(2, to_a, from_a)));
            (a.join().unwrap(), b.join().unwrap())
        });
        assert_eq!((a.unwrap(), b.unwrap()), (10, 20));
    }

    /// One key is built once however many threads ask for it; a failed build keeps nothing.
    #[test]
    fn a_key_is_built_once_and_a_failure_is_not_kept() {
        let cache = BuiltOnce::<u32, u32>::new();
        let builds = AtomicU32::new(0);
        std::thread::scope(|s| {
            for _ in 0..4 {
                s.spawn(|| {
                    let v = cache.get_or_build(7, || {
                        builds.fetch_add(1, Ordering::SeqCst);
                        std::thread::sleep(Duration::from_millis(20));
                        Ok(70)
                    });
                    assert_eq!(v.unwrap(), 70);
                });
            }
        });
        assert_eq!(builds.load(Ordering::SeqCst), 1);
        assert!(cache.get_or_build(8, || Err(Error::Gpu("no".into()))).is_err());
        assert_eq!(cache.get_or_build(8, || Ok(80)).unwrap(), 80);
    }
}
