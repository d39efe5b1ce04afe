//! The BVH's construction, written straight into the depth-first node array; each node's
//! split is chosen by the surface area heuristic ([`super::sah`]).
//!
//! The build keeps no pointer tree (pbrt-v4's `buildRecursive` allocates an interior node
//! per split and flattens afterwards): every subtree of n triangles owns 2n − 1 slots of
//! one array, its most nodes. Below [`PARALLEL_THRESHOLD`] triangles a subtree is built
//! sequentially into its slots, depth-first; above it the two children are built on
//! different threads into theirs. One pass at the end closes the gaps ([`Subtree::compact`]).

use std::time::Instant;

use glam::Vec3;

use super::sah::{decide, Decision, Primitive, Split, MEDIAN_SPLIT_DEPTH, TRAVERSAL_COST};
use crate::scene::layout::BvhNode;

/// The deepest a tree built here can be (root = depth 1).
pub const MAX_DEPTH: usize = MEDIAN_SPLIT_DEPTH + 32;
/// Subtrees with more triangles than this are built in parallel.
const PARALLEL_THRESHOLD: usize = 4096;

/// A flattened BVH and the triangle order it refers to.
#[derive(Clone, Debug)]
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    /// `order[i]` is the input index of the triangle stored at position `i`.
    pub order: Vec<u32>,
    pub stats: BvhStats,
}

#[derive(Clone, Copy, Debug, Default)]
pub struct BvhStats {
    pub triangles: usize,
    pub nodes: usize,
    pub leaves: usize,
    pub max_depth: usize,
    /// Expected cost of a random ray under the SAH model (traversal steps cost
    /// `TRAVERSAL_COST`, triangle tests 1), relative to the root's area.
    pub sah_cost: f64,
    pub build_seconds: f64,
}

impl BvhStats {
    fn add(&mut self, other: &BvhStats) {
        self.leaves += other.leaves;
        self.max_depth = self.max_depth.max(other.max_depth);
        self.sah_cost += other.sah_cost;
    }
}

/// Builds the BVH over `triangles` (three vertices each). Requires at least one triangle.
pub fn build(triangles: &[[Vec3; 3]]) -> Bvh {
    let start = Instant::now();
    assert!(!triangles.is_empty(), "a BVH needs at least one triangle");
    assert!(triangles.len() <= u32::MAX as usize, "triangle indices are 32-bit");
    let mut prims: Vec<Primitive> =
        triangles.iter().enumerate().map(|(i, t)| Primitive::new(t, i as u32)).collect();
    let root = Split::of(&prims);
    let root_area = root.bounds.surface_area().max(f32::MIN_POSITIVE) as f64;
    // Every subtree of n triangles gets 2n − 1 slots, its most nodes, so parallel subtrees
    // write straight into disjoint parts of the final array; one pass then closes the gaps.
    // The allocation is zeroed by the kernel as pages are first written, so slots no node
    // lands in cost nothing (a copy into a fresh array cost 15% of the build in page faults).
    let mut nodes: Vec<BvhNode> = bytemuck::allocation::zeroed_vec(2 * triangles.len() - 1);
    let tree = build_subtree(&mut prims, root, 0, 1, root_area, &mut nodes, 0);
    let mut stats = BvhStats { triangles: triangles.len(), ..Default::default() };
    let len = tree.compact(&mut nodes, 0, &mut stats);
    nodes.truncate(len);
    nodes.shrink_to_fit();
    let order: Vec<u32> = prims.iter().map(Primitive::index).collect();
    stats.nodes = nodes.len();
    stats.build_seconds = start.elapsed().as_secs_f64();
    Bvh { nodes, order, stats }
}

/// A subtree built sequentially: its nodes, depth-first from `nodes[0]`, with interior
/// offsets relative to `nodes[0]`, and their statistics.
struct Chunk<'a> {
    nodes: &'a mut [BvhNode],
    len: usize,
    stats: BvhStats,
}

impl Chunk<'_> {
    fn push(&mut self, node: BvhNode, stats: BvhStats) -> usize {
        self.nodes[self.len] = node;
        self.stats.add(&stats);
        self.len += 1;
        self.len - 1
    }
}

