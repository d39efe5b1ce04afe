//! Binned SAH construction (Wald 2007, "On fast Construction of SAH-based Bounding Volume
//! Hierarchies"; pbrt-v4 §7.3.2), written straight into the depth-first node array.
//!
//! The build keeps no pointer tree (pbrt-v4's `buildRecursive` allocates an interior node
//! per split and flattens afterwards): every subtree of n triangles owns 2n − 1 slots of
//! one array, its most nodes. Below [`PARALLEL_THRESHOLD`] triangles a subtree is built
//! sequentially into its slots, depth-first; above it the two children are built on
//! different threads into theirs. One pass at the end closes the gaps ([`Subtree::compact`]).
//! Primitives are 32-byte records of two 4-wide vectors so that the per-primitive work of
//! binning and partitioning, which dominates the build, is a handful of SIMD operations.
//! Nodes of at most [`SMALL_NODE`] triangles skip binning: they sort their few primitives
//! and price every cut exactly ([`small_split`]).

use std::time::Instant;

use glam::{Vec3, Vec4};

use crate::geometry::Aabb;
use crate::scene::layout::BvhNode;

/// SAH bins per split axis.
const BIN_COUNT: usize = 16;
/// Most triangles a leaf may hold.
const MAX_LEAF_TRIANGLES: usize = 8;
/// SAH cost of one traversal step relative to one triangle test (pbrt-v4 uses ½).
const TRAVERSAL_COST: f32 = 0.5;
/// Beyond this depth nodes split at the object median, which halves the count at every
/// level; so no tree is deeper than this plus log₂(2³²) = 32 levels, which bounds the CPU's
/// traversal stack and the GPU's 64-bit restart trail.
const MEDIAN_SPLIT_DEPTH: usize = 32;
/// The deepest a tree built here can be (root = depth 1).
pub const MAX_DEPTH: usize = MEDIAN_SPLIT_DEPTH + 32;
/// Nodes with at least this many triangles bin into [`BIN_SETS`] sets of bins (see
/// [`cheapest_plane`]); below it merging the sets costs more than it saves.
const LARGE_NODE: usize = 256;
const BIN_SETS: usize = 2;
/// Nodes with at most this many triangles choose their split by the exact sweep over their
/// sorted primitives ([`small_split`]) instead of by binning.
const SMALL_NODE: usize = 8;
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

/// An axis-aligned box in the x, y, z lanes of two 4-wide vectors; the w lanes carry
/// whatever the boxes it was grown from carried and are never read.
#[derive(Clone, Copy)]
struct Bounds4 {
    min: Vec4,
    max: Vec4,
}

impl Bounds4 {
    const EMPTY: Bounds4 = Bounds4 { min: Vec4::splat(f32::INFINITY), max: Vec4::splat(f32::NEG_INFINITY) };

    #[inline(always)]
    fn union(self, other: Bounds4) -> Bounds4 {
        Bounds4 { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    #[inline(always)]
    fn grow(self, p: Vec4) -> Bounds4 {
        Bounds4 { min: self.min.min(p), max: self.max.max(p) }
    }

    /// The box as the crate's box type, whose area and longest axis the SAH uses.
    #[inline(always)]
    fn aabb(&self) -> Aabb {
        Aabb { min: self.min.truncate(), max: self.max.truncate() }
    }

    #[inline(always)]
    fn surface_area(&self) -> f32 {
        self.aabb().surface_area()
    }

    fn node(&self) -> BvhNode {
        let b = self.aabb();
        BvhNode { bounds_min: b.min.to_array(), bounds_max: b.max.to_array(), ..Default::default() }
    }
}

/// A triangle's box, 32 bytes: `lo.xyz` and `hi.xyz` are its bounds, and `lo.w` carries
/// the triangle's input index as raw bits (Embree's `PrimRef` keeps its primitive ID in the
/// same place), so one record moves in the partition and no index array moves beside it.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Primitive {
    lo: Vec4,
    hi: Vec4,
}

impl Primitive {
    fn new(t: &[Vec3; 3], index: u32) -> Primitive {
        let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
        Primitive { lo: lo.extend(f32::from_bits(index)), hi: hi.extend(0.0) }
    }

