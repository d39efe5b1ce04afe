//! Binned SAH construction (Wald 2007, "On fast Construction of SAH-based Bounding Volume
//! Hierarchies"; pbrt-v4 §7.3.2), then depth-first flattening.

use std::time::Instant;

use glam::Vec3;

use crate::geometry::Aabb;
use crate::scene::layout::BvhNode;

/// SAH bins per split axis.
const BIN_COUNT: usize = 16;
/// Most triangles a leaf may hold.
const MAX_LEAF_TRIANGLES: usize = 8;
/// SAH cost of one traversal step relative to one triangle test (pbrt-v4 uses ½).
const TRAVERSAL_COST: f32 = 0.5;
/// Beyond this depth nodes split at the object median, which halves the count at every
/// level; so no tree is deeper than this plus log₂(2³²) = 32 levels, which bounds the
/// traversal stack.
const MEDIAN_SPLIT_DEPTH: usize = 32;
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

#[derive(Clone, Copy)]
struct Primitive {
    bounds: Aabb,
    centroid: Vec3,
    index: u32,
}

enum BuildNode {
    Leaf { bounds: Aabb, first: usize, count: usize },
    Interior { bounds: Aabb, axis: usize, children: Box<[BuildNode; 2]> },
}

impl BuildNode {
    fn bounds(&self) -> Aabb {
        match self {
            BuildNode::Leaf { bounds, .. } | BuildNode::Interior { bounds, .. } => *bounds,
        }
    }
}

/// Builds the BVH over `triangles` (three vertices each). Requires at least one triangle.
pub fn build(triangles: &[[Vec3; 3]]) -> Bvh {
    let start = Instant::now();
    assert!(!triangles.is_empty(), "a BVH needs at least one triangle");
    let mut prims: Vec<Primitive> = triangles
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let bounds = Aabb::from_point(t[0]).grow(t[1]).grow(t[2]);
            Primitive { bounds, centroid: bounds.centroid(), index: i as u32 }
        })
        .collect();
    let bounds = bounds_of(&prims);
    let centroid_bounds = centroid_bounds_of(&prims);
    let root = build_recursive(&mut prims, Split { bounds, centroid_bounds }, 0, 1);
    let order: Vec<u32> = prims.iter().map(|p| p.index).collect();
    let mut nodes = Vec::with_capacity(2 * triangles.len());
    let mut stats = BvhStats { triangles: triangles.len(), ..Default::default() };
    let root_area = root.bounds().surface_area().max(f32::MIN_POSITIVE) as f64;
    flatten(&root, &mut nodes, 1, root_area, &mut stats);
    stats.nodes = nodes.len();
    stats.build_seconds = start.elapsed().as_secs_f64();
    Bvh { nodes, order, stats }
}

fn bounds_of(prims: &[Primitive]) -> Aabb {
    prims.iter().fold(Aabb::EMPTY, |b, p| b.union(p.bounds))
}

fn centroid_bounds_of(prims: &[Primitive]) -> Aabb {
    prims.iter().fold(Aabb::EMPTY, |b, p| b.grow(p.centroid))
}

/// A node's primitives' bounds and their centroids' bounds. The parent's split computes
/// both for its children while it partitions, so no node makes its own passes for them
/// (they were two of the four passes per node).
#[derive(Clone, Copy)]
struct Split {
    bounds: Aabb,
    centroid_bounds: Aabb,
}

/// Both children's [`Split`]s, from the primitives either side of `mid`.
fn splits_of(prims: &[Primitive], mid: usize) -> (Split, Split) {
    let (l, r) = prims.split_at(mid);
    (
        Split { bounds: bounds_of(l), centroid_bounds: centroid_bounds_of(l) },
        Split { bounds: bounds_of(r), centroid_bounds: centroid_bounds_of(r) },
    )
}

fn build_recursive(prims: &mut [Primitive], node: Split, offset: usize, depth: usize) -> BuildNode {
    let Split { bounds, centroid_bounds } = node;
    let n = prims.len();
    if n == 1 {
        return BuildNode::Leaf { bounds, first: offset, count: 1 };
    }
    let axis = centroid_bounds.max_extent_axis();
    let (c_min, c_max) = (centroid_bounds.min[axis], centroid_bounds.max[axis]);

    let (mid, (left_split, right_split)) = if c_max <= c_min {
        // All centroids coincide: no split separates them. Keep small sets as a leaf and
        // halve large ones arbitrarily so leaves stay bounded.
        if n <= MAX_LEAF_TRIANGLES {
            return BuildNode::Leaf { bounds, first: offset, count: n };
        }
        (n / 2, splits_of(prims, n / 2))
    } else if depth >= MEDIAN_SPLIT_DEPTH {
        let mid = median_split(prims, axis);
        (mid, splits_of(prims, mid))
    } else {
        match sah_split(prims, &bounds, axis, c_min, c_max) {
            Some(split) => split,
            None => return BuildNode::Leaf { bounds, first: offset, count: n },
        }
    };

    let (left, right) = prims.split_at_mut(mid);
    let (l, r) = if n > PARALLEL_THRESHOLD {
        rayon::join(
            || build_recursive(left, left_split, offset, depth + 1),
            || build_recursive(right, right_split, offset + mid, depth + 1),
        )
    } else {
        (
            build_recursive(left, left_split, offset, depth + 1),
            build_recursive(right, right_split, offset + mid, depth + 1),
        )
    };
    BuildNode::Interior { bounds, axis, children: Box::new([l, r]) }
}

