//! Measures the irradiance cache (issue 46) against the path tracer at equal time: relMSE
//! (bias included) against a converged reference at a few short times, the time the path
//! tracer needs to catch up with the cache's error at the longest of them, and what the
//! cache costs (records, build time, memory).
//!
//!   cargo run --release --example irradiance_cache_error -- SCENE --reference REF.exr
//!       [--size 512] [--seconds 2,5,10] [--path-seconds 60] [--ic-accuracy A,B]
//!       [--ic-rays N] [--out DIR]
//!
//! Both renderers run as `pathlight render` runs them on the CPU backend (the path tracer
//! with its defaults: four continuations, caustics light-traced where exact), each as one
//! progressive render whose relMSE is taken at 1, 2, 4, … spp; the error at a time is
//! interpolated log–log between its checkpoints (`bench::series::Series`), and the cache's
//! first checkpoint includes placing its records. Where the path tracer's series ends
//! before it reaches the cache's error, its catch-up time is extrapolated from its last
//! checkpoint by the 1/t law of an unbiased estimator, and marked so. Prints a markdown
//! table.

use std::path::PathBuf;

use pathlight::bench::series::Series;
use pathlight::film::LinearImage;
use pathlight::integrator::irradiance_cache::IrradianceCacheSettings;
use pathlight::session::{BackendChoice, Session, SessionOptions};

struct Args {
    scene: PathBuf,
    size: u32,
    seconds: Vec<f64>,
    path_seconds: f64,
    accuracies: Vec<f32>,
    rays: u32,
    reference: PathBuf,
    out: PathBuf,
}

fn parse_args() -> Args {
    let mut args = Args {
        scene: PathBuf::new(),
        size: 512,
        seconds: vec![2.0, 5.0, 10.0],
        path_seconds: 60.0,
        accuracies: vec![IrradianceCacheSettings::default().accuracy],
        rays: IrradianceCacheSettings::default().gather_rays,
        reference: PathBuf::new(),
        out: PathBuf::from("target/irradiance-cache-error"),
    };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = || it.next().unwrap_or_else(|| panic!("{a} needs a value"));
        match a.as_str() {
            "--size" => args.size = value().parse().expect("--size N"),
            "--seconds" => {
                args.seconds = value().split(',').map(|s| s.parse().expect("--seconds A,B,C")).collect()
            }
            "--path-seconds" => args.path_seconds = value().parse().expect("--path-seconds S"),
            "--ic-accuracy" => {
                args.accuracies = value().split(',').map(|s| s.parse().expect("--ic-accuracy A,B")).collect()
            }
            "--ic-rays" => args.rays = value().parse().expect("--ic-rays N"),
            "--reference" => args.reference = PathBuf::from(value()),
            "--out" => args.out = PathBuf::from(value()),
            _ if args.scene.as_os_str().is_empty() => args.scene = PathBuf::from(a),
            _ => panic!("unknown argument {a}"),
        }
    }
    assert!(
        !args.scene.as_os_str().is_empty() && !args.reference.as_os_str().is_empty(),
        "usage: irradiance_cache_error SCENE --reference REF.exr [options]"
    );
    args
}

fn options(args: &Args, spp: u32, cache: Option<IrradianceCacheSettings>) -> SessionOptions {
    let mut o = SessionOptions::new(&args.scene);
    o.width = Some(args.size);
    o.height = Some(args.size);
    o.spp = spp;
    o.seed = 7;
    o.backend = BackendChoice::Cpu;
    o.irradiance_cache = cache;
    o
}

/// One progressive render until `seconds` have passed: its relMSE series, and the cache's
/// statistics when it has one. The time spent measuring the error is left out.
fn series(
    args: &Args,
    label: &str,
    cache: Option<IrradianceCacheSettings>,
    seconds: f64,
    reference: &LinearImage,
) -> (Series, Option<pathlight::integrator::irradiance_cache::IrradianceCacheStats>) {
    let spp = 1 << 20;
    let mut session = Session::open(&options(args, spp, cache)).unwrap_or_else(|e| panic!("{e}"));
    let s = Series::of_session(&mut session, label, seconds, reference).unwrap_or_else(|e| panic!("{e}"));
    let stats = session.irradiance_cache_stats();
    let name =
        format!("{}-{}.csv", args.scene.file_stem().unwrap().to_string_lossy(), label.replace(' ', "-"));
    std::fs::write(args.out.join(name), s.csv()).unwrap();
    (s, stats)
}

fn main() {
    let args = parse_args();
    std::fs::create_dir_all(&args.out).unwrap();
    let name = args.scene.file_stem().unwrap().to_string_lossy().into_owned();
    let reference = LinearImage::read(&args.reference).unwrap_or_else(|e| panic!("{e}"));
    let longest = args.seconds.iter().cloned().fold(0.0, f64::max);
    let (path, _) = series(&args, "path", None, args.path_seconds, &reference);
    let mut rows = Vec::new();
    for &accuracy in &args.accuracies {
        let settings = IrradianceCacheSettings {
            accuracy,
            gather_rays: args.rays,
            ..IrradianceCacheSettings::default()
        };
        let label = format!("cache a {accuracy}");
        let (cached, stats) = series(&args, &label, Some(settings), longest, &reference);
        rows.push((settings, cached, stats.expect("a cached render has cache statistics")));
    }

    println!("\n{name}, {0}×{0}, CPU backend, reference {1}\n", args.size, args.reference.display());
    println!("| accuracy | gather rays | records | placed in | cache memory | time | relMSE path | relMSE cached | path ÷ cached |");
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (settings, cached, stats) in &rows {
        for &t in &args.seconds {
            let (p, c) = (path.error_at_time(t), cached.error_at_time(t));
            let fmt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3e}"));
            println!(
                "| {} | {} | {} | {:.2} s | {:.0} KiB | {t} s | {} | {} | {} |",
                settings.accuracy,
                settings.gather_rays,
                stats.records,
                stats.seconds,
                stats.bytes as f64 / 1024.0,
                fmt(p),
                fmt(c),
                match (p, c) {
                    (Some(p), Some(c)) => format!("**{:.1}×**", p / c),
                    _ => "-".into(),
                }
            );
        }
    }
    println!();
    for (settings, cached, _) in &rows {
        if let Some(e) = cached.error_at_time(longest) {
            match path.time_to_error_or_extrapolated(e) {
                Some((t, extrapolated)) => println!(
                    "accuracy {}: the path tracer reaches the cache's {longest} s error ({e:.3e}) after {t:.0} s{}",
                    settings.accuracy,
                    if extrapolated { " (extrapolated by 1/t past its last checkpoint)" } else { "" }
                ),
                None => println!("accuracy {}: the path tracer's series is empty", settings.accuracy),
            }
        }
    }
}
