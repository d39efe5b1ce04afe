// Twin of src/integrator/bdpt.rs: bidirectional path tracing (Veach 1997 ch. 10; pbrt-v3
// §16.3), every strategy weighted by the power heuristic through the pdf-ratio recurrence.
// The CPU twin defines the strategies, the densities, the adjoint and the order in which
// random numbers are drawn; this file mirrors it function by function. Two entry points:
// `render` traces one sample of every pixel of its band (sample index `frame.sample_offset`)
// and leaves the pixel's own strategies' sum in `bdpt_state.values` and the t = 1 splats in
// `caustics`; `bdpt_resolve`, once every band of the pass has been traced, adds the two to
// the film as that sample.
//
// Where the CPU keeps a surface vertex's interaction and BSDF, a light vertex here keeps the
// hit (triangle, barycentrics) and the direction it was reached from, and builds them again
// when a join needs them: `surface_interaction` reads a ray only for its direction, so the
// rebuilt record has the same bits as the one the walk made (`bdpt_seen_from`).

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

// Twin of `Kind`.
const VERTEX_CAMERA: u32 = 0u;
const VERTEX_TRIANGLE_LIGHT: u32 = 1u;
const VERTEX_POINT_LIGHT: u32 = 2u;
const VERTEX_DIRECTIONAL_LIGHT: u32 = 3u;
const VERTEX_ENVIRONMENT: u32 = 4u;
const VERTEX_SURFACE: u32 = 5u;

// Twin of `Vertex`; for surfaces also the hit and the arrival direction (see the header).
struct BdptVertex {
    p: vec3<f32>,
    kind: u32,
    // As the CPU twin's `n`.
    n: vec3<f32>,
    light: u32,
    beta: vec3<f32>,
    pdf_fwd: f32,
    // Surfaces: the unit direction the subpath arrived from (pointing away).
    wo_world: vec3<f32>,
    pdf_rev: f32,
    // Surfaces: the hit's barycentrics and the point's rounding bound.
    b: vec3<f32>,
    triangle: u32,
    p_error: vec3<f32>,
    delta: bool,
    // Surfaces: a join can end here (the BSDF has a non-delta lobe).
    connectible: bool,
}

fn bdpt_endpoint(kind: u32, p: vec3<f32>, n: vec3<f32>, light: u32, beta: vec3<f32>, pdf_fwd: f32) -> BdptVertex {
    return BdptVertex(p, kind, n, light, beta, pdf_fwd, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), INVALID_INDEX, vec3<f32>(0.0), false, true);
}

fn bdpt_at_infinity(v: BdptVertex) -> bool {
    return v.kind == VERTEX_ENVIRONMENT || v.kind == VERTEX_DIRECTIONAL_LIGHT;
}

fn bdpt_on_surface(v: BdptVertex) -> bool {
    return v.kind == VERTEX_SURFACE || v.kind == VERTEX_TRIANGLE_LIGHT;
}

fn bdpt_is_delta_light(v: BdptVertex) -> bool {
    return v.kind == VERTEX_POINT_LIGHT || v.kind == VERTEX_DIRECTIONAL_LIGHT;
}

// Twin of `Vertex::emitted_towards`.
fn bdpt_emitted_towards(v: BdptVertex, other: BdptVertex) -> vec3<f32> {
    if (v.kind == VERTEX_ENVIRONMENT) {
        return -v.n;
    }
    if (v.kind == VERTEX_DIRECTIONAL_LIGHT) {
        return v.n;
    }
    let d = try_normalize(other.p - v.p);
    return select(vec3<f32>(0.0), d.xyz, d.w != 0.0);
}

// Twin of `Vertex::convert_density`.
fn bdpt_convert_density(v: BdptVertex, pdf_solid_angle: f32, next: BdptVertex) -> f32 {
    if (bdpt_at_infinity(v)) {
        var cos_next = 1.0;
        if (bdpt_on_surface(next)) {
            cos_next = abs(dot(bdpt_emitted_towards(v, next), next.n));
        }
        return pdf_solid_angle * cos_next;
    }
    if (bdpt_at_infinity(next)) {
        return pdf_solid_angle;
    }
    let d = next.p - v.p;
    let dist2 = dot(d, d);
    if (dist2 == 0.0) {
        return 0.0;
    }
    var pdf = pdf_solid_angle / dist2;
    if (bdpt_on_surface(next)) {
        pdf *= abs(dot(d / sqrt(dist2), next.n));
    }
    return pdf;
}