    fn index(&self) -> u32 {
        self.lo.w.to_bits()
    }

    fn bounds(&self) -> Bounds4 {
        Bounds4 { min: self.lo, max: self.hi }
    }

    /// Twice the box's centre, min + max. Doubling is exact in floating point, so every
    /// comparison, bin index and axis choice made on it is the one the centroid itself
    /// would give (bins: (2c − 2c₀)·(s/2) rounds as (c − c₀)·s does), without a multiply
    /// per primitive per level.
    #[inline(always)]
    fn centroid2(&self) -> Vec4 {
        self.lo + self.hi
    }
}

/// A node's primitives' bounds and the bounds of their doubled centroids. The parent's
/// split gathers both for its children per bin while it bins, so no node makes its own
/// passes for them.
#[derive(Clone, Copy)]
struct Split {
    bounds: Bounds4,
    centroid_bounds: Bounds4,
}

impl Split {
    fn of(prims: &[Primitive]) -> Split {
        prims.iter().fold(Split { bounds: Bounds4::EMPTY, centroid_bounds: Bounds4::EMPTY }, |s, p| Split {
            bounds: s.bounds.union(p.bounds()),
            centroid_bounds: s.centroid_bounds.grow(p.centroid2()),
        })
    }
}

/// What a node becomes.
enum Decision {
    Leaf,
    /// Split at `mid` (the primitives are partitioned already) along `axis`.
    Interior {
        mid: usize,
        axis: usize,
        left: Split,
        right: Split,
    },
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

/// Chooses between a leaf and a split, and partitions for a split.
fn decide(prims: &mut [Primitive], split: &Split, depth: usize) -> Decision {
    let n = prims.len();
    if n == 1 {
        return Decision::Leaf;
    }
    let axis = split.centroid_bounds.aabb().max_extent_axis();
    let (c_min, c_max) = (split.centroid_bounds.min[axis], split.centroid_bounds.max[axis]);
    if c_max <= c_min {
        // All centroids coincide: no split separates them. Keep small sets as a leaf and
        // halve large ones arbitrarily so leaves stay bounded.
        if n <= MAX_LEAF_TRIANGLES {
            return Decision::Leaf;
        }
        return split_at(prims, n / 2, axis);
    }
    if depth >= MEDIAN_SPLIT_DEPTH {
        return split_at_median(prims, axis);
    }
    match axis {
        0 => sah_split::<0>(prims, &split.bounds, c_min, c_max),
        1 => sah_split::<1>(prims, &split.bounds, c_min, c_max),
        _ => sah_split::<2>(prims, &split.bounds, c_min, c_max),
    }
}

/// A split at `mid`, both sides' bounds gathered from their primitives.
fn split_at(prims: &[Primitive], mid: usize, axis: usize) -> Decision {
    let (left, right) = prims.split_at(mid);
    Decision::Interior { mid, axis, left: Split::of(left), right: Split::of(right) }
}

/// A split at the object median along `axis`.
fn split_at_median(prims: &mut [Primitive], axis: usize) -> Decision {
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |a, b| a.centroid2()[axis].total_cmp(&b.centroid2()[axis]));
    split_at(prims, mid, axis)
}

/// The doubled centroid's component on `AXIS` (a constant, so this is one lane extract).
#[inline(always)]
fn lane<const AXIS: usize>(v: Vec4) -> f32 {
    match AXIS {
        0 => v.x,
        1 => v.y,
        _ => v.z,
    }
}

/// Which of the BIN_COUNT bins along `AXIS` a primitive falls in: bin i holds the doubled
/// centroids c with ⌊(c − c_min)·scale⌋ = i, the last bin also the far edge.
#[derive(Clone, Copy)]
struct Binning<const AXIS: usize> {
    c_min: f32,
    scale: f32,
}

impl<const AXIS: usize> Binning<AXIS> {
    fn new(c_min: f32, c_max: f32) -> Self {
        Binning { c_min, scale: BIN_COUNT as f32 / (c_max - c_min) }
    }

