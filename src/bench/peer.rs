//! `pathlight bench --peer mitsuba`: speed against error next to a peer renderer, in the
//! same run on the same machine.
//!
//! For each scene:
//!
//! 1. a reference: `OUT/<scene>/reference.exr`, rendered by pathlight at
//!    `--reference-spp` if it is not there yet (on a real GPU that takes seconds; the file
//!    can be rendered elsewhere with `--references-only` and copied in);
//! 2. pathlight's error series on each backend: one progressive render, after a one-sample
//!    warm-up that is thrown away, with relMSE against the reference at 1, 2, 4, … spp, until
//!    `--peer-seconds` have passed;
//! 3. the peer's series and a converged image with per-pixel variance, by
//!    `bench/mitsuba_peer.py` (its own glTF reader, Mitsuba 3's `path` integrator);
//! 4. a z-test of the peer's converged image against the reference (do the two renderers
//!    converge to the same image?);
//! 5. time to equal error and error at equal time, read off the series by log–log
//!    interpolation; the series go to CSV files for `bench/plot_peer.py`.
//!
//! relMSE is the benchmark protocol's (see [`crate::film::error_against`]); the peer's script
//! computes the same formula.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Instant;

use super::BenchScene;
use crate::cpu::CpuBackend;
use crate::error::{Error, Result};
use crate::film::{
    compare_images, error_against, predicted_relmse, CompareOptions, CompareReport, LinearImage,
    RenderMetadata,
};
use crate::gpu::{GpuBackend, GpuContext};
use crate::sampling::SamplerKind;
use crate::scene::{FlatScene, ViewSettings};
use crate::{render_progressive_with, Backend, RenderSettings};

/// How the peer benchmark runs.
#[derive(Clone)]
pub struct PeerOptions {
    pub width: u32,
    pub height: u32,
    /// Each renderer's series stops after the checkpoint that passes this many seconds.
    pub seconds: f64,
    /// Samples per pixel of a reference rendered here.
    pub reference_spp: u32,
    /// Where references, series and the peer's images go (`OUT/<scene>/…`).
    pub out: PathBuf,
    /// The Python interpreter that has `mitsuba` installed.
    pub python: String,
    /// The converter script.
    pub script: PathBuf,
    /// Mitsuba variant (`llvm_ad_rgb`; `scalar_rgb` where LLVM is missing).
    pub variant: String,
    /// Samples per pixel of the peer's converged image (for the z-test).
    pub converged_spp: u32,
    /// Run the peer (false: pathlight's series only, no comparison).
    pub run_peer: bool,
    /// Read the series already under `out` instead of rendering them (to redo the tables
    /// and plots); the reference must be there too.
    pub reuse_series: bool,
    pub cpu: bool,
    pub gpu: Option<Arc<GpuContext>>,
}

/// One renderer's error against time: (spp, seconds, relMSE) at each checkpoint.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(u32, f64, f64)>,
}

impl Series {
    /// Seconds to reach relMSE `error`, interpolated log–log between the checkpoints around
    /// it (relMSE falls as 1/t for an unbiased renderer, a line on log–log axes); `None`
    /// if the series never gets there.
    pub fn time_to_error(&self, error: f64) -> Option<f64> {
        let p = &self.points;
        let i = p.iter().position(|&(_, _, e)| e <= error)?;
        if i == 0 {
            // Reached at the first checkpoint: scale its time by the 1/t law.
            let (_, t, e) = p[0];
            return Some(t * e / error);
        }
        let ((_, t0, e0), (_, t1, e1)) = (p[i - 1], p[i]);
        Some(log_lerp(e0, t0, e1, t1, error))
    }

    /// relMSE after `seconds`, interpolated log–log; `None` outside the series.
    pub fn error_at_time(&self, seconds: f64) -> Option<f64> {
        let p = &self.points;
        let i = p.iter().position(|&(_, t, _)| t >= seconds)?;
        if i == 0 {
            return None;
        }
        let ((_, t0, e0), (_, t1, e1)) = (p[i - 1], p[i]);
        Some(log_lerp(t0, e0, t1, e1, seconds))
    }

    /// The last checkpoint's relMSE and seconds.
    pub fn last(&self) -> Option<(f64, f64)> {
        self.points.last().map(|&(_, t, e)| (e, t))
    }

