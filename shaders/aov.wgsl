// Auxiliary images (AOVs): each pixel's albedo, normal, depth, emission and coverage averaged
// over AOV_SAMPLES stratified camera rays (more where features vary, on silhouettes and on
// emitters' edges, as the host's list and `frame.aov_rays` say), followed through delta
// lobes. CPU twin:
// src/integrator/aov.rs, which says why the rays are stratified, where their numbers come
// from, which pixels are refined, and what a delta chain gives.

// Binding 21: one PixelAov per pixel where the render was set up for AOVs
// (`RenderSettings::aovs`), else one unused element.
@group(0) @binding(21) var<storage, read_write> aovs: array<PixelAov>;

const AOV_SAMPLES: u32 = 4u;
const AOV_MAX_DELTA_BOUNCES: u32 = 8u;
const AOV_SAMPLE_INDEX: u32 = 0xffffffffu;

// What one AOV ray found.
struct AovRay {
    hit: bool,
    depth: f32,
    albedo: vec3<f32>,
    normal: vec3<f32>,
    emission: vec3<f32>,
    // The material the albedo was read from; AOV_NO_MATERIAL for a ray that left the scene.
    material: u32,
}

// AOV ray `k` of `rays` (a square number) of pixel (x, y): in cell k of a √rays × √rays
// grid over the pixel, jittered within it.
fn aov_ray(x: u32, y: u32, cone: vec2<f32>, k: u32, rays: u32) -> AovRay {
    // √rays, exact for the square counts the passes take (CPU: `u32::isqrt`).
    let side = u32(sqrt(f32(rays)) + 0.5);
    sampler_start(SAMPLER_INDEPENDENT, x, y, AOV_SAMPLE_INDEX - k, frame.seed);
    let jitter = rng_next_2d();
    let cell = vec2<f32>(f32(k % side), f32(k / side));
    let u = min((cell + jitter) / f32(side), vec2<f32>(1.0 - 1.1920929e-7));
    var ray = generate_camera_ray(frame.width, frame.height, x, y, u);
    var out = AovRay(false, 0.0, vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), AOV_NO_MATERIAL);
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
            out.hit = true;
            out.depth = si.distance;
        }
        let material = textured_material(materials[si.material], si.uv, si.lod);
        let bsdf = gltf_bsdf_new(material, si.wo, si.front_face, si.coat_normal);
        if (has_non_delta(bsdf) || bounce == AOV_MAX_DELTA_BOUNCES) {
            out.albedo = material.base_color;
            out.normal = si.frame.z;
            out.material = si.material;
            if (si.front_face || (material.flags & MATERIAL_DOUBLE_SIDED) != 0u) {
                out.emission = material.emission;
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
    return out;
}

// The AOVs of pixel (x, y) averaged over `rays` rays (CPU twin: `pixel_aov`).
fn pixel_aov(x: u32, y: u32, cone: vec2<f32>, rays: u32) -> PixelAov {
    // `rays` counts the rays taken, so that the host can tell a pass the device cut short.
    var p = PixelAov(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0u, vec3<f32>(0.0), 0u, AOV_NO_MATERIAL, 0u, 0u, 0u);
    for (var k = 0u; k < rays; k++) {
        p.rays += 1u;
        let r = aov_ray(x, y, cone, k, rays);
        p.material = select(AOV_MIXED_MATERIALS, r.material, k == 0u || r.material == p.material);
        p.albedo += r.albedo;
        p.normal += r.normal;
        p.emission += r.emission;
        p.depth += r.depth;
        p.hits += select(0u, 1u, r.hit);
    }
    let n = f32(p.rays);
    p.albedo /= n;
    p.normal /= n;
    p.emission /= n;
    p.depth = select(0.0, p.depth / f32(p.hits), p.hits > 0u);
    return p;
}

// The first pass: AOV_SAMPLES rays per pixel of the band.
@compute @workgroup_size(8, 8, 1)
fn aov(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    // The host sets the render's cone (`render_aovs`).
    let cone = vec2<f32>(frame.cone_width, frame.cone_spread);
    aovs[px.y * frame.width + px.x] = pixel_aov(px.x, px.y, cone, AOV_SAMPLES);
}

// Binding 23: the pixels the second pass refines (`pixels_to_refine`, decided on the host
// from the first pass), row-major indices; one unused element without AOVs.
@group(0) @binding(23) var<storage, read> aov_refine_list: array<u32>;

// The second pass: `frame.aov_rays` rays for list entries `frame.sample_offset` ..
// `frame.sample_offset + frame.samples` (the dispatch's slice of the list).
@compute @workgroup_size(64, 1, 1)
fn aov_refine(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    if (gid.x >= frame.samples) {
        return;
    }
    let pixel = aov_refine_list[frame.sample_offset + gid.x];
    let cone = vec2<f32>(frame.cone_width, frame.cone_spread);
    aovs[pixel] = pixel_aov(pixel % frame.width, pixel / frame.width, cone, frame.aov_rays);
}
