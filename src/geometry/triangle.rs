//! The watertight ray–triangle test (Woop, Benthin & Wald 2013, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1)), with pbrt-v4's conservative `t > 0` test (§6.8.7).

use glam::{Mat3A, Vec3, Vec3A, Vec3Swizzles};

use super::float::{difference_of_products, gamma};
use super::ray::Ray;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Barycentric weights of p0, p1, p2.
    pub b0: f32,
    pub b1: f32,
    pub b2: f32,
    pub t: f32,
}

fn max_dimension(v: Vec3) -> usize {
    if v.x > v.y {
        if v.x > v.z {
            0
        } else {
            2
        }
    } else if v.y > v.z {
        1
    } else {
        2
    }
}

/// What the watertight test needs of a ray, computed once per ray rather than once per
/// triangle: the axis permutation that makes the direction's largest component z, and the
/// shear that maps the direction to +z (Woop et al. 2013 §3; the three divisions dominated
/// the per-triangle cost before).
///
/// The permutation and the x and y shears are one matrix, `permute_and_shear`, so that a
/// vertex goes to ray space in three vector multiplies and two adds instead of nine lane
/// picks by runtime index. Each row has the coefficient 1 at the permuted axis, the shear at the dominant
/// axis (rows x and y) and exact zeros elsewhere, and glam multiplies and adds without
/// fusing: a zero coefficient adds an exact ±0, so every coordinate is the rounded
/// `x + s·z` of the permute-then-shear form (Woop et al.'s equations), bit for bit, up to
/// the sign of a zero, which no test below reads. The WGSL twin keeps that form: on lavapipe
/// the matrix was no faster (0.34 against 0.35 Msamples/s on the Cornell box), and no
/// hardware GPU was at hand to measure.
#[derive(Clone, Copy, Debug)]
pub struct RayTrianglePrecomp {
    origin: Vec3A,
    direction: Vec3,
    /// Rows: ray-space x = d[kx] + sx·d[kz], y = d[ky] + sy·d[kz], z = d[kz] (unscaled), for
    /// d = p − origin. (The WGSL twin keeps the axis indices and `shear` = (sx, sy, sz).)
    permute_and_shear: Mat3A,
    /// 1 / d[kz]: scales ray-space z to the ray parameter.
    sz: f32,
    /// A zero direction (a shadow ray to its own origin) hits nothing.
    valid: bool,
}

impl RayTrianglePrecomp {
    pub fn new(ray: &Ray) -> RayTrianglePrecomp {
        // kz: the direction's largest axis; kx, ky the next two cyclically. Column k of
        // `permute_and_shear` is what d[k] contributes to ray space x, y, z: (1, 0, 0) for kx,
        // (0, 1, 0) for ky and (sx, sy, 1) for kz.
        let d = ray.direction;
        let (dx, dy, dz, kz) = match max_dimension(d.abs()) {
            0 => (d.y, d.z, d.x, 0),
            1 => (d.z, d.x, d.y, 1),
            _ => (d.x, d.y, d.z, 2),
        };
        let (x, y, z) = (Vec3A::X, Vec3A::Y, Vec3A::new(-dx / dz, -dy / dz, 1.0));
        let permute_and_shear = match kz {
            0 => Mat3A::from_cols(z, x, y),
            1 => Mat3A::from_cols(y, z, x),
            _ => Mat3A::from_cols(x, y, z),
        };
        RayTrianglePrecomp {
            origin: ray.origin.into(),
            direction: ray.direction,
            permute_and_shear,
            sz: 1.0 / dz,
            valid: dz != 0.0,
        }
    }
}

/// Intersects `ray` with triangle `p0 p1 p2` within `(0, ray.t_max)`.
///
/// Watertight: a ray through a shared edge or vertex hits at least one of the triangles
/// sharing it (edge functions of exactly 0 count as inside). Unlike pbrt-v4 this does not
/// re-evaluate zero edge functions in f64, because WGSL has no portable f64; that only ever
/// turns a miss into an edge hit, never the reverse.
pub fn intersect_triangle(ray: &Ray, p0: Vec3, p1: Vec3, p2: Vec3) -> Option<TriangleHit> {
    intersect_triangle_precomp(&RayTrianglePrecomp::new(ray), ray.t_max, p0, p1, p2)
}

