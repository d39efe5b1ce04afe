//! Tests of `sobol`.

use super::*;

/// The second Sobol component of index i, straight from its direction numbers.
fn sobol_second_by_definition(i: u32) -> u32 {
    let (mut r, mut v) = (0u32, 1u32 << 31);
    for k in 0..32 {
        if i >> k & 1 != 0 {
            r ^= v;
        }
        v ^= v >> 1;
    }
    r
}

#[test]
fn superset_transform_is_the_second_sobol_component() {
    // Known values in index order (not the Gray-code order of Joe & Kuo's tables):
    // 0, ½, ¾, ¼, ⅝, ⅛, ⅜, ⅞.
    let expect = [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875];
    for (i, e) in expect.iter().enumerate() {
        let y = sobol_second_reversed(i as u32).reverse_bits();
        assert_eq!(y as f64 / 4_294_967_296.0, *e, "index {i}");
    }
    let mut rng = Rng::new(1, 2, 3, 4);
    for _ in 0..10_000 {
        let i = rng.next_u32();
        assert_eq!(sobol_second_reversed(i).reverse_bits(), sobol_second_by_definition(i));
    }
}

/// One dimension's point straight from the definition, as the kernel computes it
/// (`shaders/sampling.wgsl`).
fn sobol_point(pixel_seed: u32, index_reversed: u32, dimension: u32) -> Vec2 {
    let (dimension_seed, shuffled) = dimension_seed_and_index(pixel_seed, index_reversed, dimension);
    let x = owen_scramble_reversed(shuffled, hash_u32(dimension_seed ^ 1));
    let y = owen_scramble_reversed(sobol_second_reversed(shuffled), hash_u32(dimension_seed ^ 2));
    Vec2::new(fraction_to_f32(x), fraction_to_f32(y))
}

/// The sampler hands out dimensions eight at a time from a batch; every draw, across
/// batch boundaries and after skips, is the definition's point of its dimension.
#[test]
fn batched_dimensions_are_the_definition() {
    let mut rng = Rng::new(9, 8, 7, 6);
    for _ in 0..500 {
        let (x, y, k, seed) = (rng.next_u32() % 4096, rng.next_u32() % 4096, rng.next_u32(), rng.next_u32());
        let mut sampler = PathSampler::new(SamplerKind::Sobol, x, y, k, seed);
        let PathSampler::Sobol(SobolStream { pixel_seed, index_reversed, .. }) = sampler else {
            unreachable!()
        };
        // 40 dimensions, drawn as 2-D, 1-D or skipped at random: batches are entered at
        // every lane.
        for d in 0..40 {
            let expect = sobol_point(pixel_seed, index_reversed, d);
            match rng.next_u32() % 4 {
                0 => assert_eq!(sampler.next_2d(), expect, "pixel ({x}, {y}) sample {k} dimension {d}"),
                1 => assert_eq!(sampler.next_1d(), expect.x, "pixel ({x}, {y}) sample {k} dimension {d}"),
                2 => sampler.skip_1d(),
                _ => sampler.skip_2d(),
            }
        }
    }
}

/// Skipping a number leaves the next ones as drawing it would, for both samplers.
#[test]
fn skipping_a_number_keeps_the_stream() {
    for kind in [SamplerKind::Sobol, SamplerKind::Independent] {
        let (mut drawn, mut skipped) =
            (PathSampler::new(kind, 3, 4, 5, 6), PathSampler::new(kind, 3, 4, 5, 6));
        drawn.next_2d();
        skipped.next_2d();
        drawn.next_1d();
        skipped.skip_1d();
        drawn.next_2d();
        skipped.skip_2d();
        for _ in 0..4 {
            assert_eq!(drawn.next_2d(), skipped.next_2d(), "{kind:?}");
            assert_eq!(drawn.next_1d(), skipped.next_1d(), "{kind:?}");
        }
    }
}

/// Every prefix of 2^m samples of every dimension is a (0,m,2)-net: each elementary
/// interval [a/2^j, (a+1)/2^j) × [b/2^(m−j), (b+1)/2^(m−j)) holds exactly one point.
#[test]
fn each_dimension_is_a_net_in_each_replicate() {
    for m in [1u32, 4, 6, 8] {
        let n = 1u32 << m;
        for replicate in 0..2 {
            // Dimension d of samples replicate, replicate + 2, …
            let points: Vec<Vec<Vec2>> = (0..n)
                .map(|k| {
                    let mut s = PathSampler::new(SamplerKind::Sobol, 5, 9, 2 * k + replicate, 42);
                    (0..5).map(|_| s.next_2d()).collect()
                })
                .collect();
            for d in 0..5 {
                for j in 0..=m {
                    let (nx, ny) = (1u32 << j, 1u32 << (m - j));
                    let mut cells = vec![0u32; n as usize];
                    for p in &points {
                        let (cx, cy) = ((p[d].x * nx as f32) as u32, (p[d].y * ny as f32) as u32);
                        cells[(cy * nx + cx) as usize] += 1;
                    }
                    assert!(cells.iter().all(|&c| c == 1), "m {m} dimension {d} split {j}");
                }
            }
        }
    }
}

