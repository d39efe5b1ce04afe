//! The CPU backend's 8-wide BVH: the binary tree collapsed so that one node holds up to eight
//! children's boxes, tested together with 8-wide SIMD (Wald, Benthin & Boulos 2008, "Getting
//! Rid of Packets"; Dammertz et al. 2008, "Shallow Bounding Volume Hierarchies"; Embree's
//! BVH8, its default where AVX is available).
//!
//! Eight rather than four: a ray's walk is a chain of dependent node loads, and with eight
//! children a node spans three binary levels instead of two, so the chain is shorter for the
//! same leaves (`bench/history/throughput.md`, "The CPU BVH 8-wide", has the before and after).
//!
//! The GPU keeps the binary [`BvhNode`] array (one lane per ray gains nothing from wide
//! nodes there); both trees have the same leaves over the same triangle order, so both
//! backends find the same triangle and the same hit. The box test is the binary tree's
//! ([`crate::geometry::box_entry`]) lane by lane: the same slab distances, the same 1 + 2γ₃
//! widening of the exit and the same 4γ₃ entry margin, so it is exactly as conservative.

use std::mem::MaybeUninit;

use glam::Vec3;

use super::lanes::{Lanes, LANES};

use crate::geometry::{entry_within, gamma, Ray};
use crate::scene::layout::BvhNode;

use super::build::MAX_DEPTH;

/// Children per node.
pub const WIDTH: usize = LANES;

/// One node: the boxes of up to eight children as structure-of-arrays lanes, 256 bytes.
///
/// `bounds[axis]` holds the eight children's minima on `axis` and `bounds[3 + axis]` their
/// maxima, so a ray reads its near and far slab by an index fixed per ray (Embree's
/// `nearX`/`farX`) instead of choosing between them at every node.
///
/// Lane i is a child: interior (`count[i] == 0`, `child[i]` indexes `WideBvh::nodes`), a leaf
/// (`count[i] > 0` triangles from `child[i]`), or empty (`count[i] == 0` and `child[i] ==
/// EMPTY`; its box is inverted, min = +MAX, max = −MAX, so no ray overlaps it).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct WideNode {
    pub bounds: [Lanes; 6],
    pub child: [u32; WIDTH],
    pub count: [u32; WIDTH],
}

/// Marks an empty lane.
pub const EMPTY: u32 = u32::MAX;

/// The collapsed tree; node 0 is the root.
#[derive(Clone, Debug, Default)]
pub struct WideBvh {
    pub nodes: Vec<WideNode>,
}

fn surface_area(n: &BvhNode) -> f32 {
    let d = Vec3::from(n.bounds_max) - Vec3::from(n.bounds_min);
    2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
}

impl WideBvh {
    /// Collapses the flat binary tree: each wide node takes its binary node's two children
    /// and, while it has fewer than eight, replaces the interior child of largest surface
    /// area by that child's two children (the greedy collapse of Wald et al. 2008 §3).
    pub fn collapse(nodes: &[BvhNode]) -> WideBvh {
        let mut wide = WideBvh { nodes: Vec::with_capacity(nodes.len() / 2 + 1) };
        if nodes.is_empty() {
            return wide;
        }
        wide.collapse_node(nodes, 0);
        wide
    }

