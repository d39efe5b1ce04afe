// Twin of src/integrator/irradiance_cache.rs: the lookup a camera sample makes at its first
// Lambertian vertex (`IrradianceCache::lookup`). The records are placed on the host and
// uploaded as `IrradianceCacheTables` (shaders/bindings.wgsl); this file reads them in the
// host's order, so the kernel sums the same records in the same order as the CPU.

// Does the kernel read an irradiance cache? Off, its code folds away (src/gpu/context.rs
// builds the path tracer's kernel each way on demand).
override IRRADIANCE_CACHE: bool = false;

// Twin of `FALLBACK_REACH`.
const IC_FALLBACK_REACH: f32 = 2.0;

fn ic_rotate_left_13(x: u32) -> u32 {
    return (x << 13u) | (x >> 19u);
}

// Twin of `cell_hash`.
fn ic_cell_hash(key: vec4<i32>) -> u32 {
    var h = bitcast<u32>(key.x) * 0x9e3779b1u;
    h = ic_rotate_left_13(h ^ (bitcast<u32>(key.y) * 0x85ebca77u));
    h = ic_rotate_left_13(h ^ (bitcast<u32>(key.z) * 0xc2b2ae3du));
    h ^= bitcast<u32>(key.w) * 0x27d4eb2fu;
    h ^= h >> 15u;
    h *= 0x2c1b3c6du;
    return h ^ (h >> 12u);
}

// The run (start, count) of record indices that grid cell `key` lists; count 0 where the
// table has no such cell. The table is at most half full, so an empty slot ends a probe.
fn ic_find_cell(key: vec4<i32>) -> vec2<u32> {
    let mask = frame.ic_table_mask;
    var slot = ic_cell_hash(key) & mask;
    for (var probe = 0u; probe <= mask; probe += 1u) {
        let cell = ic_cells[slot];
        if (cell.count == 0u) {
            break;
        }
        if (all(cell.key == key)) {
            return vec2<u32>(cell.start, cell.count);
        }
        slot = (slot + 1u) & mask;
    }
    return vec2<u32>(0u, 0u);
}

// Twin of `IrradianceCache::lookup`: the irradiance at p (unit normal n) in xyz with w = 1,
// or w = 0 where no record serves p (the sample is then path traced).
fn ic_lookup(p: vec3<f32>, n: vec3<f32>) -> vec4<f32> {
    var valid_sum = vec3<f32>(0.0);
    var valid_weight = 0.0;
    var near_sum = vec3<f32>(0.0);
    var near_weight = 0.0;
    let levels = ic_indices[0];
    for (var li = 0u; li < levels; li += 1u) {
        let level = bitcast<i32>(ic_indices[1u + li]);
        // p times the exact reciprocal of the cell's side 2^level, as the host's `cell_of`.
        let c = vec3<i32>(floor(p * ldexp(1.0, -level)));
        let run = ic_find_cell(vec4<i32>(level, c));
        for (var k = 0u; k < run.y; k += 1u) {
            let r = ic_records[ic_indices[run.x + k]];
            let offset = p - r.p;
            let d = length(offset);
            if (d >= IC_FALLBACK_REACH * r.radius) {
                continue;
            }
            // Ward's test (the CPU twin explains).
            if (dot(offset, n + r.n) * 0.5 < -0.05 * r.radius) {
                continue;
            }
            let normal_term = sqrt(max(1.0 - dot(n, r.n), 0.0)) / frame.ic_normal_scale;
            let epsilon = max(d / r.radius, normal_term);
            if (epsilon >= IC_FALLBACK_REACH) {
                continue;
            }
            var e = r.e;
            if (frame.ic_gradients != 0u) {
                let turn = cross(r.n, n);
                for (var ch = 0u; ch < 3u; ch += 1u) {
                    e[ch] += dot(turn, r.rotational[ch].xyz) + dot(offset, r.translational[ch].xyz);
                }
            }
            if (epsilon < 1.0) {
                let w = 1.0 - epsilon;
                valid_sum += w * e;
                valid_weight += w;
            } else if (valid_weight == 0.0) {
                let w = IC_FALLBACK_REACH - epsilon;
                near_sum += w * e;
                near_weight += w;
            }
        }
    }
    if (valid_weight > 0.0) {
        return vec4<f32>(max(valid_sum / valid_weight, vec3<f32>(0.0)), 1.0);
    }
    if (near_weight > 0.0) {
        return vec4<f32>(max(near_sum / near_weight, vec3<f32>(0.0)), 1.0);
    }
    return vec4<f32>(0.0);
}