    pub fn csv(&self) -> String {
        let mut s = String::from("spp,seconds,relmse\n");
        for (spp, t, e) in &self.points {
            s += &format!("{spp},{t:.6},{e:.8e}\n");
        }
        s
    }
}

/// y at x on the line through (x0, y0) and (x1, y1) in log–log coordinates.
fn log_lerp(x0: f64, y0: f64, x1: f64, y1: f64, x: f64) -> f64 {
    if x0 == x1 {
        return y1;
    }
    let f = (x.ln() - x0.ln()) / (x1.ln() - x0.ln());
    (y0.ln() + f * (y1.ln() - y0.ln())).exp()
}

/// Everything measured on one scene.
pub struct PeerResult {
    pub scene: String,
    pub reference_note: String,
    pub reference_noise: Option<ReferenceNoise>,
    pub pathlight: Vec<Series>,
    /// The peer's series (`None` with `run_peer` off), with its default sampler.
    pub peer: Option<Series>,
    /// The peer's series with its low-discrepancy sampler (`ldsampler`), pathlight's
    /// default's counterpart.
    pub peer_low_discrepancy: Option<Series>,
    /// The peer's converged image against the reference.
    pub agreement: Option<CompareReport>,
}

/// The backend a reference renders on: `hardware_gpu` (the fastest present) if there is
/// one, else the CPU.
fn reference_backend(
    flat: &Arc<FlatScene>,
    settings: &RenderSettings,
    hardware_gpu: Option<&Arc<GpuContext>>,
) -> Result<Box<dyn Backend>> {
    Ok(match hardware_gpu {
        Some(ctx) => Box::new(GpuBackend::new(ctx.clone(), flat, settings)?),
        None => Box::new(CpuBackend::shared(flat.clone(), settings)),
    })
}

/// A scene's reference image, what it is, and how noisy it is.
pub struct Reference {
    pub image: LinearImage,
    /// Its file, samples per pixel and backend, for the report.
    pub note: String,
    /// Its own error (`None` for a file with neither the recorded figure nor variance).
    pub noise: Option<ReferenceNoise>,
}

/// A reference's own relMSE: the floor under every error measured against it. A noise common
/// to both renderers adds the same term to both series and leaves time to equal error
/// unchanged in expectation, but near it the series bend off the straight lines the times are
/// read on, and any series with a floor of its own (a biased peer) bends sooner. The eleventh
/// and twelfth runs' 4,096-spp Cornell-box reference held 2.9·10⁻⁵, a quarter of the error
/// compared (bench/RESULTS.md, twenty-first session).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceNoise {
    pub relmse: f64,
    /// Measured (the render's two replicates, or the figure its file records), or only
    /// bounded from above by the file's variance channels, which under QMC hold the samples'
    /// spread, not the error of their mean.
    pub measured: bool,
}

impl ReferenceNoise {
    /// What a reference file says of its noise: the predicted relMSE it records
    /// ([`crate::film::PREDICTED_RELMSE_ATTRIBUTE`]), else the one its variance channels
    /// give (an upper bound for a QMC render, exact for independent samples).
    fn of_file(image: &LinearImage, attributes: &std::collections::HashMap<String, String>) -> Option<Self> {
        let recorded =
            attributes.get(crate::film::PREDICTED_RELMSE_ATTRIBUTE).and_then(|v| v.parse::<f64>().ok());
        match recorded {
            Some(relmse) if relmse.is_finite() && relmse >= 0.0 => {
                Some(ReferenceNoise { relmse, measured: true })
            }
            _ => predicted_relmse(image).map(|relmse| ReferenceNoise { relmse, measured: false }),
        }
    }

    fn describe(&self) -> &'static str {
        if self.measured {
            "measured"
        } else {
            "an upper bound from the file's variance channels"
        }
    }
}

