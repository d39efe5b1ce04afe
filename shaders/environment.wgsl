// Twin of src/light/environment.rs: the equirectangular environment light, its lookup and
// its importance sampling (same conventions; see that file).

// Smallest normal f32 (Rust's f32::MIN_POSITIVE): a floor for CDF widths.
const F32_MIN_POSITIVE: f32 = 1.17549435e-38;

// The map's frame from the world's: R_y(−rotation).
fn world_to_map(d: vec3<f32>) -> vec3<f32> {
    let c = environment.rotation_cos;
    let s = environment.rotation_sin;
    return vec3<f32>(c * d.x - s * d.z, d.y, s * d.x + c * d.z);
}

// The world's frame from the map's: R_y(rotation).
fn map_to_world(d: vec3<f32>) -> vec3<f32> {
    let c = environment.rotation_cos;
    let s = environment.rotation_sin;
    return vec3<f32>(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
}

// atan2 by Abramowitz & Stegun 4.4.49, the same multiply-adds as the CPU twin (WGSL's own
// atan2 and acos may be thousands of ulps off, which would pick other texels).
fn atan2_polynomial(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    let hi = max(ax, ay);
    if (hi == 0.0) {
        return 0.0;
    }
    let a = min(ax, ay) / hi;
    let s = a * a;
    var r = ((((0.0208351 * s - 0.085133) * s + 0.180141) * s - 0.3302995) * s + 0.999866) * a;
    if (ay > ax) {
        r = 0.5 * PI - r;
    }
    if (x < 0.0) {
        r = PI - r;
    }
    if (y < 0.0) {
        return -r;
    }
    return r;
}

fn environment_uv(d: vec3<f32>) -> vec2<f32> {
    var u = atan2_polynomial(d.x, -d.z) * (0.5 * INV_PI);
    if (u < 0.0) {
        u += 1.0;
    }
    if (u >= 1.0) {
        u = 0.0;
    }
    let sin_theta = sqrt(d.x * d.x + d.z * d.z);
    return vec2<f32>(u, atan2_polynomial(sin_theta, d.y) * INV_PI);
}

// The unit direction (map frame) of (u, v).
fn environment_direction(uv: vec2<f32>) -> vec3<f32> {
    let phi = 2.0 * PI * uv.x;
    let theta = PI * uv.y;
    let sin_theta = sin(theta);
    return vec3<f32>(sin_theta * sin(phi), cos(theta), -sin_theta * cos(phi));
}

fn texel_index(uv: vec2<f32>) -> u32 {
    let i = min(u32(uv.x * f32(environment.width)), environment.width - 1u);
    let j = min(u32(uv.y * f32(environment.height)), environment.height - 1u);
    return j * environment.width + i;
}

struct EnvironmentLookup {
    radiance: vec3<f32>,
    pdf_solid_angle: f32,
}

fn environment_lookup(d: vec3<f32>) -> EnvironmentLookup {
    let local = world_to_map(d);
    let uv = environment_uv(local);
    let t = environment_texels[texel_index(uv)];
    let sin_theta = sqrt(local.x * local.x + local.z * local.z);
    var pdf = 0.0;
    if (sin_theta > 0.0) {
        pdf = t.w / (2.0 * PI * PI * sin_theta);
    }
    return EnvironmentLookup(t.xyz, pdf);
}

fn find_interval(offset: u32, n: u32, u: f32) -> u32 {
    var lo = 0u;
    var hi = n;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (environment_cdf[offset + mid] <= u) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

struct EnvironmentSample {
    wi: vec3<f32>,
    radiance: vec3<f32>,
    pdf_solid_angle: f32,
    valid: bool,
}

fn sample_environment(u: vec2<f32>) -> EnvironmentSample {
    let w = environment.width;
    let h = environment.height;
    let j = find_interval(0u, h, u.y);
    let dv = (u.y - environment_cdf[j]) / max(environment_cdf[j + 1u] - environment_cdf[j], F32_MIN_POSITIVE);
    let row = h + 1u + j * (w + 1u);
    let i = find_interval(row, w, u.x);
    let du = (u.x - environment_cdf[row + i]) / max(environment_cdf[row + i + 1u] - environment_cdf[row + i], F32_MIN_POSITIVE);
    let uv = vec2<f32>((f32(i) + clamp(du, 0.0, 1.0)) / f32(w), (f32(j) + clamp(dv, 0.0, 1.0)) / f32(h));
    let local = environment_direction(uv);
    let t = environment_texels[j * w + i];
    let sin_theta = sqrt(local.x * local.x + local.z * local.z);
    if (sin_theta <= 0.0 || t.w <= 0.0) {
        return EnvironmentSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false);
    }
    let pdf = t.w / (2.0 * PI * PI * sin_theta);
    return EnvironmentSample(map_to_world(local), t.xyz, pdf, true);
}
