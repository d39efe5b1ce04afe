//! Measures Metropolis light transport (issue 45) against BDPT and the path tracer at equal
//! time: relMSE against a converged reference at a few times, and the time BDPT and the path
//! tracer need to reach Metropolis's error at the longest of them.
//!
//!   cargo run --release --example mlt_error -- SCENE --reference REF.exr --max-depth D
//!       [--size 128] [--seconds 5,10,20] [--mutations-per-pixel N] [--luminance-too] [--out DIR]
//!
//! `--luminance-too` also runs Metropolis with the plain luminance target (`--mlt-target
//! luminance`; the default is `relative`), as a column of its own.
//! Every renderer runs as `pathlight render` runs it on the CPU backend with the same
//! `--max-depth` (Metropolis keeps one depth per chain, so its depth is bounded, and the
//! others are held to the same paths): the path tracer with its defaults (four
//! continuations, caustics light-traced where exact), BDPT, and Metropolis with its
//! defaults unless told otherwise. Each is one progressive render whose relMSE is taken at
//! 1, 2, 4, … samples (Metropolis: passes); the error at a time is interpolated log–log
//! between checkpoints (`bench::series::Series`). Where a series ends before it reaches
//! Metropolis's error, the catch-up time is extrapolated by the 1/t law of an unbiased
//! estimator, and marked so. The reference should be rendered by an integrator other than
//! Metropolis at the same depth. Prints a markdown table; the series go to DIR as CSV.

use std::path::PathBuf;

use pathlight::bench::series::Series;
use pathlight::film::{predicted_relmse, LinearImage};
use pathlight::integrator::mlt::{MltSettings, MltTarget};
use pathlight::integrator::Integrator;
use pathlight::session::{BackendChoice, Session, SessionOptions};

struct Args {
    scene: PathBuf,
    size: u32,
    seconds: Vec<f64>,
    max_depth: u32,
    mutations_per_pixel: Option<u32>,
    luminance_too: bool,
    reference: PathBuf,
    out: PathBuf,
}

fn parse_args() -> Args {
    let mut args = Args {
        scene: PathBuf::new(),
        size: 128,
        seconds: vec![5.0, 10.0, 20.0],
        max_depth: 0,
        mutations_per_pixel: None,
        luminance_too: false,
        reference: PathBuf::new(),
        out: PathBuf::from("target/mlt-error"),
    };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = || it.next().unwrap_or_else(|| panic!("{a} needs a value"));
        match a.as_str() {
            "--size" => args.size = value().parse().expect("--size N"),
            "--seconds" => {
                args.seconds = value().split(',').map(|s| s.parse().expect("--seconds A,B,C")).collect()
            }
            "--max-depth" => args.max_depth = value().parse().expect("--max-depth D"),
            "--mutations-per-pixel" => {
                args.mutations_per_pixel = Some(value().parse().expect("--mutations-per-pixel N"))
            }
            "--luminance-too" => args.luminance_too = true,
            "--reference" => args.reference = PathBuf::from(value()),
            "--out" => args.out = PathBuf::from(value()),
            _ if args.scene.as_os_str().is_empty() => args.scene = PathBuf::from(a),
            _ => panic!("unknown argument {a}"),
        }
    }
    assert!(
        !args.scene.as_os_str().is_empty() && !args.reference.as_os_str().is_empty() && args.max_depth > 0,
        "usage: mlt_error SCENE --reference REF.exr --max-depth D [options]"
    );
    args
}