/// Renders (or reuses) `OUT/<scene>/reference.exr`.
pub fn reference(scene: &BenchScene, flat: &Arc<FlatScene>, options: &PeerOptions) -> Result<Reference> {
    let dir = options.out.join(&scene.name);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let path = dir.join("reference.exr");
    if path.exists() {
        let image = LinearImage::read(&path)?;
        if (image.width, image.height) == (options.width as usize, options.height as usize) {
            let spp = image.spp.map_or("?".into(), |n| n.to_string());
            let attributes = crate::film::read_exr(&path)?.attributes;
            let backend = attributes.get("pathlight.backend").cloned().unwrap_or_else(|| "?".into());
            let noise = ReferenceNoise::of_file(&image, &attributes);
            let note = format!("{} ({spp} spp, {backend}, reused)", path.display());
            return Ok(Reference { image, note, noise });
        }
    }
    // Its own seed, so the reference is independent of every timed render. Rendered as
    // `pathlight render` renders by default, with the backend's splitting and caustics by
    // light tracing, each chosen for the least error in the time (light tracing lowered the
    // glass scene's several-fold, bench/RESULTS.md); until the twenty-first session it was
    // path-traced and unsplit. Each camera sample then costs more, so one spp of reference
    // is worth more. Whether the estimators converge to the right image is for the z-test
    // against the peer's to say.
    let hardware_gpu = options.gpu.as_ref().filter(|ctx| ctx.is_hardware());
    let settings = RenderSettings {
        width: options.width,
        height: options.height,
        spp: options.reference_spp,
        seed: 0x5EED_0001,
        splits: crate::render::default_splits(crate::render::RenderDevice::of(hardware_gpu.map(|c| &**c))),
        light_tracing: true,
        ..RenderSettings::default()
    };
    let mut backend = reference_backend(flat, &settings, hardware_gpu)?;
    let start = Instant::now();
    eprintln!("{}: rendering the reference, {} spp on {}", scene.name, settings.spp, backend.name());
    render_progressive_with(backend.as_mut(), settings.spp, &AtomicBool::new(false), |_, _, _| Ok(false))?;
    let seconds = start.elapsed().as_secs_f64();
    let film = backend.film()?;
    let meta = RenderMetadata {
        scene: scene.name.clone(),
        backend: backend.name(),
        spp: settings.spp,
        seed: settings.seed,
        integrator: settings.integrator,
        max_depth: None,
        sampler: settings.sampler,
        splits: settings.splits,
        render_seconds: seconds,
        rejected_samples: 0,
    };
    crate::film::write_exr(&film, &meta, &path)?;
    let image = LinearImage::from_film(&film);
    // A render's own image knows its replicates: the measured figure.
    let noise = predicted_relmse(&image).map(|relmse| ReferenceNoise { relmse, measured: true });
    let note = format!("{} ({} spp, {}, {seconds:.0} s)", path.display(), settings.spp, backend.name());
    Ok(Reference { image, note, noise })
}

/// One progressive pathlight render against the reference until `seconds` have passed.
fn pathlight_series(backend: &mut dyn Backend, reference: &LinearImage, seconds: f64) -> Result<Series> {
    // Warm-up: the first pass builds per-device state (the GPU's first submits probe the
    // dispatch size); it is not part of the timed render.
    backend.render(0, 1)?;
    backend.reset()?;
    let mut points = Vec::new();
    render_progressive_with(backend, u32::MAX / 2, &AtomicBool::new(false), |b, done, t| {
        if !done.is_power_of_two() {
            return Ok(false);
        }
        let image = LinearImage::from_film(&b.film()?);
        let (_, relmse) = error_against(&image, reference);
        eprintln!("{:>24} {done:>6} spp {t:>9.3} s  relMSE {relmse:.5}", b.name());
        points.push((done, t, relmse));
        Ok(t >= seconds)
    })?;
    Ok(Series { label: format!("pathlight {}", backend.name()), points })
}

/// Runs the peer's script on `scene` and reads back its series and converged image.
fn peer_series(scene: &BenchScene, options: &PeerOptions) -> Result<(Series, LinearImage)> {
    let dir = options.out.join(&scene.name);
    run_peer_script(
        scene,
        options,
        "independent",
        &dir.join("mitsuba.csv"),
        Some(&dir.join("mitsuba-converged.exr")),
        None,
    )?;
    peer_outputs(scene, options)
}

