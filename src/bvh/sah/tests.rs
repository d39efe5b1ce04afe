//! Tests of `sah`.

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
pub(in crate::bvh) fn random_prims(seed: u64, n: usize) -> Vec<Primitive> {
    let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let mut next = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 40) as f32) / (1u64 << 24) as f32
    };
    let clusters: Vec<Vec3> = (0..1 + n % 5).map(|_| Vec3::new(next(), next(), next()) * 10.0).collect();
    (0..n)
        .map(|i| {
            let c = clusters[i % clusters.len()] + Vec3::new(next(), next(), next());
            let t =
                [c, c + Vec3::new(next(), next(), next()) * 0.3, c + Vec3::new(next(), 0.0, next()) * 0.3];
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
            Primitive::new(&[Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 0.0, 0.0), Vec3::new(x, 1.0, 0.0)], j)
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
    let random =
        (0..400u64).map(|s| (s, random_prims(s, [2, 3, 5, 8, 17, 64, 255, 256, 257, 701][s as usize % 10])));
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
                        assert_eq!(xyz_bits(&p.right), xyz_bits(&r.3), "seed {seed}, n {n}: right bounds");
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
                        let original = &before[before.iter().position(|b| b.index() == q.index()).unwrap()];
                        assert_eq!(xyz_bits(&q.bounds()), xyz_bits(&original.bounds()), "seed {seed}, n {n}");
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

#[test]
fn the_triangle_index_rides_in_the_w_lane() {
    for index in [0, 1, 12345, 1 << 23, u32::MAX >> 1] {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        assert_eq!(Primitive::new(&t, index).index(), index);
    }
}