/// One progressive render of `integrator` until `seconds` have passed: its relMSE series
/// (the time spent measuring the error left out), and Metropolis's acceptance rate.
/// Metropolis runs with `target`.
fn series(
    args: &Args,
    integrator: Integrator,
    target: MltTarget,
    seconds: f64,
    reference: &LinearImage,
) -> (Series, Option<f64>) {
    let spp = 1 << 20;
    let mut o = SessionOptions::new(&args.scene);
    o.width = Some(args.size);
    o.height = Some(args.size);
    o.spp = spp;
    o.seed = 7;
    o.backend = BackendChoice::Cpu;
    o.integrator = integrator;
    o.max_depth = Some(args.max_depth);
    if integrator == Integrator::Mlt {
        let defaults = MltSettings::default();
        o.mlt = MltSettings {
            mutations_per_pixel: args.mutations_per_pixel.unwrap_or(defaults.mutations_per_pixel),
            target,
            ..defaults
        };
    }
    let label = match (integrator, target) {
        (Integrator::Mlt, MltTarget::Luminance) => "mlt-luminance",
        _ => integrator.name(),
    };
    let mut session = Session::open(&o).unwrap_or_else(|e| panic!("{e}"));
    let s = Series::of_session(&mut session, label, seconds, reference).unwrap_or_else(|e| panic!("{e}"));
    let acceptance = session.mlt_stats().map(|m| m.acceptance_rate());
    let name = format!("{}-{label}.csv", args.scene.file_stem().unwrap().to_string_lossy());
    std::fs::write(args.out.join(name), s.csv()).unwrap();
    (s, acceptance)
}

fn main() {
    let args = parse_args();
    std::fs::create_dir_all(&args.out).unwrap();
    let name = args.scene.file_stem().unwrap().to_string_lossy().into_owned();
    let reference = LinearImage::read(&args.reference).unwrap_or_else(|e| panic!("{e}"));
    let longest = args.seconds.iter().cloned().fold(0.0, f64::max);
    let (mlt, acceptance) = series(&args, Integrator::Mlt, MltTarget::default(), longest, &reference);
    let luminance =
        args.luminance_too.then(|| series(&args, Integrator::Mlt, MltTarget::Luminance, longest, &reference));
    let (bdpt, _) = series(&args, Integrator::Bdpt, MltTarget::default(), longest, &reference);
    let (path, _) = series(&args, Integrator::Path, MltTarget::default(), longest, &reference);

    println!(
        "\n{name}, {0}×{0}, --max-depth {1}, CPU backend, reference {2} (its own relMSE {3}); Metropolis acceptance rate {4:.3}\n",
        args.size,
        args.max_depth,
        args.reference.display(),
        predicted_relmse(&reference).map_or("unknown".into(), |e| format!("{e:.2e}")),
        acceptance.unwrap_or(0.0)
    );
    if let Some((_, Some(a))) = &luminance {
        println!("Metropolis with the luminance target: acceptance rate {a:.3}\n");
    }
    let extra =
        if luminance.is_some() { " relMSE mlt, luminance target | luminance ÷ relative |" } else { "" };
    let extra_rule = if luminance.is_some() { "---:|---:|" } else { "" };
    println!("| time | relMSE path | relMSE bdpt | relMSE mlt | path ÷ mlt | bdpt ÷ mlt |{extra}");
    println!("|---:|---:|---:|---:|---:|---:|{extra_rule}");
    let fmt = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3e}"));
    let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => format!("**{:.1}×**", a / b),
        _ => "-".into(),
    };
    for &t in &args.seconds {
        let (p, b, m) = (path.error_at_time(t), bdpt.error_at_time(t), mlt.error_at_time(t));
        let extra = luminance.as_ref().map_or(String::new(), |(l, _)| {
            let l = l.error_at_time(t);
            format!(" {} | {} |", fmt(l), ratio(l, m))
        });
        println!(
            "| {t} s | {} | {} | {} | {} | {} |{extra}",
            fmt(p),
            fmt(b),
            fmt(m),
            ratio(p, m),
            ratio(b, m)
        );
    }
    println!();
    if let Some(e) = mlt.error_at_time(longest) {
        for (label, s) in [("BDPT", &bdpt), ("the path tracer", &path)] {
            match s.time_to_error_or_extrapolated(e) {
                Some((t, extrapolated)) => println!(
                    "{label} reaches Metropolis's {longest} s error ({e:.3e}) after {t:.0} s{}",
                    if extrapolated { " (extrapolated by 1/t past its last checkpoint)" } else { "" }
                ),
                None => println!("{label}: empty series"),
            }
        }
    }
}
