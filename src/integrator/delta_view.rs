//! Does the camera see nothing but delta surfaces, such as a glass pane or a mirror filling
//! the view?
//!
//! Then every camera ray's first vertex scatters by a delta lobe, and a strategy that joins
//! a light vertex to the camera (the path tracer's caustic light tracer, BDPT's t = 1) can
//! never contribute: its connection needs a non-delta vertex the camera sees directly, and
//! every such segment crosses the pane first. Skipping them changes nothing in the image
//! (the light tracer's partition gives a path to it only when its first vertex is
//! non-delta; BDPT's weights give t = 1 no share of a path whose first vertex is delta),
//! and saves their rays (issue 43: 5% of a render behind a pane).
//!
//! The test is exact, not sampled, so it is decided once per scene and camera: in camera
//! space, every triangle is clipped to the view's frustum. The delta occluders (materials
//! without a non-delta lobe on either side, untextured, opaque) that lie entirely nearer
//! than the nearest point of any other surface in the frustum, measured as depth along the
//! view axis (which orders the points along every ray alike), are projected onto the image
//! plane and cut out of the image rectangle. What remains must be empty: nothing but pieces
//! below [`REMAINDER_AREA`] of the image, the rounding of the cuts along shared edges.
//! Anything the test cannot decide cheaply (too many occluders, a triangle through the
//! eye) answers `false`, which only keeps the work.

use glam::{DVec2, DVec3, Vec3};

use crate::scene::layout::{Camera, MATERIAL_DELTA_ONLY, PROJECTION_PERSPECTIVE};
use crate::scene::FlatScene;

/// Pieces of the image rectangle left uncovered below this fraction of its area are taken
/// as rounding: cuts along an edge two triangles share are computed from the same f64
/// vertices in either order and differ by ~1e-16 of the image, while a real gap this small
/// would hold 1e-12 of the image's light.
const REMAINDER_AREA: f64 = 1e-12;

/// The most occluders the test cuts out; a view covered by more (a tessellated glass
/// sphere around the camera) keeps the work rather than spend seconds deciding.
const MAX_OCCLUDERS: usize = 4096;

/// The most uncovered pieces tracked before the test gives up (answers `false`).
const MAX_PIECES: usize = 16_384;

/// Does `camera` see only delta surfaces of `scene` (module documentation)? Reads every
/// triangle: call it once per scene and camera. `false` for an orthographic camera (it has
/// no camera connections to skip).
pub fn camera_sees_only_delta_surfaces(scene: &FlatScene, camera: &Camera) -> bool {
    if camera.projection != PROJECTION_PERSPECTIVE {
        return false;
    }
    let eye = Vec3::from(camera.position).as_dvec3();
    let axes = [camera.right, camera.up, camera.forward].map(|a| Vec3::from(a).as_dvec3());
    let (tx, ty) = (camera.half_width as f64, camera.half_height as f64);
    let mut nearest_other = f64::INFINITY;
    let mut occluders: Vec<(f64, Vec<DVec3>)> = Vec::new();
    for tri in &scene.triangles {
        let corners = [tri.p0, tri.p1, tri.p2].map(|p| {
            let d = Vec3::from(p).as_dvec3() - eye;
            DVec3::new(d.dot(axes[0]), d.dot(axes[1]), d.dot(axes[2]))
        });
        let polygon = clip_to_frustum(&corners, tx, ty);
        if polygon.len() < 3 {
            continue;
        }
        let (near, far) = polygon.iter().fold((f64::INFINITY, 0.0f64), |(n, f), p| (n.min(p.z), f.max(p.z)));
        if scene.materials[tri.material as usize].flags & MATERIAL_DELTA_ONLY != 0 {
            occluders.push((far, polygon));
        } else {
            nearest_other = nearest_other.min(near);
        }
    }
    if nearest_other == f64::INFINITY {
        // Nothing but delta surfaces (or nothing) in view.
        return true;
    }
    if nearest_other <= 0.0 {
        return false;
    }
    let mut covers: Vec<Vec<DVec2>> = Vec::new();
    for (far, polygon) in &occluders {
        if *far >= nearest_other {
            continue;
        }
        if polygon.iter().any(|p| p.z <= 0.0) {
            // Through the eye: its projection is unbounded; keep the work.
            return false;
        }
        let mut projected: Vec<DVec2> = polygon.iter().map(|p| DVec2::new(p.x / p.z, p.y / p.z)).collect();
        if signed_area(&projected) < 0.0 {
            projected.reverse();
        }
        covers.push(projected);
        if covers.len() > MAX_OCCLUDERS {
            return false;
        }
    }
    let image = vec![DVec2::new(-tx, -ty), DVec2::new(tx, -ty), DVec2::new(tx, ty), DVec2::new(-tx, ty)];
    let min_area = REMAINDER_AREA * signed_area(&image);
    let mut pieces = vec![image];
    for cover in &covers {
        let mut next = Vec::with_capacity(pieces.len());
        for piece in &pieces {
            subtract_convex(piece, cover, min_area, &mut next);
        }
        pieces = next;
        if pieces.is_empty() {
            return true;
        }
        if pieces.len() > MAX_PIECES {
            return false;
        }
    }
    pieces.iter().map(|p| signed_area(p)).sum::<f64>() <= min_area
}

