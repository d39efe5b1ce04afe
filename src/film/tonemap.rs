//! Display transforms for PNG output.

use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Tonemap {
    /// Scale by 2^exposure and clamp to [0, 1].
    #[default]
    Clamp,
    /// Narkowicz's fit of the ACES filmic curve (Narkowicz 2015, "ACES Filmic Tone Mapping
    /// Curve").
    Aces,
}

impl Tonemap {
    pub fn apply(self, c: Vec3, exposure: f32) -> Vec3 {
        let c = c * 2f32.powf(exposure);
        match self {
            Tonemap::Clamp => c.clamp(Vec3::ZERO, Vec3::ONE),
            Tonemap::Aces => {
                let (a, b, cc, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
                ((c * (a * c + b)) / (c * (cc * c + d) + e)).clamp(Vec3::ZERO, Vec3::ONE)
            }
        }
    }
}

/// The sRGB transfer function (IEC 61966-2-1).
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}
