// Twin of src/integrator/sppm.rs: stochastic progressive photon mapping (Hachisuka & Jensen
// 2009; pbrt-v4 `SPPMIntegrator`). The CPU twin explains the estimator, its radius update
// and the order in which random numbers are drawn. A pass runs as these entry points, in
// order (`GpuBackend::submit_sppm_pass`):
// 1. `sppm_visible`: each pixel's camera path to its visible point (`sppm_camera_path`),
//    into `sppm_visible_points`; a pixel's first visible point sets its radius.
// 2. `sppm_trace_photons`: the pass's photons, appended to `sppm_photons` (an atomic count;
//    a record past `frame.sppm_record_capacity` is dropped and counted).
// 3. `sppm_grid_setup`: the grid's cell edge (twice the mean radius) and the dispatch size
//    of the record passes; the pass's stored and dropped records are counted.
// 4. The uniform hash grid by count, prefix sum and scatter (`sppm_grid_count`,
//    `sppm_scan_blocks`, `sppm_scan_totals`, `sppm_scan_add`, `sppm_grid_scatter`): slot s's
//    photons are `sppm_order[end(s − 1)..end(s)]`, end(s) being `sppm_grid`'s word for s.
// 5. `sppm_gather`: each visible point gathers the photons within its pixel's radius,
//    updates the pixel's state and adds the pass's estimate to the film.
//
// The scatter places a slot's photons in the order its atomics ran, so a gather sums them
// in an order that may differ from run to run and from the CPU's: the images agree to
// rounding, not bit for bit. Which photons a pixel gathers, and so its photon count and
// radius, do not depend on the order.

// Twin of SPPM_ALPHA.
const SPPM_ALPHA: f32 = 2.0 / 3.0;
// Twin of SPPM_ALPHA_ONE_PLANE.
const SPPM_ALPHA_ONE_PLANE: f32 = 0.75;
// Twin of ONE_PLANE_AREA_TOLERANCE.
const ONE_PLANE_AREA_TOLERANCE: f32 = 0.01;
// Twin of PHOTON_STREAM.
const PHOTON_STREAM: u32 = 0xfffffffeu;
// Twins of PLANE_TOLERANCE, STEP_TOLERANCE and PLANE_POSITION_ERROR (32 f32::EPSILON).
const PLANE_TOLERANCE: f32 = 0.1;
const STEP_TOLERANCE: f32 = 1e-3;
const PLANE_POSITION_ERROR: f32 = 3.814697265625e-6;

// Twin of `plane_tolerances`: (tolerance, step) for a gather within `radius` where the larger
// coordinate's magnitude is `magnitude`.
fn sppm_plane_tolerances(radius: f32, magnitude: f32) -> vec2<f32> {
    let tolerance = PLANE_TOLERANCE * radius;
    return vec2<f32>(tolerance, min(max(STEP_TOLERANCE * radius, PLANE_POSITION_ERROR * magnitude), tolerance));
}

// The words of `sppm_grid` before its slots: this pass's photon records (appended by
// `sppm_trace_photons`), the cell edge (f32 bits), running totals the host reads for
// `SppmStats` (photon rays, stored and dropped records, each a 64-bit count in two words,
// low then high), and the workgroup counts (x, y, z) of the record passes, which the host
// copies into the indirect dispatches' buffer (a buffer bound for storage cannot be read
// as an indirect argument in the same dispatch). The slots' words follow, then the scan's
// block sums.
const SPPM_RECORDS: u32 = 0u;
const SPPM_CELL: u32 = 1u;
const SPPM_PHOTON_RAYS: u32 = 2u;
const SPPM_STORED: u32 = 4u;
const SPPM_DROPPED: u32 = 6u;
const SPPM_DISPATCH: u32 = 8u;
const SPPM_HEADER_WORDS: u32 = 12u;
// Slots per block of the prefix sum: one workgroup's.
const SPPM_SCAN_BLOCK: u32 = 256u;
// Invocations per workgroup of the passes over photon records.
const SPPM_RECORD_GROUP: u32 = 256u;

@group(0) @binding(27) var<storage, read_write> sppm_pixels: array<SppmPixelGpu>;
@group(0) @binding(28) var<storage, read_write> sppm_visible_points: array<SppmVisiblePoint>;
@group(0) @binding(29) var<storage, read_write> sppm_photons: array<SppmPhoton>;
@group(0) @binding(30) var<storage, read_write> sppm_grid: array<atomic<u32>>;
@group(0) @binding(31) var<storage, read_write> sppm_order: array<u32>;

fn sppm_photon_p(ph: SppmPhoton) -> vec3<f32> {
    return ph.position_wi_x.xyz;
}

fn sppm_photon_wi(ph: SppmPhoton) -> vec3<f32> {
    return vec3<f32>(ph.position_wi_x.w, ph.wi_yz_beta_rg.xy);
}

fn sppm_photon_beta(ph: SppmPhoton) -> vec3<f32> {
    return vec3<f32>(ph.wi_yz_beta_rg.zw, ph.beta_b_normal.x);
}

