// Auxiliary images (AOVs): each pixel's albedo, normal and depth averaged over AOV_SAMPLES
// camera rays, followed through delta lobes. CPU twin: src/integrator/aov.rs, which says
// why the rays are jittered, where their numbers come from, and what a delta chain gives.

// Binding 21: one PixelAov per pixel where the render was set up for AOVs
// (`RenderSettings::aovs`), else one unused element.
@group(0) @binding(21) var<storage, read_write> aovs: array<PixelAov>;

const AOV_SAMPLES: u32 = 16u;
const AOV_MAX_DELTA_BOUNCES: u32 = 8u;
const AOV_SAMPLE_INDEX: u32 = 0xffffffffu;

@compute @workgroup_size(8, 8, 1)
fn aov(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    let x = px.x;
    let y = px.y;
    // The host sets the cone of a render of AOV_SAMPLES samples (`GpuBackend::aovs`).
    let cone = vec2<f32>(frame.cone_width, frame.cone_spread);
    var albedo = vec3<f32>(0.0);
    var normal = vec3<f32>(0.0);
    var emission = vec3<f32>(0.0);
    var depth = 0.0;
    var hits = 0u;
    for (var k = 0u; k < AOV_SAMPLES; k++) {
        sampler_start(SAMPLER_INDEPENDENT, x, y, AOV_SAMPLE_INDEX - k, frame.seed);
        var ray = generate_camera_ray(frame.width, frame.height, x, y, rng_next_2d());
        var travelled = 0.0;
        for (var bounce = 0u; bounce <= AOV_MAX_DELTA_BOUNCES; bounce++) {
            var alpha_seed = 0u;
            if (FEATURE_ALPHA) {
                alpha_seed = rng_next_u32();
            }
            let hit = intersect_closest(ray, alpha_seed);
            if (hit.triangle == INVALID_INDEX) {
                break;
            }
            let si = surface_interaction(ray, hit, cone.x + cone.y * (travelled + hit.t));
            travelled += si.distance;
            if (bounce == 0u) {
                depth += si.distance;
                hits += 1u;
            }
            let material = textured_material(materials[si.material], si.uv, si.lod);
            let bsdf = gltf_bsdf_new(material, si.wo, si.front_face, si.coat_normal);
            if (has_non_delta(bsdf) || bounce == AOV_MAX_DELTA_BOUNCES) {
                albedo += material.base_color;
                normal += si.frame.z;
                if (si.front_face || (material.flags & MATERIAL_DOUBLE_SIDED) != 0u) {
                    emission += material.emission;
                }
                break;
            }
            let u_lobe = rng_next_1d();
            let u_dir = rng_next_direction_2d();
            let bs = gltf_bsdf_sample(bsdf, si.wo, u_lobe, u_dir);
            if (!bs.valid) {
                break;
            }
            ray = spawn_ray(si.p, si.p_error, si.n_geometric, normalize(frame_from_local(si.frame, bs.wi)));
        }
    }
    let n = f32(AOV_SAMPLES);
    var mean_depth = 0.0;
    if (hits > 0u) {
        mean_depth = depth / f32(hits);
    }
    aovs[y * frame.width + x] = PixelAov(albedo / n, mean_depth, normal / n, hits, emission / n, 0u);
}
