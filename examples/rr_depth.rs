//! Where should Russian roulette start? Measures, per start depth, the efficiency
//! 1 / (relMSE × seconds) of CPU renders against a high-sample reference (issue 8: the start
//! depth is to be chosen by measured efficiency, not by habit).
//!
//!   cargo run --release --example rr_depth [-- --size 96 --spp 32 --reference-spp 2048 --seeds 3
//!       --splits 4 --depths 1,2,3,4,5,6,8 --reference REF.exr SCENES...]
//!
//! `--splits` defaults to the CPU backend's (`CPU_DEFAULT_SPLITS`), so that the depths are
//! compared where the renderer runs. `--reference` reads an independent reference image
//! (one scene only) instead of rendering one here.

use pathlight::cpu::CpuBackend;
use pathlight::film::{error_against, LinearImage};
use pathlight::scene::{FlatScene, ViewSettings};
use pathlight::{Backend, RenderSettings};

fn render(
    scene: &FlatScene,
    size: u32,
    spp: u32,
    seed: u32,
    rr_min_depth: u32,
    splits: u32,
) -> (LinearImage, f64) {
    let settings = RenderSettings {
        width: size,
        height: size,
        spp,
        seed,
        rr_min_depth,
        splits,
        // As `pathlight render` does by default, where the scene allows it.
        light_tracing: true,
        ..RenderSettings::default()
    };
    let mut backend = CpuBackend::new(scene, &settings);
    let start = std::time::Instant::now();
    backend.render(0, spp).expect("the CPU backend does not fail");
    let seconds = start.elapsed().as_secs_f64();
    (LinearImage::from_film(&backend.film().expect("the CPU film")), seconds)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    // The word after option `name`.
    let text = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let value = |name: &str, default: u32| text(name).map_or(default, |v| v.parse().unwrap());
    let (size, spp, reference_spp) =
        (value("--size", 96), value("--spp", 32), value("--reference-spp", 2048));
    let seeds = value("--seeds", 3);
    let splits = value("--splits", pathlight::render::CPU_DEFAULT_SPLITS);
    let depths: Vec<u32> = text("--depths").map_or(vec![1, 2, 3, 4, 5, 6, 8], |list| {
        list.split(',').map(|d| d.parse().expect("--depths: a comma-separated list of depths")).collect()
    });
    let reference_file = text("--reference");
    let mut scenes: Vec<String> = args
        .iter()
        .enumerate()
        .filter(|(i, a)| !a.starts_with("--") && (*i == 0 || !args[i - 1].starts_with("--")))
        .map(|(_, a)| a.clone())
        .collect();
    if scenes.is_empty() {
        scenes = vec!["scenes/cornell-box.gltf".into(), "scenes/glass-smooth.gltf".into()];
    }
    if reference_file.is_some() && scenes.len() != 1 {
        eprintln!("--reference is one scene's image: give exactly one scene with it");
        std::process::exit(2);
    }
    println!("{splits} continuations per camera sample\n");
    println!("| scene | roulette from depth | relMSE at {spp} spp | seconds | efficiency 1/(relMSE·s) |");
    println!("|---|---:|---:|---:|---:|");
    for path in &scenes {
        let (scene, _) = pathlight::scene::load(std::path::Path::new(path)).unwrap_or_else(|e| panic!("{e}"));
        let flat = FlatScene::build(&scene, &ViewSettings { camera: None, aspect: 1.0 }).unwrap();
        // The reference without roulette's noise at the depths that matter: roulette from
        // depth 8, many samples (roulette is unbiased at every start depth).
        let reference = match &reference_file {
            Some(file) => LinearImage::read(std::path::Path::new(file)).unwrap_or_else(|e| panic!("{e}")),
            None => render(&flat, size, reference_spp, 1000, 8, splits).0,
        };
        for &depth in &depths {
            // Several seeds per depth: the error of one render at low spp is itself noisy.
            let (mut rel, mut secs) = (0.0, 0.0);
            for seed in 1..=seeds {
                let (image, s) = render(&flat, size, spp, seed, depth, splits);
                rel += error_against(&image, &reference).1 / seeds as f64;
                secs += s / seeds as f64;
            }
            println!("| {path} | {depth} | {rel:.4e} | {secs:.3} | {:.1} |", 1.0 / (rel * secs));
        }
    }
}
