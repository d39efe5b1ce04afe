//! BVH traversal against brute force, watertightness, and self-intersection of spawned
//! rays — the geometric robustness DESIGN.md asks for, on the flat arrays both backends use
//! (the binary tree, and the CPU's 8-wide collapse of it).

mod common;

use glam::Vec3;
use pathlight::bvh::{
    build, intersect_any, intersect_closest, traverse_with_short_stack, Traversal, WideBvh, MAX_DEPTH,
    SHORT_STACK_SIZE,
};
use pathlight::geometry::{intersect_triangle, spawn_ray, triangle_error_bound, Ray};
use pathlight::sampling::{sample_uniform_sphere, Rng};
use pathlight::scene::layout::Triangle;

fn to_flat(tris: &[[Vec3; 3]]) -> (Vec<pathlight::scene::layout::BvhNode>, Vec<Triangle>) {
    let bvh = build(tris);
    let triangles = bvh
        .order
        .iter()
        .map(|&i| {
            let t = tris[i as usize];
            Triangle { p0: t[0].to_array(), p1: t[1].to_array(), p2: t[2].to_array(), ..Default::default() }
        })
        .collect();
    (bvh.nodes, triangles)
}

/// Rays through a shared edge or vertex hit several triangles at the same point, but each
/// triangle's t carries its own rounding, and the triangle test compares t with `t_max` in
/// its scaled space; so which of those near-equal hits wins depends on test order. Hits
/// within this relative band of the nearest are ties.
const TIE: f32 = 1e-6;

/// The nearest hit over all triangles, and every triangle hit within [`TIE`] of it.
fn brute_force(triangles: &[Triangle], ray: &Ray) -> Option<(f32, Vec<u32>)> {
    let hits: Vec<(f32, u32)> = triangles
        .iter()
        .enumerate()
        .filter_map(|(i, t)| {
            intersect_triangle(ray, Vec3::from(t.p0), Vec3::from(t.p1), Vec3::from(t.p2))
                .map(|h| (h.t, i as u32))
        })
        .collect();
    let nearest = hits.iter().map(|h| h.0).fold(f32::INFINITY, f32::min);
    if nearest.is_infinite() {
        return None;
    }
    Some((nearest, hits.iter().filter(|h| h.0 <= nearest * (1.0 + TIE)).map(|h| h.1).collect()))
}

/// An icosphere-like closed mesh: a UV sphere with poles, vertices shared exactly.
fn closed_sphere(
    rng: &mut Rng,
    rings: usize,
    segments: usize,
    perturb: f32,
    center: Vec3,
    radius: f32,
) -> Vec<[Vec3; 3]> {
    let mut verts = vec![center + Vec3::Y * radius];
    for r in 1..rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = 2.0 * std::f32::consts::PI * s as f32 / segments as f32;
            let jitter = 1.0 + perturb * (rng.next_1d() - 0.5);
            let d = Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin());
            verts.push(center + d * radius * jitter);
        }
    }
    verts.push(center - Vec3::Y * radius);
    let idx = |r: usize, s: usize| 1 + (r - 1) * segments + s % segments;
    let last = verts.len() - 1;
    let mut tris = Vec::new();
    for s in 0..segments {
        tris.push([verts[0], verts[idx(1, s + 1)], verts[idx(1, s)]]);
        tris.push([verts[last], verts[idx(rings - 1, s)], verts[idx(rings - 1, s + 1)]]);
        for r in 1..rings - 1 {
            let (a, b, c, d) = (idx(r, s), idx(r, s + 1), idx(r + 1, s), idx(r + 1, s + 1));
            tris.push([verts[a], verts[b], verts[d]]);
            tris.push([verts[a], verts[d], verts[c]]);
        }
    }
    tris
}

