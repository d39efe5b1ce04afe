//! 8-bit sRGB PNG output.

use std::path::Path;

use super::{linear_to_srgb, write_atomically, Film, Tonemap};
use crate::error::{Error, Result};

pub fn write_png(film: &Film, path: &Path, tonemap: Tonemap, exposure: f32) -> Result<()> {
    write_png_rgb(film.width, film.height, &film.mean(), path, tonemap, exposure)
}

/// A linear image (row-major from the top row) as a PNG.
pub fn write_png_rgb(
    width: u32,
    height: u32,
    linear: &[glam::Vec3],
    path: &Path,
    tonemap: Tonemap,
    exposure: f32,
) -> Result<()> {
    let mut rgb = Vec::with_capacity(linear.len() * 3);
    for &c in linear {
        let t = tonemap.apply(c, exposure);
        for v in [t.x, t.y, t.z] {
            rgb.push((linear_to_srgb(v) * 255.0 + 0.5) as u8);
        }
    }
    write_atomically(path, |tmp| {
        let file = std::fs::File::create(tmp).map_err(|e| Error::io(path, e))?;
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = encoder.write_header().map_err(|e| Error::output(path, e.to_string()))?;
        writer.write_image_data(&rgb).map_err(|e| Error::output(path, e.to_string()))?;
        writer.finish().map_err(|e| Error::output(path, e.to_string()))
    })
}
