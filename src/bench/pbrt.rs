//! pbrt-v4 as the peer of `pathlight bench --peer pbrt` (issue 43: pbrt-v4's `bdpt` is the
//! peer of pathlight's BDPT; Mitsuba 3 has no bidirectional integrator).
//!
//! `bench/pbrt_peer.py` converts the scene (its own glTF reader); pbrt itself is run here,
//! one process per render with `--spp`, `--seed` and `--outfile`:
//!
//! 1. a converged image: [`CONVERGED_BATCHES`] renders of `--converged-spp` / batches
//!    samples with their own seeds, whose per-pixel spread gives the variance of their mean
//!    (the batches are kept as `OUT/<scene>/pbrt-<integrator>-batch<k>.exr` and reused),
//!    by pbrt's integrator or the one `--pbrt-converged-integrator` names;
//! 2. the error series: renders at 1, 2, 4, … spp, each timed, until one takes longer than
//!    the series' seconds, relMSE against pbrt's own converged image. pbrt renders
//!    spectrally, so its images differ from an RGB renderer's by a few tenths of a percent
//!    to percents (../shared/peers/pbrt-v4/README.md): each renderer is measured against its
//!    own converged image, and the report says how far the two converged images are apart.
//!
//! A render's time is the process's wall time less pbrt's start-up (parsing, BVH, spectral
//! tables), measured as the fastest of three one-pixel, one-sample renders of the scene.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use super::peer::PeerOptions;
use super::series::Series;
use super::BenchScene;
use crate::error::{Error, Result};
use crate::film::{error_against, LinearImage};

/// Independent renders the converged image is the mean of (its per-pixel variance has 15
/// degrees of freedom, as Mitsuba's converged image in `mitsuba_peer.py`).
pub const CONVERGED_BATCHES: u32 = 16;

/// pbrt's `maxdepth` where pathlight's paths are unbounded (`MAX_DEPTH` in
/// bench/pbrt_peer.py, whose docstring says why).
pub const PBRT_MAX_DEPTH: u32 = 100;

/// How to run pbrt.
#[derive(Clone, Debug)]
pub struct PbrtOptions {
    /// The `pbrt` executable.
    pub binary: PathBuf,
    /// pbrt's integrator (`bdpt`, `path`, …).
    pub integrator: String,
    /// The integrator of pbrt's converged image: `integrator` unless told otherwise. A
    /// biased integrator (`sppm`) measured against its own converged image has the bias the
    /// two share hidden from its error, while pathlight's biased integrators are measured
    /// against the path tracer's: `path` here makes the two comparable.
    pub converged_integrator: String,
}

/// pbrt's series and its converged image on one scene.
pub struct PbrtRun {
    pub series: Series,
    pub converged: LinearImage,
}

/// Converts `scene` to `OUT/<scene>/pbrt-<integrator>.pbrt` with `bench/pbrt_peer.py`.
fn convert(scene: &BenchScene, options: &PeerOptions, integrator: &str) -> Result<PathBuf> {
    let dir = options.out.join(&scene.name);
    let file = dir.join(format!("pbrt-{integrator}.pbrt"));
    let script = options.script.with_file_name("pbrt_peer.py");
    let mut command = Command::new(&options.python);
    command
        .arg(&script)
        .arg(&scene.base)
        .args(["--width", &options.width.to_string(), "--height", &options.height.to_string()])
        .args(["--integrator", integrator])
        .args(["--max-depth", &options.max_depth.unwrap_or(PBRT_MAX_DEPTH).to_string()])
        .arg("--out")
        .arg(&file);
    if let Some(insert) = &scene.insert {
        let matrix: Vec<String> = insert.transform.to_cols_array().iter().map(|v| format!("{v:e}")).collect();
        command.arg("--insert").arg(&insert.path).arg(format!("--matrix={}", matrix.join(",")));
        command.args(["--insert-white", &insert.white.to_string()]);
    }
    let status = command.status().map_err(|e| {
        Error::Settings(format!("could not run {} {}: {e}", options.python, script.display()))
    })?;
    if !status.success() {
        return Err(Error::Settings(format!(
            "{}: converting {} failed ({status})",
            script.display(),
            scene.name
        )));
    }
    Ok(file)
}

/// One pbrt render of `file` at `spp` samples with `seed` into `out`: its image and wall
/// seconds. `one_pixel`: render only pixel (0, 0) (to time the start-up).
fn render(
    pbrt: &PbrtOptions,
    file: &Path,
    spp: u32,
    seed: u32,
    out: &Path,
    one_pixel: bool,
) -> Result<(Option<LinearImage>, f64)> {
    let mut command = Command::new(&pbrt.binary);
    command
        .args(["--spp", &spp.to_string(), "--seed", &seed.to_string(), "--nthreads"])
        .arg(std::thread::available_parallelism().map_or(1, |n| n.get()).to_string())
        .arg("--quiet")
        .arg("--outfile")
        .arg(out);
    if one_pixel {
        command.args(["--pixelbounds", "0,1,0,1"]);
    }
    command.arg(file);
    let start = Instant::now();
    let output = command.output().map_err(|e| {
        Error::Settings(format!(
            "could not run pbrt ({}): {e}; build it with ../shared/peers/pbrt-v4/build_pbrt.sh and pass --pbrt",
            pbrt.binary.display()
        ))
    })?;
    let seconds = start.elapsed().as_secs_f64();
    if !output.status.success() {
        return Err(Error::Settings(format!(
            "pbrt failed on {} ({}): {}",
            file.display(),
            output.status,
            String::from_utf8_lossy(&output.stderr).trim()
        )));
    }
    let image = if one_pixel { None } else { Some(LinearImage::read(out)?) };
    Ok((image, seconds))
}