/// Random triangles plus a closed mesh plus an axis-aligned grid whose vertices share
/// coordinates, so axis-parallel rays run exactly along edges and through vertices.
fn test_scene() -> Vec<[Vec3; 3]> {
    let mut rng = Rng::new(7, 7, 7, 7);
    let mut tris = Vec::new();
    for _ in 0..3000 {
        let c = Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 10.0 - 5.0;
        let e = |r: &mut Rng| Vec3::new(r.next_1d() - 0.5, r.next_1d() - 0.5, r.next_1d() - 0.5) * 1.5;
        tris.push([c + e(&mut rng), c + e(&mut rng), c + e(&mut rng)]);
    }
    tris.extend(closed_sphere(&mut rng, 16, 24, 0.1, Vec3::new(1.0, 2.0, -1.0), 2.0));
    for i in 0..10 {
        for j in 0..10 {
            let (x, z) = (i as f32 - 5.0, j as f32 - 5.0);
            let y = -6.0;
            tris.push([Vec3::new(x, y, z), Vec3::new(x + 1.0, y, z), Vec3::new(x + 1.0, y, z + 1.0)]);
            tris.push([Vec3::new(x, y, z), Vec3::new(x + 1.0, y, z + 1.0), Vec3::new(x, y, z + 1.0)]);
            // Vertical fins on the grid lines: axis-parallel rays at y = −6 graze their edges.
            tris.push([Vec3::new(x, y, z), Vec3::new(x, y + 1.0, z), Vec3::new(x, y, z + 1.0)]);
        }
    }
    tris
}

/// Both trees (the binary one the GPU walks and the CPU's 8-wide collapse of it) against
/// brute force.
fn check_against_brute_force(
    nodes: &[pathlight::scene::layout::BvhNode],
    triangles: &[Triangle],
    ray: &Ray,
    what: &str,
) {
    check_tree_against_brute_force(nodes, triangles, ray, &format!("{what}, binary tree"));
    // Shorter stacks restart from the root more often (0: after every leaf), following the
    // restart trail back; the answer must not change.
    for limit in [0, 1, 2] {
        check_tree_against_brute_force(
            &ShortStack { nodes, limit },
            triangles,
            ray,
            &format!("{what}, binary tree, short stack of {limit}"),
        );
    }
    let wide = WideBvh::collapse(nodes);
    check_tree_against_brute_force(&wide, triangles, ray, &format!("{what}, 8-wide tree"));
}

/// The binary tree traversed with a short stack of `limit` entries instead of
/// [`SHORT_STACK_SIZE`].
struct ShortStack<'a> {
    nodes: &'a [pathlight::scene::layout::BvhNode],
    limit: usize,
}

impl Traversal for ShortStack<'_> {
    fn traverse(&self, ray: &mut Ray, visit: impl FnMut(u32, u32, &mut Ray) -> bool) {
        traverse_with_short_stack(self.nodes, self.limit, ray, visit)
    }
}

fn check_tree_against_brute_force<T: Traversal + ?Sized>(
    nodes: &T,
    triangles: &[Triangle],
    ray: &Ray,
    what: &str,
) {
    let bvh = intersect_closest(nodes, triangles, ray);
    let brute = brute_force(triangles, ray);
    match (bvh, brute) {
        (None, None) => {}
        (Some(h), Some((t, ids))) => {
            assert!(
                h.hit.t >= t && h.hit.t <= t * (1.0 + TIE),
                "{what}: BVH found t = {} but the nearest is {t} (ray {ray:?})",
                h.hit.t
            );
            assert!(
                ids.contains(&h.triangle),
                "{what}: BVH triangle {} is not among the nearest {ids:?}",
                h.triangle
            );
        }
        (b, f) => panic!("{what}: BVH {b:?} vs brute force {f:?} for ray {ray:?}"),
    }
    assert_eq!(
        intersect_any(nodes, triangles, ray),
        brute_force(triangles, ray).is_some(),
        "{what}: any-hit disagrees"
    );
}

