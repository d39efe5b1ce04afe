//! Loading real glTF assets, and rejecting malformed or hostile ones with clear errors.

mod common;

use std::path::Path;

use glam::Vec3;
use pathlight::scene::{load, load_from_bytes, FlatScene, LoadOptions, ViewSettings};
use serde_json::{json, Value};

/// A minimal glTF with one triangle list; `patch` edits the JSON before loading.
fn doc(positions: &[[f32; 3]], indices: &[u32], patch: impl FnOnce(&mut Value)) -> Vec<u8> {
    let mut bytes: Vec<u8> = positions.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    let pos_len = bytes.len();
    bytes.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let mut v = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": positions.len(), "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 1.0]},
            {"bufferView": 1, "componentType": 5125, "count": indices.len(), "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": pos_len},
            {"buffer": 0, "byteOffset": pos_len, "byteLength": bytes.len() - pos_len}
        ],
        "buffers": [{"byteLength": bytes.len(), "uri": common::buffer_data_uri(&bytes)}]
    });
    patch(&mut v);
    serde_json::to_vec(&v).unwrap()
}

const QUAD: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];

fn expect_error(bytes: &[u8], needles: &[&str]) {
    let file = Path::new("hostile.gltf");
    let err = load_from_bytes(bytes, file, &LoadOptions::default())
        .map(|_| ())
        .expect_err("must be rejected")
        .to_string();
    assert!(err.starts_with("hostile.gltf: "), "error must name the file: {err}");
    for n in needles {
        assert!(err.contains(n), "error '{err}' should mention '{n}'");
    }
}

#[test]
fn a_valid_document_loads() {
    let (scene, warnings) = load_from_bytes(
        &doc(&QUAD, &[0, 1, 2, 0, 2, 3], |_| {}),
        Path::new("ok.gltf"),
        &LoadOptions::default(),
    )
    .unwrap();
    assert_eq!(scene.triangle_count(), 2);
    assert!(warnings.is_empty(), "{warnings:?}");
}

