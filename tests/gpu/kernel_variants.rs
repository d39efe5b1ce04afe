//! Kernel variants (table forms, the traversal's short stack and restart trail) that must
//! leave every pixel's statistics bit for bit the same.

use super::textures::flat_scene_from_gltf;
use super::*;

/// How many pixels' statistics (sample counts, means, M2) differ in any bit.
fn pixels_not_bit_equal(a: &Film, b: &Film) -> usize {
    a.pixels.iter().zip(&b.pixels).filter(|(p, q)| bytemuck::bytes_of(*p) != bytemuck::bytes_of(*q)).count()
}

#[test]
fn uniform_and_storage_tables_give_the_same_image() {
    // A software adapter reads the scene's small tables from uniform buffers where they fit
    // (src/gpu/tables.rs); the same loads from a storage buffer return the same records, so
    // every form must leave every pixel's statistics bit for bit the same. Split samples (the
    // split vertex is re-shaded from its hit) and the light tracer's kernel are covered: the
    // caustic-mirror scene light-traces its caustics.
    let Some(ctx) = common::gpu() else { return };
    let size = 24;
    for (file, splits) in [("cornell-box.gltf", 3), ("hard/caustic-mirror.gltf", 1)] {
        let scene = common::flat_scene(&common::scene(file), size, size);
        let s = RenderSettings { splits, light_tracing: true, ..settings(size, 4, 9) };
        let render = |tables: pathlight::gpu::UniformTables| {
            let kernel = ctx
                .kernel(KernelKey {
                    tables,
                    ..KernelKey::new(Integrator::Path, scene.features, s.splitting())
                })
                .unwrap();
            let mut backend = GpuBackend::with_kernel(ctx.clone(), kernel, &scene, &s).unwrap();
            (common::render(&mut backend, 4), backend.light_traces_caustics())
        };
        let (storage, light_traced) = render(pathlight::gpu::UniformTables::default());
        assert_eq!(light_traced, file.contains("caustic"), "{file}: light tracing");
        let some = pathlight::gpu::UniformTables { nodes: true, materials: true, ..Default::default() };
        for tables in [pathlight::gpu::UniformTables::ALL, some] {
            let (uniform, _) = render(tables);
            let differing = pixels_not_bit_equal(&storage, &uniform);
            assert_eq!(differing, 0, "{file}, {tables:?}: {differing} of {} pixels differ", size * size);
        }
    }
    // Which forms an adapter picks: on a software one every table that fits (the Cornell
    // box's all do; the glass scene's 20,187 nodes and 10,252 triangles do not), on a
    // hardware GPU none.
    let small = common::flat_scene(&common::scene("cornell-box.gltf"), size, size);
    let large = common::flat_scene(&common::scene("cornell-spheres.gltf"), size, size);
    if ctx.prefers_uniform_tables() {
        assert_eq!(ctx.tables_for(&small), pathlight::gpu::UniformTables::ALL);
        let t = ctx.tables_for(&large);
        assert!(!t.nodes && !t.triangles && t.materials && t.lights, "{t:?}");
    } else {
        assert_eq!(ctx.tables_for(&small), pathlight::gpu::UniformTables::default());
    }
    // A kernel whose uniform tables cannot hold a scene is refused, naming the table.
    let kernel = ctx
        .kernel(KernelKey {
            tables: pathlight::gpu::UniformTables::ALL,
            ..KernelKey::new(Integrator::Path, large.features, false)
        })
        .unwrap();
    let e =
        GpuBackend::with_kernel(ctx.clone(), kernel, &large, &settings(size, 1, 1)).map(|_| ()).unwrap_err();
    assert!(e.to_string().contains("nodes from a uniform buffer of 2048 records"), "{e}");
}

/// The path tracer's unsplit kernel for `scene` whose traversal keeps `limit` deferred
/// children instead of `SHORT_STACK_SIZE`.
fn short_stack_kernel(
    ctx: &pathlight::gpu::GpuContext,
    scene: &pathlight::scene::FlatScene,
    limit: u32,
) -> std::sync::Arc<pathlight::gpu::Kernel> {
    ctx.kernel(KernelKey {
        short_stack_limit: limit,
        ..KernelKey::new(Integrator::Path, scene.features, false)
    })
    .unwrap()
}

#[test]
fn short_stack_size_does_not_change_the_image() {
    // The traversal keeps up to SHORT_STACK_SIZE deferred children in registers, pushing the
    // oldest out, and restarts from the root along its trail when they run out
    // (shaders/bvh.wgsl). It visits the leaves in the same order whatever the stack holds,
    // less those a nearer hit culls, so lowering the limit, to 0 (a restart after every leaf)
    // or to 2 (the 10⁴-triangle spheres overflow it on most rays), must leave every pixel's
    // statistics bit for bit the same: the same triangle and barycentrics from the same
    // arithmetic.
    let Some(ctx) = common::gpu() else { return };
    let (size, spp) = (24, 4);
    let scene = common::flat_scene(&common::scene("cornell-spheres.gltf"), size, size);
    let render = |limit: u32| {
        let kernel = short_stack_kernel(&ctx, &scene, limit);
        let mut backend =
            GpuBackend::with_kernel(ctx.clone(), kernel, &scene, &settings(size, spp, 3)).unwrap();
        let film = common::render(&mut backend, spp);
        (film, backend.first_hits().unwrap())
    };
    let (full, full_hits) = render(pathlight::bvh::SHORT_STACK_SIZE as u32);
    for limit in [0, 2] {
        let (short, short_hits) = render(limit);
        let differing = pixels_not_bit_equal(&full, &short);
        assert_eq!(differing, 0, "limit {limit}: {differing} of {} pixels differ", size * size);
        assert!(
            bytemuck::cast_slice::<_, u8>(&full_hits) == bytemuck::cast_slice::<_, u8>(&short_hits),
            "limit {limit}: the first hits differ"
        );
    }
}

