// Twin of src/integrator/photon.rs: photon mapping with a caustic map, a global map and a
// final gather (Jensen 1996). Both maps are built once, before the first sample, by the
// build passes of shaders/sppm.wgsl (`GpuBackend::build_photon_maps`): the global map at
// `SppmMap(0, 0)`, the caustic map at (`frame.photon_grid_base`,
// `frame.photon_record_base`). `photon_render` then adds samples as the path tracer's
// `render` does: `frame.samples` of every pixel of the band, from `frame.sample_offset`.

// Twin of CAUSTIC_RADIUS_PIXELS.
const CAUSTIC_RADIUS_PIXELS: f32 = 2.0;
// Twin of GATHER_DELTA_BOUNCES.
const GATHER_DELTA_BOUNCES: u32 = 16u;

fn photon_global_map() -> SppmMap {
    return SppmMap(0u, 0u);
}

fn photon_caustic_map() -> SppmMap {
    return SppmMap(frame.photon_grid_base, frame.photon_record_base);
}

// Twin of `final_gather`: along the visible point's BSDF sample `bs` (throughput `beta_in`
// before it), the emitter it hits first, MIS-weighted, or the global map's radiance at the
// first surface with a non-delta lobe past any delta bounces.
fn photon_final_gather(si: SurfaceInteraction, bs: BsdfSample, beta_in: vec3<f32>) -> vec3<f32> {
    var wi_world = normalize(frame_from_local(si.frame, bs.wi));
    if (!sides_agree(si, wi_world, bs.wi)) {
        return vec3<f32>(0.0);
    }
    var beta = beta_in * bs.weight;
    var ray = spawn_ray(si.p, si.p_error, si.n_geometric, wi_world);
    var emission = vec3<f32>(0.0);
    for (var bounce = 0u; bounce < GATHER_DELTA_BOUNCES; bounce++) {
        var alpha_seed = 0u;
        if (FEATURE_ALPHA) {
            alpha_seed = rng_next_u32();
        }
        let hit = intersect_closest(ray, alpha_seed);
        if (bounce == 0u) {
            // An emitter seen along the sample itself; past a delta bounce the caustic map
            // has it.
            emission = beta * sppm_mis_weighted_emission(ray, hit, bs.pdf_solid_angle);
        }
        if (hit.triangle == INVALID_INDEX) {
            return emission;
        }
        let here = surface_interaction(ray, hit, 0.0);
        let material = bdpt_vertex_material(here);
        if (FEATURE_VOLUME && (material.flags & MATERIAL_VOLUME) != 0u && !here.front_face) {
            beta *= exp(-material.attenuation_coefficient * here.distance);
        }
        let bsdf = gltf_bsdf_new(material, here.wo, here.front_face, here.coat_normal);
        if (has_non_delta(bsdf)) {
            let radius = frame.photon_global_radius;
            let gathered = sppm_gather_photons(photon_global_map(), here, bsdf, radius);
            let area = PI * radius * radius;
            return emission + beta * gathered.phi / (f32(max(frame.sppm_photons, 1u)) * area);
        }
        // A delta surface (never a matte one, so its lobe choice is drawn): follow it.
        let u_lobe = rng_next_1d();
        let next = gltf_bsdf_sample(bsdf, here.wo, u_lobe, rng_next_2d());
        if (!next.valid) {
            return emission;
        }
        wi_world = normalize(frame_from_local(here.frame, next.wi));
        if (!sides_agree(here, wi_world, next.wi)) {
            return emission;
        }
        beta *= next.weight;
        if (!is_finite_vec3(beta)) {
            return emission;
        }
        ray = spawn_ray(here.p, here.p_error, here.n_geometric, wi_world);
    }
    return emission;
}

// Twin of `photon_map_sample`: sample `k` of pixel (x, y).
fn photon_sample(x: u32, y: u32, k: u32) -> vec3<f32> {
    let path = sppm_camera_path(x, y, k);
    let vp = path.point;
    if (vp.triangle == INVALID_INDEX) {
        return vp.direct;
    }
    let surface = sppm_surface(vp);
    let direct = vp.direct + photon_final_gather(surface.si, path.bs, path.throughput);
    let radius = CAUSTIC_RADIUS_PIXELS * max(vp.footprint, frame.scene_radius * 1e-6);
    let gathered = sppm_gather_photons(photon_caustic_map(), surface.si, surface.bsdf, radius);
    let area = PI * radius * radius;
    return direct + vp.beta * gathered.phi / (f32(max(frame.photon_caustic_photons, 1u)) * area);
}

// `frame.samples` samples of every pixel of the band, from index `frame.sample_offset`.
@compute @workgroup_size(8, 8, 1)
fn photon_render(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    let pixel = px.y * frame.width + px.x;
    rays_traced = 0u;
    var p = film[pixel];
    for (var j = 0u; j < frame.samples; j++) {
        let k = frame.sample_offset + j;
        p = film_add_sample(p, photon_sample(px.x, px.y, k), replicate_of(k));
    }
    film[pixel] = p;
    ray_counts[pixel] += rays_traced;
}
