// Twin of src/cpu/integrator.rs: unidirectional path tracing with next-event estimation,
// MIS (power heuristic) and Russian roulette, and the megakernel's entry points. Bounce
// semantics, random-number order and every guard match the CPU reference.

const MAX_BOUNCES_GUARD: u32 = 1024u;
const RR_MAX_SURVIVAL: f32 = 0.95;
const RR_ANY_BOUNCE_DEPTH: u32 = 8u;

struct SurfaceInteraction {
    p: vec3<f32>,
    p_error: vec3<f32>,
    n_geometric: vec3<f32>,
    frame: Frame,
    wo: vec3<f32>,
    wo_world: vec3<f32>,
    front_face: bool,
    material: u32,
    emitter: u32,
    distance: f32,
    // UV sets 0 (xy) and 1 (zw).
    uv: vec4<f32>,
    // Texture level-of-detail bases per UV set (`lod_bases`).
    lod: vec2<f32>,
    // The clear coat's normal in the shading frame (+z without a coat).
    coat_normal: vec3<f32>,
}

fn surface_interaction(ray: Ray, hit: ClosestHit, cone_width: f32) -> SurfaceInteraction {
    let tri = triangles[hit.triangle];
    let b = hit.b;
    let p = b.x * tri.p0 + b.y * tri.p1 + b.z * tri.p2;
    let p_error = triangle_error_bound(b, tri.p0, tri.p1, tri.p2);
    let n_geometric = normalize(cross(tri.p1 - tri.p0, tri.p2 - tri.p0));
    let wo_world = -ray.direction;
    let front_face = dot(wo_world, n_geometric) > 0.0;
    let ng_facing = select(-n_geometric, n_geometric, front_face);
    let uv = triangle_uv(hit.triangle, b);
    let lod = lod_bases(hit.triangle, length(cross(tri.p1 - tri.p0, tri.p2 - tri.p0)), cone_width, dot(wo_world, n_geometric));
    var n_front = n_geometric;
    if ((tri.flags & TRIANGLE_HAS_NORMALS) != 0u) {
        let n = normals[hit.triangle];
        let interpolated = try_normalize(b.x * oct_decode(n.n0) + b.y * oct_decode(n.n1) + b.z * oct_decode(n.n2));
        if (interpolated.w != 0.0) {
            n_front = select(interpolated.xyz, -interpolated.xyz, dot(interpolated.xyz, n_geometric) < 0.0);
        }
    }
    let material = materials[tri.material];
    // The tangent frame (front side) where a normal map will read it.
    var tangent_frame = Frame(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    var has_tangent_frame = false;
    if (FEATURE_NORMAL_MAPS && (tri.flags & TRIANGLE_HAS_TANGENTS) != 0u) {
        let t = tangents[hit.triangle];
        let tangent = b.x * oct_decode(t.t0) + b.y * oct_decode(t.t1) + b.z * oct_decode(t.t2);
        let sign = select(1.0, -1.0, (t.signs & 1u) != 0u);
        let ortho = try_normalize(tangent - n_front * dot(n_front, tangent));
        if (ortho.w != 0.0) {
            tangent_frame = Frame(ortho.xyz, cross(n_front, ortho.xyz) * sign, n_front);
            has_tangent_frame = true;
        }
    }
    var n_mapped = n_front;
    if (has_tangent_frame) {
        n_mapped = map_normal(material.normal_texture, material.normal_scale, uv, lod, tangent_frame, n_geometric);
    }
    let ns = facing_normal(n_mapped, n_front, front_face, wo_world, ng_facing);
    let f = frame_from_z(ns);
    // The clear coat's own normal: its normal map, else the interpolated normal.
    var coat_normal = vec3<f32>(0.0, 0.0, 1.0);
    if (FEATURE_CLEARCOAT && material.clearcoat > 0.0) {
        var n_coat = n_front;
        if (has_tangent_frame) {
            n_coat = map_normal(material.clearcoat_normal_texture, material.clearcoat_normal_scale, uv, lod, tangent_frame, n_geometric);
        }
        coat_normal = normalize(frame_to_local(f, facing_normal(n_coat, n_front, front_face, wo_world, ng_facing)));
    }
    return SurfaceInteraction(p, p_error, n_geometric, f, frame_to_local(f, wo_world), wo_world, front_face, tri.material, tri.emitter, hit.t, uv, lod, coat_normal);
}

// The normal map `texture` (or INVALID_INDEX: none) applied in `tf` (tangent, bitangent,
// interpolated normal; glTF 2.0 §3.9.3), kept on the geometric front side; the interpolated
// normal where there is no map.
fn map_normal(texture: u32, scale: f32, uv: vec4<f32>, lod: vec2<f32>, tf: Frame, n_geometric: vec3<f32>) -> vec3<f32> {
    if (texture == INVALID_INDEX) {
        return tf.z;
    }
    let m = texture_lookup_lod(texture, uv, lod, false).xyz * 2.0 - vec3<f32>(1.0);
    let mapped = try_normalize(tf.x * (m.x * scale) + tf.y * (m.y * scale) + tf.z * m.z);
    if (mapped.w == 0.0) {
        return tf.z;
    }
    return select(mapped.xyz, tf.z, dot(mapped.xyz, n_geometric) < 0.0);
}

// Face the ray; fall back to the interpolated, then the geometric normal where the viewer
// would be below the shading hemisphere (the CPU twin explains the rule).
fn facing_normal(n: vec3<f32>, n_front: vec3<f32>, front_face: bool, wo_world: vec3<f32>, ng_facing: vec3<f32>) -> vec3<f32> {
    let s_n = select(-n, n, front_face);
    let s_front = select(-n_front, n_front, front_face);
    if (dot(s_n, wo_world) > 0.0) {
        return s_n;
    }
    if (dot(s_front, wo_world) > 0.0) {
        return s_front;
    }
    return ng_facing;
}

// Twin of `sides_agree`: reflection by the shading frame must be reflection by the
// geometric normal too (the CPU twin explains the light leak this closes).
fn sides_agree(si: SurfaceInteraction, wi_world: vec3<f32>, wi_local: vec3<f32>) -> bool {
    let wo_side = dot(si.wo_world, si.n_geometric);
    let reflected_geometrically = dot(wi_world, si.n_geometric) * wo_side > 0.0;
    return reflected_geometrically == (wi_local.z > 0.0);
}

// A NaN, to poison a sample whose throughput stopped being finite (the film rejects it).
fn poison() -> vec3<f32> {
    return vec3<f32>(bitcast<f32>(0x7fc00000u));
}

// The pixel (x, y) of invocation `gid` within this dispatch's band of rows
// [row_offset, row_offset + row_count); z = 0 when it lies outside the band or the image.
fn band_pixel(gid: vec3<u32>) -> vec3<u32> {
    let y = gid.y + frame.row_offset;
    let inside = gid.x < frame.width && gid.y < frame.row_count && y < frame.height;
    return vec3<u32>(gid.x, y, select(0u, 1u, inside));
}

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
}

