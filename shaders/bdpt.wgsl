// Twin of src/integrator/bdpt.rs: bidirectional path tracing (Veach 1997 ch. 10; pbrt-v3
// §16.3), every strategy weighted by the power heuristic through the pdf-ratio recurrence.
// The CPU twin defines the strategies, the densities, the adjoint and the order in which
// random numbers are drawn; this file mirrors it function by function. Two entry points:
// `render` traces one sample of every pixel of its band (sample index `frame.sample_offset`)
// and leaves the pixel's own strategies' sum in `bdpt_state.values` and the t = 1 splats in
// `caustics`; `bdpt_resolve`, once every band of the pass has been traced, adds the two to
// the film as that sample. The subpaths' vertices and walks are shaders/bdpt_walk.wgsl's.

// Where `render` leaves each pixel's own strategies' sum for `bdpt_resolve` (xyz), and the
// light subpaths that reached BDPT_MAX_VERTICES and were ended there (the host reads and
// clears the count, `GpuBackend::bdpt_stats`). One unused pixel for the path tracer.
struct BdptState {
    truncated: atomic<u32>,
    values: array<vec4<f32>>,
}
@group(0) @binding(20) var<storage, read_write> bdpt_state: BdptState;

// Twin of BDPT_MAX_VERTICES: the light subpath's bound, its origin included.
const BDPT_MAX_VERTICES: u32 = 16u;
// The camera vertices whose densities the weights can still read: a strategy (s, t) takes
// at most BDPT_MAX_VERTICES light vertices, so the recurrence's terms for camera vertex i
// of a path of s + t vertices exist only for i ≥ s + t − BDPT_MAX_VERTICES, and it reads
// the densities of x_{t−1} down to x_{t−BDPT_MAX_VERTICES−1}. The CPU keeps the whole camera
// subpath (up to MAX_BOUNCES_GUARD vertices); here a ring of the last 32 (a power of two
// ≥ BDPT_MAX_VERTICES + 1) gives the same sums.
const BDPT_CAMERA_RING: u32 = 32u;

// Twin of `camera_pdf_direction`.
fn bdpt_camera_pdf_direction(w: vec3<f32>) -> f32 {
    let c = dot(w, camera.forward);
    if (camera.projection != PROJECTION_PERSPECTIVE || c <= 0.0) {
        return 0.0;
    }
    let area = 4.0 * camera.half_width * camera.half_height;
    return 1.0 / (area * c * c * c);
}

// Does t = 1 exist (a perspective camera that light vertices can be joined to)? Twin of
// `BdptContext::projection` being set.
fn bdpt_has_projection() -> bool {
    return camera.projection == PROJECTION_PERSPECTIVE && frame.camera_connections != 0u;
}

// Twin of `BdptContext::strategy_is_sampled`.
fn bdpt_strategy_is_sampled(s: u32, t: u32) -> bool {
    return (t != 1u || (s != 1u && bdpt_has_projection())) && s <= BDPT_MAX_VERTICES;
}

// Twin of `BdptContext::depth_allowed`.
fn bdpt_depth_allowed(s: u32, t: u32) -> bool {
    return s + t - 2u <= min(frame.max_depth, MAX_BOUNCES_GUARD);
}
// Twin of `Densities`.
struct BdptDensities {
    fwd: f32,
    rev: f32,
    delta: bool,
}

// The light subpath of this invocation's sample and its length, and the densities of the
// camera subpath's last BDPT_CAMERA_RING vertices (x_i at i % BDPT_CAMERA_RING).
var<private> bdpt_light: array<BdptVertex, BDPT_MAX_VERTICES>;
var<private> bdpt_light_count: u32;
var<private> bdpt_camera: array<BdptDensities, BDPT_CAMERA_RING>;

fn bdpt_camera_slot(i: u32) -> u32 {
    return i & (BDPT_CAMERA_RING - 1u);
}


