// Twin of `film_add_sample` in src/film/mod.rs: Welford's update (Welford 1962); non-finite
// samples are counted and never accumulated.

fn film_add_sample(p_in: FilmPixel, x: vec3<f32>, replicate: u32) -> FilmPixel {
    var p = p_in;
    if (!is_finite_vec3(x)) {
        p.rejected += 1u;
        return p;
    }
    p.count += 1u;
    let n = f32(p.count);
    let delta = x - p.mean;
    p.mean = p.mean + delta / n;
    p.m2 = p.m2 + delta * (x - p.mean);
    if (replicate == 1u) {
        p.odd_count += 1u;
        p.odd_mean = p.odd_mean + (x - p.odd_mean) / f32(p.odd_count);
    }
    return p;
}

// The light tracer's image (`caustics`, shaders/bindings.wgsl) in 64-bit fixed point with
// CAUSTIC_FRACTION_BITS fraction bits: twin of `caustic_to_fixed` / `caustic_from_fixed` in
// src/integrator/light_tracing.rs. Integer adds commute, so the image's bits do not depend on the
// order in which the light paths' splats arrive.
const CAUSTIC_FRACTION_BITS: u32 = 20u;
const CAUSTIC_MAX_FIXED: f32 = 17592186044416.0;

// Adds one splat (finite, ≥ 0) to `pixel`: each channel rounded half to even to a multiple
// of 2⁻²⁰, clamped to 2⁴⁴, split exactly into its high and low words (both products are by
// powers of two), and added with the low word's carry.
fn caustic_splat(pixel: u32, value: vec3<f32>) {
    for (var c = 0u; c < 3u; c++) {
        let x = min(round(value[c] * f32(1u << CAUSTIC_FRACTION_BITS)), CAUSTIC_MAX_FIXED);
        if (x <= 0.0) {
            continue;
        }
        let high = u32(floor(x * (1.0 / 4294967296.0)));
        let low = u32(x - f32(high) * 4294967296.0);
        let word = 6u * pixel + 2u * c;
        let old_low = atomicAdd(&caustics[word + 1u], low);
        let carry = select(0u, 1u, old_low > 0xffffffffu - low);
        if (high + carry != 0u) {
            atomicAdd(&caustics[word], high + carry);
        }
    }
}

// The light tracer's image at `pixel` in radiance.
fn caustic_radiance(pixel: u32) -> vec3<f32> {
    var out = vec3<f32>(0.0);
    for (var c = 0u; c < 3u; c++) {
        let word = 6u * pixel + 2u * c;
        let high = f32(atomicLoad(&caustics[word])) * f32(1u << (32u - CAUSTIC_FRACTION_BITS));
        let low = f32(atomicLoad(&caustics[word + 1u])) * (1.0 / f32(1u << CAUSTIC_FRACTION_BITS));
        out[c] = high + low;
    }
    return out;
}

// A NaN, to poison a sample whose throughput stopped being finite (the film rejects it).
fn poison() -> vec3<f32> {
    return vec3<f32>(bitcast<f32>(0x7fc00000u));
}
