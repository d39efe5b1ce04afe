//! Rays, and spawning rays from surfaces without self-intersection.

use glam::Vec3;

use super::float::{next_float_down, next_float_up};

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
    let po = p + offset;
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

/// A ray leaving surface point `p` in direction `w`, with no upper bound on `t`.
pub fn spawn_ray(p: Vec3, p_error: Vec3, n_geometric: Vec3, w: Vec3) -> Ray {
    Ray { origin: offset_ray_origin(p, p_error, n_geometric, w), direction: w, t_max: f32::MAX }
}

/// A shadow ray from surface point `p` to `target`, both offset off their surfaces; it
/// reaches the target at `t = 1` and stops at `1 − SHADOW_EPSILON` (pbrt-v4 `SpawnRayTo`).
pub fn spawn_ray_to(p: Vec3, p_error: Vec3, n_geometric: Vec3, target: Vec3) -> Ray {
    let origin = offset_ray_origin(p, p_error, n_geometric, target - p);
    Ray { origin, direction: target - origin, t_max: 1.0 - SHADOW_EPSILON }
}
