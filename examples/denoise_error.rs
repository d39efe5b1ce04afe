//! Measures the denoisers (issue 47): relMSE and FLIP against a converged reference at a few
//! sample counts, against the raw image of the same samples and the raw image of the same
//! total time (render, AOVs and denoising), and what denoising costs as a share of the
//! render.
//!
//!   cargo run --release --example denoise_error -- SCENE [--size 512] [--spp 4,16,64]
//!       [--denoiser atrous,oidn] [--reference REF.exr | --reference-spp 4096]
//!       [--env MAP.hdr --env-intensity K] [--backend cpu|gpu] [--out DIR]
//!
//! The reference is read when given (a render of the same scene and size, e.g. one made on
//! a fast GPU), else rendered here and written to DIR/<scene>-reference.exr for reuse. The
//! raw series runs on the same backend as the denoised renders, one progressive render whose
//! relMSE is taken at 1, 2, 4, … spp; the error at equal time is interpolated log–log
//! between its checkpoints (`bench::series::Series`). Prints a markdown table.

use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use pathlight::bench::series::Series;
use pathlight::denoise::Denoiser;
use pathlight::film::{compare_images, error_against, AovSelection, CompareOptions, LinearImage};
use pathlight::session::{BackendChoice, EnvironmentChoice, OutputOptions, Session, SessionOptions};

struct Args {
    scene: PathBuf,
    size: u32,
    spp: Vec<u32>,
    denoisers: Vec<Denoiser>,
    reference: Option<PathBuf>,
    reference_spp: u32,
    env: Option<(PathBuf, f32)>,
    backend: BackendChoice,
    out: PathBuf,
}

fn parse_args() -> Args {
    let mut args = Args {
        scene: PathBuf::new(),
        size: 512,
        spp: vec![4, 16, 64],
        denoisers: vec![Denoiser::Atrous],
        reference: None,
        reference_spp: 4096,
        env: None,
        backend: BackendChoice::Cpu,
        out: PathBuf::from("target/denoise-error"),
    };
    let mut it = std::env::args().skip(1);
    let mut env_intensity = 1.0f32;
    let mut env_path = None;
    while let Some(a) = it.next() {
        let mut value = || it.next().unwrap_or_else(|| panic!("{a} needs a value"));
        match a.as_str() {
            "--size" => args.size = value().parse().expect("--size N"),
            "--spp" => args.spp = value().split(',').map(|s| s.parse().expect("--spp A,B,C")).collect(),
            "--denoiser" => {
                args.denoisers = value()
                    .split(',')
                    .map(|s| Denoiser::from_name(s).unwrap_or_else(|e| panic!("{e}")))
                    .collect()
            }
            "--reference" => args.reference = Some(PathBuf::from(value())),
            "--reference-spp" => args.reference_spp = value().parse().expect("--reference-spp N"),
            "--env" => env_path = Some(PathBuf::from(value())),
            "--env-intensity" => env_intensity = value().parse().expect("--env-intensity K"),
            "--backend" => {
                args.backend = match value().as_str() {
                    "cpu" => BackendChoice::Cpu,
                    "gpu" => BackendChoice::Gpu,
                    other => panic!("--backend cpu|gpu, not {other}"),
                }
            }
            "--out" => args.out = PathBuf::from(value()),
            _ if args.scene.as_os_str().is_empty() => args.scene = PathBuf::from(a),
            _ => panic!("unknown argument {a}"),
        }
    }
    assert!(!args.scene.as_os_str().is_empty(), "usage: denoise_error SCENE [options]");
    args.env = env_path.map(|p| (p, env_intensity));
    args
}

fn options(args: &Args, spp: u32, seed: u32, outputs: OutputOptions) -> SessionOptions {
    let mut o = SessionOptions::new(&args.scene);
    o.width = Some(args.size);
    o.height = Some(args.size);
    o.spp = spp;
    o.seed = seed;
    o.backend = args.backend;
    o.outputs = outputs;
    if let Some((path, intensity)) = &args.env {
        o.environment =
            EnvironmentChoice::Map { path: path.clone(), intensity: *intensity, rotation_degrees: 0.0 };
    }
    o
}

fn reference(args: &Args, name: &str) -> LinearImage {
    if let Some(path) = &args.reference {
        return LinearImage::read(path).unwrap_or_else(|e| panic!("{e}"));
    }
    let path = args.out.join(format!("{name}-{}-reference.exr", args.size));
    if let Ok(image) = LinearImage::read(&path) {
        eprintln!("reusing {}", path.display());
        return image;
    }
    eprintln!("rendering the reference, {} spp", args.reference_spp);
    let mut session = Session::open(&options(args, args.reference_spp, 1_000_003, OutputOptions::default()))
        .unwrap_or_else(|e| panic!("{e}"));
    session.render_to(args.reference_spp, &AtomicBool::new(false), |_, _| Ok(false)).unwrap();
    session.write(std::slice::from_ref(&path), pathlight::film::Tonemap::Clamp, 0.0).unwrap();
    LinearImage::read(&path).unwrap()
}

