//! The GPU megakernel against the CPU reference, on lavapipe in CI: every bundled scene by
//! a z-test and to rounding with the same seed (here), textured scenes (`textures`), and
//! kernel variants that must leave the image's bits alone (`kernel_variants`).

mod bdpt;
#[path = "../common/mod.rs"]
mod common;
mod kernel_variants;
mod mlt;
mod sppm;
mod textures;

use std::path::PathBuf;

use glam::Vec3;
use pathlight::cpu::CpuBackend;
use pathlight::film::{write_exr, Film, RenderMetadata};
use pathlight::gpu::{GpuBackend, KernelKey};
use pathlight::integrator::Integrator;
use pathlight::stats::{normal_two_sided_threshold, sidak_alpha};
use pathlight::{Backend, RenderSettings};

/// Where failing comparisons leave their images.
fn failure_dir(name: &str) -> PathBuf {
    let d = common::root().join("target").join("gpu-cpu-diff").join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Outcome of comparing two independent renders of the same scene.
struct Comparison {
    channels: usize,
    failed: usize,
    z_threshold: f64,
    /// Per channel: z-score of the difference of the two image means.
    global_z: [f64; 3],
    z_map: Vec<Vec3>,
}

/// Per-pixel-channel z-test on the difference of means, z = (a − b) / √(var_a + var_b)
/// with each var the estimated variance of that pixel's mean; Šidák-corrected at
/// α = 0.01 over all channels. Channels where both variances are 0 must agree exactly.
fn compare(a: &Film, b: &Film) -> Comparison {
    let (ma, va, mb, vb) = (a.mean(), a.variance_of_mean(), b.mean(), b.variance_of_mean());
    let channels = ma.len() * 3;
    let z_threshold = normal_two_sided_threshold(sidak_alpha(0.01, channels));
    let mut failed = 0;
    let mut z_map = Vec::with_capacity(ma.len());
    // Per channel: pixels are independent, a pixel's channels are not.
    let (mut sum_diff, mut sum_var) = ([0.0f64; 3], [0.0f64; 3]);
    for i in 0..ma.len() {
        let mut zs = [0.0f32; 3];
        for c in 0..3 {
            let d = (ma[i][c] - mb[i][c]) as f64;
            let v = (va[i][c] + vb[i][c]) as f64;
            sum_diff[c] += d;
            sum_var[c] += v;
            let z = if v > 0.0 {
                d / v.sqrt()
            } else if d == 0.0 {
                0.0
            } else {
                f64::INFINITY
            };
            if z.abs() > z_threshold {
                failed += 1;
            }
            zs[c] = z as f32;
        }
        z_map.push(Vec3::from(zs));
    }
    let global_z = [0, 1, 2].map(|c| if sum_var[c] > 0.0 { sum_diff[c] / sum_var[c].sqrt() } else { 0.0 });
    Comparison { channels, failed, z_threshold, global_z, z_map }
}

fn settings(size: u32, spp: u32, seed: u32) -> RenderSettings {
    RenderSettings { width: size, height: size, spp, seed, ..RenderSettings::default() }
}

/// Renders `scene` on both backends with different seeds (independent estimates) and checks
/// they agree statistically. On failure, the images and the |z| map go to a named folder.
fn gpu_matches_cpu(file: &str, size: u32, spp: u32) {
    gpu_matches_cpu_scene(file, &common::flat_scene(&common::scene(file), size, size), size, spp);
}

/// [`gpu_matches_cpu`] on a scene already flattened (e.g. with an environment attached);
/// `file` names it in messages and in the failure folder.
fn gpu_matches_cpu_scene(file: &str, scene: &pathlight::scene::FlatScene, size: u32, spp: u32) {
    let Some(ctx) = common::gpu() else { return };
    let cpu = common::render(&mut CpuBackend::new(scene, &settings(size, spp, 1)), spp);
    let mut gpu_backend = GpuBackend::new(ctx, scene, &settings(size, spp, 2)).unwrap();
    let gpu = common::render(&mut gpu_backend, spp);
    assert_eq!(gpu.total_samples(), (size * size * spp) as u64 - gpu.total_rejected());
    assert_comparable(file, &cpu, &gpu, size);
}

/// Two independent renders `cpu` and `gpu` of scene `file` (`size`²) agree statistically;
/// on failure their images and the |z| map go to a named folder.
fn assert_comparable(file: &str, cpu: &Film, gpu: &Film, size: u32) {
    let c = compare(cpu, gpu);
    let pass_fraction = 1.0 - c.failed as f64 / c.channels as f64;
    eprintln!(
        "{file}: {}/{} pixel channels beyond |z| = {:.2}; global z per channel = {:.2?}; rejected cpu {} gpu {}",
        c.failed,
        c.channels,
        c.z_threshold,
        c.global_z,
        cpu.total_rejected(),
        gpu.total_rejected()
    );
    // ≥ 99.5% of channels pass the corrected per-pixel test (a few pixels of heavy-tailed
    // caustic noise have underestimated variances), and each channel's image means agree
    // within 5 standard errors (a bias too small to see per pixel shows here; 5σ rather than
    // a Šidák level because those standard errors are themselves estimates, slightly
    // optimistic under heavy tails).
    let ok = pass_fraction >= 0.995 && c.global_z.iter().all(|z| z.abs() < 5.0);
    if !ok {
        let dir = failure_dir(file.trim_end_matches(".gltf"));
        let meta = RenderMetadata::default();
        write_exr(cpu, &meta, &dir.join("cpu.exr")).unwrap();
        write_exr(gpu, &meta, &dir.join("gpu.exr")).unwrap();
        let abs_z: Vec<Vec3> = c.z_map.iter().map(|z| z.abs() / c.z_threshold as f32).collect();
        common::write_debug_png(&dir.join("z.png"), size as usize, size as usize, &abs_z, 1.0);
        panic!(
            "{file}: GPU and CPU disagree: {:.2}% of channels pass (need 99.5%), global z per channel = {:.2?}; images and |z| map (white = at the threshold) in {}",
            pass_fraction * 100.0,
            c.global_z,
            dir.display()
        );
    }
}

/// With the same seed both backends draw the same random numbers and perform the same
/// arithmetic, so their images differ only by floating-point rounding (FMA contraction,
/// transcendental functions), except where rounding flips a branch (a lobe choice, a
/// roulette decision) and a path diverges: measured at ≤ 0.3% of pixels at 16 spp. This
/// paired test sees any systematic difference between the kernels in more than 1% of the
/// image, far below what the independent-seed z-test can resolve at a test's sample count.
fn same_seed_agrees(file: &str) {
    same_seed_agrees_scene(file, &common::flat_scene(&common::scene(file), 32, 32), 1e-3);
}

/// [`same_seed_agrees`] on a scene already flattened for 32×32, pixels compared to
/// `tolerance` relative (1e-3 for the reasons above; see the callers for larger ones).
fn same_seed_agrees_scene(file: &str, scene: &pathlight::scene::FlatScene, tolerance: f32) {
    same_seed_agrees_with(file, scene, tolerance, &settings(32, 16, 9));
}

/// [`same_seed_agrees_scene`] at settings `s` (32×32, 16 spp with other splitting or
/// sampler).
fn same_seed_agrees_with<'a>(
    file: &str,
    scene: &'a pathlight::scene::FlatScene,
    tolerance: f32,
    s: &RenderSettings,
) -> Option<(CpuBackend<'a>, GpuBackend)> {
    same_seed_agrees_within(file, scene, tolerance, 1, s)
}

