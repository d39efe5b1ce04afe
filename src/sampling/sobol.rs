//! The path sampler: where each of a path's random numbers comes from.
//!
//! Default: padded, shuffled, Owen-scrambled Sobol points (Burley 2020, "Practical Hash-based
//! Owen Scrambling", JCGT 9(4)). Every 2-D request of a path (camera jitter, light sample,
//! whose one point chooses the light and the point on it, BSDF direction, …) gets the next
//! *dimension*; within one dimension the pixel's samples are the first two Sobol components
//! — a (0,2)-sequence — so every power-of-two prefix of them is stratified like a
//! (0,m,2)-net. Each dimension shuffles the sample order with its own seed (a nested uniform
//! scramble of the index), which pads the dimensions together without correlating them, and
//! Owen-scrambles both coordinates.
//! Paths of any length are covered: dimensions are never exhausted. The CPU computes a
//! path's dimensions eight at a time, 8-wide (`sobol_batch`), and hands them out in order.
//!
//! One exception to the padding: a path's BSDF directions are drawn in pairs
//! ([`PathSampler::next_direction_2d`]). The second of a pair does not shuffle the index on
//! its own; it takes the third and fourth Sobol components of the index its partner
//! shuffled, so the two bounces' directions are one 4-D Owen-scrambled Sobol point (Burley
//! 2020 §5 pads 4-D Sobol points the same way). The radiance a direction finds depends on
//! the next bounce's direction, not only on its own (the Cornell box's indirect light), and
//! padding leaves that product unstratified: pairing them lowers the Cornell box's relMSE
//! by 5.7% at 256 spp (`bench/history/sampling.md`, "Direction pairs"). Light samples are
//! not paired: their term adds to the path's rather than multiplying it, which padding
//! already serves.
//!
//! Owen scrambling keeps the estimator unbiased but makes the samples of a pixel dependent,
//! so their sample variance no longer measures the mean's error (it over-states it where the
//! stratification helps). The samples are therefore split into two *replicates*, the even
//! and the odd sample indices, each with its own independent scrambling: the difference of
//! the two replicates' means is an unbiased measure of the error (Owen 2013, "Monte Carlo
//! theory, methods and examples", §17.2 on randomised QMC error estimates from independent
//! replicates), which [`crate::film`] keeps per pixel.
//!
//! `Independent` keeps one xoshiro stream per sample ([`Rng`]), whose sample variance is
//! exactly the per-sample variance a z-test expects.
//!
//! All integer arithmetic, so the WGSL twin (`shaders/sampling.wgsl`) draws the same numbers.

use glam::{UVec4, Vec2};

use super::rng::{pcg4d, Rng};

/// Where a path's random numbers come from (`--sampler`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SamplerKind {
    /// Owen-scrambled Sobol points in two independent replicates.
    #[default]
    Sobol,
    /// Independent uniform numbers (xoshiro128**).
    Independent,
}

impl SamplerKind {
    /// Every sampler.
    pub const ALL: [SamplerKind; 2] = [SamplerKind::Sobol, SamplerKind::Independent];

    /// The sampler called `name` ([`SamplerKind::name`]), if there is one.
    pub fn from_name(name: &str) -> Option<SamplerKind> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Its name on the command line and in EXR metadata.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Sobol => "sobol",
            SamplerKind::Independent => "independent",
        }
    }

    /// The value the kernel's `frame.sampler_kind` holds.
    pub fn index(self) -> u32 {
        match self {
            SamplerKind::Sobol => 0,
            SamplerKind::Independent => 1,
        }
    }
}

/// Which of the two replicates sample `sample_index` of a pixel belongs to.
pub fn replicate_of(sample_index: u32) -> u32 {
    sample_index & 1
}