/// Where a subtree's nodes were written in the array (indices into the whole array).
enum Subtree {
    /// `len` nodes from `start`, depth-first, interior offsets relative to `start`.
    Chunk { start: usize, len: usize, stats: BvhStats },
    /// A node at `start` whose children were built on different threads, in the slots after
    /// it; its second child's offset is set by [`Subtree::compact`].
    Fork { start: usize, stats: BvhStats, children: Box<[Subtree; 2]> },
}

impl Subtree {
    /// Moves the subtree's nodes down to `cursor` and on, depth-first, setting the offsets
    /// for where they land; returns the slot after the last. Subtrees lie in depth-first
    /// order and no subtree fills more than its slots, so a subtree's nodes never lie before
    /// `cursor` and moving them overwrites only slots already moved from.
    fn compact(self, nodes: &mut [BvhNode], cursor: usize, stats: &mut BvhStats) -> usize {
        match self {
            Subtree::Chunk { start, len, stats: own } => {
                nodes.copy_within(start..start + len, cursor);
                for n in &mut nodes[cursor..cursor + len] {
                    if n.triangle_count() == 0 {
                        n.offset += cursor as u32;
                    }
                }
                stats.add(&own);
                cursor + len
            }
            Subtree::Fork { start, stats: own, children } => {
                nodes[cursor] = nodes[start];
                stats.add(&own);
                let [first, second] = *children;
                let second_start = first.compact(nodes, cursor + 1, stats);
                nodes[cursor].offset = second_start as u32;
                second.compact(nodes, second_start, stats)
            }
        }
    }
}

/// Builds the subtree over `prims` into `slots` (2n − 1 of them), which start at index
/// `slots_start` of the whole array.
fn build_subtree(
    prims: &mut [Primitive],
    split: Split,
    offset: usize,
    depth: usize,
    root_area: f64,
    slots: &mut [BvhNode],
    slots_start: usize,
) -> Subtree {
    let n = prims.len();
    if n <= PARALLEL_THRESHOLD {
        let mut chunk = Chunk { nodes: slots, len: 0, stats: BvhStats::default() };
        build_sequential(prims, split, offset, depth, root_area, &mut chunk);
        return Subtree::Chunk { start: slots_start, len: chunk.len, stats: chunk.stats };
    }
    match decide(prims, &split, depth) {
        Decision::Leaf => {
            let (node, stats) = leaf(&split, offset, n, depth, root_area);
            slots[0] = node;
            Subtree::Chunk { start: slots_start, len: 1, stats }
        }
        Decision::Interior { mid, axis, left: left_split, right: right_split } => {
            let (node, stats) = interior(&split, axis, depth, root_area);
            slots[0] = node;
            let (left_slots, right_slots) = slots[1..].split_at_mut(2 * mid - 1);
            let (left, right) = prims.split_at_mut(mid);
            let (l, r) = rayon::join(
                || build_subtree(left, left_split, offset, depth + 1, root_area, left_slots, slots_start + 1),
                || {
                    build_subtree(
                        right,
                        right_split,
                        offset + mid,
                        depth + 1,
                        root_area,
                        right_slots,
                        slots_start + 2 * mid,
                    )
                },
            );
            Subtree::Fork { start: slots_start, stats, children: Box::new([l, r]) }
        }
    }
}

fn build_sequential(
    prims: &mut [Primitive],
    split: Split,
    offset: usize,
    depth: usize,
    root_area: f64,
    chunk: &mut Chunk,
) {
    match decide(prims, &split, depth) {
        Decision::Leaf => {
            let (node, stats) = leaf(&split, offset, prims.len(), depth, root_area);
            chunk.push(node, stats);
        }
        Decision::Interior { mid, axis, left: left_split, right: right_split } => {
            let (node, stats) = interior(&split, axis, depth, root_area);
            let index = chunk.push(node, stats);
            let (left, right) = prims.split_at_mut(mid);
            build_sequential(left, left_split, offset, depth + 1, root_area, chunk);
            chunk.nodes[index].offset = chunk.len as u32;
            build_sequential(right, right_split, offset + mid, depth + 1, root_area, chunk);
        }
    }
}