/// [`same_seed_agrees_with`], with up to `percent` % of the pixels allowed to differ by more
/// than `tolerance`. Returns the two backends after their renders (for what else a test
/// compares), or `None` without a GPU.
fn same_seed_agrees_within<'a>(
    file: &str,
    scene: &'a pathlight::scene::FlatScene,
    tolerance: f32,
    percent: usize,
    s: &RenderSettings,
) -> Option<(CpuBackend<'a>, GpuBackend)> {
    same_seed_agrees_on_kernel(file, scene, tolerance, percent, s, None)
}

/// [`same_seed_agrees_within`], the GPU rendering with `kernel` where one is given (else
/// with the kernel specialised to the scene).
fn same_seed_agrees_on_kernel<'a>(
    file: &str,
    scene: &'a pathlight::scene::FlatScene,
    tolerance: f32,
    percent: usize,
    s: &RenderSettings,
    kernel: Option<std::sync::Arc<pathlight::gpu::Kernel>>,
) -> Option<(CpuBackend<'a>, GpuBackend)> {
    let ctx = common::gpu()?;
    let (size, spp) = (s.width, s.spp);
    assert_eq!((size, s.height), (32, 32), "scenes are flattened for 32×32");
    let mut cpu = CpuBackend::new(scene, s);
    let mut gpu = match kernel {
        Some(kernel) => GpuBackend::with_kernel(ctx, kernel, scene, s).unwrap(),
        None => GpuBackend::new(ctx, scene, s).unwrap(),
    };
    let a = common::render(&mut cpu, spp);
    let b = common::render(&mut gpu, spp);
    let mut disagree = Vec::new();
    for (i, (x, y)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        let (x, y) = (Vec3::from(x.mean), Vec3::from(y.mean));
        // 1e-3 relative: rounding differences of a few ulps per operation, accumulated over
        // a path of tens of operations per bounce, stay below 1e-4 in 99.7% of pixels.
        let scale = x.max_element().max(y.max_element()).max(1e-6);
        if (x - y).abs().max_element() > tolerance * scale {
            disagree.push((i % size as usize, i / size as usize, x, y));
        }
    }
    eprintln!(
        "{file}: {} of {} pixels differ by more than {tolerance:e} with the same seed",
        disagree.len(),
        size * size
    );
    assert!(
        disagree.len() * 100 <= percent * (size * size) as usize,
        "{file}: with the same seed, {} of {} pixels differ by more than rounding, e.g. {:?}",
        disagree.len(),
        size * size,
        &disagree[..disagree.len().min(5)]
    );
    Some((cpu, gpu))
}