/// `common::deep_row(pairs)` seen by a camera at (0, offset, offset) that looks along +x, in
/// the deepest tree there is over it (`common::chain_tree`) instead of the builder's. The
/// camera's rays pass beside the squares smaller than about 2·offset and hit the next.
fn deep_chain_scene(pairs: bool, offset: f32) -> pathlight::scene::FlatScene {
    use serde_json::json;
    let row = common::deep_row(pairs);
    let mut bin: Vec<u8> = Vec::new();
    for t in &row {
        for v in t.p0.iter().chain(&t.p1).chain(&t.p2) {
            bin.extend_from_slice(&v.to_le_bytes());
        }
    }
    let extent = row.last().unwrap().p0[0];
    let doc = json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0, 1]}],
        // glTF cameras look along −z; a quarter turn about y makes that +x.
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0.0, offset, offset], "rotation": [0.0, -std::f32::consts::FRAC_1_SQRT_2, 0.0, std::f32::consts::FRAC_1_SQRT_2]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.01}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3 * row.len(), "type": "VEC3", "min": [1.0, 0.0, 0.0], "max": [extent, extent, extent]}],
        "bufferViews": [{"buffer": 0, "byteLength": bin.len()}],
        "buffers": [{"byteLength": bin.len(), "uri": common::buffer_data_uri(&bin)}]
    });
    let mut scene = flat_scene_from_gltf("deep-chain.gltf", &doc);
    assert!(scene.texcoords.is_empty() && scene.tangents.is_empty());
    // Back in the row's order (nearest first, a square's lower half first: its p1 has the
    // lesser z), then the chain over it.
    let key = |t: &pathlight::scene::layout::Triangle| (t.p0[0], t.p1[2]);
    let mut order: Vec<usize> = (0..scene.triangles.len()).collect();
    order.sort_by(|&a, &b| key(&scene.triangles[a]).partial_cmp(&key(&scene.triangles[b])).unwrap());
    scene.triangles = order.iter().map(|&i| scene.triangles[i]).collect();
    scene.normals = order.iter().map(|&i| scene.normals[i]).collect();
    scene.nodes = common::chain_tree(&scene.triangles, if pairs { 2 } else { 1 });
    scene.wide_bvh = pathlight::bvh::WideBvh::collapse(&scene.nodes);
    // The chain is 59 or 60 levels deep: the kernel needs both of its trail's words.
    scene.features.deep_tree = true;
    scene
}

#[test]
fn restart_trail_is_exact_past_depth_32() {
    // Camera rays along the deep chains overlap both children at nearly every level down to
    // the squares they pass beside, then go back up through the deferred children to the
    // first square they hit. With the camera beside the axis at 1.5^20, 1.5^25 and 1.5^30,
    // those lie past depth 32, around it and above it, so the restarts' trail runs through
    // both of the kernel's 32-bit words and the carry between them; the pairs' chain adds
    // deferred children that are nodes. Whatever the short stack holds, every pixel's first
    // hit is the same, and the CPU's (8-wide tree) agrees.
    let Some(ctx) = common::gpu() else { return };
    let size = 16;
    for pairs in [false, true] {
        let (mut shallowest, mut deepest) = (u32::MAX, 0);
        for k in [20, 25, 30] {
            let scene = deep_chain_scene(pairs, 1.5f32.powi(k));
            let depths = common::leaf_depths(&scene.nodes);
            let hits = |limit: u32| {
                let kernel = short_stack_kernel(&ctx, &scene, limit);
                let mut backend =
                    GpuBackend::with_kernel(ctx.clone(), kernel, &scene, &settings(size, 1, 3)).unwrap();
                backend.first_hits().unwrap()
            };
            let full = hits(pathlight::bvh::SHORT_STACK_SIZE as u32);
            for y in 0..size {
                for x in 0..size {
                    let g = &full[(y * size + x) as usize];
                    let c = pathlight::integrator::first_hit(&scene, size, size, x, y, 3);
                    let what = format!("pairs: {pairs}, 1.5^{k}, ({x},{y})");
                    assert_eq!(
                        g.triangle, c.triangle,
                        "{what}: GPU hit {} but the CPU {}",
                        g.triangle, c.triangle
                    );
                    if let Some(&depth) = depths.get(g.triangle as usize) {
                        shallowest = shallowest.min(depth);
                        deepest = deepest.max(depth);
                    }
                }
            }
            for limit in [0, 2] {
                assert!(
                    bytemuck::cast_slice::<_, u8>(&full) == bytemuck::cast_slice::<_, u8>(&hits(limit)),
                    "pairs: {pairs}, 1.5^{k}, limit {limit}: the first hits differ"
                );
            }
        }
        assert!(
            shallowest < 32 && deepest > 33,
            "pairs: {pairs}: the hits lie at depths {shallowest} to {deepest}: the test misses its point"
        );
    }
}

