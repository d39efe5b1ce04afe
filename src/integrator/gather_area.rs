//! The area of surface a photon-mapping gather draws its photons from.
//!
//! A density estimate divides the flux of the photons found within a radius r of a visible
//! point by the area they landed on. pbrt-v4's SPPM and pathlight's until 2026-12-07 divide
//! by πr², the area of the disk about the point on a plane. Where the surface ends or bends
//! within r of the point (a box's silhouette, a room's corner) the photons landed on another
//! area, and the estimate is off by the ratio of the two: on the Cornell box the boxes'
//! silhouettes came out 1–2% dark, the largest part of SPPM's error there
//! (bench/RESULTS.md, "Photon mapping").
//!
//! [`gather_area`] measures that area exactly, from the triangles themselves: the part of
//! each triangle inside the gather's sphere that the gather's tests accept (the side of the
//! winding its photons arrived on, and `super::sppm`'s `facing_each_other`), on materials
//! where photons are stored. Where it is less than πr² the gathered flux is scaled by πr²
//! over it (`super::sppm::coverage_correction`, which says why a larger area is left alone):
//! the boundary bias every kernel density estimate has at the edge of its domain, taken
//! out by measuring the boundary rather than by shrinking the disk. It needs no rays and adds no
//! noise. Where the surface is a plane wider than the sphere the area is πr² to rounding and
//! the estimate is unchanged; the correction shrinks with r as the bias does, so SPPM stays
//! consistent. A pixel's first gather's area also decides its radius update's α
//! (`super::sppm::radius_alpha`).
//!
//! Per triangle: its plane cuts the sphere in a disk of radius ρ = √(r² − h²) about the
//! point's projection (h the point's distance to the plane); the triangle is clipped by the
//! plane test's half-space (Sutherland–Hodgman), and the area of the clipped polygon inside
//! the disk is summed edge by edge: each edge with the disk's centre spans a triangle whose
//! part inside the circle is a triangle where the edge is inside and a circular sector where
//! it is outside.
//!
//! What it does not see: alpha-masked and alpha-blended surfaces count whole (their
//! cut-outs store no photons, so points beside them stay as dark as before); where textures
//! make a material delta-only in places, those places count.
//!
//! **GPU twin**: `gather_area` in `shaders/sppm.wgsl`, the same traversal order and
//! arithmetic in f32.

use glam::{Vec2, Vec3};

use crate::bvh::MAX_DEPTH;
use crate::geometry::Frame;
use crate::scene::layout::{BvhNode, Material, Triangle, MATERIAL_DELTA_ONLY};

/// The most a visible point's photons are scaled up by (πr² over the area found): a point
/// on a needle's tip or in a box's corner, where the surface within r is a small share of
/// the disk, stays an estimate of bounded variance. A box's convex corner is 4.
pub const MAX_COVERAGE_CORRECTION: f32 = 8.0;

/// What one gather accepts (see `super::sppm`'s `facing_each_other`): photons within
/// `radius` of `center` on surfaces in front of the point's plane (turned to the side its
/// camera ray came from, `n_point`), within `tolerance` behind it where the point is within
/// `step` of the photon's plane and within `step` behind it elsewhere, among those that
/// arrived on the side of their surface's winding that `winding_side` names; any photon
/// within the radius when the surface `transmits`.
#[derive(Clone, Copy, Debug)]
pub struct GatherRegion {
    pub center: Vec3,
    pub n_point: Vec3,
    pub radius: f32,
    pub tolerance: f32,
    pub step: f32,
    /// +1 where the point's camera ray came from the front of its triangle's winding, −1
    /// where from the back: the gather keeps the photons that arrived on the same side of
    /// their own triangle's winding (the back-facing test).
    pub winding_side: f32,
    pub transmits: bool,
}

/// The area of the triangles `region` accepts photons from, skipping materials flagged
/// [`MATERIAL_DELTA_ONLY`] (no photon is stored on them). Traverses the binary BVH `nodes`
/// depth first, first child before second, as its WGSL twin does.
pub fn gather_area(
    nodes: &[BvhNode],
    triangles: &[Triangle],
    materials: &[Material],
    region: &GatherRegion,
) -> f32 {
    if nodes.is_empty() || !is_positive(region.radius) {
        return 0.0;
    }
    let r2 = region.radius * region.radius;
    let mut stack = [0u32; MAX_DEPTH];
    let mut sp = 0usize;
    let mut current = 0u32;
    let mut area = 0.0f32;
    loop {
        let node = &nodes[current as usize];
        if box_distance_squared(node, region.center) <= r2 {
            let count = node.triangle_count();
            if count == 0 {
                // Interior: the first child follows its parent; the second waits.
                if sp < MAX_DEPTH {
                    stack[sp] = node.offset;
                    sp += 1;
                }
                current += 1;
                continue;
            }
            for t in &triangles[node.offset as usize..(node.offset + count) as usize] {
                if materials[t.material as usize].flags & MATERIAL_DELTA_ONLY == 0 {
                    area += triangle_area_in_region(t, region);
                }
            }
        }
        if sp == 0 {
            return area;
        }
        sp -= 1;
        current = stack[sp];
    }
}

