//! Eight f32 lanes: one per child of a [`super::wide::WideNode`].
//!
//! With AVX (pathlight builds for x86-64-v3 by default, `.cargo/config.toml`) a lane set is
//! one 256-bit register and each operation one instruction; elsewhere it is two of glam's
//! 4-wide vectors. Both give the same bits: each operation is the same IEEE operation per
//! lane (min and max return the second operand when either is NaN, as SSE's and AVX's do,
//! and comparisons are ordered, false on NaN); a test checks the two against each other.

/// Lanes per set.
pub const LANES: usize = 8;

/// The portable implementation: two 4-wide vectors.
#[allow(dead_code, reason = "the reference the AVX lanes are tested against where AVX is built")]
pub mod portable {
    use glam::{BVec4A, Vec4};

    #[derive(Clone, Copy, Debug)]
    #[repr(C, align(32))]
    pub struct Lanes([Vec4; 2]);

    /// A per-lane boolean mask.
    #[derive(Clone, Copy, Debug)]
    pub struct Mask([BVec4A; 2]);

    impl Lanes {
        #[inline(always)]
        pub fn splat(v: f32) -> Lanes {
            Lanes([Vec4::splat(v); 2])
        }
        #[inline(always)]
        pub fn from_array(a: [f32; 8]) -> Lanes {
            Lanes([Vec4::new(a[0], a[1], a[2], a[3]), Vec4::new(a[4], a[5], a[6], a[7])])
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 8] {
            let (a, b) = (self.0[0].to_array(), self.0[1].to_array());
            [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]]
        }
        #[inline(always)]
        pub fn sub(self, o: Lanes) -> Lanes {
            Lanes([self.0[0] - o.0[0], self.0[1] - o.0[1]])
        }
        #[inline(always)]
        pub fn mul(self, o: Lanes) -> Lanes {
            Lanes([self.0[0] * o.0[0], self.0[1] * o.0[1]])
        }
        #[inline(always)]
        pub fn min(self, o: Lanes) -> Lanes {
            Lanes([self.0[0].min(o.0[0]), self.0[1].min(o.0[1])])
        }
        #[inline(always)]
        pub fn max(self, o: Lanes) -> Lanes {
            Lanes([self.0[0].max(o.0[0]), self.0[1].max(o.0[1])])
        }
        #[inline(always)]
        pub fn cmple(self, o: Lanes) -> Mask {
            Mask([self.0[0].cmple(o.0[0]), self.0[1].cmple(o.0[1])])
        }
        #[inline(always)]
        pub fn cmpge(self, o: Lanes) -> Mask {
            Mask([self.0[0].cmpge(o.0[0]), self.0[1].cmpge(o.0[1])])
        }
        /// `a` where the mask is set, else `b`.
        #[inline(always)]
        pub fn select(mask: Mask, a: Lanes, b: Lanes) -> Lanes {
            Lanes([Vec4::select(mask.0[0], a.0[0], b.0[0]), Vec4::select(mask.0[1], a.0[1], b.0[1])])
        }
    }

    impl Mask {
        #[inline(always)]
        pub fn and(self, o: Mask) -> Mask {
            Mask([self.0[0] & o.0[0], self.0[1] & o.0[1]])
        }
        /// Bit i set where lane i is.
        #[inline(always)]
        pub fn bitmask(self) -> u32 {
            self.0[0].bitmask() | (self.0[1].bitmask() << 4)
        }
    }
}

/// The AVX implementation: one 256-bit register.
#[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
pub mod avx {
    use core::arch::x86_64::*;

    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct Lanes(__m256);

    /// A per-lane boolean mask (all ones or all zeros per lane).
    #[derive(Clone, Copy, Debug)]
    #[repr(transparent)]
    pub struct Mask(__m256);

