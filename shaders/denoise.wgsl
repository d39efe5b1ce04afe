// One iteration of the built-in denoiser's edge-avoiding à-trous filter, per pixel. CPU twin:
// src/denoise/atrous.rs (`atrous_pixel`, `edge_stopping`), which cites the papers and says
// what each weight does; the host prepares the demodulated signal and the guides for both.
// A shader of its own, not part of the megakernel: it reads images, not the scene.

struct DenoiseParams {
    width: u32,
    height: u32,
    // Pixels between taps: 2^iteration.
    step: i32,
    _pad: u32,
}

// Storage, not uniform: lavapipe compiles a variant of a shader for each value of a uniform
// that steers its branches (shaders/bindings.wgsl), and `step` changes every iteration.
@group(0) @binding(0) var<storage, read> params: DenoiseParams;
// Demodulated colour (xyz) and its luminance variance (w).
@group(0) @binding(1) var<storage, read> signal_in: array<vec4<f32>>;
// Unit normal (xyz; zero on a miss) and depth (w; MISS_DEPTH on a miss).
@group(0) @binding(2) var<storage, read> guide: array<vec4<f32>>;
// Emission luminance (x), coverage (y), depth gradient (z), and 1 in w where the pixel is
// kept as it is (a miss with negligible noise: `Prepared::aux` in src/denoise/atrous.rs).
@group(0) @binding(3) var<storage, read> aux: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> signal_out: array<vec4<f32>>;

const SIGMA_LUMINANCE: f32 = 4.0;
const SIGMA_NORMAL_SQUARINGS: u32 = 7u;
const WEIGHT_EXPONENT_CUTOFF: f32 = 40.0;
const SIGMA_DEPTH: f32 = 1.0;
const SIGMA_EMISSION: f32 = 0.1;
const SIGMA_COVERAGE: f32 = 1.0 / 16.0;

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

fn kernel_weight(d: i32) -> f32 {
    let k = array<f32, 3>(3.0 / 8.0, 1.0 / 4.0, 1.0 / 16.0);
    return k[abs(d)];
}

fn gaussian_weight(d: i32) -> f32 {
    return select(1.0 / 8.0, 1.0 / 4.0, d == 0);
}

// The reciprocals a pixel's taps divide by (CPU twin: `CentreWeights`).
struct CentreWeights {
    inv_sigma: f32,
    // At a Manhattan offset of 1, 2, 3 and 4 taps.
    inv_depth_width: vec4<f32>,
}

fn edge_stopping(g_p: vec4<f32>, a_p: vec4<f32>, g_q: vec4<f32>, a_q: vec4<f32>, offset: i32, l_p: f32, s_q: vec4<f32>, centre: CentreWeights) -> f32 {
    let p_hit = g_p.w >= 0.0;
    let q_hit = g_q.w >= 0.0;
    if (p_hit != q_hit) {
        return 0.0;
    }
    var normal = 1.0;
    var exponent = 0.0;
    if (p_hit) {
        normal = max(dot(g_p.xyz, g_q.xyz), 0.0);
        for (var i = 0u; i < SIGMA_NORMAL_SQUARINGS; i++) {
            normal *= normal;
        }
        exponent += abs(g_p.w - g_q.w) * centre.inv_depth_width[offset - 1];
    }
    if (a_p.x != a_q.x) {
        exponent += abs(a_p.x - a_q.x) / (SIGMA_EMISSION * max(a_p.x, a_q.x) + 1e-12);
    }
    let l_q = luminance(s_q.xyz);
    exponent += abs(l_p - l_q) * centre.inv_sigma + abs(a_p.y - a_q.y) * (1.0 / SIGMA_COVERAGE);
    if (normal == 0.0 || exponent > WEIGHT_EXPONENT_CUTOFF) {
        return 0.0;
    }
    return normal * exp(-exponent);
}

@compute @workgroup_size(8, 8, 1)
fn atrous_iteration(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = i32(params.width);
    let h = i32(params.height);
    let x = i32(gid.x);
    let y = i32(gid.y);
    if (x >= w || y >= h) {
        return;
    }
    let step = params.step;
    let centre = u32(y * w + x);
    let s_p = signal_in[centre];
    let g_p = guide[centre];
    let a_p = aux[centre];
    if (a_p.w != 0.0) {
        signal_out[centre] = s_p;
        return;
    }
    // Taps of the other kind (surface or miss) left out, as the CPU twin says why.
    let p_hit = g_p.w >= 0.0;
    var var_sum = 0.0;
    var var_weight = 0.0;
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            let qx = x + dx;
            let qy = y + dy;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h) {
                continue;
            }
            let q = u32(qy * w + qx);
            if ((guide[q].w >= 0.0) != p_hit) {
                continue;
            }
            let k = gaussian_weight(dx) * gaussian_weight(dy) * 4.0;
            var_sum += k * signal_in[q].w;
            var_weight += k;
        }
    }
    let sigma = SIGMA_LUMINANCE * sqrt(max(var_sum / var_weight, 0.0));
    let l_p = luminance(s_p.xyz);
    // As the CPU's `CentreWeights`: the offset in pixels first, then the width.
    let depth_width = SIGMA_DEPTH * a_p.z * (vec4<f32>(1.0, 2.0, 3.0, 4.0) * f32(step)) + 1e-6 * g_p.w + 1e-12;
    let centre_weights = CentreWeights(1.0 / (sigma + 1e-10), 1.0 / depth_width);
    var sum = vec3<f32>(0.0);
    var variance = 0.0;
    var weight_sum = 0.0;
    for (var dy = -2; dy <= 2; dy++) {
        for (var dx = -2; dx <= 2; dx++) {
            let qx = x + dx * step;
            let qy = y + dy * step;
            if (qx < 0 || qy < 0 || qx >= w || qy >= h) {
                continue;
            }
            let q = u32(qy * w + qx);
            let s_q = signal_in[q];
            let h_q = kernel_weight(dx) * kernel_weight(dy);
            var weight = h_q;
            if (q != centre) {
                weight = h_q * edge_stopping(g_p, a_p, guide[q], aux[q], abs(dx) + abs(dy), l_p, s_q, centre_weights);
            }
            sum += weight * s_q.xyz;
            variance += weight * weight * s_q.w;
            weight_sum += weight;
        }
    }
    signal_out[centre] = vec4<f32>(sum / weight_sum, variance / (weight_sum * weight_sum));
}
