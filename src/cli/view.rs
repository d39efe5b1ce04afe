//! `pathlight view`: a scene converging in a window ([`pathlight::viewer`]).

use std::path::PathBuf;

use clap::ValueEnum;

use super::SceneArgs;
use pathlight::scene::layout::{DISPLAY_ACES, DISPLAY_CLAMP, DISPLAY_RELATIVE_ERROR};
use pathlight::session::{check_outputs, check_target_error};
use pathlight::viewer::ViewOptions;
use pathlight::Error;

/// `view`: the scene options of `render`, and the window's own.
#[derive(clap::Args)]
pub struct ViewArgs {
    #[command(flatten)]
    common: SceneArgs,
    /// Stop accumulating at this many samples per pixel (the window stays open).
    #[arg(long, default_value_t = 4096)]
    spp: u32,
    /// Stop accumulating once the relMSE predicted from the image's own variance is at most this.
    #[arg(long)]
    target_error: Option<f64>,
    /// Render this many frames of one whole pass each (N samples per pixel), write
    /// --screenshot and the outputs, and exit: for tests and pictures.
    #[arg(long)]
    frames: Option<u32>,
    /// With --frames: save what the window shows to this PNG.
    #[arg(long, requires = "frames")]
    screenshot: Option<PathBuf>,
    /// Images written on exit (.exr with variance, .png); also what `S` writes.
    #[arg(short, long = "output")]
    output: Vec<PathBuf>,
    /// Initial exposure in stops (`+`/`-` change it).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// Initial tone map (`T` cycles them).
    #[arg(long, value_enum, default_value_t = ViewTonemap::Clamp)]
    tonemap: ViewTonemap,
}

#[derive(Clone, Copy, ValueEnum)]
enum ViewTonemap {
    Clamp,
    Aces,
    /// False colour of each pixel's relative standard error (10⁻³ blue … 1 red).
    RelativeError,
}

pub fn run(args: ViewArgs) -> Result<(), Error> {
    check_target_error(args.target_error)?;
    check_outputs(&args.output)?;
    if args.frames == Some(0) {
        return Err(Error::Settings("--frames must be at least 1".into()));
    }
    let mut session = args.common.session_options(args.spp);
    // `D` shows the denoised image, which needs the AOVs.
    session.aovs_available = true;
    pathlight::viewer::run(ViewOptions {
        show_denoised: args.common.denoise,
        denoiser: args.common.denoiser,
        session,
        target_error: args.target_error,
        frames: args.frames,
        screenshot: args.screenshot,
        outputs: args.output,
        exposure: args.exposure,
        tonemap: match args.tonemap {
            ViewTonemap::Clamp => DISPLAY_CLAMP,
            ViewTonemap::Aces => DISPLAY_ACES,
            ViewTonemap::RelativeError => DISPLAY_RELATIVE_ERROR,
        },
    })
}
