// Twin of src/bsdf/'s lobes (fresnel.rs, microfacet.rs, lambert.rs, reflection.rs,
// transmission.rs, thin_transmission.rs, sheen.rs), which bsdf_gltf.wgsl layers into the glTF
// 2.0 BSDF. The comments in the Rust files define the models; this file mirrors them function
// by function. Optional results use vec4 with w = 1 for "valid".

const MIN_ALPHA: f32 = 1e-4;
const LOBE_SELECTION_FLOOR: f32 = 0.05;

fn reflect_about(w: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return -w + 2.0 * dot(w, n) * n;
}

// pbrt-v4 `Refract`; w = 0 on total internal reflection.
fn refract_through(wi: vec3<f32>, n: vec3<f32>, eta: f32) -> vec4<f32> {
    let cos_i = dot(wi, n);
    let sin2_i = max(1.0 - cos_i * cos_i, 0.0);
    let sin2_t = sin2_i / (eta * eta);
    if (sin2_t >= 1.0) {
        return vec4<f32>(0.0);
    }
    let cos_t = sqrt(1.0 - sin2_t);
    return vec4<f32>(-wi / eta + (cos_i / eta - cos_t) * n, 1.0);
}

// ---- fresnel.rs

fn fresnel_schlick(f0: vec3<f32>, f90: f32, cos_theta: f32) -> vec3<f32> {
    let m = pow(1.0 - clamp(cos_theta, 0.0, 1.0), 5.0);
    return f0 + (vec3<f32>(f90) - f0) * m;
}

fn fresnel_dielectric(cos_theta_i: f32, eta_in: f32) -> f32 {
    var cos_i = clamp(cos_theta_i, -1.0, 1.0);
    var eta = eta_in;
    if (cos_i < 0.0) {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_i = 1.0 - cos_i * cos_i;
    let sin2_t = sin2_i / (eta * eta);
    if (sin2_t >= 1.0) {
        return 1.0;
    }
    let cos_t = sqrt(max(1.0 - sin2_t, 0.0));
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return (r_parl * r_parl + r_perp * r_perp) / 2.0;
}

// ---- microfacet.rs

fn ggx_d(m: vec3<f32>, alpha: f32) -> f32 {
    if (m.z <= 0.0) {
        return 0.0;
    }
    let a2 = alpha * alpha;
    // sin²θ + α²cos²θ without cancellation (see the CPU twin).
    let d = m.x * m.x + m.y * m.y + a2 * (m.z * m.z);
    if (d <= 0.0) {
        return 0.0;
    }
    return a2 / (PI * d * d);
}

fn smith_root(cos_theta: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let c2 = cos_theta * cos_theta;
    return sqrt(max(a2 + (1.0 - a2) * c2, 0.0));
}

fn ggx_g1(w: vec3<f32>, alpha: f32) -> f32 {
    let c = abs(w.z);
    let denom = c + smith_root(c, alpha);
    if (denom <= 0.0) {
        return 0.0;
    }
    return 2.0 * c / denom;
}

fn ggx_g2(wo: vec3<f32>, wi: vec3<f32>, alpha: f32) -> f32 {
    let co = abs(wo.z);
    let ci = abs(wi.z);
    let denom = ci * smith_root(co, alpha) + co * smith_root(ci, alpha);
    if (denom <= 0.0) {
        return 0.0;
    }
    return 2.0 * co * ci / denom;
}

fn visible_normal_pdf(wo: vec3<f32>, m: vec3<f32>, alpha: f32) -> f32 {
    let cos_o = abs(wo.z);
    if (cos_o == 0.0) {
        return 0.0;
    }
    return ggx_g1(wo, alpha) * max(dot(wo, m), 0.0) * ggx_d(m, alpha) / cos_o;
}

// Dupuy & Benyoub 2023, spherical caps.
fn sample_visible_normal(wo: vec3<f32>, alpha: f32, u: vec2<f32>) -> vec3<f32> {
    let wi_std = normalize(vec3<f32>(wo.x * alpha, wo.y * alpha, wo.z));
    let phi = 2.0 * PI * u.x;
    let z = fma(1.0 - u.y, 1.0 + wi_std.z, -wi_std.z);
    let sin_theta = sqrt(clamp(1.0 - z * z, 0.0, 1.0));
    let c = vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), z);
    let h = c + wi_std;
    return normalize(vec3<f32>(h.x * alpha, h.y * alpha, max(h.z, 0.0)));
}

