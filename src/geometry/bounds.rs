//! Axis-aligned boxes and the conservative ray–box test.

use glam::Vec3;

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
    pub origin: Vec3,
    /// 1/direction, with direction components below [`PARALLEL_THRESHOLD`] replaced by 1 so
    /// that nothing is infinite (WGSL does not promise IEEE infinities or NaN).
    pub inv_direction: Vec3,
    /// Per axis: is the ray parallel to that axis's slabs?
    pub parallel: [bool; 3],
    pub t_max: f32,
}

/// Direction components smaller than this are treated as exactly parallel to the slab. It
/// keeps 1/d ≤ 1e30, so slab distances stay finite for coordinates up to ~1e8; and it moves
/// a ray by at most 1e-30·t, below f32 resolution at any distance a scene can hold.
const PARALLEL_THRESHOLD: f32 = 1e-30;

impl RayBoxPrecomp {
    pub fn new(ray: &Ray) -> RayBoxPrecomp {
        let d = ray.direction;
        let parallel =
            [d.x.abs() < PARALLEL_THRESHOLD, d.y.abs() < PARALLEL_THRESHOLD, d.z.abs() < PARALLEL_THRESHOLD];
        let safe = Vec3::new(
            if parallel[0] { 1.0 } else { d.x },
            if parallel[1] { 1.0 } else { d.y },
            if parallel[2] { 1.0 } else { d.z },
        );
        RayBoxPrecomp { origin: ray.origin, inv_direction: Vec3::ONE / safe, parallel, t_max: ray.t_max }
    }
}

/// Does the ray overlap the box within `(0, t_max)`? Conservative: the far slab distance is
/// scaled by 1 + 2γ₃ so rounding can never make a ray slip between adjacent boxes (Ize 2013,
/// "Robust BVH Ray Traversal", JCGT 2(2); pbrt-v4 `Bounds3::IntersectP`). A ray parallel to
/// a slab overlaps it iff its origin lies in the closed slab, without any ∞·0.
///
/// The entry distance is compared with `t_max` with a margin of 4γ₃ (about 6 ulps): the
/// triangle test's own rounding can place a hit a few ulps before its box's computed entry,
/// and without the margin a node whose entry equals the current nearest `t` was pruned
/// although it held a hit one ulp nearer (found by the brute-force comparison test).
pub fn intersect_box(pre: &RayBoxPrecomp, min: Vec3, max: Vec3) -> bool {
    let t0 = (min - pre.origin) * pre.inv_direction;
    let t1 = (max - pre.origin) * pre.inv_direction;
    let mut t_near = t0.min(t1);
    let mut t_far = t0.max(t1);
    for axis in 0..3 {
        if pre.parallel[axis] {
            let inside = pre.origin[axis] >= min[axis] && pre.origin[axis] <= max[axis];
            t_near[axis] = if inside { f32::MIN } else { f32::MAX };
            t_far[axis] = if inside { f32::MAX } else { f32::MIN };
        }
    }
    let enter = t_near.x.max(t_near.y).max(t_near.z).max(0.0);
    let exit = t_far.x.min(t_far.y).min(t_far.z) * (1.0 + 2.0 * gamma(3));
    enter <= exit && enter * (1.0 - 4.0 * gamma(3)) <= pre.t_max
}