/// The recurrences give Joe & Kuo's direction numbers: m = 1, 3, 3, 9, 29, 23 for the
/// third component and 1, 3, 1, 5, 31, 29 for the fourth, as fractions m_k / 2^k.
#[test]
fn paired_components_have_the_published_direction_numbers() {
    let published = |m: [u32; 6]| -> Vec<u32> { (0..6).map(|k| m[k] << (31 - k)).collect() };
    assert_eq!(SOBOL_THIRD[..6], published([1, 3, 3, 9, 29, 23])[..]);
    assert_eq!(SOBOL_FOURTH[..6], published([1, 3, 1, 5, 31, 29])[..]);
}

/// A pixel's direction pairs are 4-D nets: 16 samples put one pair in each of the
/// 2×2×2×2 cells, 64 one in each 4×4×2×2 cell (as the first four Sobol components do),
/// whether drawn straight from the sample or from one continuation of a split, with other
/// numbers drawn between the pair's members. Padded pairs, each direction shuffled on its
/// own, fail this.
#[test]
fn direction_pairs_are_four_dimensional_nets() {
    for (n, cells) in [(16u32, [2u32, 2, 2, 2]), (64, [4, 4, 2, 2])] {
        for replicate in 0..2 {
            for split in [false, true] {
                let mut seen = vec![false; n as usize];
                for k in 0..n {
                    let mut s = PathSampler::new(SamplerKind::Sobol, 5, 9, 2 * k + replicate, 7);
                    s.next_2d();
                    if split {
                        // Sample k's continuation 0 of 1: the same index, a new stream.
                        s.next_direction_2d();
                        s = s.split(0, 1);
                    }
                    let first = s.next_direction_2d();
                    s.next_1d();
                    s.next_2d();
                    let second = s.next_direction_2d();
                    let c = [first.x, first.y, second.x, second.y];
                    let cell = (0..4).fold(0, |acc, d| acc * cells[d] + (c[d] * cells[d] as f32) as u32);
                    assert!(
                        !seen[cell as usize],
                        "n {n} replicate {replicate} split {split}: cell {cell} twice"
                    );
                    seen[cell as usize] = true;
                }
            }
        }
    }
}

/// The continuations of split samples ([`PathSampler::split`]): a replicate's first 2^m
/// samples split four ways at dimension 3 give 2^m · 4 points in each later dimension,
/// and those are a (0, m + 2, 2)-net, as 2^m · 4 unsplit samples' would be. (Indexed
/// i + j instead of i·4 + j, neighbouring samples' continuations overlap, and this fails.)
#[test]
fn split_continuations_are_a_net_in_each_later_dimension() {
    let splits = 4u32;
    for m in [0u32, 2, 5] {
        let n = 1u32 << m;
        for replicate in 0..2 {
            let mut points: Vec<Vec<Vec2>> = Vec::new();
            for k in 0..n {
                let mut s = PathSampler::new(SamplerKind::Sobol, 7, 3, 2 * k + replicate, 42);
                (0..3).for_each(|_| s.skip_2d());
                for j in 0..splits {
                    let mut c = s.split(j, splits);
                    points.push((0..4).map(|_| c.next_2d()).collect());
                }
            }
            let bits = m + 2;
            for d in 0..4 {
                for j in 0..=bits {
                    let (nx, ny) = (1u32 << j, 1u32 << (bits - j));
                    let mut cells = vec![0u32; points.len()];
                    for p in &points {
                        let (cx, cy) = ((p[d].x * nx as f32) as u32, (p[d].y * ny as f32) as u32);
                        cells[(cy * nx + cx) as usize] += 1;
                    }
                    assert!(cells.iter().all(|&c| c == 1), "m {m} later dimension {d} cells {nx}×{ny}");
                }
            }
        }
    }
}

/// The replicates and the dimensions are scrambled independently: the correlation of
/// their numbers over many pixels is near zero. With n = 65,536 pairs the standard error
/// of a correlation is 1/√n ≈ 0.004, so 0.02 is 5σ.
#[test]
fn dimensions_and_replicates_are_uncorrelated() {
    let n = 65_536u32;
    let correlation = |pairs: &[(f32, f32)]| {
        let count = pairs.len() as f64;
        let (mx, my) = pairs.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0 as f64, b + p.1 as f64));
        let (mx, my) = (mx / count, my / count);
        let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
        for p in pairs {
            let (dx, dy) = (p.0 as f64 - mx, p.1 as f64 - my);
            sxy += dx * dy;
            sxx += dx * dx;
            syy += dy * dy;
        }
        sxy / (sxx * syy).sqrt()
    };
    let (mut across_dimensions, mut across_replicates) = (Vec::new(), Vec::new());
    for p in 0..n {
        let (x, y) = (p % 256, p / 256);
        let mut even = PathSampler::new(SamplerKind::Sobol, x, y, 0, 7);
        let mut odd = PathSampler::new(SamplerKind::Sobol, x, y, 1, 7);
        let (a, b) = (even.next_2d(), even.next_2d());
        across_dimensions.push((a.x, b.x));
        across_replicates.push((a.y, odd.next_2d().y));
    }
    for (name, pairs) in [("dimensions", &across_dimensions), ("replicates", &across_replicates)] {
        let r = correlation(pairs);
        assert!(r.abs() < 0.02, "{name}: correlation {r}");
    }
}
