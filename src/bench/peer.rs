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

pub use super::series::{integrator_markdown, markdown, Series, SeriesKey};
use super::BenchScene;
use crate::cpu::CpuBackend;
use crate::error::{Error, Result};
use crate::film::{
    compare_images, error_against, predicted_relmse, CompareOptions, CompareReport, LinearImage,
    RenderMetadata,
};
use crate::gpu::{GpuBackend, GpuContext};
use crate::integrator::Integrator;
use crate::sampling::SamplerKind;
use crate::scene::{FlatScene, ViewSettings};
use crate::{render_progressive_with, Backend, RenderSettings};

/// The peer renderer.
#[derive(Clone, Debug)]
pub enum PeerKind {
    /// Mitsuba 3 through `bench/mitsuba_peer.py` (its `path` integrator).
    Mitsuba,
    /// pbrt-v4 (`super::pbrt`), with the integrator it names.
    Pbrt(super::pbrt::PbrtOptions),
}

/// How the peer benchmark runs.
#[derive(Clone)]
pub struct PeerOptions {
    pub peer: PeerKind,
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
    /// pathlight's integrators, a series each on every backend that has it (`bench
    /// --integrator path,bdpt`); the path tracer's also with independent samples on the CPU.
    pub integrators: Vec<Integrator>,
    /// The integrator that renders a reference made here (`--reference-integrator`): the
    /// one that converges fastest on the scene. A scene lit indirectly converges many times
    /// faster under BDPT.
    pub reference_integrator: Integrator,
    /// The most scattering events of every path, pathlight's and the peer's (`bench
    /// --max-depth`); None: unbounded, with roulette (the peers: pbrt's `maxdepth` 100,
    /// Mitsuba's −1).
    pub max_depth: Option<u32>,
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
/// read on, and any series with a floor of its own (a biased peer) bends sooner (a reference
/// once held a quarter of the error compared: `bench/history/peers.md`).
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

    pub(super) fn describe(&self) -> &'static str {
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
            let attribute = |name: &str| attributes.get(name).cloned().unwrap_or_else(|| "?".into());
            let (backend, integrator) = (attribute("pathlight.backend"), attribute("pathlight.integrator"));
            let noise = ReferenceNoise::of_file(&image, &attributes);
            let note = format!("{} ({spp} spp, {integrator}, {backend}, reused)", path.display());
            return Ok(Reference { image, note, noise });
        }
    }
    // Its own seed, so the reference is independent of every timed render. Rendered as
    // `pathlight render` renders by default, with the backend's splitting and caustics by
    // light tracing, each chosen for the least error in the time (light tracing lowers the
    // glass scene's several-fold, `bench/history/light-tracing.md`). Each camera sample then costs more, so one spp of reference
    // is worth more. Whether the estimators converge to the right image is for the z-test
    // against the peer's to say.
    let integrator = options.reference_integrator;
    let hardware_gpu = options.gpu.as_ref().filter(|ctx| ctx.is_hardware() && integrator.has_gpu_kernel());
    let settings = RenderSettings {
        integrator,
        width: options.width,
        height: options.height,
        spp: options.reference_spp,
        seed: 0x5EED_0001,
        splits: crate::render::default_splits(crate::render::RenderDevice::of(hardware_gpu.map(|c| &**c))),
        light_tracing: true,
        max_depth: options.max_depth,
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
        seed: settings.seed,
        integrator: settings.integrator,
        max_depth: settings.max_depth_bound(),
        sampler: settings.sampler,
        splits: settings.splits,
        render_seconds: seconds,
        samples: 0..settings.spp,
        total_spp: settings.spp,
        light_tracing: settings.light_tracing,
        ..RenderMetadata::default()
    };
    crate::film::write_exr(&film, &meta, &path)?;
    let image = LinearImage::from_film(&film);
    // A render's own image knows its replicates: the measured figure.
    let noise = predicted_relmse(&image).map(|relmse| ReferenceNoise { relmse, measured: true });
    let note = format!(
        "{} ({} spp, {integrator}, {}, {seconds:.0} s)",
        path.display(),
        settings.spp,
        backend.name()
    );
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
    Ok(Series { label: format!("pathlight {}", backend.name()), points, key: None })
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
pub(super) fn read_series(path: &Path, label: String) -> Result<Series> {
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
    Ok(Series { label, points, key: None })
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
    device: &str,
    settings: &RenderSettings,
    file: &Path,
    reference: &LinearImage,
    options: &PeerOptions,
) -> Result<Series> {
    let key =
        SeriesKey { backend: device.to_string(), integrator: settings.integrator, sampler: settings.sampler };
    let mut label = format!("pathlight {}", backend.name());
    if key.integrator != Integrator::Path {
        label += &format!(", {}", key.integrator);
    }
    if key.sampler != SamplerKind::default() {
        label += &format!(", {} sampler", key.sampler.name());
    }
    let mut series = if options.reuse_series {
        read_series(file, label)?
    } else {
        let mut series = pathlight_series(backend, reference, options.seconds)?;
        series.label = label;
        std::fs::write(file, series.csv()).map_err(|e| Error::io(file, e))?;
        series
    };
    series.key = Some(key);
    Ok(series)
}

