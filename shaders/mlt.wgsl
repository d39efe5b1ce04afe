// Twin of src/integrator/mlt.rs: Metropolis light transport in primary sample space
// (Kelemen et al. 2002) with the multiplexed choice of strategy (Hachisuka, Kaplanyan &
// Dachsbacher 2014; pbrt-v4 `MLTIntegrator`), over shaders/bdpt.wgsl's strategies. A pass is
// four steps, the host between the first two (`GpuBackend::trace_mlt_pass`):
//   1. `mlt_bootstrap`: each bootstrap sample's target T (its contribution's luminance
//      times its pixel's importance, `mlt_importance`, which the host makes), an
//      independent sample from its own stream; the host reads them back and draws the
//      chains' starts by T, and the pass's normalisation b, as the CPU does
//      (`chain_starts`).
//   2. `mlt_start`: each chain runs its start sample again, which fills its primary sample.
//   3. `mlt_mutate`, over as many dispatches as it takes: each chain makes up to
//      `frame.mlt_mutations` mutations, splatting both the proposal and the current state
//      with their expected weights into `caustics` (64-bit fixed point: the sum does not
//      depend on the order).
//   4. `mlt_resolve`: the splats times b · pixels / mutations, added to the film as the
//      pass's one sample.
// Steps 1 to 3 are one entry point (`mlt_render`), step 4 another.
// A chain is one invocation; its state stays in `mlt_chains` and `mlt_numbers` between
// dispatches, and in private memory while one runs.

@group(0) @binding(27) var<storage, read_write> mlt_chains: array<MltChainGpu>;
// MLT_NUMBERS entries per chain.
@group(0) @binding(28) var<storage, read_write> mlt_numbers: array<MltNumberGpu>;
// The bootstrap samples' targets.
@group(0) @binding(29) var<storage, read_write> mlt_bootstrap_targets: array<f32>;
// Running totals, as 64-bit (low, high) word pairs: rays, accepted mutations, samples
// dropped for reading past MLT_NUMBERS_PER_STREAM.
@group(0) @binding(30) var<storage, read_write> mlt_counters: array<atomic<u32>, 6>;
// Per pixel, the weight of its paths' luminance in the target (the host's `importance_map`,
// 1 everywhere until it makes one). Only read; declared read_write because binding 31's
// layout entry is shared with photon mapping's, which writes it.
@group(0) @binding(31) var<storage, read_write> mlt_importance: array<f32>;
const MLT_COUNTER_RAYS: u32 = 0u;
const MLT_COUNTER_ACCEPTED: u32 = 2u;
const MLT_COUNTER_OVERFLOWS: u32 = 4u;

// Twins of `MLT_BOOTSTRAP_STREAM` and `MLT_CHAIN_STREAM`.
const MLT_BOOTSTRAP_STREAM: u32 = 0xfffffffcu;
const MLT_CHAIN_STREAM: u32 = 0xfffffffbu;
// Twin of `MAX_MLT_DEPTH`.
const MLT_MAX_DEPTH: u32 = 15u;

fn mlt_add_u64(word: u32, value: u32) {
    let old_low = atomicAdd(&mlt_counters[word], value);
    if (old_low > 0xffffffffu - value) {
        atomicAdd(&mlt_counters[word + 1u], 1u);
    }
}

