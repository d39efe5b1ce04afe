// Next-event estimation (twin of `next_event` in src/integrator/path.rs), shared by the path
// tracer's `render` and photon mapping's camera paths (shaders/sppm.wgsl), which include it
// without the rest of the path tracer.

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

