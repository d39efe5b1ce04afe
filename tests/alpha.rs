//! Alpha modes (glTF 2.0 §3.9.4) on both backends: MASK with a checker alpha passes exactly
//! the light its holes let through, BLEND (stochastic transparency) passes 1 − alpha, and
//! shadow rays and camera rays respect both (issue 7).

mod common;

use glam::Vec3;
use pathlight::cpu::CpuBackend;
use pathlight::geometry::Ray;
use pathlight::gpu::GpuBackend;
use pathlight::sampling::Rng;
use pathlight::scene::{FlatScene, ViewSettings};
use pathlight::RenderSettings;
use serde_json::json;

/// An 8×8 checker of alpha 0 and 255 (white), PNG as a data URI.
fn checker_alpha_png() -> String {
    let mut rgba = Vec::new();
    for j in 0..8 {
        for i in 0..8 {
            rgba.extend_from_slice(&[255, 255, 255, if (i + j) % 2 == 0 { 255 } else { 0 }]);
        }
    }
    common::png_data_uri(8, 8, &rgba)
}

/// A white floor (y = 0); over x ∈ [−1.5, −0.5] a MASK quad at y = 0.5 with the checker
/// alpha (nearest filter, cutoff 0.5: exactly half its area opaque); over x ∈ [0.5, 1.5] a
/// BLEND quad of alpha 0.3. Both quads are one-sided facing up and double-sided materials.
/// A directional light shines straight down. Camera 0 looks down from above (through the
/// quads); camera 1 is orthographic between the quads and the floor, looking down, so it sees
/// the floor and no quad: x ∈ [−3, 3] across the image, z ∈ [−2, 2] down it.
fn alpha_scene(camera: usize, aspect: f64) -> FlatScene {
    let quad =
        |x0: f32, x1: f32, y: f32, z0: f32, z1: f32| [[x0, y, z1], [x1, y, z1], [x1, y, z0], [x0, y, z0]];
    let quads =
        [quad(-3.0, 3.0, 0.0, -2.0, 2.0), quad(-1.5, -0.5, 0.5, -0.5, 0.5), quad(0.5, 1.5, 0.5, -0.5, 0.5)];
    let mut bin: Vec<u8> = Vec::new();
    for q in &quads {
        for v in q {
            for c in v {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    let uv: [f32; 8] = [0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0];
    for _ in 0..3 {
        for v in uv {
            bin.extend_from_slice(&v.to_le_bytes());
        }
    }
    for i in [0u32, 1, 2, 0, 2, 3] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let lambert = json!({"pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 1.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}});
    let mut mask = lambert.clone();
    mask["alphaMode"] = json!("MASK");
    mask["alphaCutoff"] = json!(0.5);
    mask["doubleSided"] = json!(true);
    mask["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    let mut blend = lambert.clone();
    blend["alphaMode"] = json!("BLEND");
    blend["doubleSided"] = json!(true);
    blend["pbrMetallicRoughness"]["baseColorFactor"] = json!([1.0, 1.0, 1.0, 0.3]);
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_specular"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 3.0}]}},
        "scenes": [{"nodes": [0, 1, 2, 3, 4, 5]}],
        "nodes": [
            {"mesh": 0}, {"mesh": 1}, {"mesh": 2},
            // −Z turned to −Y: +90° about X.
            {"rotation": [-h, 0.0, 0.0, h], "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"camera": 0, "translation": [0.0, 4.0, 0.0], "rotation": [-h, 0.0, 0.0, h]},
            {"camera": 1, "translation": [0.0, 0.3, 0.0], "rotation": [-h, 0.0, 0.0, h]}
        ],
        "cameras": [
            {"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.01}},
            {"type": "orthographic", "orthographic": {"xmag": 3.0, "ymag": 2.0, "znear": 0.01, "zfar": 10.0}}
        ],
        "meshes": (0..3).map(|q| json!({"primitives": [{"attributes": {"POSITION": q, "TEXCOORD_0": 3 + q}, "indices": 6, "material": q}]})).collect::<Vec<_>>(),
        "materials": [lambert, mask, blend],
        "samplers": [{"magFilter": 9728, "minFilter": 9728}],
        "images": [{"uri": checker_alpha_png()}],
        "textures": [{"source": 0, "sampler": 0}],
        "accessors": (0..3).map(|q| json!({"bufferView": 0, "byteOffset": 48 * q, "componentType": 5126, "count": 4, "type": "VEC3",
                "min": [-3.0, 0.0, -2.0], "max": [3.0, 0.5, 2.0]}))
            .chain((0..3).map(|q| json!({"bufferView": 1, "byteOffset": 32 * q, "componentType": 5126, "count": 4, "type": "VEC2"})))
            .chain(std::iter::once(json!({"bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR"})))
            .collect::<Vec<_>>(),
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 144},
            {"buffer": 0, "byteOffset": 144, "byteLength": 96},
            {"buffer": 0, "byteOffset": 240, "byteLength": 24}
        ],
        "buffers": [{"byteLength": bin.len(), "uri": common::buffer_data_uri(&bin)}]
    });
    let path = std::env::temp_dir().join(format!("pathlight-alpha-{}.gltf", std::process::id()));
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let loaded = pathlight::scene::load(&path);
    let _ = std::fs::remove_file(&path);
    let (scene, warnings) = loaded.unwrap_or_else(|e| panic!("{e}"));
    assert!(warnings.is_empty(), "{warnings:?}");
    let flat = FlatScene::build(&scene, &ViewSettings { camera: Some(camera), aspect }).unwrap();
    assert!(flat.features.alpha && flat.features.textures);
    flat
}

/// The fraction of vertical shadow rays from floor points under `x ∈ [x0, x1]`,
/// `z ∈ [−0.5, 0.5]` that reach the sky (world coordinates; the flat scene is camera-relative).
fn passing_fraction(scene: &FlatScene, x0: f32, x1: f32, n: u32) -> f64 {
    let origin = scene.camera_desc.position.as_vec3();
    let mut rng = Rng::new(1, 2, 3, 4);
    let mut passed = 0;
    for _ in 0..n {
        let u = rng.next_2d();
        let p = Vec3::new(x0 + (x1 - x0) * u.x, 0.01, -0.5 + u.y) - origin;
        let ray = Ray { origin: p, direction: Vec3::Y, t_max: f32::MAX };
        if !scene.intersect_any(&ray, rng.next_u32()) {
            passed += 1;
        }
    }
    passed as f64 / n as f64
}

#[test]
fn shadow_rays_pass_the_light_alpha_lets_through() {
    let scene = alpha_scene(0, 1.0);
    let n = 40_000;
    // Binomial standard deviation √(p(1−p)/n) ≤ 0.0025; 5σ is 0.0125. The checker's open
    // area is exactly half (nearest filter, whole cells), so MASK passes 0.5.
    let mask = passing_fraction(&scene, -1.5, -0.5, n);
    assert!((mask - 0.5).abs() < 0.0125, "MASK passes {mask}, expected 0.5");
    let blend = passing_fraction(&scene, 0.5, 1.5, n);
    assert!((blend - 0.7).abs() < 0.0125, "BLEND (alpha 0.3) passes {blend}, expected 0.7");
    let open = passing_fraction(&scene, -0.4, 0.4, n);
    assert_eq!(open, 1.0, "nothing above the floor between the quads");
}

#[test]
fn the_floor_under_each_quad_receives_the_light_alpha_lets_through() {
    // Camera 1 sees only the floor. With direct light only (max depth 1) a floor point's
    // radiance is ρE/π where the light reaches it and 0 where not, so the floor under a quad,
    // relative to the open floor, is exactly the fraction the quad passes: 0.5 (MASK, by
    // area) and 0.7 (BLEND, in expectation).
    let (w, h, spp) = (96u32, 64u32, 64u32);
    let scene = alpha_scene(1, w as f64 / h as f64);
    let settings =
        RenderSettings { width: w, height: h, spp, seed: 5, max_depth: Some(1), ..RenderSettings::default() };
    let film = common::render(&mut CpuBackend::new(&scene, &settings), spp);
    let means = film.mean();
    let region_mean = |x0: f32, x1: f32| {
        let (mut sum, mut n) = (0.0f64, 0);
        for y in 0..h {
            for x in 0..w {
                let wx = -3.0 + 6.0 * (x as f32 + 0.5) / w as f32;
                let wz = -2.0 + 4.0 * (y as f32 + 0.5) / h as f32;
                // Whole pixels inside the region (a pixel is 1/16 unit wide).
                if wx - 1.0 / 32.0 >= x0 && wx + 1.0 / 32.0 <= x1 && wz.abs() + 1.0 / 32.0 <= 0.5 {
                    sum += means[(y * w + x) as usize].y as f64;
                    n += 1;
                }
            }
        }
        assert!(n >= 100, "region [{x0}, {x1}] has {n} pixels");
        sum / n as f64
    };
    let open = region_mean(-0.4, 0.4);
    let mask = region_mean(-1.5, -0.5) / open;
    let blend = region_mean(0.5, 1.5) / open;
    eprintln!("floor under MASK {mask:.4}, under BLEND {blend:.4} of the open floor ({open:.4})");
    // MASK: the region is whole checker cells (1/8 unit, two pixels each), so 0.5 up to the
    // pixel filter's jitter across cell edges: ±0.01. BLEND: ~10⁵ binomial shadow decisions
    // of p = 0.7, σ ≈ 0.0015; ±0.01 is over 6σ.
    assert!((mask - 0.5).abs() < 0.01, "MASK: {mask}");
    assert!((blend - 0.7).abs() < 0.01, "BLEND: {blend}");
}

#[test]
fn alpha_gpu_matches_cpu() {
    let Some(ctx) = common::gpu() else { return };
    let scene = alpha_scene(0, 1.0);
    let (size, spp) = (32, 64);
    let settings =
        |seed| RenderSettings { width: size, height: size, spp, seed, ..RenderSettings::default() };
    let cpu = common::render(&mut CpuBackend::new(&scene, &settings(7)), spp);
    let gpu = common::render(&mut GpuBackend::new(ctx.clone(), &scene, &settings(7)).unwrap(), spp);
    // Same seed: the same stochastic-transparency decisions (same hash, same seeds drawn in
    // the same order), so the images agree to rounding (1e-3 relative, as in tests/gpu/).
    let mut differ = 0;
    for (a, b) in cpu.pixels.iter().zip(&gpu.pixels) {
        let (a, b) = (Vec3::from(a.mean), Vec3::from(b.mean));
        if (a - b).abs().max_element() > 1e-3 * a.max_element().max(b.max_element()).max(1e-6) {
            differ += 1;
        }
    }
    assert!(differ * 100 <= size * size, "{differ} of {} pixels differ with the same seed", size * size);
    // And the image means agree within 4 standard errors per channel.
    let a = common::image_mean_and_standard_error(&cpu);
    let b = common::image_mean_and_standard_error(&gpu);
    for c in 0..3 {
        let z = (a[c].0 - b[c].0) / (a[c].1.powi(2) + b[c].1.powi(2)).sqrt().max(1e-12);
        assert!(z.abs() < 4.0, "channel {c}: CPU {:?} vs GPU {:?}", a[c], b[c]);
    }
}