/// `x > 0`, false for NaN: a degenerate triangle, edge or radius counts nothing.
fn is_positive(x: f32) -> bool {
    x > 0.0
}

/// Squared distance from `p` to the node's box (0 inside).
fn box_distance_squared(node: &BvhNode, p: Vec3) -> f32 {
    let lo = Vec3::from(node.bounds_min);
    let hi = Vec3::from(node.bounds_max);
    let d = (lo - p).max(p - hi).max(Vec3::ZERO);
    d.length_squared()
}

/// The area of triangle `t` inside `region`'s sphere and accepted by its plane tests.
pub fn triangle_area_in_region(t: &Triangle, region: &GatherRegion) -> f32 {
    let x = region.center;
    let a = Vec3::from(t.p0) - x;
    let b = Vec3::from(t.p1) - x;
    let c = Vec3::from(t.p2) - x;
    let n = (b - a).cross(c - a);
    let len = n.length();
    if !is_positive(len) {
        return 0.0;
    }
    // The side of the triangle the gather takes photons from: the gather keeps a photon
    // that arrived on the side of its surface's winding normal that the point's camera ray
    // came from of the point's own (the back-facing test), whichever side the point lies on.
    let n = n / len * region.winding_side;
    // The point's height above the triangle's plane on that side: the gather's "point
    // height" for every photon the back-facing test keeps there.
    let height = -a.dot(n);
    let rho2 = region.radius * region.radius - height * height;
    if !is_positive(rho2) {
        return 0.0;
    }
    let mut polygon = [a, b, c, Vec3::ZERO, Vec3::ZERO];
    let mut count = 3;
    if !region.transmits {
        // `in_front_of_each_other` with the point's height fixed: the photon's height above
        // the point's plane, y·n_point, must be at least −step where the point lies more
        // than the step in front of the triangle, at least −tolerance where it lies within
        // the step of its plane, and within [−tolerance, step] where it lies behind it by
        // less than the tolerance; farther behind, nothing counts.
        let (lower, upper) = if height > region.step {
            (region.step, None)
        } else if height >= -region.step {
            (region.tolerance, None)
        } else if height >= -region.tolerance {
            (region.tolerance, Some(region.step))
        } else {
            return 0.0;
        };
        count = clip_to_half_space(&mut polygon, count, region.n_point, lower);
        if let Some(upper) = upper {
            count = clip_to_half_space(&mut polygon, count, -region.n_point, upper);
        }
    }
    if count < 3 {
        return 0.0;
    }
    // Coordinates in the plane about the point's projection q = −height·n: y − q projects
    // onto the frame's x and y as y does, since q is along n.
    let frame = Frame::from_z(n);
    let mut flat = [Vec2::ZERO; 5];
    for (f, p) in flat.iter_mut().zip(&polygon[..count]) {
        *f = Vec2::new(p.dot(frame.x), p.dot(frame.y));
    }
    polygon_area_in_disk(&flat[..count], rho2)
}

/// The area of the convex polygon `polygon` inside the circle of squared radius `rho2`
/// about 0. Where no edge's line comes within the radius (the polygon holds the whole disk,
/// or misses it) it is πρ² or 0 without the edge sums' arc tangents: the case of most
/// triangles a gather's sphere meets.
fn polygon_area_in_disk(polygon: &[Vec2], rho2: f32) -> f32 {
    let count = polygon.len();
    let (mut crossed, mut positive, mut negative) = (false, false, false);
    for i in 0..count {
        let (p, q) = (polygon[i], polygon[(i + 1) % count]);
        let d = q - p;
        let dd = d.length_squared();
        let m = p + d * (-p.dot(d) / dd);
        crossed |= !is_positive(dd) || m.length_squared() < rho2;
        let side = p.perp_dot(q);
        positive |= side > 0.0;
        negative |= side < 0.0;
    }
    if !crossed {
        return if positive && negative { 0.0 } else { std::f32::consts::PI * rho2 };
    }
    let mut signed = 0.0f32;
    for i in 0..count {
        signed += segment_area_in_disk(polygon[i], polygon[(i + 1) % count], rho2);
    }
    signed.abs()
}

