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
    let unblocked = unblocked_light_sample(si, bsdf, u_light);
    if (!unblocked.valid) {
        return vec3<f32>(0.0);
    }
    let ls = unblocked.ls;
    let wi = unblocked.wi;
    let contribution = beta * unblocked.f * abs(wi.z) * ls.radiance;
    if (ls.is_delta) {
        return contribution / ls.pdf;
    }
    let w = power_heuristic(ls.pdf, gltf_bsdf_pdf(bsdf, si.wo, wi));
    return contribution * w / ls.pdf;
}

