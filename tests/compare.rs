//! `pathlight compare`: measured false-alarm and detection rates (issue 9), bad input, and
//! the command line's exit codes and JSON.
//!
//! Renders are CPU renders at 64×64 (the statistics do not depend on the backend: tests/gpu.rs
//! shows both render the same image).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use pathlight::cpu::CpuBackend;
use pathlight::film::{compare_images, write_exr, CompareOptions, LinearImage, RenderMetadata};
use pathlight::sampling::SamplerKind;
use pathlight::scene::{FlatScene, Scene, ViewSettings};
use pathlight::RenderSettings;

const SIZE: u32 = 64;
/// Seed pairs per measured rate (the issue asks for at least 20).
const TRIALS: u32 = 20;
/// Samples per pixel at which the documented differences are detected (README, "Using
/// pathlight in CI"), and of the committed-style reference they are compared against.
const DETECT_SPP: u32 = 64;
const REFERENCE_SPP: u32 = 1024;

fn load(name: &str) -> Scene {
    pathlight::scene::load(&common::scene(name)).unwrap_or_else(|e| panic!("{e}")).0
}

fn flatten(scene: &Scene) -> FlatScene {
    FlatScene::build(scene, &ViewSettings { camera: None, aspect: 1.0 }).unwrap()
}

/// A render with the independent sampler, whose variance channels are exactly the variance
/// of the mean: the calibration the z-test's false-alarm and detection rates assume, and what
/// the README's CI workflow asks for (`--sampler independent`).
fn render(scene: &FlatScene, spp: u32, seed: u32) -> LinearImage {
    render_with(scene, spp, seed, SamplerKind::Independent)
}

fn render_with(scene: &FlatScene, spp: u32, seed: u32, sampler: SamplerKind) -> LinearImage {
    let settings =
        RenderSettings { width: SIZE, height: SIZE, spp, seed, sampler, ..RenderSettings::default() };
    LinearImage::from_film(&common::render(&mut CpuBackend::new(scene, &settings), spp))
}

/// The Cornell box with its back wall (z = 559.2 mm) `factor` times as bright in albedo.
fn back_wall_scaled(factor: f32) -> Scene {
    let mut scene = load("cornell-box.gltf");
    let white = scene.materials.iter().position(|m| m.name == "white").expect("white material");
    let mut darker = scene.materials[white].clone();
    darker.name = "back wall".into();
    darker.base_color *= factor;
    scene.materials.push(darker);
    let back = scene.materials.len() as u32 - 1;
    let mut changed = 0;
    for t in 0..scene.triangle_count() {
        let p = &scene.positions[3 * t..3 * t + 3];
        if scene.triangle_materials[t] == white as u32 && p.iter().all(|v| (v.z - 0.5592).abs() < 1e-6) {
            scene.triangle_materials[t] = back;
            changed += 1;
        }
    }
    assert_eq!(changed, 2, "the back wall is one quad");
    scene
}

/// The Cornell box with its light's emission scaled by `factor`.
fn light_scaled(factor: f32) -> Scene {
    let mut scene = load("cornell-box.gltf");
    let light = scene.materials.iter_mut().find(|m| m.name == "light").expect("light material");
    light.emission *= factor;
    scene
}

/// How many of `TRIALS` comparisons say "same".
fn passes(mut pair: impl FnMut(u32) -> (LinearImage, LinearImage)) -> u32 {
    (0..TRIALS)
        .filter(|&k| {
            let (test, reference) = pair(k);
            compare_images(&test, &reference, &CompareOptions::default()).unwrap().same()
        })
        .count() as u32
}

#[test]
fn equal_renders_pass_at_least_19_times_in_20() {
    // Bound: at the family-wise α = 0.01 the expected number of false alarms in 20 is 0.2;
    // 19 of 20 leaves room for one, which honest equal renders reach with probability
    // ≈ 1.7% (binomial), so a second failure means the test is miscalibrated.
    // The default Sobol sampler's variance channels over-state its error, so its z-test
    // errs on the side of "same": it must pass at least as often.
    for sampler in [SamplerKind::Independent, SamplerKind::Sobol] {
        for name in ["cornell-box.gltf", "glass-smooth.gltf"] {
            let scene = flatten(&load(name));
            for spp in [16, 64] {
                let same = passes(|k| {
                    (
                        render_with(&scene, spp, 2 * k + 1, sampler),
                        render_with(&scene, spp, 2 * k + 2, sampler),
                    )
                });
                eprintln!("{name} at {spp} spp, {sampler:?}, seed pairs: {same}/{TRIALS} pass");
                assert!(same >= TRIALS - 1, "{name} at {spp} spp, {sampler:?}: only {same}/{TRIALS} pass");
            }
        }
    }
}

