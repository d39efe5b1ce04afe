//! Caustics by light tracing (`src/integrator/light_tracing.rs`, `shaders/light_tracing.wgsl`): the
//! light tracer and the path tracer split path space between them, so with it each backend
//! must render the same image as without it, and as a scene whose answer is known.

mod common;

use pathlight::cpu::CpuBackend;
use pathlight::film::{compare_images, CompareOptions, Film, LinearImage};
use pathlight::gpu::GpuBackend;
use pathlight::scene::FlatScene;
use pathlight::{Backend, RenderSettings};

fn settings(size: u32, spp: u32, seed: u32, max_depth: Option<u32>, light_tracing: bool) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        spp,
        seed,
        max_depth,
        light_tracing,
        ..RenderSettings::default()
    }
}

/// Renders `scene` on the CPU backend, checking that it light traces the caustics exactly
/// when `expect_light_tracing` says.
fn render(scene: &FlatScene, settings: &RenderSettings, expect_light_tracing: bool) -> Film {
    let mut backend = CpuBackend::new(scene, settings);
    assert_eq!(backend.light_traces_caustics(), expect_light_tracing, "{}", backend.name());
    common::render(&mut backend, settings.spp)
}

/// The multi-scale z-test `pathlight compare` runs (false-alarm rate 1%), and the image
/// means within 4 standard errors (a false alarm once in 16,000 runs per channel).
fn assert_same(test: &Film, reference: &Film, what: &str) {
    let report = compare_images(
        &LinearImage::from_film(test),
        &LinearImage::from_film(reference),
        &CompareOptions::default(),
    )
    .unwrap();
    assert!(report.same(), "{what}: {}", report.failures.join("; "));
    let (a, b) =
        (common::image_mean_and_standard_error(test), common::image_mean_and_standard_error(reference));
    for c in 0..3 {
        let ((ma, sa), (mb, sb)) = (a[c], b[c]);
        let z = (ma - mb) / (sa * sa + sb * sb).sqrt();
        assert!(
            z.abs() < 4.0,
            "{what}: channel {c} image means {ma} ± {sa} and {mb} ± {sb} differ by {z:.1}σ"
        );
    }
    assert_eq!(test.total_rejected(), 0, "{what}: non-finite samples");
}

#[test]
fn a_ceiling_lit_through_a_mirror_equals_it_lit_by_the_lamps_mirror_image() {
    // Two bounces (ceiling, mirror) of `caustic-mirror.gltf` are one bounce of its twin with
    // the mirror image of the lamp instead of the mirror: an exact answer for the light
    // tracer's emission sampling, its camera connection (pixel area, cos³θ) and the
    // partition, since with it every such path is light traced and none path traced.
    let size = 48;
    let hard = common::root().join("scenes/hard");
    let mirrored = common::flat_scene(&hard.join("caustic-mirror.gltf"), size, size);
    let direct = common::flat_scene(&hard.join("caustic-mirror-virtual.gltf"), size, size);
    // The twin has no delta material: nothing for the light tracer, so it does not run.
    let expected = render(&direct, &settings(size, 256, 1, Some(1), true), false);
    let light_traced = render(&mirrored, &settings(size, 64, 2, Some(2), true), true);
    assert_same(&light_traced, &expected, "light traced");
    // The path tracer alone finds these paths only when a ceiling sample's mirror direction
    // hits the lamp (about 1% of them): rare and bright, so it needs 16× the samples for each
    // pixel's variance estimate to have seen enough of them.
    let path_traced = render(&mirrored, &settings(size, 1024, 3, Some(2), false), false);
    assert_same(&path_traced, &expected, "path traced");
}