#[test]
fn traversal_equals_brute_force() {
    let tris = test_scene();
    let (nodes, triangles) = to_flat(&tris);
    let mut rng = Rng::new(1, 2, 3, 4);
    // Random rays, some with a finite t_max.
    for i in 0..20_000 {
        let origin = Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 16.0 - 8.0;
        let direction = sample_uniform_sphere(rng.next_2d());
        let t_max = if i % 3 == 0 { rng.next_1d() * 10.0 } else { f32::MAX };
        check_against_brute_force(&nodes, &triangles, &Ray { origin, direction, t_max }, "random ray");
    }
    // Axis-parallel rays from points on the integer grid (they run along shared edges and
    // through shared vertices) and from random points.
    let axes = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    for i in -7..=7 {
        for j in -7..=7 {
            for (k, d) in axes.iter().enumerate() {
                let (a, b) = (i as f32, j as f32);
                let origin = match k / 2 {
                    0 => Vec3::new(-20.0 * d.x, a.clamp(-6.0, 6.0), b),
                    1 => Vec3::new(a, -20.0 * d.y, b),
                    _ => Vec3::new(a, -6.0, -20.0 * d.z),
                };
                check_against_brute_force(
                    &nodes,
                    &triangles,
                    &Ray { origin, direction: *d, t_max: f32::MAX },
                    "axis-parallel ray",
                );
            }
        }
    }
    for _ in 0..5000 {
        let origin = Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 16.0 - 8.0;
        let d = axes[(rng.next_1d() * 6.0) as usize % 6];
        check_against_brute_force(
            &nodes,
            &triangles,
            &Ray { origin, direction: d, t_max: f32::MAX },
            "random axis-parallel ray",
        );
    }
    // Rays aimed exactly at vertices and at edge midpoints.
    for t in tris.iter().step_by(7) {
        let origin = Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) * 20.0 - 10.0;
        for target in [t[0], t[1], t[2], 0.5 * (t[0] + t[1]), 0.5 * (t[1] + t[2])] {
            check_against_brute_force(
                &nodes,
                &triangles,
                &Ray { origin, direction: target - origin, t_max: f32::MAX },
                "ray at a vertex or edge",
            );
        }
    }
}

#[test]
fn closed_mesh_is_watertight() {
    // 100 000 rays from inside a closed, randomly perturbed sphere must all hit it, many of
    // them aimed exactly at its vertices and edges, where a non-watertight test leaks.
    let mut rng = Rng::new(4, 4, 4, 4);
    let tris = closed_sphere(&mut rng, 40, 60, 0.2, Vec3::new(0.3, -0.2, 0.1), 1.0);
    let (nodes, triangles) = to_flat(&tris);
    let wide = WideBvh::collapse(&nodes);
    let mut misses = 0;
    for i in 0..100_000 {
        let origin =
            Vec3::new(0.3, -0.2, 0.1) + (Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d()) - 0.5) * 0.6;
        let direction = match i % 3 {
            0 => sample_uniform_sphere(rng.next_2d()),
            1 => tris[i % tris.len()][i % 3] - origin,
            _ => {
                let t = tris[i % tris.len()];
                t[0].lerp(t[1], rng.next_1d()) - origin
            }
        };
        let ray = Ray { origin, direction, t_max: f32::MAX };
        if intersect_closest(&nodes, &triangles, &ray).is_none()
            || intersect_closest(&wide, &triangles, &ray).is_none()
        {
            misses += 1;
        }
    }
    assert_eq!(misses, 0, "{misses} of 100000 rays escaped a closed mesh");
}

#[test]
fn spawned_rays_never_rehit_their_triangle() {
    // At every scale and distance from the origin, a ray spawned from a hit point (in any
    // direction, either side of the surface) must not hit the triangle it left.
    let mut rng = Rng::new(5, 5, 5, 5);
    for scale in [1e-3f32, 1.0, 1e3, 1e6] {
        for distance in [0.0f32, 1e-3, 1.0, 1e3, 1e6] {
            let center = Vec3::new(1.0, -0.7, 0.4).normalize() * distance;
            let mut failures = 0;
            for _ in 0..20_000 {
                let e =
                    |r: &mut Rng| Vec3::new(r.next_1d() - 0.5, r.next_1d() - 0.5, r.next_1d() - 0.5) * scale;
                let (p0, p1, p2) = (center + e(&mut rng), center + e(&mut rng), center + e(&mut rng));
                // Aim at a random interior point from outside.
                let b = pathlight::sampling::sample_uniform_triangle(rng.next_2d());
                let target = b.x * p0 + b.y * p1 + b.z * p2;
                let from = target + sample_uniform_sphere(rng.next_2d()) * scale * 2.0;
                let ray = Ray { origin: from, direction: target - from, t_max: f32::MAX };
                let Some(hit) = intersect_triangle(&ray, p0, p1, p2) else { continue };
                let p = hit.b0 * p0 + hit.b1 * p1 + hit.b2 * p2;
                let err = triangle_error_bound(&hit, p0, p1, p2);
                let Some(n) = (p1 - p0).cross(p2 - p0).try_normalize() else { continue };
                let w = sample_uniform_sphere(rng.next_2d());
                let spawned = spawn_ray(p, err, n, w);
                if intersect_triangle(&spawned, p0, p1, p2).is_some() {
                    failures += 1;
                }
            }
            assert_eq!(
                failures, 0,
                "scale {scale}, distance {distance}: {failures} spawned rays re-hit their triangle"
            );
        }
    }
}

