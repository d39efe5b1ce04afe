//! Images read back for comparison: linear RGB, with the per-pixel variance of the mean when
//! the file carries it.

use std::path::Path;

use super::{read_exr, Film};
use crate::error::{Error, Result};
use crate::scene::texture::srgb_decode;

/// A linear RGB image and, if known, the estimated variance of each pixel's mean.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearImage {
    pub width: usize,
    pub height: usize,
    /// Row-major, top row first.
    pub rgb: Vec<[f32; 3]>,
    /// Variance of each pixel's mean (pathlight EXRs: `variance.R/G/B`); `None` when the file
    /// has none, or when it was rendered with fewer than 2 samples per pixel (no estimate).
    pub variance: Option<Vec<[f32; 3]>>,
    /// Samples per pixel, where the file says (`pathlight.spp`).
    pub spp: Option<u32>,
    /// Variance of each pixel's mean measured from the sampler's two independent replicates
    /// ([`Film::replicate_variance_of_mean`]): renders only, never read from a file. Unbiased
    /// under QMC, where `variance` (from the samples' spread) over-states the error, but with
    /// one degree of freedom per pixel: for image-wide error estimates, not per-pixel tests.
    pub replicate_variance: Option<Vec<[f32; 3]>>,
}

impl LinearImage {
    /// The film's mean and variance of the mean, as a rendered EXR would hold them.
    pub fn from_film(film: &Film) -> LinearImage {
        let spp = film.pixels.iter().map(|p| p.count).min().unwrap_or(0);
        LinearImage {
            width: film.width as usize,
            height: film.height as usize,
            rgb: film.mean().iter().map(|c| c.to_array()).collect(),
            variance: (spp >= 2).then(|| film.variance_of_mean().iter().map(|v| v.to_array()).collect()),
            spp: Some(spp),
            replicate_variance: film
                .replicate_variance_of_mean()
                .map(|v| v.iter().map(|v| v.to_array()).collect()),
        }
    }

    /// Reads an EXR (channels R, G, B, or raw.R/G/B where the file was denoised, and
    /// optionally variance.R/G/B) or a PNG (8 or 16 bit,
    /// grey or RGB, alpha ignored; decoded from sRGB to linear with the exact transfer
    /// function). Anything unreadable, truncated, missing channels or holding non-finite
    /// values is an error naming the file and what is wrong.
    pub fn read(path: &Path) -> Result<LinearImage> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        // A decoder panicking on a hostile file must not take the comparison down.
        let read = std::panic::catch_unwind(|| match ext.as_deref() {
            Some("exr") => read_exr_image(path),
            Some("png") => read_png_image(path),
            _ => Err(Error::image(path, "not an .exr or .png file")),
        });
        let image =
            read.unwrap_or_else(|_| Err(Error::image(path, "the decoder failed on malformed data")))?;
        image.check_finite(path)?;
        Ok(image)
    }

    fn check_finite(&self, path: &Path) -> Result<()> {
        let mut bad = 0usize;
        let mut first = None;
        for (i, c) in self.rgb.iter().enumerate() {
            let var_ok =
                self.variance.as_ref().is_none_or(|v| v[i].iter().all(|x| x.is_finite() && *x >= 0.0));
            if !c.iter().all(|x| x.is_finite()) || !var_ok {
                bad += 1;
                first.get_or_insert(i);
            }
        }
        match first {
            None => Ok(()),
            Some(i) => Err(Error::image(
                path,
                format!(
                    "{bad} pixel(s) hold non-finite values or negative variance (first at x {}, y {})",
                    i % self.width,
                    i / self.width
                ),
            )),
        }
    }
}

fn read_exr_image(path: &Path) -> Result<LinearImage> {
    let exr = read_exr(path)?;
    let n = exr.width * exr.height;
    let planes = |names: [&str; 3]| -> Option<Result<Vec<[f32; 3]>>> {
        let found: Vec<Option<&Vec<f32>>> = names.iter().map(|c| exr.channels.get(*c)).collect();
        if found.iter().all(Option::is_none) {
            return None;
        }
        Some(match (found[0], found[1], found[2]) {
            (Some(r), Some(g), Some(b)) if r.len() == n && g.len() == n && b.len() == n => {
                Ok((0..n).map(|i| [r[i], g[i], b[i]]).collect())
            }
            (Some(_), Some(_), Some(_)) => {
                Err(Error::image(path, "channel sizes differ from the image size"))
            }
            _ => Err(Error::image(path, format!("has only some of the channels {}", names.join(", ")))),
        })
    };
    let mut names: Vec<&str> = exr.channels.keys().map(String::as_str).collect();
    names.sort_unstable();
    // A denoised EXR holds the denoised image in R, G, B and the mean its variance describes
    // in raw.R, raw.G, raw.B: a comparison reads the latter (`render --denoise`).
    let rgb =
        planes(["raw.R", "raw.G", "raw.B"]).or_else(|| planes(["R", "G", "B"])).unwrap_or_else(|| {
            Err(Error::image(path, format!("has no R, G, B channels (it has: {})", names.join(", "))))
        })?;
    let spp = exr.attributes.get("pathlight.spp").and_then(|s| s.parse::<u32>().ok());
    let variance = match planes(["variance.R", "variance.G", "variance.B"]).transpose()? {
        // With one sample per pixel the film stores 0: no estimate, not certainty.
        Some(_) if spp.is_some_and(|s| s < 2) => None,
        v => v,
    };
    Ok(LinearImage { width: exr.width, height: exr.height, rgb, variance, spp, replicate_variance: None })
}

fn read_png_image(path: &Path) -> Result<LinearImage> {
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(|e| Error::image(path, format!("cannot read PNG: {e}")))?;
    let size =
        reader.output_buffer_size().ok_or_else(|| Error::image(path, "PNG dimensions are too large"))?;
    let mut buf = vec![0u8; size];
    let info =
        reader.next_frame(&mut buf).map_err(|e| Error::image(path, format!("cannot read PNG: {e}")))?;
    let (width, height) = (info.width as usize, info.height as usize);
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => return Err(Error::image(path, "indexed PNG was not expanded")),
    };
    let wide = info.bit_depth == png::BitDepth::Sixteen;
    let max = if wide { 65535.0 } else { 255.0 };
    let sample = |i: usize| -> f32 {
        let v = if wide { u16::from_be_bytes([buf[2 * i], buf[2 * i + 1]]) as f32 } else { buf[i] as f32 };
        srgb_decode(v / max)
    };
    let rgb = (0..width * height)
        .map(|p| {
            let base = p * channels;
            if channels < 3 {
                [sample(base); 3]
            } else {
                [sample(base), sample(base + 1), sample(base + 2)]
            }
        })
        .collect();
    Ok(LinearImage { width, height, rgb, variance: None, spp: None, replicate_variance: None })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::linear_to_srgb;

    #[test]
    fn srgb_round_trips() {
        for i in 0..=255 {
            let v = i as f32 / 255.0;
            assert!((linear_to_srgb(srgb_decode(v)) - v).abs() < 1e-5, "{v}");
        }
    }
}