#[test]
fn glass_and_mirror_spheres_render_the_same_with_and_without_light_tracing() {
    // The glass scene's caustics pass through a refracting sphere with shading normals: the
    // light tracer's 1/η² and shading-normal factors. The path tracer's caustic samples are
    // rare and bright (heavy-tailed), so it gets 8× the samples: at 512 spp each of the
    // 32² pixels has seen enough of them for its variance estimate to hold.
    let size = 32;
    let scene = common::flat_scene(&common::scene("cornell-spheres.gltf"), size, size);
    let light_traced = render(&scene, &settings(size, 64, 4, None, true), true);
    let path_traced = render(&scene, &settings(size, 512, 5, None, false), false);
    assert_same(&light_traced, &path_traced, "cornell-spheres");
}

#[test]
fn scenes_the_light_tracer_cannot_take_are_path_traced() {
    // No delta material (nothing to light trace), rough metal and plastic (glTF layers whose
    // adjoint is not the BSDF swapped), and the option off.
    for (name, light_tracing) in
        [("cornell-box.gltf", true), ("glossy-metal.gltf", true), ("cornell-spheres.gltf", false)]
    {
        let scene = common::flat_scene(&common::scene(name), 8, 8);
        let backend = CpuBackend::new(&scene, &settings(8, 1, 0, None, light_tracing));
        assert!(!backend.light_traces_caustics(), "{name}: {}", backend.name());
    }
}

#[test]
fn behind_a_glass_pane_filling_the_view_nothing_is_light_traced() {
    use pathlight::integrator::delta_view::camera_sees_only_delta_surfaces;
    // Every camera ray meets the pane first: no light path can be joined to the camera, so
    // the light tracer is skipped (its partition gives it only paths whose first vertex is
    // non-delta, and there are none).
    let path = common::root().join("scenes/hard/cornell-spheres-behind-glass.gltf");
    let scene = common::flat_scene(&path, 8, 8);
    assert!(camera_sees_only_delta_surfaces(&scene, &scene.camera));
    assert!(!CpuBackend::new(&scene, &settings(8, 1, 0, None, true)).light_traces_caustics());
    // Without the pane, or with a pane that leaves a sliver of the view uncovered, the
    // walls are seen directly and the light tracer runs.
    let open = common::flat_scene(&common::scene("cornell-spheres.gltf"), 8, 8);
    assert!(!camera_sees_only_delta_surfaces(&open, &open.camera));
    assert!(CpuBackend::new(&open, &settings(8, 1, 0, None, true)).light_traces_caustics());
    let (mut loaded, _) = pathlight::scene::load(&path).unwrap();
    let pane = loaded.materials.iter().position(|m| m.name == "thin glass pane").unwrap() as u32;
    // The pane spans x from -0.2 to 0.8 at z = -0.7, 0.1 in front of the eye at x = 0.278,
    // where the view spans 0.278 ± 0.0357 (tan of half the 39.3° field of view, × 0.1).
    // Moved 0.49 to the left its right edge is at 0.31: the view's last 0.004 (6% of its
    // width) sees the walls past it.
    for (tri, material) in loaded.positions.chunks_exact_mut(3).zip(&loaded.triangle_materials) {
        if *material == pane {
            for p in tri {
                p.x -= 0.49;
            }
        }
    }
    let view = pathlight::scene::ViewSettings { camera: None, aspect: 1.0 };
    let gap = FlatScene::build(&loaded, &view).unwrap();
    assert!(!camera_sees_only_delta_surfaces(&gap, &gap.camera), "the pane leaves a sliver of the view open");
}

#[test]
fn row_bands_give_the_same_film_as_whole_passes() {
    // The viewer renders one sample index band by band: each band must take the same light
    // tracer pass as a whole-image render does.
    let (scene, s) = banded_scene();
    assert_banded_equals_whole(CpuBackend::new(&scene, &s), CpuBackend::new(&scene, &s));
}

/// The glass scene at 24² and its settings (4 spp) for the banded-render tests.
fn banded_scene() -> (FlatScene, RenderSettings) {
    let size = 24;
    let scene = common::flat_scene(&common::scene("cornell-spheres.gltf"), size, size);
    (scene, settings(size, 4, 7, None, true))
}

