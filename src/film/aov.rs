//! The auxiliary images (AOVs) as images: what `--aov` writes beside the radiance and what
//! the denoiser reads (`crate::integrator::aov` renders them).
//!
//! EXR channels, named as tev, Blender's compositor and Nuke group them (a layer per prefix):
//! `albedo.R`, `albedo.G`, `albedo.B`; `normal.X`, `normal.Y`, `normal.Z` (world space);
//! `depth.Z` (distance from the camera, +∞ where the pixel sees no surface).

use glam::Vec3;

use crate::error::{Error, Result};
use crate::scene::layout::PixelAov;

/// A render's AOVs, row-major from the top row.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Aovs {
    pub width: u32,
    pub height: u32,
    /// Mean albedo of the first non-delta surface (`PixelAov::albedo`).
    pub albedo: Vec<Vec3>,
    /// Mean world-space shading normal, not renormalised (`PixelAov::normal`).
    pub normal: Vec<Vec3>,
    /// Mean distance to the first surface; +∞ where no AOV ray hit one.
    pub depth: Vec<f32>,
}

impl Aovs {
    /// The images of the AOV pass's `pixels`.
    pub fn from_pixels(width: u32, height: u32, pixels: &[PixelAov]) -> Aovs {
        Aovs {
            width,
            height,
            albedo: pixels.iter().map(|p| Vec3::from(p.albedo)).collect(),
            normal: pixels.iter().map(|p| Vec3::from(p.normal)).collect(),
            depth: pixels.iter().map(|p| if p.hits > 0 { p.depth } else { f32::INFINITY }).collect(),
        }
    }
}

/// Which AOVs an EXR gets (`--aov albedo,normal,depth`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AovSelection {
    pub albedo: bool,
    pub normal: bool,
    pub depth: bool,
}

impl AovSelection {
    pub const ALL: AovSelection = AovSelection { albedo: true, normal: true, depth: true };

    /// Parses a comma-separated list of `albedo`, `normal`, `depth` (or `all`).
    pub fn parse(list: &str) -> Result<AovSelection> {
        let mut s = AovSelection::default();
        for name in list.split(',').map(str::trim) {
            match name {
                "albedo" => s.albedo = true,
                "normal" => s.normal = true,
                "depth" => s.depth = true,
                "all" => s = AovSelection::ALL,
                _ => {
                    return Err(Error::Settings(format!(
                        "--aov: unknown AOV '{name}'; there are: albedo, normal, depth, all"
                    )))
                }
            }
        }
        Ok(s)
    }

    pub fn any(self) -> bool {
        self.albedo || self.normal || self.depth
    }

    /// The union of two selections.
    pub fn with(self, other: AovSelection) -> AovSelection {
        AovSelection {
            albedo: self.albedo || other.albedo,
            normal: self.normal || other.normal,
            depth: self.depth || other.depth,
        }
    }
}

/// The EXR channels of `aovs` that `selection` names, as (name, values).
pub fn aov_channels(aovs: &Aovs, selection: AovSelection) -> Vec<(String, Vec<f32>)> {
    let mut out = Vec::new();
    let mut put = |prefix: &str, names: [&str; 3], plane: &[Vec3]| {
        for (c, n) in names.iter().enumerate() {
            out.push((format!("{prefix}.{n}"), plane.iter().map(|v| v[c]).collect()));
        }
    };
    if selection.albedo {
        put("albedo", ["R", "G", "B"], &aovs.albedo);
    }
    if selection.normal {
        put("normal", ["X", "Y", "Z"], &aovs.normal);
    }
    if selection.depth {
        out.push(("depth.Z".to_string(), aovs.depth.clone()));
    }
    out
}

/// The AOVs an EXR read back holds (channels as [`aov_channels`] writes them); an error
/// naming `path` and the first channel missing.
pub fn aovs_from_channels(
    path: &std::path::Path,
    width: usize,
    height: usize,
    channels: &std::collections::HashMap<String, Vec<f32>>,
) -> Result<Aovs> {
    let plane = |name: &str| -> Result<&Vec<f32>> {
        channels.get(name).ok_or_else(|| {
            Error::image(
                path,
                format!("has no {name} channel: render it with --aov albedo,normal,depth (or --denoise)"),
            )
        })
    };
    let vec3s = |names: [&str; 3]| -> Result<Vec<Vec3>> {
        let [a, b, c] = [plane(names[0])?, plane(names[1])?, plane(names[2])?];
        Ok((0..width * height).map(|i| Vec3::new(a[i], b[i], c[i])).collect())
    };
    Ok(Aovs {
        width: width as u32,
        height: height as u32,
        albedo: vec3s(["albedo.R", "albedo.G", "albedo.B"])?,
        normal: vec3s(["normal.X", "normal.Y", "normal.Z"])?,
        depth: plane("depth.Z")?.clone(),
    })
}