/// Every bundled scene; `every_bundled_scene_is_compared` keeps this list honest.
const SCENES: &[&str] = &[
    "cornell-box.gltf",
    "cornell-spheres.gltf",
    "furnace-0.5.gltf",
    "furnace-0.9.gltf",
    "glossy-metal.gltf",
    "glass-smooth.gltf",
    "glass-rough.gltf",
    "punctual.gltf",
    "env-furnace.gltf",
    "env-objects.gltf",
    "lamp-shade-room.gltf",
    "slit-room.gltf",
];

#[test]
fn every_bundled_scene_is_compared() {
    let mut on_disk: Vec<String> = std::fs::read_dir(common::root().join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".gltf") || n.ends_with(".glb"))
        .collect();
    on_disk.sort();
    let mut listed: Vec<String> = SCENES.iter().map(|s| s.to_string()).collect();
    listed.sort();
    assert_eq!(
        on_disk, listed,
        "tests/gpu.rs SCENES must list every scene in scenes/ (and each needs a *_gpu_matches_cpu test)"
    );
}

#[test]
fn same_seed_renders_agree_to_rounding() {
    for file in SCENES {
        same_seed_agrees(file);
    }
}

/// Split samples: the kernel starts a sample's continuations one after another from the
/// vertex it saved, the CPU in a loop; both draw each continuation's numbers from the same
/// split streams (Sobol and independent alike), so the renders agree to rounding as unsplit
/// ones do. Scenes with a split vertex behind glass, with roulette, and with an environment.
#[test]
fn split_renders_agree_to_rounding() {
    use pathlight::sampling::SamplerKind;
    for file in ["cornell-box.gltf", "cornell-spheres.gltf", "glass-rough.gltf", "env-objects.gltf"] {
        let scene = common::flat_scene(&common::scene(file), 32, 32);
        for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
            let s = RenderSettings { splits: 3, sampler, ..settings(32, 16, 9) };
            same_seed_agrees_with(file, &scene, 1e-3, &s);
        }
    }
}

/// Light-traced caustics: the kernel traces the CPU's light paths from the same streams and
/// sums their splats in the same fixed point, so the renders agree to rounding as path-traced
/// ones do; a light path that rounding diverges moves a few splats, within the 1% of pixels
/// the test allows. Both samplers (the light paths always draw independent numbers), a
/// mirror's caustic and the glass scene's.
#[test]
fn light_traced_renders_agree_to_rounding() {
    use pathlight::sampling::SamplerKind;
    let Some(ctx) = common::gpu() else { return };
    for file in ["cornell-spheres.gltf", "hard/caustic-mirror.gltf"] {
        let scene = common::flat_scene(&common::scene(file), 32, 32);
        for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
            let s = RenderSettings { sampler, light_tracing: true, ..settings(32, 16, 9) };
            let gpu = GpuBackend::new(ctx.clone(), &scene, &s).unwrap();
            assert!(gpu.light_traces_caustics(), "{file}: {}", gpu.name());
            same_seed_agrees_with(file, &scene, 1e-3, &s);
        }
    }
}

