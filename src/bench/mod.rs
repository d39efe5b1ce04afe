//! Throughput benchmarks: scene preparation, BVH build, kernel build, and samples/s and
//! rays/s per backend (`pathlight bench`). Speed is measured here, never asserted in tests.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use glam::{DMat4, DQuat, DVec3, Vec3};

use crate::cpu::CpuBackend;
use crate::error::Result;
use crate::gpu::{GpuBackend, GpuContext};
use crate::scene::{FlatScene, MaterialDesc, Scene, SceneFeatures, ViewSettings};
use crate::{Backend, RenderSettings};

/// One measured configuration.
#[derive(Clone, Debug)]
pub struct BenchRow {
    pub scene: String,
    pub integrator: crate::integrator::Integrator,
    pub backend: String,
    /// Which kernel (GPU): the scene's specialised one or the general one.
    pub kernel: String,
    pub kernel_build_seconds: Option<f64>,
    pub spp: u32,
    pub seconds: f64,
    pub samples_per_second: f64,
    pub rays_per_second: f64,
}

/// Scene-preparation figures.
#[derive(Clone, Debug)]
pub struct PrepRow {
    pub scene: String,
    pub triangles: usize,
    pub load_seconds: f64,
    pub bvh_seconds: f64,
    pub bvh_nodes: usize,
    pub sah_cost: f64,
    pub features: String,
}

impl PrepRow {
    /// The markdown table's header lines for [`PrepRow::markdown`].
    pub const MARKDOWN_HEADER: &'static str = "| scene | triangles | load s | BVH build s | BVH nodes | SAH cost | features |\n|---|---:|---:|---:|---:|---:|---|";

    /// This row as a line of the markdown table.
    pub fn markdown(&self) -> String {
        format!(
            "| {} | {} | {:.3} | {:.3} | {} | {:.2} | {} |",
            self.scene,
            self.triangles,
            self.load_seconds,
            self.bvh_seconds,
            self.bvh_nodes,
            self.sah_cost,
            self.features
        )
    }
}

impl BenchRow {
    /// The markdown table's header lines for [`BenchRow::markdown`].
    pub const MARKDOWN_HEADER: &'static str = "| scene | integrator | backend | kernel | kernel build s | spp | seconds | Msamples/s | Mrays/s |\n|---|---|---|---|---:|---:|---:|---:|---:|";

    /// This row as a line of the markdown table.
    pub fn markdown(&self) -> String {
        format!(
            "| {} | {} | {} | {} | {} | {} | {:.2} | {:.3} | {:.2} |",
            self.scene,
            self.integrator,
            self.backend,
            self.kernel,
            self.kernel_build_seconds.map(|s| format!("{s:.3}")).unwrap_or_else(|| "-".into()),
            self.spp,
            self.seconds,
            self.samples_per_second / 1e6,
            self.rays_per_second / 1e6
        )
    }
}

pub mod pbrt;
pub mod peer;
pub mod series;

/// A second model placed in a benchmark scene, as [`BenchScene`] composes it.
#[derive(Clone, Debug)]
pub struct Insert {
    pub path: PathBuf,
    pub transform: DMat4,
    /// The Lambertian albedo it is given (scans and test meshes bring no usable material).
    pub white: f32,
}

/// A benchmark scene: a glTF file, and optionally a model from the shared assets placed
/// in it. The peer benchmark passes the same description to the Mitsuba converter, so the
/// composition has one source.
#[derive(Clone, Debug)]
pub struct BenchScene {
    pub name: String,
    pub base: PathBuf,
    pub insert: Option<Insert>,
}

impl BenchScene {
    /// Resolves a benchmark name: a scene in `scenes/` (e.g. `cornell-box`), a path, or a
    /// composed scene:
    ///
    /// * `bunny-in-cornell`: the Stanford bunny scan (69,451 triangles) standing on the
    ///   Cornell box's floor, white Lambertian;
    /// * `spheres-in-cornell`: the 1M-triangle MetalRoughSpheresNoTextures (a 7×7 grid of
    ///   spheres) standing upright in the Cornell box, facing the camera, white Lambertian.
    pub fn resolve(name: &str, root: &Path, assets: &Path) -> BenchScene {
        let cornell = root.join("scenes/cornell-box.gltf");
        let composed = |path: PathBuf, transform: DMat4| BenchScene {
            name: name.into(),
            base: cornell.clone(),
            insert: Some(Insert { path, transform, white: 0.75 }),
        };
        let turn = DMat4::from_quat(DQuat::from_rotation_y(std::f64::consts::PI));
        match name {
            // The scan is ~0.155 units tall with its base at y = 0.033; scale it to 0.39 m
            // and stand it in the middle of the floor.
            "bunny-in-cornell" => {
                let s = 2.5;
                composed(
                    assets.join("bvh/stanford-bunny.glb"),
                    DMat4::from_translation(DVec3::new(0.28, -0.033 * s, 0.28))
                        * turn
                        * DMat4::from_scale(DVec3::splat(s)),
                )
            }
            // The grid spans x −0.0009…0.0065, y −0.0010…0.0065, z −0.0033…0.0003 and faces
            // +z; scaled by 54 (0.40 m wide), turned to face the camera, 5 cm above the floor.
            "spheres-in-cornell" => composed(
                assets.join("khronos/MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb"),
                DMat4::from_translation(DVec3::new(0.428, 0.105, 0.22))
                    * turn
                    * DMat4::from_scale(DVec3::splat(54.0)),
            ),
            _ => {
                let base = if Path::new(name).exists() {
                    PathBuf::from(name)
                } else {
                    root.join("scenes").join(format!("{name}.gltf"))
                };
                BenchScene { name: name.into(), base, insert: None }
            }
        }
    }

