// Twin of src/bvh/traverse.rs: traversal of the flat BVH, nearer child first, with a short
// stack in registers and a restart trail instead of a full stack (Laine 2010, "Restart Trail
// for Stackless BVH Traversal", HPG): no private array at all.

// Deferred children the short stack holds in its two vec4<u32> registers.
const SHORT_STACK_SIZE: u32 = 8u;
// How many of them it may use: all, except in tests, which lower it (0: a restart from the
// root after every leaf) to show that the image does not depend on it.
override SHORT_STACK_LIMIT: u32 = SHORT_STACK_SIZE;

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

// The restart trail's 64 bits as (bits 63..32, bits 31..0): depth d (1 ..= 64, the root's
// children 1) is bit 64 − d, so deeper levels are less significant and marking a node done is
// one addition whose carry moves up past the levels finished with it (Laine 2010 §3). WGSL has
// no 64-bit integers; the twin's u64 operations are spelt out on the two words. A tree no
// deeper than 32 levels below its root (every scene without FEATURE_DEEP_TREE) uses only the
// first, and the second's arithmetic folds away.
fn trail_bit(depth: u32) -> vec2<u32> {
    if (!FEATURE_DEEP_TREE || depth <= 32u) {
        return vec2<u32>(1u << (32u - depth), 0u);
    }
    return vec2<u32>(0u, 1u << (64u - depth));
}

fn trail_has(trail: vec2<u32>, depth: u32) -> bool {
    return any((trail & trail_bit(depth)) != vec2<u32>(0u));
}

// `trail`'s bits for depths 1 ..= `depth` (1 ..= 64).
fn trail_through(trail: vec2<u32>, depth: u32) -> vec2<u32> {
    if (!FEATURE_DEEP_TREE || depth <= 32u) {
        return vec2<u32>(trail.x & (0xffffffffu << (32u - depth)), 0u);
    }
    return vec2<u32>(trail.x, trail.y & (0xffffffffu << (64u - depth)));
}

// The trail once the node at `depth` (≥ 1) is done: its deeper bits cleared and its own bit
// added with carry. Zero when the carry leaves the top: the whole tree is done.
fn trail_pop(trail: vec2<u32>, depth: u32) -> vec2<u32> {
    let kept = trail_through(trail, depth);
    let bit = trail_bit(depth);
    if (!FEATURE_DEEP_TREE) {
        return vec2<u32>(kept.x + bit.x, 0u);
    }
    let low = kept.y + bit.y;
    return vec2<u32>(kept.x + bit.x + select(0u, 1u, low < kept.y), low);
}

fn trail_is_empty(trail: vec2<u32>) -> bool {
    return trail.x == 0u && (!FEATURE_DEEP_TREE || trail.y == 0u);
}

// The depth of the trail's lowest set bit (trail ≠ 0).
fn trail_depth(trail: vec2<u32>) -> u32 {
    if (FEATURE_DEEP_TREE && trail.y != 0u) {
        return 64u - countTrailingZeros(trail.y);
    }
    return 32u - countTrailingZeros(trail.x);
}

// Twin of `Trail`: per depth on the path to the current node, `passed` says the traversal is
// in the last child it will visit there, `single` that it is the only child the ray
// overlapped (src/bvh/traverse.rs explains why a restart needs both).
struct Trail {
    passed: vec2<u32>,
    single: vec2<u32>,
}

// Where traversal goes from an interior node: the child to visit next (`descend` false when
// neither) and, when the ray overlaps both and the nearer is next, the farther one to defer.
struct ChildStep {
    next: u32,
    descend: bool,
    deferred: u32,
    defer: bool,
    trail: Trail,
}

// Both children's boxes are tested at their parent; the first is stored right after it, the
// second at its offset. Which is nearer is decided from their entry distances without
// `t_max` (ties: the first), so that it reads the same when a restart comes back with a
// shorter `t_max`; only then is each tested against `t_max`.
fn child_step(pre: TraversalPrecomp, t_max: f32, current: u32, node: BvhNode, depth: u32, trail: Trail) -> ChildStep {
    let first = current + 1u;
    let second = node.offset;
    let a = box_entry(pre.boxes, F32_MAX, nodes[first].bounds_min, nodes[first].bounds_max);
    let b = box_entry(pre.boxes, F32_MAX, nodes[second].bounds_min, nodes[second].bounds_max);
    let first_nearer = a >= 0.0 && (b < 0.0 || a <= b);
    let near = select(second, first, first_nearer);
    let far = select(first, second, first_nearer);
    let near_entry = select(b, a, first_nearer);
    let far_entry = select(a, b, first_nearer);
    let hit_near = near_entry >= 0.0 && entry_within(near_entry, t_max);
    let hit_far = far_entry >= 0.0 && entry_within(far_entry, t_max);

    let child = depth + 1u;
    let bit = trail_bit(child);
    let passed = trail_has(trail.passed, child);
    // The nearer of two is done: only the farther may be left.
    let far_only = passed && !trail_has(trail.single, child);
    let one_hit = hit_near != hit_far;
    let new_level = !passed && one_hit;
    // The nearer child culled: whatever the trail held below it is moot (the twin says why
    // a restart never meets this).
    let kept = select(trail.passed, trail_through(trail.passed, child), hit_far);
    return ChildStep(
        select(select(far, near, hit_near), far, far_only),
        select(hit_near || hit_far, hit_far, far_only),
        far,
        !passed && hit_near && hit_far,
        Trail(
            select(trail.passed, kept | bit, new_level),
            select(trail.single, select(trail.single & ~bit, trail.single | bit, one_hit), !passed),
        ),
    );
}

