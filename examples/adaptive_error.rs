//! Measures adaptive sampling (issue 47) against uniform sampling at equal time: a uniform
//! render's relMSE against a converged reference at 1, 2, 4, … spp, and adaptive renders at
//! several thresholds, each compared with the uniform series at its own time (interpolated
//! log–log, `bench::series::Series`), with the image means, which an unbiased scheme leaves
//! where they were.
//!
//!   cargo run --release --example adaptive_error -- SCENE --reference REF.exr
//!       [--size 256] [--spp 1024] [--thresholds 0.1,0.05,0.02] [--min-spp 16]
//!       [--env MAP.hdr --env-intensity K] [--backend cpu|gpu] [--no-light-tracing]
//!
//! The reference must be a render of the same scene, size and environment (for example one
//! made on a fast GPU with `pathlight render --spp 65536`). Prints a markdown table.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use pathlight::bench::series::Series;
use pathlight::film::{error_against, LinearImage};
use pathlight::sampling::adaptive::AdaptiveSettings;
use pathlight::session::{BackendChoice, EnvironmentChoice, Session, SessionOptions};

struct Args {
    scene: PathBuf,
    reference: PathBuf,
    size: u32,
    spp: u32,
    thresholds: Vec<f32>,
    min_spp: u32,
    env: Option<(PathBuf, f32)>,
    backend: BackendChoice,
    light_tracing: bool,
}

fn parse_args() -> Args {
    let mut args = Args {
        scene: PathBuf::new(),
        reference: PathBuf::new(),
        size: 256,
        spp: 1024,
        thresholds: vec![0.1, 0.05, 0.02],
        min_spp: 16,
        env: None,
        backend: BackendChoice::Cpu,
        light_tracing: true,
    };
    let mut it = std::env::args().skip(1);
    let (mut env_path, mut env_intensity) = (None, 1.0f32);
    while let Some(a) = it.next() {
        let mut value = || it.next().unwrap_or_else(|| panic!("{a} needs a value"));
        match a.as_str() {
            "--reference" => args.reference = PathBuf::from(value()),
            "--size" => args.size = value().parse().expect("--size N"),
            "--spp" => args.spp = value().parse().expect("--spp N"),
            "--thresholds" => {
                args.thresholds = value().split(',').map(|t| t.parse().expect("--thresholds A,B")).collect()
            }
            "--min-spp" => args.min_spp = value().parse().expect("--min-spp N"),
            "--env" => env_path = Some(PathBuf::from(value())),
            "--env-intensity" => env_intensity = value().parse().expect("--env-intensity K"),
            "--backend" => {
                args.backend = match value().as_str() {
                    "cpu" => BackendChoice::Cpu,
                    "gpu" => BackendChoice::Gpu,
                    other => panic!("--backend cpu|gpu, not {other}"),
                }
            }
            "--no-light-tracing" => args.light_tracing = false,
            _ if args.scene.as_os_str().is_empty() => args.scene = PathBuf::from(a),
            _ => panic!("unknown argument {a}"),
        }
    }
    assert!(
        !args.scene.as_os_str().is_empty() && !args.reference.as_os_str().is_empty(),
        "usage: adaptive_error SCENE --reference REF.exr [options]"
    );
    args.env = env_path.map(|p| (p, env_intensity));
    args
}

fn options(args: &Args, adaptive: Option<AdaptiveSettings>) -> SessionOptions {
    let mut o = SessionOptions::new(&args.scene);
    o.width = Some(args.size);
    o.height = Some(args.size);
    o.spp = args.spp;
    o.seed = 11;
    o.backend = args.backend;
    o.light_tracing = args.light_tracing;
    o.adaptive = adaptive;
    if let Some((path, intensity)) = &args.env {
        o.environment =
            EnvironmentChoice::Map { path: path.clone(), intensity: *intensity, rotation_degrees: 0.0 };
    }
    o
}

/// The image's mean over pixels, per channel, relative to the reference's.
fn mean_ratio(image: &LinearImage, reference: &LinearImage) -> [f64; 3] {
    [0, 1, 2].map(|c| {
        let sum = |i: &LinearImage| i.rgb.iter().map(|p| p[c] as f64).sum::<f64>();
        sum(image) / sum(reference).max(1e-30)
    })
}

fn main() {
    let args = parse_args();
    let reference = LinearImage::read(&args.reference).unwrap_or_else(|e| panic!("{e}"));
    let stop = AtomicBool::new(false);

    // The uniform series, its measurement time left out.
    let mut session = Session::open(&options(&args, None)).unwrap_or_else(|e| panic!("{e}"));
    let backend = session.backend_name();
    let mut uniform = Series { label: "uniform".into(), points: Vec::new(), key: None };
    let start = Instant::now();
    let mut excluded = 0.0;
    session
        .render_to(args.spp, &stop, |b, done| {
            if done.is_power_of_two() || done == args.spp {
                let t = Instant::now();
                let e = error_against(&LinearImage::from_film(&b.film()?), &reference).1;
                excluded += t.elapsed().as_secs_f64();
                uniform.points.push((done, start.elapsed().as_secs_f64() - excluded, e));
            }
            Ok(false)
        })
        .unwrap();
    let name = args.scene.file_stem().unwrap().to_string_lossy().into_owned();
    println!(
        "\n{name}, {0}×{0}, backend {backend}, at most {1} spp, pilot {2} spp\n",
        args.size, args.spp, args.min_spp
    );
    println!(
        "uniform: {}",
        uniform
            .points
            .iter()
            .map(|(s, t, e)| format!("{s} spp {t:.2} s {e:.3e}"))
            .collect::<Vec<_>>()
            .join("; ")
    );
    println!("\n| threshold | seconds | mean spp | relMSE adaptive | relMSE uniform at equal time | uniform ÷ adaptive | image mean ÷ reference (R, G, B) |");
    println!("|---:|---:|---:|---:|---:|---:|---|");
    for &threshold in &args.thresholds {
        let adaptive = AdaptiveSettings { threshold, min_spp: args.min_spp };
        let mut session = Session::open(&options(&args, Some(adaptive))).unwrap();
        let stats = session.render_to(args.spp, &stop, |_, _| Ok(false)).unwrap();
        let image = LinearImage::from_film(&session.film().unwrap());
        let e = error_against(&image, &reference).1;
        let budgets = session.sample_budgets().unwrap();
        let mean_spp = budgets.iter().map(|&b| b as f64).sum::<f64>() / budgets.len() as f64;
        let u = uniform.error_at_time(stats.seconds);
        let m = mean_ratio(&image, &reference);
        println!(
            "| {threshold} | {:.2} | {mean_spp:.1} | {e:.3e} | {} | {} | {:.4}, {:.4}, {:.4} |",
            stats.seconds,
            u.map_or("-".into(), |u| format!("{u:.3e}")),
            u.map_or("-".into(), |u| format!("{:.2}×", u / e)),
            m[0],
            m[1],
            m[2]
        );
    }
}