    /// (c − c_min)·scale, whose floor is the bin.
    #[inline(always)]
    fn offset(&self, p: &Primitive) -> f32 {
        // The lane of lo + hi, added as scalars (the same sum) so that the partition, which
        // copies whole records, reads only these two floats besides its 32-byte moves.
        (lane::<AXIS>(p.lo) + lane::<AXIS>(p.hi) - self.c_min) * self.scale
    }

    /// The float-to-int cast saturates (NaN to 0), so the index is in range.
    #[inline(always)]
    fn bin(&self, p: &Primitive) -> usize {
        (self.offset(p) as u32 as usize).min(BIN_COUNT - 1)
    }
}

/// The cheapest plane between bins: its cost (each side's triangle count times its area,
/// summed), the last bin on its left, and both sides' bounds and centroid bounds. The
/// centroid bounds come from per-bin boxes of the centroids, exact since every centroid of
/// a side lies in one of its bins; gathering them while binning rather than while
/// partitioning costs two vector operations per primitive instead of eight (the
/// partition's per-side selects), which made the whole build about 3% faster.
struct Plane {
    cost: f32,
    last_left_bin: usize,
    left: Bounds4,
    right: Bounds4,
    left_centroids: Bounds4,
    right_centroids: Bounds4,
}

/// Finds the cheapest of the BIN_COUNT − 1 planes on `AXIS` and partitions there; a leaf
/// where that is cheaper (and allowed); the object median where no plane separates the
/// primitives (every centroid in one bin: a tiny spread at large magnitude). Nodes of at
/// most [`SMALL_NODE`] primitives are priced exactly instead ([`small_split`]).
fn sah_split<const AXIS: usize>(
    prims: &mut [Primitive],
    bounds: &Bounds4,
    c_min: f32,
    c_max: f32,
) -> Decision {
    let n = prims.len();
    if n <= SMALL_NODE {
        return small_split::<AXIS>(prims, bounds);
    }
    let binning = Binning::<AXIS>::new(c_min, c_max);
    let plane = cheapest_plane(prims, binning);
    let Some(plane) = plane else {
        return split_at_median(prims, AXIS);
    };
    let area = bounds.surface_area().max(f32::MIN_POSITIVE);
    let split_cost = TRAVERSAL_COST + plane.cost / area;
    if n <= MAX_LEAF_TRIANGLES && n as f32 <= split_cost {
        return Decision::Leaf;
    }
    let mid = partition(prims, binning, plane.last_left_bin);
    if mid == 0 || mid == n {
        return split_at_median(prims, AXIS);
    }
    Decision::Interior {
        mid,
        axis: AXIS,
        left: Split { bounds: plane.left, centroid_bounds: plane.left_centroids },
        right: Split { bounds: plane.right, centroid_bounds: plane.right_centroids },
    }
}

/// The split of a node of at most [`SMALL_NODE`] primitives: they are sorted by centroid
/// along `AXIS` and every one of the n − 1 places between neighbours is priced, which
/// includes every plane binning could choose (a plane cuts the sorted order somewhere), so
/// the choice costs no more than binning's. Binning has a fixed cost (sixteen bins to
/// clear and sweep) that dominates nodes this small, and most nodes are this small: on the
/// 1.04 M-triangle spheres, 0.85 M of the 1.03 M nodes of two triangles or more hold at
/// most eight. (The sort is on whole records: sorting keys and gathering after, or a
/// sorting network, measured slower for the two- to four-triangle nodes that dominate.)
fn small_split<const AXIS: usize>(prims: &mut [Primitive], bounds: &Bounds4) -> Decision {
    let n = prims.len();
    debug_assert!((2..=SMALL_NODE).contains(&n));
    // Insertion sort by the doubled centroid.
    let mut sorted = [Primitive { lo: Vec4::ZERO, hi: Vec4::ZERO }; SMALL_NODE];
    let mut keys = [0.0f32; SMALL_NODE];
    for (i, p) in prims.iter().enumerate() {
        let key = lane::<AXIS>(p.centroid2());
        let mut j = i;
        while j > 0 && keys[j - 1] > key {
            keys[j] = keys[j - 1];
            sorted[j] = sorted[j - 1];
            j -= 1;
        }
        keys[j] = key;
        sorted[j] = *p;
    }
    let sorted = &sorted[..n];
    // right_area[j]: the area of the box around sorted[j..].
    let mut right_area = [0.0f32; SMALL_NODE];
    let mut acc = Bounds4::EMPTY;
    for j in (1..n).rev() {
        acc = acc.union(sorted[j].bounds());
        right_area[j] = acc.surface_area();
    }
    // The first j primitives go left; the cheapest j, the first of equals.
    let (mut acc, mut best) = (Bounds4::EMPTY, (f32::INFINITY, n / 2));
    for j in 1..n {
        acc = acc.union(sorted[j - 1].bounds());
        let cost = j as f32 * acc.surface_area() + (n - j) as f32 * right_area[j];
        if cost < best.0 {
            best = (cost, j);
        }
    }
    // A NaN cost (a non-finite box) leaves `best` infinite, which makes a node of at most
    // MAX_LEAF_TRIANGLES a leaf and a larger one split the sorted order in half.
    let area = bounds.surface_area().max(f32::MIN_POSITIVE);
    if n <= MAX_LEAF_TRIANGLES && n as f32 <= TRAVERSAL_COST + best.0 / area {
        return Decision::Leaf;
    }
    prims.copy_from_slice(sorted);
    split_at(prims, best.1, AXIS)
}

/// The cheapest plane from BIN_COUNT bins, or `None` when no plane has primitives on both
/// sides.
fn cheapest_plane<const AXIS: usize>(prims: &[Primitive], binning: Binning<AXIS>) -> Option<Plane> {
    let mut counts = [0u32; BIN_COUNT];
    let mut bin_bounds = [Bounds4::EMPTY; BIN_COUNT];
    let mut bin_centroids = [Bounds4::EMPTY; BIN_COUNT];
    let bin = |p: &Primitive,
               counts: &mut [u32; BIN_COUNT],
               bin_bounds: &mut [Bounds4; BIN_COUNT],
               bin_centroids: &mut [Bounds4; BIN_COUNT]| {
        let b = binning.bin(p);
        counts[b] += 1;
        bin_bounds[b] = bin_bounds[b].union(p.bounds());
        bin_centroids[b] = bin_centroids[b].grow(p.centroid2());
    };
    if prims.len() < LARGE_NODE {
        prims.iter().for_each(|p| bin(p, &mut counts, &mut bin_bounds, &mut bin_centroids));
    } else {
        // Neighbouring primitives mostly share a bin, so with one set of bins each update
        // would wait for the previous one's store: consecutive primitives go to
        // BIN_SETS different sets, merged after.
        let mut sets =
            [([0u32; BIN_COUNT], [Bounds4::EMPTY; BIN_COUNT], [Bounds4::EMPTY; BIN_COUNT]); BIN_SETS];
        let mut groups = prims.chunks_exact(BIN_SETS);
        for group in &mut groups {
            for (p, (c, b, k)) in group.iter().zip(sets.iter_mut()) {
                bin(p, c, b, k);
            }
        }
        groups.remainder().iter().for_each(|p| bin(p, &mut counts, &mut bin_bounds, &mut bin_centroids));
        for (c, b, k) in &sets {
            for i in 0..BIN_COUNT {
                counts[i] += c[i];
                bin_bounds[i] = bin_bounds[i].union(b[i]);
                bin_centroids[i] = bin_centroids[i].union(k[i]);
            }
        }
    }
    // Only the occupied bins are swept. An empty bin changes no sum and no box, so a plane
    // after an empty bin costs exactly what the plane before it did, and only a strictly
    // cheaper plane replaces the best: skipping them changes no choice. Most nodes are
    // small (a node of three triangles fills at most three of the sixteen bins), and for
    // them sweeping every bin cost more than binning.
    let mut occupied = [0usize; BIN_COUNT];
    let mut m = 0;
    for (i, &count) in counts.iter().enumerate() {
        // Written unconditionally, kept when occupied: no branch to mispredict.
        occupied[m] = i;
        m += (count != 0) as usize;
    }
    let occupied = &occupied[..m];
    // right_area[j], right_count[j]: of the bins occupied[j..].
    let mut right_area = [0.0f32; BIN_COUNT];
    let mut right_count = [0u32; BIN_COUNT];
    let (mut acc, mut cnt) = (Bounds4::EMPTY, 0);
    for j in (1..m).rev() {
        acc = acc.union(bin_bounds[occupied[j]]);
        cnt += counts[occupied[j]];
        right_area[j] = acc.surface_area();
        right_count[j] = cnt;
    }
    let (mut acc, mut cnt) = (Bounds4::EMPTY, 0);
    let mut best = (f32::INFINITY, 0usize);
    for j in 0..m.saturating_sub(1) {
        acc = acc.union(bin_bounds[occupied[j]]);
        cnt += counts[occupied[j]];
        let cost = cnt as f32 * acc.surface_area() + right_count[j + 1] as f32 * right_area[j + 1];
        if cost < best.0 {
            best = (cost, j);
        }
    }
    if best.0.is_infinite() {
        return None;
    }
    let union_of = |boxes: &[Bounds4; BIN_COUNT], bins: &[usize]| {
        bins.iter().fold(Bounds4::EMPTY, |b, &i| b.union(boxes[i]))
    };
    let (lefts, rights) = (&occupied[..=best.1], &occupied[best.1 + 1..]);
    Some(Plane {
        cost: best.0,
        last_left_bin: occupied[best.1],
        left: union_of(&bin_bounds, lefts),
        right: union_of(&bin_bounds, rights),
        left_centroids: union_of(&bin_centroids, lefts),
        right_centroids: union_of(&bin_centroids, rights),
    })
}

/// Partitions in place so that the primitives in bins up to `last_left_bin` come first,
/// keeping their order; returns their count. A primitive goes left when its offset x has
/// ⌊x⌋ ≤ last_left_bin, that is when x ≥ last_left_bin + 1 is false (a NaN offset, bin 0,
/// goes left too), which needs no conversion to an integer.
///
/// Lomuto's scheme with a gap instead of swaps (the cyclic form of Bergdoll's branchless
/// Lomuto, as in Rust's `sort_unstable` since 1.81): the first right primitive is held out,
/// leaving a gap, and each later primitive p costs two plain copies whichever side it
/// goes, the first right one into the gap and p into its place, after which p's old slot
/// is the gap. Which side a primitive goes is a coin toss deep in the tree, so a branch
/// would mispredict; the swap form needed four selects and four stores of 16 bytes per
/// primitive instead of two 32-byte copies. The right side's order is a rotation of its
/// original order, not the original.
fn partition<const AXIS: usize>(
    prims: &mut [Primitive],
    binning: Binning<AXIS>,
    last_left_bin: usize,
) -> usize {
    let threshold = (last_left_bin + 1) as f32;
    let goes_right = |p: &Primitive| binning.offset(p) >= threshold;
    // The leading left primitives are in place already.
    let Some(first_right) = prims.iter().position(goes_right) else {
        return prims.len();
    };
    let held = prims[first_right];
    let (mut gap, mut mid) = (first_right, first_right);
    // Invariant: prims[..mid] are the left primitives so far in order, prims[mid..i] the
    // right ones but for the slot at `gap`, whose content is stale.
    for i in first_right + 1..prims.len() {
        let left = !goes_right(&prims[i]);
        prims[gap] = prims[mid];
        prims.copy_within(i..i + 1, mid);
        gap = i;
        mid += left as usize;
    }
    prims[gap] = prims[mid];
    prims[mid] = held;
    mid
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The textbook sweep over all BIN_COUNT − 1 planes (this builder's before occupied-bin
    /// sweeps): (cost, last left bin, left bounds, right bounds).
    fn reference_plane<const AXIS: usize>(
        prims: &[Primitive],
        binning: Binning<AXIS>,
    ) -> Option<(f32, usize, Bounds4, Bounds4)> {
        let mut counts = [0u32; BIN_COUNT];
        let mut bins = [Bounds4::EMPTY; BIN_COUNT];
        for p in prims {
            let b = binning.bin(p);
            counts[b] += 1;
            bins[b] = bins[b].union(p.bounds());
        }
        let mut best = None::<(f32, usize)>;
        for plane in 0..BIN_COUNT - 1 {
            let (l, r) = (&bins[..=plane], &bins[plane + 1..]);
            let (nl, nr): (u32, u32) = (counts[..=plane].iter().sum(), counts[plane + 1..].iter().sum());
            if nl == 0 || nr == 0 {
                continue;
            }
            let union = |b: &[Bounds4]| b.iter().fold(Bounds4::EMPTY, |a, &x| a.union(x));
            let cost = nl as f32 * union(l).surface_area() + nr as f32 * union(r).surface_area();
            if best.is_none_or(|(c, _)| cost < c) {
                best = Some((cost, plane));
            }
        }
        let (cost, plane) = best?;
        let union = |b: &[Bounds4]| b.iter().fold(Bounds4::EMPTY, |a, &x| a.union(x));
        Some((cost, plane, union(&bins[..=plane]), union(&bins[plane + 1..])))
    }

    fn xyz_bits(b: &Bounds4) -> [u32; 6] {
        let (lo, hi) = (b.min.truncate().to_array(), b.max.truncate().to_array());
        [lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]].map(f32::to_bits)
    }

    /// Random triangles in clusters, so that nodes have empty bins, crowded bins and ties.
    fn random_prims(seed: u64, n: usize) -> Vec<Primitive> {
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / (1u64 << 24) as f32
        };
        let clusters: Vec<Vec3> = (0..1 + n % 5).map(|_| Vec3::new(next(), next(), next()) * 10.0).collect();
        (0..n)
            .map(|i| {
                let c = clusters[i % clusters.len()] + Vec3::new(next(), next(), next());
                let t = [
                    c,
                    c + Vec3::new(next(), next(), next()) * 0.3,
                    c + Vec3::new(next(), 0.0, next()) * 0.3,
                ];
                Primitive::new(&t, i as u32)
            })
            .collect()
    }