#[test]
fn renders_against_a_high_sample_reference_pass_and_real_differences_fail() {
    let cornell = flatten(&load("cornell-box.gltf"));
    let reference = render(&cornell, REFERENCE_SPP, 1000);
    // The CI pattern: a committed high-spp reference, a low-spp render of the same scene.
    // At 16 spp most renders have not drawn the rarest bright paths yet; before the test
    // borrowed the reference's per-sample variance this raised 6 false alarms in 20.
    for spp in [16, DETECT_SPP] {
        let same = passes(|k| (render(&cornell, spp, k + 1), reference.clone()));
        eprintln!("cornell at {spp} spp against the {REFERENCE_SPP}-spp reference: {same}/{TRIALS} pass");
        assert!(same >= TRIALS - 1, "{spp} spp: only {same}/{TRIALS} pass");
    }
    // Power, measured over 200 seeds at 64 spp (2026-11-24): the darker back wall was found
    // every time, so it must be found in all 20 tries. The brighter light was missed 4 times
    // in 200 (about 2%), so 20 tries may miss it once or twice; at a 2% miss rate three
    // misses or more in 20 have probability 0.7%, and would mean the detector lost power.
    for (what, scene, allowed_misses) in
        [("back wall 3% darker", back_wall_scaled(0.97), 0), ("light 2% brighter", light_scaled(1.02), 2)]
    {
        let scene = flatten(&scene);
        let same = passes(|k| (render(&scene, DETECT_SPP, k + 1), reference.clone()));
        eprintln!("{what} at {DETECT_SPP} spp: detected {}/{TRIALS}", TRIALS - same);
        assert!(
            same <= allowed_misses,
            "{what} at {DETECT_SPP} spp went unnoticed {same} times in {TRIALS} (at most {allowed_misses} allowed)"
        );
    }
}

fn pathlight() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_pathlight"));
    c.env("XDG_RUNTIME_DIR", "/tmp");
    c
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pathlight-compare-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(image: &LinearImage, path: &Path) {
    let mut film = pathlight::film::Film::new(image.width as u32, image.height as u32);
    let var = image.variance.clone().unwrap_or_default();
    for (i, p) in film.pixels.iter_mut().enumerate() {
        // A film whose mean and variance of the mean are the image's: 2 samples, M2 = 2·var.
        p.count = 2;
        p.mean = image.rgb[i];
        p.m2 = var.get(i).map_or([0.0; 3], |v| v.map(|v| 2.0 * v));
    }
    let meta = RenderMetadata { samples: 0..2, ..RenderMetadata::default() };
    write_exr(&film, &meta, path).unwrap();
}