    pub fn load(&self) -> Result<Scene> {
        let (mut scene, _) = crate::scene::load(&self.base)?;
        if let Some(insert) = &self.insert {
            let (model, _) = crate::scene::load(&insert.path)?;
            let white = MaterialDesc {
                name: format!("{} (white Lambertian)", insert.path.display()),
                base_color: Vec3::splat(insert.white),
                metallic: 0.0,
                roughness: 1.0,
                specular_factor: 0.0,
                ..MaterialDesc::default()
            };
            scene.append(&model, insert.transform, Some(white));
        }
        Ok(scene)
    }
}

/// Loads a benchmark scene by name (see [`BenchScene::resolve`]).
pub fn load_bench_scene(name: &str, root: &Path, assets: &Path) -> Result<Scene> {
    BenchScene::resolve(name, root, assets).load()
}

pub fn prepare(name: &str, scene: &Scene, aspect: f64, load_seconds: f64) -> Result<(FlatScene, PrepRow)> {
    let flat = FlatScene::build(scene, &ViewSettings { camera: None, aspect })?;
    let row = PrepRow {
        scene: name.into(),
        triangles: flat.triangles.len(),
        load_seconds,
        bvh_seconds: flat.bvh_stats.build_seconds,
        bvh_nodes: flat.bvh_stats.nodes,
        sah_cost: flat.bvh_stats.sah_cost,
        features: flat.features.describe(),
    };
    Ok((flat, row))
}

/// Renders `spp` samples per pixel after a one-sample warm-up (GPU: the first dispatches
/// probe the submit size) and measures the timed part only: (seconds, samples, rays).
fn measure(backend: &mut dyn Backend, spp: u32, pixels: u64) -> Result<(f64, u64, u64)> {
    backend.render(0, 1)?;
    let rays_before = backend.rays_traced()?;
    let start = Instant::now();
    backend.render(1, spp)?;
    let seconds = start.elapsed().as_secs_f64();
    let rays = backend.rays_traced()? - rays_before;
    Ok((seconds, pixels * spp as u64, rays))
}

/// Measures `flat` on the CPU and, if `gpu` is given, with its specialised kernel and with
/// the general (all-features) kernel.
pub fn bench_scene(
    name: &str,
    flat: &FlatScene,
    settings: &RenderSettings,
    gpu: Option<&Arc<GpuContext>>,
    cpu: bool,
) -> Result<Vec<BenchRow>> {
    let mut rows = Vec::new();
    let spp = settings.spp;
    let pixels = settings.width as u64 * settings.height as u64;
    let mut push =
        |backend: String, kernel: &str, build: Option<f64>, (seconds, samples, rays): (f64, u64, u64)| {
            rows.push(BenchRow {
                scene: name.into(),
                integrator: settings.integrator,
                backend,
                kernel: kernel.into(),
                kernel_build_seconds: build,
                spp,
                seconds,
                samples_per_second: samples as f64 / seconds,
                rays_per_second: rays as f64 / seconds,
            })
        };
    if cpu {
        let mut b = CpuBackend::new(flat, settings);
        let m = measure(&mut b, spp, pixels)?;
        push(b.name(), "-", None, m);
    }
    if let Some(ctx) = gpu {
        // The kernel `render` uses (specialised, its tables in the adapter's preferred forms)
        // and the general one (every feature, every table a storage buffer).
        let specialised = ctx.kernel_for_scene(flat, settings)?;
        let general = ctx.kernel(crate::gpu::KernelKey::new(
            settings.integrator,
            SceneFeatures::ALL,
            settings.splitting(),
        ))?;
        for (label, features, kernel) in
            [("specialised", flat.features, specialised), ("general", SceneFeatures::ALL, general)]
        {
            let build = kernel.build_seconds;
            let tables = kernel.key.tables.describe();
            let mut b = GpuBackend::with_kernel(ctx.clone(), kernel, flat, settings)?;
            let m = measure(&mut b, spp, pixels)?;
            push(ctx.name(), &format!("{label} [{}; {tables}]", features.describe()), Some(build), m);
        }
    }
    Ok(rows)
}

/// A short description of this machine for results files.
pub fn machine_description() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    format!("{cpu} ({}), {} threads for the CPU backend", vector_extensions(), rayon::current_num_threads())
}

/// The widest vector extension the CPU has and the one this build was compiled for. Both
/// belong in a results file: a peer that compiles its kernels at run time (Mitsuba 3's
/// LLVM variants) uses what the CPU has, pathlight what it was built for, and two runs on
/// hosts that differ here are not one comparison (`bench/history/peers.md`, third run).
pub fn vector_extensions() -> String {
    #[cfg(target_arch = "x86_64")]
    {
        // Widest first: (name, the CPU has it, this build was compiled for it).
        let extensions = [
            ("AVX-512", std::arch::is_x86_feature_detected!("avx512f"), cfg!(target_feature = "avx512f")),
            ("AVX2", std::arch::is_x86_feature_detected!("avx2"), cfg!(target_feature = "avx2")),
            ("AVX", std::arch::is_x86_feature_detected!("avx"), cfg!(target_feature = "avx")),
        ];
        let widest = |pick: fn(&(&str, bool, bool)) -> bool| {
            extensions.iter().find(|e| pick(e)).map_or("SSE2", |e| e.0)
        };
        format!("CPU has {}, pathlight built for {}", widest(|e| e.1), widest(|e| e.2))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        std::env::consts::ARCH.to_string()
    }
}
