//! Traversal of the flat binary BVH, nearer child first (after pbrt-v4 §7.3.5), with a
//! short stack and a restart trail instead of a full stack (Laine 2010, "Restart Trail for
//! Stackless BVH Traversal", HPG): the twin of `traverse` in shaders/bvh.wgsl, where the
//! short stack lives in registers and no array is needed at all.

use glam::Vec3;

use crate::geometry::{
    box_entry, entry_within, intersect_triangle_precomp, Ray, RayBoxPrecomp, RayTrianglePrecomp, TriangleHit,
};
use crate::scene::layout::{BvhNode, Triangle};

use super::trail::{trail_bit, trail_depth, trail_pop, trail_through};
use super::wide::{traverse_wide, WideBvh};

/// Deferred children the traversal keeps (its short stack). Deeper deferrals drop the
/// oldest; when the stack runs dry the traversal starts over from the root and follows its
/// trail back. The GPU holds these in two `vec4<u32>` registers: lavapipe writes a private
/// array lane by lane and its mere presence cost more than its writes
/// (`bench/history/lavapipe.md`, "the traversal stack in registers").
pub const SHORT_STACK_SIZE: usize = 8;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestHit {
    /// Index into the (BVH-ordered) triangle array.
    pub triangle: u32,
    pub hit: TriangleHit,
}

fn vertices(t: &Triangle) -> (Vec3, Vec3, Vec3) {
    (Vec3::from(t.p0), Vec3::from(t.p1), Vec3::from(t.p2))
}

/// The per-ray state of [`traverse_with_short_stack`] besides the node.
///
/// At each depth d on the path from the root to the current node, d's bit of `passed`
/// ([`trail_bit`]) says the traversal is in the last child it will visit at that depth: the
/// farther of two children (the nearer one done), or the only one of them the ray
/// overlapped, which d's bit of `single` marks. A clear `passed` bit means the nearer of
/// two: the farther waits on the short stack (or was dropped from it). After a restart the
/// traversal descends from the root following these bits. `single` is what keeps a restart
/// exact: with `passed` alone, a level whose farther child a nearer hit has culled since
/// (its nearer child done) would read the same as one whose ray only ever overlapped the
/// nearer child (not done), and telling them apart would cost visiting the nearer child
/// again.
#[derive(Clone, Copy)]
struct Trail {
    passed: u64,
    single: u64,
}

/// Where traversal goes from an interior node: the child to visit next (`None`: neither)
/// and, when the ray overlaps both and the nearer is next, the farther one to defer.
struct ChildStep {
    next: Option<u32>,
    deferred: Option<u32>,
    trail: Trail,
}

/// Both children's boxes are tested at their parent; the first is stored right after it,
/// the second at its offset. Which of them is nearer is decided from their entry distances
/// without `t_max` (ties: the first), so that it reads the same when a restart comes back
/// with a shorter `t_max`; only then is each tested against `t_max`.
fn child_step(
    nodes: &[BvhNode],
    pre: &RayBoxPrecomp,
    t_max: f32,
    current: u32,
    depth: u32,
    trail: Trail,
) -> ChildStep {
    let entry = |node: u32| {
        let node = &nodes[node as usize];
        box_entry(pre, f32::MAX, Vec3::from(node.bounds_min), Vec3::from(node.bounds_max))
    };
    let (first, second) = (current + 1, nodes[current as usize].offset);
    let (a, b) = (entry(first), entry(second));
    let first_nearer = match (a, b) {
        (Some(a), Some(b)) => a <= b,
        (a, _) => a.is_some(),
    };
    let (near, far, near_entry, far_entry) =
        if first_nearer { (first, second, a, b) } else { (second, first, b, a) };
    let hit_near = near_entry.is_some_and(|e| entry_within(e, t_max));
    let hit_far = far_entry.is_some_and(|e| entry_within(e, t_max));

    // The cases, at the child's depth: not yet passed there, the ray overlaps both (go to
    // the nearer, defer the farther), one (go to it, and mark the level passed and single)
    // or neither (pop). If the one is the farther, whatever the trail held below the nearer
    // is moot and cleared; on a restart that cannot happen unless a hit inside the nearer
    // child came before its box's entry, which the entry margin of `entry_within` rules
    // out, so no test reaches it: the clear keeps the trail right should rounding allow it.
    // Passed and single: go to whichever child is overlapped now (at most the one that
    // was). Passed, not single: the nearer is done; the farther if it is still overlapped.
    // The kernel computes the same with selects.
    let child = depth + 1;
    let bit = trail_bit(child);
    let passed = trail.passed & bit != 0;
    let far_only = passed && trail.single & bit == 0;
    let one_hit = hit_near != hit_far;
    let new_level = !passed && one_hit;
    let kept = if hit_far { trail_through(trail.passed, child) } else { trail.passed };
    let next = if far_only || !hit_near { far } else { near };
    let descend = if far_only { hit_far } else { hit_near || hit_far };
    ChildStep {
        next: descend.then_some(next),
        deferred: (!passed && hit_near && hit_far).then_some(far),
        trail: Trail {
            passed: if new_level { kept | bit } else { trail.passed },
            single: match (passed, one_hit) {
                (true, _) => trail.single,
                (false, true) => trail.single | bit,
                (false, false) => trail.single & !bit,
            },
        },
    }
}