fn run(args: &[&Path], extra: &[&str]) -> (i32, String, String) {
    let out = pathlight().arg("compare").args(args).args(extra).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn command_line_exit_codes_and_json() {
    let dir = temp_dir("cli");
    let cornell = flatten(&load("cornell-box.gltf"));
    let (a, b, c) = (dir.join("a.exr"), dir.join("b.exr"), dir.join("darker.exr"));
    write(&render(&cornell, 16, 1), &a);
    write(&render(&cornell, 16, 2), &b);
    write(&render(&flatten(&light_scaled(0.5)), 16, 3), &c);

    let (diff, zmap) = (dir.join("d.png"), dir.join("z.exr"));
    let (code, stdout, stderr) =
        run(&[&a, &b], &["--json", "--diff", diff.to_str().unwrap(), "--zmap", zmap.to_str().unwrap()]);
    assert_eq!(code, 0, "{stdout}{stderr}");
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("JSON on stdout");
    assert_eq!(v["verdict"], "same");
    for key in ["rmse", "relmse", "mae", "psnr", "max_abs", "mean_ratio", "flip"] {
        assert!(!v["metrics"][key].is_null(), "metrics.{key} in {v}");
    }
    let stat = &v["statistical_test"];
    assert_eq!(stat["variance_from"], "both");
    assert!(stat["blocks"][0]["block"] == 4 && stat["blocks"][0]["passed_fraction"].is_number(), "{stat}");
    assert!(stat["image_mean"]["z"].is_array() && stat["worst_blocks"].is_array(), "{stat}");
    assert!(LinearImage::read(&zmap).unwrap().rgb.iter().all(|z| z.iter().all(|v| v.is_finite())));
    assert!(LinearImage::read(&diff).is_ok(), "the heat map is a readable PNG");

    let (code, stdout, _) = run(&[&c, &a], &[]);
    assert_eq!(code, 1, "a half-bright light differs: {stdout}");
    assert!(stdout.contains("verdict: different") && stdout.contains("image means differ"), "{stdout}");
}

#[test]
fn bad_inputs_exit_2_with_a_clear_message() {
    let dir = temp_dir("bad");
    let cornell = flatten(&load("cornell-box.gltf"));
    let good = dir.join("good.exr");
    let image = render(&cornell, 4, 1);
    write(&image, &good);
    let expect = |args: &[&Path], extra: &[&str], needle: &str| {
        let (code, _, stderr) = run(args, extra);
        assert_eq!(code, 2, "{args:?}: {stderr}");
        assert!(
            stderr.contains(needle) && !stderr.contains("panicked"),
            "{args:?}: '{stderr}' lacks '{needle}'"
        );
    };
    expect(&[&dir.join("missing.exr"), &good], &[], "missing.exr");

    let truncated = dir.join("truncated.exr");
    let bytes = std::fs::read(&good).unwrap();
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    expect(&[&truncated, &good], &[], "truncated.exr");

    let small = dir.join("small.exr");
    let mut half = image.clone();
    half.height /= 2;
    half.rgb.truncate(half.width * half.height);
    half.variance.as_mut().unwrap().truncate(half.width * half.height);
    write(&half, &small);
    expect(&[&small, &good], &[], "differ in size");

    let nan = dir.join("nan.exr");
    let mut poisoned = image.clone();
    poisoned.rgb[5][1] = f32::NAN;
    poisoned.rgb[70][0] = f32::INFINITY;
    write(&poisoned, &nan);
    expect(&[&nan, &good], &[], "2 pixel(s) hold non-finite values");

    // A PNG has no variance: without a threshold there is nothing to judge by.
    let png = dir.join("a.png");
    let mut film = pathlight::film::Film::new(SIZE, SIZE);
    film.pixels.iter_mut().for_each(|p| p.count = 1);
    pathlight::film::write_png(&film, &png, pathlight::film::Tonemap::Clamp, 0.0).unwrap();
    expect(&[&png, &png], &[], "give a threshold");
    let (code, stdout, _) = run(&[&png, &png], &["--max-flip", "0.01"]);
    assert_eq!(code, 0, "identical PNGs under a FLIP threshold: {stdout}");

    let no_rgb = dir.join("odd.txt");
    std::fs::write(&no_rgb, b"not an image").unwrap();
    expect(&[&no_rgb, &good], &[], "not an .exr or .png");
}

/// The table in the README ("Using pathlight in CI"): detection rate of each difference by
/// spp, against the same high-spp reference. A measurement, not a check:
/// `cargo test --release --test compare -- --ignored --nocapture`.
#[test]
#[ignore = "measurement for the README (about 3 minutes on 2 cores)"]
fn measure_detection_rate_by_spp() {
    let cornell = flatten(&load("cornell-box.gltf"));
    let reference = render(&cornell, REFERENCE_SPP, 1000);
    let cases = [
        ("unchanged (false alarms)", cornell.clone()),
        ("back wall 3% darker", flatten(&back_wall_scaled(0.97))),
        ("back wall 1% darker", flatten(&back_wall_scaled(0.99))),
        ("light 2% brighter", flatten(&light_scaled(1.02))),
        ("light 0.5% brighter", flatten(&light_scaled(1.005))),
    ];
    println!("| {SIZE}×{SIZE}, reference {REFERENCE_SPP} spp | 4 spp | 16 spp | 64 spp | 256 spp |");
    println!("|---|---:|---:|---:|---:|");
    for (what, scene) in &cases {
        let rates: Vec<String> = [4, 16, 64, 256]
            .iter()
            .map(|&spp| {
                let differ = TRIALS - passes(|k| (render(scene, spp, k + 1), reference.clone()));
                format!("{differ}/{TRIALS}")
            })
            .collect();
        println!("| {what} | {} |", rates.join(" | "));
    }
}
