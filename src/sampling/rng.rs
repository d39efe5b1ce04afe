//! The per-sample random number generator: xoshiro128** seeded by the pcg4d hash.
//!
//! Both are pure 32-bit integer arithmetic, so the WGSL twin produces the same stream: a
//! sample with the same pixel, index and seed draws the same numbers on both backends.

use glam::{UVec4, Vec2};

/// pcg4d: a 4-D → 4-D integer hash (Jarzynski & Olano 2020, "Hash Functions for GPU
/// Rendering", JCGT 9(3)), used to seed one independent stream per (pixel, sample, seed).
pub fn pcg4d(v: UVec4) -> UVec4 {
    let mut v = v * 1_664_525u32 + UVec4::splat(1_013_904_223);
    v.x = v.x.wrapping_add(v.y.wrapping_mul(v.w));
    v.y = v.y.wrapping_add(v.z.wrapping_mul(v.x));
    v.z = v.z.wrapping_add(v.x.wrapping_mul(v.y));
    v.w = v.w.wrapping_add(v.y.wrapping_mul(v.z));
    v ^= v >> 16;
    v.x = v.x.wrapping_add(v.y.wrapping_mul(v.w));
    v.y = v.y.wrapping_add(v.z.wrapping_mul(v.x));
    v.z = v.z.wrapping_add(v.x.wrapping_mul(v.y));
    v.w = v.w.wrapping_add(v.y.wrapping_mul(v.z));
    v
}

/// xoshiro128** (Blackman & Vigna 2021, "Scrambled Linear Pseudorandom Number
/// Generators", ACM TOMS 47(4)): 128 bits of state, period 2¹²⁸ − 1.
#[derive(Clone, Debug)]
pub struct Rng {
    s: [u32; 4],
}

impl Rng {
    /// The stream for sample `sample_index` of pixel `(x, y)` under `seed`.
    pub fn new(x: u32, y: u32, sample_index: u32, seed: u32) -> Rng {
        let h = pcg4d(UVec4::new(x, y, sample_index, seed));
        let mut s = [h.x, h.y, h.z, h.w];
        // xoshiro's only invalid state is all zeros.
        if s == [0; 4] {
            s[0] = 1;
        }
        Rng { s }
    }

    pub fn next_u32(&mut self) -> u32 {
        let s = &mut self.s;
        let result = s[1].wrapping_mul(5).rotate_left(7).wrapping_mul(9);
        let t = s[1] << 9;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(11);
        result
    }

    /// Uniform in [0, 1): the top 24 bits, so every value is exactly representable.
    pub fn next_1d(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        let y = self.next_1d();
        Vec2::new(x, y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_differ_and_are_uniform() {
        // Mean and variance of U[0,1) are 1/2 and 1/12; with n = 1e6 the standard error of
        // the mean is sqrt(1/12/n) ≈ 2.9e-4, so 5σ ≈ 1.5e-3.
        let mut rng = Rng::new(3, 4, 5, 6);
        let n = 1_000_000;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let u = rng.next_1d() as f64;
            assert!((0.0..1.0).contains(&u));
            sum += u;
            sum2 += u * u;
        }
        let mean = sum / n as f64;
        let var = sum2 / n as f64 - mean * mean;
        assert!((mean - 0.5).abs() < 1.5e-3, "mean {mean}");
        assert!((var - 1.0 / 12.0).abs() < 1e-3, "variance {var}");
        let a = Rng::new(0, 0, 0, 0).next_u32();
        let b = Rng::new(0, 0, 1, 0).next_u32();
        let c = Rng::new(1, 0, 0, 0).next_u32();
        assert!(a != b && b != c && a != c);
    }
}