/// [`intersect_triangle`] with the ray's part precomputed (BVH traversal).
#[inline(always)]
pub fn intersect_triangle_precomp(
    pre: &RayTrianglePrecomp,
    t_max: f32,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
) -> Option<TriangleHit> {
    if !pre.valid {
        return None;
    }
    // Translate to the ray origin, permute so the ray's dominant axis is z, shear so the ray
    // becomes +z.
    let to_ray_space = |p: Vec3| pre.permute_and_shear * (Vec3A::from(p) - pre.origin);
    let (mut p0t, mut p1t, mut p2t) = (to_ray_space(p0), to_ray_space(p1), to_ray_space(p2));
    let sz = pre.sz;

    // Edge functions.
    let e0 = difference_of_products(p1t.x, p2t.y, p1t.y, p2t.x);
    let e1 = difference_of_products(p2t.x, p0t.y, p2t.y, p0t.x);
    let e2 = difference_of_products(p0t.x, p1t.y, p0t.y, p1t.x);
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 {
        return None;
    }
    // Degenerate triangles have no surface to hit, though the shear's rounding can leave
    // their projection a sliver. Tested only here, where most rays have already missed by
    // the edge signs: the same answer as testing first, for a fraction of the work.
    if (p2 - p0).cross(p1 - p0).length_squared() == 0.0 {
        return None;
    }

    // The shear's rounding is in units of length, so it is bounded with the z extent before
    // the scaling below makes z dimensionless. (pbrt-v4 takes the scaled extent, which is
    // the same for unit directions; shadow rays here run from a point to a light with an
    // unnormalised direction, and in a scene a millionth of a unit across the scaled extent
    // is ~10⁶ times the length units: every hit then failed the t > δt test and shadow rays
    // passed through walls — issue 11's tiny Cornell box.)
    let max_z_length = Vec3::new(p0t.z, p1t.z, p2t.z).abs().max_element();

    // Scaled distance, tested against (0, t_max) without dividing.
    p0t.z *= sz;
    p1t.z *= sz;
    p2t.z *= sz;
    let t_scaled = e0 * p0t.z + e1 * p1t.z + e2 * p2t.z;
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_max * det) {
        return None;
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_max * det) {
        return None;
    }
    let inv_det = 1.0 / det;
    let b0 = e0 * inv_det;
    let b1 = e1 * inv_det;
    let b2 = e2 * inv_det;
    let t = t_scaled * inv_det;

    // Reject hits whose t is not provably positive (pbrt-v4 §6.8.7).
    let max_zt = Vec3::new(p0t.z, p1t.z, p2t.z).abs().max_element();
    let delta_z = gamma(3) * max_zt;
    let max_xt = Vec3::new(p0t.x, p1t.x, p2t.x).abs().max_element();
    let max_yt = Vec3::new(p0t.y, p1t.y, p2t.y).abs().max_element();
    let delta_x = gamma(5) * (max_xt + max_z_length);
    let delta_y = gamma(5) * (max_yt + max_z_length);
    let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = Vec3::new(e0, e1, e2).abs().max_element();
    let delta_t = 3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
    if t <= delta_t && !plane_ahead(pre.origin.into(), pre.direction, p0, p1, p2) {
        return None;
    }
    Some(TriangleHit { b0, b1, b2, t })
}

/// Is the triangle's plane provably crossed ahead of `origin` along `direction`?
///
/// The bound δt above grows with the triangle's extent, so on a large triangle it rejects
/// hits that are merely close: a bounce off one wall of a room within ~10⁻⁵ of the corner
/// met the next wall inside δt and left the room (the sealed room of issue 11, lit through
/// its corner in 2 of 9,216 pixels once the Sobol sampler drew such paths). For such a hit
/// the side of the plane the origin lies on decides instead: with n = (p₁ − p₀) × (p₂ − p₀)
/// and s = n·(o − p₀), the plane lies ahead iff s and n·d have opposite signs, and both
/// signs are certain when each value exceeds its rounding bound, γ₉ times the sum of the
/// absolute terms that form it (one rounding for each difference, two for each product
/// and difference in the cross product, three for the dot products: eight; one to spare).
/// A ray spawned off this triangle, or off a coplanar neighbour, has its origin on the side
/// it leaves towards, so this never admits a self-hit; the remaining blind band is the
/// bound on s, about 10⁻⁶ of the triangle's distance, not δt.
fn plane_ahead(origin: Vec3, direction: Vec3, p0: Vec3, p1: Vec3, p2: Vec3) -> bool {
    let (e1, e2, a) = (p1 - p0, p2 - p0, origin - p0);
    let n = e1.cross(e2);
    let n_abs = (e1.yzx() * e2.zxy()).abs() + (e1.zxy() * e2.yzx()).abs();
    let s = n.dot(a);
    let nd = n.dot(direction);
    let bound = gamma(9);
    s.abs() > bound * n_abs.dot(a.abs())
        && nd.abs() > bound * n_abs.dot(direction.abs())
        && (s < 0.0) != (nd < 0.0)
}

/// Conservative absolute error of the point `b0·p0 + b1·p1 + b2·p2` (pbrt-v4 eq. 6.29).
pub fn triangle_error_bound(hit: &TriangleHit, p0: Vec3, p1: Vec3, p2: Vec3) -> Vec3 {
    ((hit.b0 * p0).abs() + (hit.b1 * p1).abs() + (hit.b2 * p2).abs()) * gamma(7)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unnormalised_directions_hit_at_every_scale() {
        // A point-to-point ray (as shadow rays are: direction = target − origin, t in
        // (0, 1)) through the middle of a triangle, the whole configuration scaled from 1e-8
        // to 1e8: the hit must be found at t = 1/2 at every scale.
        for k in -8..=8 {
            let s = 10f32.powi(k);
            let (p0, p1, p2) =
                (Vec3::new(-1.0, -1.0, 0.3) * s, Vec3::new(1.0, -1.0, 0.3) * s, Vec3::new(0.0, 1.0, 0.3) * s);
            let origin = Vec3::new(0.1, -0.2, -0.7) * s;
            let target = Vec3::new(-0.1, 0.1, 1.3) * s;
            let ray = Ray { origin, direction: target - origin, t_max: 1.0 };
            let hit = intersect_triangle(&ray, p0, p1, p2).unwrap_or_else(|| panic!("missed at scale 1e{k}"));
            assert!((hit.t - 0.5).abs() < 1e-5, "scale 1e{k}: t = {}", hit.t);
        }
    }
}