/// Relative SAH weight of a node: its area over the root's.
fn weight(split: &Split, root_area: f64) -> f64 {
    split.bounds.surface_area() as f64 / root_area
}

/// A leaf over `count` triangles from `first`, and its statistics.
fn leaf(split: &Split, first: usize, count: usize, depth: usize, root_area: f64) -> (BvhNode, BvhStats) {
    let mut node = split.bounds.node();
    node.offset = first as u32;
    node.count_axis = count as u32;
    let stats = BvhStats {
        leaves: 1,
        max_depth: depth,
        sah_cost: weight(split, root_area) * count as f64,
        ..Default::default()
    };
    (node, stats)
}

/// An interior node (its second child's offset is filled in later) and its statistics.
fn interior(split: &Split, axis: usize, depth: usize, root_area: f64) -> (BvhNode, BvhStats) {
    let mut node = split.bounds.node();
    node.count_axis = (axis as u32) << 16;
    let stats = BvhStats {
        max_depth: depth,
        sah_cost: weight(split, root_area) * TRAVERSAL_COST as f64,
        ..Default::default()
    };
    (node, stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::sah::tests::random_prims;

    /// Walks the tree from the root: every node is reached once, children lie inside their
    /// parents, leaves cover every triangle once and bound their own, and the statistics
    /// count what is there.
    fn check_structure(triangles: &[[Vec3; 3]], bvh: &Bvh) {
        let nodes = &bvh.nodes;
        let mut seen = vec![false; nodes.len()];
        let mut covered = vec![false; triangles.len()];
        let (mut leaves, mut max_depth) = (0, 0);
        let mut stack = vec![(0usize, 1usize)];
        while let Some((i, depth)) = stack.pop() {
            assert!(!seen[i], "node {i} reached twice");
            seen[i] = true;
            max_depth = max_depth.max(depth);
            let node = &nodes[i];
            let (lo, hi) = (Vec3::from(node.bounds_min), Vec3::from(node.bounds_max));
            let count = node.triangle_count() as usize;
            if count > 0 {
                leaves += 1;
                for slot in node.offset as usize..node.offset as usize + count {
                    assert!(!covered[slot], "triangle slot {slot} in two leaves");
                    covered[slot] = true;
                    for v in triangles[bvh.order[slot] as usize] {
                        assert!(
                            v.cmpge(lo).all() && v.cmple(hi).all(),
                            "leaf {i} does not bound its triangle"
                        );
                    }
                }
            } else {
                let second = node.offset as usize;
                assert!(second > i + 1 && second < nodes.len(), "node {i}: second child {second}");
                for child in [i + 1, second] {
                    let c = &nodes[child];
                    assert!(
                        Vec3::from(c.bounds_min).cmpge(lo).all() && Vec3::from(c.bounds_max).cmple(hi).all(),
                        "child {child} outside its parent {i}"
                    );
                    stack.push((child, depth + 1));
                }
            }
        }
        assert!(seen.iter().all(|&s| s), "unreachable nodes");
        assert!(covered.iter().all(|&c| c), "triangles in no leaf");
        assert_eq!(
            (leaves, max_depth, nodes.len()),
            (bvh.stats.leaves, bvh.stats.max_depth, bvh.stats.nodes)
        );
    }

    #[test]
    fn parallel_subtrees_compact_into_one_valid_tree() {
        // Far above PARALLEL_THRESHOLD, so subtrees are built on several threads into
        // their own slots and moved together; and small trees, built in one chunk.
        for (seed, n) in [(1, 40_000), (2, 9_000), (3, 4_097), (4, 1), (5, 2), (6, 100)] {
            let prims = random_prims(seed, n);
            let triangles: Vec<[Vec3; 3]> = prims
                .iter()
                .map(|p| {
                    let (lo, hi) = (p.lo.truncate(), p.hi.truncate());
                    [lo, hi, Vec3::new(lo.x, hi.y, lo.z)]
                })
                .collect();
            let bvh = build(&triangles);
            check_structure(&triangles, &bvh);
        }
    }
}
