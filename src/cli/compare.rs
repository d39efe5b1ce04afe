//! `pathlight compare`: two images, noise-aware, with its own exit codes.

use std::path::PathBuf;
use std::process::ExitCode;

use pathlight::film::{compare_images, write_diff_png, write_zmap_exr, CompareOptions, LinearImage};
use pathlight::Error;

#[derive(clap::Args)]
pub struct CompareArgs {
    /// The image under test (.exr, ideally a pathlight EXR with variance, or .png).
    test: PathBuf,
    /// The reference image (.exr or .png).
    reference: PathBuf,
    /// Family-wise false-alarm rate of the statistical test.
    #[arg(long, default_value_t = 0.01)]
    alpha: f64,
    /// Edge of the pixel blocks pooled by the statistical test.
    #[arg(long, default_value_t = 4)]
    block: usize,
    /// Also fail when the RMSE exceeds this.
    #[arg(long)]
    max_rmse: Option<f64>,
    /// Also fail when the relMSE (mean of (t − r)² / (r² + 0.01)) exceeds this.
    #[arg(long)]
    max_relmse: Option<f64>,
    /// Also fail when the mean FLIP error exceeds this.
    #[arg(long)]
    max_flip: Option<f64>,
    /// Also fail when any |test − reference| exceeds this.
    #[arg(long)]
    max_abs: Option<f64>,
    /// Print every number as JSON on standard output instead of the text report.
    #[arg(long)]
    json: bool,
    /// Write a heat map of |z| (or of |test − reference| without variance) to this PNG.
    #[arg(long)]
    diff: Option<PathBuf>,
    /// Write the per-pixel z-scores to this EXR.
    #[arg(long)]
    zmap: Option<PathBuf>,
}

/// Exit 0 when the images match, 1 when they differ, 2 on bad input or usage.
pub fn run(args: CompareArgs) -> ExitCode {
    let compare = || -> Result<bool, Error> {
        let test = LinearImage::read(&args.test)?;
        let reference = LinearImage::read(&args.reference)?;
        let options = CompareOptions {
            alpha: args.alpha,
            block: args.block,
            max_rmse: args.max_rmse,
            max_relmse: args.max_relmse,
            max_flip: args.max_flip,
            max_abs: args.max_abs,
        };
        let report = compare_images(&test, &reference, &options)?;
        if let Some(p) = &args.diff {
            write_diff_png(&report, &test, &reference, p)?;
        }
        if let Some(p) = &args.zmap {
            write_zmap_exr(&report, p)?;
        }
        if args.json {
            out!("{:#}", report.to_json());
        } else {
            out!("{} vs {}: {report}", args.test.display(), args.reference.display());
        }
        Ok(report.same())
    };
    match compare() {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
    }
}