fn sppm_photon_n(ph: SppmPhoton) -> vec3<f32> {
    return ph.beta_b_normal.yzw;
}

// Adds `value` to the 64-bit count at words `word` (low) and `word + 1` (high).
fn sppm_add_u64(word: u32, value: u32) {
    let old_low = atomicAdd(&sppm_grid[word], value);
    if (old_low > 0xffffffffu - value) {
        atomicAdd(&sppm_grid[word + 1u], 1u);
    }
}

// A photon map in the shared buffers: its grid's first word in `sppm_grid` (its header,
// slots and block sums follow) and its first record in `sppm_photons` (its run of
// `sppm_order` starts there too). SPPM has one, at (0, 0); the photon-map integrator
// (shaders/photon.wgsl) a global and a caustic one.
struct SppmMap {
    grid: u32,
    records: u32,
}

// The map a build dispatch writes (`frame.photon_grid_base`, `frame.photon_record_base`).
fn sppm_current_map() -> SppmMap {
    return SppmMap(frame.photon_grid_base, frame.photon_record_base);
}

fn sppm_cell_edge(map: SppmMap) -> f32 {
    return bitcast<f32>(atomicLoad(&sppm_grid[map.grid + SPPM_CELL]));
}

// Twin of `PhotonGrid::cell_of` (f32 to i32 saturates in WGSL as `as i32` does in Rust).
fn sppm_cell_of(p: vec3<f32>, cell: f32) -> vec3<i32> {
    return vec3<i32>(floor(p / cell));
}

// Twin of `PhotonGrid::slot`.
fn sppm_slot(c: vec3<i32>) -> u32 {
    let h = (bitcast<u32>(c.x) * 73856093u) ^ (bitcast<u32>(c.y) * 19349663u) ^ (bitcast<u32>(c.z) * 83492791u);
    return h & frame.sppm_slot_mask;
}

// The word of slot s in `sppm_grid`: its count, then (after the scan) its run's start, then
// (after the scatter) its run's end.
fn sppm_slot_word(map: SppmMap, s: u32) -> u32 {
    return map.grid + SPPM_HEADER_WORDS + s;
}

// The word of the scan's block `b` sum, after the slots.
fn sppm_block_word(map: SppmMap, b: u32) -> u32 {
    return map.grid + SPPM_HEADER_WORDS + frame.sppm_slot_mask + 1u + b;
}

// A pixel's camera path up to its visible point: the point (`triangle` INVALID_INDEX where
// there is none), and the visible point's own BSDF sample with the throughput before it,
// for what the caller adds along that sample (`at_visible_point` in the CPU twin).
struct SppmCameraPath {
    point: SppmVisiblePoint,
    throughput: vec3<f32>,
    bs: BsdfSample,
}

// Twin of `camera_path` but for the `at_visible_point` call, which the caller makes on its
// return (no number is drawn in between): `sppm_bsdf_sampled_emission` for SPPM, the final
// gather for the photon-map integrator.
fn sppm_camera_path(x: u32, y: u32, k: u32) -> SppmCameraPath {
    var path: SppmCameraPath;
    path.point.triangle = INVALID_INDEX;
    sampler_start(frame.sampler_kind, x, y, k, frame.seed);
    var ray = generate_camera_ray(frame.width, frame.height, x, y, rng_next_2d());
    var beta = vec3<f32>(1.0);
    var eta_scale = 1.0;
    var travelled = 0.0;
    var direct = vec3<f32>(0.0);
    var prev_delta = true;
    var prev_pdf = 0.0;
    var non_delta_depth = 0u;
    for (var depth = 0u; depth <= MAX_BOUNCES_GUARD; depth++) {
        var alpha_seed = 0u;
        if (FEATURE_ALPHA) {
            alpha_seed = rng_next_u32();
        }
        let hit = intersect_closest(ray, alpha_seed);
        if (hit.triangle == INVALID_INDEX) {
            if (FEATURE_ENVIRONMENT && environment.present != 0u) {
                let env = environment_lookup(ray.direction);
                var weight = 1.0;
                if (!prev_delta && environment.light_index != INVALID_INDEX) {
                    weight = power_heuristic(prev_pdf, lights[environment.light_index].pmf * env.pdf_solid_angle);
                }
                direct += beta * env.radiance * weight;
            }
            break;
        }
        let cone_width = frame.cone_width + frame.cone_spread * (travelled + hit.t);
        let si = surface_interaction(ray, hit, cone_width);
        travelled += si.distance;
        let untextured = materials[si.material];
        let material = textured_material(untextured, si.uv, si.lod);
        if (FEATURE_VOLUME && (material.flags & MATERIAL_VOLUME) != 0u && !si.front_face) {
            beta *= exp(-material.attenuation_coefficient * si.distance);
        }
        if (max_element(untextured.emission) > 0.0 && (si.front_face || (material.flags & MATERIAL_DOUBLE_SIDED) != 0u)) {
            if (prev_delta || si.emitter == INVALID_INDEX) {
                direct += beta * material.emission;
            } else {
                let le = emitted_radiance(untextured, hit.triangle, hit.b);
                direct += beta * le * power_heuristic(prev_pdf, triangle_light_pdf(lights[si.emitter], ray.origin, si.p));
            }
        }
        if (depth == MAX_BOUNCES_GUARD) {
            break;
        }
        let bsdf = gltf_bsdf_new(material, si.wo, si.front_face, si.coat_normal);
        direct += next_event(si, bsdf, beta);
        let u_lobe = rng_next_1d();
        let u_dir = rng_next_direction_2d();
        let bs = gltf_bsdf_sample(bsdf, si.wo, u_lobe, u_dir);
        if (!bs.valid) {
            break;
        }
        if (!bs.is_delta && has_diffuse_lobe(bsdf)) {
            // (The throughput is finite here: a bounce that made it otherwise returned.)
            path.point.origin = ray.origin;
            path.point.triangle = hit.triangle;
            path.point.direction = ray.direction;
            path.point.t = hit.t;
            path.point.b = hit.b;
            path.point.cone_width = cone_width;
            path.point.beta = beta / non_delta_probability(bsdf);
            path.point.footprint = frame.sppm_footprint_width + frame.sppm_footprint_spread * travelled;
            path.point.direct = direct;
            path.throughput = beta;
            path.bs = bs;
            return path;
        }
        let wi_world = normalize(frame_from_local(si.frame, bs.wi));
        if (!sides_agree(si, wi_world, bs.wi)) {
            break;
        }
        beta *= bs.weight;
        eta_scale *= bs.eta_scale;
        if (!is_finite_vec3(beta)) {
            path.point.direct = poison();
            return path;
        }
        prev_delta = bs.is_delta;
        prev_pdf = bs.pdf_solid_angle;
        if (!bs.is_delta) {
            non_delta_depth += 1u;
        }
        ray = spawn_ray(si.p, si.p_error, si.n_geometric, wi_world);
        if (non_delta_depth >= frame.rr_min_depth || depth + 1u >= RR_ANY_BOUNCE_DEPTH) {
            let q = survival_probability(beta, eta_scale);
            if (q <= 0.0 || rng_next_1d() >= q) {
                break;
            }
            beta /= q;
        }
    }
    path.point.direct = direct;
    return path;
}

