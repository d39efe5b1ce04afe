//! Stack-based traversal of the flat BVH, nearer child first (after pbrt-v4 §7.3.5).

use glam::Vec3;

use crate::geometry::{
    box_entry, entry_within, intersect_triangle_precomp, Ray, RayBoxPrecomp, RayTrianglePrecomp, TriangleHit,
};
use crate::scene::layout::{BvhNode, Triangle};

use super::build::MAX_DEPTH;
use super::wide::{traverse_wide, WideBvh};

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

/// Visits the leaves the ray may touch, nearer first; `visit` tests a leaf's triangles, may
/// shorten `ray.t_max`, and returns `true` to stop.
///
/// An interior node tests both children's boxes, descends into the nearer overlap and
/// defers the other with its entry distance; a deferred child whose entry lies beyond the
/// nearest hit found meanwhile is dropped without loading it again (pbrt-v4 §7.3.5 orders
/// by the split axis instead and tests each node's own box when it is visited).
fn traverse(nodes: &[BvhNode], ray: &mut Ray, mut visit: impl FnMut(u32, u32, &mut Ray) -> bool) {
    let pre = RayBoxPrecomp::new(ray);
    let entry = |node: u32, t_max: f32| {
        let node = &nodes[node as usize];
        box_entry(&pre, t_max, Vec3::from(node.bounds_min), Vec3::from(node.bounds_max))
    };
    if entry(0, ray.t_max).is_none() {
        return;
    }
    let mut stack = [(0u32, 0.0f32); TRAVERSAL_STACK_SIZE];
    let mut sp = 0usize;
    let mut current = 0u32;
    loop {
        let node = &nodes[current as usize];
        let count = node.triangle_count();
        if count > 0 {
            if visit(node.offset, count, ray) {
                return;
            }
        } else {
            let (first, second) = (current + 1, node.offset);
            match (entry(first, ray.t_max), entry(second, ray.t_max)) {
                (Some(a), Some(b)) => {
                    let (near, far, far_entry) = if a <= b { (first, second, b) } else { (second, first, a) };
                    stack[sp] = (far, far_entry);
                    sp += 1;
                    current = near;
                    continue;
                }
                (Some(_), None) => {
                    current = first;
                    continue;
                }
                (None, Some(_)) => {
                    current = second;
                    continue;
                }
                (None, None) => {}
            }
        }
        // The next deferred child that may still hold a nearer hit.
        loop {
            if sp == 0 {
                return;
            }
            sp -= 1;
            let (node, node_entry) = stack[sp];
            if entry_within(node_entry, ray.t_max) {
                current = node;
                break;
            }
        }
    }
}

/// A tree the intersection queries can walk: the flat binary [`BvhNode`] array (the GPU's
/// layout) or the CPU's 8-wide [`WideBvh`]. Both visit the same leaves over the same
/// triangle order.
pub trait Traversal {
    /// Calls `visit(first, count, ray)` for the leaves the ray may touch, nearer first, until
    /// it returns `true`; `visit` may shorten `ray.t_max`.
    fn traverse(&self, ray: &mut Ray, visit: impl FnMut(u32, u32, &mut Ray) -> bool);

    /// [`Traversal::traverse`] for a query that stops at the first hit it accepts, whose
    /// answer does not depend on the order the leaves come in.
    fn traverse_any(&self, ray: &mut Ray, visit: impl FnMut(u32, u32, &mut Ray) -> bool) {
        self.traverse(ray, visit)
    }
}

impl Traversal for [BvhNode] {
    fn traverse(&self, ray: &mut Ray, visit: impl FnMut(u32, u32, &mut Ray) -> bool) {
        traverse(self, ray, visit)
    }
}

impl Traversal for Vec<BvhNode> {
    fn traverse(&self, ray: &mut Ray, visit: impl FnMut(u32, u32, &mut Ray) -> bool) {
        traverse(self, ray, visit)
    }
}

impl Traversal for WideBvh {
    fn traverse(&self, ray: &mut Ray, visit: impl FnMut(u32, u32, &mut Ray) -> bool) {
        traverse_wide::<true>(self, ray, visit)
    }

    fn traverse_any(&self, ray: &mut Ray, visit: impl FnMut(u32, u32, &mut Ray) -> bool) {
        traverse_wide::<false>(self, ray, visit)
    }
}

/// The nearest intersection in `(0, ray.t_max)`.
pub fn intersect_closest<T: Traversal + ?Sized>(
    tree: &T,
    triangles: &[Triangle],
    ray: &Ray,
) -> Option<ClosestHit> {
    intersect_closest_filtered(tree, triangles, ray, |_, _| true)
}

/// Is anything hit in `(0, ray.t_max)`? Stops at the first hit (shadow rays).
pub fn intersect_any<T: Traversal + ?Sized>(tree: &T, triangles: &[Triangle], ray: &Ray) -> bool {
    intersect_any_filtered(tree, triangles, ray, |_, _| true)
}

/// [`intersect_closest`] counting only the hits `accept(triangle, hit)` keeps (any-hit
/// filtering: alpha-tested surfaces).
pub fn intersect_closest_filtered<T: Traversal + ?Sized>(
    tree: &T,
    triangles: &[Triangle],
    ray: &Ray,
    accept: impl Fn(u32, &TriangleHit) -> bool,
) -> Option<ClosestHit> {
    let mut ray = *ray;
    let mut best = None;
    let pre = RayTrianglePrecomp::new(&ray);
    tree.traverse(&mut ray, |first, count, ray| {
        for i in first..first + count {
            let (p0, p1, p2) = vertices(&triangles[i as usize]);
            if let Some(hit) = intersect_triangle_precomp(&pre, ray.t_max, p0, p1, p2) {
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
pub fn intersect_any_filtered<T: Traversal + ?Sized>(
    tree: &T,
    triangles: &[Triangle],
    ray: &Ray,
    accept: impl Fn(u32, &TriangleHit) -> bool,
) -> bool {
    let mut ray = *ray;
    let mut found = false;
    let pre = RayTrianglePrecomp::new(&ray);
    tree.traverse_any(&mut ray, |first, count, ray| {
        for i in first..first + count {
            let (p0, p1, p2) = vertices(&triangles[i as usize]);
            if let Some(hit) = intersect_triangle_precomp(&pre, ray.t_max, p0, p1, p2) {
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