/// A 32-bit integer hash with low bias (Wellons 2018, "Prospecting for Hash Functions",
/// `lowbias32`).
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// A random permutation of 32-bit values in which each bit depends only on the bits below it
/// (Laine & Karras 2011's construction, with Vegdahl 2021's constants, "Building a Better LK
/// Hash"). Applied to bit-reversed values it is an Owen scramble.
fn lk_permute(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// Owen scramble of the 32-bit fraction whose *bit-reversed* value is `reversed`; returns
/// the scrambled fraction (most significant bit = ½).
fn owen_scramble_reversed(reversed: u32, seed: u32) -> u32 {
    lk_permute(reversed, seed).reverse_bits()
}

/// Bit-reversed second Sobol component of index `i`.
///
/// Its generator matrix is Pascal's triangle mod 2 (direction numbers v₁ = ½,
/// vₖ₊₁ = vₖ ⊕ vₖ/2), so by Lucas' theorem output bit a (a = 0 the ½ bit) is the parity of
/// the index bits k whose positions are supersets of a's (k & a = a): a superset-XOR
/// transform over the five bits of a position, five shift-and-mask steps.
fn sobol_second_reversed(i: u32) -> u32 {
    let mut r = i;
    r ^= (r >> 1) & 0x5555_5555;
    r ^= (r >> 2) & 0x3333_3333;
    r ^= (r >> 4) & 0x0f0f_0f0f;
    r ^= (r >> 8) & 0x00ff_00ff;
    r ^= (r >> 16) & 0x0000_ffff;
    r
}

/// Dimensions a [`PathSampler`] draws at once: eight 32-bit lanes, one AVX2 register.
const BATCH: usize = 8;

/// The golden-ratio step between dimensions' seeds.
pub(crate) const DIMENSION_STEP: u32 = 0x9e37_79b9;

/// Dimension `dimension`'s seed: the root of its index shuffle and its two scrambles.
#[inline(always)]
fn dimension_seed(pixel_seed: u32, dimension: u32) -> u32 {
    hash_u32(pixel_seed ^ dimension.wrapping_mul(DIMENSION_STEP))
}

/// Dimension `dimension`'s seed and the sample's shuffled index there.
fn dimension_seed_and_index(pixel_seed: u32, index_reversed: u32, dimension: u32) -> (u32, u32) {
    let dimension_seed = dimension_seed(pixel_seed, dimension);
    // Nested uniform scramble of the index (Burley 2020 §4): the first 2^m samples map to
    // one aligned block of 2^m Sobol indices, so each prefix stays a (0,m,2)-net.
    (dimension_seed, owen_scramble_reversed(index_reversed, dimension_seed))
}

/// The points of dimensions `first .. first + BATCH`: the index shuffled by each
/// dimension's seed, then its x (the first Sobol component, the bit-reversed index: van der
/// Corput) and its y (the second) Owen-scrambled by seeds derived from it. Written as loops
/// over eight lanes of plain integer operations, which the compiler turns into 8-wide AVX2
/// (the bit reversals included): eight dimensions cost about what two did one at a time.
/// The tests hold it to `sobol_point`, the same definition one dimension at a time.
fn sobol_batch(pixel_seed: u32, index_reversed: u32, first: u32) -> [[f32; BATCH]; 2] {
    let mut seed = [0u32; BATCH];
    for (i, s) in seed.iter_mut().enumerate() {
        *s = dimension_seed(pixel_seed, first.wrapping_add(i as u32));
    }
    let mut shuffled = [0u32; BATCH];
    for i in 0..BATCH {
        shuffled[i] = owen_scramble_reversed(index_reversed, seed[i]);
    }
    let mut out = [[0.0f32; BATCH]; 2];
    for i in 0..BATCH {
        out[0][i] = fraction_to_f32(owen_scramble_reversed(shuffled[i], hash_u32(seed[i] ^ 1)));
    }
    for i in 0..BATCH {
        out[1][i] = fraction_to_f32(owen_scramble_reversed(
            sobol_second_reversed(shuffled[i]),
            hash_u32(seed[i] ^ 2),
        ));
    }
    out
}

/// The first 24 direction numbers (columns, as fractions: most significant bit ½) of a Sobol
/// component of degree `degree`, from its first columns `initial` (the initial m_k, placed)
/// by the recurrence v_k = v_{k−degree} ⊕ (v_{k−degree} ≫ degree) ⊕ the earlier columns
/// `taps` selects (bit j: v_{k−1−j}) (Bratley & Fox 1988). 24 columns are enough: column k
/// has no bit above position k + 1, and an Owen scramble's output bit depends only on the
/// input's bits above it, so index bits from 24 on change nothing `fraction_to_f32` keeps.
/// The WGSL twin (`sobol_third_fourth`) runs the same recurrences in registers.
const fn sobol_columns(degree: usize, taps: u32, initial: [u32; 3]) -> [u32; 24] {
    let mut v = [0u32; 24];
    let mut k = 0;
    while k < 24 {
        v[k] = if k < degree {
            initial[k]
        } else {
            let mut x = v[k - degree] ^ (v[k - degree] >> degree);
            let mut j = 0;
            while j + 1 < degree {
                if taps >> j & 1 != 0 {
                    x ^= v[k - 1 - j];
                }
                j += 1;
            }
            x
        };
        k += 1;
    }
    v
}

/// The third and fourth Sobol components: primitive polynomials x² + x + 1 and x³ + x + 1
/// with initial m = (1, 3) and (1, 3, 1) (Joe & Kuo 2008, `new-joe-kuo-6.21201`'s second
/// and third rows).
const SOBOL_THIRD: [u32; 24] = sobol_columns(2, 0b1, [0x8000_0000, 0xc000_0000, 0]);
const SOBOL_FOURTH: [u32; 24] = sobol_columns(3, 0b10, [0x8000_0000, 0xc000_0000, 0x2000_0000]);

/// A Sobol component by bytes of the index: entry `b · 256 + v` is the XOR of the columns
/// that byte `b` of the index selects when it is `v`, so a component is three lookups.
const fn byte_tables(columns: &[u32; 24]) -> [u32; 768] {
    let mut table = [0u32; 768];
    let mut b = 0;
    while b < 3 {
        let mut v = 0;
        while v < 256 {
            let mut x = 0;
            let mut k = 0;
            while k < 8 {
                if v >> k & 1 != 0 {
                    x ^= columns[b * 8 + k];
                }
                k += 1;
            }
            table[b * 256 + v] = x;
            v += 1;
        }
        b += 1;
    }
    table
}

static SOBOL_THIRD_BYTES: [u32; 768] = byte_tables(&SOBOL_THIRD);
static SOBOL_FOURTH_BYTES: [u32; 768] = byte_tables(&SOBOL_FOURTH);

/// The Sobol component whose [`byte_tables`] are `table`, at index `i` (a fraction).
#[inline(always)]
fn sobol_component(table: &[u32; 768], i: u32) -> u32 {
    table[(i & 0xff) as usize]
        ^ table[256 + (i >> 8 & 0xff) as usize]
        ^ table[512 + (i >> 16 & 0xff) as usize]
}

/// The second of a direction pair: Sobol components 3 and 4 of `shuffled` (the index its
/// partner's dimension shuffled), each Owen-scrambled by seeds of this pair member's own
/// dimension, `dimension_seed`. WGSL twin: the second half of `rng_next_direction_2d`.
fn paired_point(shuffled: u32, dimension_seed: u32) -> (f32, f32) {
    let x = owen_scramble_reversed(
        sobol_component(&SOBOL_THIRD_BYTES, shuffled).reverse_bits(),
        hash_u32(dimension_seed ^ 1),
    );
    let y = owen_scramble_reversed(
        sobol_component(&SOBOL_FOURTH_BYTES, shuffled).reverse_bits(),
        hash_u32(dimension_seed ^ 2),
    );
    (fraction_to_f32(x), fraction_to_f32(y))
}

/// Distinguishes the independent sampler's continuation streams ([`PathSampler::split`])
/// from its sample streams, which are seeded by (x, y, sample index, seed).
pub(crate) const SPLIT_STREAM_SALT: u32 = 0x5b1e_7c3d;

/// Top 24 bits of a fraction as a float in [0, 1), each value exactly representable.
fn fraction_to_f32(u: u32) -> f32 {
    (u >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// One path's Sobol numbers: its dimensions handed out in order, computed eight at a time.
#[derive(Clone, Debug)]
pub struct SobolStream {
    /// Hash of (pixel, seed, replicate): the root of every dimension's scrambling.
    pixel_seed: u32,
    /// The sample's index within its replicate, bit-reversed.
    index_reversed: u32,
    /// The next dimension to hand out.
    dimension: u32,
    /// The first dimension in `batch`.
    batch_first: u32,
    /// Dimensions `batch_first ..` as numbers in [0, 1): `batch[0]` the x, `batch[1]` the y
    /// coordinates.
    batch: [[f32; BATCH]; 2],
    /// The dimension of the first direction of a pair whose second is still to be drawn,
    /// plus one; 0 when the next direction starts a pair.
    partner: u32,
}

impl SobolStream {
    fn new(pixel_seed: u32, index_reversed: u32) -> SobolStream {
        SobolStream {
            pixel_seed,
            index_reversed,
            dimension: 0,
            batch_first: 0,
            // Every path draws its camera jitter from dimension 0.
            batch: sobol_batch(pixel_seed, index_reversed, 0),
            partner: 0,
        }
    }

    /// The next dimension's point (x, y), from the batch, refilled from this dimension on
    /// when it has run out.
    #[inline(always)]
    fn next_point(&mut self) -> (f32, f32) {
        let d = self.dimension;
        self.dimension += 1;
        let mut lane = d.wrapping_sub(self.batch_first) as usize;
        if lane >= BATCH {
            self.refill(d);
            lane = 0;
        }
        (self.batch[0][lane], self.batch[1][lane])
    }

    /// Out of line and marked cold (it runs at most once per eight draws), so that a draw
    /// from the batch saves no registers for it.
    #[cold]
    #[inline(never)]
    fn refill(&mut self, first: u32) {
        self.batch = sobol_batch(self.pixel_seed, self.index_reversed, first);
        self.batch_first = first;
    }

    /// The next dimension's point as a BSDF direction: the first of a pair as any point,
    /// the second as the pair's third and fourth components.
    #[inline(always)]
    fn next_direction(&mut self) -> (f32, f32) {
        if self.partner == 0 {
            self.partner = self.dimension + 1;
            return self.next_point();
        }
        let (_, shuffled) = dimension_seed_and_index(self.pixel_seed, self.index_reversed, self.partner - 1);
        self.partner = 0;
        let seed = dimension_seed(self.pixel_seed, self.dimension);
        self.dimension += 1;
        paired_point(shuffled, seed)
    }

    /// Passes over the next dimension.
    fn skip(&mut self) {
        self.dimension += 1;
    }

    /// A uniform 32-bit integer from the next dimension, not stratified.
    fn next_u32(&mut self) -> u32 {
        let (dimension_seed, shuffled) =
            dimension_seed_and_index(self.pixel_seed, self.index_reversed, self.dimension);
        self.dimension += 1;
        hash_u32(dimension_seed ^ shuffled)
    }
}

/// The random numbers of one sample (one path) of one pixel.
#[derive(Clone, Debug)]
pub enum PathSampler {
    Sobol(SobolStream),
    Independent(Rng),
}

impl PathSampler {
    /// The numbers of sample `sample_index` of pixel `(x, y)` under `seed`.
    pub fn new(kind: SamplerKind, x: u32, y: u32, sample_index: u32, seed: u32) -> PathSampler {
        match kind {
            SamplerKind::Sobol => PathSampler::Sobol(SobolStream::new(
                pcg4d(UVec4::new(x, y, seed, replicate_of(sample_index))).x,
                (sample_index >> 1).reverse_bits(),
            )),
            SamplerKind::Independent => PathSampler::Independent(Rng::new(x, y, sample_index, seed)),
        }
    }

    /// The numbers of continuation `j` of `splits` when a path is split
    /// (`integrator::path::radiance`), from the next dimension on.
    ///
    /// Sobol: the sample's index within its replicate, i, becomes i·splits + j, and the
    /// dimensions go on from where the path has reached. Each dimension shuffles its index
    /// on its own, so from there on a pixel's continuations are the points of a sequence
    /// `splits` times as long: its n samples' n·splits continuations are stratified in
    /// every dimension as n·splits unsplit samples would be (a (0,m,2)-net for each
    /// power-of-two prefix when `splits` is a power of two), and padded against the
    /// dimensions before. Independent: a fresh stream seeded from the path's next number and
    /// `(j, splits)`.
    pub fn split(&self, j: u32, splits: u32) -> PathSampler {
        match self {
            PathSampler::Sobol(stream) => {
                let index = stream.index_reversed.reverse_bits().wrapping_mul(splits).wrapping_add(j);
                // A continuation's first direction starts a pair: a pair begun before the split
                // belongs to another index.
                let mut split =
                    SobolStream { index_reversed: index.reverse_bits(), partner: 0, ..stream.clone() };
                split.refill(split.dimension);
                PathSampler::Sobol(split)
            }
            PathSampler::Independent(rng) => {
                let root = rng.clone().next_u32();
                PathSampler::Independent(Rng::new(root, j, splits, SPLIT_STREAM_SALT))
            }
        }
    }

    /// A uniform 32-bit integer (stochastic alpha's hash input), not stratified.
    pub fn next_u32(&mut self) -> u32 {
        match self {
            PathSampler::Sobol(stream) => stream.next_u32(),
            PathSampler::Independent(rng) => rng.next_u32(),
        }
    }

    /// Uniform in [0, 1): the x coordinate of the next dimension.
    pub fn next_1d(&mut self) -> f32 {
        match self {
            PathSampler::Sobol(stream) => stream.next_point().0,
            PathSampler::Independent(rng) => rng.next_1d(),
        }
    }

    /// Passes over the number [`Self::next_1d`] would return, leaving every later number
    /// as it would have been: a path that has no use for a number (the lobe choice of a
    /// one-lobe BSDF) skips the work of drawing it but keeps the stream the other backend,
    /// which draws it, follows.
    pub fn skip_1d(&mut self) {
        match self {
            PathSampler::Sobol(stream) => stream.skip(),
            PathSampler::Independent(rng) => {
                rng.next_u32();
            }
        }
    }

    /// Passes over the pair [`Self::next_2d`] would return (one Sobol dimension, two
    /// independent numbers), as [`Self::skip_1d`] does.
    pub fn skip_2d(&mut self) {
        match self {
            PathSampler::Sobol(stream) => stream.skip(),
            PathSampler::Independent(rng) => {
                rng.next_u32();
                rng.next_u32();
            }
        }
    }

    /// Uniform in [0, 1)², for sampling a BSDF direction: under Sobol, a path's directions
    /// come in pairs that are 4-D points (the module's documentation); independent numbers
    /// otherwise, as [`Self::next_2d`].
    pub fn next_direction_2d(&mut self) -> Vec2 {
        match self {
            PathSampler::Sobol(stream) => {
                let (x, y) = stream.next_direction();
                Vec2::new(x, y)
            }
            PathSampler::Independent(_) => self.next_2d(),
        }
    }

    /// Uniform in [0, 1)².
    pub fn next_2d(&mut self) -> Vec2 {
        match self {
            PathSampler::Sobol(stream) => {
                let (x, y) = stream.next_point();
                Vec2::new(x, y)
            }
            PathSampler::Independent(rng) => rng.next_2d(),
        }
    }
}

#[cfg(test)]
mod tests;