// Twin of `light_subpath`: fills `bdpt_light` from the light stream (the sampler is
// the light path's when called). `fixed_length` 0: BDPT's own, ended by Russian roulette or
// at BDPT_MAX_VERTICES (a truncation, counted); otherwise exactly that many vertices, or
// fewer where the walk cannot go on, without roulette (`SubpathLength::Fixed`, Metropolis).
fn bdpt_light_subpath(fixed_length: u32) {
    bdpt_light_count = 0u;
    var y0: BdptVertex;
    var walk: BdptWalk;
    if (!bdpt_light_origin(&y0, &walk)) {
        return;
    }
    walk.roulette = fixed_length == 0u;
    bdpt_light[0] = y0;
    bdpt_light_count = 1u;
    loop {
        let here = bdpt_light_count;
        var v: BdptVertex;
        var si: SurfaceInteraction;
        var material: Material;
        var bsdf: GltfBsdf;
        if (!bdpt_trace(&walk, bdpt_light[here - 1u], &v, &si, &material, &bsdf)) {
            return;
        }
        if (fixed_length == here + 1u) {
            // The last vertex: a join evaluates it, nothing scatters from it.
            bdpt_light[here] = v;
            bdpt_light_count = here + 1u;
            return;
        }
        let rev = bdpt_scatter(&walk, &v, si, bsdf, bdpt_light[here - 1u], here);
        bdpt_light[here] = v;
        bdpt_light_count = here + 1u;
        if (rev < 0.0) {
            return;
        }
        bdpt_light[here - 1u].pdf_rev = rev;
        if (bdpt_light_count == BDPT_MAX_VERTICES) {
            if (fixed_length == 0u) {
                atomicAdd(&bdpt_state.truncated, 1u);
            }
            return;
        }
    }
}

// Twin of `pdf_light_origin`.
fn bdpt_pdf_light_origin(v: BdptVertex) -> f32 {
    if (v.light >= frame.light_count) {
        return 0.0;
    }
    let light = lights[v.light];
    if (v.kind == VERTEX_TRIANGLE_LIGHT || v.kind == VERTEX_SURFACE) {
        let area = triangle_light_normal_area(light).w;
        return select(0.0, light.pmf / area, area > 0.0);
    }
    if (v.kind == VERTEX_ENVIRONMENT) {
        return light.pmf * environment_lookup(v.n).pdf_solid_angle;
    }
    if (bdpt_is_delta_light(v)) {
        return light.pmf;
    }
    return 0.0;
}

// Twin of `pdf_light`.
fn bdpt_pdf_light(v: BdptVertex, to: BdptVertex) -> f32 {
    let w = bdpt_emitted_towards(v, to);
    var cos_to = 1.0;
    if (bdpt_on_surface(to)) {
        cos_to = abs(dot(w, to.n));
    }
    if (bdpt_at_infinity(v)) {
        return cos_to / bdpt_disk_area();
    }
    if (v.kind == VERTEX_TRIANGLE_LIGHT || v.kind == VERTEX_SURFACE) {
        let is_surface = v.kind == VERTEX_SURFACE;
        var triangle = v.triangle;
        if (!is_surface) {
            triangle = lights[v.light].triangle;
        }
        let double_sided = (materials[triangles[triangle].material].flags & MATERIAL_DOUBLE_SIDED) != 0u;
        // A light vertex's `n` is the side it emits from; a surface's its winding's.
        let cos_emit = dot(w, v.n);
        var pdf_direction = 0.0;
        if (double_sided) {
            pdf_direction = abs(cos_emit) / (2.0 * PI);
        } else if (cos_emit > 0.0 || !is_surface) {
            pdf_direction = abs(cos_emit) / PI;
        }
        return bdpt_convert_density(v, pdf_direction, to);
    }
    if (v.kind == VERTEX_POINT_LIGHT) {
        let light = lights[v.light];
        var pdf_direction = 1.0 / (4.0 * PI);
        if (light.kind == LIGHT_SPOT) {
            pdf_direction = 0.0;
            if (dot(w, light.direction) >= light.cos_outer) {
                pdf_direction = 1.0 / (2.0 * PI * max(1.0 - light.cos_outer, F32_MIN_POSITIVE));
            }
        }
        return bdpt_convert_density(v, pdf_direction, to);
    }
    return 0.0;
}

// Twin of `JoinDensities`.
struct BdptJoin {
    light_end: f32,
    light_before: f32,
    camera_end: f32,
    camera_before: f32,
    // s = 1: the light sample stands in for y₀, with this forward density and delta flag.
    has_light_sample: bool,
    light_sample_fwd: f32,
    light_sample_delta: bool,
}

