//! `pathlight render`: a scene to EXR and PNG, with a progress bar, Ctrl-C and the
//! convergence log; the render itself is [`RenderJob::run`].

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use clap::ValueEnum;
use indicatif::{ProgressBar, ProgressStyle};

use super::SceneArgs;
use pathlight::film::Tonemap;
use pathlight::session::{shard_samples, JobEvent, RenderJob, Session};
use pathlight::tev::TevStream;
use pathlight::Error;

#[derive(clap::Args)]
pub struct RenderArgs {
    #[command(flatten)]
    common: SceneArgs,
    /// Output image(s): .exr (linear radiance + variance) or .png (sRGB). Repeat for several.
    #[arg(short, long = "output", required = true)]
    output: Vec<PathBuf>,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Render only the sample indices START..END of the --spp (a part of the render, merged
    /// with the others by `pathlight merge`); the EXR then holds the film's whole state.
    #[arg(long, value_name = "START..END", value_parser = parse_samples, conflicts_with = "shard")]
    samples: Option<std::ops::Range<u32>>,
    /// Render part I of N (I from 0, as a Kubernetes completion index or a Slurm array task
    /// id): the sample indices ⌊I·spp/N⌋..⌊(I+1)·spp/N⌋, as --samples.
    #[arg(long, value_name = "I/N", value_parser = parse_shard)]
    shard: Option<(u32, u32)>,
    /// With --irradiance-cache: also write this PNG, the image darkened with a red dot at
    /// each pixel whose camera path placed a record (for debugging where records go).
    #[arg(long, value_name = "OUT.png", requires = "irradiance_cache")]
    ic_show_records: Option<PathBuf>,
    /// PNG exposure in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// PNG tone curve.
    #[arg(long, value_enum, default_value_t = TonemapChoice::Clamp)]
    tonemap: TonemapChoice,
    /// A reference image (EXR, same size): log RMSE and relMSE against it at 1, 2, 4, … spp.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// Write the convergence log (spp, seconds, RMSE, relMSE, predicted relMSE) to this
    /// .csv or .json file.
    #[arg(long)]
    log: Option<PathBuf>,
    /// Stop after the pass that passes this many seconds (the image keeps what it has).
    #[arg(long)]
    time_limit: Option<f64>,
    /// Stop once the relMSE predicted from the image's own variance is at most this.
    #[arg(long)]
    target_error: Option<f64>,
    /// Stream progressive updates to the tev HDR viewer at HOST:PORT (default
    /// 127.0.0.1:14158); a tev that is not running is a warning, not a failed render.
    #[arg(long, num_args = 0..=1, default_missing_value = "", value_name = "HOST:PORT")]
    tev: Option<String>,
    /// Adaptive sampling: each pixel gets the samples it needs to reach
    /// --adaptive-threshold, at least --adaptive-min-spp and at most --spp, decided after a
    /// pilot of --adaptive-min-spp samples from each pixel's neighbours' samples, never its
    /// own, so that no pixel's mean is biased by its own stopping rule (the pilot's samples
    /// are kept). The EXR records each pixel's count (channel sampleCount).
    #[arg(long)]
    adaptive: bool,
    /// The relative standard error of a pixel of the image's mean noise (0.02: 2%).
    #[arg(long, default_value_t = pathlight::sampling::adaptive::DEFAULT_ADAPTIVE_THRESHOLD, requires = "adaptive")]
    adaptive_threshold: f32,
    /// Samples per pixel of the adaptive pilot, and the fewest any pixel gets.
    #[arg(long, default_value_t = pathlight::sampling::adaptive::DEFAULT_ADAPTIVE_MIN_SPP, requires = "adaptive")]
    adaptive_min_spp: u32,
    /// With --integrator bdpt: also write each strategy's weighted contribution to
    /// DIR/s{S}-t{T}.exr (S light and T camera vertices; the images sum to the render),
    /// as pbrt-v4's --write-bdpt-strategies does, for seeing which strategy carries what.
    #[arg(long, value_name = "DIR")]
    bdpt_strategies: Option<PathBuf>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TonemapChoice {
    Clamp,
    Aces,
}

impl From<TonemapChoice> for Tonemap {
    fn from(choice: TonemapChoice) -> Tonemap {
        match choice {
            TonemapChoice::Clamp => Tonemap::Clamp,
            TonemapChoice::Aces => Tonemap::Aces,
        }
    }
}

/// Parses `START..END`.
fn parse_samples(s: &str) -> Result<std::ops::Range<u32>, String> {
    let (a, b) = s.split_once("..").ok_or("expected START..END, e.g. 0..64")?;
    let (a, b) = (
        a.trim().parse::<u32>().map_err(|e| format!("'{a}': {e}"))?,
        b.trim().parse::<u32>().map_err(|e| format!("'{b}': {e}"))?,
    );
    if a >= b {
        return Err(format!("{a}..{b} is empty: START must be below END"));
    }
    Ok(a..b)
}

/// Parses `I/N` with I < N.
fn parse_shard(s: &str) -> Result<(u32, u32), String> {
    let (i, n) = s.split_once('/').ok_or("expected I/N, e.g. 0/4")?;
    let (i, n) = (
        i.trim().parse::<u32>().map_err(|e| format!("'{i}': {e}"))?,
        n.trim().parse::<u32>().map_err(|e| format!("'{n}': {e}"))?,
    );
    if n == 0 || i >= n {
        return Err(format!("{i}/{n}: I must be below N (parts are numbered from 0)"));
    }
    Ok((i, n))
}

pub fn run(args: RenderArgs) -> Result<(), Error> {
    let mut job = RenderJob {
        tonemap: args.tonemap.into(),
        exposure: args.exposure,
        log: args.log,
        time_limit: args.time_limit,
        target_error: args.target_error,
        ..RenderJob::new(args.spp, args.output)
    };
    // A part renders up to its range's end (`RenderJob::spp` is the last sample index).
    job.check()?;
    let samples = match (args.samples.clone(), args.shard) {
        (Some(range), _) => Some(range),
        (None, Some((i, n))) => {
            let range = shard_samples(i, n, args.spp);
            if range.is_empty() {
                return Err(Error::Settings(format!(
                    "--shard {i}/{n}: {n} parts of {} samples leave part {i} none; use at most {} parts",
                    args.spp, args.spp
                )));
            }
            Some(range)
        }
        (None, None) => None,
    };
    if samples.is_some() {
        job.check_part()?;
    }
    let mut options = args.common.session_options(args.spp);
    options.samples = samples;
    options.record_strategies = args.bdpt_strategies.is_some();
    options.adaptive = args.adaptive.then_some(pathlight::sampling::adaptive::AdaptiveSettings {
        threshold: args.adaptive_threshold,
        min_spp: args.adaptive_min_spp,
    });
    let mut session = Session::open(&options)?;
    for w in &session.warnings {
        eprintln!("warning: {}: {w}", args.common.scene.display());
    }
    eprintln!("{}", session.describe());
    for note in session.backend_note.iter().chain(&session.backend_detail) {
        eprintln!("{note}");
    }
    let (width, height) = (session.settings.width, session.settings.height);
    if let Some(range) = &options.samples {
        job.spp = range.end;
        eprintln!("rendering samples {}..{} of {}", range.start, range.end, args.spp);
    }
    if let Some(path) = &args.reference {
        job.reference = Some(RenderJob::read_reference(path, &session)?);
    }
    if let Some(address) = &args.tev {
        let address = if address.is_empty() { pathlight::tev::DEFAULT_ADDRESS } else { address.as_str() };
        match TevStream::connect(address, &pathlight::tev::image_name(&args.common.scene), width, height) {
            Ok(stream) => job.tev = Some(stream),
            Err(e) => eprintln!("warning: --tev: {e}; rendering without it"),
        }
    }

    // Ctrl-C stops after the pass in flight and still writes what was rendered; a second
    // Ctrl-C exits at once.
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        let _ = ctrlc::set_handler(move || {
            if stop.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
            eprintln!(
                "\ninterrupted: finishing the current pass and writing the image (Ctrl-C again to abort)"
            );
        });
    }
    let bar = ProgressBar::new(job.spp as u64);
    bar.set_position(session.first_sample() as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:40} {pos}/{len} spp  {elapsed_precise} elapsed  ETA {eta_precise}{msg}",
        )
        .expect("static template"),
    );
    let report = job.run(&mut session, &stop, |event| match event {
        JobEvent::Pass { spp, active } => {
            bar.set_position(spp as u64);
            if let Some(share) = active {
                bar.set_message(format!("  {:.1}% of pixels still sampling", 100.0 * share));
            }
        }
        JobEvent::Row { row, against_reference: true } => bar.suspend(|| {
            eprintln!(
                "{:>6} spp {:>9.3} s  RMSE {:.5}  relMSE {:.5}  predicted relMSE {:.5}",
                row.spp,
                row.seconds,
                row.rmse.unwrap_or(f64::NAN),
                row.relmse.unwrap_or(f64::NAN),
                row.predicted_relmse
            )
        }),
        JobEvent::Row { .. } => {}
        JobEvent::Warning(w) => bar.suspend(|| eprintln!("warning: {w}")),
    });
    bar.finish_and_clear();
    let report = report?;
    let stats = report.stats;
    let stats = pathlight::RenderStats { spp: stats.spp - session.first_sample(), ..stats };
    eprintln!(
        "{}{} spp at {width}×{height} in {:.2} s: {:.3} Msamples/s, {:.2} Mrays/s, {} rejected sample(s), backend {}",
        if stats.interrupted { "interrupted after " } else { "" },
        stats.spp,
        stats.seconds,
        report.samples as f64 / stats.seconds.max(1e-9) / 1e6,
        report.rays as f64 / stats.seconds.max(1e-9) / 1e6,
        report.rejected,
        session.backend_name()
    );
    if let Some(budgets) = session.sample_budgets() {
        let n = budgets.len().max(1) as f64;
        let mean = budgets.iter().map(|&b| b as f64).sum::<f64>() / n;
        let full = budgets.iter().filter(|&&b| b >= args.spp).count() as f64 / n;
        eprintln!(
            "adaptive: pilot of {} spp in {:.2} s; {mean:.1} spp per pixel on average ({}..{}), {:.1}% of pixels at --spp {}",
            args.adaptive_min_spp,
            session.pilot_seconds(),
            budgets.iter().min().unwrap_or(&0),
            budgets.iter().max().unwrap_or(&0),
            100.0 * full,
            args.spp
        );
    }
    let extras = session.extras_timing();
    if let Some(denoiser) = session.output_options().denoiser {
        eprintln!(
            "denoised by {denoiser} in {:.3} s (AOVs rendered in {:.3} s)",
            extras.denoise_seconds, extras.aov_seconds
        );
    } else if session.output_options().aovs.any() {
        eprintln!("AOVs rendered in {:.3} s", extras.aov_seconds);
    }
    if let Some(bdpt) = session.bdpt_stats() {
        eprintln!(
            "bdpt: {} light subpath(s) reached the bound of {} vertices and ended there (the weights leave out the strategies it makes impossible)",
            bdpt.truncated,
            pathlight::integrator::bdpt::BDPT_MAX_VERTICES
        );
    }
    if let Some(mlt) = session.mlt_stats() {
        eprintln!(
            "mlt: {} passes, acceptance rate {:.3}; the variance channels are the spread across passes (their errors uncorrelated)",
            mlt.passes,
            mlt.acceptance_rate()
        );
        if mlt.dropped_samples > 0 {
            eprintln!(
                "warning: mlt: {} samples read more than {} numbers from one stream and were dropped (a bias: this is a bug, please report it)",
                mlt.dropped_samples,
                pathlight::integrator::mlt::MLT_NUMBERS_PER_STREAM
            );
        }
        if mlt.passes_without_light > 0 {
            eprintln!(
                "warning: mlt: the bootstrap of {} of {} passes found no path that carries light (up to --max-depth {}); their images are black",
                mlt.passes_without_light,
                mlt.passes,
                session.settings.max_depth_bound().unwrap_or(u32::MAX)
            );
        }
    }
    if let Some(cache) = session.irradiance_cache_stats() {
        eprintln!(
            "irradiance cache: {} records placed in {:.2} s ({} gather rays), {:.0} KiB; the variance channels and the predicted error measure the samples' noise given the cache, not its interpolation bias",
            cache.records,
            cache.seconds,
            cache.gather_rays,
            cache.bytes as f64 / 1024.0
        );
    }
    if let Some(path) = &args.ic_show_records {
        write_record_image(&mut session, path, args.tonemap.into(), args.exposure)?;
    }
    if let Some(sppm) = session.sppm_stats().filter(|s| s.passes == 0) {
        eprintln!(
            "photon: {} photons stored in the global and caustic maps; the variance channels and the predicted error measure its noise given the maps, not their bias",
            sppm.stored_photons
        );
    } else if let Some(sppm) = session.sppm_stats() {
        let per_pass = sppm.stored_photons as f64 / sppm.passes.max(1) as f64;
        eprintln!(
            "sppm: {} passes, {per_pass:.0} photons stored per pass; the variance channels and the predicted error measure its noise, not the bias of its gather radius",
            sppm.passes
        );
        if sppm.dropped_photons > 0 {
            eprintln!(
                "warning: sppm dropped {} photon records past the bound of {} per pass (the image is darker where they landed); lower --photons",
                sppm.dropped_photons, sppm.record_capacity
            );
        }
    }
    if let Some(dir) = &args.bdpt_strategies {
        write_strategy_images(&mut session, dir, width as usize, height as usize)?;
    }
    Ok(())
}