// The surface interaction, material and BSDF of visible point `vp`, built again from its
// ray and hit with the operations that first built them (the same bits).
struct SppmSurface {
    si: SurfaceInteraction,
    bsdf: GltfBsdf,
}

fn sppm_surface(vp: SppmVisiblePoint) -> SppmSurface {
    let ray = Ray(vp.origin, vp.direction, F32_MAX);
    let si = surface_interaction(ray, ClosestHit(vp.triangle, vp.b, vp.t), vp.cone_width);
    let material = textured_material(materials[si.material], si.uv, si.lod);
    return SppmSurface(si, gltf_bsdf_new(material, si.wo, si.front_face, si.coat_normal));
}

// Twin of `bsdf_sampled_emission`: the emitter the visible point's own BSDF sample `bs`
// sees (throughput `beta` before it), MIS-weighted against the light sample.
fn sppm_bsdf_sampled_emission(si: SurfaceInteraction, bs: BsdfSample, beta: vec3<f32>) -> vec3<f32> {
    let wi_world = normalize(frame_from_local(si.frame, bs.wi));
    if (!sides_agree(si, wi_world, bs.wi)) {
        return vec3<f32>(0.0);
    }
    let ray = spawn_ray(si.p, si.p_error, si.n_geometric, wi_world);
    var seed = 0u;
    if (FEATURE_ALPHA) {
        seed = rng_next_u32();
    }
    let hit = intersect_closest(ray, seed);
    return beta * bs.weight * sppm_mis_weighted_emission(ray, hit, bs.pdf_solid_angle);
}

// Twin of `mis_weighted_emission`.
fn sppm_mis_weighted_emission(ray: Ray, hit: ClosestHit, pdf_bsdf: f32) -> vec3<f32> {
    if (hit.triangle == INVALID_INDEX) {
        if (!FEATURE_ENVIRONMENT || environment.present == 0u) {
            return vec3<f32>(0.0);
        }
        let env = environment_lookup(ray.direction);
        var weight = 1.0;
        if (environment.light_index != INVALID_INDEX) {
            weight = power_heuristic(pdf_bsdf, lights[environment.light_index].pmf * env.pdf_solid_angle);
        }
        return env.radiance * weight;
    }
    let si = surface_interaction(ray, hit, 0.0);
    let material = materials[si.material];
    if (max_element(material.emission) <= 0.0 || !(si.front_face || (material.flags & MATERIAL_DOUBLE_SIDED) != 0u)) {
        return vec3<f32>(0.0);
    }
    let le = emitted_radiance(material, hit.triangle, hit.b);
    var weight = 1.0;
    if (si.emitter != INVALID_INDEX) {
        weight = power_heuristic(pdf_bsdf, triangle_light_pdf(lights[si.emitter], ray.origin, si.p));
    }
    return le * weight;
}