// Where a split sample's continuations start (the CPU twin's `radiance` explains
// splitting): the hit that made the vertex and the cone width it was shaded with, the path up
// to it, its sampler state and the radiance gathered before the split. A continuation shades
// the vertex again from its hit, with the same operations and so the same bits, instead of
// keeping the surface and its BSDF (some 70 values) live across the loop: on lavapipe, whose
// `if` only masks lanes and runs both arms, the copies in and out cost every bounce, and
// shading the saved hit costs nothing extra, since the bounce shades a hit anyway. Split
// renders 3–5% faster there (bench/RESULTS.md, twenty-fifth session).
struct SplitVertex {
    hit: ClosestHit,
    cone_width: f32,
    path: PathState,
    rng: vec4<u32>,
    l_prefix: vec3<f32>,
}

// One invocation per pixel of the band: adds `samples` samples, starting at index
// `sample_offset`, to the pixel's running statistics. The path is the CPU twin's
// (`radiance` in src/cpu/integrator.rs), bounce for bounce.
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
@compute @workgroup_size(8, 8, 1)
fn render(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u || frame.samples == 0u) {
        return;
    }
    let x = px.x;
    let y = px.y;
    let pixel = y * frame.width + x;
    var p = film[pixel];
    rays_traced = 0u;
    let cone = vec2<f32>(frame.cone_width, frame.cone_spread);
    // The path of sample `sample_offset + k`, started at the top of the loop whenever
    // `start_path` is set (WGSL zero-initialises the rest until then).
    var k = 0u;
    var start_path = true;
    var path: PathState;
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
            path = PathState(camera_ray, 0.0, vec3<f32>(1.0), 0u, true, 0.0, 1.0, 0u, false);
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
                if (hit.triangle == INVALID_INDEX) {
                    if (FEATURE_ENVIRONMENT && environment.present != 0u) {
                        let env = environment_lookup(path.ray.direction);
                        if (path.depth == 0u || path.prev_delta || environment.light_index == INVALID_INDEX) {
                            l += path.beta * env.radiance;
                        } else {
                            let light_pdf = lights[environment.light_index].pmf * env.pdf_solid_angle;
                            l += path.beta * env.radiance * power_heuristic(path.prev_pdf, light_pdf);
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
            if (!resuming) {
                path.travelled += si.distance;

                if (FEATURE_VOLUME && (material.flags & MATERIAL_VOLUME) != 0u && !si.front_face) {
                    path.beta *= exp(-material.attenuation_coefficient * si.distance);
                }

                // Full weight: the cone's level of detail; weighted against light sampling: level 0,
                // what light sampling sees (the CPU twin explains).
                if (max_element(untextured.emission) > 0.0 && (si.front_face || (material.flags & MATERIAL_DOUBLE_SIDED) != 0u)) {
                    if (path.depth == 0u || path.prev_delta || si.emitter == INVALID_INDEX) {
                        // A caustic path the light tracer takes is left out here (the CPU
                        // twin's `trace` explains the partition).
                        let light_traced = frame.light_traced_caustics != 0u && path.prev_delta
                            && path.first_vertex_smooth && si.emitter != INVALID_INDEX;
                        if (!light_traced) {
                            l += path.beta * material.emission;
                        }
                    } else {
                        let light_pdf = triangle_light_pdf(lights[si.emitter], path.ray.origin, si.p);
                        l += path.beta * emitted_radiance(untextured, hit.triangle, hit.b) * power_heuristic(path.prev_pdf, light_pdf);
                    }
                }

                if (path.depth >= frame.max_depth || path.depth >= MAX_BOUNCES_GUARD) {
                    break;
                }
                l += next_event(si, bsdf, path.beta);

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
            path.beta *= bs.weight;
            if (!is_finite_vec3(path.beta)) {
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
                let q = min(max_element(path.beta * path.eta_scale), RR_MAX_SURVIVAL);
                if (q <= 0.0 || rng_next_1d() >= q) {
                    break;
                }
                path.beta /= q;
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
            if (sample_ended) {
                // A poisoned path poisons its sample, split or not (the CPU twin returns at once).
                var x = select(l, poison(), poisoned);
                if (frame.light_traced_caustics != 0u) {
                    // The light tracer's half of the pixel for this sample index.
                    x += caustic_radiance(pixel);
                }
                p = film_add_sample(p, x, replicate_of(frame.sample_offset + k));
                k += 1u;
                if (k == frame.samples) {
                    break;
                }
                start_path = true;
            }
        }
    }
    film[pixel] = p;
    ray_counts[pixel] += rays_traced;
}

// Twin of `next_event`: one light sample at `si`, MIS-weighted against the BSDF's
// sampling, times the throughput `beta`.
fn next_event(si: SurfaceInteraction, bsdf: GltfBsdf, beta: vec3<f32>) -> vec3<f32> {
    if (!has_non_delta(bsdf) || frame.light_count == 0u) {
        return vec3<f32>(0.0);
    }
    let u_light = rng_next_2d();
    let ls = sample_light(si.p, si.p_error, si.n_geometric, u_light);
    if (!ls.valid) {
        return vec3<f32>(0.0);
    }
    let wi = frame_to_local(si.frame, ls.wi);
    var f = vec3<f32>(0.0);
    if (sides_agree(si, ls.wi, wi)) {
        f = gltf_bsdf_eval(bsdf, si.wo, wi);
    }
    if (max_element(f) <= 0.0) {
        return vec3<f32>(0.0);
    }
    var shadow_seed = 0u;
    if (FEATURE_ALPHA) {
        shadow_seed = rng_next_u32();
    }
    if (intersect_any(ls.shadow_ray, shadow_seed)) {
        return vec3<f32>(0.0);
    }
    let contribution = beta * f * abs(wi.z) * ls.radiance;
    if (ls.is_delta) {
        return contribution / ls.pdf;
    }
    let w = power_heuristic(ls.pdf, gltf_bsdf_pdf(bsdf, si.wo, wi));
    return contribution * w / ls.pdf;
}

// What the camera ray of sample 0 hits: the first-hit AOV (distance, normal, albedo).
@compute @workgroup_size(8, 8, 1)
fn first_hit(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    let x = px.x;
    let y = px.y;
    // Jittered by the independent sampler on both backends (`cpu::first_hit`).
    sampler_start(SAMPLER_INDEPENDENT, x, y, 0u, frame.seed);
    let ray = generate_camera_ray(frame.width, frame.height, x, y, rng_next_2d());
    let hit = intersect_closest(ray, 0u);
    var out = FirstHit(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), INVALID_INDEX);
    if (hit.triangle != INVALID_INDEX) {
        let cone = vec2<f32>(frame.cone_width, frame.cone_spread);
        let si = surface_interaction(ray, hit, cone.x + cone.y * hit.t);
        out = FirstHit(si.frame.z, si.distance, textured_material(materials[si.material], si.uv, si.lod).base_color, hit.triangle);
    }
    first_hits[y * frame.width + x] = out;
}
