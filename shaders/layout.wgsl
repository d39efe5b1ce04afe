// Twin of src/scene/layout.rs: every struct and constant the kernels share with the host.
// The test `layout_matches_wgsl` (src/gpu/shader.rs) parses this file with naga and checks
// each struct's size and field offsets, and each constant's value, against the Rust ones.

struct BvhNode {
    bounds_min: vec3<f32>,
    offset: u32,
    bounds_max: vec3<f32>,
    count_axis: u32,
}

struct Triangle {
    p0: vec3<f32>,
    material: u32,
    p1: vec3<f32>,
    emitter: u32,
    p2: vec3<f32>,
    flags: u32,
}

struct TriangleNormals {
    n0: u32,
    n1: u32,
    n2: u32,
    _pad0: u32,
}

struct Material {
    base_color: vec3<f32>,
    alpha: f32,
    emission: vec3<f32>,
    flags: u32,
    specular_color: vec3<f32>,
    specular_factor: f32,
    attenuation_coefficient: vec3<f32>,
    ior: f32,
    metallic: f32,
    alpha_roughness: f32,
    transmission: f32,
    roughness: f32,
    base_color_texture: u32,
    metallic_roughness_texture: u32,
    normal_texture: u32,
    emissive_texture: u32,
    transmission_texture: u32,
    specular_texture: u32,
    specular_color_texture: u32,
    normal_scale: f32,
    alpha_cutoff: f32,
    clearcoat: f32,
    clearcoat_roughness: f32,
    clearcoat_texture: u32,
    clearcoat_roughness_texture: u32,
    clearcoat_normal_texture: u32,
    clearcoat_normal_scale: f32,
    sheen_roughness: f32,
    sheen_color: vec3<f32>,
    sheen_color_texture: u32,
    sheen_roughness_texture: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct TextureInfo {
    offset: u32,
    width: u32,
    height: u32,
    flags: u32,
}

struct TextureBinding {
    row0: vec3<f32>,
    texture: u32,
    row1: vec3<f32>,
    tex_coord: u32,
}

struct TriangleTexcoords {
    uv0: array<vec2<f32>, 3>,
    uv1: array<vec2<f32>, 3>,
}

struct TriangleTangents {
    t0: u32,
    t1: u32,
    t2: u32,
    signs: u32,
}

struct Light {
    position: vec3<f32>,
    kind: u32,
    direction: vec3<f32>,
    triangle: u32,
    intensity: vec3<f32>,
    pmf: f32,
    cos_outer: f32,
    spot_scale: f32,
    alias_probability: f32,
    alias_index: u32,
}

struct Camera {
    right: vec3<f32>,
    projection: u32,
    up: vec3<f32>,
    half_height: f32,
    forward: vec3<f32>,
    half_width: f32,
    position: vec3<f32>,
    _pad0: u32,
}

struct Environment {
    width: u32,
    height: u32,
    rotation_cos: f32,
    rotation_sin: f32,
    light_index: u32,
    present: u32,
    _pad0: u32,
    _pad1: u32,
}

struct FrameParams {
    width: u32,
    height: u32,
    sample_offset: u32,
    samples: u32,
    seed: u32,
    max_depth: u32,
    rr_min_depth: u32,
    light_count: u32,
    row_offset: u32,
    row_count: u32,
    cone_width: f32,
    cone_spread: f32,
    sampler_kind: u32,
    splits: u32,
    light_traced_caustics: u32,
    camera_connections: u32,
    scene_center: vec3<f32>,
    scene_radius: f32,
    light_paths: u32,
    ic_normal_scale: f32,
    ic_gradients: u32,
    ic_table_mask: u32,
    sppm_photons: u32,
    sppm_radius_pixels: f32,
    sppm_slot_mask: u32,
    sppm_record_capacity: u32,
    sppm_footprint_width: f32,
    sppm_footprint_spread: f32,
    photon_grid_base: u32,
    photon_record_base: u32,
    photon_kind: u32,
    photon_cell: f32,
    photon_global_radius: f32,
    photon_caustic_photons: u32,
    mlt_items: u32,
    mlt_mutations: u32,
    mlt_large_step: f32,
    mlt_scale: f32,
    ic_gather_jobs: u32,
    ic_gather_job_offset: u32,
    ic_gather_round: u32,
    ic_gather_polar_strata: u32,
    aov_rays: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Twin of `SppmPixelGpu` (src/scene/layout.rs).
struct SppmPixelGpu {
    tau: vec3<f32>,
    radius: f32,
    direct: vec3<f32>,
    photon_count: f32,
    alpha: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Twin of `SppmVisiblePoint`.
struct SppmVisiblePoint {
    origin: vec3<f32>,
    triangle: u32,
    direction: vec3<f32>,
    t: f32,
    b: vec3<f32>,
    cone_width: f32,
    beta: vec3<f32>,
    footprint: f32,
    direct: vec3<f32>,
    _pad0: u32,
}

// Twin of `SppmPhoton`: three vec4s, unpacked by `sppm_photon_*` in shaders/sppm.wgsl.
struct SppmPhoton {
    position_wi_x: vec4<f32>,
    wi_yz_beta_rg: vec4<f32>,
    beta_b_normal: vec4<f32>,
}

// Twin of `MltNumberGpu` (the top bit of `modified` and `backup_modified`: set).
struct MltNumberGpu {
    value: f32,
    backup_value: f32,
    modified: u32,
    backup_modified: u32,
}

// Twin of `MltChainGpu`.
struct MltChainGpu {
    sampler_rng: vec4<u32>,
    chain_rng: vec4<u32>,
    value: vec3<f32>,
    scalar_target: f32,
    pixel: u32,
    depth: u32,
    iteration: u32,
    last_large_step: u32,
    start: u32,
    remaining: u32,
    used: u32,
    started: u32,
}

struct IrradianceRecordGpu {
    p: vec3<f32>,
    radius: f32,
    n: vec3<f32>,
    _pad0: u32,
    e: vec3<f32>,
    _pad1: u32,
    rotational: array<vec4<f32>, 3>,
    translational: array<vec4<f32>, 3>,
}

struct IrradianceCell {
    key: vec4<i32>,
    start: u32,
    count: u32,
    _pad0: u32,
    _pad1: u32,
}

// Twin of `IcVertexGpu` (`triangle` INVALID_INDEX: the pixel has no Lambertian vertex).
struct IcVertexGpu {
    origin: vec3<f32>,
    triangle: u32,
    direction: vec3<f32>,
    t: f32,
    b: vec3<f32>,
    cone_width: f32,
    p: vec3<f32>,
    footprint: f32,
    frame_x: vec3<f32>,
    rays: u32,
    frame_y: vec3<f32>,
    _pad0: u32,
    frame_z: vec3<f32>,
    _pad1: u32,
}

// Twin of `IcGatherResultGpu` (`distance` negative: no hit).
struct IcGatherResultGpu {
    radiance: vec3<f32>,
    distance: f32,
    rays: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct FilmPixel {
    mean: vec3<f32>,
    count: u32,
    m2: vec3<f32>,
    rejected: u32,
    odd_mean: vec3<f32>,
    odd_count: u32,
}

struct FirstHit {
    normal: vec3<f32>,
    distance: f32,
    albedo: vec3<f32>,
    triangle: u32,
}

struct PixelAov {
    albedo: vec3<f32>,
    depth: f32,
    normal: vec3<f32>,
    hits: u32,
    emission: vec3<f32>,
    rays: u32,
    material: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

struct DisplayParams {
    film_width: u32,
    film_height: u32,
    target_width: u32,
    target_height: u32,
    exposure_scale: f32,
    tonemap: u32,
    encode_srgb: u32,
    _pad0: u32,
}

const INVALID_INDEX: u32 = 0xffffffffu;
// `PixelAov::material` where every AOV ray left the scene, and where they read different
// materials (CPU: `scene::layout`).
const AOV_NO_MATERIAL: u32 = 0xffffffffu;
const AOV_MIXED_MATERIALS: u32 = 0xfffffffeu;
const TRIANGLE_HAS_NORMALS: u32 = 1u;
const TRIANGLE_HAS_TANGENTS: u32 = 2u;
const WRAP_REPEAT: u32 = 0u;
const WRAP_CLAMP_TO_EDGE: u32 = 1u;
const WRAP_MIRRORED_REPEAT: u32 = 2u;
const TEXTURE_NEAREST: u32 = 16u;
const MATERIAL_DOUBLE_SIDED: u32 = 1u;
const MATERIAL_VOLUME: u32 = 2u;
const MATERIAL_ALPHA_MASK: u32 = 4u;
const MATERIAL_ALPHA_BLEND: u32 = 8u;
const MATERIAL_DELTA_ONLY: u32 = 16u;
const LIGHT_TRIANGLE: u32 = 0u;
const LIGHT_POINT: u32 = 1u;
const LIGHT_SPOT: u32 = 2u;
const LIGHT_DIRECTIONAL: u32 = 3u;
const LIGHT_ENVIRONMENT: u32 = 4u;
const PROJECTION_PERSPECTIVE: u32 = 0u;
const PROJECTION_ORTHOGRAPHIC: u32 = 1u;
const DISPLAY_CLAMP: u32 = 0u;
const DISPLAY_ACES: u32 = 1u;
const DISPLAY_RELATIVE_ERROR: u32 = 2u;