    // SAFETY (every `unsafe` below): the intrinsics take no pointers, and the cfg on this
    // module builds it only where AVX is enabled for the whole program, so the CPU has it.
    impl Lanes {
        #[inline(always)]
        pub fn splat(v: f32) -> Lanes {
            unsafe { Lanes(_mm256_set1_ps(v)) }
        }
        #[inline(always)]
        pub fn from_array(a: [f32; 8]) -> Lanes {
            unsafe { Lanes(_mm256_setr_ps(a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7])) }
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 8] {
            bytemuck::cast(self.0)
        }
        #[inline(always)]
        pub fn sub(self, o: Lanes) -> Lanes {
            unsafe { Lanes(_mm256_sub_ps(self.0, o.0)) }
        }
        #[inline(always)]
        pub fn mul(self, o: Lanes) -> Lanes {
            unsafe { Lanes(_mm256_mul_ps(self.0, o.0)) }
        }
        #[inline(always)]
        pub fn min(self, o: Lanes) -> Lanes {
            unsafe { Lanes(_mm256_min_ps(self.0, o.0)) }
        }
        #[inline(always)]
        pub fn max(self, o: Lanes) -> Lanes {
            unsafe { Lanes(_mm256_max_ps(self.0, o.0)) }
        }
        #[inline(always)]
        pub fn cmple(self, o: Lanes) -> Mask {
            unsafe { Mask(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0)) }
        }
        #[inline(always)]
        pub fn cmpge(self, o: Lanes) -> Mask {
            unsafe { Mask(_mm256_cmp_ps::<_CMP_GE_OQ>(self.0, o.0)) }
        }
        /// `a` where the mask is set, else `b`.
        #[inline(always)]
        pub fn select(mask: Mask, a: Lanes, b: Lanes) -> Lanes {
            unsafe { Lanes(_mm256_blendv_ps(b.0, a.0, mask.0)) }
        }
    }

    impl Mask {
        #[inline(always)]
        pub fn and(self, o: Mask) -> Mask {
            unsafe { Mask(_mm256_and_ps(self.0, o.0)) }
        }
        /// Bit i set where lane i is.
        #[inline(always)]
        pub fn bitmask(self) -> u32 {
            unsafe { _mm256_movemask_ps(self.0) as u32 }
        }
    }
}

#[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
pub use avx::Lanes;
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx")))]
pub use portable::Lanes;

#[cfg(test)]
mod tests {
    use super::portable;
    use super::*;

    /// Values that exercise every special case: signed zeros, infinities, NaN, the largest
    /// and smallest magnitudes.
    const SPECIAL: [f32; 12] = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        f32::MAX,
        -f32::MAX,
        1e-45,
        -3.5,
        2.25,
    ];

    fn sets() -> Vec<[f32; 8]> {
        let mut out = Vec::new();
        let mut state = 0x1234_5678u32;
        for k in 0..400 {
            let mut a = [0.0f32; 8];
            for v in &mut a {
                state = crate::sampling::hash_u32(state);
                *v = if k % 2 == 0 {
                    SPECIAL[(state % SPECIAL.len() as u32) as usize]
                } else {
                    f32::from_bits(state & 0xbfff_ffff) // finite and infinite magnitudes, both signs
                };
            }
            out.push(a);
        }
        out
    }

    /// The lanes in use (AVX where built with it) and the portable reference give the same
    /// bits for every operation. Where AVX is not built this compares the reference with
    /// itself, which still checks the array round trip.
    #[test]
    fn lanes_match_the_portable_reference() {
        let sets = sets();
        let bits = |a: [f32; 8]| a.map(f32::to_bits);
        // Each set against the next (special values against random bits), the one after
        // (two sets of special values, so equal lanes and NaN pairs occur) and itself.
        let pairs = sets.windows(3).flat_map(|w| [(w[0], w[1]), (w[0], w[2]), (w[0], w[0])]);
        for (a, b) in pairs {
            let (x, y) = (Lanes::from_array(a), Lanes::from_array(b));
            let (p, q) = (portable::Lanes::from_array(a), portable::Lanes::from_array(b));
            assert_eq!(bits(x.to_array()), bits(a));
            assert_eq!(bits(x.sub(y).to_array()), bits(p.sub(q).to_array()), "sub {a:?} {b:?}");
            assert_eq!(bits(x.mul(y).to_array()), bits(p.mul(q).to_array()), "mul {a:?} {b:?}");
            assert_eq!(bits(x.min(y).to_array()), bits(p.min(q).to_array()), "min {a:?} {b:?}");
            assert_eq!(bits(x.max(y).to_array()), bits(p.max(q).to_array()), "max {a:?} {b:?}");
            assert_eq!(x.cmple(y).bitmask(), p.cmple(q).bitmask(), "cmple {a:?} {b:?}");
            assert_eq!(x.cmpge(y).bitmask(), p.cmpge(q).bitmask(), "cmpge {a:?} {b:?}");
            assert_eq!(
                x.cmple(y).and(x.cmpge(y)).bitmask(),
                p.cmple(q).and(p.cmpge(q)).bitmask(),
                "and {a:?} {b:?}"
            );
            assert_eq!(
                bits(Lanes::select(x.cmple(y), x, y).to_array()),
                bits(portable::Lanes::select(p.cmple(q), p, q).to_array()),
                "select {a:?} {b:?}"
            );
        }
        // Each lane's comparison lands in its own bit.
        for lane in 0..LANES {
            let mut a = [0.0f32; 8];
            a[lane] = -1.0;
            assert_eq!(Lanes::from_array(a).cmple(Lanes::splat(-0.5)).bitmask(), 1 << lane);
        }
    }
}