fn median_split(prims: &mut [Primitive], axis: usize) -> usize {
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
    mid
}

/// Partitions `prims` at the best binned-SAH plane and returns the split index with both
/// children's [`Split`]s, or `None` when a leaf is cheaper (and allowed).
fn sah_split(
    prims: &mut [Primitive],
    bounds: &Aabb,
    axis: usize,
    c_min: f32,
    c_max: f32,
) -> Option<(usize, (Split, Split))> {
    let n = prims.len();
    let scale = BIN_COUNT as f32 / (c_max - c_min);
    let bin_of = |c: f32| (((c - c_min) * scale) as usize).min(BIN_COUNT - 1);
    let mut counts = [0usize; BIN_COUNT];
    let mut bin_bounds = [Aabb::EMPTY; BIN_COUNT];
    for p in prims.iter() {
        let b = bin_of(p.centroid[axis]);
        counts[b] += 1;
        bin_bounds[b] = bin_bounds[b].union(p.bounds);
    }
    // Sweep from the right to get the area and count of every right-hand side, then from
    // the left, costing each of the BIN_COUNT − 1 planes.
    let mut right_area = [0.0f32; BIN_COUNT];
    let mut right_count = [0usize; BIN_COUNT];
    let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
    for i in (1..BIN_COUNT).rev() {
        acc = acc.union(bin_bounds[i]);
        cnt += counts[i];
        right_area[i] = acc.surface_area();
        right_count[i] = cnt;
    }
    let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
    let mut best = (f32::INFINITY, 0usize);
    for i in 0..BIN_COUNT - 1 {
        acc = acc.union(bin_bounds[i]);
        cnt += counts[i];
        if cnt == 0 || right_count[i + 1] == 0 {
            continue;
        }
        let cost = cnt as f32 * acc.surface_area() + right_count[i + 1] as f32 * right_area[i + 1];
        if cost < best.0 {
            best = (cost, i);
        }
    }
    let area = bounds.surface_area().max(f32::MIN_POSITIVE);
    let split_cost = TRAVERSAL_COST + best.0 / area;
    let leaf_cost = n as f32;
    let median = |prims: &mut [Primitive]| {
        let mid = median_split(prims, axis);
        (mid, splits_of(prims, mid))
    };
    if best.0.is_infinite() {
        // Every centroid fell into one bin (a tiny spread at large magnitude): split evenly.
        return Some(median(prims));
    }
    if n <= MAX_LEAF_TRIANGLES && leaf_cost <= split_cost {
        return None;
    }
    // Partition, growing each side's centroid bounds on the way; each side's bounds are
    // the union of its bins.
    let split_bin = best.1;
    let mut mid = 0;
    let (mut left_centroids, mut right_centroids) = (Aabb::EMPTY, Aabb::EMPTY);
    for i in 0..n {
        let c = prims[i].centroid;
        if bin_of(c[axis]) <= split_bin {
            prims.swap(i, mid);
            mid += 1;
            left_centroids = left_centroids.grow(c);
        } else {
            right_centroids = right_centroids.grow(c);
        }
    }
    if mid == 0 || mid == n {
        return Some(median(prims));
    }
    let left_bounds = bin_bounds[..=split_bin].iter().fold(Aabb::EMPTY, |b, &x| b.union(x));
    let right_bounds = bin_bounds[split_bin + 1..].iter().fold(Aabb::EMPTY, |b, &x| b.union(x));
    Some((
        mid,
        (
            Split { bounds: left_bounds, centroid_bounds: left_centroids },
            Split { bounds: right_bounds, centroid_bounds: right_centroids },
        ),
    ))
}

/// Appends `node` and its subtree depth-first; returns the node's index.
fn flatten(
    node: &BuildNode,
    out: &mut Vec<BvhNode>,
    depth: usize,
    root_area: f64,
    stats: &mut BvhStats,
) -> usize {
    let index = out.len();
    let b = node.bounds();
    let rel_area = b.surface_area() as f64 / root_area;
    stats.max_depth = stats.max_depth.max(depth);
    out.push(BvhNode { bounds_min: b.min.to_array(), bounds_max: b.max.to_array(), ..Default::default() });
    match node {
        BuildNode::Leaf { first, count, .. } => {
            stats.leaves += 1;
            stats.sah_cost += rel_area * *count as f64;
            out[index].offset = *first as u32;
            out[index].count_axis = *count as u32;
        }
        BuildNode::Interior { axis, children, .. } => {
            stats.sah_cost += rel_area * TRAVERSAL_COST as f64;
            flatten(&children[0], out, depth + 1, root_area, stats);
            let second = flatten(&children[1], out, depth + 1, root_area, stats);
            out[index].offset = second as u32;
            out[index].count_axis = (*axis as u32) << 16;
        }
    }
    index
}
