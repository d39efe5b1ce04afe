//! The analytic furnace on the CPU reference: the camera inside a closed Lambertian sphere
//! of albedo ρ whose inside emits L_e = 1. Every path sees L = L_e + ρL, so every pixel's
//! exact value is L_e / (1 − ρ).

mod common;

use pathlight::cpu::CpuBackend;
use pathlight::RenderSettings;

fn furnace(albedo: f64, file: &str) {
    let (w, h, spp) = (48, 48, 96);
    let scene = common::flat_scene(&common::scene(file), w, h);
    let settings = RenderSettings { width: w, height: h, spp, seed: 7, ..RenderSettings::default() };
    let film = common::render(&mut CpuBackend::new(&scene, &settings), spp);
    assert_eq!(film.total_rejected(), 0);
    let exact = 1.0 / (1.0 - albedo);
    for (c, (mean, se)) in common::image_mean_and_standard_error(&film).into_iter().enumerate() {
        eprintln!("furnace ρ = {albedo}, channel {c}: mean {mean:.5} ± {se:.5} (exact {exact})");
        // 4 standard errors of the image mean: a false failure has probability 6e-5.
        assert!(
            (mean - exact).abs() < 4.0 * se,
            "furnace ρ = {albedo}: mean {mean:.5} ± {se:.5}, exact {exact} ({:.1} standard errors off)",
            (mean - exact).abs() / se
        );
        // The error bars must be informative, not vacuous.
        assert!(se < 0.01 * exact, "standard error {se} is too large to test anything");
    }
}

#[test]
fn furnace_albedo_0_5() {
    furnace(0.5, "furnace-0.5.gltf");
}

#[test]
fn furnace_albedo_0_9() {
    furnace(0.9, "furnace-0.9.gltf");
}

/// The environment furnace (scenes/env-furnace.gltf): a closed, convex, white Lambertian
/// sphere with no light of its own under a constant environment of radiance L. Every point
/// of the sphere sees only sky, so every pixel, sphere and background alike, is exactly L.
fn environment_furnace(background: Option<glam::Vec3>) {
    let (w, h, spp) = (40, 40, 64);
    let (mut scene, _) = pathlight::scene::load(&common::scene("env-furnace.gltf")).unwrap();
    scene.environment = background.map(pathlight::light::EnvironmentDesc::constant);
    let flat = pathlight::scene::FlatScene::build(
        &scene,
        &pathlight::scene::ViewSettings { camera: None, aspect: 1.0 },
    )
    .unwrap();
    // Without a background the scene has no light: the documented default lights it.
    assert_eq!(flat.default_environment, background.is_none());
    // ... and says so.
    assert_eq!(flat.warnings().iter().any(|w| w.contains("no lights")), background.is_none());
    let exact = background.unwrap_or(pathlight::scene::DEFAULT_BACKGROUND);
    let settings = RenderSettings { width: w, height: h, spp, seed: 3, ..RenderSettings::default() };
    let film = common::render(&mut CpuBackend::new(&flat, &settings), spp);
    assert_eq!(film.total_rejected(), 0);
    for (c, (mean, se)) in common::image_mean_and_standard_error(&film).into_iter().enumerate() {
        let exact = exact[c] as f64;
        eprintln!("environment furnace, channel {c}: mean {mean:.5} ± {se:.5} (exact {exact})");
        // 4 standard errors of the image mean: a false failure has probability 6e-5.
        assert!((mean - exact).abs() < 4.0 * se, "mean {mean} ± {se}, exact {exact}");
        assert!(se < 0.01 * exact, "standard error {se} is too large to test anything");
    }
    // Background pixels see the environment directly: exactly L, with no noise at all.
    let corner = film.pixel(0, 0);
    assert_eq!(glam::Vec3::from(corner.mean), exact, "a pixel of open sky");
}

#[test]
fn environment_furnace_default_background() {
    environment_furnace(None);
}

#[test]
fn environment_furnace_coloured_background() {
    environment_furnace(Some(glam::Vec3::new(0.25, 0.5, 1.0)));
}

/// A glass furnace: the env-furnace sphere made of smooth, non-absorbing refracting glass
/// (ior 1.5) under pathlight's default sky (radiance 1). Exact Fresnel conserves energy and
/// every path leaves the sphere again (the 1/η² of entering cancelled by leaving), so every
/// pixel is 1 up to the sphere's faceting: a deep-path test (total internal reflection keeps
/// paths inside for many bounces) of Russian roulette with η-scale taken out of its survival
/// probability. Roulette must not change the expected image: rendered with and without it,
/// the image means agree statistically.
#[test]
fn glass_furnace_with_and_without_roulette() {
    let (w, h, spp) = (32, 32, 256);
    let (mut scene, _) = pathlight::scene::load(&common::scene("env-furnace.gltf")).unwrap();
    for m in &mut scene.materials {
        m.transmission = 1.0;
        m.thickness = 1.0;
        m.roughness = 0.0;
        m.metallic = 0.0;
        m.specular_factor = 1.0;
        m.ior = 1.5;
    }
    let flat = pathlight::scene::FlatScene::build(
        &scene,
        &pathlight::scene::ViewSettings { camera: None, aspect: 1.0 },
    )
    .unwrap();
    assert!(flat.features.volume && flat.default_environment);
    let render = |seed, rr_min_depth| {
        let settings =
            RenderSettings { width: w, height: h, spp, seed, rr_min_depth, ..RenderSettings::default() };
        let film = common::render(&mut CpuBackend::new(&flat, &settings), spp);
        assert_eq!(film.total_rejected(), 0);
        common::image_mean_and_standard_error(&film)
    };
    // Roulette from depth 3 (where it thins paths out sooner than the default, so it tests
    // more of them), and none (a start beyond the 1024-bounce guard).
    let with = render(11, 3);
    let without = render(12, 5000);
    for c in 0..3 {
        let ((a, sa), (b, sb)) = (with[c], without[c]);
        eprintln!(
            "glass furnace, channel {c}: with roulette {a:.5} ± {sa:.5}, without {b:.5} ± {sb:.5} (exact 1)"
        );
        // Unbiasedness: 4 standard errors of the difference.
        assert!((a - b).abs() < 4.0 * (sa * sa + sb * sb).sqrt(), "roulette changes the mean: {a} vs {b}");
        // Near the exact 1: the interpolated shading normals of a 1280-triangle sphere send a
        // few refracted paths out of the wrong side of a facet, losing about 2e-4 of the
        // energy with and without roulette alike (measured: 0.99983 ± 0.00005 without it);
        // 5e-4 bounds that loss, plus 4 standard errors.
        assert!((a - 1.0).abs() < 5e-4 + 4.0 * sa, "with roulette: {a} ± {sa}");
        assert!(sa < 0.01, "standard error {sa} is too large to test anything");
    }
}