/// The peer's series with its low-discrepancy sampler (no converged image: the z-test is
/// the default sampler's), or why there is none. Mitsuba 3.9's `ldsampler` never finishes a
/// render of a closed mirror-and-glass scene at unlimited depth (measured on
/// `cornell-spheres`: not one 4-spp 64×64 image in 100 s, while with `max_depth` 64 the
/// same render takes 0.02 s), so this series runs under a time limit and its absence is
/// reported, not fatal.
fn peer_low_discrepancy_series(
    scene: &BenchScene,
    options: &PeerOptions,
) -> std::result::Result<Series, String> {
    let log = options.out.join(&scene.name).join("mitsuba-ldsampler.csv");
    if !options.reuse_series {
        let limit = std::time::Duration::from_secs_f64((10.0 * options.seconds).max(120.0));
        run_peer_script(scene, options, "ldsampler", &log, None, Some(limit)).map_err(|e| e.to_string())?;
    }
    read_series(&log, format!("Mitsuba 3 {} ldsampler", options.variant)).map_err(|e| e.to_string())
}

/// Runs the converter script: the error series with Mitsuba sampler `sampler` into `log`
/// and, if asked, the converged image; killed after `limit`, if given.
fn run_peer_script(
    scene: &BenchScene,
    options: &PeerOptions,
    sampler: &str,
    log: &Path,
    converged: Option<&Path>,
    limit: Option<std::time::Duration>,
) -> Result<()> {
    let dir = options.out.join(&scene.name);
    let mut command = Command::new(&options.python);
    command
        .arg(&options.script)
        .arg(&scene.base)
        .args(["--width", &options.width.to_string(), "--height", &options.height.to_string()])
        .args(["--variant", &options.variant, "--sampler", sampler])
        .arg("--reference")
        .arg(dir.join("reference.exr"))
        .args(["--time-limit", &options.seconds.to_string()])
        .args(["--converged-spp", &options.converged_spp.to_string()])
        .arg("--log")
        .arg(log);
    if let Some(converged) = converged {
        command.arg("--converged").arg(converged);
    }
    if let Some(insert) = &scene.insert {
        let matrix: Vec<String> = insert.transform.to_cols_array().iter().map(|v| format!("{v:e}")).collect();
        command.arg("--insert").arg(&insert.path).arg(format!("--matrix={}", matrix.join(",")));
        command.args(["--insert-white", &insert.white.to_string()]);
    }
    let mut child = command.spawn().map_err(|e| {
        Error::Settings(format!("could not run {} {}: {e}", options.python, options.script.display()))
    })?;
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| Error::io(&options.script, e))? {
            break status;
        }
        if let Some(limit) = limit.filter(|&limit| start.elapsed() > limit) {
            let _ = child.kill();
            let _ = child.wait();
            return Err(Error::Settings(format!(
                "{} with Mitsuba's {sampler}: no result within {:.0} s, stopped",
                scene.name,
                limit.as_secs_f64()
            )));
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    };
    if !status.success() {
        return Err(Error::Settings(format!(
            "{}: the peer's script failed ({status})",
            options.script.display()
        )));
    }
    Ok(())
}

/// The peer's series and converged image as its script left them.
fn peer_outputs(scene: &BenchScene, options: &PeerOptions) -> Result<(Series, LinearImage)> {
    let dir = options.out.join(&scene.name);
    let series = read_series(&dir.join("mitsuba.csv"), format!("Mitsuba 3 {}", options.variant))?;
    Ok((series, LinearImage::read(&dir.join("mitsuba-converged.exr"))?))
}

/// Reads a series CSV (columns `spp`, `seconds` and `relmse`, by name).
fn read_series(path: &Path, label: String) -> Result<Series> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').collect();
    let column = |name: &str| {
        header
            .iter()
            .position(|h| h.trim() == name)
            .ok_or_else(|| Error::Settings(format!("{}: no '{name}' column", path.display())))
    };
    let (spp, seconds, relmse) = (column("spp")?, column("seconds")?, column("relmse")?);
    let mut points = Vec::new();
    for line in lines {
        let f: Vec<&str> = line.split(',').collect();
        let parse = |i: usize| -> Result<f64> {
            f.get(i)
                .and_then(|v| v.trim().parse::<f64>().ok())
                .ok_or_else(|| Error::Settings(format!("{}: bad line '{line}'", path.display())))
        };
        points.push((parse(spp)? as u32, parse(seconds)?, parse(relmse)?));
    }
    Ok(Series { label, points })
}

