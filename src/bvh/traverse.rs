//! Stack-based traversal of the flat BVH, nearer child first (pbrt-v4 §7.3.5).

use glam::Vec3;

use crate::geometry::{intersect_box, intersect_triangle, Ray, RayBoxPrecomp, TriangleHit};
use crate::scene::layout::{BvhNode, Triangle};

use super::build::MAX_DEPTH;

/// Entries in the traversal stack: one per level is enough, because each level pushes at
/// most one deferred child.
pub const TRAVERSAL_STACK_SIZE: usize = MAX_DEPTH;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestHit {
    /// Index into the (BVH-ordered) triangle array.
    pub triangle: u32,
    pub hit: TriangleHit,
}

fn vertices(t: &Triangle) -> (Vec3, Vec3, Vec3) {
    (Vec3::from(t.p0), Vec3::from(t.p1), Vec3::from(t.p2))
}

/// Visits the leaves the ray may touch, in front-to-back order; `visit` tests a leaf's
/// triangles, may shorten `ray.t_max`, and returns `true` to stop.
fn traverse(nodes: &[BvhNode], ray: &mut Ray, mut visit: impl FnMut(u32, u32, &mut Ray) -> bool) {
    let dir_is_neg = [ray.direction.x < 0.0, ray.direction.y < 0.0, ray.direction.z < 0.0];
    let mut pre = RayBoxPrecomp::new(ray);
    let mut stack = [0u32; TRAVERSAL_STACK_SIZE];
    let mut sp = 0usize;
    let mut current = 0u32;
    loop {
        let node = &nodes[current as usize];
        pre.t_max = ray.t_max;
        if intersect_box(&pre, Vec3::from(node.bounds_min), Vec3::from(node.bounds_max)) {
            let count = node.triangle_count();
            if count > 0 {
                if visit(node.offset, count, ray) {
                    return;
                }
            } else {
                // Visit the child on the ray's near side first.
                let (near, far) = if dir_is_neg[node.axis() as usize] {
                    (node.offset, current + 1)
                } else {
                    (current + 1, node.offset)
                };
                stack[sp] = far;
                sp += 1;
                current = near;
                continue;
            }
        }
        if sp == 0 {
            return;
        }
        sp -= 1;
        current = stack[sp];
    }
}

/// The nearest intersection in `(0, ray.t_max)`.
pub fn intersect_closest(nodes: &[BvhNode], triangles: &[Triangle], ray: &Ray) -> Option<ClosestHit> {
    intersect_closest_filtered(nodes, triangles, ray, |_, _| true)
}

/// Is anything hit in `(0, ray.t_max)`? Stops at the first hit (shadow rays).
pub fn intersect_any(nodes: &[BvhNode], triangles: &[Triangle], ray: &Ray) -> bool {
    intersect_any_filtered(nodes, triangles, ray, |_, _| true)
}

/// [`intersect_closest`] counting only the hits `accept(triangle, hit)` keeps (any-hit
/// filtering: alpha-tested surfaces).
pub fn intersect_closest_filtered(
    nodes: &[BvhNode],
    triangles: &[Triangle],
    ray: &Ray,
    accept: impl Fn(u32, &TriangleHit) -> bool,
) -> Option<ClosestHit> {
    let mut ray = *ray;
    let mut best = None;
    traverse(nodes, &mut ray, |first, count, ray| {
        for i in first..first + count {
            let (p0, p1, p2) = vertices(&triangles[i as usize]);
            if let Some(hit) = intersect_triangle(ray, p0, p1, p2) {
                if accept(i, &hit) {
                    ray.t_max = hit.t;
                    best = Some(ClosestHit { triangle: i, hit });
                }
            }
        }
        false
    });
    best
}

/// [`intersect_any`] counting only the hits `accept` keeps.
pub fn intersect_any_filtered(
    nodes: &[BvhNode],
    triangles: &[Triangle],
    ray: &Ray,
    accept: impl Fn(u32, &TriangleHit) -> bool,
) -> bool {
    let mut ray = *ray;
    let mut found = false;
    traverse(nodes, &mut ray, |first, count, ray| {
        for i in first..first + count {
            let (p0, p1, p2) = vertices(&triangles[i as usize]);
            if let Some(hit) = intersect_triangle(ray, p0, p1, p2) {
                if accept(i, &hit) {
                    found = true;
                    return true;
                }
            }
        }
        false
    });
    found
}
