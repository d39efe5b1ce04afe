//! The environment light: an equirectangular radiance map at infinity (or a constant
//! background), importance-sampled by a piecewise-constant 2D distribution (pbrt-v4
//! `ImageInfiniteLight` and `PiecewiseConstant2D`, §12.5.2 and §A.5) and combined with BSDF
//! sampling by MIS like any area light.
//!
//! Convention (the one Mitsuba 3's `envmap` uses, so one file means the same in both): +Y is
//! up; a direction d in the map's frame looks up u = atan2(d.x, −d.z) / 2π wrapped to [0, 1)
//! and v = acos(d.y) / π, with row 0 at the top (v = 0 is straight up). The map is turned
//! about +Y by `rotation` (right-handed): a world direction d looks up R_y(−rotation)·d.
//!
//! The sampling density over (u, v) is proportional to luminance × sin θ per texel, so
//! directions near the poles (whose texels cover little solid angle) are not oversampled;
//! the density per solid angle is p(u, v) / (2π² sin θ).
//!
//! WGSL twin: `shaders/environment.wgsl` (same function names).

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use crate::error::{Error, Result};
use crate::scene::layout::{Environment, INVALID_INDEX};

/// Rows of the map that stands for a constant background: enough for the sin θ weighting to
/// make sampling nearly uniform over the sphere.
const CONSTANT_ROWS: u32 = 32;
/// The largest map accepted, texels per side (a 16k × 8k map is 1.5 GiB as f32 RGB).
const MAX_SIDE: u32 = 16384;

/// The environment a render uses, before flattening.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentDesc {
    pub width: u32,
    pub height: u32,
    /// Linear radiance, row-major, row 0 at the top.
    pub texels: Vec<Vec3>,
    /// Scale applied to every texel.
    pub intensity: f32,
    /// Rotation about +Y, in degrees.
    pub rotation_degrees: f32,
    /// The file it came from; `None` for a constant background.
    pub source: Option<PathBuf>,
}

impl EnvironmentDesc {
    /// A constant background of radiance `rgb` from every direction.
    pub fn constant(rgb: Vec3) -> EnvironmentDesc {
        EnvironmentDesc {
            width: 1,
            height: CONSTANT_ROWS,
            texels: vec![rgb; CONSTANT_ROWS as usize],
            intensity: 1.0,
            rotation_degrees: 0.0,
            source: None,
        }
    }

    /// Reads an equirectangular map: Radiance `.hdr` or OpenEXR (`R`, `G`, `B`). Negative or
    /// non-finite texels, and maps of absurd size, are errors naming the file.
    pub fn load(path: &Path) -> Result<EnvironmentDesc> {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        let (width, height, texels) = match ext.as_deref() {
            Some("hdr") => {
                // The reader's default limits (512 MiB) bound what a hostile header can allocate.
                let reader = image::ImageReader::open(path)
                    .map_err(|e| Error::io(path, e))?
                    .with_guessed_format()
                    .map_err(|e| Error::io(path, e))?;
                let img = reader.decode().map_err(|e| Error::image(path, format!("cannot read HDR: {e}")))?;
                let rgb = img.to_rgb32f();
                let texels: Vec<Vec3> = rgb.pixels().map(|p| Vec3::from(p.0)).collect();
                (rgb.width(), rgb.height(), texels)
            }
            Some("exr") => {
                let exr = crate::film::read_exr(path)?;
                let plane = |c: &str| {
                    exr.channels
                        .get(c)
                        .ok_or_else(|| Error::image(path, format!("the environment map has no {c} channel")))
                };
                let (r, g, b) = (plane("R")?, plane("G")?, plane("B")?);
                let texels = (0..exr.width * exr.height).map(|i| Vec3::new(r[i], g[i], b[i])).collect();
                (exr.width as u32, exr.height as u32, texels)
            }
            _ => return Err(Error::image(path, "an environment map must be a .hdr or .exr file")),
        };
        if width == 0 || height == 0 || width > MAX_SIDE || height > MAX_SIDE {
            return Err(Error::image(path, format!("{width}×{height} is not a usable environment map size")));
        }
        if let Some(i) = texels.iter().position(|t: &Vec3| !t.is_finite() || t.min_element() < 0.0) {
            return Err(Error::image(
                path,
                format!("texel at x {}, y {} is negative or not finite", i as u32 % width, i as u32 / width),
            ));
        }
        Ok(EnvironmentDesc {
            width,
            height,
            texels,
            intensity: 1.0,
            rotation_degrees: 0.0,
            source: Some(path.into()),
        })
    }
}

