// Twin of src/sampling/ (rng.rs, sobol.rs, warp.rs): the same integer arithmetic, so a sample with the
// same pixel, index and seed draws the same numbers as on the CPU. At the end, Metropolis's
// primary sample (twin of `MltSampler` in src/integrator/mlt.rs).

const PI: f32 = 3.14159265358979323846;
const INV_PI: f32 = 0.31830988618379067154;

// pcg4d (Jarzynski & Olano 2020, "Hash Functions for GPU Rendering", JCGT 9(3)).
fn pcg4d(v_in: vec4<u32>) -> vec4<u32> {
    var v = v_in * 1664525u + vec4<u32>(1013904223u);
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    v = v ^ (v >> vec4<u32>(16u));
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    return v;
}

// The path sampler (twin of src/sampling/sobol.rs, which explains the construction):
// padded, shuffled, Owen-scrambled Sobol points in two replicates (Burley 2020), or
// independent xoshiro128** numbers (Blackman & Vigna 2021). One sample's state, per
// invocation: for Sobol (pixel seed, bit-reversed index within the replicate, next
// dimension, the dimension of a direction pair's first member plus one or 0); for the
// independent sampler the xoshiro state.
const SAMPLER_SOBOL: u32 = 0u;
const SAMPLER_INDEPENDENT: u32 = 1u;
// SAMPLER_MLT (2): a Metropolis chain's primary sample (below).

var<private> path_sampler_kind: u32;
var<private> rng_s: vec4<u32>;

// The stream row light paths draw from (no pixel has it): the light tracer's and
// bidirectional path tracing's light subpaths.
const LIGHT_PATH_STREAM: u32 = 0xffffffffu;

fn replicate_of(sample_index: u32) -> u32 {
    return sample_index & 1u;
}

fn sampler_start(kind: u32, x: u32, y: u32, sample_index: u32, seed: u32) {
    path_sampler_kind = kind;
    if (kind == SAMPLER_SOBOL) {
        rng_s = vec4<u32>(pcg4d(vec4<u32>(x, y, seed, replicate_of(sample_index))).x,
                          reverseBits(sample_index >> 1u), 0u, 0u);
        return;
    }
    xoshiro_seed(vec4<u32>(x, y, sample_index, seed));
}

// Twin of `Rng::new`: the xoshiro128** state hashed from `key` (never all zero, the one
// state the generator cannot leave).
fn xoshiro_seed(key: vec4<u32>) {
    rng_s = pcg4d(key);
    if (all(rng_s == vec4<u32>(0u))) {
        rng_s.x = 1u;
    }
}

// Twin of `PathSampler::split`: the numbers of continuation `j` of `splits` of a split
// path whose sampler state was `state` (`rng_s` then), from its next dimension on. Sobol:
// the index within the replicate becomes i·splits + j; independent: a fresh stream seeded
// from the path's next number.
const SPLIT_STREAM_SALT: u32 = 0x5b1e7c3du;

fn sampler_split(state: vec4<u32>, j: u32, splits: u32) {
    rng_s = state;
    if (path_sampler_kind == SAMPLER_SOBOL) {
        rng_s.y = reverseBits(reverseBits(state.y) * splits + j);
        // A continuation's first direction starts a pair.
        rng_s.w = 0u;
        return;
    }
    xoshiro_seed(vec4<u32>(xoshiro_next(), j, splits, SPLIT_STREAM_SALT));
}

fn rotl(x: u32, k: u32) -> u32 {
    return (x << k) | (x >> (32u - k));
}

fn xoshiro_next() -> u32 {
    let result = rotl(rng_s.y * 5u, 7u) * 9u;
    let t = rng_s.y << 9u;
    rng_s.z ^= rng_s.x;
    rng_s.w ^= rng_s.y;
    rng_s.y ^= rng_s.z;
    rng_s.x ^= rng_s.w;
    rng_s.z ^= t;
    rng_s.w = rotl(rng_s.w, 11u);
    return result;
}

// lowbias32 (Wellons 2018).
fn hash_u32(x_in: u32) -> u32 {
    var x = x_in;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    x ^= x >> 16u;
    return x;
}

// Laine–Karras permutation with Vegdahl 2021's constants.
fn lk_permute(x_in: u32, seed: u32) -> u32 {
    var x = x_in;
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16u) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

fn owen_scramble_reversed(reversed: u32, seed: u32) -> u32 {
    return reverseBits(lk_permute(reversed, seed));
}