/// `--ic-show-records OUT.png`: the image at half brightness, a red pixel where each record's
/// camera path started.
fn write_record_image(
    session: &mut Session,
    path: &std::path::Path,
    tonemap: pathlight::film::Tonemap,
    exposure: f32,
) -> Result<(), Error> {
    let pixels = session.irradiance_record_pixels().ok_or_else(|| {
        Error::Settings(format!(
            "--ic-show-records: the {} backend placed no irradiance cache",
            session.backend_name()
        ))
    })?;
    let film = session.film()?;
    let mut image: Vec<glam::Vec3> = film.mean().iter().map(|c| *c * 0.5).collect();
    // Red at any exposure and tone curve: far past white in red, nothing in green and blue.
    let marker = glam::Vec3::new(1e6, 0.0, 0.0);
    for (x, y) in pixels {
        if x < film.width && y < film.height {
            image[(y * film.width + x) as usize] = marker;
        }
    }
    pathlight::film::write_png_rgb(film.width, film.height, &image, path, tonemap, exposure)?;
    eprintln!("irradiance cache records drawn on {}", path.display());
    Ok(())
}

/// `--bdpt-strategies DIR`: one EXR per strategy that contributed, named by its (s, t).
fn write_strategy_images(
    session: &mut Session,
    dir: &std::path::Path,
    width: usize,
    height: usize,
) -> Result<(), Error> {
    let images = session.strategy_images()?.ok_or_else(|| {
        Error::Settings(format!(
            "--bdpt-strategies: the {} backend recorded no strategies",
            session.backend_name()
        ))
    })?;
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::output(dir, format!("cannot create the strategies' folder: {e}")))?;
    for ((s, t), image) in &images {
        let path = dir.join(format!("s{s}-t{t}.exr"));
        pathlight::film::write_rgb_exr(width, height, image, &path)?;
    }
    eprintln!("wrote {} strategy image(s) to {}", images.len(), dir.display());
    Ok(())
}
