// Twin of the subpath half of src/integrator/bdpt.rs: the vertex, the walk that extends a
// subpath by tracing and scattering (radiance from the camera, importance from a light),
// and the origin of a light subpath (`light_subpath_origin`). Bidirectional path tracing
// (shaders/bdpt.wgsl) joins the subpaths these make; photon mapping (shaders/sppm.wgsl)
// walks photons with them. The CPU twin defines the densities, the adjoint and the order
// in which random numbers are drawn.
//
// Where the CPU keeps a surface vertex's interaction and BSDF, a vertex here keeps the hit
// (triangle, barycentrics) and the direction it was reached from, and builds them again
// when it needs them: `surface_interaction` reads a ray only for its direction, so the
// rebuilt record has the same bits as the one the walk made (`bdpt_seen_from`).


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



fn bdpt_disk_area() -> f32 {
    return PI * frame.scene_radius * frame.scene_radius;
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
    // Plays Russian roulette (Metropolis's fixed-length subpaths do not).
    roulette: bool,
}

fn bdpt_walk_new(ray: Ray, beta: vec3<f32>, pdf_solid_angle: f32, importance: bool) -> BdptWalk {
    let roulette_scale = select(1.0, 1.0 / max_element(beta), importance);
    return BdptWalk(ray, beta, pdf_solid_angle, 1.0, 0u, roulette_scale, importance, true);
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
    if (!(*walk).roulette) {
        plays = false;
    } else if ((*walk).importance) {
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

// Twin of `light_subpath_origin`: a light chosen by power, a point on it and a direction
// from it, drawn from the light stream (the sampler is the light path's when called). Sets
// the origin `y0` and the walk that leaves it; false where no light sends anything.
fn bdpt_light_origin(y0: ptr<function, BdptVertex>, walk_out: ptr<function, BdptWalk>) -> bool {
    if (frame.light_count == 0u) {
        return false;
    }
    let index = choose_light(rng_next_2d());
    let u_point = rng_next_2d();
    let u_side = rng_next_1d();
    let u_direction = rng_next_2d();
    let light = lights[index];
    let pmf = light.pmf;
    if (pmf <= 0.0) {
        return false;
    }
    let disk_area = bdpt_disk_area();
    var ray: Ray;
    var beta: vec3<f32>;
    var pdf_direction = 1.0;
    if (FEATURE_EMISSIVE_TRIANGLES && light.kind == LIGHT_TRIANGLE) {
        // Twin of `sample_triangle_emission`.
        let tri = triangles[light.triangle];
        let material = materials[tri.material];
        let na = triangle_light_normal_area(light);
        if (na.w == 0.0) {
            return false;
        }
        let point = sample_triangle_point(tri, u_point);
        let double_sided = (material.flags & MATERIAL_DOUBLE_SIDED) != 0u;
        let sides = select(1.0, 2.0, double_sided);
        let normal = select(na.xyz, -na.xyz, double_sided && u_side < 0.5);
        let radiance = emitted_radiance(material, light.triangle, point.b);
        let local = sample_cosine_hemisphere(u_direction);
        let direction = frame_from_local(frame_from_z(normal), local);
        *y0 = bdpt_endpoint(VERTEX_TRIANGLE_LIGHT, point.p, normal, index, radiance, pmf / na.w);
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
        *y0 = bdpt_endpoint(VERTEX_POINT_LIGHT, light.position, vec3<f32>(0.0), index, intensity, pmf);
        ray = Ray(light.position, direction, F32_MAX);
        beta = intensity / (pmf * pdf);
        pdf_direction = pdf;
    } else if (FEATURE_DIRECTIONAL_LIGHTS && light.kind == LIGHT_DIRECTIONAL) {
        let origin = bdpt_disk_point(-light.direction, u_point);
        *y0 = bdpt_endpoint(VERTEX_DIRECTIONAL_LIGHT, origin, light.direction, index, light.intensity, pmf);
        ray = Ray(origin, light.direction, F32_MAX);
        beta = light.intensity * (disk_area / pmf);
    } else if (FEATURE_ENVIRONMENT && light.kind == LIGHT_ENVIRONMENT) {
        let es = sample_environment(u_direction);
        if (!es.valid) {
            return false;
        }
        let origin = bdpt_disk_point(es.wi, u_point);
        *y0 = bdpt_endpoint(VERTEX_ENVIRONMENT, vec3<f32>(0.0), es.wi, index, es.radiance, pmf * es.pdf_solid_angle);
        ray = Ray(origin, -es.wi, F32_MAX);
        beta = es.radiance * (disk_area / (pmf * es.pdf_solid_angle));
    } else {
        return false;
    }
    if (!is_finite_vec3(beta) || max_element(beta) <= 0.0) {
        return false;
    }
    // Lights at infinity send y₁ the density of the disk's point (`convert_density`).
    let pdf_solid_angle = select(pdf_direction, 1.0 / disk_area, bdpt_at_infinity(*y0));
    *walk_out = bdpt_walk_new(ray, beta, pdf_solid_angle, true);
    return true;
}