/// The environment as both backends read it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FlatEnvironment {
    pub params: Environment,
    /// Per texel: radiance × intensity (rgb) and the sampling density over (u, v) (w).
    pub texels: Vec<[f32; 4]>,
    /// The marginal CDF over rows (`height + 1` values), then each row's conditional CDF
    /// over columns (`width + 1` values each); all normalised to end at 1.
    pub cdf: Vec<f32>,
    /// Emitted power for the light table: π r² ∫ L dω (luminance), r the scene's radius.
    pub power: f64,
}

impl FlatEnvironment {
    /// Builds texels and sampling distribution; `light_index` is filled in by the caller.
    pub fn build(desc: &EnvironmentDesc, scene_radius: f32) -> FlatEnvironment {
        let (w, h) = (desc.width as usize, desc.height as usize);
        let angle = desc.rotation_degrees.to_radians();
        let luminance = |c: Vec3| 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
        // Sampling weight per texel (f64: sums over millions of texels).
        let sin_theta = |j: usize| (std::f64::consts::PI * (j as f64 + 0.5) / h as f64).sin();
        let radiance: Vec<Vec3> = desc.texels.iter().map(|t| *t * desc.intensity).collect();
        let weight = |i: usize, j: usize| luminance(radiance[j * w + i]).max(0.0) as f64 * sin_theta(j);
        let row_sums: Vec<f64> = (0..h).map(|j| (0..w).map(|i| weight(i, j)).sum()).collect();
        let total: f64 = row_sums.iter().sum();
        // ∫ over (u, v) ∈ [0,1]² of the weight function, whose density is weight / integral.
        let integral = total / (w * h) as f64;
        let mut cdf = Vec::with_capacity(h + 1 + h * (w + 1));
        let mut running = 0.0f64;
        cdf.push(0.0);
        for s in &row_sums {
            running += s;
            cdf.push(if total > 0.0 { (running / total) as f32 } else { 0.0 });
        }
        for (j, s) in row_sums.iter().enumerate() {
            let mut running = 0.0f64;
            cdf.push(0.0);
            for i in 0..w {
                running += weight(i, j);
                cdf.push(if *s > 0.0 { (running / s) as f32 } else { (i + 1) as f32 / w as f32 });
            }
        }
        if total > 0.0 {
            // Exactly 1 at the ends, whatever the rounding.
            cdf[h] = 1.0;
        }
        let texels = (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .map(|(i, j)| {
                let pdf_uv = if integral > 0.0 { weight(i, j) / integral } else { 0.0 };
                let c = radiance[j * w + i];
                [c.x, c.y, c.z, pdf_uv as f32]
            })
            .collect();
        // π r² Σ L ΔΩ with ΔΩ = (2π / w)(π / h) sin θ: the power through the scene's disk.
        let solid_angle_sum =
            total * (2.0 * std::f64::consts::PI / w as f64) * (std::f64::consts::PI / h as f64);
        let power = std::f64::consts::PI * (scene_radius as f64).powi(2) * solid_angle_sum;
        FlatEnvironment {
            params: Environment {
                width: w as u32,
                height: h as u32,
                rotation_cos: angle.cos(),
                rotation_sin: angle.sin(),
                light_index: INVALID_INDEX,
                present: 1,
                _pad0: 0,
                _pad1: 0,
            },
            texels,
            cdf,
            power,
        }
    }
}

/// The map's frame from the world's: R_y(−rotation).
fn world_to_map(env: &Environment, d: Vec3) -> Vec3 {
    let (c, s) = (env.rotation_cos, env.rotation_sin);
    Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z)
}

/// The world's frame from the map's: R_y(rotation).
fn map_to_world(env: &Environment, d: Vec3) -> Vec3 {
    let (c, s) = (env.rotation_cos, env.rotation_sin);
    Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z)
}