    /// Appends the wide node whose children are `binary`'s (or `binary` itself when it is a
    /// leaf, for a root leaf) and returns its index.
    fn collapse_node(&mut self, nodes: &[BvhNode], binary: u32) -> u32 {
        let node = &nodes[binary as usize];
        let mut lanes: Vec<u32> =
            if node.triangle_count() > 0 { vec![binary] } else { vec![binary + 1, node.offset] };
        while lanes.len() < WIDTH {
            let widest =
                lanes.iter().enumerate().filter(|(_, &n)| nodes[n as usize].triangle_count() == 0).max_by(
                    |a, b| {
                        surface_area(&nodes[*a.1 as usize]).total_cmp(&surface_area(&nodes[*b.1 as usize]))
                    },
                );
            let Some((i, &n)) = widest else { break };
            lanes.swap_remove(i);
            lanes.extend([n + 1, nodes[n as usize].offset]);
        }
        // Reserve this node's slot before its children append theirs; its boxes are set
        // once every lane is known.
        let index = self.nodes.len() as u32;
        self.nodes.push(WideNode {
            bounds: [Lanes::splat(0.0); 6],
            child: [EMPTY; WIDTH],
            count: [0; WIDTH],
        });
        // Empty lanes keep inverted boxes.
        let mut bounds = [
            [f32::MAX; WIDTH],
            [f32::MAX; WIDTH],
            [f32::MAX; WIDTH],
            [-f32::MAX; WIDTH],
            [-f32::MAX; WIDTH],
            [-f32::MAX; WIDTH],
        ];
        for (lane, &n) in lanes.iter().enumerate() {
            let child = &nodes[n as usize];
            let (child_index, count) = if child.triangle_count() > 0 {
                (child.offset, child.triangle_count())
            } else {
                (self.collapse_node(nodes, n), 0)
            };
            for axis in 0..3 {
                bounds[axis][lane] = child.bounds_min[axis];
                bounds[3 + axis][lane] = child.bounds_max[axis];
            }
            let w = &mut self.nodes[index as usize];
            w.child[lane] = child_index;
            w.count[lane] = count;
        }
        self.nodes[index as usize].bounds = bounds.map(Lanes::from_array);
        index
    }
}

/// Per-ray constants of the 8-wide box test.
struct RayWidePrecomp {
    origin: [Lanes; 3],
    inv_direction: [Lanes; 3],
    /// Per axis: the index in [`WideNode::bounds`] of the slab the ray enters by (the minimum
    /// when the direction is ≥ 0) and of the one it leaves by.
    near: [usize; 3],
    far: [usize; 3],
    /// Per axis: is the ray parallel to the slabs ([`crate::geometry::RayBoxPrecomp`]).
    parallel: [bool; 3],
}

impl RayWidePrecomp {
    fn new(ray: &Ray) -> RayWidePrecomp {
        let pre = crate::geometry::RayBoxPrecomp::new(ray);
        let parallel = pre.parallel.bitmask();
        let (o, inv) = (pre.origin, pre.inv_direction);
        // Written out per axis: as `[0, 1, 2].map(..)` the five arrays were an out-of-line
        // call per ray (~40 instructions of a Cornell-box ray's few hundred). Axis a's
        // minimum slab is bounds[a], its maximum bounds[3 + a].
        let positive = [inv.x >= 0.0, inv.y >= 0.0, inv.z >= 0.0];
        let near = |a: usize| if positive[a] { a } else { 3 + a };
        let far = |a: usize| if positive[a] { 3 + a } else { a };
        RayWidePrecomp {
            origin: [Lanes::splat(o.x), Lanes::splat(o.y), Lanes::splat(o.z)],
            inv_direction: [Lanes::splat(inv.x), Lanes::splat(inv.y), Lanes::splat(inv.z)],
            near: [near(0), near(1), near(2)],
            far: [far(0), far(1), far(2)],
            parallel: [parallel & 1 != 0, parallel & 2 != 0, parallel & 4 != 0],
        }
    }

    fn any_parallel(&self) -> bool {
        self.parallel.iter().any(|&p| p)
    }
}

/// Entry distances of the eight lanes (clamped to 0) and the mask of lanes the ray overlaps
/// within `(0, t_max)`: [`crate::geometry::box_entry`] on eight boxes at once. `PARALLEL`:
/// the ray is parallel to some axis's slabs, which are then tested by the origin (rare, so
/// the common case is compiled without that branch).
#[inline(always)]
fn wide_box_entry<const PARALLEL: bool>(pre: &RayWidePrecomp, t_max: f32, node: &WideNode) -> (Lanes, u32) {
    let mut t_near = Lanes::splat(0.0);
    let mut t_far = Lanes::splat(f32::MAX);
    for axis in 0..3 {
        let (near, far) = if PARALLEL && pre.parallel[axis] {
            let (min, max) = (node.bounds[axis], node.bounds[3 + axis]);
            let o = pre.origin[axis];
            let inside = o.cmpge(min).and(o.cmple(max));
            (
                Lanes::select(inside, Lanes::splat(f32::MIN), Lanes::splat(f32::MAX)),
                Lanes::select(inside, Lanes::splat(f32::MAX), Lanes::splat(f32::MIN)),
            )
        } else {
            (
                node.bounds[pre.near[axis]].sub(pre.origin[axis]).mul(pre.inv_direction[axis]),
                node.bounds[pre.far[axis]].sub(pre.origin[axis]).mul(pre.inv_direction[axis]),
            )
        };
        t_near = t_near.max(near);
        t_far = t_far.min(far);
    }
    let exit = t_far.mul(Lanes::splat(1.0 + 2.0 * gamma(3)));
    let within = t_near.mul(Lanes::splat(1.0 - 4.0 * gamma(3))).cmple(Lanes::splat(t_max));
    (t_near, t_near.cmple(exit).and(within).bitmask())
}

