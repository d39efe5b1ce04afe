// Twin of src/integrator/light_tracing.rs: the caustic paths by light tracing, connected to the
// camera. src/integrator/partition.rs explains the partition of path space between this and
// `render`, src/integrator/light_tracing.rs the two factors by which importance transport
// differs from radiance transport.

// One invocation per light path of pass `frame.sample_offset`: path i = y · width + x, the
// band's rows as `render` covers them, for i below `frame.light_paths`. Its camera
// connections are splatted, divided by the number of paths, into `caustics`, which the host
// clears before the pass.
@compute @workgroup_size(8, 8, 1)
fn trace_caustics(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    let i = px.y * frame.width + px.x;
    if (i >= frame.light_paths) {
        return;
    }
    rays_traced = 0u;
    sampler_start(SAMPLER_INDEPENDENT, i, LIGHT_PATH_STREAM, frame.sample_offset, frame.seed);
    trace_light_path();
    ray_counts[i] += rays_traced;
}

// Twin of `trace_light_path`.
fn trace_light_path() {
    // The light and a point on it, chosen as next-event estimation chooses them.
    let light = lights[choose_light(rng_next_2d())];
    let u_point = rng_next_2d();
    let u_side = rng_next_1d();
    let u_direction = rng_next_2d();
    if (light.kind != LIGHT_TRIANGLE || light.pmf <= 0.0) {
        return;
    }
    let tri = triangles[light.triangle];
    let material = materials[tri.material];
    let na = triangle_light_normal_area(light);
    if (na.w == 0.0) {
        return;
    }
    let point = sample_triangle_point(tri, u_point);
    let double_sided = (material.flags & MATERIAL_DOUBLE_SIDED) != 0u;
    let sides = select(1.0, 2.0, double_sided);
    let n_emit = select(na.xyz, -na.xyz, double_sided && u_side < 0.5);
    let le = emitted_radiance(material, light.triangle, point.b);
    // β = Le cos θ / (pdf_point pdf_direction) = Le π area sides / pmf.
    var beta = le * (PI * na.w * sides / light.pmf);
    if (!is_finite_vec3(beta) || max_element(beta) <= 0.0) {
        return;
    }
    let roulette_scale = 1.0 / max_element(beta);
    let direction = frame_from_local(frame_from_z(n_emit), sample_cosine_hemisphere(u_direction));
    var ray = spawn_ray(point.p, point.p_error, n_emit, direction);

    // Vertex j of the light path is the j-th scattering event of the finished path.
    for (var j = 1u; j <= MAX_BOUNCES_GUARD; j++) {
        let hit = intersect_closest(ray, 0u);
        if (hit.triangle == INVALID_INDEX) {
            return;
        }
        let si = surface_interaction(ray, hit, 0.0);
        let m = materials[si.material];
        if (FEATURE_VOLUME && (m.flags & MATERIAL_VOLUME) != 0u && !si.front_face) {
            beta *= exp(-m.attenuation_coefficient * si.distance);
        }
        let bsdf = gltf_bsdf_new(m, si.wo, si.front_face, si.coat_normal);
        if (j >= 2u && has_non_delta(bsdf)) {
            connect_to_camera(si, hit, beta);
        }
        if (j >= frame.max_depth) {
            return;
        }
        let u_lobe = rng_next_1d();
        let u = rng_next_2d();
        let bs = gltf_bsdf_sample(bsdf, si.wo, u_lobe, u);
        // The vertex next to the light must be a delta event: other paths are the path
        // tracer's.
        if (!bs.valid || (j == 1u && !bs.is_delta)) {
            return;
        }
        let wi_world = normalize(frame_from_local(si.frame, bs.wi));
        if (!sides_agree(si, wi_world, bs.wi)) {
            return;
        }
        // The adjoint's shading-normal factor, exactly 1 where the shading normal is the
        // geometric one.
        let ng = si.n_geometric;
        var shading = 1.0;
        if (!(all(si.frame.z == ng) || all(si.frame.z == -ng))) {
            shading = (si.wo.z * abs(dot(wi_world, ng))) / (abs(dot(si.wo_world, ng)) * abs(bs.wi.z));
        }
        beta *= bs.weight * (bs.eta_scale * shading);
        if (!is_finite_vec3(beta)) {
            return;
        }
        if (j >= LIGHT_RR_MIN_VERTICES) {
            let survival = survival_probability(beta, roulette_scale);
            if (survival <= 0.0 || rng_next_1d() >= survival) {
                return;
            }
            beta /= survival;
        }
        ray = spawn_ray(si.p, si.p_error, ng, wi_world);
    }
}

