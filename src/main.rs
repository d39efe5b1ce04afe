//! The `pathlight` command line: parses the arguments and dispatches to the command's module
//! in `src/cli/` (the binary's own modules; the work is the library's).

#[macro_use]
mod cli;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "pathlight",
    version,
    about = "A physically based Monte Carlo path tracer (GPU megakernel on Vulkan, CPU reference)"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a glTF scene to EXR (linear, with per-pixel variance) and/or PNG.
    Render(cli::render::RenderArgs),
    /// Watch a scene converge in a window (drag to orbit, wheel to zoom, S saves, Esc quits).
    View(cli::view::ViewArgs),
    /// List the Vulkan adapters with their driver, type and the limits that matter.
    Info,
    /// Measure scene preparation and render throughput; prints markdown tables.
    Bench(cli::bench::BenchArgs),
    /// Compare two images, noise-aware: exit 0 if they match, 1 if they differ, 2 on bad input.
    Compare(cli::compare::CompareArgs),
    /// Merge the parts of one render (`render --shard I/N` or `--samples A..B`) exactly.
    Merge(cli::merge::MergeArgs),
    /// Denoise an EXR rendered with its AOVs (`render --aov all`), guided by them.
    Denoise(cli::denoise::DenoiseArgs),
}

fn main() -> ExitCode {
    // Mesa's Vulkan drivers print "XDG_RUNTIME_DIR is invalid or not set" on every start
    // when it is unset (headless servers, CI); pathlight uses no display, so point it at the
    // temporary directory. Done first, while the process is single-threaded.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let result = match Cli::parse().command {
        // `compare` has its own exit codes: 0 same, 1 different, 2 bad input or usage.
        Command::Compare(args) => return cli::compare::run(args),
        Command::Render(args) => cli::render::run(args),
        Command::View(args) => cli::view::run(args),
        Command::Info => cli::info::run(),
        Command::Bench(args) => cli::bench::run(args),
        Command::Merge(args) => cli::merge::run(args),
        Command::Denoise(args) => cli::denoise::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
