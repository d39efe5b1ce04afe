//! A whole render as `pathlight render` runs it, for any caller: progressive passes into a
//! session's film with checkpoints (a convergence log against an optional reference, a time
//! limit, an error target, tev updates), then the outputs, written even when a pass fails.
//! The command line adds only its progress bar and its messages, through [`JobEvent`]s.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use super::Session;
use crate::error::{Error, Result};
use crate::film::{
    check_writable, convergence_csv, convergence_json, write_atomically, ConvergenceRow, LinearImage, Tonemap,
};
use crate::render::RenderStats;
use crate::tev::TevStream;

/// Seconds between tev updates at most a few times a second: each sends the whole image.
const TEV_UPDATE_SECONDS: f64 = 0.25;

/// What to render and where it goes.
pub struct RenderJob {
    /// Samples per pixel to reach (unless a limit below stops the render first).
    pub spp: u32,
    /// Images written at the end: .exr (linear radiance and variance) or .png.
    pub outputs: Vec<PathBuf>,
    pub tonemap: Tonemap,
    /// PNG exposure in stops.
    pub exposure: f32,
    /// A reference of the same size: the log's rows then carry RMSE and relMSE against it.
    pub reference: Option<LinearImage>,
    /// The convergence log (rows at 1, 2, 4, … spp): .csv or .json.
    pub log: Option<PathBuf>,
    /// Stop after the pass that passes this many seconds.
    pub time_limit: Option<f64>,
    /// Stop once the relMSE predicted from the image's own error estimate is at most this.
    pub target_error: Option<f64>,
    /// A tev viewer the film is streamed to as it converges.
    pub tev: Option<TevStream>,
}

/// What a running job reports to its caller.
pub enum JobEvent<'a> {
    /// A pass ended with this many samples per pixel (the most any pixel has, under adaptive
    /// sampling, where `active` is the share of pixels that take more).
    Pass { spp: u32, active: Option<f64> },
    /// A convergence row was taken (against the reference when there is one).
    Row { row: &'a ConvergenceRow, against_reference: bool },
    /// Something went wrong that does not stop the render (tev went away).
    Warning(String),
}

/// What a finished job did.
pub struct JobReport {
    pub stats: RenderStats,
    /// The convergence rows taken.
    pub rows: Vec<ConvergenceRow>,
    /// Rays traced (camera, bounce and shadow rays).
    pub rays: u64,
    /// Samples taken, rejected (non-finite) ones included, and those rejected.
    pub samples: u64,
    pub rejected: u64,
}

/// Checks that every output can be written, and has an extension pathlight writes, before
/// any work: a missing folder or a read-only target must not cost a whole render.
pub fn check_outputs(outputs: &[PathBuf]) -> Result<()> {
    for path in outputs {
        match extension(path).as_deref() {
            Some("exr") | Some("png") => check_writable(path)?,
            _ => return Err(Error::Settings(format!("{}: output must end in .exr or .png", path.display()))),
        }
    }
    Ok(())
}

fn extension(path: &Path) -> Option<String> {
    path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase)
}

/// `--target-error` must be a positive, finite relMSE.
pub fn check_target_error(target_error: Option<f64>) -> Result<()> {
    if target_error.is_some_and(|e| !(e > 0.0 && e.is_finite())) {
        return Err(Error::Settings("--target-error must be positive and finite".into()));
    }
    Ok(())
}

impl RenderJob {
    /// A job with no log, limits, reference or tev.
    pub fn new(spp: u32, outputs: Vec<PathBuf>) -> RenderJob {
        RenderJob {
            spp,
            outputs,
            tonemap: Tonemap::Clamp,
            exposure: 0.0,
            reference: None,
            log: None,
            time_limit: None,
            target_error: None,
            tev: None,
        }
    }

    /// Checks the outputs, the log and the limits before any work.
    pub fn check(&self) -> Result<()> {
        check_outputs(&self.outputs)?;
        if let Some(log) = &self.log {
            match extension(log).as_deref() {
                Some("csv") | Some("json") => check_writable(log)?,
                _ => {
                    return Err(Error::Settings(format!(
                        "{}: --log must end in .csv or .json",
                        log.display()
                    )))
                }
            }
        }
        if self.time_limit.is_some_and(|t| !(t > 0.0 && t.is_finite()))
            || self.target_error.is_some_and(|e| !(e > 0.0 && e.is_finite()))
        {
            return Err(Error::Settings(
                "--time-limit and --target-error must be positive and finite".into(),
            ));
        }
        Ok(())
    }

    /// Checks a job that renders a part of a render (`SessionOptions::samples`): it needs an
    /// EXR output, the only one that carries the film's state `merge` reads, and no limit that
    /// could stop it before its range's end and leave a gap.
    pub fn check_part(&self) -> Result<()> {
        if !self.outputs.iter().any(|o| extension(o).as_deref() == Some("exr")) {
            return Err(Error::Settings(
                "a part (--samples, --shard) needs an .exr output: only an EXR carries the film's state \
                 that `pathlight merge` reads"
                    .into(),
            ));
        }
        if self.time_limit.is_some() || self.target_error.is_some() {
            return Err(Error::Settings(
                "--time-limit and --target-error would stop a part early and leave a gap in the render; \
                 a part (--samples, --shard) renders its whole range"
                    .into(),
            ));
        }
        Ok(())
    }

