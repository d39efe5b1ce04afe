//! Untrusted scenes: external URIs stay inside the scene's folder (issue 12).
//!
//! The layout every test builds, in its own temporary folder:
//!
//! ```text
//! root/secret/outside.bin     a buffer holding a triangle far from the legitimate one
//! root/scene/inside.bin       the legitimate buffer
//! root/scene/sub/dir/deep.bin, root/scene/with space.bin   legitimate, elsewhere inside
//! root/scene/link-out.bin  -> ../secret/outside.bin         a symbolic link leading out
//! root/scene/dir-out       -> ../secret                     a linked folder leading out
//! root/scene/link-in.bin   -> sub/dir/deep.bin              a link that stays inside
//! ```
//!
//! "Reads nothing" is shown with a target that would change the render: with
//! `allow_any_path` the same URI loads, and the scene then holds the outside triangle.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use pathlight::scene::{load_with, LoadOptions, Scene};
use serde_json::json;

/// The x coordinate of the triangle in the outside file; the inside ones sit at x ≤ 1.
const OUTSIDE_X: f32 = 1000.0;

fn triangle_bytes(x: f32) -> Vec<u8> {
    [[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x, 1.0, 0.0]]
        .iter()
        .flatten()
        .flat_map(|v: &f32| v.to_le_bytes())
        .collect()
}

/// Builds the layout above in a fresh folder named after the test; returns its root.
fn layout(name: &str) -> PathBuf {
    let root = std::env::temp_dir().join(format!("pathlight-uri-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let scene = root.join("scene");
    std::fs::create_dir_all(scene.join("sub/dir")).unwrap();
    std::fs::create_dir_all(root.join("secret")).unwrap();
    std::fs::write(root.join("secret/outside.bin"), triangle_bytes(OUTSIDE_X)).unwrap();
    std::fs::write(scene.join("inside.bin"), triangle_bytes(0.0)).unwrap();
    std::fs::write(scene.join("sub/dir/deep.bin"), triangle_bytes(0.5)).unwrap();
    std::fs::write(scene.join("with space.bin"), triangle_bytes(0.25)).unwrap();
    std::os::unix::fs::symlink("../secret/outside.bin", scene.join("link-out.bin")).unwrap();
    std::os::unix::fs::symlink("../secret", scene.join("dir-out")).unwrap();
    std::os::unix::fs::symlink("sub/dir/deep.bin", scene.join("link-in.bin")).unwrap();
    root
}

/// Writes `root/scene/main.gltf`: one triangle whose buffer has `uri`, and optionally an
/// image with `image_uri`. Returns the scene file.
fn scene_with(root: &Path, uri: &str, image_uri: Option<&str>) -> PathBuf {
    let mut v = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0.0, 0.0, 0.0], "max": [2000.0, 1.0, 0.0]}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}],
        "buffers": [{"byteLength": 36, "uri": uri}]
    });
    if let Some(image) = image_uri {
        v["images"] = json!([{"uri": image}]);
    }
    let file = root.join("scene/main.gltf");
    std::fs::write(&file, serde_json::to_vec(&v).unwrap()).unwrap();
    file
}

fn first_x(scene: &Scene) -> f32 {
    scene.positions[0].x as f32
}

fn strict() -> LoadOptions {
    LoadOptions::default()
}

fn trusting() -> LoadOptions {
    LoadOptions { allow_any_path: true }
}

/// Asserts `uri` is refused by default with an error naming the file, the element and the
/// URI, and that the same scene under `allow_any_path` would have rendered the outside file
/// (unless `never` is set: schemes stay refused even then).
fn refused(root: &Path, uri: &str, image: bool, never: bool) {
    let (buffer_uri, image_uri) = if image { ("inside.bin", Some(uri)) } else { (uri, None) };
    let file = scene_with(root, buffer_uri, image_uri);
    let err = load_with(&file, &strict()).map(|_| ()).expect_err(uri).to_string();
    let element = if image { "image 0" } else { "buffer 0" };
    assert!(err.starts_with(&file.display().to_string()), "names the file: {err}");
    assert!(err.contains(element) && err.contains(uri), "names the element and the URI: {err}");
    assert!(!err.contains("\u{0}") && err.len() < 400, "quotes nothing else: {err}");
    let trusted = load_with(&file, &trusting());
    if never {
        let e = trusted.map(|_| ()).expect_err("schemes stay refused").to_string();
        assert!(e.contains("never fetches"), "{e}");
    } else if !image {
        let (scene, _) = trusted.unwrap_or_else(|e| panic!("{uri} with allow_any_path: {e}"));
        assert_eq!(first_x(&scene), OUTSIDE_X, "{uri}: the outside file would have changed the render");
    } else {
        trusted.unwrap_or_else(|e| panic!("{uri} with allow_any_path: {e}"));
    }
}