/// Clips the convex polygon `polygon[..count]` to y·n ≥ −offset (Sutherland–Hodgman against
/// one plane) in place; returns the new count. A triangle clipped twice has at most five
/// corners.
fn clip_to_half_space(polygon: &mut [Vec3; 5], count: usize, n: Vec3, offset: f32) -> usize {
    let corners = *polygon;
    let mut out = 0;
    for i in 0..count {
        let p = corners[i];
        let q = corners[(i + 1) % count];
        let dp = p.dot(n) + offset;
        let dq = q.dot(n) + offset;
        if dp >= 0.0 && out < 5 {
            polygon[out] = p;
            out += 1;
        }
        if (dp >= 0.0) != (dq >= 0.0) && out < 5 {
            polygon[out] = p + (q - p) * (dp / (dp - dq));
            out += 1;
        }
    }
    out
}

/// The signed area of the triangle (0, a, b) inside the circle of squared radius `rho2`
/// about 0: a triangle over the part of the edge ab inside the circle, a sector
/// ½ρ²·angle over each part outside it.
fn segment_area_in_disk(a: Vec2, b: Vec2, rho2: f32) -> f32 {
    let d = b - a;
    let dd = d.length_squared();
    if !is_positive(dd) {
        return 0.0;
    }
    let sector = |p: Vec2, q: Vec2| 0.5 * rho2 * p.perp_dot(q).atan2(p.dot(q));
    // The line's closest point to the centre, computed directly (not from a quadratic's
    // discriminant, which cancels when the edge is long against the radius).
    let t0 = -a.dot(d) / dd;
    let m = a + d * t0;
    let inside2 = rho2 - m.length_squared();
    if !is_positive(inside2) {
        return sector(a, b);
    }
    let half = (inside2 / dd).sqrt();
    let (t1, t2) = (t0 - half, t0 + half);
    if t1 >= 1.0 || t2 <= 0.0 {
        return sector(a, b);
    }
    let p1 = if t1 > 0.0 { a + d * t1 } else { a };
    let p2 = if t2 < 1.0 { a + d * t2 } else { b };
    let mut area = 0.5 * p1.perp_dot(p2);
    if t1 > 0.0 {
        area += sector(a, p1);
    }
    if t2 < 1.0 {
        area += sector(p2, b);
    }
    area
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::sppm::{in_front_of_each_other, PLANE_TOLERANCE, STEP_TOLERANCE};

    fn triangle(p0: Vec3, p1: Vec3, p2: Vec3) -> Triangle {
        Triangle {
            p0: p0.to_array(),
            material: 0,
            p1: p1.to_array(),
            emitter: 0,
            p2: p2.to_array(),
            flags: 0,
        }
    }

    fn region(center: Vec3, n_point: Vec3, radius: f32) -> GatherRegion {
        GatherRegion {
            center,
            n_point,
            radius,
            tolerance: PLANE_TOLERANCE * radius,
            step: STEP_TOLERANCE * radius,
            winding_side: 1.0,
            transmits: false,
        }
    }

    /// Monte Carlo estimate of the same area: uniform points on the triangle, kept where the
    /// gather's own test would keep a photon there (within the sphere, and
    /// `in_front_of_each_other` with the photon on the side `winding_side` names).
    fn sampled_area(t: &Triangle, r: &GatherRegion, n: u32) -> f32 {
        let (a, b, c) = (Vec3::from(t.p0), Vec3::from(t.p1), Vec3::from(t.p2));
        let full = 0.5 * (b - a).cross(c - a).length();
        let n_photon = (b - a).cross(c - a).normalize() * r.winding_side;
        let mut rng = crate::sampling::Rng::new(1, 2, 3, 4);
        let mut kept = 0u32;
        for _ in 0..n {
            let (mut s, mut q) = (rng.next_1d(), rng.next_1d());
            if s + q > 1.0 {
                (s, q) = (1.0 - s, 1.0 - q);
            }
            let y = a + (b - a) * s + (c - a) * q;
            let d = y - r.center;
            if d.length_squared() <= r.radius * r.radius
                && (r.transmits || in_front_of_each_other(d, r.n_point, n_photon, 1.0, r.radius))
            {
                kept += 1;
            }
        }
        full * kept as f32 / n as f32
    }

    #[test]
    fn a_plane_wider_than_the_sphere_gives_the_disk() {
        let t =
            triangle(Vec3::new(-10.0, -10.0, 0.0), Vec3::new(10.0, -10.0, 0.0), Vec3::new(0.0, 10.0, 0.0));
        let r = region(Vec3::new(0.3, 0.2, 0.0), Vec3::Z, 0.01);
        let exact = std::f32::consts::PI * 1e-4;
        // f32 rounding of coordinates ~10 against a radius of 0.01: a few 1e-5 relative.
        assert!((triangle_area_in_region(&t, &r) / exact - 1.0).abs() < 1e-4);
        // Half the radius off the plane, on the side its photons face: the disk of radius
        // √(r² − h²).
        let above = GatherRegion { winding_side: -1.0, ..region(Vec3::new(0.3, 0.2, -0.005), Vec3::Z, 0.01) };
        let exact = std::f32::consts::PI * (1e-4 - 0.25e-4);
        assert!((triangle_area_in_region(&t, &above) / exact - 1.0).abs() < 1e-4);
    }

    #[test]
    fn an_edge_through_the_centre_halves_the_disk() {
        // A square's edge on x = 0, the point on it.
        let r = region(Vec3::new(0.0, 0.5, 0.0), Vec3::Z, 0.1);
        let a = triangle(Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0));
        let b = triangle(Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        let total = triangle_area_in_region(&a, &r) + triangle_area_in_region(&b, &r);
        let half = 0.5 * std::f32::consts::PI * 0.01;
        assert!((total / half - 1.0).abs() < 1e-5, "{total} against {half}");
    }

    #[test]
    fn clipped_and_bent_triangles_match_sampling() {
        // A wall meeting the point's floor at a convex edge (behind the point's plane), one
        // at a concave edge (in front), a wall whose photons arrive on the side away from
        // the point, which lies behind their plane within the tolerance (only the slab
        // within [−tolerance, step] of the point's plane counts), and one cut by the
        // sphere's surface at a slant, also as seen by a surface that transmits.
        let n = 400_000;
        let cases = [
            (
                triangle(Vec3::new(0.05, -1.0, 0.0), Vec3::new(0.05, 1.0, 0.0), Vec3::new(0.05, 0.0, -1.0)),
                region(Vec3::new(0.0, 0.0, 0.0), Vec3::Z, 0.2),
            ),
            (
                triangle(Vec3::new(0.05, -1.0, 0.0), Vec3::new(0.05, 1.0, 0.0), Vec3::new(0.05, 0.0, 1.0)),
                GatherRegion { winding_side: -1.0, ..region(Vec3::new(0.0, 0.0, 0.0), Vec3::Z, 0.2) },
            ),
            (
                triangle(Vec3::new(0.01, -1.0, -1.0), Vec3::new(0.01, 1.0, 0.0), Vec3::new(0.01, -1.0, 1.0)),
                region(Vec3::new(0.0, 0.0, 0.0), Vec3::Z, 0.2),
            ),
            (
                triangle(Vec3::new(-0.3, -0.2, 0.05), Vec3::new(0.4, 0.1, -0.02), Vec3::new(0.0, 0.3, 0.2)),
                GatherRegion {
                    winding_side: -1.0,
                    ..region(Vec3::new(0.02, 0.03, 0.0), Vec3::new(0.0, 0.6, 0.8), 0.15)
                },
            ),
            (
                triangle(Vec3::new(-0.3, -0.2, 0.05), Vec3::new(0.4, 0.1, -0.02), Vec3::new(0.0, 0.3, 0.2)),
                GatherRegion {
                    transmits: true,
                    ..region(Vec3::new(0.02, 0.03, 0.0), Vec3::new(0.0, 0.6, 0.8), 0.15)
                },
            ),
        ];
        // The concave wall's photons on its side away from the point, 0.25 r behind them:
        // none counts.
        let (t, r) = &cases[1];
        assert_eq!(triangle_area_in_region(t, &GatherRegion { winding_side: 1.0, ..*r }), 0.0);
        for (i, (t, r)) in cases.iter().enumerate() {
            let exact = triangle_area_in_region(t, r);
            let sampled = sampled_area(t, r, n);
            let full = 0.5
                * (Vec3::from(t.p1) - Vec3::from(t.p0)).cross(Vec3::from(t.p2) - Vec3::from(t.p0)).length();
            // Binomial standard error of the kept share, times the triangle's area; 5σ.
            let p = (sampled / full).clamp(1e-6, 1.0);
            let sigma = full * (p * (1.0 - p) / n as f32).sqrt();
            assert!(exact > 0.0, "case {i}: empty");
            assert!(
                (exact - sampled).abs() <= 5.0 * sigma,
                "case {i}: exact {exact}, sampled {sampled} ± {sigma}"
            );
        }
    }
}