fn bdpt_join_none() -> BdptJoin {
    return BdptJoin(0.0, 0.0, 0.0, 0.0, false, 0.0, false);
}

fn bdpt_remap0(x: f32) -> f32 {
    return select(1.0, x, x != 0.0);
}

// Camera vertex i's densities as strategy (·, t)'s join sees them.
fn bdpt_camera_at(i: u32, t: u32, join: BdptJoin) -> BdptDensities {
    var d = bdpt_camera[bdpt_camera_slot(i)];
    if (i == t - 1u) {
        d.rev = join.camera_end;
        d.delta = false;
    } else if (i + 2u == t) {
        d.rev = join.camera_before;
    }
    return d;
}

// Light vertex i's densities as strategy (s, ·)'s join sees them.
fn bdpt_light_at(i: u32, s: u32, join: BdptJoin) -> BdptDensities {
    var d: BdptDensities;
    if (i == 0u && join.has_light_sample) {
        d = BdptDensities(join.light_sample_fwd, 0.0, false);
    } else {
        let v = bdpt_light[i];
        d = BdptDensities(v.pdf_fwd, v.pdf_rev, v.delta);
    }
    if (i + 1u == s) {
        d.rev = join.light_end;
        d.delta = false;
    } else if (i + 2u == s) {
        d.rev = join.light_before;
    }
    return d;
}

// Twin of `mis_weight`. The camera side's loop stops where no term can count (the ring's
// comment above).
fn bdpt_mis_weight(s: u32, t: u32, join: BdptJoin) -> f32 {
    var sum = 0.0;
    var ri = 1.0;
    let lowest = max(i32(s + t) - i32(BDPT_MAX_VERTICES), 1);
    var next = bdpt_camera_at(t - 1u, t, join);
    for (var i = i32(t) - 1; i >= lowest; i--) {
        let here = next;
        next = bdpt_camera_at(u32(i) - 1u, t, join);
        ri *= bdpt_remap0(here.rev) / bdpt_remap0(here.fwd);
        if (!here.delta && !next.delta && bdpt_strategy_is_sampled(s + t - u32(i), u32(i))) {
            sum += ri * ri;
        }
    }
    var light0_delta = false;
    if (join.has_light_sample) {
        light0_delta = join.light_sample_delta;
    } else if (s > 0u) {
        light0_delta = bdpt_is_delta_light(bdpt_light[0]);
    }
    ri = 1.0;
    for (var i = i32(s) - 1; i >= 0; i--) {
        let here = bdpt_light_at(u32(i), s, join);
        ri *= bdpt_remap0(here.rev) / bdpt_remap0(here.fwd);
        var delta_before = light0_delta;
        if (i > 0) {
            delta_before = bdpt_light_at(u32(i) - 1u, s, join).delta;
        }
        if (!here.delta && !delta_before && bdpt_strategy_is_sampled(u32(i), s + t - u32(i))) {
            sum += ri * ri;
        }
    }
    let w = 1.0 / (1.0 + sum);
    return select(0.0, w, is_finite_f32(w));
}

// Twin of `emitter_hit`: s = 0 at camera vertex `pt` (x_{t−1}, reached from `ptm`).
fn bdpt_emitter_hit(pt: BdptVertex, ptm: BdptVertex, si: SurfaceInteraction, material: Material, t: u32) -> vec3<f32> {
    var le = vec3<f32>(0.0);
    if (pt.kind == VERTEX_ENVIRONMENT) {
        le = environment_lookup(pt.n).radiance;
    } else {
        let untextured = materials[si.material];
        let lit_side = si.front_face || (untextured.flags & MATERIAL_DOUBLE_SIDED) != 0u;
        if (max_element(untextured.emission) <= 0.0 || !lit_side) {
            return vec3<f32>(0.0);
        }
        if (pt.light == INVALID_INDEX) {
            // Emission that is no light: only this strategy finds it.
            return pt.beta * material.emission;
        }
        le = emitted_radiance(untextured, pt.triangle, pt.b);
    }
    let value = pt.beta * le;
    if (pt.light == INVALID_INDEX || max_element(value) <= 0.0 || t == 2u) {
        return value;
    }
    var join = bdpt_join_none();
    join.camera_end = bdpt_pdf_light_origin(pt);
    join.camera_before = bdpt_pdf_light(pt, ptm);
    return value * bdpt_mis_weight(0u, t, join);
}