/// The irradiance cache (issue 46): the GPU backend places its records with its own passes
/// (first vertices and gather rays on the device, from the CPU's streams; the phases,
/// reductions and grid on the host) and its kernel reads them in the host's order, so with
/// the same seed the records' count and placing pixels are the CPU's and the cached renders
/// agree to rounding on every bundled scene; a record the rounding moves across a validity
/// boundary changes a few pixels, within the 1% the test allows. Sobol numbers on every
/// scene and independent ones on three (the cache reads its numbers through the same
/// sampler interface either way; both samplers on all twelve took 85 s of CI's GPU tests
/// with a warm shader cache); and a camera set later places the records again, for the new
/// view, on both backends.
#[test]
fn irradiance_cache_renders_agree_to_rounding() {
    use pathlight::integrator::irradiance_cache::IrradianceCacheSettings;
    use pathlight::sampling::SamplerKind;
    let Some(ctx) = common::gpu() else { return };
    for file in SCENES {
        let scene = common::flat_scene(&common::scene(file), 32, 32);
        let mut samplers = vec![SamplerKind::Sobol];
        if ["cornell-box.gltf", "punctual.gltf", "env-objects.gltf"].contains(file) {
            samplers.push(SamplerKind::Independent);
        }
        for sampler in samplers {
            let s = RenderSettings {
                sampler,
                irradiance_cache: Some(IrradianceCacheSettings::default()),
                ..settings(32, 16, 9)
            };
            let (mut cpu, mut gpu) = same_seed_agrees_with(file, &scene, 1e-3, &s).expect("a GPU");
            assert_eq!(cpu.irradiance_record_pixels(), gpu.irradiance_record_pixels(), "{file}");
            // The device traced the same overture paths and the same gather rounds: a path the
            // rounding lengthens or shortens changes the ray counts by a few (measured on the
            // Cornell box at 64²: 6 of 1,968,661); 0.1% would be a record's extra round.
            let (c, g) = (cpu.irradiance_cache_stats().unwrap(), gpu.irradiance_cache_stats().unwrap());
            assert_eq!(c.overture_rays, g.overture_rays, "{file}");
            let drift = (c.gather_rays as f64 - g.gather_rays as f64).abs() / c.gather_rays.max(1) as f64;
            assert!(drift < 1e-3, "{file}: gather rays {} (CPU) vs {} (GPU)", c.gather_rays, g.gather_rays);
        }
    }
    // A new camera: nearer the scene, the records land elsewhere, on both backends alike.
    let scene = common::flat_scene(&common::scene("cornell-box.gltf"), 32, 32);
    let mut camera = scene.camera;
    camera.position = (Vec3::from(camera.forward) * 0.3 * scene.scene_radius).to_array();
    let s =
        RenderSettings { irradiance_cache: Some(IrradianceCacheSettings::default()), ..settings(32, 4, 9) };
    let mut cpu = CpuBackend::new(&scene, &s);
    let mut gpu = GpuBackend::new(ctx.clone(), &scene, &s).unwrap();
    common::render(&mut cpu, 1);
    let before = cpu.irradiance_record_pixels();
    for backend in [&mut cpu as &mut dyn Backend, &mut gpu] {
        backend.set_camera(&camera).unwrap();
        backend.reset().unwrap();
    }
    let (a, b) = (common::render(&mut cpu, 4), common::render(&mut gpu, 4));
    assert_ne!(before, cpu.irradiance_record_pixels(), "the records did not move with the camera");
    assert_eq!(cpu.irradiance_record_pixels(), gpu.irradiance_record_pixels());
    for (x, y) in a.pixels.iter().zip(&b.pixels) {
        let (x, y) = (Vec3::from(x.mean), Vec3::from(y.mean));
        // The same bound as `same_seed_agrees_with`, here on every pixel of a matte box.
        assert!((x - y).abs().max_element() <= 1e-3 * x.max_element().max(y.max_element()).max(1e-6));
    }
}

#[test]
fn cornell_box_gpu_matches_cpu() {
    gpu_matches_cpu("cornell-box.gltf", 32, 128);
}

#[test]
fn lamp_shade_room_gpu_matches_cpu() {
    // Lit only by way of the ceiling: rare bright paths, so more samples than the box.
    gpu_matches_cpu("lamp-shade-room.gltf", 24, 512);
}

