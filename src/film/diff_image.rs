//! Pictures of a comparison: a heat map PNG and a z-score EXR, for looking at what failed.

use std::path::Path;

use super::compare::CompareReport;
use super::exr_io::write_rgb_exr;
use super::image::LinearImage;
use super::write_atomically;
use crate::error::{Error, Result};

/// Writes a heat map (magma colours): with a statistical test, |z| per pixel (largest over
/// channels) scaled so the per-pixel failure threshold is the brightest colour; without one,
/// |test − reference| (largest over channels) scaled by its maximum.
pub fn write_diff_png(
    report: &CompareReport,
    test: &LinearImage,
    reference: &LinearImage,
    path: &Path,
) -> Result<()> {
    let heat: Vec<f32> = match &report.stat {
        Some(s) => {
            let scale = s.pixels.threshold as f32;
            s.pixel_z.iter().map(|z| z.iter().fold(0.0f32, |m, v| m.max(v.abs())) / scale).collect()
        }
        None => {
            let d: Vec<f32> = test
                .rgb
                .iter()
                .zip(&reference.rgb)
                .map(|(t, r)| (0..3).fold(0.0f32, |m, c| m.max((t[c] - r[c]).abs())))
                .collect();
            let max = d.iter().cloned().fold(0.0f32, f32::max);
            d.iter().map(|v| if max > 0.0 { v / max } else { 0.0 }).collect()
        }
    };
    let lut = nv_flip::magma_lut().to_vec();
    let entries = lut.len() / 3;
    let rgb: Vec<u8> = heat
        .iter()
        .flat_map(|&h| {
            // NaN (never produced, but harmless) maps to the first entry.
            let k = ((h.clamp(0.0, 1.0) * (entries - 1) as f32).round() as usize).min(entries - 1);
            [lut[3 * k], lut[3 * k + 1], lut[3 * k + 2]]
        })
        .collect();
    write_atomically(path, |tmp| {
        let file = std::fs::File::create(tmp).map_err(|e| Error::io(path, e))?;
        let mut encoder =
            png::Encoder::new(std::io::BufWriter::new(file), report.width as u32, report.height as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(|e| Error::output(path, e.to_string()))?;
        writer.write_image_data(&rgb).map_err(|e| Error::output(path, e.to_string()))?;
        writer.finish().map_err(|e| Error::output(path, e.to_string()))
    })
}

/// Writes the signed per-pixel z-scores as an EXR with channels R, G, B. Needs a
/// statistical test (variance in at least one image).
pub fn write_zmap_exr(report: &CompareReport, path: &Path) -> Result<()> {
    let stat = report
        .stat
        .as_ref()
        .ok_or_else(|| Error::output(path, "a z-map needs per-pixel variance in at least one image"))?;
    let z: Vec<glam::Vec3> = stat.pixel_z.iter().map(|z| glam::Vec3::from(*z)).collect();
    write_rgb_exr(report.width, report.height, &z, path)
}