// Step 1: pixel (x, y)'s camera path of pass `frame.sample_offset`, over the band's rows.
@compute @workgroup_size(8, 8, 1)
fn sppm_visible(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    let pixel = px.y * frame.width + px.x;
    rays_traced = 0u;
    let path = sppm_camera_path(px.x, px.y, frame.sample_offset);
    var vp = path.point;
    if (vp.triangle != INVALID_INDEX) {
        vp.direct += sppm_bsdf_sampled_emission(sppm_surface(vp).si, path.bs, path.throughput);
    }
    sppm_visible_points[pixel] = vp;
    // A pixel's first visible point sets its radius.
    if (vp.triangle != INVALID_INDEX && sppm_pixels[pixel].radius == 0.0) {
        sppm_pixels[pixel].radius = frame.sppm_radius_pixels * max(vp.footprint, frame.scene_radius * 1e-6);
    }
    ray_counts[pixel] += rays_traced;
}

// Step 2: photon i of the pass (`dispatch_item`), for i below `frame.sppm_photons` (twin of
// `trace_photons`), into the map `frame.photon_grid_base` and `frame.photon_record_base`
// name, keeping the landings `frame.photon_kind` says.
@compute @workgroup_size(8, 8, 1)
fn sppm_trace_photons(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    load_dispatch_constants();
    let i = dispatch_item(gid, groups, frame.sppm_photons);
    if (i == INVALID_INDEX) {
        return;
    }
    rays_traced = 0u;
    sampler_start(SAMPLER_INDEPENDENT, i, PHOTON_STREAM, frame.sample_offset, frame.seed);
    sppm_trace_photon();
    sppm_add_u64(SPPM_PHOTON_RAYS, rays_traced);
}

// Twins of `PhotonKind`: which landings a map keeps (`frame.photon_kind`).
const PHOTONS_INDIRECT: u32 = 0u;
const PHOTONS_ALL: u32 = 1u;
const PHOTONS_CAUSTIC: u32 = 2u;

// Twin of `trace_photon`: a photon at every surface with a non-delta lobe that the map's
// kind keeps, appended to the map this dispatch builds.
fn sppm_trace_photon() {
    let map = sppm_current_map();
    let kind = frame.photon_kind;
    var prev: BdptVertex;
    var walk: BdptWalk;
    if (!bdpt_light_origin(&prev, &walk)) {
        return;
    }
    // Every bounce so far was by a delta lobe.
    var delta_so_far = true;
    for (var here = 1u; ; here++) {
        var v: BdptVertex;
        var si: SurfaceInteraction;
        var material: Material;
        var bsdf: GltfBsdf;
        if (!bdpt_trace(&walk, prev, &v, &si, &material, &bsdf)) {
            return;
        }
        var kept = kind == PHOTONS_ALL;
        if (kind == PHOTONS_INDIRECT) {
            kept = here >= 2u;
        } else if (kind == PHOTONS_CAUSTIC) {
            kept = here >= 2u && delta_so_far;
        }
        if (v.kind == VERTEX_SURFACE && kept && has_non_delta(bsdf) && is_finite_vec3(v.beta)) {
            let record = atomicAdd(&sppm_grid[map.grid + SPPM_RECORDS], 1u);
            if (record < frame.sppm_record_capacity) {
                let wi = si.wo_world;
                sppm_photons[map.records + record] = SppmPhoton(vec4<f32>(v.p, wi.x), vec4<f32>(wi.yz, v.beta.xy), vec4<f32>(v.beta.z, v.n));
            }
        }
        if (bdpt_scatter(&walk, &v, si, bsdf, prev, here) < 0.0) {
            return;
        }
        delta_so_far = delta_so_far && v.delta;
        if (kind == PHOTONS_CAUSTIC && !delta_so_far) {
            // No later landing can be a caustic's.
            return;
        }
        prev = v;
    }
}

var<workgroup> sppm_radius_sums: array<f32, 256>;
var<workgroup> sppm_radius_counts: array<u32, 256>;