/// `image` as a [`LinearImage`] of the reference's size.
fn linear(image: &[glam::Vec3], reference: &LinearImage) -> LinearImage {
    LinearImage {
        width: reference.width,
        height: reference.height,
        rgb: image.iter().map(|v| v.to_array()).collect(),
        variance: None,
        spp: None,
        replicate_variance: None,
    }
}

fn flip(image: &[glam::Vec3], reference: &LinearImage) -> f64 {
    let options = CompareOptions { max_abs: Some(f64::INFINITY), ..CompareOptions::default() };
    compare_images(&linear(image, reference), reference, &options).unwrap().metrics.flip
}

fn relmse(image: &[glam::Vec3], reference: &LinearImage) -> f64 {
    error_against(&linear(image, reference), reference).1
}

fn main() {
    let args = parse_args();
    std::fs::create_dir_all(&args.out).unwrap();
    let name = args.scene.file_stem().unwrap().to_string_lossy().into_owned();
    let reference = reference(&args, &name);
    let max_spp = *args.spp.iter().max().unwrap();

    // The raw series: one progressive render, relMSE at 1, 2, 4, … spp, long enough for the
    // equal-time comparison of the largest count (denoising adds its time).
    let raw_spp = (max_spp * 4).max(64);
    let mut session = Session::open(&options(&args, raw_spp, 7, OutputOptions::default())).unwrap();
    let mut raw = Series { label: "raw".into(), points: Vec::new(), key: None };
    let start = Instant::now();
    let mut seconds_excluded = 0.0;
    session
        .render_to(raw_spp, &AtomicBool::new(false), |backend, done| {
            if done.is_power_of_two() {
                let t = Instant::now();
                let mean = backend.film()?.mean();
                let e = relmse(&mean, &reference);
                seconds_excluded += t.elapsed().as_secs_f64();
                raw.points.push((done, start.elapsed().as_secs_f64() - seconds_excluded, e));
            }
            Ok(false)
        })
        .unwrap();
    let backend = session.backend_name();

    println!("\n{name}, {0}×{0}, backend {backend}\n", args.size);
    println!("| denoiser | spp | render s | AOVs s | denoise s | denoise share | relMSE raw | relMSE denoised | raw ÷ denoised | relMSE raw at equal time | ÷ denoised | FLIP raw | FLIP denoised |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for &denoiser in &args.denoisers {
        for &spp in &args.spp {
            let outputs = OutputOptions { aovs: AovSelection::default(), denoiser: Some(denoiser) };
            let mut session = Session::open(&options(&args, spp, 7, outputs)).unwrap();
            let stats = session.render_to(spp, &AtomicBool::new(false), |_, _| Ok(false)).unwrap();
            let (image, timing) = session.denoised(denoiser).unwrap();
            let e = relmse(&image, &reference);
            // The raw image of these very samples (its textures read at this spp's level of
            // detail, as the AOVs are): what the denoiser started from.
            let raw_mean = session.film().unwrap().mean();
            let raw_here = relmse(&raw_mean, &reference);
            let total = stats.seconds + timing.aov_seconds + timing.denoise_seconds;
            let raw_equal = raw.error_at_time(total);
            let extra = timing.aov_seconds + timing.denoise_seconds;
            println!(
                "| {denoiser} | {spp} | {:.3} | {:.3} | {:.3} | {:.1}% | {:.3e} | {:.3e} | {:.1}× | {} | {} | {:.4} | {:.4} |",
                stats.seconds,
                timing.aov_seconds,
                timing.denoise_seconds,
                100.0 * extra / stats.seconds,
                raw_here,
                e,
                raw_here / e,
                raw_equal.map_or("-".into(), |r| format!("{r:.3e}")),
                raw_equal.map_or("-".into(), |r| format!("{:.1}×", r / e)),
                flip(&raw_mean, &reference),
                flip(&image, &reference)
            );
            if std::env::var_os("DENOISE_DUMP").is_some() {
                let dump = |name: &str, v: &[glam::Vec3]| {
                    let bytes: Vec<u8> =
                        v.iter().flat_map(|c| c.to_array()).flat_map(f32::to_le_bytes).collect();
                    std::fs::write(args.out.join(format!("{name}.f32")), bytes).unwrap();
                };
                dump("denoised", &image);
                dump("raw", &session.film().unwrap().mean());
                let r: Vec<glam::Vec3> = reference.rgb.iter().map(|c| glam::Vec3::from(*c)).collect();
                dump("reference", &r);
                let aovs = session.aovs().unwrap();
                dump("albedo", &aovs.albedo);
                dump("normal", &aovs.normal);
            }
            let png = args.out.join(format!("{name}-{}-{denoiser}-{spp}.png", args.size));
            let _ = pathlight::film::write_png_rgb(
                args.size,
                args.size,
                &image,
                &png,
                pathlight::film::Tonemap::Aces,
                0.0,
            );
        }
    }
}
