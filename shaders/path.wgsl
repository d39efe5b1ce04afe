// Twin of src/integrator/path.rs: unidirectional path tracing with next-event estimation,
// MIS (power heuristic) and Russian roulette: the `render` entry point. Bounce semantics,
// random-number order and every guard match the CPU reference.

// `FrameParams::light_traced_caustics` (twins of the constants in src/scene/layout.rs): the
// light tracer's image of the sample index is added to each sample, or (adaptive sampling)
// summed apart by `accumulate_caustic_sums` in shaders/light_tracing.wgsl.
const CAUSTICS_PER_SAMPLE: u32 = 1u;
const CAUSTICS_APART: u32 = 2u;

// A path between bounces (twin of the CPU's `PathState`).
struct PathState {
    // The ray to trace next (unit direction).
    ray: Ray,
    // Distance travelled along the path before `ray`: the cone keeps its spread.
    travelled: f32,
    // Throughput.
    beta: vec3<f32>,
    // Scattering events so far (0 for the camera ray).
    depth: u32,
    // Did the last scattering sample a delta lobe (or is this the camera ray)?
    prev_delta: bool,
    // The last BSDF sample's solid-angle density, for MIS against light sampling.
    prev_pdf: f32,
    // Product of η² over the refractions so far, taken out of roulette (the CPU twin explains).
    eta_scale: f32,
    // Bounces that sampled a non-delta lobe: where roulette starts (the CPU twin explains).
    non_delta_depth: u32,
    // Did the first vertex scatter by a non-delta lobe? (The light tracer's half of path
    // space, `frame.light_traced_caustics`, needs it.)
    first_vertex_smooth: bool,
    // Throughput for the sampled lights' emission at the next hit only: the Lambertian
    // lobe's share of the last BSDF sample where the irradiance cache gave that lobe's
    // indirect light (the CPU twin explains).
    direct_only_beta: vec3<f32>,
    // Has the path passed its first Lambertian vertex, where the cache is consulted once?
    cache_consulted: bool,
}

// Where a split sample's continuations start (the CPU twin's `radiance` explains
// splitting): the hit that made the vertex and the cone width it was shaded with, the path up
// to it, its sampler state and the radiance gathered before the split. A continuation shades
// the vertex again from its hit, with the same operations and so the same bits, instead of
// keeping the surface and its BSDF (some 70 values) live across the loop: on lavapipe, whose
// `if` only masks lanes and runs both arms, the copies in and out cost every bounce, and
// shading the saved hit costs nothing extra, since the bounce shades a hit anyway (measured:
// bench/history/lavapipe.md).
struct SplitVertex {
    hit: ClosestHit,
    cone_width: f32,
    path: PathState,
    rng: vec4<u32>,
    l_prefix: vec3<f32>,
}