// A t = 1 join's pixel and weighted value; `valid` false where it carries nothing.
struct BdptCameraJoin {
    pixel: u32,
    value: vec3<f32>,
    valid: bool,
}

// Twin of `join_camera`: t = 1, light vertex y_{s−1} joined to the camera at `x0`, and the
// pixel it projects to.
fn bdpt_join_camera_value(x0: BdptVertex, s: u32) -> BdptCameraJoin {
    let none = BdptCameraJoin(0u, vec3<f32>(0.0), false);
    var alpha_seed = 0u;
    if (FEATURE_ALPHA) {
        alpha_seed = rng_next_u32();
    }
    let qs = bdpt_light[s - 1u];
    if (!bdpt_has_projection() || qs.kind != VERTEX_SURFACE || !qs.connectible) {
        return none;
    }
    let proj = project_to_pixel(qs.p, frame.width, frame.height);
    if (!proj.valid) {
        return none;
    }
    let seen = bdpt_seen_from(qs, -proj.direction);
    let f_cos = bdpt_f_cos(seen, qs.wo_world);
    if (max_element(f_cos) <= 0.0) {
        return none;
    }
    let ng = qs.n;
    let cos_in = abs(dot(qs.wo_world, ng));
    if (cos_in == 0.0) {
        return none;
    }
    if (intersect_any(spawn_ray_to(qs.p, qs.p_error, ng, camera.position), alpha_seed)) {
        return none;
    }
    let c = proj.cos_theta;
    let value = qs.beta * f_cos * abs(dot(proj.direction, ng))
        / (cos_in * pinhole_pixel_area(frame.width, frame.height) * c * c * c * proj.distance2);
    if (!is_finite_vec3(value)) {
        return none;
    }
    var join = bdpt_join_none();
    join.light_end = bdpt_convert_density(x0, bdpt_camera_pdf_direction(proj.direction), qs);
    join.light_before = bdpt_convert_density(qs, bdpt_pdf(seen, qs.wo_world), bdpt_light[s - 2u]);
    return BdptCameraJoin(proj.pixel, value * bdpt_mis_weight(s, 1u, join), true);
}

// BDPT's t = 1 join, splatted (divided by the number of light paths) where it projects.
fn bdpt_join_camera(x0: BdptVertex, s: u32) {
    let j = bdpt_join_camera_value(x0, s);
    if (j.valid) {
        caustic_splat(j.pixel, j.value * (1.0 / f32(frame.width * frame.height)));
    }
}

// Twin of `join_light_sample`: s = 1 at camera vertex `pt` (x_{t−1}, reached from `ptm`).
fn bdpt_join_light_sample(pt: BdptVertex, ptm: BdptVertex, si: SurfaceInteraction, bsdf: GltfBsdf, t: u32) -> vec3<f32> {
    if (pt.kind != VERTEX_SURFACE || !pt.connectible || frame.light_count == 0u) {
        return vec3<f32>(0.0);
    }
    let unblocked = unblocked_light_sample(si, bsdf, rng_next_2d());
    if (!unblocked.valid) {
        return vec3<f32>(0.0);
    }
    let ls = unblocked.ls;
    let wi = unblocked.wi;
    let f = unblocked.f;
    let value = pt.beta * f * abs(wi.z) * ls.radiance / ls.pdf;
    // The sampled light as a vertex, for its densities.
    let light = lights[ls.light_index];
    var y0: BdptVertex;
    if (light.kind == LIGHT_TRIANGLE) {
        // The side facing x_{t−1}: the one the light sample left from.
        let n = triangle_light_normal_area(light).xyz;
        y0 = bdpt_endpoint(VERTEX_TRIANGLE_LIGHT, ls.position, select(n, -n, dot(n, ls.wi) > 0.0), ls.light_index, vec3<f32>(0.0), 0.0);
    } else if (light.kind == LIGHT_POINT || light.kind == LIGHT_SPOT) {
        y0 = bdpt_endpoint(VERTEX_POINT_LIGHT, ls.position, vec3<f32>(0.0), ls.light_index, vec3<f32>(0.0), 0.0);
    } else if (light.kind == LIGHT_DIRECTIONAL) {
        y0 = bdpt_endpoint(VERTEX_DIRECTIONAL_LIGHT, vec3<f32>(0.0), light.direction, ls.light_index, vec3<f32>(0.0), 0.0);
    } else {
        y0 = bdpt_endpoint(VERTEX_ENVIRONMENT, vec3<f32>(0.0), ls.wi, ls.light_index, vec3<f32>(0.0), 0.0);
    }
    var join = bdpt_join_none();
    if (!ls.is_delta) {
        join.light_end = bdpt_convert_density(pt, gltf_bsdf_pdf(bsdf, si.wo, wi), y0);
    }
    join.camera_end = bdpt_pdf_light(y0, pt);
    if (t >= 3u) {
        join.camera_before = bdpt_convert_density(pt, bdpt_pdf(bdpt_seen_from(pt, ls.wi), si.wo_world), ptm);
    }
    join.has_light_sample = true;
    join.light_sample_fwd = bdpt_pdf_light_origin(y0);
    join.light_sample_delta = bdpt_is_delta_light(y0);
    return value * bdpt_mis_weight(1u, t, join);
}