// Step 3, one workgroup: the cell edge, twice the mean radius of the pixels with a visible
// point (twin of the CPU's `mean_radius`, summed in another order: the edge only sizes the
// cells, and a gather reads every cell its disk overlaps whatever their size), or
// `frame.photon_cell` where the host gives one (the photon maps'); the record passes'
// workgroup counts; the pass's stored and dropped records.
@compute @workgroup_size(256, 1, 1)
fn sppm_grid_setup(@builtin(local_invocation_index) lane: u32) {
    load_dispatch_constants();
    let pixels = frame.width * frame.height;
    var sum = 0.0;
    var count = 0u;
    // The photon maps' cells are the host's; their kernel keeps no visible points.
    let pixels_read = select(pixels, 0u, frame.photon_cell > 0.0);
    for (var i = lane; i < pixels_read; i += 256u) {
        let radius = sppm_pixels[i].radius;
        if (sppm_visible_points[i].triangle != INVALID_INDEX && radius > 0.0) {
            sum += radius;
            count += 1u;
        }
    }
    sppm_radius_sums[lane] = sum;
    sppm_radius_counts[lane] = count;
    workgroupBarrier();
    for (var stride = 128u; stride > 0u; stride >>= 1u) {
        if (lane < stride) {
            sppm_radius_sums[lane] += sppm_radius_sums[lane + stride];
            sppm_radius_counts[lane] += sppm_radius_counts[lane + stride];
        }
        workgroupBarrier();
    }
    if (lane == 0u) {
        var cell = 1.0;
        let n = sppm_radius_counts[0];
        if (n > 0u) {
            let mean = sppm_radius_sums[0] / f32(n);
            if (is_finite_f32(mean) && mean > 0.0) {
                cell = 2.0 * mean;
            }
        }
        if (frame.photon_cell > 0.0) {
            cell = frame.photon_cell;
        }
        let map = sppm_current_map();
        atomicStore(&sppm_grid[map.grid + SPPM_CELL], bitcast<u32>(cell));
        let records = atomicLoad(&sppm_grid[map.grid + SPPM_RECORDS]);
        let stored = min(records, frame.sppm_record_capacity);
        atomicStore(&sppm_grid[map.grid + SPPM_RECORDS], stored);
        sppm_add_u64(SPPM_STORED, stored);
        sppm_add_u64(SPPM_DROPPED, records - stored);
        atomicStore(&sppm_grid[map.grid + SPPM_DISPATCH], max((stored + SPPM_RECORD_GROUP - 1u) / SPPM_RECORD_GROUP, 1u));
        atomicStore(&sppm_grid[map.grid + SPPM_DISPATCH + 1u], 1u);
        atomicStore(&sppm_grid[map.grid + SPPM_DISPATCH + 2u], 1u);
    }
}

fn sppm_record_count(map: SppmMap) -> u32 {
    return atomicLoad(&sppm_grid[map.grid + SPPM_RECORDS]);
}

// Step 4a: each stored photon counts itself in its cell's slot.
@compute @workgroup_size(256, 1, 1)
fn sppm_grid_count(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let map = sppm_current_map();
    if (gid.x >= sppm_record_count(map)) {
        return;
    }
    let c = sppm_cell_of(sppm_photon_p(sppm_photons[map.records + gid.x]), sppm_cell_edge(map));
    atomicAdd(&sppm_grid[sppm_slot_word(map, sppm_slot(c))], 1u);
}

var<workgroup> sppm_scan: array<u32, 256>;

// The exclusive prefix sum of `sppm_scan` in place (Hillis & Steele 1986 steps on the
// inclusive sums, then shifted); returns the total. Every invocation of the workgroup calls it.
fn sppm_scan_workgroup(lane: u32, value: u32) -> u32 {
    sppm_scan[lane] = value;
    workgroupBarrier();
    for (var offset = 1u; offset < 256u; offset <<= 1u) {
        var add = 0u;
        if (lane >= offset) {
            add = sppm_scan[lane - offset];
        }
        workgroupBarrier();
        sppm_scan[lane] += add;
        workgroupBarrier();
    }
    let total = sppm_scan[255];
    let exclusive = sppm_scan[lane] - value;
    workgroupBarrier();
    sppm_scan[lane] = exclusive;
    workgroupBarrier();
    return total;
}

// Step 4b: block `group` of SPPM_SCAN_BLOCK slots: counts to starts within the block; the
// block's total to its block word.
@compute @workgroup_size(256, 1, 1)
fn sppm_scan_blocks(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    load_dispatch_constants();
    let map = sppm_current_map();
    let s = group.x * SPPM_SCAN_BLOCK + lane;
    let word = sppm_slot_word(map, s);
    let count = atomicLoad(&sppm_grid[word]);
    let total = sppm_scan_workgroup(lane, count);
    atomicStore(&sppm_grid[word], sppm_scan[lane]);
    if (lane == 0u) {
        atomicStore(&sppm_grid[sppm_block_word(map, group.x)], total);
    }
}

// Step 4c, one workgroup: the block totals to block starts; each invocation sums a run of
// consecutive blocks, then the runs' totals are scanned together.
@compute @workgroup_size(256, 1, 1)
fn sppm_scan_totals(@builtin(local_invocation_index) lane: u32) {
    load_dispatch_constants();
    let map = sppm_current_map();
    let blocks = (frame.sppm_slot_mask + 1u) / SPPM_SCAN_BLOCK;
    let per_lane = (blocks + 255u) / 256u;
    let first = min(lane * per_lane, blocks);
    let last = min(first + per_lane, blocks);
    var run = 0u;
    for (var b = first; b < last; b++) {
        run += atomicLoad(&sppm_grid[sppm_block_word(map, b)]);
    }
    _ = sppm_scan_workgroup(lane, run);
    var start = sppm_scan[lane];
    for (var b = first; b < last; b++) {
        let word = sppm_block_word(map, b);
        let total = atomicLoad(&sppm_grid[word]);
        atomicStore(&sppm_grid[word], start);
        start += total;
    }
}