/// Visits the leaves the ray may touch; `visit(first, count, ray)` tests a leaf's triangles,
/// may shorten `ray.t_max`, and returns `true` to stop. A deferred child whose entry lies
/// beyond the nearest hit found meanwhile is dropped. `NEAREST_FIRST`: the overlapped
/// children of a node are visited nearer boxes first (closest-hit queries); without it in
/// lane order, which saves the sort where the answer does not depend on the order (any-hit
/// queries: shadow rays).
pub fn traverse_wide<const NEAREST_FIRST: bool>(
    bvh: &WideBvh,
    ray: &mut Ray,
    visit: impl FnMut(u32, u32, &mut Ray) -> bool,
) {
    if bvh.nodes.is_empty() {
        return;
    }
    let pre = RayWidePrecomp::new(ray);
    if pre.any_parallel() {
        traverse_wide_with::<true, NEAREST_FIRST>(bvh, &pre, ray, visit)
    } else {
        traverse_wide_with::<false, NEAREST_FIRST>(bvh, &pre, ray, visit)
    }
}

#[inline(always)]
fn traverse_wide_with<const PARALLEL: bool, const NEAREST_FIRST: bool>(
    bvh: &WideBvh,
    pre: &RayWidePrecomp,
    ray: &mut Ray,
    mut visit: impl FnMut(u32, u32, &mut Ray) -> bool,
) {
    // Each level defers at most WIDTH − 1 children, and the tree is no deeper than the
    // binary one. Left uninitialised (5.4 KB): zeroing the 4-wide tree's 2.3 KB stack took
    // 14% of a Cornell-box render.
    let mut stack = [const { MaybeUninit::<(u32, u32, f32)>::uninit() }; (WIDTH - 1) * MAX_DEPTH + 1];
    let mut sp = 0usize;
    let mut current = 0u32;
    loop {
        let node = &bvh.nodes[current as usize];
        let (entry, mut mask) = wide_box_entry::<PARALLEL>(pre, ray.t_max, node);
        if mask != 0 && mask & (mask - 1) == 0 {
            // One child overlapped (the common case below the top levels): go straight to
            // it, as pushing and popping it would.
            let lane = mask.trailing_zeros() as usize;
            if node.count[lane] == 0 {
                current = node.child[lane];
                continue;
            }
            if visit(node.child[lane], node.count[lane], ray) {
                return;
            }
        } else {
            let entry = entry.to_array();
            // Push the overlapped lanes farthest first, so the nearest is popped next.
            let base = sp;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let item = (node.child[lane], node.count[lane], entry[lane]);
                let mut i = sp;
                // SAFETY: entries below `sp` have all been written.
                while NEAREST_FIRST && i > base && unsafe { stack[i - 1].assume_init() }.2 < item.2 {
                    stack[i] = stack[i - 1];
                    i -= 1;
                }
                stack[i] = MaybeUninit::new(item);
                sp += 1;
            }
        }
        // The next deferred child (nearest first) that may still hold a nearer hit; leaves
        // are tested as they come off the stack.
        loop {
            if sp == 0 {
                return;
            }
            sp -= 1;
            // SAFETY: as above, `sp` < the number of entries written.
            let (child, count, child_entry) = unsafe { stack[sp].assume_init() };
            if !entry_within(child_entry, ray.t_max) {
                continue;
            }
            if count == 0 {
                current = child;
                break;
            }
            if visit(child, count, ray) {
                return;
            }
        }
    }
}