/// The CSV file of a pathlight series: `pathlight-<device>[-<integrator>][-<sampler>].csv`
/// (the path tracer and the default sampler unnamed, as the files of earlier runs are).
fn series_file(dir: &Path, device: &str, settings: &RenderSettings) -> PathBuf {
    let mut name = format!("pathlight-{device}");
    if settings.integrator != Integrator::Path {
        name += &format!("-{}", settings.integrator);
    }
    if settings.sampler != SamplerKind::default() {
        name += &format!("-{}", settings.sampler.name());
    }
    dir.join(name + ".csv")
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
        max_depth: options.max_depth,
        ..RenderSettings::default()
    };
    let dir = options.out.join(&scene.name);
    let mut pathlight = Vec::new();
    for &integrator in &options.integrators {
        let settings = RenderSettings { integrator, ..settings.clone() };
        if options.cpu {
            let mut backend = CpuBackend::shared(flat.clone(), &settings);
            let file = series_file(&dir, "cpu", &settings);
            pathlight.push(backend_series(&mut backend, "cpu", &settings, &file, &reference, options)?);
            if integrator == Integrator::Path {
                // The same backend with independent random numbers: what the default Sobol
                // sampler gains, in the same run.
                let independent = RenderSettings { sampler: SamplerKind::Independent, ..settings.clone() };
                let mut backend = CpuBackend::shared(flat.clone(), &independent);
                let file = series_file(&dir, "cpu", &independent);
                pathlight.push(backend_series(
                    &mut backend,
                    "cpu",
                    &independent,
                    &file,
                    &reference,
                    options,
                )?);
            }
        }
        if let Some(ctx) = options.gpu.as_ref().filter(|_| integrator.has_gpu_kernel()) {
            let splits = crate::render::default_splits(crate::render::RenderDevice::of(Some(ctx)));
            let gpu_settings = RenderSettings { splits, ..settings.clone() };
            let mut backend = GpuBackend::new(ctx.clone(), &flat, &gpu_settings)?;
            let file = series_file(&dir, "gpu", &gpu_settings);
            pathlight.push(backend_series(&mut backend, "gpu", &gpu_settings, &file, &reference, options)?);
        }
    }
    let (peer, agreement, peer_low_discrepancy) = if let (true, PeerKind::Pbrt(pbrt)) =
        (options.run_peer, &options.peer)
    {
        // Measured against its own converged image; how far that is from pathlight's is
        // the agreement (spectral rendering keeps it from passing the z-test exactly).
        let run = super::pbrt::run(scene, options, pbrt)?;
        let agreement = compare_images(&run.converged, &reference, &CompareOptions::default())?;
        (Some(run.series), Some(agreement), None)
    } else if options.run_peer {
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