#[test]
fn tree_depth_is_bounded_on_adversarial_input() {
    // Triangles at exponentially growing distances make SAH splits peel one triangle at a
    // time; the median fallback must keep the tree within the traversal's bounds
    // (the CPU's stack, the GPU's 64-bit restart trail).
    let tris: Vec<[Vec3; 3]> = (0..20_000)
        .map(|i| {
            let x = 1.001f32.powi(i);
            [Vec3::new(x, 0.0, 0.0), Vec3::new(x, 1.0, 0.0), Vec3::new(x, 0.0, 1.0)]
        })
        .collect();
    let bvh = build(&tris);
    assert!(bvh.stats.max_depth <= MAX_DEPTH, "depth {} > {MAX_DEPTH}", bvh.stats.max_depth);
    // Identical triangles (all centroids equal) still make bounded leaves.
    let same = vec![[Vec3::ZERO, Vec3::X, Vec3::Y]; 1000];
    let bvh = build(&same);
    assert!(bvh.nodes.iter().all(|n| n.triangle_count() <= 8));
    let (nodes, triangles) = to_flat(&same);
    let ray = Ray { origin: Vec3::new(0.2, 0.2, 1.0), direction: -Vec3::Z, t_max: f32::MAX };
    assert!(intersect_closest(&nodes, &triangles, &ray).is_some());
}

#[test]
fn restart_trail_is_exact_on_a_deep_tree() {
    // The deepest trees there are over a row of growing squares (common::chain_tree): leaves
    // down to depth 59 (single triangles) and 60 (pairs, whose farther children are nodes
    // of their own), so rays along the row pass depth 32, where the kernel's 64-bit trail
    // crosses from one 32-bit word into the other, overlap both children at nearly every
    // level and overflow any short stack. With 0, 1, 2 and the full SHORT_STACK_SIZE
    // entries, closest and any hits equal brute force.
    for pairs in [false, true] {
        let triangles = common::deep_row(pairs);
        let nodes = common::chain_tree(&triangles, if pairs { 2 } else { 1 });
        let depths = common::leaf_depths(&nodes);
        let mut rng = Rng::new(6, 6, 6, 6);
        let (mut shallowest, mut deepest) = (u32::MAX, 0);
        for i in 0..300 {
            // Beside the axis by up to 1.5^40, so that the nearest square hit varies.
            let offset = 1.5f32.powf(rng.next_1d() * 40.0);
            let (y, z) = (rng.next_1d() * offset, rng.next_1d() * offset);
            let slant = Vec3::new(0.0, rng.next_1d() - 0.5, rng.next_1d() - 0.5) * 0.5;
            let ray = match i % 3 {
                // Along the row from either end, and from inside it.
                0 => Ray { origin: Vec3::new(0.0, y, z), direction: Vec3::X + slant, t_max: f32::MAX },
                1 => Ray { origin: Vec3::new(1e12, y, z), direction: -Vec3::X + slant, t_max: f32::MAX },
                _ => Ray {
                    origin: Vec3::new(1.5f32.powf(rng.next_1d() * 60.0), y, z),
                    direction: if i % 2 == 0 { Vec3::X } else { -Vec3::X } + slant,
                    t_max: f32::MAX,
                },
            };
            for limit in [0, 1, 2, SHORT_STACK_SIZE] {
                check_tree_against_brute_force(
                    &ShortStack { nodes: &nodes, limit },
                    &triangles,
                    &ray,
                    &format!("deep tree (pairs: {pairs}), short stack of {limit}"),
                );
            }
            if let Some(hit) = intersect_closest(&nodes, &triangles, &ray) {
                shallowest = shallowest.min(depths[hit.triangle as usize]);
                deepest = deepest.max(depths[hit.triangle as usize]);
            }
        }
        assert!(
            shallowest < 32 && deepest > 33,
            "pairs: {pairs}: the hits lie at depths {shallowest} to {deepest}: the test misses its point"
        );
    }
}