/// atan2(y, x) in (−π, π] by the polynomial of Abramowitz & Stegun 4.4.49 (|ε| ≤ 1e-5 rad
/// on [0, 1], extended by symmetry). The environment lookup uses it rather than the
/// platform's atan2/acos because WGSL allows those thousands of ulps of error: with the same
/// few multiply-adds on both backends, both pick the same texel for the same direction.
pub fn atan2_polynomial(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let hi = ax.max(ay);
    if hi == 0.0 {
        return 0.0;
    }
    let a = ax.min(ay) / hi;
    let s = a * a;
    let mut r = ((((0.020_835_1 * s - 0.085_133) * s + 0.180_141) * s - 0.330_299_5) * s + 0.999_866) * a;
    if ay > ax {
        r = std::f32::consts::FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = std::f32::consts::PI - r;
    }
    if y < 0.0 {
        -r
    } else {
        r
    }
}

/// (u, v) ∈ [0, 1)² × [0, 1] of a unit direction in the map's frame.
pub fn environment_uv(d: Vec3) -> Vec2 {
    let mut u = atan2_polynomial(d.x, -d.z) * (0.5 * std::f32::consts::FRAC_1_PI);
    if u < 0.0 {
        u += 1.0;
    }
    // Rounding can give exactly 1 after the wrap; keep u in [0, 1).
    let u = if u >= 1.0 { 0.0 } else { u };
    // θ = acos(y), as atan2(sin θ, cos θ): accurate at the poles too.
    let sin_theta = (d.x * d.x + d.z * d.z).sqrt();
    Vec2::new(u, atan2_polynomial(sin_theta, d.y) * std::f32::consts::FRAC_1_PI)
}

/// The unit direction (map frame) of (u, v).
pub fn environment_direction(uv: Vec2) -> Vec3 {
    let phi = 2.0 * std::f32::consts::PI * uv.x;
    let theta = std::f32::consts::PI * uv.y;
    let sin_theta = theta.sin();
    Vec3::new(sin_theta * phi.sin(), theta.cos(), -sin_theta * phi.cos())
}

/// The texel under (u, v).
fn texel_index(env: &Environment, uv: Vec2) -> usize {
    let i = ((uv.x * env.width as f32) as u32).min(env.width - 1);
    let j = ((uv.y * env.height as f32) as u32).min(env.height - 1);
    (j * env.width + i) as usize
}

/// Radiance arriving from world direction `d` (unit) and the density per solid angle with
/// which [`sample_environment`] picks it.
pub fn environment_lookup(env: &Environment, texels: &[[f32; 4]], d: Vec3) -> (Vec3, f32) {
    let local = world_to_map(env, d);
    let uv = environment_uv(local);
    let t = texels[texel_index(env, uv)];
    // √(x² + z²), not √(1 − y²), which cancels catastrophically near the poles.
    let sin_theta = (local.x * local.x + local.z * local.z).sqrt();
    let pdf = if sin_theta > 0.0 {
        t[3] / (2.0 * std::f32::consts::PI * std::f32::consts::PI * sin_theta)
    } else {
        0.0
    };
    (Vec3::new(t[0], t[1], t[2]), pdf)
}