/// The scene flattened for the benchmark's image size (its own camera).
pub fn flat_scene(scene: &BenchScene, options: &PeerOptions) -> Result<Arc<FlatScene>> {
    let view = ViewSettings { camera: None, aspect: options.width as f64 / options.height as f64 };
    Ok(Arc::new(FlatScene::build(&scene.load()?, &view)?))
}

/// pathlight's series on `backend` written to `file`, or with `reuse_series` the one
/// already there.
fn backend_series(
    backend: &mut dyn Backend,
    label_suffix: &str,
    file: &Path,
    reference: &LinearImage,
    options: &PeerOptions,
) -> Result<Series> {
    let label = format!("pathlight {}{label_suffix}", backend.name());
    if options.reuse_series {
        return read_series(file, label);
    }
    let mut series = pathlight_series(backend, reference, options.seconds)?;
    series.label = label;
    std::fs::write(file, series.csv()).map_err(|e| Error::io(file, e))?;
    Ok(series)
}

/// Measures one scene: reference, pathlight's series on each backend, the peer's.
pub fn run_scene(scene: &BenchScene, options: &PeerOptions) -> Result<PeerResult> {
    let flat = flat_scene(scene, options)?;
    let Reference { image: reference, note: reference_note, noise: reference_noise } =
        reference(scene, &flat, options)?;
    // Each backend as `pathlight render` runs it, with its default splitting.
    let settings = RenderSettings {
        width: options.width,
        height: options.height,
        spp: 1 << 20,
        splits: crate::render::default_splits(crate::render::RenderDevice::Cpu),
        light_tracing: true,
        ..RenderSettings::default()
    };
    let dir = options.out.join(&scene.name);
    let mut pathlight = Vec::new();
    if options.cpu {
        let mut backend = CpuBackend::shared(flat.clone(), &settings);
        pathlight.push(backend_series(
            &mut backend,
            "",
            &dir.join("pathlight-cpu.csv"),
            &reference,
            options,
        )?);
        // The same backend with independent random numbers: what the default Sobol sampler
        // gains, in the same run.
        let independent = RenderSettings { sampler: SamplerKind::Independent, ..settings.clone() };
        let mut backend = CpuBackend::shared(flat.clone(), &independent);
        let file = dir.join("pathlight-cpu-independent.csv");
        pathlight.push(backend_series(&mut backend, ", independent sampler", &file, &reference, options)?);
    }
    if let Some(ctx) = &options.gpu {
        let splits = crate::render::default_splits(crate::render::RenderDevice::of(Some(ctx)));
        let gpu_settings = RenderSettings { splits, ..settings.clone() };
        let mut backend = GpuBackend::new(ctx.clone(), &flat, &gpu_settings)?;
        pathlight.push(backend_series(
            &mut backend,
            "",
            &dir.join("pathlight-gpu.csv"),
            &reference,
            options,
        )?);
    }
    let (peer, agreement, peer_low_discrepancy) = if options.run_peer {
        let (peer, converged) =
            if options.reuse_series { peer_outputs(scene, options)? } else { peer_series(scene, options)? };
        let agreement = compare_images(&converged, &reference, &CompareOptions::default())?;
        let low_discrepancy = peer_low_discrepancy_series(scene, options)
            .inspect_err(|why| eprintln!("{}: no ldsampler series: {why}", scene.name))
            .ok();
        (Some(peer), Some(agreement), low_discrepancy)
    } else {
        (None, None, None)
    };
    Ok(PeerResult {
        scene: scene.name.clone(),
        reference_note,
        reference_noise,
        pathlight,
        peer,
        peer_low_discrepancy,
        agreement,
    })
}