// Twin of `connect_to_camera`: splats the contribution of light-path vertex `si` (hit `hit`,
// throughput `beta`) to the pixel it projects into, unless it is outside the image, faces
// away or is occluded.
fn connect_to_camera(si: SurfaceInteraction, hit: ClosestHit, beta: vec3<f32>) {
    let proj = project_to_pixel(si.p, frame.width, frame.height);
    if (!proj.valid) {
        return;
    }
    // The surface as the camera ray through the pixel would see it.
    let camera_ray = Ray(camera.position, proj.direction, F32_MAX);
    let seen = surface_interaction(camera_ray, ClosestHit(hit.triangle, hit.b, sqrt(proj.distance2)), 0.0);
    let bsdf = gltf_bsdf_new(materials[seen.material], seen.wo, seen.front_face, seen.coat_normal);
    let w_light = si.wo_world;
    let wi = frame_to_local(seen.frame, w_light);
    if (!sides_agree(seen, w_light, wi)) {
        return;
    }
    let f = gltf_bsdf_eval(bsdf, seen.wo, wi);
    // A non-finite `f` is caught by the last test.
    if (max_element(f) <= 0.0) {
        return;
    }
    let ng = si.n_geometric;
    let cos_light_geometric = abs(dot(w_light, ng));
    if (cos_light_geometric == 0.0) {
        return;
    }
    if (intersect_any(spawn_ray_to(si.p, si.p_error, ng, camera.position), 0u)) {
        return;
    }
    let c = proj.cos_theta;
    let value = beta * f * (abs(wi.z) * abs(dot(proj.direction, ng)))
        / (cos_light_geometric * pinhole_pixel_area(frame.width, frame.height) * c * c * c * proj.distance2);
    if (!is_finite_vec3(value)) {
        return;
    }
    caustic_splat(proj.pixel, value * (1.0 / f32(frame.light_paths)));
}

// Words (f32 bits) per pixel of an adaptive render's caustic sums, which follow the pass's
// image (6 words per pixel) in `caustics`: Σ P_k·c_k for even and for odd sample indices,
// then Σ P_k·c_k² (twin of `CausticSums` in src/integrator/light_tracing.rs, which explains
// the estimator).
const CAUSTIC_SUM_WORDS: u32 = 9u;

// One invocation per pixel, after every band of pass `frame.sample_offset` (of
// `frame.light_paths` paths): adds the pass's image to the pixel's sums, in the order and
// f32 arithmetic of `CausticSums::add_pass`. One invocation owns each pixel's words, so
// plain loads and stores suffice (the buffer is atomic for the splats).
@compute @workgroup_size(8, 8, 1)
fn accumulate_caustic_sums(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    let pixel = px.y * frame.width + px.x;
    let c = caustic_radiance(pixel);
    if (all(c == vec3<f32>(0.0))) {
        // No splat landed here this pass: adding zero would change nothing.
        return;
    }
    let paths = f32(frame.light_paths);
    let base = 6u * frame.width * frame.height + CAUSTIC_SUM_WORDS * pixel;
    let r = replicate_of(frame.sample_offset);
    for (var ch = 0u; ch < 3u; ch++) {
        add_to_caustic_word(base + 3u * r + ch, paths * c[ch]);
        add_to_caustic_word(base + 6u + ch, paths * c[ch] * c[ch]);
    }
}

fn add_to_caustic_word(word: u32, value: f32) {
    let sum = bitcast<f32>(atomicLoad(&caustics[word])) + value;
    atomicStore(&caustics[word], bitcast<u32>(sum));
}