#[test]
fn slit_room_gpu_matches_cpu() {
    // Lit only through a 2 cm slit: rarer bright paths still than the lamp room's.
    gpu_matches_cpu("slit-room.gltf", 24, 512);
}

#[test]
fn cornell_spheres_gpu_matches_cpu() {
    gpu_matches_cpu("cornell-spheres.gltf", 32, 128);
}

#[test]
fn furnace_gpu_matches_cpu() {
    gpu_matches_cpu("furnace-0.5.gltf", 24, 64);
}

#[test]
fn furnace_0_9_gpu_matches_cpu() {
    gpu_matches_cpu("furnace-0.9.gltf", 24, 64);
}

#[test]
fn glossy_metal_gpu_matches_cpu() {
    gpu_matches_cpu("glossy-metal.gltf", 32, 128);
}

#[test]
fn smooth_glass_gpu_matches_cpu() {
    gpu_matches_cpu("glass-smooth.gltf", 32, 128);
}

#[test]
fn rough_glass_gpu_matches_cpu() {
    gpu_matches_cpu("glass-rough.gltf", 32, 128);
}

#[test]
fn punctual_lights_gpu_matches_cpu() {
    gpu_matches_cpu("punctual.gltf", 32, 128);
}

#[test]
fn first_hits_agree() {
    let Some(ctx) = common::gpu() else { return };
    for file in ["cornell-box.gltf", "glossy-metal.gltf", "glass-smooth.gltf"] {
        let size = 48;
        let scene = common::flat_scene(&common::scene(file), size, size);
        let mut gpu = GpuBackend::new(ctx.clone(), &scene, &settings(size, 1, 3)).unwrap();
        let gpu_hits = gpu.first_hits().unwrap();
        let mut mismatches = 0;
        for y in 0..size {
            for x in 0..size {
                let g = &gpu_hits[(y * size + x) as usize];
                let c = pathlight::integrator::first_hit(&scene, size, size, x, y, 3);
                // Same ray, same triangle test: the hit triangle matches except where a ray
                // grazes an edge shared by two triangles (a tie decided by rounding).
                if g.triangle != c.triangle {
                    mismatches += 1;
                    continue;
                }
                if c.triangle == u32::MAX {
                    continue;
                }
                // Distance: both compute it in f32 through the same operations, but GPU
                // FMA contraction and division differ by a few ulps: 1e-5 relative.
                assert!(
                    (g.distance - c.distance).abs() <= 1e-5 * c.distance,
                    "{file} ({x},{y}): distance {} vs {}",
                    g.distance,
                    c.distance
                );
                // Normals: decoding and interpolation differ by rounding only.
                let dot = Vec3::from(g.normal).dot(Vec3::from(c.normal));
                assert!(dot > 1.0 - 1e-5, "{file} ({x},{y}): normals {:?} vs {:?}", g.normal, c.normal);
                assert_eq!(g.albedo, c.albedo, "{file} ({x},{y}): albedo");
            }
        }
        // Edge ties: at most 0.5% of pixels.
        assert!(mismatches * 200 <= size * size, "{file}: {mismatches} pixels hit different triangles");
    }
}

#[test]
fn furnace_on_gpu_is_analytic() {
    let Some(ctx) = common::gpu() else { return };
    for (file, albedo) in [("furnace-0.5.gltf", 0.5), ("furnace-0.9.gltf", 0.9)] {
        let (size, spp) = (32, 96);
        let scene = common::flat_scene(&common::scene(file), size, size);
        let film =
            common::render(&mut GpuBackend::new(ctx.clone(), &scene, &settings(size, spp, 11)).unwrap(), spp);
        let exact = 1.0 / (1.0 - albedo);
        for (mean, se) in common::image_mean_and_standard_error(&film) {
            eprintln!("GPU furnace ρ = {albedo}: mean {mean:.5} ± {se:.5} (exact {exact})");
            // 4 standard errors: false failure probability 6e-5.
            assert!(
                (mean - exact).abs() < 4.0 * se,
                "GPU furnace ρ = {albedo}: {mean} ± {se}, exact {exact}"
            );
            assert!(se < 0.01 * exact);
        }
    }
}