// Twin of `join`: s ≥ 2, t ≥ 2, camera vertex `pt` (x_{t−1}, reached from `ptm`; its
// interaction `si`, material `material` and BSDF `bsdf`) joined to light vertex y_{s−1}.
fn bdpt_join(pt: BdptVertex, ptm: BdptVertex, si: SurfaceInteraction, material: Material, bsdf: GltfBsdf, s: u32, t: u32) -> vec3<f32> {
    var alpha_seed = 0u;
    if (FEATURE_ALPHA) {
        alpha_seed = rng_next_u32();
    }
    let qs = bdpt_light[s - 1u];
    if (pt.kind != VERTEX_SURFACE || qs.kind != VERTEX_SURFACE || !pt.connectible || !qs.connectible) {
        return vec3<f32>(0.0);
    }
    let d = qs.p - pt.p;
    let dist2 = dot(d, d);
    if (dist2 == 0.0) {
        return vec3<f32>(0.0);
    }
    // A join must leave each surface by more than the points' rounding (the CPU twin).
    let error = si.p_error + qs.p_error;
    if (abs(dot(d, si.n_geometric)) <= dot(error, abs(si.n_geometric)) || abs(dot(d, qs.n)) <= dot(error, abs(qs.n))) {
        return vec3<f32>(0.0);
    }
    let w = d / sqrt(dist2);
    let pt_own = BdptSeen(si, bsdf);
    let f_camera = bdpt_f_cos(pt_own, w);
    if (max_element(f_camera) <= 0.0) {
        return vec3<f32>(0.0);
    }
    let qs_seen = bdpt_seen_from(qs, -w);
    let f_light = bdpt_f_cos(qs_seen, qs.wo_world);
    if (max_element(f_light) <= 0.0) {
        return vec3<f32>(0.0);
    }
    let cos_in = abs(dot(qs.wo_world, qs.n));
    if (cos_in == 0.0) {
        return vec3<f32>(0.0);
    }
    var value = pt.beta * f_camera * f_light * qs.beta * (abs(dot(w, qs.n)) / (cos_in * dist2));
    if (!is_finite_vec3(value) || max_element(value) <= 0.0) {
        return vec3<f32>(0.0);
    }
    // A join inside a refracting solid crosses its medium.
    if (FEATURE_VOLUME && (material.flags & MATERIAL_VOLUME) != 0u && dot(w, si.n_geometric) < 0.0) {
        value *= exp(-material.attenuation_coefficient * sqrt(dist2));
    }
    let q_target = offset_ray_origin(qs.p, qs.p_error, qs.n, -w);
    if (intersect_any(spawn_ray_to(pt.p, si.p_error, si.n_geometric, q_target), alpha_seed)) {
        return vec3<f32>(0.0);
    }
    let qs_own = bdpt_seen_from(qs, qs.wo_world);
    var join = bdpt_join_none();
    join.light_end = bdpt_convert_density(pt, bdpt_pdf(pt_own, w), qs);
    join.light_before = bdpt_convert_density(qs, bdpt_pdf(qs_seen, qs.wo_world), bdpt_light[s - 2u]);
    join.camera_end = bdpt_convert_density(qs, bdpt_pdf(qs_own, -w), pt);
    if (t >= 3u) {
        join.camera_before = bdpt_convert_density(pt, bdpt_pdf(bdpt_seen_from(pt, w), si.wo_world), ptm);
    }
    return value * bdpt_mis_weight(s, t, join);
}

