//! Measures what texture level of detail (mip maps chosen by ray cones) does to error: a
//! finely checkered floor runs to the horizon under a white sky, rendered with and without
//! mip maps at 1 to 64 spp; each is compared with a high-sample render without mip maps
//! (the pixel integral of the full-resolution texture, the unbiased answer).
//!
//! Without mip maps the far floor aliases into noise that only many samples average away;
//! with them it is grey from the first sample, at the price of a bias (the box-filtered
//! levels blur a little more than the pixel does). The table shows both.
//!
//!   cargo run --release --example texture_lod [-- --size 128 --reference-spp 2048 --out DIR]

use pathlight::cpu::CpuBackend;
use pathlight::film::{error_against, LinearImage};
use pathlight::scene::{FlatScene, ViewSettings};
use pathlight::{Backend, RenderSettings};
use serde_json::json;

/// A 256² checker of 4-texel squares, as a PNG `data:` URI.
fn checker_uri() -> String {
    use base64::Engine;
    let side = 256u32;
    let mut rgba = Vec::with_capacity((side * side * 4) as usize);
    for y in 0..side {
        for x in 0..side {
            let v = if (x / 4 + y / 4) % 2 == 0 { 230u8 } else { 20 };
            rgba.extend_from_slice(&[v, v, v, 255]);
        }
    }
    let mut png = Vec::new();
    use image::ImageEncoder;
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&rgba, side, side, image::ExtendedColorType::Rgba8)
        .expect("encode the checker");
    format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(&png))
}

/// The floor (400 × 400 units, the texture repeated 100 times each way) and a camera 1 unit
/// above it looking towards the horizon.
fn scene_file() -> std::path::PathBuf {
    use base64::Engine;
    let (h, r) = (200.0f32, 100.0f32);
    let positions = [[-h, 0.0, -h], [h, 0.0, -h], [h, 0.0, h], [-h, 0.0, h]];
    let uvs = [[0.0, 0.0], [r, 0.0], [r, r], [0.0, r]];
    let indices: [u32; 6] = [0, 2, 1, 0, 3, 2];
    let mut bin = Vec::new();
    positions.iter().flatten().for_each(|v: &f32| bin.extend_from_slice(&v.to_le_bytes()));
    uvs.iter().flatten().for_each(|v: &f32| bin.extend_from_slice(&v.to_le_bytes()));
    indices.iter().for_each(|i| bin.extend_from_slice(&i.to_le_bytes()));
    // Pitched down by 10° about +X, from 1 unit above the floor.
    let (s, c) = (-5.0f64.to_radians().sin(), 5.0f64.to_radians().cos());
    let doc = json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0.0, 1.0, 0.0], "rotation": [s, 0.0, 0.0, c]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "aspectRatio": 1.0, "znear": 0.01}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
        "samplers": [{"wrapS": 10497, "wrapT": 10497, "magFilter": 9729, "minFilter": 9987}],
        "images": [{"uri": checker_uri()}],
        "textures": [{"source": 0, "sampler": 0}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-h, 0.0, -h], "max": [h, 0.0, h]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 32},
            {"buffer": 0, "byteOffset": 80, "byteLength": 24}
        ],
        "buffers": [{"byteLength": bin.len(), "uri": format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&bin))}]
    });
    let path = std::env::temp_dir().join(format!("pathlight-texture-lod-{}.gltf", std::process::id()));
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

fn flat(mipmaps: bool) -> FlatScene {
    let path = scene_file();
    let (mut scene, _) = pathlight::scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    let _ = std::fs::remove_file(&path);
    for t in &mut scene.textures {
        t.mipmaps = mipmaps;
    }
    scene.environment = Some(pathlight::light::EnvironmentDesc::constant(glam::Vec3::ONE));
    FlatScene::build(&scene, &ViewSettings { camera: Some(0), aspect: 1.0 }).unwrap()
}

fn render(scene: &FlatScene, size: u32, spp: u32, seed: u32, png: Option<&str>) -> (LinearImage, f64) {
    let settings = RenderSettings { width: size, height: size, spp, seed, ..RenderSettings::default() };
    let mut backend = CpuBackend::new(scene, &settings);
    let start = std::time::Instant::now();
    backend.render(0, spp).unwrap();
    let seconds = start.elapsed().as_secs_f64();
    let film = backend.film().unwrap();
    if let Some(path) = png {
        pathlight::film::write_png(&film, std::path::Path::new(path), pathlight::film::Tonemap::Clamp, 0.0)
            .unwrap();
    }
    (LinearImage::from_film(&film), seconds)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str, default: u32| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .map_or(default, |v| v.parse().unwrap())
    };
    let size = arg("--size", 128);
    let reference_spp = arg("--reference-spp", 2048);
    let (without, with) = (flat(false), flat(true));
    let out = args.iter().position(|a| a == "--out").and_then(|i| args.get(i + 1)).cloned();
    let png = |name: &str| out.as_ref().map(|dir| format!("{dir}/{name}.png"));
    let (reference, seconds) = render(&without, size, reference_spp, 1000, png("reference").as_deref());
    println!("reference: {size}² at {reference_spp} spp without mip maps ({seconds:.1} s, CPU)");
    println!("| spp | relMSE, no mip maps | relMSE, mip maps | seconds, no mip maps | seconds, mip maps |");
    println!("|---:|---:|---:|---:|---:|");
    for spp in [1, 4, 16, 64] {
        let (a, ta) = render(&without, size, spp, 1, png(&format!("no-mips-{spp}spp")).as_deref());
        let (b, tb) = render(&with, size, spp, 1, png(&format!("mips-{spp}spp")).as_deref());
        let (_, rel_a) = error_against(&a, &reference);
        let (_, rel_b) = error_against(&b, &reference);
        println!("| {spp} | {rel_a:.5} | {rel_b:.5} | {ta:.2} | {tb:.2} |");
    }
    // The bias of the mip-mapped image: its own converged error against the reference.
    let (b, _) = render(&with, size, reference_spp, 2000, png("mips-converged").as_deref());
    let (_, bias) = error_against(&b, &reference);
    println!("mip maps at {reference_spp} spp against the reference (their bias plus both images' noise): relMSE {bias:.5}");
}