#[test]
fn uris_leaving_the_scene_folder_are_refused() {
    let root = layout("refused");
    let outside = root.join("secret/outside.bin");
    let absolute = outside.to_str().unwrap().to_string();
    for image in [false, true] {
        refused(&root, &absolute, image, false);
        refused(&root, "../secret/outside.bin", image, false);
        refused(&root, "sub/../../secret/outside.bin", image, false);
        refused(&root, "%2e%2e/secret/outside.bin", image, false);
        refused(&root, "link-out.bin", image, false);
        refused(&root, "dir-out/outside.bin", image, false);
        refused(&root, &format!("file://{absolute}"), image, true);
        // Port 9 on loopback (discard): nothing is listening, and nothing may be asked.
        refused(&root, "http://127.0.0.1:9/outside.bin", image, true);
        refused(&root, "HTTPS://127.0.0.1:9/outside.bin", image, true);
    }
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn legitimate_uris_keep_working() {
    let root = layout("legitimate");
    let data = common::buffer_data_uri(&triangle_bytes(0.75));
    for (uri, x) in [
        ("inside.bin", 0.0),
        ("./inside.bin", 0.0),
        ("sub/dir/deep.bin", 0.5),
        ("sub/dir/../dir/deep.bin", 0.5),
        ("with%20space.bin", 0.25),
        ("link-in.bin", 0.5),
        (data.as_str(), 0.75),
    ] {
        let file = scene_with(&root, uri, Some("sub/dir/deep.bin"));
        let (scene, _) = load_with(&file, &strict()).unwrap_or_else(|e| panic!("{uri}: {e}"));
        assert_eq!(first_x(&scene), x, "{uri}");
    }
    // The Khronos models with external buffers and images load under the default rule (all
    // of them: tests/scene_load.rs `khronos_sample_assets_load`).
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn malformed_buffers_are_not_quoted() {
    // An index buffer made of a file's bytes must not be echoed in the error: the error
    // names positions and counts from the JSON only. The "secret" is ASCII text whose bytes,
    // read as u32 indices, would be large numbers.
    let root = layout("quote");
    let secret = b"root:x:0:0:root:/root:/bin/bash\n";
    std::fs::write(root.join("scene/secret.bin"), secret).unwrap();
    let mut positions = triangle_bytes(0.0);
    positions.extend_from_slice(secret);
    std::fs::write(root.join("scene/mixed.bin"), &positions).unwrap();
    let v = json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5125, "count": 3, "type": "SCALAR"}
        ],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 12}],
        "buffers": [{"byteLength": 36 + secret.len(), "uri": "mixed.bin"}]
    });
    let file = root.join("scene/quote.gltf");
    std::fs::write(&file, serde_json::to_vec(&v).unwrap()).unwrap();
    let err = load_with(&file, &strict()).map(|_| ()).expect_err("indices out of range").to_string();
    let as_index = u32::from_le_bytes(secret[0..4].try_into().unwrap()).to_string();
    assert!(!err.contains(&as_index), "the buffer's bytes are quoted: {err}");
    assert!(err.contains("element 0 of the indices"), "{err}");
    let _ = std::fs::remove_dir_all(&root);
}

#[test]
fn the_command_line_refuses_by_default_and_allow_any_path_lifts_it() {
    let root = layout("cli");
    let file = scene_with(&root, "../secret/outside.bin", None);
    let run = |extra: &[&str]| {
        let out_png = root.join("out.png");
        let mut c = Command::new(env!("CARGO_BIN_EXE_pathlight"));
        c.env("XDG_RUNTIME_DIR", "/tmp")
            .args(["render", file.to_str().unwrap(), "--backend", "cpu", "--spp", "1", "--width", "8"])
            .arg("-o")
            .arg(&out_png)
            .args(extra);
        c.output().unwrap()
    };
    let refused = run(&[]);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success(), "{stderr}");
    assert!(stderr.contains("buffer 0") && stderr.contains("--allow-any-path"), "{stderr}");
    let allowed = run(&["--allow-any-path"]);
    assert!(allowed.status.success(), "{}", String::from_utf8_lossy(&allowed.stderr));
    let _ = std::fs::remove_dir_all(&root);
}