// Bit-reversed second Sobol component: a superset-XOR transform (Pascal's matrix mod 2).
fn sobol_second_reversed(i: u32) -> u32 {
    var r = i;
    r ^= (r >> 1u) & 0x55555555u;
    r ^= (r >> 2u) & 0x33333333u;
    r ^= (r >> 4u) & 0x0f0f0f0fu;
    r ^= (r >> 8u) & 0x00ff00ffu;
    r ^= (r >> 16u) & 0x0000ffffu;
    return r;
}

fn fraction_to_f32(u: u32) -> f32 {
    return f32(u >> 8u) * (1.0 / 16777216.0);
}

// The golden-ratio step between dimensions' seeds.
const DIMENSION_STEP: u32 = 0x9e3779b9u;

// Dimension `dimension`'s seed: the root of its index shuffle and its two scrambles.
fn dimension_seed(pixel_seed: u32, dimension: u32) -> u32 {
    return hash_u32(pixel_seed ^ (dimension * DIMENSION_STEP));
}

// The next dimension's seed and this sample's shuffled index there.
fn sobol_next_dimension() -> vec2<u32> {
    let seed = dimension_seed(rng_s.x, rng_s.z);
    rng_s.z += 1u;
    return vec2<u32>(seed, owen_scramble_reversed(rng_s.y, seed));
}

fn rng_next_u32() -> u32 {
    if (MLT_SAMPLER && path_sampler_kind == SAMPLER_MLT) {
        // Twin of `MltSampler`'s u32: the number scaled to 32 bits.
        return u32(mlt_next() * 4294967296.0);
    }
    if (path_sampler_kind == SAMPLER_SOBOL) {
        let d = sobol_next_dimension();
        return hash_u32(d.x ^ d.y);
    }
    return xoshiro_next();
}

// Uniform in [0, 1).
fn rng_next_1d() -> f32 {
    if (MLT_SAMPLER && path_sampler_kind == SAMPLER_MLT) {
        return mlt_next();
    }
    if (path_sampler_kind == SAMPLER_SOBOL) {
        let d = sobol_next_dimension();
        return fraction_to_f32(owen_scramble_reversed(d.y, hash_u32(d.x ^ 1u)));
    }
    return fraction_to_f32(xoshiro_next());
}

// The point whose two coordinates, bit-reversed, are `reversed`, Owen-scrambled by the
// seeds of the dimension whose seed is `seed`.
fn sobol_scrambled_point(reversed: vec2<u32>, seed: u32) -> vec2<f32> {
    let x = owen_scramble_reversed(reversed.x, hash_u32(seed ^ 1u));
    let y = owen_scramble_reversed(reversed.y, hash_u32(seed ^ 2u));
    return vec2<f32>(fraction_to_f32(x), fraction_to_f32(y));
}

fn rng_next_2d() -> vec2<f32> {
    if (MLT_SAMPLER && path_sampler_kind == SAMPLER_MLT) {
        let x = mlt_next();
        let y = mlt_next();
        return vec2<f32>(x, y);
    }
    if (path_sampler_kind == SAMPLER_SOBOL) {
        let d = sobol_next_dimension();
        return sobol_scrambled_point(vec2<u32>(d.y, sobol_second_reversed(d.y)), d.x);
    }
    let x = fraction_to_f32(xoshiro_next());
    let y = fraction_to_f32(xoshiro_next());
    return vec2<f32>(x, y);
}

// Twin of `sobol_component` on `SOBOL_THIRD` and `SOBOL_FOURTH`: the third and fourth Sobol
// components (fractions) of index i's 24 low bits, the columns made by the recurrences of
// `sobol_columns` (x² + x + 1: v_k = v_k−1 ⊕ v_k−2 ⊕ v_k−2 ≫ 2; x³ + x + 1:
// v_k = v_k−2 ⊕ v_k−3 ⊕ v_k−3 ≫ 3) in registers, where the CPU reads byte tables.
fn sobol_third_fourth(i: u32) -> vec2<u32> {
    var third = vec2<u32>(0x80000000u, 0xc0000000u);
    var fourth = vec3<u32>(0x80000000u, 0xc0000000u, 0x20000000u);
    var x = vec2<u32>(0u);
    for (var k = 0u; k < 24u; k++) {
        let bit = 0u - ((i >> k) & 1u);
        x ^= vec2<u32>(third.x, fourth.x) & vec2<u32>(bit);
        third = vec2<u32>(third.y, third.y ^ third.x ^ (third.x >> 2u));
        fourth = vec3<u32>(fourth.y, fourth.z, fourth.y ^ fourth.x ^ (fourth.x >> 3u));
    }
    return x;
}

