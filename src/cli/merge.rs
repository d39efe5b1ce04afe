//! `pathlight merge`: the parts of one render (`render --shard`, `--samples`) merged exactly
//! into one image ([`pathlight::film::merge_files`]).

use std::path::PathBuf;

use pathlight::film::merge_files;
use pathlight::Error;

#[derive(clap::Args)]
pub struct MergeArgs {
    /// The parts: EXRs written by `render --shard I/N` or `--samples A..B`, or by `merge`.
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// The merged image (.exr, with its film's state, so it merges again).
    #[arg(short, long = "output")]
    output: PathBuf,
}

pub fn run(args: MergeArgs) -> Result<(), Error> {
    let report = merge_files(&args.inputs, &args.output)?;
    let missing = report.samples.start > 0 || report.samples.end < report.total_spp;
    eprintln!(
        "merged {} part(s): samples {}..{} of the render's {}{} into {}{}",
        report.parts,
        report.samples.start,
        report.samples.end,
        report.total_spp,
        if missing { " (the rest are not rendered yet)" } else { "" },
        args.output.display(),
        report.predicted_relmse.map(|e| format!(", predicted relMSE {e:.3e}")).unwrap_or_default()
    );
    Ok(())
}