// Twin of `scene::luminance`.
fn mlt_luminance(c: vec3<f32>) -> f32 {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// One Metropolis sample: its pixel and contribution C; `valid` false where it carries
// nothing (twin of `strategy_sample`'s None).
struct MltSample {
    pixel: u32,
    value: vec3<f32>,
    valid: bool,
}

// Twin of `strategy_sample`: a path of `depth` scattering events, its strategy (s, t)
// chosen by the camera stream's first number, a camera subpath of exactly t vertices
// through the film point of the next two, a light subpath of exactly s, no roulette, and
// the join; the value times the number of strategies (t = 1: divided by the pixels).
fn mlt_strategy_sample(depth: u32) -> MltSample {
    var out = MltSample(0u, vec3<f32>(0.0), false);
    bdpt_light_count = 0u;
    mlt_start_stream(MLT_STREAM_CAMERA);
    var s = 0u;
    var t = 2u;
    var strategies = 1u;
    if (depth > 0u) {
        let n = depth + 2u;
        s = min(u32(rng_next_1d() * f32(n)), n - 1u);
        t = n - s;
        strategies = n;
    }
    let u_film = rng_next_2d();
    if (!bdpt_strategy_is_sampled(s, t)) {
        return out;
    }
    let fx = u_film.x * f32(frame.width);
    let fy = u_film.y * f32(frame.height);
    let px = min(u32(fx), frame.width - 1u);
    let py = min(u32(fy), frame.height - 1u);
    let jitter = vec2<f32>(clamp(fx - f32(px), 0.0, 1.0), clamp(fy - f32(py), 0.0, 1.0));
    let ray = generate_camera_ray(frame.width, frame.height, px, py, jitter);
    out.pixel = py * frame.width + px;

    var x0 = bdpt_endpoint(VERTEX_CAMERA, ray.origin, camera.forward, 0u, vec3<f32>(1.0), 1.0);
    x0.delta = camera.projection != PROJECTION_PERSPECTIVE;
    bdpt_camera[0] = BdptDensities(1.0, 0.0, x0.delta);
    // x_{t−2} and x_{t−1} and the latter's surface.
    var before = x0;
    var end = x0;
    var end_si: SurfaceInteraction;
    var end_material: Material;
    var end_bsdf: GltfBsdf;
    if (t >= 2u) {
        var pdf_direction = 1.0;
        if (!x0.delta) {
            pdf_direction = bdpt_camera_pdf_direction(ray.direction);
        }
        var walk = bdpt_walk_new(ray, vec3<f32>(1.0), pdf_direction, false);
        walk.roulette = false;
        var prev = x0;
        var here = 1u;
        loop {
            var v: BdptVertex;
            var si: SurfaceInteraction;
            var material: Material;
            var bsdf: GltfBsdf;
            if (!bdpt_trace(&walk, prev, &v, &si, &material, &bsdf)) {
                return out;
            }
            bdpt_camera[bdpt_camera_slot(here)] = BdptDensities(v.pdf_fwd, 0.0, false);
            here += 1u;
            if (here == t) {
                before = prev;
                end = v;
                end_si = si;
                end_material = material;
                end_bsdf = bsdf;
                break;
            }
            if (v.kind == VERTEX_ENVIRONMENT) {
                return out;
            }
            let rev = bdpt_scatter(&walk, &v, si, bsdf, prev, here - 1u);
            if (rev < 0.0) {
                return out;
            }
            bdpt_camera[bdpt_camera_slot(here - 2u)].rev = rev;
            bdpt_camera[bdpt_camera_slot(here - 1u)].delta = v.delta;
            prev = v;
        }
    }

    mlt_start_stream(MLT_STREAM_LIGHT);
    if (s >= 2u) {
        bdpt_light_subpath(s);
        if (bdpt_light_count != s) {
            return out;
        }
    }

    mlt_start_stream(MLT_STREAM_CONNECTION);
    var value: vec3<f32>;
    if (t == 1u) {
        let j = bdpt_join_camera_value(x0, s);
        if (!j.valid) {
            return out;
        }
        out.pixel = j.pixel;
        value = j.value / (f32(frame.width) * f32(frame.height));
    } else if (s == 0u) {
        value = bdpt_emitter_hit(end, before, end_si, end_material, t);
    } else if (s == 1u) {
        value = bdpt_join_light_sample(end, before, end_si, end_bsdf, t);
    } else {
        value = bdpt_join(end, before, end_si, end_material, end_bsdf, s, t);
    }
    value *= f32(strategies);
    out.value = value;
    // A sample that read past the numbers' bound is dropped (and counted by the caller).
    out.valid = is_finite_vec3(value) && max_element(value) > 0.0 && !mlt_overflow;
    return out;
}

// The target T of a sample (twin of `State::of`).
fn mlt_target(sample: MltSample) -> f32 {
    if (!sample.valid) {
        return 0.0;
    }
    return max(mlt_luminance(sample.value), 0.0) * mlt_importance[sample.pixel];
}

// This dispatch's item (bootstrap sample or chain) for `gid` (`dispatch_item`).
fn mlt_item(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return dispatch_item(gid, groups, frame.mlt_items);
}

fn mlt_depths() -> u32 {
    return min(frame.max_depth, MLT_MAX_DEPTH) + 1u;
}

// The chain's numbers between dispatches: entries [c · MLT_NUMBERS, + used).
fn mlt_store_numbers(c: u32) {
    for (var i = 0u; i < mlt_used; i++) {
        mlt_numbers[c * MLT_NUMBERS + i] = mlt_numbers_private[i];
    }
}

// A step of the chain's acceptance stream (twin of `Chain::rng`), kept apart from the
// sampler's own (`rng_s`).
var<private> mlt_chain_rng: vec4<u32>;

fn mlt_chain_next_1d() -> f32 {
    let sampler_rng = rng_s;
    rng_s = mlt_chain_rng;
    let u = fraction_to_f32(xoshiro_next());
    mlt_chain_rng = rng_s;
    rng_s = sampler_rng;
    return u;
}

// 1. Bootstrap sample i's target (twin of `mlt_pass`'s bootstrap).
fn mlt_bootstrap(i: u32) {
    xoshiro_seed(vec4<u32>(i, MLT_BOOTSTRAP_STREAM, frame.sample_offset, frame.seed));
    mlt_sampler_fresh();
    let sample = mlt_strategy_sample(i % mlt_depths());
    mlt_bootstrap_targets[i] = mlt_target(sample);
    if (mlt_overflow) {
        mlt_add_u64(MLT_COUNTER_OVERFLOWS, 1u);
    }
}

// 2. Chain c's first state: its bootstrap sample run again from the same stream, which
// fills its primary sample (twin of `mlt_pass`'s chain starts). The host wrote its start,
// depth and mutations.
fn mlt_start(c: u32, chain: ptr<function, MltChainGpu>) {
    xoshiro_seed(vec4<u32>((*chain).start, MLT_BOOTSTRAP_STREAM, frame.sample_offset, frame.seed));
    mlt_sampler_fresh();
    let sample = mlt_strategy_sample((*chain).depth);
    (*chain).value = select(vec3<f32>(0.0), sample.value, sample.valid);
    (*chain).scalar_target = mlt_target(sample);
    (*chain).pixel = select(0u, sample.pixel, sample.valid);
    (*chain).started = 1u;
    // The chain's own stream, past the draw that chose its start (`chain_starts`).
    let sampler_rng = rng_s;
    xoshiro_seed(vec4<u32>(c, MLT_CHAIN_STREAM, frame.sample_offset, frame.seed));
    xoshiro_next();
    mlt_chain_rng = rng_s;
    rng_s = sampler_rng;
}

// The chain's sampler as the last dispatch left it.
fn mlt_load(c: u32, chain: MltChainGpu) {
    mlt_sampler_fresh();
    for (var i = 0u; i < chain.used; i++) {
        mlt_numbers_private[i] = mlt_numbers[c * MLT_NUMBERS + i];
    }
    mlt_used = chain.used;
    mlt_iteration = chain.iteration;
    mlt_last_large_step = chain.last_large_step;
    rng_s = chain.sampler_rng;
    mlt_chain_rng = chain.chain_rng;
}

// 3. Up to `n` of the chain's mutations (twin of `Chain::run`).
fn mlt_mutate(chain: ptr<function, MltChainGpu>, n: u32) {
    var accepted = 0u;
    var overflows = 0u;
    for (var m = 0u; m < n; m++) {
        mlt_start_iteration();
        let proposal = mlt_strategy_sample((*chain).depth);
        if (mlt_overflow) {
            overflows += 1u;
        }
        let proposal_target = mlt_target(proposal);
        let current_target = (*chain).scalar_target;
        var accept = 1.0;
        if (current_target > 0.0) {
            accept = min(proposal_target / current_target, 1.0);
        }
        if (proposal_target > 0.0 && accept > 0.0) {
            caustic_splat(proposal.pixel, proposal.value * (accept / proposal_target));
        }
        if (current_target > 0.0 && accept < 1.0) {
            caustic_splat((*chain).pixel, (*chain).value * ((1.0 - accept) / current_target));
        }
        if (mlt_chain_next_1d() < accept) {
            (*chain).value = select(vec3<f32>(0.0), proposal.value, proposal.valid);
            (*chain).pixel = select(0u, proposal.pixel, proposal.valid);
            (*chain).scalar_target = proposal_target;
            mlt_accept();
            accepted += 1u;
        } else {
            mlt_reject();
        }
    }
    (*chain).remaining -= n;
    mlt_add_u64(MLT_COUNTER_ACCEPTED, accepted);
    if (overflows > 0u) {
        mlt_add_u64(MLT_COUNTER_OVERFLOWS, overflows);
    }
}

// Steps 1 to 3 in one entry point, so that a driver compiles the strategy sample once:
// with `frame.mlt_mutations` 0, bootstrap sample i; otherwise chain i, started if it has
// not been, then up to `frame.mlt_mutations` of its mutations.
@compute @workgroup_size(8, 8, 1)
fn mlt_render(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    load_dispatch_constants();
    let i = mlt_item(gid, groups);
    if (i == INVALID_INDEX) {
        return;
    }
    rays_traced = 0u;
    if (frame.mlt_mutations == 0u) {
        mlt_bootstrap(i);
        mlt_add_u64(MLT_COUNTER_RAYS, rays_traced);
        return;
    }
    var chain = mlt_chains[i];
    let n = min(frame.mlt_mutations, chain.remaining);
    if (chain.started == 0u) {
        mlt_start(i, &chain);
    } else if (n == 0u) {
        return;
    } else {
        mlt_load(i, chain);
    }
    mlt_mutate(&chain, n);
    chain.sampler_rng = rng_s;
    chain.chain_rng = mlt_chain_rng;
    chain.iteration = mlt_iteration;
    chain.last_large_step = mlt_last_large_step;
    chain.used = mlt_used;
    mlt_store_numbers(i);
    mlt_chains[i] = chain;
    mlt_add_u64(MLT_COUNTER_RAYS, rays_traced);
}

// 4. The pass's image over the band: the summed splats times b · pixels / mutations
// (`frame.mlt_scale`), added to the film as its one sample.
@compute @workgroup_size(8, 8, 1)
fn mlt_resolve(@builtin(global_invocation_id) gid: vec3<u32>) {
    load_dispatch_constants();
    let px = band_pixel(gid);
    if (px.z == 0u) {
        return;
    }
    let pixel = px.y * frame.width + px.x;
    let x = caustic_radiance(pixel) * frame.mlt_scale;
    film[pixel] = film_add_sample(film[pixel], x, replicate_of(frame.sample_offset));
}