#[test]
fn specialised_and_general_kernels_agree() {
    // The all-features kernel renders the Cornell box like the specialised one: switching
    // code off must not change the image. Same seed, so the paths are the same samples; they
    // differ only by rounding in code the specialised kernel omits.
    let Some(ctx) = common::gpu() else { return };
    let scene = common::flat_scene(&common::scene("cornell-box.gltf"), 24, 24);
    let general =
        ctx.kernel(KernelKey::new(Integrator::Path, pathlight::scene::SceneFeatures::ALL, true)).unwrap();
    let a = common::render(&mut GpuBackend::new(ctx.clone(), &scene, &settings(24, 8, 5)).unwrap(), 8);
    let b = common::render(
        &mut GpuBackend::with_kernel(ctx.clone(), general, &scene, &settings(24, 8, 5)).unwrap(),
        8,
    );
    let c = compare(&a, &b);
    assert!(
        c.failed == 0 && c.global_z.iter().all(|z| z.abs() < 1.0),
        "{} channels differ, global z {:?}",
        c.failed,
        c.global_z
    );
}

#[test]
fn missing_gpu_fails_in_ci_and_skips_loudly_elsewhere() {
    if std::env::var("PATHLIGHT_META_TEST").is_ok() {
        return; // the child processes below must not recurse
    }
    let exe = std::env::current_exe().unwrap();
    let run = |ci: Option<&str>| {
        let mut c = std::process::Command::new(&exe);
        c.args(["--exact", "furnace_on_gpu_is_analytic", "--nocapture"])
            .env("PATHLIGHT_META_TEST", "1")
            // Hide every Vulkan driver from the loader.
            .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
            .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
            .env_remove("CI");
        if let Some(v) = ci {
            c.env("CI", v);
        }
        c.output().unwrap()
    };
    let in_ci = run(Some("true"));
    let text = String::from_utf8_lossy(&in_ci.stderr).into_owned() + &String::from_utf8_lossy(&in_ci.stdout);
    assert!(!in_ci.status.success(), "with CI=true a missing GPU must fail the test: {text}");
    assert!(text.contains("CI=true but no usable GPU"), "{text}");
    let local = run(None);
    let text = String::from_utf8_lossy(&local.stderr).into_owned() + &String::from_utf8_lossy(&local.stdout);
    assert!(local.status.success(), "without CI a missing GPU skips: {text}");
    assert!(text.contains("SKIPPED: no usable GPU"), "the skip must be loud: {text}");
}

#[test]
fn a_film_too_large_for_the_device_is_a_clear_error() {
    let Some(ctx) = common::gpu() else { return };
    let scene = common::flat_scene(&common::scene("cornell-box.gltf"), 1, 1);
    // 4096² pixels × 32 bytes = 512 MiB of film; lavapipe binds at most 128 MiB. On a device
    // whose binding limit is larger, use a size past that limit instead.
    let max = ctx.limits.max_storage_buffer_binding_size.min(ctx.limits.max_buffer_size);
    let side = (((max / 32) as f64).sqrt() as u32 + 64).max(4096);
    let err =
        GpuBackend::new(ctx.clone(), &scene, &settings(side, 1, 0)).map(|_| ()).unwrap_err().to_string();
    assert!(err.contains("film") && err.contains("does not fit"), "{err}");
}

/// env-objects.gltf under an HDR map from the shared assets (rotated, scaled).
fn environment_scene() -> pathlight::scene::FlatScene {
    let (mut scene, _) = pathlight::scene::load(&common::scene("env-objects.gltf")).unwrap();
    let mut env =
        pathlight::light::EnvironmentDesc::load(&common::assets().join("env/chinese_garden_1k.hdr")).unwrap();
    env.intensity = 0.7;
    env.rotation_degrees = 40.0;
    scene.environment = Some(env);
    pathlight::scene::FlatScene::build(&scene, &pathlight::scene::ViewSettings { camera: None, aspect: 1.0 })
        .unwrap()
}

#[test]
fn env_objects_gpu_matches_cpu() {
    gpu_matches_cpu("env-objects.gltf", 32, 128);
}

#[test]
fn env_furnace_gpu_matches_cpu() {
    gpu_matches_cpu("env-furnace.gltf", 24, 64);
}

#[test]
#[cfg_attr(
    not(feature = "shared-assets"),
    ignore = "needs ../shared/assets: cargo test --features shared-assets"
)]
fn hdr_environment_gpu_matches_cpu() {
    gpu_matches_cpu_scene("env-objects-garden", &environment_scene(), 32, 128);
}

