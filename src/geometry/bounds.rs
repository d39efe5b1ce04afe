//! Axis-aligned boxes and the conservative ray–box test.

use glam::{BVec3A, Vec3, Vec3A};

use super::float::gamma;
use super::ray::Ray;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    pub fn from_point(p: Vec3) -> Aabb {
        Aabb { min: p, max: p }
    }

    pub fn union(self, other: Aabb) -> Aabb {
        Aabb { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    pub fn grow(self, p: Vec3) -> Aabb {
        Aabb { min: self.min.min(p), max: self.max.max(p) }
    }

    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    pub fn centroid(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    pub fn diagonal(&self) -> Vec3 {
        self.max - self.min
    }

    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.diagonal();
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    pub fn max_extent_axis(&self) -> usize {
        let d = self.diagonal();
        if d.x >= d.y && d.x >= d.z {
            0
        } else if d.y >= d.z {
            1
        } else {
            2
        }
    }
}

/// Per-ray constants of the box test, computed once per traversal.
#[derive(Clone, Copy, Debug)]
pub struct RayBoxPrecomp {
    /// SIMD vectors (`Vec3A`): the test is a handful of 4-wide operations and selects,
    /// without a branch per axis.
    pub origin: Vec3A,
    /// 1/direction, with direction components below [`PARALLEL_THRESHOLD`] replaced by 1 so
    /// that nothing is infinite (WGSL does not promise IEEE infinities or NaN).
    pub inv_direction: Vec3A,
    /// Per axis: is the ray parallel to that axis's slabs?
    pub parallel: BVec3A,
}

/// Direction components smaller than this are treated as exactly parallel to the slab. It
/// keeps 1/d ≤ 1e30, so slab distances stay finite for coordinates up to ~1e8; and it moves
/// a ray by at most 1e-30·t, below f32 resolution at any distance a scene can hold.
const PARALLEL_THRESHOLD: f32 = 1e-30;

impl RayBoxPrecomp {
    pub fn new(ray: &Ray) -> RayBoxPrecomp {
        let d = Vec3A::from(ray.direction);
        let parallel = d.abs().cmplt(Vec3A::splat(PARALLEL_THRESHOLD));
        let safe = Vec3A::select(parallel, Vec3A::ONE, d);
        RayBoxPrecomp { origin: Vec3A::from(ray.origin), inv_direction: Vec3A::ONE / safe, parallel }
    }
}

/// The entry distance (clamped to 0) where the ray overlaps the box within `(0, t_max)`,
/// else `None`; traversal uses it to visit the nearer child first and to drop a deferred
/// child once a hit nearer than its entry is found ([`entry_within`]). Conservative: the far slab distance is
/// scaled by 1 + 2γ₃ so rounding can never make a ray slip between adjacent boxes (Ize 2013,
/// "Robust BVH Ray Traversal", JCGT 2(2); pbrt-v4 `Bounds3::IntersectP`). A ray parallel to
/// a slab overlaps it iff its origin lies in the closed slab, without any ∞·0.
///
/// The entry distance is compared with `t_max` with a margin of 4γ₃ (about 6 ulps): the
/// triangle test's own rounding can place a hit a few ulps before its box's computed entry,
/// and without the margin a node whose entry equals the current nearest `t` was pruned
/// although it held a hit one ulp nearer (found by the brute-force comparison test).
#[inline(always)]
pub fn box_entry(pre: &RayBoxPrecomp, t_max: f32, min: Vec3, max: Vec3) -> Option<f32> {
    let (min, max) = (Vec3A::from(min), Vec3A::from(max));
    let t0 = (min - pre.origin) * pre.inv_direction;
    let t1 = (max - pre.origin) * pre.inv_direction;
    let inside = pre.origin.cmpge(min) & pre.origin.cmple(max);
    let t_near = Vec3A::select(
        pre.parallel,
        Vec3A::select(inside, Vec3A::splat(f32::MIN), Vec3A::splat(f32::MAX)),
        t0.min(t1),
    );
    let t_far = Vec3A::select(
        pre.parallel,
        Vec3A::select(inside, Vec3A::splat(f32::MAX), Vec3A::splat(f32::MIN)),
        t0.max(t1),
    );
    let enter = t_near.max_element().max(0.0);
    let exit = t_far.min_element() * (1.0 + 2.0 * gamma(3));
    (enter <= exit && entry_within(enter, t_max)).then_some(enter)
}

/// Is a box entered at `enter` still before `t_max`? (With the 4γ₃ margin above.)
#[inline(always)]
pub fn entry_within(enter: f32, t_max: f32) -> bool {
    enter * (1.0 - 4.0 * gamma(3)) <= t_max
}
