//! Choosing a node's split by the surface area heuristic: binned SAH (Wald 2007, "On fast
//! Construction of SAH-based Bounding Volume Hierarchies"; pbrt-v4 §7.3.2) over the
//! centroids, an exact sweep for nodes of at most [`SMALL_NODE`] triangles ([`small_split`]),
//! and the in-place partition of the primitives. [`super::build`] drives it.
//!
//! Primitives are 32-byte records of two 4-wide vectors so that the per-primitive work of
//! binning and partitioning, which dominates the build, is a handful of SIMD operations.

use glam::{Vec3, Vec4};

use crate::geometry::Aabb;
use crate::scene::layout::BvhNode;

/// SAH bins per split axis.
pub(super) const BIN_COUNT: usize = 16;
/// Most triangles a leaf may hold.
pub(super) const MAX_LEAF_TRIANGLES: usize = 8;
/// SAH cost of one traversal step relative to one triangle test (pbrt-v4 uses ½).
pub(super) const TRAVERSAL_COST: f32 = 0.5;
/// Beyond this depth nodes split at the object median, which halves the count at every
/// level; so no tree is deeper than this plus log₂(2³²) = 32 levels, which bounds the CPU's
/// traversal stack and the GPU's 64-bit restart trail.
pub(super) const MEDIAN_SPLIT_DEPTH: usize = 32;
/// Nodes with at least this many triangles bin into [`BIN_SETS`] sets of bins (see
/// [`cheapest_plane`]); below it merging the sets costs more than it saves.
pub(super) const LARGE_NODE: usize = 256;
pub(super) const BIN_SETS: usize = 2;
/// Nodes with at most this many triangles choose their split by the exact sweep over their
/// sorted primitives ([`small_split`]) instead of by binning.
pub(super) const SMALL_NODE: usize = 8;

/// An axis-aligned box in the x, y, z lanes of two 4-wide vectors; the w lanes carry
/// whatever the boxes it was grown from carried and are never read.
#[derive(Clone, Copy)]
pub(super) struct Bounds4 {
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
    pub(super) fn surface_area(&self) -> f32 {
        self.aabb().surface_area()
    }

    pub(super) fn node(&self) -> BvhNode {
        let b = self.aabb();
        BvhNode { bounds_min: b.min.to_array(), bounds_max: b.max.to_array(), ..Default::default() }
    }
}

/// A triangle's box, 32 bytes: `lo.xyz` and `hi.xyz` are its bounds, and `lo.w` carries
/// the triangle's input index as raw bits (Embree's `PrimRef` keeps its primitive ID in the
/// same place), so one record moves in the partition and no index array moves beside it.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
pub(super) struct Primitive {
    pub(super) lo: Vec4,
    pub(super) hi: Vec4,
}

impl Primitive {
    pub(super) fn new(t: &[Vec3; 3], index: u32) -> Primitive {
        let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
        Primitive { lo: lo.extend(f32::from_bits(index)), hi: hi.extend(0.0) }
    }

    pub(super) fn index(&self) -> u32 {
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
pub(super) struct Split {
    pub(super) bounds: Bounds4,
    pub(super) centroid_bounds: Bounds4,
}

impl Split {
    pub(super) fn of(prims: &[Primitive]) -> Split {
        prims.iter().fold(Split { bounds: Bounds4::EMPTY, centroid_bounds: Bounds4::EMPTY }, |s, p| Split {
            bounds: s.bounds.union(p.bounds()),
            centroid_bounds: s.centroid_bounds.grow(p.centroid2()),
        })
    }
}

/// What a node becomes.
pub(super) enum Decision {
    Leaf,
    /// Split at `mid` (the primitives are partitioned already) along `axis`.
    Interior {
        mid: usize,
        axis: usize,
        left: Split,
        right: Split,
    },
}

/// Chooses between a leaf and a split, and partitions for a split.
pub(super) fn decide(prims: &mut [Primitive], split: &Split, depth: usize) -> Decision {
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
pub(super) fn split_at(prims: &[Primitive], mid: usize, axis: usize) -> Decision {
    let (left, right) = prims.split_at(mid);
    Decision::Interior { mid, axis, left: Split::of(left), right: Split::of(right) }
}

/// A split at the object median along `axis`.
pub(super) fn split_at_median(prims: &mut [Primitive], axis: usize) -> Decision {
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |a, b| a.centroid2()[axis].total_cmp(&b.centroid2()[axis]));
    split_at(prims, mid, axis)
}

/// The doubled centroid's component on `AXIS` (a constant, so this is one lane extract).
#[inline(always)]
pub(super) fn lane<const AXIS: usize>(v: Vec4) -> f32 {
    match AXIS {
        0 => v.x,
        1 => v.y,
        _ => v.z,
    }
}

/// Which of the BIN_COUNT bins along `AXIS` a primitive falls in: bin i holds the doubled
/// centroids c with ⌊(c − c_min)·scale⌋ = i, the last bin also the far edge.
#[derive(Clone, Copy)]
pub(super) struct Binning<const AXIS: usize> {
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
pub(super) struct Plane {
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
pub(super) fn sah_split<const AXIS: usize>(
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
pub(super) fn small_split<const AXIS: usize>(prims: &mut [Primitive], bounds: &Bounds4) -> Decision {
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
pub(super) fn cheapest_plane<const AXIS: usize>(
    prims: &[Primitive],
    binning: Binning<AXIS>,
) -> Option<Plane> {
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
pub(super) fn partition<const AXIS: usize>(
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
pub(super) mod tests;