#[test]
fn hostile_documents_are_rejected_with_clear_errors() {
    expect_error(&doc(&QUAD, &[0, 1, 77777], |_| {}), &["element 2 of the indices", "4 vertices"]);
    expect_error(
        &doc(&QUAD, &[0, 1, 2], |v| v["accessors"][0]["count"] = json!(1_000_000)),
        &["POSITION", "do not fit", "buffer view 0"],
    );
    expect_error(
        &doc(&QUAD, &[0, 1, 2], |v| v["accessors"][0]["count"] = json!(u32::MAX as u64 * 4)),
        &["POSITION"],
    );
    expect_error(
        &doc(&QUAD, &[0, 1, 2], |v| v["bufferViews"][0]["byteLength"] = json!(1u64 << 40)),
        &["buffer view 0", "outside buffer 0"],
    );
    expect_error(
        &doc(&QUAD, &[0, 1, 2], |v| v["bufferViews"][0]["byteStride"] = json!(4)),
        &["byteStride 4"],
    );
    expect_error(
        &doc(&[[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]], &[0, 1, 2], |_| {}),
        &["no triangles to render", "dropped 1 triangle(s) with a NaN or infinite vertex"],
    );
    expect_error(
        &doc(&QUAD, &[0, 1, 2], |v| v["extensionsRequired"] = json!(["KHR_draco_mesh_compression"])),
        &["requires extension KHR_draco_mesh_compression"],
    );
    expect_error(
        &doc(&QUAD, &[0, 1, 2], |v| v["nodes"] = json!([{"mesh": 0, "children": [1]}, {"children": [0]}])),
        &["cycle"],
    );
    expect_error(
        &doc(&QUAD, &[0, 1, 2], |v| v["buffers"][0]["uri"] = json!("missing.bin")),
        &["buffer 0", "missing.bin"],
    );
    expect_error(
        &doc(&QUAD, &[0, 1, 2], |v| v["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(9)),
        &["POSITION refers to accessor 9"],
    );
    expect_error(
        &doc(&QUAD, &[0, 1, 2], |v| v["meshes"][0]["primitives"][0]["indices"] = json!(9)),
        &["invalid glTF"],
    );
    expect_error(&doc(&QUAD, &[0, 1, 2], |v| v["nodes"][0]["mesh"] = json!(3)), &["invalid glTF"]);
    expect_error(
        &doc(&QUAD, &[0, 1, 2], |v| v["accessors"][0]["componentType"] = json!(5123)),
        &["only FLOAT VEC3"],
    );
    // A sparse accessor needs no buffer view (its base is zeros): 2⁴⁰ of them must not be
    // allocated.
    expect_error(
        &doc(&QUAD, &[0, 1, 2], |v| {
            let a = &mut v["accessors"][0];
            a.as_object_mut().unwrap().remove("bufferView");
            a["count"] = json!(1u64 << 40);
            a["sparse"] = json!({"count": 1, "indices": {"bufferView": 1, "componentType": 5125}, "values": {"bufferView": 0}});
        }),
        &["not a plausible count"],
    );
    expect_error(
        &doc(&QUAD, &[0, 1, 2], |v| {
            v["accessors"][0].as_object_mut().unwrap().remove("bufferView").map(|_| ()).unwrap()
        }),
        &["bufferView"],
    );
    expect_error(b"{\"asset\": ", &["not a valid glTF"]);
    expect_error(b"glTF\x02\x00\x00\x00\xff\xff\xff\xff", &["not a valid glTF"]);
    expect_error(&doc(&QUAD, &[0, 1, 2], |v| v["scenes"] = json!([{"nodes": []}])), &["no triangles"]);
}

#[test]
fn unsupported_optional_extensions_warn() {
    let (_, warnings) = load_from_bytes(
        &doc(&QUAD, &[0, 1, 2], |v| v["extensionsUsed"] = json!(["EXT_fancy"])),
        Path::new("w.gltf"),
        &LoadOptions::default(),
    )
    .unwrap();
    assert!(warnings.iter().any(|w| w.contains("EXT_fancy")), "{warnings:?}");
}

#[test]
fn negative_determinant_transforms_flip_winding() {
    // A counter-clockwise quad facing +Z; mirrored in X by a node with scale (−1, 1, 1) it
    // must still face +Z (glTF 2.0 §3.7.4: the winding flips with the determinant).
    for (scale, what) in [([1.0, 1.0, 1.0], "plain"), ([-1.0, 1.0, 1.0], "mirrored")] {
        let bytes = doc(&QUAD, &[0, 1, 2, 0, 2, 3], |v| v["nodes"][0]["scale"] = json!(scale));
        let (scene, _) = load_from_bytes(&bytes, Path::new("m.gltf"), &LoadOptions::default()).unwrap();
        for t in scene.positions.chunks_exact(3) {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            assert!(n.z > 0.0, "{what}: front face must stay +Z, got {n:?}");
        }
    }
}

#[test]
fn node_transforms_keep_f64_precision() {
    // glTF JSON numbers are doubles; a translation of 1e6 + 0.123456 must survive to the
    // f64 scene (f32 would round it to 1000000.125).
    let bytes =
        doc(&QUAD, &[0, 1, 2], |v| v["nodes"][0]["translation"] = json!([1_000_000.123_456, 0.0, 0.0]));
    let (scene, _) = load_from_bytes(&bytes, Path::new("p.gltf"), &LoadOptions::default()).unwrap();
    assert!((scene.positions[0].x - 1_000_000.123_456).abs() < 1e-9, "{}", scene.positions[0].x);
}

#[test]
fn far_from_the_origin_renders_the_same_image() {
    // The Cornell box under a root node translated by 10⁶ in every axis. Camera-relative
    // flattening in f64 keeps every f32 vertex within one ulp of the untranslated scene (the
    // only loss: the camera's decimal position plus 10⁶ rounds in f64), so the images agree
    // up to the rare path that takes a different branch on a one-ulp difference. In f32
    // world coordinates the same scene would be quantised to 0.0625 units.
    let path = common::scene("cornell-box.gltf");
    let mut v: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let roots = v["scenes"][0]["nodes"].clone();
    let root = v["nodes"].as_array().unwrap().len();
    v["nodes"].as_array_mut().unwrap().push(json!({"translation": [1e6, 1e6, 1e6], "children": roots}));
    v["scenes"][0]["nodes"] = json!([root]);
    let (far, _) = load_from_bytes(&serde_json::to_vec(&v).unwrap(), &path, &LoadOptions::default()).unwrap();
    let (near, _) = load(&path).unwrap();
    let view = ViewSettings { camera: None, aspect: 1.0 };
    let (far, near) = (FlatScene::build(&far, &view).unwrap(), FlatScene::build(&near, &view).unwrap());
    for (f, n) in far.triangles.iter().zip(&near.triangles) {
        for (a, b) in [f.p0, f.p1, f.p2].iter().flatten().zip([n.p0, n.p1, n.p2].iter().flatten()) {
            assert!(
                (a - b).abs() <= 2.0 * f32::EPSILON * a.abs().max(b.abs()),
                "{a} vs {b}: more than an ulp apart"
            );
        }
    }
    let settings = pathlight::RenderSettings { width: 32, height: 32, spp: 4, ..Default::default() };
    let a = common::render(&mut pathlight::cpu::CpuBackend::new(&far, &settings), 4);
    let b = common::render(&mut pathlight::cpu::CpuBackend::new(&near, &settings), 4);
    // One-ulp geometry differences perturb the last bits of most radiance values; a whole
    // path diverges only where such a difference flips a comparison, in a few pixels.
    let close = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(x, y)| {
            (Vec3::from(x.mean) - Vec3::from(y.mean)).abs().max_element()
                <= 1e-3 * Vec3::from(y.mean).max_element() + 1e-6
        })
        .count();
    assert!(close * 100 >= a.pixels.len() * 97, "only {close} of {} pixels agree to 1e-3", a.pixels.len());
    for ((ma, _), (mb, _)) in
        common::image_mean_and_standard_error(&a).into_iter().zip(common::image_mean_and_standard_error(&b))
    {
        assert!((ma - mb).abs() < 1e-2 * mb, "means {ma} vs {mb}");
    }
}

#[test]
#[cfg_attr(
    not(feature = "shared-assets"),
    ignore = "needs ../shared/assets: cargo test --features shared-assets"
)]
fn khronos_sample_assets_load() {
    let assets = common::assets();
    // (file, expected triangle count after instancing and dropping degenerate triangles)
    let expected: &[(&str, Option<usize>)] = &[
        ("khronos/Box/Box.glb", Some(12)),
        ("khronos/NegativeScaleTest/NegativeScaleTest.glb", None),
        ("khronos/OrientationTest/OrientationTest.glb", None),
        ("khronos/EmissiveStrengthTest/EmissiveStrengthTest.glb", None),
        ("khronos/SpecularTest/SpecularTest.glb", None),
        ("khronos/TransmissionRoughnessTest/TransmissionRoughnessTest.glb", None),
        ("khronos/AttenuationTest/AttenuationTest.glb", None),
        ("khronos/LightsPunctualLamp/LightsPunctualLamp.gltf", None),
        ("khronos/Cameras/Cameras.gltf", Some(2)),
        ("khronos/DamagedHelmet/DamagedHelmet.glb", Some(15_452)),
        ("khronos/ClearCoatTest/ClearCoatTest.glb", None),
        ("khronos/GlassVaseFlowers/GlassVaseFlowers.glb", None),
        ("khronos/TextureTransformTest/TextureTransformTest.gltf", None),
        ("khronos/AlphaBlendModeTest/AlphaBlendModeTest.glb", None),
        ("khronos/ToyCar/ToyCar.gltf", None),
        ("khronos/TransmissionTest/TransmissionTest.glb", None),
        ("bvh/stanford-bunny.glb", Some(69_451)),
    ];
    for (file, tris) in expected {
        let (scene, warnings) = load(&assets.join(file)).unwrap_or_else(|e| panic!("{e}"));
        eprintln!(
            "{file}: {} triangles, {} materials, {} lights, {} cameras; {warnings:?}",
            scene.triangle_count(),
            scene.materials.len(),
            scene.lights.len(),
            scene.cameras.len()
        );
        if let Some(t) = tris {
            assert_eq!(scene.triangle_count(), *t, "{file}");
        }
    }
    let (lamp, _) = load(&assets.join("khronos/LightsPunctualLamp/LightsPunctualLamp.gltf")).unwrap();
    assert_eq!(lamp.lights.len(), 5, "LightsPunctualLamp has 5 point lights");
    let (emissive, _) = load(&assets.join("khronos/EmissiveStrengthTest/EmissiveStrengthTest.glb")).unwrap();
    let strongest = emissive.materials.iter().map(|m| m.emission.max_element()).fold(0.0, f32::max);
    // emissiveFactor is at most 1, so emission above 1 shows the strength was applied.
    assert!(strongest > 1.0, "emissive strength applied: {strongest}");
    let (cameras, _) = load(&assets.join("khronos/Cameras/Cameras.gltf")).unwrap();
    assert_eq!(cameras.cameras.len(), 2, "perspective and orthographic");
}
