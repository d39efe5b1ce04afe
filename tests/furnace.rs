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
