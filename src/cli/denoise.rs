//! `pathlight denoise`: an EXR rendered with its AOVs (`render --aov all` or `--denoise`),
//! denoised after the fact; the work is [`pathlight::denoise`]'s.

use std::path::PathBuf;

use super::render::TonemapChoice;
use pathlight::denoise::file::read_denoise_input;
use pathlight::denoise::Denoiser;
use pathlight::film::{write_denoised_copy, write_png_rgb};
use pathlight::Error;

#[derive(clap::Args)]
pub struct DenoiseArgs {
    /// The EXR to denoise: pathlight's, with the albedo, normal and depth channels
    /// (`render --aov all`); its raw.R/G/B are used when it was denoised before.
    input: PathBuf,
    /// Output image(s): .exr (the input's channels, R, G, B denoised and the mean it was made
    /// from in raw.R/G/B) or .png (the denoised image, tone-mapped). Repeat for several.
    #[arg(short, long = "output", required = true)]
    output: Vec<PathBuf>,
    /// atrous (built in) or oidn (Intel Open Image Denoise, builds with the `oidn` feature).
    #[arg(long, default_value = "atrous", value_parser = super::parse_denoiser())]
    denoiser: Denoiser,
    /// PNG exposure in stops.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
    /// PNG tone curve.
    #[arg(long, value_enum, default_value_t = TonemapChoice::Clamp)]
    tonemap: TonemapChoice,
}

pub fn run(args: DenoiseArgs) -> Result<(), Error> {
    args.denoiser.check_available()?;
    pathlight::session::check_outputs(&args.output)?;
    let input = read_denoise_input(&args.input, args.denoiser)?;
    let start = std::time::Instant::now();
    let denoised = pathlight::denoise::denoise(args.denoiser, &input.input(), None)?;
    let seconds = start.elapsed().as_secs_f64();
    for o in &args.output {
        if o.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
            write_denoised_copy(&args.input, &denoised, args.denoiser.name(), o)?;
        } else {
            write_png_rgb(input.width, input.height, &denoised, o, args.tonemap.into(), args.exposure)?;
        }
    }
    eprintln!(
        "{}: {}×{} denoised by {} in {seconds:.3} s",
        args.input.display(),
        input.width,
        input.height,
        args.denoiser
    );
    Ok(())
}