#[test]
#[cfg_attr(
    not(feature = "shared-assets"),
    ignore = "needs ../shared/assets: cargo test --features shared-assets"
)]
fn hdr_environment_same_seed_agrees() {
    same_seed_agrees_scene("env-objects-garden", &environment_scene(), 1e-3);
}

/// The light choice reuses the light point's first number (`choose_light_reusing`). Where
/// lights differ in power, the alias table's columns are split between two lights, and both
/// arms of the rescaling run: EmissiveStrengthTest's cubes glow at five strengths, under the
/// studio environment (one more light). The bundled scenes' lamps are pairs of equal
/// triangles, whose columns are whole, so there only the first arm runs.
#[test]
#[cfg_attr(
    not(feature = "shared-assets"),
    ignore = "needs ../shared/assets: cargo test --features shared-assets"
)]
fn lights_of_unequal_power_same_seed_agree() {
    let assets = common::assets();
    let model = assets.join("khronos/EmissiveStrengthTest/EmissiveStrengthTest.glb");
    let (mut scene, _) = pathlight::scene::load(&model).unwrap();
    scene.environment =
        Some(pathlight::light::EnvironmentDesc::load(&assets.join("env/studio_small_05_1k.hdr")).unwrap());
    let view = pathlight::scene::ViewSettings { camera: None, aspect: 1.0 };
    let flat = pathlight::scene::FlatScene::build(&scene, &view).unwrap();
    let split_columns = flat.lights.iter().filter(|l| l.alias_probability < 1.0).count();
    assert!(split_columns > 0, "every alias column whole: the second arm is not exercised");
    same_seed_agrees_scene("EmissiveStrengthTest", &flat, 1e-3);
}

/// Every sample lands, however many a dispatch carries: an 8 × 8 image is rendered in
/// dispatches of many samples per pixel, where lavapipe once lost some of them silently
/// (lavapipe's loop limiter: `SOFTWARE_GPU_GROUP_SECONDS` in src/gpu/renderer.rs).
#[test]
fn every_sample_lands_on_a_small_image() {
    let Some(gpu) = common::gpu() else { return };
    for (scene, splits) in [("cornell-spheres.gltf", 1), ("cornell-box.gltf", 4)] {
        let flat = common::flat_scene(&common::scene(scene), 8, 8);
        let settings = RenderSettings { splits, ..settings(8, 1024, 3) };
        let mut backend = GpuBackend::new(gpu.clone(), &flat, &settings).unwrap();
        let film = common::render(&mut backend, 1024);
        let short: Vec<(usize, u32)> = film
            .pixels
            .iter()
            .enumerate()
            .filter(|(_, p)| p.count + p.rejected != 1024)
            .map(|(i, p)| (i, p.count))
            .collect();
        assert!(short.is_empty(), "{scene}: pixels short of 1,024 samples (pixel, count): {short:?}");
    }
}

/// The net under the time budget: dispatches forced to take up to 512 samples per pixel at
/// once, several times lavapipe's loop limit (about 12 ms of work per group of lanes, some
/// 100 samples of this scene), lose samples; the backend sees the film's counts fall
/// short, takes the call's samples again sized by time, and ends with the image a render
/// kept inside the budget makes, bit for bit.
#[test]
fn samples_a_device_cuts_short_are_taken_again() {
    let Some(gpu) = common::gpu() else { return };
    if gpu.is_hardware() {
        eprintln!(
            "SKIPPED samples_a_device_cuts_short_are_taken_again: a hardware GPU has no loop limit to meet"
        );
        return;
    }
    let flat = common::flat_scene(&common::scene("cornell-spheres.gltf"), 8, 8);
    let settings = RenderSettings { splits: 1, ..settings(8, 1024, 3) };
    let mut careful = GpuBackend::new(gpu.clone(), &flat, &settings).unwrap();
    let expected = common::render(&mut careful, 1024);
    let mut reckless = GpuBackend::new(gpu.clone(), &flat, &settings).unwrap();
    reckless.force_software_dispatch_samples(1024);
    let film = common::render(&mut reckless, 1024);
    assert!(reckless.software_retries() > 0, "dispatches of 512 samples never met the loop limit");
    let short = film.pixels.iter().filter(|p| p.count + p.rejected != 1024).count();
    assert_eq!(short, 0, "{short} pixel(s) short of 1,024 samples after the retries");
    // Each pixel adds its samples in index order however the work was split.
    assert!(film.pixels == expected.pixels, "the retried render differs from one inside the budget");
}