    /// Reads `path` as the job's reference, which must have the session's image size.
    pub fn read_reference(path: &Path, session: &Session) -> Result<LinearImage> {
        let (width, height) = (session.settings.width, session.settings.height);
        let image = LinearImage::read(path)?;
        if (image.width, image.height) != (width as usize, height as usize) {
            return Err(Error::Settings(format!(
                "{}: the reference is {}×{}, the render {width}×{height}",
                path.display(),
                image.width,
                image.height
            )));
        }
        Ok(image)
    }

    /// Renders `session` to the job's end (its spp, a limit, or `stop`), then writes the log
    /// and the outputs. A failed pass (a GPU fault or timeout) still writes the passes before
    /// it to the outputs, and the error says so.
    pub fn run(
        mut self,
        session: &mut Session,
        stop: &AtomicBool,
        mut on_event: impl FnMut(JobEvent),
    ) -> Result<JobReport> {
        let mut rows: Vec<ConvergenceRow> = Vec::new();
        let logging = self.reference.is_some() || self.log.is_some();
        let start = Instant::now();
        let mut last_tev = None::<Instant>;
        let (spp, time_limit, target_error) = (self.spp, self.time_limit, self.target_error);
        let reference = self.reference.take();
        let tev = &mut self.tev;
        // Adaptive sampling: the pilot first, so that each pass can report the share of
        // pixels still taking samples (`render_to` would run it too).
        let mut budgets: Vec<u32> = match session.decide_sample_counts(stop) {
            Ok(_) => session.sample_budgets().map(<[u32]>::to_vec).unwrap_or_default(),
            Err(e) => return Err(e),
        };
        budgets.sort_unstable();
        let active = |done: u32| {
            (!budgets.is_empty()).then(|| {
                (budgets.len() - budgets.partition_point(|&b| b <= done)) as f64 / budgets.len() as f64
            })
        };
        let rendered = session.render_to(spp, stop, |b, done| {
            let seconds = start.elapsed().as_secs_f64();
            on_event(JobEvent::Pass { spp: done, active: active(done) });
            let mut stop_now = time_limit.is_some_and(|t| seconds >= t);
            // A log row at 1, 2, 4, … spp when asked for one, the predicted error after every
            // pass when the error target may stop the render.
            let log_here = logging && (done.is_power_of_two() || done == spp);
            if log_here || target_error.is_some() {
                let image = LinearImage::from_film(&b.film()?);
                let row = ConvergenceRow::new(&image, reference.as_ref(), done, seconds);
                stop_now |= target_error.is_some_and(|e| row.predicted_relmse <= e);
                if log_here || (stop_now && logging) {
                    on_event(JobEvent::Row { row: &row, against_reference: reference.is_some() });
                    rows.push(row);
                }
            }
            if let Some(t) = tev.as_mut() {
                if last_tev.is_none_or(|l| l.elapsed().as_secs_f64() >= TEV_UPDATE_SECONDS) || done == spp {
                    if let Err(e) = t.update(&b.film()?) {
                        on_event(JobEvent::Warning(format!("--tev: {e}; no more updates")));
                        *tev = None;
                    }
                    last_tev = Some(Instant::now());
                }
            }
            Ok(stop_now)
        });
        let stats = match rendered {
            Ok(stats) => stats,
            // The passes before the failure are in the film: write them where they can still
            // be read back, then report the failure.
            Err(e) => {
                let outputs: Vec<String> = self.outputs.iter().map(|o| o.display().to_string()).collect();
                return Err(match session.write_plain(&self.outputs, self.tonemap, self.exposure) {
                    Ok(()) => Error::Gpu(format!(
                        "{e}; the {} spp completed before it were written to {}",
                        session.spp(),
                        outputs.join(", ")
                    )),
                    Err(w) => Error::Gpu(format!(
                        "{e}; the samples rendered before it could not be read back ({w})"
                    )),
                });
            }
        };
        if let Some(log) = &self.log {
            let text = if extension(log).as_deref() == Some("json") {
                format!("{:#}\n", convergence_json(&rows))
            } else {
                convergence_csv(&rows)
            };
            write_atomically(log, |tmp| std::fs::write(tmp, &text).map_err(|e| Error::io(log, e)))?;
        }
        let film = session.film()?;
        if let Some(t) = self.tev.as_mut() {
            // The final image, then the connection closes (the image stays open in tev).
            if let Err(e) = t.update(&film) {
                on_event(JobEvent::Warning(format!("--tev: {e}")));
            }
        }
        session.write(&self.outputs, self.tonemap, self.exposure)?;
        let rejected = film.total_rejected();
        Ok(JobReport {
            stats,
            rows,
            rays: session.rays_traced()?,
            samples: film.total_samples() + rejected,
            rejected,
        })
    }
}