// Step 4d: each slot's start within its block plus its block's start.
@compute @workgroup_size(256, 1, 1)
fn sppm_scan_add(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) lane: u32) {
    load_dispatch_constants();
    let map = sppm_current_map();
    let word = sppm_slot_word(map, group.x * SPPM_SCAN_BLOCK + lane);
    let block_start = atomicLoad(&sppm_grid[sppm_block_word(map, group.x)]);
    atomicAdd(&sppm_grid[word], block_start);
}

// Step 4e: each stored photon takes the next place of its slot's run; each slot's word ends
// at its run's end.
@compute @workgroup_size(256, 1, 1)
fn sppm_grid_scatter(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let map = sppm_current_map();
    if (gid.x >= sppm_record_count(map)) {
        return;
    }
    let record = map.records + gid.x;
    let c = sppm_cell_of(sppm_photon_p(sppm_photons[record]), sppm_cell_edge(map));
    let place = atomicAdd(&sppm_grid[sppm_slot_word(map, sppm_slot(c))], 1u);
    sppm_order[map.records + place] = record;
}

// The photons of `map`'s slot s: `sppm_order[run.x..run.y]`.
fn sppm_run(map: SppmMap, s: u32) -> vec2<u32> {
    var start = 0u;
    if (s > 0u) {
        start = atomicLoad(&sppm_grid[sppm_slot_word(map, s - 1u)]);
    }
    return vec2<u32>(map.records + start, map.records + atomicLoad(&sppm_grid[sppm_slot_word(map, s)]));
}

// Φ (xyz) and M (w) of a gather.
struct SppmGathered {
    phi: vec3<f32>,
    m: u32,
}

// Twin of the test and the sum inside `PhotonGrid::gather`: adds photon `i` to `out` where
// it lies within `radius` of the surface point `si` (BSDF `bsdf`) and can light it.
fn sppm_photon_flux(i: u32, si: SurfaceInteraction, bsdf: GltfBsdf, radius: f32, transmits: bool, out: ptr<function, SppmGathered>) {
    let ph = sppm_photons[i];
    let r2 = radius * radius;
    let p = sppm_photon_p(ph);
    let n = sppm_photon_n(ph);
    let d = p - si.p;
    let ng = si.n_geometric;
    if (dot(d, d) > r2) {
        return;
    }
    let w = sppm_photon_wi(ph);
    // Back-facing photons (the CPU twin explains).
    if (!transmits && (dot(w, n) > 0.0) != (dot(si.wo_world, ng) > 0.0)) {
        return;
    }
    // Twin of `facing_each_other`.
    if (!transmits) {
        let n_point = select(-ng, ng, dot(si.wo_world, ng) > 0.0);
        let n_photon = select(-n, n, dot(w, n) > 0.0);
        let photon_height = dot(d, n_point);
        let point_height = -dot(d, n_photon);
        let lower = min(photon_height, point_height);
        let upper = max(photon_height, point_height);
        let magnitude = max(max(max(abs(si.p.x), abs(si.p.y)), abs(si.p.z)), max(max(abs(p.x), abs(p.y)), abs(p.z)));
        let bounds = sppm_plane_tolerances(radius, magnitude);
        let tolerance = bounds.x;
        let step = bounds.y;
        if (!(lower >= -step || (lower >= -tolerance && upper <= step))) {
            return;
        }
    }
    let wi = frame_to_local(si.frame, w);
    if (!sides_agree(si, w, wi)) {
        return;
    }
    let cos_geometric = abs(dot(w, ng));
    if (cos_geometric <= 0.0) {
        return;
    }
    let f = gltf_bsdf_eval(bsdf, si.wo, wi);
    (*out).phi += sppm_photon_beta(ph) * f * (abs(wi.z) / cos_geometric);
    (*out).m += 1u;
}

// Twins of `crate::bvh::MAX_DEPTH` (the gather area's traversal stack) and
// `MAX_COVERAGE_CORRECTION`.
const GATHER_STACK_SIZE: u32 = 64u;
const MAX_COVERAGE_CORRECTION: f32 = 8.0;

// Twin of `gather_area::segment_area_in_disk`: the signed area of the triangle (0, a, b)
// inside the circle of squared radius rho2 about 0.
fn gather_sector(p: vec2<f32>, q: vec2<f32>, rho2: f32) -> f32 {
    return 0.5 * rho2 * atan2(p.x * q.y - p.y * q.x, dot(p, q));
}

fn gather_segment_area(a: vec2<f32>, b: vec2<f32>, rho2: f32) -> f32 {
    let d = b - a;
    let dd = dot(d, d);
    if (!(dd > 0.0)) {
        return 0.0;
    }
    let t0 = -dot(a, d) / dd;
    let m = a + d * t0;
    let inside2 = rho2 - dot(m, m);
    if (!(inside2 > 0.0)) {
        return gather_sector(a, b, rho2);
    }
    let half = sqrt(inside2 / dd);
    let t1 = t0 - half;
    let t2 = t0 + half;
    if (t1 >= 1.0 || t2 <= 0.0) {
        return gather_sector(a, b, rho2);
    }
    let p1 = select(a, a + d * t1, t1 > 0.0);
    let p2 = select(b, a + d * t2, t2 < 1.0);
    var area = 0.5 * (p1.x * p2.y - p1.y * p2.x);
    if (t1 > 0.0) {
        area += gather_sector(a, p1, rho2);
    }
    if (t2 < 1.0) {
        area += gather_sector(p2, b, rho2);
    }
    return area;
}