/// Visits the leaves the ray may touch, nearer first; `visit` tests a leaf's triangles, may
/// shorten `ray.t_max`, and returns `true` to stop. Keeps up to `stack_limit` (at most
/// [`SHORT_STACK_SIZE`]) deferred children; 0 restarts from the root after every leaf.
///
/// The leaves come in the order a full stack would give, less those a nearer hit culls; a
/// deferred child is not tested against the nearest hit again when it is taken up (the
/// kernel keeps no entry distances: a second set of registers for a test that seldom
/// prunes). So the result does not depend on `stack_limit` (tests/bvh.rs, tests/gpu/kernel_variants.rs).
pub fn traverse_with_short_stack(
    nodes: &[BvhNode],
    stack_limit: usize,
    ray: &mut Ray,
    mut visit: impl FnMut(u32, u32, &mut Ray) -> bool,
) {
    let pre = RayBoxPrecomp::new(ray);
    let root = &nodes[0];
    if box_entry(&pre, ray.t_max, Vec3::from(root.bounds_min), Vec3::from(root.bounds_max)).is_none() {
        return;
    }
    let stack_limit = stack_limit.min(SHORT_STACK_SIZE);
    // The latest deferral first, as the kernel shifts its registers.
    let mut stack = [0u32; SHORT_STACK_SIZE];
    let mut sp = 0usize;
    let mut trail = Trail { passed: 0, single: 0 };
    let (mut current, mut depth) = (0u32, 0u32);
    loop {
        // Down through interior nodes until a leaf, or a node none of whose children the ray
        // needs (the kernel's while-while loop: the same visits in the same order).
        let mut node = &nodes[current as usize];
        while node.triangle_count() == 0 {
            let step = child_step(nodes, &pre, ray.t_max, current, depth, trail);
            trail = step.trail;
            let Some(next) = step.next else { break };
            if let Some(far) = step.deferred {
                stack.copy_within(0..SHORT_STACK_SIZE - 1, 1);
                stack[0] = far;
                sp = (sp + 1).min(stack_limit);
            }
            current = next;
            depth += 1;
            node = &nodes[current as usize];
        }
        let count = node.triangle_count();
        if count > 0 && visit(node.offset, count, ray) {
            return;
        }
        // `current` is done, and with it every ancestor whose last child it was.
        if depth == 0 {
            return;
        }
        trail.passed = trail_pop(trail.passed, depth);
        if trail.passed == 0 {
            return;
        }
        depth = trail_depth(trail.passed);
        if sp > 0 {
            // The farther child deferred at `depth`: the latest deferral still pending.
            current = stack[0];
            stack.copy_within(1.., 0);
            sp -= 1;
        } else {
            // Its deferral was dropped: down from the root again, along the trail.
            current = 0;
            depth = 0;
        }
    }
}

/// [`traverse_with_short_stack`] with the whole short stack: the kernel's traversal.
fn traverse(nodes: &[BvhNode], ray: &mut Ray, visit: impl FnMut(u32, u32, &mut Ray) -> bool) {
    traverse_with_short_stack(nodes, SHORT_STACK_SIZE, ray, visit)
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