/// Renders four sample indices whole on `whole` and in three bands of rows each on
/// `banded`: the films and the ray counts must be equal.
fn assert_banded_equals_whole(mut whole: impl Backend, mut banded: impl Backend) {
    whole.render(0, 4).unwrap();
    for k in 0..4 {
        for rows in [0..10, 10..17, 17..24] {
            banded.render_rows(k, rows).unwrap();
        }
    }
    assert!(whole.film().unwrap() == banded.film().unwrap(), "banded film differs");
    assert_eq!(whole.rays_traced().unwrap(), banded.rays_traced().unwrap());
}

#[test]
fn on_the_gpu_a_ceiling_lit_through_a_mirror_equals_it_lit_by_the_lamps_mirror_image() {
    // The exact answer above for the kernel's light tracer (`trace_caustics`): its splats,
    // their fixed-point sums, and `render` leaving the same paths out.
    let Some(ctx) = common::gpu() else { return };
    let size = 48;
    let hard = common::root().join("scenes/hard");
    let mirrored = common::flat_scene(&hard.join("caustic-mirror.gltf"), size, size);
    let direct = common::flat_scene(&hard.join("caustic-mirror-virtual.gltf"), size, size);
    let expected = render(&direct, &settings(size, 256, 1, Some(1), true), false);
    let s = settings(size, 64, 2, Some(2), true);
    let mut gpu = GpuBackend::new(ctx, &mirrored, &s).unwrap();
    assert!(gpu.light_traces_caustics(), "{}", gpu.name());
    let light_traced = common::render(&mut gpu, s.spp);
    assert_same(&light_traced, &expected, "light traced on the GPU");
}

#[test]
fn on_the_gpu_glass_and_mirror_spheres_render_the_same_with_and_without_light_tracing() {
    // As on the CPU (see that test for the sample counts), the kernel's light tracer against
    // the CPU backend's path tracer alone.
    let Some(ctx) = common::gpu() else { return };
    let size = 32;
    let scene = common::flat_scene(&common::scene("cornell-spheres.gltf"), size, size);
    let s = settings(size, 64, 4, None, true);
    let mut gpu = GpuBackend::new(ctx, &scene, &s).unwrap();
    assert!(gpu.light_traces_caustics(), "{}", gpu.name());
    let light_traced = common::render(&mut gpu, s.spp);
    let path_traced = render(&scene, &settings(size, 512, 5, None, false), false);
    assert_same(&light_traced, &path_traced, "cornell-spheres on the GPU");
}

#[test]
fn on_the_gpu_row_bands_give_the_same_film_as_whole_passes() {
    // The viewer's way on the kernel: each band of a sample index must see that index's
    // light-traced image, traced once.
    let Some(ctx) = common::gpu() else { return };
    let (scene, s) = banded_scene();
    let whole = GpuBackend::new(ctx.clone(), &scene, &s).unwrap();
    assert!(whole.light_traces_caustics(), "{}", whole.name());
    assert_banded_equals_whole(whole, GpuBackend::new(ctx, &scene, &s).unwrap());
}

#[test]
fn the_gpu_light_traces_exactly_the_scenes_the_cpu_does() {
    let Some(ctx) = common::gpu() else { return };
    for (name, light_tracing) in [
        ("cornell-box.gltf", true),
        ("glossy-metal.gltf", true),
        ("cornell-spheres.gltf", false),
        ("cornell-spheres.gltf", true),
        ("hard/cornell-spheres-behind-glass.gltf", true),
    ] {
        let scene = common::flat_scene(&common::scene(name), 8, 8);
        let s = settings(8, 1, 0, None, light_tracing);
        let gpu = GpuBackend::new(ctx.clone(), &scene, &s).unwrap();
        let cpu = CpuBackend::new(&scene, &s);
        assert_eq!(gpu.light_traces_caustics(), cpu.light_traces_caustics(), "{name}: {}", gpu.name());
    }
}
