// Twin of src/geometry/ and src/scene/normals.rs: floating-point error bounds, frames, the
// watertight triangle test, the conservative box test, and ray spawning.

const MACHINE_EPSILON: f32 = 0x1p-24f;
const F32_MAX: f32 = 0x1.fffffep+127f;
// Smallest length whose reciprocal is finite (glam's `try_normalize` criterion).
const MIN_NORMALIZABLE_LENGTH: f32 = 0x1p-127f;

fn gamma(n: i32) -> f32 {
    let ne = f32(n) * MACHINE_EPSILON;
    return ne / (1.0 - ne);
}

fn next_float_up(v_in: f32) -> f32 {
    var v = v_in;
    if (v > F32_MAX) {
        return v;
    }
    if (v == 0.0) {
        v = 0.0;
    }
    let bits = bitcast<u32>(v);
    if (v >= 0.0) {
        return bitcast<f32>(bits + 1u);
    }
    return bitcast<f32>(bits - 1u);
}

fn next_float_down(v_in: f32) -> f32 {
    var v = v_in;
    if (v < -F32_MAX) {
        return v;
    }
    if (v == 0.0) {
        v = -0.0;
    }
    let bits = bitcast<u32>(v);
    if (v > 0.0) {
        return bitcast<f32>(bits - 1u);
    }
    return bitcast<f32>(bits + 1u);
}

// a·b − c·d by Kahan's FMA algorithm (pbrt-v4 `DifferenceOfProducts`).
fn difference_of_products(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let cd = c * d;
    let diff = fma(a, b, -cd);
    let error = fma(-c, d, cd);
    return diff + error;
}

// 1 with the sign of x (including −0), as Rust's `1.0f32.copysign(x)`.
fn sign_of(x: f32) -> f32 {
    return bitcast<f32>((bitcast<u32>(x) & 0x80000000u) | 0x3f800000u);
}

