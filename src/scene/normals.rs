//! Octahedral unit-vector encoding into two snorm16 values (Cigolle, Donow, Evangelakos,
//! Mara, McGuire & Meyer 2014, "A Survey of Efficient Representations for Independent Unit
//! Vectors", JCGT 3(2)). Worst-case angular error is about 3e-5 rad.
//!
//! WGSL twin: `oct_decode` in `shaders/geometry.wgsl`, which uses `unpack2x16snorm`.

use glam::{Vec2, Vec3};

fn sign_not_zero(v: Vec2) -> Vec2 {
    Vec2::new(if v.x >= 0.0 { 1.0 } else { -1.0 }, if v.y >= 0.0 { 1.0 } else { -1.0 })
}

/// Packs the unit vector `n`: x in the low 16 bits, as WGSL's `pack2x16snorm`.
pub fn oct_encode(n: Vec3) -> u32 {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    let mut p = Vec2::new(n.x, n.y) / l1;
    if n.z < 0.0 {
        p = (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * sign_not_zero(p);
    }
    let q = |v: f32| ((v.clamp(-1.0, 1.0) * 32767.0).round() as i16) as u16 as u32;
    q(p.x) | (q(p.y) << 16)
}

/// Unpacks to a unit vector, exactly as the WGSL `oct_decode` does.
pub fn oct_decode(packed: u32) -> Vec3 {
    let un = |bits: u32| ((bits as u16 as i16) as f32 / 32767.0).clamp(-1.0, 1.0);
    let p = Vec2::new(un(packed & 0xffff), un(packed >> 16));
    let mut n = Vec3::new(p.x, p.y, 1.0 - p.x.abs() - p.y.abs());
    let t = (-n.z).max(0.0);
    n.x += if n.x >= 0.0 { -t } else { t };
    n.y += if n.y >= 0.0 { -t } else { t };
    n.normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{sample_uniform_sphere, Rng};

    #[test]
    fn round_trip_error_is_small() {
        let mut rng = Rng::new(9, 9, 9, 9);
        let mut worst = 0.0f32;
        let mut dirs: Vec<Vec3> = (0..200_000).map(|_| sample_uniform_sphere(rng.next_2d())).collect();
        dirs.extend([Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z]);
        for n in dirs {
            let d = oct_decode(oct_encode(n)).as_dvec3();
            let n = n.as_dvec3().normalize();
            // atan2(|a×b|, a·b) in f64: acos of an f32 dot product cannot resolve angles
            // below ~3e-4 rad.
            worst = worst.max(d.cross(n).length().atan2(d.dot(n)) as f32);
        }
        // 16-bit octahedral encoding: the quantisation step is 2/65535 in the square, which
        // maps to at most ~4.3e-5 rad on the sphere (Cigolle et al. 2014, Table 1: "oct16"),
        // plus f32 rounding of the normalisation.
        assert!(worst < 1e-4, "worst angular error {worst}");
    }
}
