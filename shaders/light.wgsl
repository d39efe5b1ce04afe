// Twin of src/light/mod.rs: next-event estimation's light sampling.

struct LightSample {
    wi: vec3<f32>,
    radiance: vec3<f32>,
    pdf: f32,
    is_delta: bool,
    shadow_ray: Ray,
    valid: bool,
    // The sampled point (triangle and point lights; zero for lights at infinity) and the
    // light's index: bidirectional path tracing weighs the sample as a light vertex.
    position: vec3<f32>,
    light_index: u32,
}

fn no_light_sample() -> LightSample {
    return LightSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false, Ray(vec3<f32>(0.0), vec3<f32>(0.0), 0.0), false, vec3<f32>(0.0), INVALID_INDEX);
}

fn choose_light(u: vec2<f32>) -> u32 {
    let n = frame.light_count;
    let i = min(u32(u.x * f32(n)), n - 1u);
    if (u.y < lights[i].alias_probability) {
        return i;
    }
    return lights[i].alias_index;
}

// The largest f32 below 1 (CPU twin: ONE_MINUS_EPSILON in src/light/mod.rs).
const ONE_MINUS_EPSILON: f32 = 0.99999994;

// Twin of `choose_light_reusing`: the light chosen by the single uniform `u` (the alias
// table's column ⌊u·n⌋, its coin the fraction left), with `u` rescaled to a uniform of its
// own in [0, 1) for the point on the light.
struct LightChoice {
    index: u32,
    u: f32,
}

fn choose_light_reusing(u: f32) -> LightChoice {
    let n = frame.light_count;
    let x = u * f32(n);
    let column = min(u32(x), n - 1u);
    let coin = clamp(x - f32(column), 0.0, ONE_MINUS_EPSILON);
    let p = lights[column].alias_probability;
    // coin < p implies p > 0, and coin ≥ p that p < 1: neither division is by zero.
    if (coin < p) {
        return LightChoice(column, min(coin / p, ONE_MINUS_EPSILON));
    }
    return LightChoice(lights[column].alias_index, min((coin - p) / (1.0 - p), ONE_MINUS_EPSILON));
}

// An emissive-triangle light's unit normal (xyz) and area (w), stored when the scene was
// flattened (CPU twin: triangle_light_normal_area in src/light/mod.rs).
fn triangle_light_normal_area(light: Light) -> vec4<f32> {
    return vec4<f32>(light.direction, light.intensity.x);
}

// A uniformly distributed point on a triangle (density 1 / area): barycentrics, point and
// the point's error bound (CPU twin: sample_triangle_point in src/light/mod.rs).
struct TrianglePoint {
    b: vec3<f32>,
    p: vec3<f32>,
    p_error: vec3<f32>,
}

fn sample_triangle_point(tri: Triangle, u: vec2<f32>) -> TrianglePoint {
    let b = sample_uniform_triangle(u);
    let q = b.x * tri.p0 + b.y * tri.p1 + b.z * tri.p2;
    let q_error = gamma(6) * (abs(b.x * tri.p0) + abs(b.y * tri.p1) + abs(b.z * tri.p2));
    return TrianglePoint(b, q, q_error);
}

fn spot_falloff(light: Light, cos_theta: f32) -> f32 {
    let t = clamp((cos_theta - light.cos_outer) * light.spot_scale, 0.0, 1.0);
    return t * t;
}

// `u_point_in.x` also chooses the light (`choose_light_reusing`).
fn sample_light(p: vec3<f32>, p_error: vec3<f32>, n_geometric: vec3<f32>, u_point_in: vec2<f32>) -> LightSample {
    if (frame.light_count == 0u) {
        return no_light_sample();
    }
    let choice = choose_light_reusing(u_point_in.x);
    let u_point = vec2<f32>(choice.u, u_point_in.y);
    let light = lights[choice.index];
    let pmf = light.pmf;
    if (pmf <= 0.0) {
        return no_light_sample();
    }
    if (FEATURE_EMISSIVE_TRIANGLES && light.kind == LIGHT_TRIANGLE) {
        let tri = triangles[light.triangle];
        let material = materials[tri.material];
        let point = sample_triangle_point(tri, u_point);
        let na = triangle_light_normal_area(light);
        let to_light = point.p - p;
        let dist2 = dot(to_light, to_light);
        if (dist2 == 0.0 || na.w == 0.0) {
            return no_light_sample();
        }
        let wi = to_light / sqrt(dist2);
        let cos_light = -dot(wi, na.xyz);
        let double_sided = (material.flags & MATERIAL_DOUBLE_SIDED) != 0u;
        if (cos_light == 0.0 || (!double_sided && cos_light < 0.0)) {
            return no_light_sample();
        }
        let pdf = pmf * dist2 / (na.w * abs(cos_light));
        let q_off = offset_ray_origin(point.p, point.p_error, na.xyz, -wi);
        return LightSample(wi, emitted_radiance(material, light.triangle, point.b), pdf, false, spawn_ray_to(p, p_error, n_geometric, q_off), true, point.p, choice.index);
    }
    if (FEATURE_POINT_LIGHTS && (light.kind == LIGHT_POINT || light.kind == LIGHT_SPOT)) {
        let to_light = light.position - p;
        let dist2 = dot(to_light, to_light);
        if (dist2 == 0.0) {
            return no_light_sample();
        }
        let wi = to_light / sqrt(dist2);
        var radiance = light.intensity / dist2;
        if (FEATURE_SPOT_LIGHTS && light.kind == LIGHT_SPOT) {
            radiance *= spot_falloff(light, -dot(wi, light.direction));
        }
        return LightSample(wi, radiance, pmf, true, spawn_ray_to(p, p_error, n_geometric, light.position), true, light.position, choice.index);
    }
    if (FEATURE_ENVIRONMENT && light.kind == LIGHT_ENVIRONMENT) {
        let es = sample_environment(u_point);
        if (!es.valid) {
            return no_light_sample();
        }
        return LightSample(es.wi, es.radiance, pmf * es.pdf_solid_angle, false, spawn_ray(p, p_error, n_geometric, es.wi), true, vec3<f32>(0.0), choice.index);
    }
    if (FEATURE_DIRECTIONAL_LIGHTS && light.kind == LIGHT_DIRECTIONAL) {
        let wi = -light.direction;
        return LightSample(wi, light.intensity, pmf, true, spawn_ray(p, p_error, n_geometric, wi), true, vec3<f32>(0.0), choice.index);
    }
    return no_light_sample();
}

fn triangle_light_pdf(light: Light, origin: vec3<f32>, hit_point: vec3<f32>) -> f32 {
    let na = triangle_light_normal_area(light);
    let d = hit_point - origin;
    let dist2 = dot(d, d);
    if (dist2 == 0.0 || na.w == 0.0) {
        return 0.0;
    }
    let cos_light = abs(dot(d / sqrt(dist2), na.xyz));
    if (cos_light == 0.0) {
        return 0.0;
    }
    return light.pmf * dist2 / (na.w * cos_light);
}