/// The mean of the batch images with the variance of that mean from their spread.
fn mean_of_batches(batches: &[LinearImage]) -> LinearImage {
    let n = batches.len() as f64;
    let pixels = batches[0].rgb.len();
    let mut rgb = vec![[0.0f32; 3]; pixels];
    let mut variance = vec![[0.0f32; 3]; pixels];
    for i in 0..pixels {
        for c in 0..3 {
            let mean = batches.iter().map(|b| b.rgb[i][c] as f64).sum::<f64>() / n;
            let spread = batches.iter().map(|b| (b.rgb[i][c] as f64 - mean).powi(2)).sum::<f64>() / (n - 1.0);
            rgb[i][c] = mean as f32;
            variance[i][c] = (spread / n) as f32;
        }
    }
    LinearImage { rgb, variance: Some(variance), spp: None, replicate_variance: None, ..batches[0].clone() }
}

/// pbrt's converged image and error series on `scene` (module documentation).
pub fn run(scene: &BenchScene, options: &PeerOptions, pbrt: &PbrtOptions) -> Result<PbrtRun> {
    let dir = options.out.join(&scene.name);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let file = convert(scene, options, &pbrt.integrator)?;
    let converged_file = if pbrt.converged_integrator == pbrt.integrator {
        file.clone()
    } else {
        convert(scene, options, &pbrt.converged_integrator)?
    };
    let tag = format!("pbrt-{}", pbrt.integrator);
    let scratch = dir.join(format!("{tag}-series.exr"));
    let batch_spp = (options.converged_spp / CONVERGED_BATCHES).max(1);
    let mut batches = Vec::new();
    for k in 0..CONVERGED_BATCHES {
        let path = dir.join(format!("pbrt-{}-batch{k}.exr", pbrt.converged_integrator));
        let reusable = path.exists()
            && LinearImage::read(&path)
                .is_ok_and(|b| (b.width, b.height) == (options.width as usize, options.height as usize));
        if !reusable {
            let name = &pbrt.converged_integrator;
            eprintln!("{}: pbrt {name} converged batch {k}, {batch_spp} spp", scene.name);
            render(pbrt, &converged_file, batch_spp, 1_000_000 + k, &path, false)?;
        }
        batches.push(LinearImage::read(&path)?);
    }
    let converged = mean_of_batches(&batches);
    let log = dir.join(format!("{tag}.csv"));
    let label = format!("pbrt-v4 {}", pbrt.integrator);
    if options.reuse_series {
        return Ok(PbrtRun { series: super::peer::read_series(&log, label)?, converged });
    }
    let startup = (0..3)
        .map(|_| render(pbrt, &file, 1, 0, &scratch, true).map(|(_, s)| s))
        .collect::<Result<Vec<f64>>>()?
        .into_iter()
        .fold(f64::INFINITY, f64::min);
    eprintln!("{}: pbrt start-up {startup:.3} s (subtracted from each render's time)", scene.name);
    let mut points = Vec::new();
    let mut spp = 1;
    while spp <= 1 << 20 {
        let (image, wall) = render(pbrt, &file, spp, spp, &scratch, false)?;
        let seconds = (wall - startup).max(1e-6);
        let (_, relmse) = error_against(&image.expect("a full render"), &converged);
        eprintln!(
            "{:>24} {spp:>6} spp {seconds:>9.3} s  relMSE {relmse:.5}",
            format!("pbrt-v4 {}", pbrt.integrator)
        );
        points.push((spp, seconds, relmse));
        if seconds >= options.seconds {
            break;
        }
        spp *= 2;
    }
    let _ = std::fs::remove_file(&scratch);
    let series = Series { label, points, key: None };
    std::fs::write(&log, series.csv()).map_err(|e| Error::io(&log, e))?;
    Ok(PbrtRun { series, converged })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mean_of_batches_carries_the_variance_of_that_mean() {
        let image = |v: f32| LinearImage {
            width: 1,
            height: 1,
            rgb: vec![[v, 2.0 * v, 0.0]],
            variance: None,
            spp: None,
            replicate_variance: None,
        };
        // Batches 1, 2, 3, 6: mean 3, sample variance (4 + 1 + 0 + 9) / 3, of the mean / 4.
        let m = mean_of_batches(&[image(1.0), image(2.0), image(3.0), image(6.0)]);
        assert_eq!(m.rgb[0], [3.0, 6.0, 0.0]);
        let v = m.variance.unwrap()[0];
        assert!(
            (v[0] - 14.0 / 12.0).abs() < 1e-6 && (v[1] - 56.0 / 12.0).abs() < 1e-5 && v[2] == 0.0,
            "{v:?}"
        );
    }
}