// True iff no component is infinite or NaN, decided on the bits (WGSL lets compilers assume
// floating-point values are finite, so `x != x` is not a reliable test).
fn is_finite_f32(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn is_finite_vec3(v: vec3<f32>) -> bool {
    return is_finite_f32(v.x) && is_finite_f32(v.y) && is_finite_f32(v.z);
}

fn max_element(v: vec3<f32>) -> f32 {
    return max(max(v.x, v.y), v.z);
}

// `normalize` that reports degenerate input: w = 0 marks "no direction".
fn try_normalize(v: vec3<f32>) -> vec4<f32> {
    let len = length(v);
    if (!(len >= MIN_NORMALIZABLE_LENGTH) || !is_finite_f32(len)) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(v / len, 1.0);
}

struct Frame {
    x: vec3<f32>,
    y: vec3<f32>,
    z: vec3<f32>,
}

// Duff et al. 2017, "Building an Orthonormal Basis, Revisited", JCGT 6(1), Listing 3.
fn frame_from_z(n: vec3<f32>) -> Frame {
    let sign = sign_of(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let x = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let y = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return Frame(x, y, n);
}

fn frame_to_local(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(v, f.x), dot(v, f.y), dot(v, f.z));
}

fn frame_from_local(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return f.x * v.x + f.y * v.y + f.z * v.z;
}

struct Ray {
    origin: vec3<f32>,
    direction: vec3<f32>,
    t_max: f32,
}

const SHADOW_EPSILON: f32 = 1e-4;

fn round_away(po: f32, o: f32) -> f32 {
    if (o > 0.0) {
        return next_float_up(po);
    }
    if (o < 0.0) {
        return next_float_down(po);
    }
    return po;
}

// pbrt-v4 §6.8.6 `OffsetRayOrigin`.
fn offset_ray_origin(p: vec3<f32>, p_error: vec3<f32>, n_geometric: vec3<f32>, w: vec3<f32>) -> vec3<f32> {
    let d = dot(abs(n_geometric), p_error);
    var offset = n_geometric * d;
    if (dot(w, n_geometric) < 0.0) {
        offset = -offset;
    }
    let po = p + offset;
    return vec3<f32>(round_away(po.x, offset.x), round_away(po.y, offset.y), round_away(po.z, offset.z));
}

fn spawn_ray(p: vec3<f32>, p_error: vec3<f32>, n_geometric: vec3<f32>, w: vec3<f32>) -> Ray {
    return Ray(offset_ray_origin(p, p_error, n_geometric, w), w, F32_MAX);
}

fn spawn_ray_to(p: vec3<f32>, p_error: vec3<f32>, n_geometric: vec3<f32>, target_point: vec3<f32>) -> Ray {
    let origin = offset_ray_origin(p, p_error, n_geometric, target_point - p);
    return Ray(origin, target_point - origin, 1.0 - SHADOW_EPSILON);
}

// Per-ray constants of the box test.
struct RayBoxPrecomp {
    origin: vec3<f32>,
    inv_direction: vec3<f32>,
    parallel: vec3<bool>,
}

const PARALLEL_THRESHOLD: f32 = 1e-30;

fn ray_box_precomp(ray: Ray) -> RayBoxPrecomp {
    let parallel = abs(ray.direction) < vec3<f32>(PARALLEL_THRESHOLD);
    let safe = select(ray.direction, vec3<f32>(1.0), parallel);
    return RayBoxPrecomp(ray.origin, vec3<f32>(1.0) / safe, parallel);
}

// Twin of `entry_within`.
fn entry_within(enter: f32, t_max: f32) -> bool {
    return enter * (1.0 - 4.0 * gamma(3)) <= t_max;
}

// Twin of `box_entry` (Ize 2013 / pbrt-v4 `Bounds3::IntersectP`; src/geometry/bounds.rs
// explains the margins): the entry distance (≥ 0) of an overlap, or −1 for a miss.
fn box_entry(pre: RayBoxPrecomp, t_max: f32, bmin: vec3<f32>, bmax: vec3<f32>) -> f32 {
    let t0 = (bmin - pre.origin) * pre.inv_direction;
    let t1 = (bmax - pre.origin) * pre.inv_direction;
    var t_near = min(t0, t1);
    var t_far = max(t0, t1);
    let inside = pre.origin >= bmin & pre.origin <= bmax;
    t_near = select(t_near, select(vec3<f32>(F32_MAX), vec3<f32>(-F32_MAX), inside), pre.parallel);
    t_far = select(t_far, select(vec3<f32>(-F32_MAX), vec3<f32>(F32_MAX), inside), pre.parallel);
    let enter = max(max(max(t_near.x, t_near.y), t_near.z), 0.0);
    let exit = min(min(t_far.x, t_far.y), t_far.z) * (1.0 + 2.0 * gamma(3));
    return select(-1.0, enter, enter <= exit && entry_within(enter, t_max));
}

struct TriangleHit {
    b: vec3<f32>,
    t: f32,
    valid: bool,
}

fn no_triangle_hit() -> TriangleHit {
    return TriangleHit(vec3<f32>(0.0), 0.0, false);
}

fn max_dimension(v: vec3<f32>) -> u32 {
    if (v.x > v.y) {
        if (v.x > v.z) {
            return 0u;
        }
        return 2u;
    }
    if (v.y > v.z) {
        return 1u;
    }
    return 2u;
}

fn permute(v: vec3<f32>, x: u32, y: u32, z: u32) -> vec3<f32> {
    return vec3<f32>(v[x], v[y], v[z]);
}

// Twin of `RayTrianglePrecomp`: the permutation and shear of the watertight test, once per
// ray.
struct RayTrianglePrecomp {
    origin: vec3<f32>,
    direction: vec3<f32>,
    k: vec3<u32>,
    shear: vec3<f32>,
    valid: bool,
}

fn ray_triangle_precomp(ray: Ray) -> RayTrianglePrecomp {
    let kz = max_dimension(abs(ray.direction));
    let kx = select(kz + 1u, 0u, kz == 2u);
    let ky = select(kx + 1u, 0u, kx == 2u);
    let d = permute(ray.direction, kx, ky, kz);
    return RayTrianglePrecomp(ray.origin, ray.direction, vec3<u32>(kx, ky, kz), vec3<f32>(-d.x / d.z, -d.y / d.z, 1.0 / d.z), d.z != 0.0);
}

// Woop, Benthin & Wald 2013 with pbrt-v4's conservative t test; twin of
// `intersect_triangle_precomp` in src/geometry/triangle.rs.
fn intersect_triangle_precomp(pre: RayTrianglePrecomp, t_max: f32, p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>) -> TriangleHit {
    if (!pre.valid) {
        return no_triangle_hit();
    }
    let k = pre.k;
    var p0t = permute(p0 - pre.origin, k.x, k.y, k.z);
    var p1t = permute(p1 - pre.origin, k.x, k.y, k.z);
    var p2t = permute(p2 - pre.origin, k.x, k.y, k.z);
    let sx = pre.shear.x;
    let sy = pre.shear.y;
    let sz = pre.shear.z;
    p0t.x += sx * p0t.z;
    p0t.y += sy * p0t.z;
    p1t.x += sx * p1t.z;
    p1t.y += sy * p1t.z;
    p2t.x += sx * p2t.z;
    p2t.y += sy * p2t.z;

    let e0 = difference_of_products(p1t.x, p2t.y, p1t.y, p2t.x);
    let e1 = difference_of_products(p2t.x, p0t.y, p2t.y, p0t.x);
    let e2 = difference_of_products(p0t.x, p1t.y, p0t.y, p1t.x);
    if ((e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0)) {
        return no_triangle_hit();
    }
    let det = e0 + e1 + e2;
    if (det == 0.0) {
        return no_triangle_hit();
    }
    // Degenerate triangles: tested where most rays have already missed (see the twin).
    let c = cross(p2 - p0, p1 - p0);
    if (dot(c, c) == 0.0) {
        return no_triangle_hit();
    }

    // The shear's rounding is bounded in units of length, before z is scaled (the CPU twin
    // explains why).
    let max_z_length = max_element(abs(vec3<f32>(p0t.z, p1t.z, p2t.z)));
    p0t.z *= sz;
    p1t.z *= sz;
    p2t.z *= sz;
    let t_scaled = e0 * p0t.z + e1 * p1t.z + e2 * p2t.z;
    if (det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_max * det)) {
        return no_triangle_hit();
    }
    if (det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_max * det)) {
        return no_triangle_hit();
    }
    let inv_det = 1.0 / det;
    let b = vec3<f32>(e0, e1, e2) * inv_det;
    let t = t_scaled * inv_det;

    let max_zt = max_element(abs(vec3<f32>(p0t.z, p1t.z, p2t.z)));
    let delta_z = gamma(3) * max_zt;
    let max_xt = max_element(abs(vec3<f32>(p0t.x, p1t.x, p2t.x)));
    let max_yt = max_element(abs(vec3<f32>(p0t.y, p1t.y, p2t.y)));
    let delta_x = gamma(5) * (max_xt + max_z_length);
    let delta_y = gamma(5) * (max_yt + max_z_length);
    let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = max_element(abs(vec3<f32>(e0, e1, e2)));
    let delta_t = 3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * abs(inv_det);
    if (t <= delta_t && !plane_ahead(pre.origin, pre.direction, p0, p1, p2)) {
        return no_triangle_hit();
    }
    return TriangleHit(b, t, true);
}