/// The results as Markdown: one row per pathlight backend and scene.
pub fn markdown(results: &[PeerResult]) -> String {
    let mut s = String::new();
    s += "| scene | same image as the peer? | pathlight backend | relMSE compared | pathlight s | Mitsuba s | speed vs Mitsuba (time to equal error) | at equal time | relMSE pathlight | relMSE Mitsuba | speed vs Mitsuba with ldsampler |\n";
    s += "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for r in results {
        let same = match &r.agreement {
            Some(a) if a.same() => "yes (z-test passes)".to_string(),
            Some(a) => format!("**no**: {}", a.failures.join("; ")),
            None => "(peer not run)".into(),
        };
        for p in &r.pathlight {
            // Pairwise with the peer: the lower error both series reached, the shorter time.
            let error = compared_error(p, r.peer.as_ref());
            let time = [p]
                .into_iter()
                .chain(&r.peer)
                .map(|s| s.last().map(|l| l.1))
                .try_fold(f64::INFINITY, |m, t| t.map(|t| m.min(t)));
            let t_pl = error.and_then(|e| p.time_to_error(e));
            let t_mi = error.zip(r.peer.as_ref()).and_then(|(e, peer)| peer.time_to_error(e));
            let e_pl = time.and_then(|t| p.error_at_time(t));
            let e_mi = time.zip(r.peer.as_ref()).and_then(|(t, peer)| peer.error_at_time(t));
            let f = |v: Option<f64>, d: usize| v.map_or("-".into(), |v| format!("{v:.d$}"));
            let g = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.3e}"));
            let ratio = match (t_pl, t_mi) {
                (Some(a), Some(b)) => format!("{:.2}×", b / a),
                _ => "-".into(),
            };
            let ratio_low_discrepancy = r
                .peer_low_discrepancy
                .as_ref()
                .and_then(|peer| speed_ratio(p, peer))
                .map_or("-".into(), |x| format!("{x:.2}×"));
            s += &format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                r.scene,
                same,
                p.label.trim_start_matches("pathlight "),
                g(error),
                f(t_pl, 2),
                f(t_mi, 2),
                ratio,
                time.map_or("-".into(), |t| format!("{t:.1} s")),
                g(e_pl),
                g(e_mi),
                ratio_low_discrepancy,
            );
        }
    }
    s += &reference_noise_lines(results);
    s
}

/// How many times faster `a` reaches the lower error both series reached than `b` does
/// (time to equal error, `b`'s time over `a`'s).
fn speed_ratio(a: &Series, b: &Series) -> Option<f64> {
    let error = a.last()?.0.max(b.last()?.0);
    Some(b.time_to_error(error)? / a.time_to_error(error)?)
}

/// The error a row reads time to equal error at: the larger of the last errors of the
/// pathlight series and the peer's, the lowest both reached (`None` if either is empty).
fn compared_error(pathlight: &Series, peer: Option<&Series>) -> Option<f64> {
    [pathlight]
        .into_iter()
        .chain(peer)
        .map(|s| s.last().map(|l| l.0))
        .try_fold(0.0f64, |m, e| e.map(|e| m.max(e)))
}

/// Under the table, a line per scene on its reference's own error against the smallest
/// error compared (what each row's time to equal error is read at), with a warning where
/// the reference's noise is more than a tenth of it ([`ReferenceNoise`]).
fn reference_noise_lines(results: &[PeerResult]) -> String {
    let mut s = String::new();
    for r in results {
        let Some(noise) = r.reference_noise else { continue };
        let compared = r
            .pathlight
            .iter()
            .filter_map(|p| compared_error(p, r.peer.as_ref()))
            .fold(f64::INFINITY, f64::min);
        s += &format!(
            "\n{}: the reference's own relMSE is {:.2e} ({})",
            r.scene,
            noise.relmse,
            noise.describe()
        );
        if compared.is_finite() && compared > 0.0 {
            let share = noise.relmse / compared;
            s += &format!(", {:.1}% of the smallest relMSE compared", 100.0 * share);
            if share > REFERENCE_NOISE_WARNING {
                s += ". **More than a tenth: the ratios read near it are uncertain; render a longer \
                      reference (`--reference-spp`).**";
            }
        }
        s += "\n";
    }
    s
}

/// The share of the compared error above which a reference's noise is called out. For
/// series of the form a/t + R read where R is this share of the error, the log–log slope is
/// −0.9 instead of −1, and a time read between checkpoints 4× apart (Mitsuba's `ldsampler`
/// series) comes out 2.5% long, between checkpoints 2× apart 0.6%: below the peer runs'
/// spread from run to run (bench/RESULTS.md).
const REFERENCE_NOISE_WARNING: f64 = 0.1;

/// Runs `bench/plot_peer.py` over the CSV files (a missing matplotlib is a warning).
pub fn plot(options: &PeerOptions, scenes: &[String]) {
    let script = options.script.with_file_name("plot_peer.py");
    let status = Command::new(&options.python).arg(&script).arg(&options.out).args(scenes).status();
    match status {
        Ok(s) if s.success() => {}
        Ok(s) => eprintln!("warning: {} failed ({s}); no plots", script.display()),
        Err(e) => eprintln!("warning: could not run {}: {e}; no plots", script.display()),
    }
}

