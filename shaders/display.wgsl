// ---- shaders/display.wgsl
// The viewer's display pass (src/viewer/display.rs): a full-screen triangle whose fragments
// read the film in place (on the GPU backend the accumulation buffer itself, no readback)
// and tone-map it. Composed after layout.wgsl, whose FilmPixel and DisplayParams it reads.

@group(0) @binding(0) var<storage, read> film: array<FilmPixel>;
@group(0) @binding(1) var<storage, read> display: DisplayParams;

@vertex
fn display_vertex(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // (−1, −1), (3, −1), (−1, 3): one triangle covering the target.
    let x = f32((i << 1u) & 2u) * 2.0 - 1.0;
    let y = f32(i & 2u) * 2.0 - 1.0;
    return vec4<f32>(x, y, 0.0, 1.0);
}

// The sRGB transfer function (twin of film::linear_to_srgb).
fn display_srgb(v: f32) -> f32 {
    let c = clamp(v, 0.0, 1.0);
    if (c <= 0.0031308) {
        return 12.92 * c;
    }
    return 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

// Relative standard error 10^-3 … 1 as blue → cyan → green → yellow → red.
fn error_colour(relative: f32) -> vec3<f32> {
    let t = clamp((log2(max(relative, 1e-6)) / log2(10.0) + 3.0) / 3.0, 0.0, 1.0);
    let r = clamp(2.0 * t - 0.5, 0.0, 1.0);
    let g = clamp(2.0 - abs(4.0 * t - 2.0), 0.0, 1.0);
    let b = clamp(1.5 - 2.5 * t, 0.0, 1.0);
    return vec3<f32>(r, g, b);
}

@fragment
fn display_fragment(@builtin(position) position: vec4<f32>) -> @location(0) vec4<f32> {
    let fx = u32(position.x * f32(display.film_width) / f32(display.target_width));
    let fy = u32(position.y * f32(display.film_height) / f32(display.target_height));
    let p = film[min(fy, display.film_height - 1u) * display.film_width + min(fx, display.film_width - 1u)];
    var c: vec3<f32>;
    if (display.tonemap == DISPLAY_RELATIVE_ERROR) {
        // Standard error of the mean over the mean, both Rec. 709 luminance-weighted (the
        // weighted sum of the channel variances: an estimate that ignores their covariance).
        let n = f32(p.count);
        let variance = select(0.0, dot(p.m2, vec3<f32>(0.2126, 0.7152, 0.0722)) / (n * (n - 1.0)), p.count > 1u);
        let mean = dot(p.mean, vec3<f32>(0.2126, 0.7152, 0.0722));
        c = select(vec3<f32>(0.0), error_colour(sqrt(variance) / max(mean, 1e-4)), p.count > 1u);
    } else {
        let x = p.mean * display.exposure_scale;
        if (display.tonemap == DISPLAY_ACES) {
            c = clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), vec3<f32>(0.0), vec3<f32>(1.0));
        } else {
            c = clamp(x, vec3<f32>(0.0), vec3<f32>(1.0));
        }
    }
    if (display.encode_srgb == 1u) {
        c = vec3<f32>(display_srgb(c.x), display_srgb(c.y), display_srgb(c.z));
    }
    return vec4<f32>(c, 1.0);
}