// Twin of `plane_ahead`: is the triangle's plane provably crossed ahead of the origin? Decides
// hits that δt's extent-wide bound cannot (a bounce near a room's corner).
fn plane_ahead(origin: vec3<f32>, direction: vec3<f32>, p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>) -> bool {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let a = origin - p0;
    let n = cross(e1, e2);
    let n_abs = abs(e1.yzx * e2.zxy) + abs(e1.zxy * e2.yzx);
    let s = dot(n, a);
    let nd = dot(n, direction);
    let bound = gamma(9);
    return abs(s) > bound * dot(n_abs, abs(a)) && abs(nd) > bound * dot(n_abs, abs(direction))
        && (s < 0.0) != (nd < 0.0);
}

// pbrt-v4 eq. 6.29.
fn triangle_error_bound(b: vec3<f32>, p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>) -> vec3<f32> {
    return (abs(b.x * p0) + abs(b.y * p1) + abs(b.z * p2)) * gamma(7);
}

// Octahedral decoding (Cigolle et al. 2014); twin of src/scene/normals.rs `oct_decode`.
fn oct_decode(packed: u32) -> vec3<f32> {
    let p = unpack2x16snorm(packed);
    var n = vec3<f32>(p.x, p.y, 1.0 - abs(p.x) - abs(p.y));
    let t = max(-n.z, 0.0);
    n.x += select(t, -t, n.x >= 0.0);
    n.y += select(t, -t, n.y >= 0.0);
    return normalize(n);
}