// Visits the leaves the ray may touch, nearer child first (twin of
// `traverse_with_short_stack`): the closest hit, or with `any_hit` the first hit found
// (shadow rays). Up to SHORT_STACK_LIMIT deferred children wait in two vec4<u32> registers,
// the latest in stack_low.x; a deeper deferral pushes the oldest out, and when the registers
// run dry the traversal descends from the root again along its trail. Lavapipe keeps a
// private array in memory and writes it lane by lane, and the array stack this replaced
// cost it more than its writes. A deferred child is not tested against the nearest hit
// again when it is taken up: its entry distance held beside it cost lavapipe more than the
// culling saved. The hits found are the same either way (both measured:
// bench/history/lavapipe.md).
//
// The loop is "while-while" (Aila & Laine 2009, "Understanding the Efficiency of Ray
// Traversal on GPUs", HPG, §3): an inner loop descends through interior nodes until the ray
// reaches a leaf or a node none of whose children it needs, and only then is a leaf tested
// and the trail popped. A group of lanes that runs as one (8 on lavapipe, 32 on NVIDIA) thus
// steps interior nodes together and tests leaves together, instead of paying for both kinds
// of step at every iteration, as the one-loop "if-if" form did: lavapipe's `if` only masks
// lanes off, without a branch (Mesa's gallivm, `lp_exec_mask_cond_push`). Each ray visits
// the same nodes in the same order as before (what it gained on lavapipe:
// bench/history/lavapipe.md, "The GPU's traversal in while-while form").
fn traverse(ray_in: Ray, any_hit: bool, alpha_seed: u32) -> ClosestHit {
    rays_traced += 1u;
    var ray = ray_in;
    var best = ClosestHit(INVALID_INDEX, vec3<f32>(0.0), 0.0);
    let pre = TraversalPrecomp(ray_box_precomp(ray), ray_triangle_precomp(ray));
    if (box_entry(pre.boxes, ray.t_max, nodes[0].bounds_min, nodes[0].bounds_max) < 0.0) {
        return best;
    }
    let stack_limit = min(SHORT_STACK_LIMIT, SHORT_STACK_SIZE);
    var stack_low = vec4<u32>(0u);
    var stack_high = vec4<u32>(0u);
    var sp = 0u;
    var trail = Trail(vec2<u32>(0u), vec2<u32>(0u));
    var current = 0u;
    var depth = 0u;
    loop {
        // Down through interior nodes until a leaf, or a node none of whose children the ray
        // needs.
        var node = nodes[current];
        loop {
            if (node_triangle_count(node) > 0u) {
                break;
            }
            let step = child_step(pre, ray.t_max, current, node, depth, trail);
            trail = step.trail;
            if (!step.descend) {
                break;
            }
            if (step.defer) {
                stack_high = vec4<u32>(stack_low.w, stack_high.xyz);
                stack_low = vec4<u32>(step.deferred, stack_low.xyz);
                sp = min(sp + 1u, stack_limit);
            }
            current = step.next;
            depth += 1u;
            node = nodes[current];
        }
        if (node_triangle_count(node) > 0u) {
            if (visit_leaf(node, pre, any_hit, alpha_seed, &ray, &best)) {
                return best;
            }
        }
        // `current` is done, and with it every ancestor whose last child it was.
        if (depth == 0u) {
            break;
        }
        trail.passed = trail_pop(trail.passed, depth);
        if (trail_is_empty(trail.passed)) {
            break;
        }
        depth = trail_depth(trail.passed);
        if (sp > 0u) {
            // The farther child deferred at `depth`: the latest deferral still pending.
            current = stack_low.x;
            stack_low = vec4<u32>(stack_low.yzw, stack_high.x);
            stack_high = vec4<u32>(stack_high.yzw, 0u);
            sp -= 1u;
        } else {
            // Its deferral was pushed out: down from the root again, along the trail.
            current = 0u;
            depth = 0u;
        }
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
