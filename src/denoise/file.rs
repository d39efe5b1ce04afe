//! `pathlight denoise IN.exr -o OUT.exr`: denoising a rendered EXR after the fact, from the
//! channels `render --aov all` or `--denoise` wrote (`crate::film::aov` names them).

use std::path::Path;

use glam::Vec3;

use super::{DenoiseInput, Denoiser};
use crate::error::{Error, Result};
use crate::film::{aovs_from_channels, read_exr, Aovs};

/// What a denoiser reads, as an EXR holds it.
pub struct FileInput {
    pub width: u32,
    pub height: u32,
    /// The raw mean: `raw.R`, `raw.G`, `raw.B` when the file was denoised before (its `R`,
    /// `G`, `B` are then a denoiser's output), else `R`, `G`, `B`.
    pub color: Vec<Vec3>,
    /// `variance.R`, `variance.G`, `variance.B`; zero where the file has none.
    pub variance: Vec<Vec3>,
    pub aovs: Aovs,
    /// Samples per pixel (`pathlight.spp`; 1 where the file does not say).
    pub spp: f32,
}

impl FileInput {
    /// The denoiser's view of it.
    pub fn input(&self) -> DenoiseInput<'_> {
        DenoiseInput {
            width: self.width,
            height: self.height,
            color: &self.color,
            variance: &self.variance,
            aovs: &self.aovs,
            spp: self.spp,
        }
    }
}

/// Reads what `denoiser` needs from the EXR at `path`: an error naming the file and the
/// first channel missing (the variance only for a denoiser that reads it).
pub fn read_denoise_input(path: &Path, denoiser: Denoiser) -> Result<FileInput> {
    let exr = read_exr(path)?;
    let n = exr.width * exr.height;
    let plane3 = |names: [&str; 3]| -> Option<Result<Vec<Vec3>>> {
        let found: Vec<&Vec<f32>> = names.iter().filter_map(|c| exr.channels.get(*c)).collect();
        if found.is_empty() {
            return None;
        }
        Some(match found[..] {
            [r, g, b] if r.len() == n && g.len() == n && b.len() == n => {
                Ok((0..n).map(|i| Vec3::new(r[i], g[i], b[i])).collect())
            }
            [_, _, _] => Err(Error::image(
                path,
                format!("its {} channels differ from the image's size", names.join(", ")),
            )),
            _ => Err(Error::image(path, format!("has only some of the channels {}", names.join(", ")))),
        })
    };
    let color = plane3(["raw.R", "raw.G", "raw.B"])
        .or_else(|| plane3(["R", "G", "B"]))
        .unwrap_or_else(|| Err(Error::image(path, "has no R, G, B channels")))?;
    let variance = match plane3(["variance.R", "variance.G", "variance.B"]) {
        Some(v) => v?,
        None if denoiser.needs_variance() => {
            return Err(Error::image(
                path,
                format!("has no variance.R, variance.G, variance.B channels, which --denoiser {denoiser} reads (pathlight's renders write them)"),
            ))
        }
        None => vec![Vec3::ZERO; n],
    };
    if let Some(i) = color.iter().chain(&variance).position(|c| !c.is_finite()) {
        return Err(Error::image(path, format!("holds a non-finite value (pixel {})", i % n)));
    }
    let aovs = aovs_from_channels(path, exr.width, exr.height, &exr.channels, denoiser.needs_depth())?;
    let guides_finite = aovs.albedo.iter().chain(&aovs.normal).all(|v| v.is_finite())
        && aovs.depth.iter().all(|z| !z.is_nan());
    if !guides_finite {
        return Err(Error::image(
            path,
            "its albedo, normal or depth channels hold a NaN or an infinite normal",
        ));
    }
    let spp = exr.attributes.get("pathlight.spp").and_then(|s| s.parse::<f32>().ok()).unwrap_or(1.0).max(1.0);
    Ok(FileInput { width: exr.width as u32, height: exr.height as u32, color, variance, aovs, spp })
}