// Twin of `PathSampler::next_direction_2d`: under Sobol a path's BSDF directions come in
// pairs, the second the third and fourth components of the index its partner's dimension
// shuffled (src/sampling/sobol.rs explains).
fn rng_next_direction_2d() -> vec2<f32> {
    if (MLT_SAMPLER && path_sampler_kind == SAMPLER_MLT) {
        return rng_next_2d();
    }
    if (path_sampler_kind != SAMPLER_SOBOL) {
        return rng_next_2d();
    }
    if (rng_s.w == 0u) {
        rng_s.w = rng_s.z + 1u;
        return rng_next_2d();
    }
    let shuffled = owen_scramble_reversed(rng_s.y, dimension_seed(rng_s.x, rng_s.w - 1u));
    rng_s.w = 0u;
    let seed = dimension_seed(rng_s.x, rng_s.z);
    rng_s.z += 1u;
    return sobol_scrambled_point(reverseBits(sobol_third_fourth(shuffled)), seed);
}

// Concentric square-to-disk map (Shirley & Chiu 1997). The angle is π/4 · t or
// π/2 − π/4 · t with |t| ≤ 1, so one sin_cos_quarter_pi of π/4 · t serves both octant pairs.
fn sample_uniform_disk_concentric(u: vec2<f32>) -> vec2<f32> {
    let o = 2.0 * u - vec2<f32>(1.0);
    if (o.x == 0.0 && o.y == 0.0) {
        return vec2<f32>(0.0);
    }
    if (abs(o.x) > abs(o.y)) {
        let sc = sin_cos_quarter_pi((PI / 4.0) * (o.y / o.x));
        return o.x * sc.yx;
    }
    let sc = sin_cos_quarter_pi((PI / 4.0) * (o.x / o.y));
    return o.y * sc;
}

// (sin x, cos x) for |x| ≤ π/4: Cephes's single-precision minimax polynomials, no range
// reduction needed (CPU twin: sin_cos_quarter_pi in src/sampling/warp.rs, within 1.2 ulp).
fn sin_cos_quarter_pi(x: f32) -> vec2<f32> {
    let z = x * x;
    let s = x + x * z * (-1.6666655e-1 + z * (8.332161e-3 + z * -1.9515296e-4));
    let c = 1.0 - 0.5 * z + z * z * (4.1666646e-2 + z * (-1.3887316e-3 + z * 2.4433157e-5));
    return vec2<f32>(s, c);
}

fn sample_cosine_hemisphere(u: vec2<f32>) -> vec3<f32> {
    let d = sample_uniform_disk_concentric(u);
    let z = sqrt(max(1.0 - d.x * d.x - d.y * d.y, 0.0));
    return vec3<f32>(d.x, d.y, z);
}

fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    return max(cos_theta, 0.0) * INV_PI;
}

// Heitz's low-distortion square-to-triangle map; barycentrics (b0, b1, b2).
fn sample_uniform_triangle(u: vec2<f32>) -> vec3<f32> {
    var b0: f32;
    var b1: f32;
    if (u.x < u.y) {
        b0 = u.x / 2.0;
        b1 = u.y - b0;
    } else {
        b1 = u.y / 2.0;
        b0 = u.x - b1;
    }
    return vec3<f32>(b0, b1, 1.0 - b0 - b1);
}

// ---- Metropolis's primary sample

// Twin of `MltSampler` in src/integrator/mlt.rs: a Metropolis chain's primary sample (Kelemen
// et al. 2002), mutated lazily as it is read (pbrt-v4 `MLTSampler`). The rng_next_* functions
// of shaders/sampling.wgsl read from it while `path_sampler_kind` is SAMPLER_MLT, so the
// bidirectional walks draw their numbers from it unchanged. Only the Metropolis kernel sets
// MLT_SAMPLER; in every other kernel the branches to it are constant false and the driver
// drops them and the private array with them.
override MLT_SAMPLER: bool = false;

const SAMPLER_MLT: u32 = 2u;

// Twin of `Stream`: the camera, light and connection streams; number j of stream s is entry
// 3j + s.
const MLT_STREAM_CAMERA: u32 = 0u;
const MLT_STREAM_LIGHT: u32 = 1u;
const MLT_STREAM_CONNECTION: u32 = 2u;
const MLT_STREAMS: u32 = 3u;

// The most numbers one sample reads from a stream (twin of `MLT_NUMBERS_PER_STREAM`, which
// counts them): at the deepest path Metropolis renders (MAX_MLT_DEPTH = 15) the camera
// stream reads 3 (strategy, film point) + 16 alpha seeds + 15 scatterings × 3 = 64, the
// light stream 7 (the origin) + 15 + 14 × 3 = 64, the connection stream at most 3. A read
// past it sets `mlt_overflow`, and the sample is dropped and counted (`MLT_COUNTER_OVERFLOWS` in shaders/mlt.wgsl).
const MLT_NUMBERS_PER_STREAM: u32 = 64u;
const MLT_NUMBERS: u32 = MLT_NUMBERS_PER_STREAM * MLT_STREAMS;