// Twin of `Seen`: a surface as a path arriving from one direction sees it.
struct BdptSeen {
    si: SurfaceInteraction,
    bsdf: GltfBsdf,
}

// Twin of `vertex_material`: textures at their finest level (the CPU twin's "Textures").
fn bdpt_vertex_material(si: SurfaceInteraction) -> Material {
    return textured_material(materials[si.material], si.uv, vec2<f32>(LOD_FINEST));
}

// Twin of `Vertex::seen_from`: surface vertex `v` seen from direction `w` (unit, world,
// pointing away), its interaction and BSDF built for `w`.
fn bdpt_seen_from(v: BdptVertex, w: vec3<f32>) -> BdptSeen {
    let ray = Ray(v.p + w, -w, F32_MAX);
    let si = surface_interaction(ray, ClosestHit(v.triangle, v.b, 1.0), 0.0);
    let material = bdpt_vertex_material(si);
    return BdptSeen(si, gltf_bsdf_new(material, si.wo, si.front_face, si.coat_normal));
}

// Twin of `Seen::f_cos`.
fn bdpt_f_cos(seen: BdptSeen, w_light: vec3<f32>) -> vec3<f32> {
    let wi = frame_to_local(seen.si.frame, w_light);
    if (!sides_agree(seen.si, w_light, wi)) {
        return vec3<f32>(0.0);
    }
    return gltf_bsdf_eval(seen.bsdf, seen.si.wo, wi) * abs(wi.z);
}

// Twin of `Seen::pdf`.
fn bdpt_pdf(seen: BdptSeen, w_to: vec3<f32>) -> f32 {
    let wi = frame_to_local(seen.si.frame, w_to);
    if (!sides_agree(seen.si, w_to, wi)) {
        return 0.0;
    }
    return gltf_bsdf_pdf(seen.bsdf, seen.si.wo, wi);
}

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

