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
// src/bvh/traverse.rs). With `any_hit` it returns at the first hit found (shadow rays);
// otherwise the nearest hit.
fn traverse(ray_in: Ray, any_hit: bool, alpha_seed: u32) -> ClosestHit {
    rays_traced += 1u;
    var ray = ray_in;
    var best = ClosestHit(INVALID_INDEX, vec3<f32>(0.0), 0.0);
    let dir_is_neg = ray.direction < vec3<f32>(0.0);
    let pre = ray_box_precomp(ray);
    var stack: array<u32, TRAVERSAL_STACK_SIZE>;
    var sp = 0u;
    var current = 0u;
    loop {
        let node = nodes[current];
        if (intersect_box(pre, ray.t_max, node.bounds_min, node.bounds_max)) {
            let count = node_triangle_count(node);
            if (count > 0u) {
                for (var i = node.offset; i < node.offset + count; i++) {
                    let tri = triangles[i];
                    let hit = intersect_triangle(ray, tri.p0, tri.p1, tri.p2);
                    if (hit.valid && (!FEATURE_ALPHA || alpha_accepts(i, hit.b, alpha_seed))) {
                        ray.t_max = hit.t;
                        best = ClosestHit(i, hit.b, hit.t);
                        if (any_hit) {
                            return best;
                        }
                    }
                }
            } else {
                var near = current + 1u;
                var far = node.offset;
                if (dir_is_neg[node_axis(node)]) {
                    near = node.offset;
                    far = current + 1u;
                }
                stack[sp] = far;
                sp += 1u;
                current = near;
                continue;
            }
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