// Small steps' standard deviation (twin of `DEFAULT_SIGMA`).
const MLT_SIGMA: f32 = 0.01;

// `MltNumberGpu`'s flag bit: the number has been read by some state (twin of `set`).
const MLT_SET: u32 = 0x80000000u;

// The chain's primary sample while a dispatch runs it (loaded from and stored back to
// `mlt_numbers` in shaders/mlt.wgsl), the entries read so far, and the sampler's state. The
// sampler's own random numbers are xoshiro128** in `rng_s` (twin of `MltSampler::rng`).
var<private> mlt_numbers_private: array<MltNumberGpu, MLT_NUMBERS>;
var<private> mlt_used: u32;
var<private> mlt_iteration: u32;
var<private> mlt_last_large_step: u32;
var<private> mlt_large_step: bool;
var<private> mlt_stream: u32;
var<private> mlt_index: u32;
var<private> mlt_overflow: bool;

fn mlt_sampler_next_1d() -> f32 {
    return fraction_to_f32(xoshiro_next());
}

// Twin of `MltSampler::new`, its xoshiro state already in `rng_s`: every number unread, the
// first state a large step.
fn mlt_sampler_fresh() {
    path_sampler_kind = SAMPLER_MLT;
    for (var i = 0u; i < MLT_NUMBERS; i++) {
        mlt_numbers_private[i] = MltNumberGpu(0.0, 0.0, 0u, 0u);
    }
    mlt_used = 0u;
    mlt_iteration = 0u;
    mlt_last_large_step = 0u;
    mlt_large_step = true;
    mlt_stream = 0u;
    mlt_index = 0u;
    mlt_overflow = false;
}

// Twin of `MltSampler::start_iteration`.
fn mlt_start_iteration() {
    mlt_iteration += 1u;
    mlt_large_step = mlt_sampler_next_1d() < frame.mlt_large_step;
    mlt_overflow = false;
}

// Twin of `MltSampler::accept`.
fn mlt_accept() {
    if (mlt_large_step) {
        mlt_last_large_step = mlt_iteration;
    }
}

// Twin of `MltSampler::reject`: every number the proposal changed gets its value back.
fn mlt_reject() {
    for (var i = 0u; i < mlt_used; i++) {
        let x = mlt_numbers_private[i];
        if ((x.modified & ~MLT_SET) == mlt_iteration) {
            mlt_numbers_private[i] = MltNumberGpu(x.backup_value, x.backup_value, x.backup_modified, x.backup_modified);
        }
    }
    mlt_iteration -= 1u;
}

// Twin of `StreamNumbers::start_stream`.
fn mlt_start_stream(stream: u32) {
    mlt_stream = stream;
    mlt_index = 0u;
}

// Twin of `MltSampler::next`: the stream's next number, brought up to this iteration.
fn mlt_next() -> f32 {
    if (mlt_index >= MLT_NUMBERS_PER_STREAM) {
        mlt_overflow = true;
        return 0.5;
    }
    let i = mlt_index * MLT_STREAMS + mlt_stream;
    mlt_index += 1u;
    mlt_used = max(mlt_used, i + 1u);
    var x = mlt_numbers_private[i];
    let was_set = (x.modified & MLT_SET) != 0u;
    var modified = x.modified & ~MLT_SET;
    // Untouched since before the last accepted large step: that step replaced it.
    if (was_set && modified < mlt_last_large_step) {
        x.value = mlt_sampler_next_1d();
        modified = mlt_last_large_step;
    }
    x.backup_value = x.value;
    x.backup_modified = modified | select(0u, MLT_SET, was_set);
    if (mlt_large_step || !was_set) {
        x.value = mlt_sampler_next_1d();
    } else {
        // The small steps it missed add up to one of deviation σ·√n.
        let missed = f32(mlt_iteration - modified);
        let u1 = 1.0 - mlt_sampler_next_1d();
        let u2 = mlt_sampler_next_1d();
        let normal = sqrt(-2.0 * log(u1)) * cos(2.0 * PI * u2);
        let moved = x.value + normal * MLT_SIGMA * sqrt(missed);
        let wrapped = moved - floor(moved);
        // A tiny negative step can round up to exactly 1.
        x.value = select(0.0, wrapped, wrapped < 1.0);
    }
    x.modified = mlt_iteration | MLT_SET;
    mlt_numbers_private[i] = x;
    return x.value;
}