// ---- lambert.rs

fn lambert_sample(u: vec2<f32>) -> vec3<f32> {
    return sample_cosine_hemisphere(u);
}

fn lambert_eval(wi: vec3<f32>) -> f32 {
    return select(0.0, INV_PI, wi.z > 0.0);
}

fn lambert_pdf(wi: vec3<f32>) -> f32 {
    return cosine_hemisphere_pdf(wi.z);
}

// ---- reflection.rs

fn reflection_sample(wo: vec3<f32>, alpha: f32, u: vec2<f32>) -> vec4<f32> {
    let m = sample_visible_normal(wo, alpha, u);
    let wi = reflect_about(wo, m);
    return vec4<f32>(wi, select(0.0, 1.0, wi.z > 0.0));
}

fn reflection_half_vector(wo: vec3<f32>, wi: vec3<f32>) -> vec4<f32> {
    if (wo.z <= 0.0 || wi.z <= 0.0) {
        return vec4<f32>(0.0);
    }
    return try_normalize(wo + wi);
}

fn reflection_eval(wo: vec3<f32>, wi: vec3<f32>, alpha: f32) -> f32 {
    let m = reflection_half_vector(wo, wi);
    if (m.w == 0.0) {
        return 0.0;
    }
    return ggx_d(m.xyz, alpha) * ggx_g2(wo, wi, alpha) / (4.0 * wo.z * wi.z);
}

fn reflection_pdf(wo: vec3<f32>, wi: vec3<f32>, alpha: f32) -> f32 {
    let m = reflection_half_vector(wo, wi);
    if (m.w == 0.0) {
        return 0.0;
    }
    let wo_m = abs(dot(wo, m.xyz));
    if (wo_m == 0.0) {
        return 0.0;
    }
    return visible_normal_pdf(wo, m.xyz, alpha) / (4.0 * wo_m);
}

// ---- transmission.rs

fn transmission_sample(wo: vec3<f32>, alpha: f32, eta: f32, u: vec2<f32>) -> vec4<f32> {
    let m = sample_visible_normal(wo, alpha, u);
    let wi = refract_through(wo, m, eta);
    if (wi.w == 0.0 || wi.z >= 0.0) {
        return vec4<f32>(0.0);
    }
    return wi;
}

fn transmission_half_vector(wo: vec3<f32>, wi: vec3<f32>, eta: f32) -> vec4<f32> {
    if (wo.z <= 0.0 || wi.z >= 0.0) {
        return vec4<f32>(0.0);
    }
    var m = try_normalize(wi * eta + wo);
    if (m.w == 0.0) {
        return m;
    }
    if (m.z < 0.0) {
        m = vec4<f32>(-m.xyz, 1.0);
    }
    if (dot(wo, m.xyz) <= 0.0 || dot(wi, m.xyz) >= 0.0) {
        return vec4<f32>(0.0);
    }
    return m;
}

fn transmission_eval(wo: vec3<f32>, wi: vec3<f32>, alpha: f32, eta: f32) -> f32 {
    let m = transmission_half_vector(wo, wi, eta);
    if (m.w == 0.0) {
        return 0.0;
    }
    let wi_m = dot(wi, m.xyz);
    let wo_m = dot(wo, m.xyz);
    let s = wi_m + wo_m / eta;
    let denom = s * s * abs(wi.z) * wo.z;
    if (denom == 0.0) {
        return 0.0;
    }
    return ggx_d(m.xyz, alpha) * ggx_g2(wo, wi, alpha) * abs(wi_m * wo_m) / denom / (eta * eta);
}

fn transmission_pdf(wo: vec3<f32>, wi: vec3<f32>, alpha: f32, eta: f32) -> f32 {
    let m = transmission_half_vector(wo, wi, eta);
    if (m.w == 0.0) {
        return 0.0;
    }
    let wi_m = dot(wi, m.xyz);
    let s = wi_m + dot(wo, m.xyz) / eta;
    let denom = s * s;
    if (denom == 0.0) {
        return 0.0;
    }
    return visible_normal_pdf(wo, m.xyz, alpha) * abs(wi_m) / denom;
}

