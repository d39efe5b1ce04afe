// Resources of the megakernel (`GpuContext::new` in src/gpu/context.rs creates the matching
// layout).
//
// The per-dispatch bindings are storage buffers, not uniform ones: Mesa's lavapipe (22.3)
// inlines the values of uniform buffers that steer branches and loops into the shader and
// JIT-compiles a new variant of the whole megakernel each time such a binding is re-bound,
// keeping every variant. With `camera` and `frame` as uniforms that was one compile and about
// 1.2 MB per submit, for the life of the device (issue 6; tests/gpu_memory.rs).

// Bindings 0 `nodes`, 1 `triangles`, 3 `materials` and 4 `lights` are declared after the
// files, each as a storage or a uniform array (src/gpu/tables.rs says when and why).
@group(0) @binding(2) var<storage, read> normals: array<TriangleNormals>;
@group(0) @binding(5) var<storage, read> camera_buffer: Camera;
@group(0) @binding(6) var<storage, read> frame_buffer: FrameParams;
@group(0) @binding(7) var<storage, read_write> film: array<FilmPixel>;
@group(0) @binding(8) var<storage, read_write> first_hits: array<FirstHit>;
// Rays traced per pixel (closest-hit and shadow rays), for throughput reporting.
@group(0) @binding(9) var<storage, read_write> ray_counts: array<u32>;
// The environment light (src/light/environment.rs): parameters, texels (rgb radiance, w the
// sampling density over (u, v)), and the marginal then conditional CDFs. A scene without
// one binds one unused element of each.
@group(0) @binding(10) var<storage, read> environment: Environment;
@group(0) @binding(11) var<storage, read> environment_texels: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read> environment_cdf: array<f32>;
// Textures (src/scene/texture.rs): RGBA8 texels, per-texture descriptors, how each material
// input reads its texture, and per-triangle UVs and tangents. A scene without them binds one
// unused element of each.
@group(0) @binding(13) var<storage, read> texels: array<u32>;
@group(0) @binding(14) var<storage, read> texture_infos: array<TextureInfo>;
@group(0) @binding(15) var<storage, read> texture_bindings: array<TextureBinding>;
@group(0) @binding(16) var<storage, read> texcoords: array<TriangleTexcoords>;
@group(0) @binding(17) var<storage, read> tangents: array<TriangleTangents>;
// The sheen lobe's directional albedo E(μ, roughness), SHEEN_ALBEDO_SIZE² entries
// (src/bsdf/sheen.rs computes it); one unused element without sheen.
@group(0) @binding(18) var<storage, read> sheen_albedo_table: array<f32>;
// The light tracer's image of the current sample index (shaders/light_tracing.wgsl): per
// pixel and channel a 64-bit fixed-point sum (CPU twin: `caustic_to_fixed`), as a high and
// a low word, so that atomic adds in any order give the same bits. One unused pixel where
// the caustics are path traced.
@group(0) @binding(19) var<storage, read_write> caustics: array<atomic<u32>>;
// Adaptive sampling (src/sampling/adaptive.rs): pixel i takes the sample indices below
// sample_budgets[i]. Without it one element, 0xffffffff, which `sample_budget` reads for
// every pixel.
@group(0) @binding(22) var<storage, read> sample_budgets: array<u32>;

// The path tracer's irradiance cache (src/integrator/irradiance_cache.rs, placed on the
// host): its records, its hash table of grid cells, and `ic_indices`, which holds the
// number of grid levels L, the L levels, then each cell's run of record indices. Without a
// cache one unused element each (L = 0).
@group(0) @binding(24) var<storage, read> ic_records: array<IrradianceRecordGpu>;
@group(0) @binding(25) var<storage, read> ic_cells: array<IrradianceCell>;
@group(0) @binding(26) var<storage, read> ic_indices: array<u32>;

fn sample_budget(pixel: u32) -> u32 {
    return sample_budgets[min(pixel, arrayLength(&sample_budgets) - 1u)];
}

// The dispatch's camera and parameters, copied out of their storage buffers once per
// invocation by `load_dispatch_constants`, which every entry point calls first. Lavapipe
// compiles each read of a storage buffer into a loop over its eight SIMD lanes that tests
// each lane's mask and bounds (Mesa's `emit_load_mem`), and every bounce of `render` reads
// about twenty of these fields (camera rays, roulette, splitting, light counts); as private
// values they are read once (measured: bench/history/lavapipe.md).
var<private> camera: Camera;
var<private> frame: FrameParams;

fn load_dispatch_constants() {
    camera = camera_buffer;
    frame = frame_buffer;
}
