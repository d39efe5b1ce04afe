//! Numerical stability on hard cases (issue 11): scenes under `scenes/hard/` (made by
//! `examples/make_scenes.rs`), each with a property whose right answer is known, checked on
//! both backends.

mod common;

use pathlight::cpu::CpuBackend;
use pathlight::film::Film;
use pathlight::gpu::GpuBackend;
use pathlight::scene::FlatScene;
use pathlight::RenderSettings;

fn hard_scene(name: &str, size: u32) -> FlatScene {
    common::flat_scene(&common::root().join("scenes/hard").join(name), size, size)
}

/// Renders `scene` on the CPU and, when there is one, on the GPU: `(backend, film)` pairs.
fn render_both(scene: &FlatScene, size: u32, spp: u32, seed: u32) -> Vec<(&'static str, Film)> {
    let settings = RenderSettings { width: size, height: size, spp, seed, ..RenderSettings::default() };
    let mut out = vec![("cpu", common::render(&mut CpuBackend::new(scene, &settings), spp))];
    if let Some(ctx) = common::gpu() {
        let mut gpu = GpuBackend::new(ctx, scene, &settings).unwrap();
        out.push(("gpu", common::render(&mut gpu, spp)));
    }
    out
}

#[test]
fn a_sealed_room_lit_from_outside_is_exactly_black() {
    // A closed cube with shared vertices and averaged corner normals, the camera inside, a
    // point light and an emissive quad outside. Every path from the camera stays inside, so
    // every sample must be exactly 0: not small, zero.
    // Before the fix this lit 16,147 of 16,384 pixels at 128², 64 spp (depth 1 already).
    let scene = hard_scene("sealed-room.gltf", 96);
    for (backend, film) in render_both(&scene, 96, 32, 1) {
        let lit: Vec<(usize, f32)> = film
            .mean()
            .iter()
            .enumerate()
            .filter(|(_, m)| m.max_element() != 0.0)
            .map(|(i, m)| (i, m.max_element()))
            .collect();
        assert!(
            lit.is_empty(),
            "{backend}: {} of {} pixels receive light, e.g. {:?}",
            lit.len(),
            film.pixels.len(),
            &lit[..lit.len().min(5)]
        );
        assert_eq!(film.total_rejected(), 0, "{backend}: non-finite samples");
    }
}