// ---- thin_transmission.rs

fn mirror_z(w: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(w.x, w.y, -w.z);
}

fn thin_transmission_sample(wo: vec3<f32>, alpha: f32, u: vec2<f32>) -> vec4<f32> {
    let r = reflection_sample(wo, alpha, u);
    return vec4<f32>(mirror_z(r.xyz), r.w);
}

fn thin_transmission_half_vector(wo: vec3<f32>, wi: vec3<f32>) -> vec4<f32> {
    if (wi.z >= 0.0) {
        return vec4<f32>(0.0);
    }
    return reflection_half_vector(wo, mirror_z(wi));
}

fn thin_transmission_eval(wo: vec3<f32>, wi: vec3<f32>, alpha: f32) -> f32 {
    if (wi.z >= 0.0) {
        return 0.0;
    }
    return reflection_eval(wo, mirror_z(wi), alpha);
}

fn thin_transmission_pdf(wo: vec3<f32>, wi: vec3<f32>, alpha: f32) -> f32 {
    if (wi.z >= 0.0) {
        return 0.0;
    }
    return reflection_pdf(wo, mirror_z(wi), alpha);
}

// ---- sheen.rs

const MIN_SHEEN_ROUGHNESS: f32 = 0.07;
const SHEEN_ALBEDO_SIZE: u32 = 32u;

fn sheen_alpha(roughness: f32) -> f32 {
    let r = clamp(roughness, MIN_SHEEN_ROUGHNESS, 1.0);
    return r * r;
}

fn charlie_d(cos_theta_h: f32, alpha: f32) -> f32 {
    let inv_alpha = 1.0 / alpha;
    let sin2 = max(1.0 - cos_theta_h * cos_theta_h, 0.0);
    return (2.0 + inv_alpha) * pow(sin2, 0.5 * inv_alpha) * (0.5 * INV_PI);
}

fn ashikhmin_v(cos_o: f32, cos_i: f32) -> f32 {
    let s = cos_i + cos_o - cos_i * cos_o;
    return select(0.0, 0.25 / s, s > 0.0);
}

fn sheen_eval(wo: vec3<f32>, wi: vec3<f32>, alpha: f32) -> f32 {
    if (wo.z <= 0.0 || wi.z <= 0.0) {
        return 0.0;
    }
    let h = try_normalize(wo + wi);
    if (h.w == 0.0) {
        return 0.0;
    }
    return charlie_d(h.z, alpha) * ashikhmin_v(wo.z, wi.z);
}

fn sheen_albedo(mu: f32, roughness: f32) -> f32 {
    let last = f32(SHEEN_ALBEDO_SIZE - 1u);
    let x = clamp(mu, 0.0, 1.0) * last;
    let y = clamp(roughness, 0.0, 1.0) * last;
    let x0f = min(floor(x), last - 1.0);
    let y0f = min(floor(y), last - 1.0);
    let tx = x - x0f;
    let ty = y - y0f;
    let x0 = u32(x0f);
    let y0 = u32(y0f);
    let row0 = y0 * SHEEN_ALBEDO_SIZE;
    let row1 = row0 + SHEEN_ALBEDO_SIZE;
    let top = sheen_albedo_table[row0 + x0] * (1.0 - tx) + sheen_albedo_table[row0 + x0 + 1u] * tx;
    let bottom = sheen_albedo_table[row1 + x0] * (1.0 - tx) + sheen_albedo_table[row1 + x0 + 1u] * tx;
    return top * (1.0 - ty) + bottom * ty;
}

fn sheen_albedo_scaling(sheen_color: vec3<f32>, roughness: f32, mu_o: f32, mu_i: f32) -> f32 {
    let c = max_element(sheen_color);
    let e = max(sheen_albedo(mu_o, roughness), sheen_albedo(mu_i, roughness));
    return clamp(1.0 - c * e, 0.0, 1.0);
}