// One invocation per pixel of the band: adds `samples` samples, starting at index
// `sample_offset`, to the pixel's running statistics. The path is the CPU twin's
// (`radiance` in src/integrator/path.rs), bounce for bounce.
//
// Path regeneration (Novák, Havran & Dachsbacher 2010, "Path regeneration for interactive
// path tracing"): the outer loop runs bounces, not samples, and an invocation whose path
// has ended starts the pixel's next sample at once. With a loop over samples around a loop
// over bounces, the invocations that execute together (eight lanes of a vector on
// lavapipe, a warp or wave on a GPU) all wait for the longest of their paths before any
// starts its next sample, and Russian roulette makes path lengths vary widely. Each pixel's
// samples still end, and reach the film, in index order, so the image is bit for bit the one
// the nested loops gave. A split sample's continuations are regenerated the same way: each
// starts from the saved vertex when the one before it ends.
//
// Gather mode (irradiance-cache placement, `frame.ic_gather_jobs` > 0, only in the kernel
// built with IRRADIANCE_CACHE): each invocation traces one gather ray of a record
// (`ic_gather_start` in shaders/irradiance_cache.wgsl) as the same bounce loop, and writes
// its radiance, its first hit's distance and its rays to `ic_gather_results` instead of the
// film (twin of `indirect_radiance`).
@compute @workgroup_size(8, 8, 1)
fn render(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    load_dispatch_constants();
    let gather = IRRADIANCE_CACHE && frame.ic_gather_jobs != 0u;
    var x = 0u;
    var y = 0u;
    var pixel = 0u;
    var samples = 1u;
    var job = 0u;
    var cone = vec2<f32>(frame.cone_width, frame.cone_spread);
    // Gather mode: the first hit's distance (negative: none) of the gather ray.
    var gather_distance = -1.0;
    var p: FilmPixel;
    var k = 0u;
    var start_path = true;
    var path: PathState;
    rays_traced = 0u;
    if (gather) {
        let item = dispatch_item(gid, groups, frame.ic_gather_jobs);
        if (item == INVALID_INDEX) {
            return;
        }
        job = frame.ic_gather_job_offset + item;
        let start = ic_gather_start(job);
        if (!start.traced) {
            ic_gather_results[job] = IcGatherResultGpu(vec3<f32>(0.0), -1.0, 0u, 0u, 0u, 0u);
            return;
        }
        // `indirect_radiance`'s path: past the record's vertex (depth 1), its first hit
        // weighing a sampled light's emission by the weight of a strategy with no density, 0,
        // and the cache already consulted.
        path = PathState(start.ray, 0.0, vec3<f32>(1.0), 1u, false, 0.0, 1.0, 1u, true, vec3<f32>(0.0), true);
        cone = vec2<f32>(start.cone_width, 0.0);
        start_path = false;
    } else {
        let px = band_pixel(gid);
        if (px.z == 0u || frame.samples == 0u) {
            return;
        }
        x = px.x;
        y = px.y;
        pixel = y * frame.width + x;
        // Adaptive sampling: the samples of this dispatch below the pixel's budget.
        let budget = sample_budget(pixel);
        if (budget <= frame.sample_offset) {
            return;
        }
        samples = min(frame.samples, budget - frame.sample_offset);
        p = film[pixel];
    }
    // The path of sample `sample_offset + k`, started at the top of the loop whenever
    // `start_path` is set (WGSL zero-initialises the rest until then).
    // The radiance of the path (of the current continuation once the sample has split).
    var l: vec3<f32>;
    var poisoned: bool;
    // Splitting: has this sample split, which continuation is being traced, does the next
    // bounce start it from `split_vertex`, and the sum of the continuations' radiance.
    var split = false;
    var split_j = 0u;
    var resume_split = false;
    var split_vertex: SplitVertex;
    var split_sum: vec3<f32>;
    loop {
        if (start_path) {
            sampler_start(frame.sampler_kind, x, y, frame.sample_offset + k, frame.seed);
            let camera_ray = generate_camera_ray(frame.width, frame.height, x, y, rng_next_2d());
            path = PathState(camera_ray, 0.0, vec3<f32>(1.0), 0u, true, 0.0, 1.0, 0u, false, vec3<f32>(0.0), false);
            l = vec3<f32>(0.0);
            poisoned = false;
            split = false;
            start_path = false;
        }
        // One bounce: the inner loop runs once, and a `break` from it ends the path (its
        // radiance in `l`), as a `break` ends the CPU twin's bounce loop.
        var path_ended = true;
        loop {
            var hit: ClosestHit;
            var cone_width: f32;
            let resuming = resume_split;
            if (resuming) {
                // The next continuation: from the split vertex, with its own numbers.
                resume_split = false;
                hit = split_vertex.hit;
                cone_width = split_vertex.cone_width;
                path = split_vertex.path;
                sampler_split(split_vertex.rng, split_j, frame.splits);
            } else {
                var alpha_seed = 0u;
                if (FEATURE_ALPHA) {
                    alpha_seed = rng_next_u32();
                }
                hit = intersect_closest(path.ray, alpha_seed);
                if (gather && path.depth == 1u && hit.triangle != INVALID_INDEX) {
                    gather_distance = hit.t;
                }
                if (hit.triangle == INVALID_INDEX) {
                    if (FEATURE_ENVIRONMENT && environment.present != 0u) {
                        let env = environment_lookup(path.ray.direction);
                        if (path.depth == 0u || path.prev_delta || environment.light_index == INVALID_INDEX) {
                            l += path.beta * env.radiance;
                        } else {
                            let light_pdf = lights[environment.light_index].pmf * env.pdf_solid_angle;
                            l += direct_throughput(path) * env.radiance * power_heuristic(path.prev_pdf, light_pdf);
                        }
                    }
                    break;
                }
                cone_width = cone.x + cone.y * (path.travelled + hit.t);
            }
            let si = surface_interaction(path.ray, hit, cone_width);
            let untextured = materials[si.material];
            let material = textured_material(untextured, si.uv, si.lod);
            let bsdf = gltf_bsdf_new(material, si.wo, si.front_face, si.coat_normal);
            var cached_lambert = false;
            if (!resuming) {
                path.travelled += si.distance;

                if (FEATURE_VOLUME && (material.flags & MATERIAL_VOLUME) != 0u && !si.front_face) {
                    let transmittance = exp(-material.attenuation_coefficient * si.distance);
                    path.beta *= transmittance;
                    if (IRRADIANCE_CACHE) {
                        path.direct_only_beta *= transmittance;
                    }
                }

                // Full weight: the cone's level of detail; weighted against light sampling: level 0,
                // what light sampling sees (the CPU twin explains).
                if (max_element(untextured.emission) > 0.0 && (si.front_face || (material.flags & MATERIAL_DOUBLE_SIDED) != 0u)) {
                    if (path.depth == 0u || path.prev_delta || si.emitter == INVALID_INDEX) {
                        // A caustic path the light tracer takes is left out here (the CPU
                        // twin's `trace` explains the partition).
                        let light_traced = frame.light_traced_caustics != 0u
                            && caustic_is_light_traced(path.prev_delta, path.first_vertex_smooth, si.emitter);
                        if (!light_traced) {
                            l += path.beta * material.emission;
                        }
                    } else {
                        let light_pdf = triangle_light_pdf(lights[si.emitter], path.ray.origin, si.p);
                        l += direct_throughput(path) * emitted_radiance(untextured, hit.triangle, hit.b) * power_heuristic(path.prev_pdf, light_pdf);
                    }
                }
                if (IRRADIANCE_CACHE && any(path.direct_only_beta != vec3<f32>(0.0))) {
                    // The cache had the Lambertian lobe's light from here on; what other
                    // lobes sent this way goes on.
                    path.direct_only_beta = vec3<f32>(0.0);
                    if (all(path.beta == vec3<f32>(0.0))) {
                        break;
                    }
                }

                if (path.depth >= frame.max_depth || path.depth >= MAX_BOUNCES_GUARD) {
                    break;
                }
                l += next_event(si, bsdf, path.beta);
                if (IRRADIANCE_CACHE && !path.cache_consulted && path.non_delta_depth == 0u && has_lambert_lobe(bsdf)) {
                    // The Lambertian lobe's indirect light from the cache (the CPU twin's
                    // `trace` explains).
                    path.cache_consulted = true;
                    let cached = ic_lookup(si.p, si.frame.z);
                    if (cached.w > 0.0) {
                        l += path.beta * gltf_bsdf_diffuse_albedo(bsdf, si.wo) * cached.xyz * INV_PI;
                        cached_lambert = true;
                    }
                }

                if (SPLITTING && frame.splits > 1u && !split && has_non_delta(bsdf)) {
                    // Split here: the prefix's radiance is kept, and continuation 0 goes on.
                    split = true;
                    split_j = 0u;
                    split_sum = vec3<f32>(0.0);
                    split_vertex = SplitVertex(hit, cone_width, path, rng_s, l);
                    l = vec3<f32>(0.0);
                    sampler_split(rng_s, 0u, frame.splits);
                }
            }

            // Twin of `scatter`.
            let u_lobe = rng_next_1d();
            let u_dir = rng_next_direction_2d();
            let bs = gltf_bsdf_sample(bsdf, si.wo, u_lobe, u_dir);
            if (!bs.valid) {
                break;
            }
            let wi_world = normalize(frame_from_local(si.frame, bs.wi));
            if (!sides_agree(si, wi_world, bs.wi)) {
                break;
            }
            if (IRRADIANCE_CACHE && cached_lambert && !bs.is_delta) {
                let lambert = min(gltf_bsdf_eval_diffuse(bsdf, si.wo, bs.wi) * (abs(bs.wi.z) / bs.pdf_solid_angle), bs.weight);
                path.direct_only_beta = path.beta * lambert;
                path.beta *= max(bs.weight - lambert, vec3<f32>(0.0));
            } else {
                path.beta *= bs.weight;
            }
            if (!is_finite_vec3(path.beta) || (IRRADIANCE_CACHE && !is_finite_vec3(path.direct_only_beta))) {
                poisoned = true;
                break;
            }
            if (path.depth == 0u) {
                path.first_vertex_smooth = !bs.is_delta;
            }
            path.prev_delta = bs.is_delta;
            path.prev_pdf = bs.pdf_solid_angle;
            path.eta_scale *= bs.eta_scale;
            path.depth += 1u;
            path.ray = spawn_ray(si.p, si.p_error, si.n_geometric, wi_world);

            if (!bs.is_delta) {
                path.non_delta_depth += 1u;
            }
            if (path.non_delta_depth >= frame.rr_min_depth || path.depth >= RR_ANY_BOUNCE_DEPTH) {
                let q = survival_probability(direct_throughput(path), path.eta_scale);
                if (q <= 0.0 || rng_next_1d() >= q) {
                    break;
                }
                path.beta /= q;
                if (IRRADIANCE_CACHE) {
                    path.direct_only_beta /= q;
                }
            }
            path_ended = false;
            break;
        }
        if (path_ended) {
            var sample_ended = true;
            if (split && !poisoned) {
                // A continuation ended: the next one starts, or the sample is the prefix's
                // radiance plus their mean.
                split_sum += l;
                split_j += 1u;
                if (split_j < frame.splits) {
                    l = vec3<f32>(0.0);
                    resume_split = true;
                    sample_ended = false;
                } else {
                    l = split_vertex.l_prefix + split_sum / f32(frame.splits);
                }
            }
            if (gather) {
                // A poisoned gather ray counts as no light (`compute_record`).
                let radiance = select(l, vec3<f32>(0.0), poisoned || !is_finite_vec3(l));
                ic_gather_results[job] = IcGatherResultGpu(radiance, gather_distance, rays_traced, 0u, 0u, 0u);
                return;
            }
            if (sample_ended) {
                // A poisoned path poisons its sample, split or not (the CPU twin returns at once).
                var value = select(l, poison(), poisoned);
                if (frame.light_traced_caustics == CAUSTICS_PER_SAMPLE) {
                    // The light tracer's half of the pixel for this sample index.
                    value += caustic_radiance(pixel);
                }
                p = film_add_sample(p, value, replicate_of(frame.sample_offset + k));
                k += 1u;
                if (k == samples) {
                    break;
                }
                start_path = true;
            }
        }
    }
    film[pixel] = p;
    ray_counts[pixel] += rays_traced;
}

// The throughput a sampled light's emission at the next hit is weighted by: the path's, and
// under the irradiance cache also the Lambertian share that carries only that emission.
// Without the cache this is `path.beta`, and the sum folds away.
fn direct_throughput(path: PathState) -> vec3<f32> {
    if (IRRADIANCE_CACHE) {
        return path.beta + path.direct_only_beta;
    }
    return path.beta;
}