    /// Unit triangles at x = 0, 1, …, k − 1, `copies` of each, in a scrambled order: with
    /// k − 1 dividing 8 every bin offset is an exact integer, so primitives sit exactly on
    /// bin boundaries, and the symmetric row makes planes cost exactly the same.
    fn lattice_prims(k: u32, copies: u32, seed: u64) -> Vec<Primitive> {
        let mut prims: Vec<Primitive> = (0..k * copies)
            .map(|j| {
                let x = (j % k) as f32;
                Primitive::new(
                    &[Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 0.0, 0.0), Vec3::new(x, 1.0, 0.0)],
                    j,
                )
            })
            .collect();
        let len = prims.len();
        for i in 0..len {
            prims.swap(i, (seed as usize * 7 + i * 13) % len);
        }
        prims
    }

    #[test]
    fn occupied_bin_sweep_and_branchless_partition_match_the_textbook_ones() {
        // Random clusters at sizes on both sides of LARGE_NODE (one set of bins or two) and
        // odd ones (a primitive left over after the pairs); then lattices with exact ties.
        let random = (0..400u64)
            .map(|s| (s, random_prims(s, [2, 3, 5, 8, 17, 64, 255, 256, 257, 701][s as usize % 10])));
        let lattices = [3, 5, 9, 17].into_iter().flat_map(|k| {
            (1..4).map(move |copies| (u64::from(k * copies), lattice_prims(k, copies, u64::from(k))))
        });
        for (seed, mut prims) in random.chain(lattices) {
            let n = prims.len();
            let split = Split::of(&prims);
            let axis = split.centroid_bounds.aabb().max_extent_axis();
            let (c_min, c_max) = (split.centroid_bounds.min[axis], split.centroid_bounds.max[axis]);
            assert!(c_max > c_min);
            macro_rules! check {
                ($axis:literal) => {{
                    let binning = Binning::<$axis>::new(c_min, c_max);
                    let plane = cheapest_plane(&prims, binning);
                    let reference = reference_plane(&prims, binning);
                    match (&plane, &reference) {
                        (None, None) => {}
                        (Some(p), Some(r)) => {
                            assert_eq!(p.cost.to_bits(), r.0.to_bits(), "seed {seed}, n {n}: cost");
                            assert_eq!(p.last_left_bin, r.1, "seed {seed}, n {n}: plane");
                            assert_eq!(xyz_bits(&p.left), xyz_bits(&r.2), "seed {seed}, n {n}: left bounds");
                            assert_eq!(
                                xyz_bits(&p.right),
                                xyz_bits(&r.3),
                                "seed {seed}, n {n}: right bounds"
                            );
                        }
                        _ => panic!("seed {seed}, n {n}: one sweep found a plane, the other none"),
                    }
                    if let Some(p) = plane {
                        // By bin index: the left primitives in their order, then the rest
                        // in some order.
                        let order = |v: &[Primitive]| v.iter().map(Primitive::index).collect::<Vec<_>>();
                        let goes_left = |q: &&Primitive| binning.bin(q) <= p.last_left_bin;
                        let expected_left: Vec<u32> =
                            prims.iter().filter(goes_left).map(Primitive::index).collect();
                        let mut expected_right: Vec<u32> =
                            prims.iter().filter(|q| !goes_left(q)).map(Primitive::index).collect();
                        let before = prims.clone();
                        let mid = partition(&mut prims, binning, p.last_left_bin);
                        assert_eq!(mid, expected_left.len(), "seed {seed}, n {n}: split index");
                        assert_eq!(order(&prims[..mid]), expected_left, "seed {seed}, n {n}: left order");
                        let mut right = order(&prims[mid..]);
                        right.sort_unstable();
                        expected_right.sort_unstable();
                        assert_eq!(right, expected_right, "seed {seed}, n {n}: right side");
                        // Whole records moved, not parts of them.
                        for q in &prims {
                            let original =
                                &before[before.iter().position(|b| b.index() == q.index()).unwrap()];
                            assert_eq!(
                                xyz_bits(&q.bounds()),
                                xyz_bits(&original.bounds()),
                                "seed {seed}, n {n}"
                            );
                        }
                        let (l, r) = (Split::of(&prims[..mid]), Split::of(&prims[mid..]));
                        // The sides' centroid bounds, gathered per bin while binning.
                        assert_eq!(xyz_bits(&p.left_centroids), xyz_bits(&l.centroid_bounds));
                        assert_eq!(xyz_bits(&p.right_centroids), xyz_bits(&r.centroid_bounds));
                    }
                }};
            }
            match axis {
                0 => check!(0),
                1 => check!(1),
                _ => check!(2),
            }
        }
    }

    /// The cheapest of the n − 1 cuts of `prims` sorted stably by doubled centroid on
    /// `axis`, priced one by one from scratch: (cost, primitives on the left).
    fn reference_small_split(prims: &[Primitive], axis: usize) -> (f32, usize) {
        let mut sorted = prims.to_vec();
        sorted.sort_by(|a, b| a.centroid2()[axis].total_cmp(&b.centroid2()[axis]));
        let area =
            |side: &[Primitive]| side.iter().fold(Bounds4::EMPTY, |b, p| b.union(p.bounds())).surface_area();
        let n = sorted.len();
        (1..n)
            .map(|j| (j as f32 * area(&sorted[..j]) + (n - j) as f32 * area(&sorted[j..]), j))
            .fold((f32::INFINITY, 0), |best, c| if c.0 < best.0 { c } else { best })
    }

    #[test]
    fn small_nodes_take_the_cheapest_cut_which_is_no_dearer_than_binning() {
        // Random clusters of every small size, and lattices whose centroids tie exactly.
        let random = (0..600u64).map(|s| random_prims(s, 2 + s as usize % (SMALL_NODE - 1)));
        let lattices = [(2, 1), (3, 2), (4, 2), (2, 4), (5, 1), (7, 1), (8, 1)]
            .into_iter()
            .map(|(k, copies)| lattice_prims(k, copies, u64::from(k)));
        let mut splits = 0;
        for (case, mut prims) in random.chain(lattices).enumerate() {
            let n = prims.len();
            assert!((2..=SMALL_NODE).contains(&n));
            let split = Split::of(&prims);
            let axis = split.centroid_bounds.aabb().max_extent_axis();
            let (c_min, c_max) = (split.centroid_bounds.min[axis], split.centroid_bounds.max[axis]);
            if c_max <= c_min {
                continue;
            }
            let (cost, cut) = reference_small_split(&prims, axis);
            // Binning's plane cuts the same sorted order between two different keys, and
            // prices that cut with the same f32 operations: it cannot be cheaper.
            let binned = match axis {
                0 => cheapest_plane(&prims, Binning::<0>::new(c_min, c_max)),
                1 => cheapest_plane(&prims, Binning::<1>::new(c_min, c_max)),
                _ => cheapest_plane(&prims, Binning::<2>::new(c_min, c_max)),
            };
            let binned = binned.expect("distinct centroids on the axis fill two bins");
            assert!(cost <= binned.cost, "case {case}: exact {cost} dearer than binned {}", binned.cost);
            let before: Vec<u32> = prims.iter().map(Primitive::index).collect();
            let decision = match axis {
                0 => small_split::<0>(&mut prims, &split.bounds),
                1 => small_split::<1>(&mut prims, &split.bounds),
                _ => small_split::<2>(&mut prims, &split.bounds),
            };
            let leaf_is_cheaper = n as f32 <= TRAVERSAL_COST + cost / split.bounds.surface_area();
            match decision {
                Decision::Leaf => {
                    assert!(leaf_is_cheaper, "case {case}: a leaf where the cut {cut} is cheaper");
                    let after: Vec<u32> = prims.iter().map(Primitive::index).collect();
                    assert_eq!(before, after, "case {case}: a leaf reordered its primitives");
                }
                Decision::Interior { mid, axis: split_axis, left, right } => {
                    splits += 1;
                    assert!(!leaf_is_cheaper, "case {case}: split where a leaf is no dearer");
                    assert_eq!((mid, split_axis), (cut, axis), "case {case}: cut");
                    let key = |p: &Primitive| p.centroid2()[axis];
                    let left_max = prims[..mid].iter().map(key).fold(f32::NEG_INFINITY, f32::max);
                    let right_min = prims[mid..].iter().map(key).fold(f32::INFINITY, f32::min);
                    assert!(left_max <= right_min, "case {case}: sides overlap on the axis");
                    let mut after: Vec<u32> = prims.iter().map(Primitive::index).collect();
                    let mut sorted_before = before.clone();
                    after.sort_unstable();
                    sorted_before.sort_unstable();
                    assert_eq!(after, sorted_before, "case {case}: primitives lost or doubled");
                    let (l, r) = (Split::of(&prims[..mid]), Split::of(&prims[mid..]));
                    for (got, want) in [(left, l), (right, r)] {
                        assert_eq!(xyz_bits(&got.bounds), xyz_bits(&want.bounds), "case {case}");
                        assert_eq!(
                            xyz_bits(&got.centroid_bounds),
                            xyz_bits(&want.centroid_bounds),
                            "case {case}"
                        );
                    }
                }
            }
        }
        assert!(splits > 100, "only {splits} of the cases split: the test exercises too little");
    }

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

    #[test]
    fn the_triangle_index_rides_in_the_w_lane() {
        for index in [0, 1, 12345, 1 << 23, u32::MAX >> 1] {
            let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
            assert_eq!(Primitive::new(&t, index).index(), index);
        }
    }
}