/// The largest index `i` in `[0, n)` with `cdf[i] <= u`, over a CDF of `n + 1` values starting
/// at `offset` (pbrt-v4 `FindInterval`, as a plain binary search both backends run alike).
pub fn find_interval(cdf: &[f32], offset: usize, n: usize, u: f32) -> usize {
    let (mut lo, mut hi) = (0usize, n);
    // Invariant: cdf[offset + lo] <= u (cdf starts at 0), and the answer is below hi.
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if cdf[offset + mid] <= u {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Samples a direction by the map's distribution: `(world direction, radiance, density per
/// solid angle)`, or `None` where the density vanishes (the poles).
pub fn sample_environment(
    env: &Environment,
    texels: &[[f32; 4]],
    cdf: &[f32],
    u: Vec2,
) -> Option<(Vec3, Vec3, f32)> {
    let (w, h) = (env.width as usize, env.height as usize);
    let j = find_interval(cdf, 0, h, u.y);
    let dv = (u.y - cdf[j]) / (cdf[j + 1] - cdf[j]).max(f32::MIN_POSITIVE);
    let row = h + 1 + j * (w + 1);
    let i = find_interval(cdf, row, w, u.x);
    let du = (u.x - cdf[row + i]) / (cdf[row + i + 1] - cdf[row + i]).max(f32::MIN_POSITIVE);
    let uv =
        Vec2::new((i as f32 + du.clamp(0.0, 1.0)) / w as f32, (j as f32 + dv.clamp(0.0, 1.0)) / h as f32);
    let local = environment_direction(uv);
    let t = texels[j * w + i];
    // sin θ of the direction itself, exactly as `environment_lookup` computes it, so MIS sees
    // the same density from both techniques.
    let sin_theta = (local.x * local.x + local.z * local.z).sqrt();
    if sin_theta <= 0.0 || t[3] <= 0.0 {
        return None;
    }
    let pdf = t[3] / (2.0 * std::f32::consts::PI * std::f32::consts::PI * sin_theta);
    Some((map_to_world(env, local), Vec3::new(t[0], t[1], t[2]), pdf))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_convention_is_mitsubas() {
        // −Z is the map's horizontal centre-left seam start (u = 0), +X a quarter turn on.
        // Tolerance: the atan2 polynomial's 1e-5 rad is 2e-6 in u and 3e-6 in v.
        let uv = |d: Vec3| environment_uv(d);
        assert!((uv(Vec3::new(0.0, 0.0, -1.0)) - Vec2::new(0.0, 0.5)).length() < 1e-5);
        assert!((uv(Vec3::new(1.0, 0.0, 0.0)) - Vec2::new(0.25, 0.5)).length() < 1e-5);
        assert!((uv(Vec3::new(0.0, 0.0, 1.0)) - Vec2::new(0.5, 0.5)).length() < 1e-5);
        assert!((uv(Vec3::new(-1.0, 0.0, 0.0)) - Vec2::new(0.75, 0.5)).length() < 1e-5);
        assert!(uv(Vec3::Y).y.abs() < 1e-5, "row 0 is straight up");
        assert!((uv(-Vec3::Y).y - 1.0).abs() < 1e-5);
        for k in 0..100 {
            let uv0 = Vec2::new((k as f32 * 0.37).fract(), 0.01 + 0.98 * (k as f32 * 0.61).fract());
            let d = environment_direction(uv0);
            assert!((environment_uv(d) - uv0).length() < 1e-4, "{uv0}");
        }
    }

    #[test]
    fn atan2_polynomial_is_within_its_bound() {
        for k in 0..=2000 {
            let angle = -std::f32::consts::PI + k as f32 * std::f32::consts::TAU / 2000.0;
            for r in [1e-3f32, 1.0, 1e3] {
                let (y, x) = (r * angle.sin(), r * angle.cos());
                let err = (atan2_polynomial(y, x) - y.atan2(x)).abs();
                // A&S 4.4.49's 1e-5, plus f32 rounding of the range reduction; ±π wraps.
                assert!(err < 1.2e-5 || (err - std::f32::consts::TAU).abs() < 1.2e-5, "{angle}: {err}");
            }
        }
    }

    #[test]
    fn rotation_turns_the_map_about_up() {
        let desc = EnvironmentDesc { rotation_degrees: 90.0, ..EnvironmentDesc::constant(Vec3::ONE) };
        let env = FlatEnvironment::build(&desc, 1.0).params;
        // Turned by +90° about +Y, what was at −Z (u = 0) is now at −X.
        let d = map_to_world(&env, Vec3::new(0.0, 0.0, -1.0));
        assert!((d - Vec3::new(-1.0, 0.0, 0.0)).length() < 1e-6, "{d}");
        assert!((world_to_map(&env, d) - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
    }

    #[test]
    fn find_interval_skips_empty_cells() {
        let cdf = [0.0, 0.5, 0.5, 0.5, 1.0];
        assert_eq!(find_interval(&cdf, 0, 4, 0.0), 0);
        assert_eq!(find_interval(&cdf, 0, 4, 0.49), 0);
        assert_eq!(find_interval(&cdf, 0, 4, 0.5), 3);
        assert_eq!(find_interval(&cdf, 0, 4, 0.99), 3);
    }
}
