//! Rays, and spawning rays from surfaces without self-intersection.

use glam::Vec3;

/// A ray `origin + t·direction`, `t ∈ (0, t_max)`. `direction` need not be unit length.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3,
    pub direction: Vec3,
    pub t_max: f32,
}

/// Shadow rays stop this fraction short of their target (pbrt-v4 `ShadowEpsilon`), so the
/// light's own surface is not counted as an occluder.
pub const SHADOW_EPSILON: f32 = 1e-4;

/// Moves `p` off its surface far enough that a ray leaving in `w` cannot re-hit the
/// surface, using the point's conservative error bound `p_error` (pbrt-v4 §6.8.6
/// `OffsetRayOrigin`): offset along the geometric normal by the error box's projection, then
/// round each component away from the surface.
#[inline(always)]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, n_geometric: Vec3, w: Vec3) -> Vec3 {
    let d = n_geometric.abs().dot(p_error);
    let mut offset = n_geometric * d;
    if w.dot(n_geometric) < 0.0 {
        offset = -offset;
    }
    round_away(p + offset, offset)
}

/// Each component of `po` one float further in the direction of `offset`'s component:
/// [`next_float_up`](super::float::next_float_up) where it is positive,
/// [`next_float_down`](super::float::next_float_down) where negative, unchanged
/// where zero. The scalar reference: three data-dependent branches per component.
/// Built where the SSE form is not, and in tests as the reference it is held to.
#[cfg(any(test, not(all(target_arch = "x86_64", target_feature = "sse4.1"))))]
fn round_away_scalar(po: Vec3, offset: Vec3) -> Vec3 {
    use super::float::{next_float_down, next_float_up};
    let round = |po: f32, o: f32| {
        if o > 0.0 {
            next_float_up(po)
        } else if o < 0.0 {
            next_float_down(po)
        } else {
            po
        }
    };
    Vec3::new(round(po.x, offset.x), round(po.y, offset.y), round(po.z, offset.z))
}

/// [`round_away_scalar`] on the three components at once, without branches: every ray a
/// path spawns goes through here (three per bounce with light sampling), and as branches
/// the rounding was about half of spawning a ray. The same bits for every input, NaN aside
/// (its payload may be quietened); a test holds it to the scalar form.
#[cfg(all(target_arch = "x86_64", target_feature = "sse4.1"))]
#[inline(always)]
fn round_away(po: Vec3, offset: Vec3) -> Vec3 {
    use core::arch::x86_64::*;
    // SAFETY: the intrinsics touch registers and the local array `out` (four floats, the
    // store's width) only, and the cfg builds this only where SSE4.1 is enabled for the
    // whole program.
    unsafe {
        let v = _mm_setr_ps(po.x, po.y, po.z, 0.0);
        let o = _mm_setr_ps(offset.x, offset.y, offset.z, 0.0);
        let zero = _mm_setzero_ps();
        let sign = _mm_set1_ps(-0.0);
        let (one, minus_one) = (_mm_set1_epi32(1), _mm_set1_epi32(-1));
        // Up: −0 counts as +0 (adding +0 turns −0 into +0 and changes nothing else); the bits
        // step up for v ≥ 0 and down for negative v; +∞ stays.
        let up_v = _mm_add_ps(v, zero);
        let up_step = _mm_blendv_epi8(minus_one, one, _mm_castps_si128(_mm_cmpge_ps(up_v, zero)));
        let up = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(up_v), up_step));
        let up = _mm_blendv_ps(up, v, _mm_cmpeq_ps(v, _mm_set1_ps(f32::INFINITY)));
        // Down, mirrored: +0 counts as −0 (−((−v) + 0)); −∞ stays.
        let down_v = _mm_xor_ps(_mm_add_ps(_mm_xor_ps(v, sign), zero), sign);
        let down_step = _mm_blendv_epi8(one, minus_one, _mm_castps_si128(_mm_cmpgt_ps(down_v, zero)));
        let down = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(down_v), down_step));
        let down = _mm_blendv_ps(down, v, _mm_cmpeq_ps(v, _mm_set1_ps(f32::NEG_INFINITY)));
        let r = _mm_blendv_ps(v, down, _mm_cmplt_ps(o, zero));
        let r = _mm_blendv_ps(r, up, _mm_cmpgt_ps(o, zero));
        let mut out = [0.0f32; 4];
        _mm_storeu_ps(out.as_mut_ptr(), r);
        Vec3::new(out[0], out[1], out[2])
    }
}

#[cfg(not(all(target_arch = "x86_64", target_feature = "sse4.1")))]
#[inline(always)]
fn round_away(po: Vec3, offset: Vec3) -> Vec3 {
    round_away_scalar(po, offset)
}

/// A ray leaving surface point `p` in direction `w`, with no upper bound on `t`. Inlined:
/// left to the compiler, the integrator's `scatter` called it out of line, 0.8% more
/// instructions on the Cornell box.
#[inline(always)]
pub fn spawn_ray(p: Vec3, p_error: Vec3, n_geometric: Vec3, w: Vec3) -> Ray {
    Ray { origin: offset_ray_origin(p, p_error, n_geometric, w), direction: w, t_max: f32::MAX }
}

/// A shadow ray from surface point `p` to `target`, both offset off their surfaces; it
/// reaches the target at `t = 1` and stops at `1 − SHADOW_EPSILON` (pbrt-v4 `SpawnRayTo`).
#[inline(always)]
pub fn spawn_ray_to(p: Vec3, p_error: Vec3, n_geometric: Vec3, target: Vec3) -> Ray {
    let origin = offset_ray_origin(p, p_error, n_geometric, target - p);
    Ray { origin, direction: target - origin, t_max: 1.0 - SHADOW_EPSILON }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The branch-free rounding gives the scalar reference's bits for every pairing of
    /// special and ordinary values and every offset sign (where SSE4.1 is not built, the
    /// reference against itself).
    #[test]
    fn round_away_is_the_scalar_rounding() {
        let values = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            1e-45,
            -1e-45,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::MAX,
            -f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            3.25e7,
            -0.1,
        ];
        let offsets = [1e-6, -1e-6, 0.0, -0.0, f32::NAN];
        for &a in &values {
            for &b in &values {
                for &oa in &offsets {
                    for &ob in &offsets {
                        let (po, o) = (Vec3::new(a, b, a), Vec3::new(oa, ob, -oa));
                        let (got, want) = (round_away(po, o), round_away_scalar(po, o));
                        assert_eq!(
                            got.to_array().map(f32::to_bits),
                            want.to_array().map(f32::to_bits),
                            "po {po:?}, offset {o:?}"
                        );
                    }
                }
            }
        }
    }
}
