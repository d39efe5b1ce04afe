//! The auxiliary images (AOVs) as images: what `--aov` writes beside the radiance and what
//! the denoiser reads (`crate::integrator::aov` renders them).
//!
//! EXR channels, named as tev, Blender's compositor and Nuke group them (a layer per prefix):
//! `albedo.R`, `albedo.G`, `albedo.B`; `normal.X`, `normal.Y`, `normal.Z` (world space);
//! `depth.Z` (distance from the camera, +∞ where the pixel sees no surface);
//! `emission.R`, `emission.G`, `emission.B` (what the surface seen emits towards the camera);
//! `coverage.Y` (the share of the pixel's AOV rays that hit a surface).

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
    /// Mean emitted radiance of the surface the albedo is read from (`PixelAov::emission`).
    pub emission: Vec<Vec3>,
    /// The share of the pixel's AOV rays that hit a surface (`PixelAov::hits` /
    /// `PixelAov::rays`): below 1 on a silhouette against the background.
    pub coverage: Vec<f32>,
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
            emission: pixels.iter().map(|p| Vec3::from(p.emission)).collect(),
            coverage: pixels
                .iter()
                .map(|p| if p.rays > 0 { p.hits as f32 / p.rays as f32 } else { 0.0 })
                .collect(),
        }
    }
}

/// Which AOVs an EXR gets (`--aov albedo,normal,depth`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AovSelection {
    pub albedo: bool,
    pub normal: bool,
    pub depth: bool,
    /// Emission and coverage (`emission.*`, `coverage.Y`): what the built-in denoiser reads
    /// beside the other three.
    pub emission: bool,
}

impl AovSelection {
    pub const ALL: AovSelection = AovSelection { albedo: true, normal: true, depth: true, emission: true };

    /// Parses a comma-separated list of `albedo`, `normal`, `depth`, `emission` (or `all`).
    pub fn parse(list: &str) -> Result<AovSelection> {
        let mut s = AovSelection::default();
        for name in list.split(',').map(str::trim) {
            match name {
                "albedo" => s.albedo = true,
                "normal" => s.normal = true,
                "depth" => s.depth = true,
                "emission" => s.emission = true,
                "all" => s = AovSelection::ALL,
                _ => {
                    return Err(Error::Settings(format!(
                        "--aov: unknown AOV '{name}'; there are: albedo, normal, depth, emission, all"
                    )))
                }
            }
        }
        Ok(s)
    }

    pub fn any(self) -> bool {
        self.albedo || self.normal || self.depth || self.emission
    }

    /// The union of two selections.
    pub fn with(self, other: AovSelection) -> AovSelection {
        AovSelection {
            albedo: self.albedo || other.albedo,
            normal: self.normal || other.normal,
            depth: self.depth || other.depth,
            emission: self.emission || other.emission,
        }
    }
}

/// The EXR channels of `aovs` that `selection` names, as (name, values).
pub fn aov_channels(aovs: &Aovs, selection: AovSelection) -> Vec<(String, Vec<f32>)> {
    let vec3s = |prefix: &str, names: [&str; 3], plane: &[Vec3]| {
        names
            .iter()
            .enumerate()
            .map(|(c, n)| (format!("{prefix}.{n}"), plane.iter().map(|v| v[c]).collect()))
            .collect::<Vec<_>>()
    };
    let mut out = Vec::new();
    if selection.albedo {
        out.extend(vec3s("albedo", ["R", "G", "B"], &aovs.albedo));
    }
    if selection.normal {
        out.extend(vec3s("normal", ["X", "Y", "Z"], &aovs.normal));
    }
    if selection.depth {
        out.push(("depth.Z".to_string(), aovs.depth.clone()));
    }
    if selection.emission {
        out.extend(vec3s("emission", ["R", "G", "B"], &aovs.emission));
        out.push(("coverage.Y".to_string(), aovs.coverage.clone()));
    }
    out
}

/// The AOVs an EXR read back holds (channels as [`aov_channels`] writes them); an error
/// naming `path` and the first channel missing or of the wrong size. Without `depth.Z` and
/// `need_depth` false, depth is +∞ (no surface) everywhere. Emission and coverage are
/// optional: without them, no emission and full coverage (or none where depth says so).
pub fn aovs_from_channels(
    path: &std::path::Path,
    width: usize,
    height: usize,
    channels: &std::collections::HashMap<String, Vec<f32>>,
    need_depth: bool,
) -> Result<Aovs> {
    let n = width * height;
    let plane = |name: &str| -> Result<&Vec<f32>> {
        let data = channels.get(name).ok_or_else(|| {
            Error::image(path, format!("has no {name} channel: render it with --aov all (or --denoise)"))
        })?;
        if data.len() != n {
            return Err(Error::image(
                path,
                format!("its {name} channel has {} values for {n} pixels", data.len()),
            ));
        }
        Ok(data)
    };
    let vec3s = |names: [&str; 3]| -> Result<Vec<Vec3>> {
        let [a, b, c] = [plane(names[0])?, plane(names[1])?, plane(names[2])?];
        Ok((0..n).map(|i| Vec3::new(a[i], b[i], c[i])).collect())
    };
    let albedo = vec3s(["albedo.R", "albedo.G", "albedo.B"])?;
    let normal = vec3s(["normal.X", "normal.Y", "normal.Z"])?;
    let depth = if need_depth || channels.contains_key("depth.Z") {
        plane("depth.Z")?.clone()
    } else {
        vec![f32::INFINITY; n]
    };
    let emission = if channels.contains_key("emission.R") {
        vec3s(["emission.R", "emission.G", "emission.B"])?
    } else {
        vec![Vec3::ZERO; n]
    };
    let coverage = if channels.contains_key("coverage.Y") {
        plane("coverage.Y")?.clone()
    } else {
        depth.iter().map(|z| if z.is_finite() { 1.0 } else { 0.0 }).collect()
    };
    Ok(Aovs { width: width as u32, height: height as u32, albedo, normal, depth, emission, coverage })
}