// What one gather accepts (twin of `gather_area::GatherRegion`).
struct GatherRegion {
    center: vec3<f32>,
    n_point: vec3<f32>,
    radius: f32,
    tolerance: f32,
    step: f32,
    winding_side: f32,
    transmits: bool,
}

// Twin of `gather_area::clip_to_half_space`: clips polygon[0..count) to y·n ≥ −offset.
fn gather_clip(polygon: ptr<function, array<vec3<f32>, 5>>, count: u32, n: vec3<f32>, offset: f32) -> u32 {
    let corners = *polygon;
    var out = 0u;
    for (var i = 0u; i < count; i++) {
        let p = corners[i];
        let q = corners[(i + 1u) % count];
        let dp = dot(p, n) + offset;
        let dq = dot(q, n) + offset;
        if (dp >= 0.0 && out < 5u) {
            (*polygon)[out] = p;
            out += 1u;
        }
        if ((dp >= 0.0) != (dq >= 0.0) && out < 5u) {
            (*polygon)[out] = p + (q - p) * (dp / (dp - dq));
            out += 1u;
        }
    }
    return out;
}

// Twin of `gather_area::polygon_area_in_disk`.
fn gather_polygon_area(flat: array<vec2<f32>, 5>, count: u32, rho2: f32) -> f32 {
    var crossed = false;
    var positive = false;
    var negative = false;
    for (var i = 0u; i < count; i++) {
        let p = flat[i];
        let q = flat[(i + 1u) % count];
        let d = q - p;
        let dd = dot(d, d);
        let m = p + d * (-dot(p, d) / dd);
        crossed = crossed || !(dd > 0.0) || dot(m, m) < rho2;
        let side = p.x * q.y - p.y * q.x;
        positive = positive || side > 0.0;
        negative = negative || side < 0.0;
    }
    if (!crossed) {
        return select(PI * rho2, 0.0, positive && negative);
    }
    var signed = 0.0;
    for (var i = 0u; i < count; i++) {
        signed += gather_segment_area(flat[i], flat[(i + 1u) % count], rho2);
    }
    return abs(signed);
}

// Twin of `gather_area::triangle_area_in_region`.
fn gather_triangle_area(t: Triangle, region: GatherRegion) -> f32 {
    let x = region.center;
    let a = t.p0 - x;
    let b = t.p1 - x;
    let c = t.p2 - x;
    let cr = cross(b - a, c - a);
    let len = length(cr);
    if (!(len > 0.0)) {
        return 0.0;
    }
    let n = cr / len * region.winding_side;
    let height = -dot(a, n);
    let rho2 = region.radius * region.radius - height * height;
    if (!(rho2 > 0.0)) {
        return 0.0;
    }
    var polygon = array<vec3<f32>, 5>(a, b, c, vec3<f32>(0.0), vec3<f32>(0.0));
    var count = 3u;
    if (!region.transmits) {
        // The bounds on the photon's height above the point's plane (the CPU twin explains).
        var lower = region.tolerance;
        var slab = false;
        if (height > region.step) {
            lower = region.step;
        } else if (height < -region.tolerance) {
            return 0.0;
        } else if (height < -region.step) {
            slab = true;
        }
        count = gather_clip(&polygon, count, region.n_point, lower);
        if (slab) {
            count = gather_clip(&polygon, count, -region.n_point, region.step);
        }
    }
    if (count < 3u) {
        return 0.0;
    }
    let frame = frame_from_z(n);
    var flat: array<vec2<f32>, 5>;
    for (var i = 0u; i < count; i++) {
        flat[i] = vec2<f32>(dot(polygon[i], frame.x), dot(polygon[i], frame.y));
    }
    return gather_polygon_area(flat, count, rho2);
}

// Twin of `gather_area::gather_area`: depth first, first child before second.
fn gather_area(region: GatherRegion) -> f32 {
    if (!(region.radius > 0.0)) {
        return 0.0;
    }
    let r2 = region.radius * region.radius;
    var stack: array<u32, GATHER_STACK_SIZE>;
    var sp = 0u;
    var current = 0u;
    var area = 0.0;
    loop {
        let node = nodes[current];
        let d = max(max(node.bounds_min - region.center, region.center - node.bounds_max), vec3<f32>(0.0));
        if (dot(d, d) <= r2) {
            let count = node_triangle_count(node);
            if (count == 0u) {
                if (sp < GATHER_STACK_SIZE) {
                    stack[sp] = node.offset;
                    sp += 1u;
                }
                current += 1u;
                continue;
            }
            for (var i = node.offset; i < node.offset + count; i++) {
                let t = triangles[i];
                if ((materials[t.material].flags & MATERIAL_DELTA_ONLY) == 0u) {
                    area += gather_triangle_area(t, region);
                }
            }
        }
        if (sp == 0u) {
            break;
        }
        sp -= 1u;
        current = stack[sp];
    }
    return area;
}

