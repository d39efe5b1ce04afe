//! Intel Open Image Denoise (the `oidn` feature): its `RT` filter, a neural network trained
//! on path-traced images, guided by the albedo and normal AOVs (Open Image Denoise's
//! documentation, "RT"). It reads the colour as HDR and ignores the variance; the AOVs are
//! passed as they are (not "clean": through glass their lobe choice is random, so they carry
//! a little noise, which the filter is trained to expect).

use glam::Vec3;

use super::DenoiseInput;
use crate::error::{Error, Result};

/// Denoises `input` on Open Image Denoise's default device (a CUDA, HIP or SYCL GPU where
/// its module for one loads, else the CPU).
pub fn denoise(input: &DenoiseInput) -> Result<Vec<Vec3>> {
    let fail = |what: &str, e: oidn::Error| Error::Settings(format!("Open Image Denoise: {what}: {e}"));
    let device = oidn::Device::new().map_err(|e| fail("no device", e))?;
    let flat = |plane: &[Vec3]| -> Vec<f32> { plane.iter().flat_map(|v| v.to_array()).collect() };
    // Albedo is read in [0, 1] and normals in [-1, 1]; the AOVs are, but a clamp keeps a
    // stray value from being rejected.
    let albedo: Vec<f32> = flat(&input.aovs.albedo).into_iter().map(|v| v.clamp(0.0, 1.0)).collect();
    let normal: Vec<f32> = flat(&input.aovs.normal).into_iter().map(|v| v.clamp(-1.0, 1.0)).collect();
    let color = flat(input.color);
    let albedo = device.create_buffer(&albedo).map_err(|e| fail("albedo buffer", e))?;
    let normal = device.create_buffer(&normal).map_err(|e| fail("normal buffer", e))?;
    let mut output = vec![0.0f32; color.len()];
    let mut filter = oidn::RayTracing::try_new(&device).map_err(|e| fail("RT filter", e))?;
    filter
        .albedo_normal_buffer(albedo, normal)
        .map_err(|e| fail("guides", e))?
        .hdr(true)
        .image_dimensions(input.width as usize, input.height as usize);
    filter.filter(&color, &mut output).map_err(|e| fail("filtering", e))?;
    device.get_error().map_err(|e| fail("filtering", e))?;
    Ok(output.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
}