// Twin of `bdpt_sample` (and of `CpuBackend::render_bdpt_pass`'s per-pixel work): one
// sample of every pixel of the band for sample index `frame.sample_offset`.
@compute @workgroup_size(8, 8, 1)
fn render(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    let x = px.x;
    let y = px.y;
    let pixel = y * frame.width + x;
    let k = frame.sample_offset;
    rays_traced = 0u;

    // The light subpath and its t = 1 joins, from the light path's stream.
    sampler_start(SAMPLER_INDEPENDENT, pixel, LIGHT_PATH_STREAM, k, frame.seed);
    bdpt_light_subpath(0u);
    var x0 = bdpt_endpoint(VERTEX_CAMERA, camera.position, camera.forward, 0u, vec3<f32>(1.0), 1.0);
    // An orthographic camera's direction is a delta: no strategy can join to it.
    x0.delta = camera.projection != PROJECTION_PERSPECTIVE;
    for (var s = 2u; s <= bdpt_light_count; s++) {
        if (bdpt_depth_allowed(s, 1u)) {
            bdpt_join_camera(x0, s);
        }
    }

    // The camera subpath, each vertex joined to every light vertex as it is reached.
    sampler_start(frame.sampler_kind, x, y, k, frame.seed);
    let ray = generate_camera_ray(frame.width, frame.height, x, y, rng_next_2d());
    x0.p = ray.origin;
    bdpt_camera[0] = BdptDensities(1.0, 0.0, x0.delta);
    var pdf_direction = 1.0;
    if (!x0.delta) {
        pdf_direction = bdpt_camera_pdf_direction(ray.direction);
    }
    var walk = bdpt_walk_new(ray, vec3<f32>(1.0), pdf_direction, false);
    var prev = x0;
    var own = vec3<f32>(0.0);
    var t = 1u;
    loop {
        var v: BdptVertex;
        var si: SurfaceInteraction;
        var material: Material;
        var bsdf: GltfBsdf;
        if (!bdpt_trace(&walk, prev, &v, &si, &material, &bsdf)) {
            break;
        }
        t += 1u;
        bdpt_camera[bdpt_camera_slot(t - 1u)] = BdptDensities(v.pdf_fwd, 0.0, false);
        for (var s = 0u; s <= bdpt_light_count; s++) {
            if (!bdpt_depth_allowed(s, t)) {
                continue;
            }
            var value: vec3<f32>;
            if (s == 0u) {
                value = bdpt_emitter_hit(v, prev, si, material, t);
            } else if (s == 1u) {
                value = bdpt_join_light_sample(v, prev, si, bsdf, t);
            } else {
                value = bdpt_join(v, prev, si, material, bsdf, s, t);
            }
            if (max_element(value) > 0.0) {
                own += value;
            }
        }
        if (v.kind == VERTEX_ENVIRONMENT) {
            break;
        }
        let rev = bdpt_scatter(&walk, &v, si, bsdf, prev, t - 1u);
        if (rev < 0.0) {
            break;
        }
        bdpt_camera[bdpt_camera_slot(t - 2u)].rev = rev;
        bdpt_camera[bdpt_camera_slot(t - 1u)].delta = v.delta;
        prev = v;
    }
    bdpt_state.values[pixel] = vec4<f32>(own, 0.0);
    ray_counts[pixel] += rays_traced;
}

// Adds each pixel of the band its sample of index `frame.sample_offset`: its own
// strategies' sum and every pixel's t = 1 splats into it, once the whole pass is traced.
@compute @workgroup_size(8, 8, 1)
fn bdpt_resolve(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    let pixel = px.y * frame.width + px.x;
    let x = bdpt_state.values[pixel].xyz + caustic_radiance(pixel);
    film[pixel] = film_add_sample(film[pixel], x, replicate_of(frame.sample_offset));
}
