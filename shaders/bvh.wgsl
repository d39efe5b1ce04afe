// Twin of src/bvh/traverse.rs: stack-based traversal of the flat BVH, nearer child first,
// in two tiers: with the stack in registers while it fits, else with an array stack.

const TRAVERSAL_STACK_SIZE: u32 = 64u;
// Deferred children the register stack of `traverse_in_registers` holds.
const REGISTER_STACK_SIZE: u32 = 8u;
// How many of them it may use before the traversal starts over with the array stack: all
// of them, except in tests, which lower it (0: always the array stack) to show that both
// tiers give the same image.
override REGISTER_STACK_LIMIT: u32 = REGISTER_STACK_SIZE;

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

// Per-ray constants of the box and triangle tests.
struct TraversalPrecomp {
    boxes: RayBoxPrecomp,
    triangles: RayTrianglePrecomp,
}

// Tests the triangles of `leaf`, shortening `ray` to each accepted hit and recording it in
// `best`; true when an any-hit query may stop.
fn visit_leaf(leaf: BvhNode, pre: TraversalPrecomp, any_hit: bool, alpha_seed: u32, ray: ptr<function, Ray>, best: ptr<function, ClosestHit>) -> bool {
    let count = node_triangle_count(leaf);
    for (var i = leaf.offset; i < leaf.offset + count; i++) {
        let tri = triangles[i];
        let hit = intersect_triangle_precomp(pre.triangles, (*ray).t_max, tri.p0, tri.p1, tri.p2);
        if (hit.valid && (!FEATURE_ALPHA || alpha_accepts(i, hit.b, alpha_seed))) {
            (*ray).t_max = hit.t;
            *best = ClosestHit(i, hit.b, hit.t);
            if (any_hit) {
                return true;
            }
        }
    }
    return false;
}

// Where traversal goes from interior node `current`: the child to visit next (`descend`
// false when the ray misses both) and, when it overlaps both, the farther one to defer.
struct ChildStep {
    next: u32,
    descend: bool,
    deferred: u32,
    defer: bool,
}

// Both children's boxes are tested at their parent; the first is stored right after it, the
// second at its offset. The nearer of two overlapped children goes first (ties: the first).
fn child_step(pre: TraversalPrecomp, t_max: f32, current: u32, node: BvhNode) -> ChildStep {
    let first = current + 1u;
    let second = node.offset;
    let a = box_entry(pre.boxes, t_max, nodes[first].bounds_min, nodes[first].bounds_max);
    let b = box_entry(pre.boxes, t_max, nodes[second].bounds_min, nodes[second].bounds_max);
    let first_next = a >= 0.0 && (b < 0.0 || a <= b);
    return ChildStep(
        select(second, first, first_next),
        a >= 0.0 || b >= 0.0,
        select(first, second, first_next),
        a >= 0.0 && b >= 0.0,
    );
}