// Twin of `gather_coverage_area`: the area the gather at `si` within `radius` draws from.
fn sppm_gather_coverage_area(si: SurfaceInteraction, bsdf: GltfBsdf, radius: f32) -> f32 {
    let winding_side = select(-1.0, 1.0, dot(si.wo_world, si.n_geometric) > 0.0);
    let magnitude = max(max(abs(si.p.x), abs(si.p.y)), abs(si.p.z));
    let bounds = sppm_plane_tolerances(radius, magnitude);
    let region = GatherRegion(
        si.p,
        si.n_geometric * winding_side,
        radius,
        bounds.x,
        bounds.y,
        winding_side,
        has_rough_transmission(bsdf),
    );
    return gather_area(region);
}

// Twin of `coverage_correction`: the disk over the area a gather draws from, where smaller.
fn sppm_coverage_correction(disk: f32, area: f32) -> f32 {
    return disk / clamp(area, disk / MAX_COVERAGE_CORRECTION, disk);
}

// Twin of `radius_alpha`: a pixel's α, decided at its first gather.
fn sppm_radius_alpha(disk: f32, area: f32) -> f32 {
    return select(SPPM_ALPHA, SPPM_ALPHA_ONE_PLANE, abs(area / disk - 1.0) <= ONE_PLANE_AREA_TOLERANCE);
}

// Twin of `PhotonGrid::gather`. Cells may share a slot: each cell's run is read, and a
// photon counts only in its own cell, so that every photon within the radius (whose cell
// lies in the range) counts once. A range with more cells than slots reads every slot.
fn sppm_gather_photons(map: SppmMap, si: SurfaceInteraction, bsdf: GltfBsdf, radius: f32) -> SppmGathered {
    var out = SppmGathered(vec3<f32>(0.0), 0u);
    if (sppm_record_count(map) == 0u || radius <= 0.0) {
        return out;
    }
    let cell = sppm_cell_edge(map);
    let lo = sppm_cell_of(si.p - vec3<f32>(radius), cell);
    let hi = sppm_cell_of(si.p + vec3<f32>(radius), cell);
    let transmits = has_rough_transmission(bsdf);
    let extent = vec3<f32>(hi - lo) + vec3<f32>(1.0);
    if (extent.x * extent.y * extent.z > f32(frame.sppm_slot_mask)) {
        for (var s = 0u; s <= frame.sppm_slot_mask; s++) {
            let run = sppm_run(map, s);
            for (var j = run.x; j < run.y; j++) {
                sppm_photon_flux(sppm_order[j], si, bsdf, radius, transmits, &out);
            }
        }
        return out;
    }
    for (var cz = lo.z; cz <= hi.z; cz++) {
        for (var cy = lo.y; cy <= hi.y; cy++) {
            for (var cx = lo.x; cx <= hi.x; cx++) {
                let c = vec3<i32>(cx, cy, cz);
                let run = sppm_run(map, sppm_slot(c));
                for (var j = run.x; j < run.y; j++) {
                    let i = sppm_order[j];
                    if (all(sppm_cell_of(sppm_photon_p(sppm_photons[i]), cell) == c)) {
                        sppm_photon_flux(i, si, bsdf, radius, transmits, &out);
                    }
                }
            }
        }
    }
    return out;
}

// Step 5: pixel (x, y)'s update of pass `frame.sample_offset` (twin of `sppm_pass`'s last
// loop), over the band's rows.
@compute @workgroup_size(8, 8, 1)
fn sppm_gather(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    let pixel = px.y * frame.width + px.x;
    let vp = sppm_visible_points[pixel];
    var state = sppm_pixels[pixel];
    var estimate = vp.direct;
    state.direct += vp.direct;
    if (vp.triangle != INVALID_INDEX) {
        let surface = sppm_surface(vp);
        let si = surface.si;
        var gathered = sppm_gather_photons(SppmMap(0u, 0u), si, surface.bsdf, state.radius);
        let area = PI * state.radius * state.radius;
        let covered = sppm_gather_coverage_area(si, surface.bsdf, state.radius);
        gathered.phi *= sppm_coverage_correction(area, covered);
        if (state.alpha == 0.0) {
            state.alpha = sppm_radius_alpha(area, covered);
        }
        estimate += vp.beta * gathered.phi / (f32(frame.sppm_photons) * area);
        if (gathered.m > 0u) {
            let m = f32(gathered.m);
            let n = state.photon_count + state.alpha * m;
            let radius = state.radius * sqrt(n / (state.photon_count + m));
            let shrink = (radius / state.radius) * (radius / state.radius);
            state.tau = (state.tau + vp.beta * gathered.phi) * shrink;
            state.photon_count = n;
            state.radius = radius;
        }
    }
    sppm_pixels[pixel] = state;
    film[pixel] = film_add_sample(film[pixel], estimate, replicate_of(frame.sample_offset));
}