/// Sutherland–Hodgman: the part of the triangle inside the pyramid |x| ≤ tx·z, |y| ≤ ty·z
/// (camera space, z forward), which lies at z ≥ 0.
fn clip_to_frustum(corners: &[DVec3; 3], tx: f64, ty: f64) -> Vec<DVec3> {
    let planes: [fn(DVec3, f64, f64) -> f64; 4] = [
        |p, tx, _| tx * p.z - p.x,
        |p, tx, _| tx * p.z + p.x,
        |p, _, ty| ty * p.z - p.y,
        |p, _, ty| ty * p.z + p.y,
    ];
    let mut polygon = corners.to_vec();
    for inside in planes {
        polygon = clip(&polygon, |p| inside(p, tx, ty));
        if polygon.is_empty() {
            break;
        }
    }
    polygon
}

/// The part of convex `polygon` where `inside` ≥ 0 (`inside` affine in the point).
fn clip<P>(polygon: &[P], inside: impl Fn(P) -> f64) -> Vec<P>
where
    P: Copy + std::ops::Add<Output = P> + std::ops::Sub<Output = P> + std::ops::Mul<f64, Output = P>,
{
    let mut out = Vec::with_capacity(polygon.len() + 1);
    for (i, &a) in polygon.iter().enumerate() {
        let b = polygon[(i + 1) % polygon.len()];
        let (da, db) = (inside(a), inside(b));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

/// The area of a simple polygon (shoelace formula), positive when counter-clockwise.
fn signed_area(p: &[DVec2]) -> f64 {
    let mut twice = 0.0;
    for (i, a) in p.iter().enumerate() {
        twice += a.perp_dot(p[(i + 1) % p.len()]);
    }
    0.5 * twice
}

/// Appends `piece` minus `cover` (both convex, counter-clockwise) to `out` as convex pieces,
/// dropping any below `min_area`: the part outside `cover`'s first edge, then of the rest
/// the part outside its second edge, and so on.
fn subtract_convex(piece: &[DVec2], cover: &[DVec2], min_area: f64, out: &mut Vec<Vec<DVec2>>) {
    let mut rest = piece.to_vec();
    for (i, &a) in cover.iter().enumerate() {
        let b = cover[(i + 1) % cover.len()];
        // Left of a→b is inside a counter-clockwise polygon.
        let left = |p: DVec2| (b - a).perp_dot(p - a);
        let outside = clip(&rest, |p| -left(p));
        if outside.len() >= 3 && signed_area(&outside) > min_area {
            out.push(outside);
        }
        rest = clip(&rest, left);
        if rest.len() < 3 || signed_area(&rest) <= min_area {
            return;
        }
    }
    // What is left lies inside every edge: covered.
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(lo: f64, hi: f64) -> Vec<DVec2> {
        vec![DVec2::new(lo, lo), DVec2::new(hi, lo), DVec2::new(hi, hi), DVec2::new(lo, hi)]
    }

    fn area_of(pieces: &[Vec<DVec2>]) -> f64 {
        pieces.iter().map(|p| signed_area(p)).sum()
    }

    #[test]
    fn subtracting_convex_polygons_leaves_the_exact_remainder() {
        let mut out = Vec::new();
        // A unit square minus its top-right quarter: three quarters remain.
        subtract_convex(&square(0.0, 1.0), &square(0.5, 2.0), 0.0, &mut out);
        assert!((area_of(&out) - 0.75).abs() < 1e-12, "{out:?}");
        // Minus a square holding it: nothing.
        out.clear();
        subtract_convex(&square(0.0, 1.0), &square(-1.0, 2.0), 1e-12, &mut out);
        assert!(out.is_empty(), "{out:?}");
        // Minus a disjoint square: all of it.
        out.clear();
        subtract_convex(&square(0.0, 1.0), &square(3.0, 4.0), 0.0, &mut out);
        assert!((area_of(&out) - 1.0).abs() < 1e-12);
        // Minus a small square in the middle: 1 − 0.04, in convex pieces.
        out.clear();
        subtract_convex(&square(0.0, 1.0), &square(0.4, 0.6), 0.0, &mut out);
        assert!((area_of(&out) - 0.96).abs() < 1e-12);
        assert!(out.iter().all(|p| signed_area(p) > 0.0));
    }

    #[test]
    fn a_triangle_is_clipped_to_the_frustum() {
        // A triangle at depth 1 larger than the view (half extents 0.5): clipped to the
        // view's square at that depth.
        let t = [DVec3::new(-10.0, -10.0, 1.0), DVec3::new(10.0, -10.0, 1.0), DVec3::new(0.0, 10.0, 1.0)];
        let p = clip_to_frustum(&t, 0.5, 0.5);
        let flat: Vec<DVec2> = p.iter().map(|p| p.truncate()).collect();
        assert!((signed_area(&flat).abs() - 1.0).abs() < 1e-12, "{p:?}");
        // Behind the eye: nothing.
        let behind = t.map(|p| DVec3::new(p.x, p.y, -1.0));
        assert!(clip_to_frustum(&behind, 0.5, 0.5).is_empty());
    }
}