// Visits the leaves the ray may touch, nearer child first (twin of `traverse` in
// src/bvh/traverse.rs: both children's boxes are tested at their parent, the farther one
// deferred). With `any_hit` it returns at the first hit found (shadow rays); otherwise the
// nearest hit. Unlike the CPU twin it keeps no entry distances to drop deferred children
// whose entry lies beyond the nearest hit: a second private array cost as much on lavapipe
// as the culling saved (bunny in the Cornell box: 0.088 vs 0.089 Msamples/s; Cornell box
// 5% slower). The hits found are the same either way.
fn traverse_with_stack(ray_in: Ray, any_hit: bool, alpha_seed: u32) -> ClosestHit {
    var ray = ray_in;
    var best = ClosestHit(INVALID_INDEX, vec3<f32>(0.0), 0.0);
    let pre = TraversalPrecomp(ray_box_precomp(ray), ray_triangle_precomp(ray));
    if (box_entry(pre.boxes, ray.t_max, nodes[0].bounds_min, nodes[0].bounds_max) < 0.0) {
        return best;
    }
    var stack: array<u32, TRAVERSAL_STACK_SIZE>;
    var sp = 0u;
    var current = 0u;
    loop {
        let node = nodes[current];
        var descend = false;
        if (node_triangle_count(node) > 0u) {
            if (visit_leaf(node, pre, any_hit, alpha_seed, &ray, &best)) {
                return best;
            }
        } else {
            let step = child_step(pre, ray.t_max, current, node);
            if (step.defer) {
                stack[sp] = step.deferred;
                sp += 1u;
            }
            current = step.next;
            descend = step.descend;
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

struct RegisterTraversal {
    hit: ClosestHit,
    // A child more had to be deferred than the registers hold; `hit` is then incomplete.
    overflowed: bool,
}

// `traverse_with_stack` with its stack in two vec4<u32> registers, shifted on each push and
// pop, instead of a private array. Lavapipe keeps a private array in memory and writes it
// lane by lane, reading masked-off lanes' old values back (13% of its render time), and the
// array's presence cost more: the Cornell box renders 1.3× faster without it
// (bench/RESULTS.md).
fn traverse_in_registers(ray_in: Ray, any_hit: bool, alpha_seed: u32) -> RegisterTraversal {
    var ray = ray_in;
    var best = ClosestHit(INVALID_INDEX, vec3<f32>(0.0), 0.0);
    let pre = TraversalPrecomp(ray_box_precomp(ray), ray_triangle_precomp(ray));
    if (box_entry(pre.boxes, ray.t_max, nodes[0].bounds_min, nodes[0].bounds_max) < 0.0) {
        return RegisterTraversal(best, false);
    }
    // The deferred children, the latest in stack_low.x, then .y, .z, .w, stack_high.x, ….
    var stack_low = vec4<u32>(0u);
    var stack_high = vec4<u32>(0u);
    var sp = 0u;
    var current = 0u;
    loop {
        let node = nodes[current];
        var descend = false;
        if (node_triangle_count(node) > 0u) {
            if (visit_leaf(node, pre, any_hit, alpha_seed, &ray, &best)) {
                return RegisterTraversal(best, false);
            }
        } else {
            let step = child_step(pre, ray.t_max, current, node);
            if (step.defer) {
                if (sp >= min(REGISTER_STACK_LIMIT, REGISTER_STACK_SIZE)) {
                    return RegisterTraversal(best, true);
                }
                stack_high = vec4<u32>(stack_low.w, stack_high.xyz);
                stack_low = vec4<u32>(step.deferred, stack_low.xyz);
                sp += 1u;
            }
            current = step.next;
            descend = step.descend;
        }
        if (descend) {
            continue;
        }
        if (sp == 0u) {
            break;
        }
        sp -= 1u;
        current = stack_low.x;
        stack_low = vec4<u32>(stack_low.yzw, stack_high.x);
        stack_high = vec4<u32>(stack_high.yzw, 0u);
    }
    return RegisterTraversal(best, false);
}

// Visits the leaves in `traverse_with_stack`'s order: in registers while at most
// REGISTER_STACK_SIZE children are deferred (every ray in a Cornell box, most rays of a
// 10⁴-triangle scene), else over again from the root with the array stack. Both visit the
// same leaves in the same order up to the overflow, so the result is `traverse_with_stack`'s
// either way. Lavapipe skips the array tier whenever no lane of a SIMD group needs it.
fn traverse(ray: Ray, any_hit: bool, alpha_seed: u32) -> ClosestHit {
    rays_traced += 1u;
    let fast = traverse_in_registers(ray, any_hit, alpha_seed);
    if (!fast.overflowed) {
        return fast.hit;
    }
    return traverse_with_stack(ray, any_hit, alpha_seed);
}

// The nearest intersection in (0, ray.t_max); alpha-tested hits by `alpha_seed`.
fn intersect_closest(ray: Ray, alpha_seed: u32) -> ClosestHit {
    return traverse(ray, false, alpha_seed);
}

// Is anything hit in (0, ray.t_max)? (Shadow rays.)
fn intersect_any(ray: Ray, alpha_seed: u32) -> bool {
    return traverse(ray, true, alpha_seed).triangle != INVALID_INDEX;
}
