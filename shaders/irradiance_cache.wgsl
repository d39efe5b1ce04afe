// Twin of src/integrator/irradiance_cache.rs: the lookup a camera sample makes at its first
// Lambertian vertex (`IrradianceCache::lookup`), and the placement's device passes.
//
// Placement (the CPU twin's `IrradianceCache::build_on_device` explains the division of
// work): `ic_first_vertex` finds every pixel's first Lambertian vertex, and `render`'s
// gather mode (shaders/path.wgsl) traces the gather rays of the records a phase needs, one
// ray per invocation, from `ic_gather_start`. The host reduces each record's rays, places
// the records and uploads them as `IrradianceCacheTables` (shaders/bindings.wgsl); the
// lookup reads them in the host's order, so the kernel sums the same records in the same
// order as the CPU.

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

// The placement passes' buffers (`IcPlacement` in src/gpu/renderer.rs): every pixel's first
// Lambertian vertex, the pixels whose records a gather round traces (record r's rays are
// jobs r·M·3M to (r + 1)·M·3M − 1), and each job's result. One unused element each until a
// cache is placed.
@group(0) @binding(27) var<storage, read_write> ic_vertices: array<IcVertexGpu>;
@group(0) @binding(28) var<storage, read_write> ic_gather_pixels: array<u32>;
@group(0) @binding(29) var<storage, read_write> ic_gather_results: array<IcGatherResultGpu>;

// Twins of `OVERTURE_SALT`, `MAX_DELTA_CHAIN` and `IC_STREAM`.
const IC_OVERTURE_SALT: u32 = 0x1c0ffee5u;
const IC_MAX_DELTA_CHAIN: u32 = 16u;
const IC_STREAM: u32 = 0xfffffffdu;

// Twin of `first_lambertian_vertex`: pixel (x, y)'s overture camera path through delta
// bounces to its first vertex with a Lambertian lobe. `frame.cone_width` and `cone_spread`
// hold one pixel's cone (a one-sample render's), as on the CPU.
@compute @workgroup_size(8, 8, 1)
fn ic_first_vertex(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    let x = px.x;
    let y = px.y;
    sampler_start(SAMPLER_INDEPENDENT, x, y, 0u, frame.seed ^ IC_OVERTURE_SALT);
    var ray = generate_camera_ray(frame.width, frame.height, x, y, rng_next_2d());
    var out: IcVertexGpu;
    out.triangle = INVALID_INDEX;
    var travelled = 0.0;
    var rays = 0u;
    for (var bounce = 0u; bounce <= IC_MAX_DELTA_CHAIN; bounce += 1u) {
        rays += 1u;
        var alpha_seed = 0u;
        if (FEATURE_ALPHA) {
            alpha_seed = rng_next_u32();
        }
        let hit = intersect_closest(ray, alpha_seed);
        if (hit.triangle == INVALID_INDEX) {
            break;
        }
        let cone_width = frame.cone_width + frame.cone_spread * (travelled + hit.t);
        let si = surface_interaction(ray, hit, cone_width);
        travelled += si.distance;
        // `vertex_material`: textures at their finest level.
        let material = textured_material(materials[si.material], si.uv, vec2<f32>(LOD_FINEST));
        let bsdf = gltf_bsdf_new(material, si.wo, si.front_face, si.coat_normal);
        if (has_lambert_lobe(bsdf)) {
            out = IcVertexGpu(ray.origin, hit.triangle, ray.direction, hit.t, hit.b, cone_width, si.p,
                frame.cone_width + frame.cone_spread * travelled, si.frame.x, 0u, si.frame.y, 0u, si.frame.z, 0u);
            break;
        }
        let u_lobe = rng_next_1d();
        let bs = gltf_bsdf_sample(bsdf, si.wo, u_lobe, rng_next_2d());
        if (!bs.valid || !bs.is_delta) {
            break;
        }
        let wi = normalize(frame_from_local(si.frame, bs.wi));
        if (!sides_agree(si, wi, bs.wi)) {
            break;
        }
        ray = spawn_ray(si.p, si.p_error, si.n_geometric, wi);
    }
    out.rays = rays;
    ic_vertices[y * frame.width + x] = out;
}

// How a gather ray starts (`render`'s gather mode): the ray, the cone width its hits are
// shaded with, and whether it is traced at all.
struct IcGatherStart {
    ray: Ray,
    cone_width: f32,
    traced: bool,
}

// Twin of one stratum of `compute_record`'s gather: job `job` of the round is stratum
// (j, k) of record `job / (M·3M)`, its direction θ_j = asin √((j + ξ)/M),
// φ_k = 2π(k + ξ')/3M in the record's shading frame, its numbers from
// `Rng::new(pixel, IC_STREAM, round · M·3M + stratum, seed)`. A direction below the
// geometric surface is not traced (no light, no distance), as on the CPU.
fn ic_gather_start(job: u32) -> IcGatherStart {
    let m = frame.ic_gather_polar_strata;
    let n = 3u * m;
    let count = m * n;
    let stratum = job % count;
    let pixel = ic_gather_pixels[job / count];
    let v = ic_vertices[pixel];
    let si = surface_interaction(Ray(v.origin, v.direction, F32_MAX), ClosestHit(v.triangle, v.b, v.t), v.cone_width);
    path_sampler_kind = SAMPLER_INDEPENDENT;
    xoshiro_seed(vec4<u32>(pixel, IC_STREAM, frame.ic_gather_round * count + stratum, frame.seed));
    let u = rng_next_2d();
    let j = stratum / n;
    let k = stratum % n;
    let sin2 = (f32(j) + u.x) / f32(m);
    let sin_theta = sqrt(sin2);
    let cos_theta = sqrt(max(1.0 - sin2, 0.0));
    let phi = 2.0 * PI * (f32(k) + u.y) / f32(n);
    let local = vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
    let world = normalize(frame_from_local(si.frame, local));
    let ray = spawn_ray(si.p, si.p_error, si.n_geometric, world);
    return IcGatherStart(ray, v.footprint, sides_agree(si, world, local));
}