#[test]
fn restart_trail_arithmetic_matches_its_twin() {
    // The kernel keeps the 64-bit restart trail as two 32-bit words (shaders/bvh.wgsl); its
    // bit, clear, add-with-carry and lowest-set-bit helpers must give what the CPU twin's
    // u64 operations give (pathlight::bvh::trail), at every depth and across the words.
    use pathlight::bvh::trail::{trail_bit, trail_depth, trail_pop, trail_through};
    use wgpu::util::DeviceExt;
    let Some(ctx) = common::gpu() else { return };
    let mut rng = pathlight::sampling::Rng::new(7, 7, 7, 7);
    let mut random_u64 = || {
        let word = |r: &mut pathlight::sampling::Rng| (r.next_1d() * 4294967296.0) as u64;
        (word(&mut rng) << 32) | word(&mut rng)
    };
    // Trails dense and sparse, with runs of ones across the words (long carries), at each depth.
    let mut cases: Vec<(u64, u32)> = Vec::new();
    for depth in 1..=64u32 {
        let ones_below = |n: u32| if n >= 64 { !0u64 } else { (1u64 << n) - 1 };
        for trail in [0, !0, 1 << 32, 1 << 31, ones_below(40) << 8, !ones_below(30), ones_below(33)] {
            cases.push((trail, depth));
        }
        for _ in 0..16 {
            let (a, b) = (random_u64(), random_u64());
            cases.extend([(a, depth), (a & b, depth), (a | b, depth)]);
        }
    }
    let input: Vec<[u32; 4]> = cases.iter().map(|&(t, d)| [(t >> 32) as u32, t as u32, d, 0]).collect();
    let common = pathlight::gpu::shader::COMMON_FILES;
    let bvh_files = common.iter().position(|(name, _)| *name == "bvh.wgsl").unwrap() + 1;
    let source = pathlight::gpu::shader::compose_with_tables(
        &common[..bvh_files],
        pathlight::gpu::UniformTables::default(),
    ) + r#"
@group(0) @binding(100) var<storage, read> trail_cases: array<vec4<u32>>;
@group(0) @binding(101) var<storage, read_write> trail_results: array<vec4<u32>>;

@compute @workgroup_size(64)
fn test_trail(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= arrayLength(&trail_cases)) {
        return;
    }
    let trail = trail_cases[i].xy;
    let depth = trail_cases[i].z;
    let lowest = select(trail_depth(trail), 0u, trail_is_empty(trail));
    trail_results[2u * i] = vec4<u32>(trail_pop(trail, depth), trail_through(trail, depth));
    trail_results[2u * i + 1u] = vec4<u32>(trail_bit(depth), lowest, u32(trail_has(trail, depth)));
}
"#;
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("trail test"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("trail test"),
        layout: None,
        module: &module,
        entry_point: Some("test_trail"),
        compilation_options: Default::default(),
        cache: None,
    });
    let cases_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("trail cases"),
        contents: bytemuck::cast_slice(&input),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = (input.len() * 2 * 16) as u64;
    let results = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("trail results"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("trail readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("trail test"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 100, resource: cases_buffer.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 101, resource: results.as_entire_binding() },
        ],
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((input.len() as u32).div_ceil(64), 1, 1);
    }
    encoder.copy_buffer_to_buffer(&results, 0, &staging, 0, size);
    ctx.queue.submit([encoder.finish()]);
    staging.slice(..).map_async(wgpu::MapMode::Read, |r| r.unwrap());
    device.poll(wgpu::PollType::wait_indefinitely()).unwrap();
    let out: Vec<[u32; 4]> = bytemuck::cast_slice(&staging.slice(..).get_mapped_range().unwrap()).to_vec();
    let join = |high: u32, low: u32| ((high as u64) << 32) | low as u64;
    for (i, &(trail, depth)) in cases.iter().enumerate() {
        let (a, b) = (out[2 * i], out[2 * i + 1]);
        let what = format!("trail {trail:#018x}, depth {depth}");
        assert_eq!(join(a[0], a[1]), trail_pop(trail, depth), "{what}: trail_pop");
        assert_eq!(join(a[2], a[3]), trail_through(trail, depth), "{what}: trail_through");
        assert_eq!(join(b[0], b[1]), trail_bit(depth), "{what}: trail_bit");
        let lowest = if trail == 0 { 0 } else { trail_depth(trail) };
        assert_eq!(b[2], lowest, "{what}: trail_depth");
        assert_eq!(b[3] != 0, trail & trail_bit(depth) != 0, "{what}: trail_has");
    }
}