fn bdpt_disk_area() -> f32 {
    return PI * frame.scene_radius * frame.scene_radius;
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

// Twin of `Walk`.
struct BdptWalk {
    ray: Ray,
    beta: vec3<f32>,
    pdf_solid_angle: f32,
    eta_scale: f32,
    non_delta_depth: u32,
    roulette_scale: f32,
    // Carries importance (the light subpath), not radiance.
    importance: bool,
}

fn bdpt_walk_new(ray: Ray, beta: vec3<f32>, pdf_solid_angle: f32, importance: bool) -> BdptWalk {
    let roulette_scale = select(1.0, 1.0 / max_element(beta), importance);
    return BdptWalk(ray, beta, pdf_solid_angle, 1.0, 0u, roulette_scale, importance);
}

// Twin of `Walk::trace`: traces the walk's ray from `prev`; false where it reaches nothing
// (the camera subpath's environment vertex counts as something). A surface's interaction,
// material and BSDF come back in `si`, `material`, `bsdf`.
fn bdpt_trace(walk: ptr<function, BdptWalk>, prev: BdptVertex, v: ptr<function, BdptVertex>, si_out: ptr<function, SurfaceInteraction>, material_out: ptr<function, Material>, bsdf_out: ptr<function, GltfBsdf>) -> bool {
    var alpha_seed = 0u;
    if (FEATURE_ALPHA) {
        alpha_seed = rng_next_u32();
    }
    let hit = intersect_closest((*walk).ray, alpha_seed);
    if (hit.triangle == INVALID_INDEX) {
        if (!(*walk).importance && FEATURE_ENVIRONMENT && environment.present != 0u) {
            *v = bdpt_endpoint(VERTEX_ENVIRONMENT, vec3<f32>(0.0), (*walk).ray.direction, environment.light_index, (*walk).beta, (*walk).pdf_solid_angle);
            return true;
        }
        return false;
    }
    let si = surface_interaction((*walk).ray, hit, 0.0);
    let material = bdpt_vertex_material(si);
    if (FEATURE_VOLUME && (material.flags & MATERIAL_VOLUME) != 0u && !si.front_face) {
        (*walk).beta *= exp(-material.attenuation_coefficient * si.distance);
    }
    let bsdf = gltf_bsdf_new(material, si.wo, si.front_face, si.coat_normal);
    var out = BdptVertex(si.p, VERTEX_SURFACE, si.n_geometric, si.emitter, (*walk).beta, 0.0, si.wo_world, 0.0, hit.b, hit.triangle, si.p_error, false, has_non_delta(bsdf));
    out.pdf_fwd = bdpt_convert_density(prev, (*walk).pdf_solid_angle, out);
    *v = out;
    *si_out = si;
    *material_out = material;
    *bsdf_out = bsdf;
    return true;
}

// Twin of `Walk::scatter`: samples the BSDF at `v` (vertex `here` of its subpath, reached
// from `prev`; interaction `si`, BSDF `bsdf`) and plays roulette. Sets `v.delta`; returns
// the reverse density of `prev` if the walk goes on, −1 if it ends.
fn bdpt_scatter(walk: ptr<function, BdptWalk>, v: ptr<function, BdptVertex>, si: SurfaceInteraction, bsdf: GltfBsdf, prev: BdptVertex, here: u32) -> f32 {
    let least_depth = here + select(0u, 1u, (*walk).importance);
    if (least_depth > min(frame.max_depth, MAX_BOUNCES_GUARD) || (*v).kind != VERTEX_SURFACE) {
        return -1.0;
    }
    let u_lobe = rng_next_1d();
    let u_dir = rng_next_direction_2d();
    let bs = gltf_bsdf_sample(bsdf, si.wo, u_lobe, u_dir);
    if (!bs.valid) {
        return -1.0;
    }
    let w_next = normalize(frame_from_local(si.frame, bs.wi));
    if (!sides_agree(si, w_next, bs.wi)) {
        return -1.0;
    }
    let ng = si.n_geometric;
    var pdf_reverse = 0.0;
    var weight = bs.weight;
    if ((*walk).importance) {
        if (bs.is_delta) {
            var shading = 1.0;
            if (!(all(si.frame.z == ng) || all(si.frame.z == -ng))) {
                shading = (si.wo.z * abs(dot(w_next, ng))) / (abs(dot(si.wo_world, ng)) * abs(bs.wi.z));
            }
            weight = bs.weight * (bs.eta_scale * shading);
        } else {
            // The BSDF built for the camera's side, `w_next`, over the density it was
            // sampled with from the light's side (the CPU twin's "Adjoint").
            let seen = bdpt_seen_from(*v, w_next);
            let f_cos = bdpt_f_cos(seen, si.wo_world);
            let cos_in = abs(dot(si.wo_world, ng));
            weight = vec3<f32>(0.0);
            if (cos_in > 0.0) {
                weight = f_cos * (abs(dot(w_next, ng)) / (cos_in * bs.pdf_solid_angle));
            }
            pdf_reverse = bdpt_pdf(seen, si.wo_world);
        }
    } else if (!bs.is_delta) {
        pdf_reverse = bdpt_pdf(bdpt_seen_from(*v, w_next), si.wo_world);
    }
    (*walk).beta *= weight;
    if (!is_finite_vec3((*walk).beta) || max_element((*walk).beta) <= 0.0) {
        return -1.0;
    }
    (*v).delta = bs.is_delta;
    (*walk).pdf_solid_angle = select(bs.pdf_solid_angle, 0.0, bs.is_delta);
    var rev = 0.0;
    if (!bs.is_delta) {
        rev = bdpt_convert_density(*v, pdf_reverse, prev);
    }
    (*walk).eta_scale *= bs.eta_scale;
    if (!bs.is_delta) {
        (*walk).non_delta_depth += 1u;
    }
    var plays = false;
    var q = 1.0;
    if ((*walk).importance) {
        plays = here >= LIGHT_RR_MIN_VERTICES;
        if (plays) {
            q = survival_probability((*walk).beta, (*walk).roulette_scale);
        }
    } else {
        plays = (*walk).non_delta_depth >= frame.rr_min_depth || here >= RR_ANY_BOUNCE_DEPTH;
        if (plays) {
            q = survival_probability((*walk).beta, (*walk).eta_scale);
        }
    }
    if (plays) {
        if (q <= 0.0 || rng_next_1d() >= q) {
            return -1.0;
        }
        (*walk).beta /= q;
    }
    (*walk).ray = spawn_ray(si.p, si.p_error, ng, w_next);
    return rev;
}

// Twin of `disk_point`.
fn bdpt_disk_point(towards: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let f = frame_from_z(towards);
    let d = sample_uniform_disk_concentric(u) * frame.scene_radius;
    return frame.scene_center + towards * frame.scene_radius + f.x * d.x + f.y * d.y;
}

// Twin of `sample_cone`: a direction (xyz) uniform in the cone about `axis` and its density
// per solid angle (w).
fn bdpt_sample_cone(axis: vec3<f32>, cos_max: f32, u: vec2<f32>) -> vec4<f32> {
    let cos_theta = 1.0 - u.x * (1.0 - cos_max);
    let sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    let phi = 2.0 * PI * u.y;
    let local = vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
    let pdf = 1.0 / (2.0 * PI * max(1.0 - cos_max, F32_MIN_POSITIVE));
    return vec4<f32>(frame_from_local(frame_from_z(axis), local), pdf);
}

// Twin of `sample_uniform_sphere`.
fn bdpt_sample_uniform_sphere(u: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt(max(1.0 - z * z, 0.0));
    let phi = 2.0 * PI * u.y;
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

// Twin of `light_subpath`: fills `bdpt_light` from the light stream (the sampler is
// the light path's when called).
fn bdpt_light_subpath() {
    bdpt_light_count = 0u;
    if (frame.light_count == 0u) {
        return;
    }
    let index = choose_light(rng_next_2d());
    let u_point = rng_next_2d();
    let u_side = rng_next_1d();
    let u_direction = rng_next_2d();
    let light = lights[index];
    let pmf = light.pmf;
    if (pmf <= 0.0) {
        return;
    }
    let disk_area = bdpt_disk_area();
    var y0: BdptVertex;
    var ray: Ray;
    var beta: vec3<f32>;
    var pdf_direction = 1.0;
    if (FEATURE_EMISSIVE_TRIANGLES && light.kind == LIGHT_TRIANGLE) {
        // Twin of `sample_triangle_emission`.
        let tri = triangles[light.triangle];
        let material = materials[tri.material];
        let na = triangle_light_normal_area(light);
        if (na.w == 0.0) {
            return;
        }
        let point = sample_triangle_point(tri, u_point);
        let double_sided = (material.flags & MATERIAL_DOUBLE_SIDED) != 0u;
        let sides = select(1.0, 2.0, double_sided);
        let normal = select(na.xyz, -na.xyz, double_sided && u_side < 0.5);
        let radiance = emitted_radiance(material, light.triangle, point.b);
        let local = sample_cosine_hemisphere(u_direction);
        let direction = frame_from_local(frame_from_z(normal), local);
        y0 = bdpt_endpoint(VERTEX_TRIANGLE_LIGHT, point.p, normal, index, radiance, pmf / na.w);
        ray = spawn_ray(point.p, point.p_error, normal, direction);
        beta = radiance * (PI * na.w * sides / pmf);
        pdf_direction = local.z / (PI * sides);
    } else if (FEATURE_POINT_LIGHTS && (light.kind == LIGHT_POINT || light.kind == LIGHT_SPOT)) {
        var direction: vec3<f32>;
        var pdf: f32;
        var intensity = light.intensity;
        if (FEATURE_SPOT_LIGHTS && light.kind == LIGHT_SPOT) {
            let cone = bdpt_sample_cone(light.direction, light.cos_outer, u_direction);
            direction = cone.xyz;
            pdf = cone.w;
            intensity *= spot_falloff(light, dot(direction, light.direction));
        } else {
            direction = bdpt_sample_uniform_sphere(u_direction);
            pdf = 1.0 / (4.0 * PI);
        }
        y0 = bdpt_endpoint(VERTEX_POINT_LIGHT, light.position, vec3<f32>(0.0), index, intensity, pmf);
        ray = Ray(light.position, direction, F32_MAX);
        beta = intensity / (pmf * pdf);
        pdf_direction = pdf;
    } else if (FEATURE_DIRECTIONAL_LIGHTS && light.kind == LIGHT_DIRECTIONAL) {
        let origin = bdpt_disk_point(-light.direction, u_point);
        y0 = bdpt_endpoint(VERTEX_DIRECTIONAL_LIGHT, origin, light.direction, index, light.intensity, pmf);
        ray = Ray(origin, light.direction, F32_MAX);
        beta = light.intensity * (disk_area / pmf);
    } else if (FEATURE_ENVIRONMENT && light.kind == LIGHT_ENVIRONMENT) {
        let es = sample_environment(u_direction);
        if (!es.valid) {
            return;
        }
        let origin = bdpt_disk_point(es.wi, u_point);
        y0 = bdpt_endpoint(VERTEX_ENVIRONMENT, vec3<f32>(0.0), es.wi, index, es.radiance, pmf * es.pdf_solid_angle);
        ray = Ray(origin, -es.wi, F32_MAX);
        beta = es.radiance * (disk_area / (pmf * es.pdf_solid_angle));
    } else {
        return;
    }
    if (!is_finite_vec3(beta) || max_element(beta) <= 0.0) {
        return;
    }
    bdpt_light[0] = y0;
    bdpt_light_count = 1u;
    // Lights at infinity send y₁ the density of the disk's point (`convert_density`).
    let pdf_solid_angle = select(pdf_direction, 1.0 / disk_area, bdpt_at_infinity(y0));
    var walk = bdpt_walk_new(ray, beta, pdf_solid_angle, true);
    loop {
        let here = bdpt_light_count;
        var v: BdptVertex;
        var si: SurfaceInteraction;
        var material: Material;
        var bsdf: GltfBsdf;
        if (!bdpt_trace(&walk, bdpt_light[here - 1u], &v, &si, &material, &bsdf)) {
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
            atomicAdd(&bdpt_state.truncated, 1u);
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

// Twin of `join_camera`: t = 1, light vertex y_{s−1} joined to the camera at `x0` and
// splatted (divided by the number of light paths) where it projects.
fn bdpt_join_camera(x0: BdptVertex, s: u32) {
    var alpha_seed = 0u;
    if (FEATURE_ALPHA) {
        alpha_seed = rng_next_u32();
    }
    let qs = bdpt_light[s - 1u];
    if (!bdpt_has_projection() || qs.kind != VERTEX_SURFACE || !qs.connectible) {
        return;
    }
    let proj = project_to_pixel(qs.p, frame.width, frame.height);
    if (!proj.valid) {
        return;
    }
    let seen = bdpt_seen_from(qs, -proj.direction);
    let f_cos = bdpt_f_cos(seen, qs.wo_world);
    if (max_element(f_cos) <= 0.0) {
        return;
    }
    let ng = qs.n;
    let cos_in = abs(dot(qs.wo_world, ng));
    if (cos_in == 0.0) {
        return;
    }
    if (intersect_any(spawn_ray_to(qs.p, qs.p_error, ng, camera.position), alpha_seed)) {
        return;
    }
    let c = proj.cos_theta;
    let value = qs.beta * f_cos * abs(dot(proj.direction, ng))
        / (cos_in * pinhole_pixel_area(frame.width, frame.height) * c * c * c * proj.distance2);
    if (!is_finite_vec3(value)) {
        return;
    }
    var join = bdpt_join_none();
    join.light_end = bdpt_convert_density(x0, bdpt_camera_pdf_direction(proj.direction), qs);
    join.light_before = bdpt_convert_density(qs, bdpt_pdf(seen, qs.wo_world), bdpt_light[s - 2u]);
    let weighted = value * bdpt_mis_weight(s, 1u, join);
    caustic_splat(proj.pixel, weighted * (1.0 / f32(frame.width * frame.height)));
}

// Twin of `join_light_sample`: s = 1 at camera vertex `pt` (x_{t−1}, reached from `ptm`).
fn bdpt_join_light_sample(pt: BdptVertex, ptm: BdptVertex, si: SurfaceInteraction, bsdf: GltfBsdf, t: u32) -> vec3<f32> {
    if (pt.kind != VERTEX_SURFACE || !pt.connectible || frame.light_count == 0u) {
        return vec3<f32>(0.0);
    }
    let ls = sample_light(si.p, si.p_error, si.n_geometric, rng_next_2d());
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
    var alpha_seed = 0u;
    if (FEATURE_ALPHA) {
        alpha_seed = rng_next_u32();
    }
    if (intersect_any(ls.shadow_ray, alpha_seed)) {
        return vec3<f32>(0.0);
    }
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
    bdpt_light_subpath();
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