/// Where the converter script is: beside the binary's source tree (`bench/`).
pub fn default_script(root: &Path) -> PathBuf {
    root.join("bench/mitsuba_peer.py")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(points: &[(u32, f64, f64)]) -> Series {
        Series { label: "s".into(), points: points.to_vec() }
    }

    #[test]
    fn time_to_error_follows_the_one_over_t_law() {
        // relMSE = 0.1 / t exactly: log–log interpolation is exact.
        let s = series(&[(1, 1.0, 0.1), (2, 2.0, 0.05), (4, 4.0, 0.025)]);
        assert!((s.time_to_error(0.04).unwrap() - 2.5).abs() < 1e-12);
        assert!((s.error_at_time(3.0).unwrap() - 0.1 / 3.0).abs() < 1e-12);
        // Reached at once: scaled back along 1/t.
        assert!((s.time_to_error(0.2).unwrap() - 0.5).abs() < 1e-12);
        assert_eq!(s.time_to_error(0.01), None);
        assert_eq!(s.error_at_time(5.0), None);
        assert_eq!(s.error_at_time(0.5), None);
    }

    fn result(noise: Option<ReferenceNoise>) -> PeerResult {
        PeerResult {
            scene: "box".into(),
            reference_note: String::new(),
            reference_noise: noise,
            // Ends at 2e-4 and 1e-4: the smaller of the two rows' compared errors is 1e-4
            // (each row compares at the larger last error of its series and the peer's).
            pathlight: vec![
                series(&[(1, 1.0, 4e-4), (2, 2.0, 2e-4)]),
                series(&[(1, 1.0, 2e-4), (2, 2.0, 5e-5)]),
            ],
            peer: Some(series(&[(1, 1.0, 2e-4), (2, 2.0, 1e-4)])),
            peer_low_discrepancy: None,
            agreement: None,
        }
    }

    #[test]
    fn a_noisy_reference_is_called_out_under_the_table() {
        let quiet = reference_noise_lines(&[result(Some(ReferenceNoise { relmse: 5e-6, measured: true }))]);
        assert!(quiet.contains("box: the reference's own relMSE is 5.00e-6 (measured), 5.0% of"), "{quiet}");
        assert!(!quiet.contains("More than a tenth"), "{quiet}");
        let noisy =
            reference_noise_lines(&[result(Some(ReferenceNoise { relmse: 2.5e-5, measured: false }))]);
        assert!(
            noisy.contains("2.50e-5 (an upper bound from the file's variance channels), 25.0% of"),
            "{noisy}"
        );
        assert!(noisy.contains("More than a tenth"), "{noisy}");
        assert_eq!(reference_noise_lines(&[result(None)]), "");
    }

    #[test]
    fn a_reference_file_gives_its_recorded_noise_else_a_bound_from_its_variance() {
        let image = LinearImage {
            width: 1,
            height: 2,
            rgb: vec![[1.0; 3], [0.0; 3]],
            variance: Some(vec![[0.01; 3], [0.01; 3]]),
            spp: Some(4),
            replicate_variance: None,
        };
        // (0.01 / (1 + 0.01) + 0.01 / 0.01) / 2 over the two pixels.
        let bound = (0.01 / 1.01 + 1.0) / 2.0;
        let mut attributes = std::collections::HashMap::new();
        let from_variance = ReferenceNoise::of_file(&image, &attributes).unwrap();
        assert!(!from_variance.measured && (from_variance.relmse - bound).abs() < 1e-6, "{from_variance:?}");
        attributes.insert(crate::film::PREDICTED_RELMSE_ATTRIBUTE.to_string(), "1.5e-6".to_string());
        assert_eq!(
            ReferenceNoise::of_file(&image, &attributes),
            Some(ReferenceNoise { relmse: 1.5e-6, measured: true })
        );
        // A garbled figure is not believed.
        attributes.insert(crate::film::PREDICTED_RELMSE_ATTRIBUTE.to_string(), "NaN".to_string());
        assert!(!ReferenceNoise::of_file(&image, &attributes).unwrap().measured);
    }
}
