// Twin of src/bvh/traverse.rs: stack-based traversal of the flat BVH, nearer child first.

const TRAVERSAL_STACK_SIZE: u32 = 64u;

// Rays this invocation has traced (closest-hit and any-hit), for throughput reporting.
var<private> rays_traced: u32;

struct ClosestHit {
    triangle: u32,
    b: vec3<f32>,
    t: f32,
}

fn node_triangle_count(n: BvhNode) -> u32 {
    return n.count_axis & 0xffffu;
}

fn node_axis(n: BvhNode) -> u32 {
    return (n.count_axis >> 16u) & 3u;
}

// Visits the leaves the ray may touch, nearer child first (twin of `traverse` in
// src/bvh/traverse.rs: both children's boxes are tested at their parent, the farther one
// deferred). With `any_hit` it returns at the first hit found (shadow rays); otherwise the
// nearest hit. Unlike the CPU twin it keeps no entry distances to drop deferred children
// whose entry lies beyond the nearest hit: a second private array cost as much on lavapipe
// as the culling saved (bunny in the Cornell box: 0.088 vs 0.089 Msamples/s; Cornell box
// 5% slower). The hits found are the same either way.
fn traverse(ray_in: Ray, any_hit: bool, alpha_seed: u32) -> ClosestHit {
    rays_traced += 1u;
    var ray = ray_in;
    var best = ClosestHit(INVALID_INDEX, vec3<f32>(0.0), 0.0);
    let pre = ray_box_precomp(ray);
    let tri_pre = ray_triangle_precomp(ray);
    if (box_entry(pre, ray.t_max, nodes[0].bounds_min, nodes[0].bounds_max) < 0.0) {
        return best;
    }
    var stack: array<u32, TRAVERSAL_STACK_SIZE>;
    var sp = 0u;
    var current = 0u;
    loop {
        let node = nodes[current];
        let count = node_triangle_count(node);
        var descend = false;
        if (count > 0u) {
            for (var i = node.offset; i < node.offset + count; i++) {
                let tri = triangles[i];
                let hit = intersect_triangle_precomp(tri_pre, ray.t_max, tri.p0, tri.p1, tri.p2);
                if (hit.valid && (!FEATURE_ALPHA || alpha_accepts(i, hit.b, alpha_seed))) {
                    ray.t_max = hit.t;
                    best = ClosestHit(i, hit.b, hit.t);
                    if (any_hit) {
                        return best;
                    }
                }
            }
        } else {
            let first = current + 1u;
            let second = node.offset;
            let a = box_entry(pre, ray.t_max, nodes[first].bounds_min, nodes[first].bounds_max);
            let b = box_entry(pre, ray.t_max, nodes[second].bounds_min, nodes[second].bounds_max);
            if (a >= 0.0 && b >= 0.0) {
                let first_nearer = a <= b;
                stack[sp] = select(first, second, first_nearer);
                sp += 1u;
                current = select(second, first, first_nearer);
                descend = true;
            } else if (a >= 0.0) {
                current = first;
                descend = true;
            } else if (b >= 0.0) {
                current = second;
                descend = true;
            }
        }
        if (descend) {
            continue;
        }
        if (sp == 0u) {
            break;
        }
        sp -= 1u;
        current = stack[sp];
    }
    return best;
}

// The nearest intersection in (0, ray.t_max); alpha-tested hits by `alpha_seed`.
fn intersect_closest(ray: Ray, alpha_seed: u32) -> ClosestHit {
    return traverse(ray, false, alpha_seed);
}

// Is anything hit in (0, ray.t_max)? (Shadow rays.)
fn intersect_any(ray: Ray, alpha_seed: u32) -> bool {
    return traverse(ray, true, alpha_seed).triangle != INVALID_INDEX;
}
