//! Every struct of the flat scene both backends render from, in one place: the loader
//! writes them, the CPU reference and the BSDF read them, and the GPU uploads them as they
//! are. (They live with the scene, not the GPU backend, so that the reference depends on
//! nothing of the backend it checks.)
//!
//! Each is `#[repr(C)]` + [`bytemuck::Pod`] with named padding (`_pad*`), declared through
//! [`gpu_struct!`], which also records every field's offset. The WGSL twins live in
//! `shaders/layout.wgsl` under the same names; the test `layout_matches_wgsl` in
//! `src/gpu/shader.rs` parses the WGSL with naga and checks that every struct's size and every
//! field's offset equal the Rust ones. Nothing here relies on a "must match" comment.
//!
//! The CPU reference renders from exactly these arrays too, so a disagreement between the
//! backends points at a kernel, not at the data.

/// A struct whose layout is mirrored by a WGSL struct of the same name.
pub trait GpuStruct: bytemuck::Pod {
    /// The struct's name, in Rust and in WGSL.
    const NAME: &'static str;
    /// `(field name, byte offset)` for every field, padding included.
    fn field_offsets() -> Vec<(&'static str, usize)>;
}

/// Declares a GPU-visible struct and records its field offsets for the layout test.
macro_rules! gpu_struct {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $( $(#[$field_meta:meta])* pub $field:ident : $ty:ty ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name {
            $( $(#[$field_meta])* pub $field: $ty ),*
        }
        impl GpuStruct for $name {
            const NAME: &'static str = stringify!($name);
            fn field_offsets() -> Vec<(&'static str, usize)> {
                vec![$( (stringify!($field), core::mem::offset_of!($name, $field)) ),*]
            }
        }
    };
}

/// `FrameParams::light_traced_caustics`: the light tracer's image of the sample index is
/// added to each sample.
pub const CAUSTICS_PER_SAMPLE: u32 = 1;
/// `FrameParams::light_traced_caustics`: the caustics are light traced and summed apart
/// (adaptive sampling, `crate::integrator::CausticSums`).
pub const CAUSTICS_APART: u32 = 2;

/// Marks "no index" in `u32` index fields (no emitter, missed ray, …).
pub const INVALID_INDEX: u32 = u32::MAX;
/// [`PixelAov::material`] of a pixel whose AOV rays all left the scene.
pub const AOV_NO_MATERIAL: u32 = INVALID_INDEX;
/// [`PixelAov::material`] of a pixel whose AOV rays read more than one material (or some
/// read one and some left the scene).
pub const AOV_MIXED_MATERIALS: u32 = u32::MAX - 1;

gpu_struct! {
    /// One node of the flattened BVH: 32 bytes, the layout of pbrt-v4's `LinearBVHNode`.
    ///
    /// Nodes are stored depth-first: an interior node's first child is the next node in the
    /// array and `offset` is the index of its second child. A leaf's triangles are
    /// `triangles[offset .. offset + count]`.
    pub struct BvhNode {
        pub bounds_min: [f32; 3],
        /// Interior: index of the second child. Leaf: index of the first triangle.
        pub offset: u32,
        pub bounds_max: [f32; 3],
        /// Bits 0..16: triangle count (0 for an interior node). Bits 16..18: split axis.
        pub count_axis: u32,
    }
}

impl BvhNode {
    pub fn triangle_count(&self) -> u32 {
        self.count_axis & 0xffff
    }
    pub fn axis(&self) -> u32 {
        (self.count_axis >> 16) & 3
    }
}

gpu_struct! {
    /// A triangle in BVH leaf order, camera-relative world space, 48 bytes.
    ///
    /// Front face = counter-clockwise `p0, p1, p2` seen from the front (glTF's convention,
    /// already corrected for negative-determinant node transforms).
    pub struct Triangle {
        pub p0: [f32; 3],
        /// Index into the material array.
        pub material: u32,
        pub p1: [f32; 3],
        /// Index into the light array when this triangle emits, else [`INVALID_INDEX`].
        pub emitter: u32,
        pub p2: [f32; 3],
        /// [`TRIANGLE_HAS_NORMALS`]: interpolate the vertex normals in [`TriangleNormals`];
        /// otherwise shade with the geometric normal.
        pub flags: u32,
    }
}

/// [`Triangle::flags`] bit: the triangle carries per-vertex shading normals.
pub const TRIANGLE_HAS_NORMALS: u32 = 1;
/// [`Triangle::flags`] bit: the triangle carries per-vertex tangents (normal mapping).
pub const TRIANGLE_HAS_TANGENTS: u32 = 2;

gpu_struct! {
    /// Per-vertex shading normals of one triangle (same order as [`Triangle`]), each
    /// octahedron-encoded into two snorm16 values (Cigolle et al. 2014, "A Survey of Efficient
    /// Representations for Independent Unit Vectors"); WGSL decodes with `unpack2x16snorm`.
    pub struct TriangleNormals {
        pub n0: u32,
        pub n1: u32,
        pub n2: u32,
        pub _pad0: u32,
    }
}

gpu_struct! {
    /// A material reduced to what the kernels evaluate, 176 bytes. See `src/bsdf/gltf.rs` for
    /// how each field enters the glTF BSDF.
    pub struct Material {
        /// Linear base colour.
        pub base_color: [f32; 3],
        /// glTF alpha (carried for alpha modes; not yet evaluated).
        pub alpha: f32,
        /// Emitted radiance: `emissiveFactor × KHR_materials_emissive_strength`.
        pub emission: [f32; 3],
        /// [`MATERIAL_DOUBLE_SIDED`] | [`MATERIAL_VOLUME`].
        pub flags: u32,
        /// KHR_materials_specular `specularColorFactor`.
        pub specular_color: [f32; 3],
        /// KHR_materials_specular `specularFactor`.
        pub specular_factor: f32,
        /// KHR_materials_volume absorption coefficient σₐ = −ln(attenuationColor) /
        /// attenuationDistance, per unit of scene length.
        pub attenuation_coefficient: [f32; 3],
        /// KHR_materials_ior.
        pub ior: f32,
        pub metallic: f32,
        /// GGX α = roughness² (0 means a true delta lobe), see `bsdf::alpha_from_roughness`.
        pub alpha_roughness: f32,
        /// KHR_materials_transmission `transmissionFactor`.
        pub transmission: f32,
        /// glTF `roughnessFactor` (a metallic-roughness texture scales it before
        /// `alpha_from_roughness`).
        pub roughness: f32,
        /// Texture inputs: indices into the [`TextureBinding`] array, or [`INVALID_INDEX`].
        pub base_color_texture: u32,
        pub metallic_roughness_texture: u32,
        pub normal_texture: u32,
        pub emissive_texture: u32,
        pub transmission_texture: u32,
        pub specular_texture: u32,
        pub specular_color_texture: u32,
        /// glTF `normalTexture.scale`.
        pub normal_scale: f32,
        /// glTF `alphaCutoff` (alpha mode MASK).
        pub alpha_cutoff: f32,
        /// KHR_materials_clearcoat `clearcoatFactor` (0: no coat).
        pub clearcoat: f32,
        /// KHR_materials_clearcoat `clearcoatRoughnessFactor` (perceptual; GGX α = its square).
        pub clearcoat_roughness: f32,
        /// KHR_materials_clearcoat textures: factor (R), roughness (G), and the coat's own
        /// normal map (without one the coat follows the interpolated normal, not the base's
        /// normal map).
        pub clearcoat_texture: u32,
        pub clearcoat_roughness_texture: u32,
        pub clearcoat_normal_texture: u32,
        /// `clearcoatNormalTexture.scale`.
        pub clearcoat_normal_scale: f32,
        /// KHR_materials_sheen `sheenRoughnessFactor` (perceptual; Charlie α = its square).
        pub sheen_roughness: f32,
        /// KHR_materials_sheen `sheenColorFactor` (black: no sheen).
        pub sheen_color: [f32; 3],
        /// KHR_materials_sheen textures: colour (RGB, sRGB) and roughness (A).
        pub sheen_color_texture: u32,
        pub sheen_roughness_texture: u32,
        pub _pad0: u32,
        pub _pad1: u32,
        pub _pad2: u32,
    }
}

impl Material {
    /// Every texture input (an index into the [`TextureBinding`] array, or
    /// [`INVALID_INDEX`]).
    pub fn texture_inputs(&self) -> [u32; 12] {
        [
            self.base_color_texture,
            self.metallic_roughness_texture,
            self.normal_texture,
            self.emissive_texture,
            self.transmission_texture,
            self.specular_texture,
            self.specular_color_texture,
            self.clearcoat_texture,
            self.clearcoat_roughness_texture,
            self.clearcoat_normal_texture,
            self.sheen_color_texture,
            self.sheen_roughness_texture,
        ]
    }

    /// Does a normal map (the base's or the coat's) need the triangle's tangent frame?
    pub fn is_normal_mapped(&self) -> bool {
        self.normal_texture != INVALID_INDEX || self.clearcoat_normal_texture != INVALID_INDEX
    }
}

gpu_struct! {
    /// One image in the texel array: `width × height` RGBA8 texels (one `u32` each, R in the
    /// low byte) from `offset`, row 0 at the top (glTF UV (0, 0)), 16 bytes.
    pub struct TextureInfo {
        pub offset: u32,
        pub width: u32,
        pub height: u32,
        /// Bits 0–1: wrap S, bits 2–3: wrap T (`WRAP_*`); [`TEXTURE_NEAREST`].
        pub flags: u32,
    }
}

pub const WRAP_REPEAT: u32 = 0;
pub const WRAP_CLAMP_TO_EDGE: u32 = 1;
pub const WRAP_MIRRORED_REPEAT: u32 = 2;
/// [`TextureInfo::flags`] bit: nearest-texel magnification (glTF `magFilter` NEAREST).
pub const TEXTURE_NEAREST: u32 = 16;

gpu_struct! {
    /// How a material input reads a texture (glTF `textureInfo` + KHR_texture_transform),
    /// 32 bytes: uv' = (row0 · (u, v, 1), row1 · (u, v, 1)).
    pub struct TextureBinding {
        pub row0: [f32; 3],
        /// Index into the [`TextureInfo`] array.
        pub texture: u32,
        pub row1: [f32; 3],
        /// Which UV set: 0 or 1.
        pub tex_coord: u32,
    }
}

gpu_struct! {
    /// Per-vertex texture coordinates of one triangle (sets 0 and 1), 48 bytes.
    pub struct TriangleTexcoords {
        pub uv0: [[f32; 2]; 3],
        pub uv1: [[f32; 2]; 3],
    }
}

gpu_struct! {
    /// Per-vertex tangents of one triangle, octahedron-encoded like [`TriangleNormals`];
    /// bit k of `signs` set means vertex k's bitangent sign (glTF `TANGENT.w`) is −1.
    pub struct TriangleTangents {
        pub t0: u32,
        pub t1: u32,
        pub t2: u32,
        pub signs: u32,
    }
}

/// [`Material::flags`] bit: emits from both faces (glTF `doubleSided`).
pub const MATERIAL_DOUBLE_SIDED: u32 = 1;
/// [`Material::flags`] bit: a refracting solid (KHR_materials_volume `thicknessFactor` > 0);
/// otherwise transmission is thin-walled.
pub const MATERIAL_VOLUME: u32 = 2;
/// [`Material::flags`] bit: alpha mode MASK (a hit counts where alpha ≥ `alpha_cutoff`).
pub const MATERIAL_ALPHA_MASK: u32 = 4;
/// [`Material::flags`] bit: alpha mode BLEND, as stochastic transparency (a hit counts with
/// probability alpha).
pub const MATERIAL_ALPHA_BLEND: u32 = 8;
/// [`Material::flags`] bit, set by [`crate::scene::FlatScene::build`]: the material
/// reflects and refracts only by delta lobes, from both sides, untextured and opaque, so no
/// photon is ever stored on it (`crate::integrator::gather_area` leaves its area out).
pub const MATERIAL_DELTA_ONLY: u32 = 16;

gpu_struct! {
    /// One light, with its entry of the power-proportional alias table, 64 bytes.
    pub struct Light {
        /// Point and spot: position (camera-relative world).
        pub position: [f32; 3],
        /// One of the `LIGHT_*` constants.
        pub kind: u32,
        /// Spot and directional: the direction the light travels in (unit). Emissive
        /// triangle: the unit normal of its winding's front side
        /// ([`crate::light::triangle_normal_area`]), kept because every light sample needs it.
        pub direction: [f32; 3],
        /// Emissive triangle: index into the triangle array.
        pub triangle: u32,
        /// Point and spot: radiant intensity (W/sr per unit colour). Directional: irradiance.
        /// Emissive triangle: the triangle's area in `intensity[0]` (its radiance is the
        /// material's emission).
        pub intensity: [f32; 3],
        /// Probability of choosing this light (proportional to its power).
        pub pmf: f32,
        /// Spot: cos(outer cone angle).
        pub cos_outer: f32,
        /// Spot: 1 / (cos inner − cos outer), as KHR_lights_punctual suggests.
        pub spot_scale: f32,
        /// Alias table (Vose 1991): keep this entry with this probability…
        pub alias_probability: f32,
        /// …else take this one.
        pub alias_index: u32,
    }
}

pub const LIGHT_TRIANGLE: u32 = 0;
pub const LIGHT_POINT: u32 = 1;
pub const LIGHT_SPOT: u32 = 2;
pub const LIGHT_DIRECTIONAL: u32 = 3;
/// The environment (see [`Environment`]): one entry of the light table like any other.
pub const LIGHT_ENVIRONMENT: u32 = 4;

gpu_struct! {
    /// The environment light: an equirectangular map of `width × height` texels (row 0 at
    /// the top, +Y up) with its sampling distribution, 32 bytes. Texels and distribution are
    /// separate arrays (`src/light/environment.rs` describes them).
    pub struct Environment {
        pub width: u32,
        pub height: u32,
        /// Rotation of the map about +Y: cos and sin of the angle.
        pub rotation_cos: f32,
        pub rotation_sin: f32,
        /// The environment's entry in the light array, or [`INVALID_INDEX`] when it carries
        /// no power (it is then seen, but never sampled).
        pub light_index: u32,
        /// 1 when the scene has an environment; 0: rays that miss see black.
        pub present: u32,
        pub _pad0: u32,
        pub _pad1: u32,
    }
}

gpu_struct! {
    /// The camera, in camera-relative world space (it sits at the origin), 48 bytes.
    pub struct Camera {
        /// Unit vector to the image's right.
        pub right: [f32; 3],
        /// [`PROJECTION_PERSPECTIVE`] or [`PROJECTION_ORTHOGRAPHIC`].
        pub projection: u32,
        /// Unit vector to the image's top.
        pub up: [f32; 3],
        /// Perspective: tan(yfov / 2). Orthographic: half the view height (glTF `ymag`).
        pub half_height: f32,
        /// Unit viewing direction (the camera node's −Z).
        pub forward: [f32; 3],
        /// Perspective: tan(xfov / 2). Orthographic: half the view width.
        pub half_width: f32,
        /// The eye (camera-relative world): zero for the camera the scene was flattened
        /// around; a viewer that moves the camera sets it instead of rebuilding the scene.
        pub position: [f32; 3],
        pub _pad0: u32,
    }
}

pub const PROJECTION_PERSPECTIVE: u32 = 0;
pub const PROJECTION_ORTHOGRAPHIC: u32 = 1;

gpu_struct! {
    /// What one dispatch computes, 176 bytes.
    pub struct FrameParams {
        pub width: u32,
        pub height: u32,
        /// Index of the first sample of this dispatch, per pixel.
        pub sample_offset: u32,
        /// Samples per pixel this dispatch adds.
        pub samples: u32,
        pub seed: u32,
        /// Most scattering events a path may have (`u32::MAX`: unlimited).
        pub max_depth: u32,
        /// Russian roulette applies once a path has this many non-delta scattering events
        /// (`crate::integrator::IntegratorSettings::rr_min_depth`).
        pub rr_min_depth: u32,
        pub light_count: u32,
        /// First image row of this dispatch.
        pub row_offset: u32,
        /// Rows in this dispatch.
        pub row_count: u32,
        /// The camera rays' cone for texture level of detail (`scene::camera::RayCone`):
        /// width at the camera and spread angle.
        pub cone_width: f32,
        pub cone_spread: f32,
        /// `SamplerKind::index` of the paths' sampler.
        pub sampler_kind: u32,
        /// Continuations per camera sample (`RenderSettings::splits`; 1: no splitting).
        pub splits: u32,
        /// [`CAUSTICS_PER_SAMPLE`]: the caustic paths are light traced
        /// (`crate::integrator::supports_light_tracing`): `render` leaves them out and adds
        /// the light tracer's image for its one sample index (`samples` is then 1);
        /// [`CAUSTICS_APART`]: light traced, and an adaptive render sums the light tracer's
        /// images apart (`crate::integrator::CausticSums`), so `render` leaves them out and
        /// adds nothing; 0: every path is path traced.
        pub light_traced_caustics: u32,
        /// Bidirectional path tracing: 1 where light vertices may be joined to the camera
        /// (`crate::integrator::IntegratorSettings::camera_connections`), else 0.
        pub camera_connections: u32,
        /// The scene's bounding sphere (`FlatScene::scene_center`, `scene_radius`): where
        /// bidirectional light subpaths from lights at infinity start.
        pub scene_center: [f32; 3],
        pub scene_radius: f32,
        /// Light paths the light tracer traces in this pass (`trace_caustics`): one per
        /// pixel, or under adaptive sampling one per pixel still taking samples; its splats
        /// are divided by it.
        pub light_paths: u32,
        /// The irradiance cache's normal unit times its accuracy, a √(1 − cos 10°)
        /// (`integrator::irradiance_cache`); 0 without a cache.
        pub ic_normal_scale: f32,
        /// 1: interpolate the cache's records with their gradients.
        pub ic_gradients: u32,
        /// The cache's hash table of cells has `ic_table_mask + 1` slots (a power of two).
        pub ic_table_mask: u32,
        /// Stochastic progressive photon mapping (shaders/sppm.wgsl): photons per pass.
        pub sppm_photons: u32,
        /// Its initial radius in pixel footprints.
        pub sppm_radius_pixels: f32,
        /// Its photon grid has `sppm_slot_mask + 1` slots (a power of two, at least 256).
        pub sppm_slot_mask: u32,
        /// The photon records a pass may keep (`sppm_photons` holds as many).
        pub sppm_record_capacity: u32,
        /// One pixel's camera ray cone (a one-sample render's): a visible point's footprint.
        pub sppm_footprint_width: f32,
        pub sppm_footprint_spread: f32,
        /// The photon map a build dispatch writes: its grid's first word and its first
        /// record (shaders/sppm.wgsl `SppmMap`); for the photon-map integrator's render, the
        /// caustic map's (the global map's are 0).
        pub photon_grid_base: u32,
        pub photon_record_base: u32,
        /// Which landings a build dispatch keeps (`integrator::sppm::PhotonKind`: 0
        /// indirect, 1 all, 2 caustic).
        pub photon_kind: u32,
        /// The map's cell edge where the host sets it (the photon maps'); 0: twice the
        /// pixels' mean radius (SPPM's).
        pub photon_cell: f32,
        /// The photon-map integrator: the global map's gather radius, and the photons
        /// traced for the caustic map (`sppm_photons` holds the global map's).
        pub photon_global_radius: f32,
        pub photon_caustic_photons: u32,
        /// Metropolis (shaders/mlt.wgsl): the dispatch's items (bootstrap samples, or
        /// chains), the mutations each chain makes in it, the probability of a large step,
        /// and the factor from the pass's summed splats to its image (`PassPlan::image_scale`).
        pub mlt_items: u32,
        pub mlt_mutations: u32,
        pub mlt_large_step: f32,
        pub mlt_scale: f32,
        /// The irradiance cache's gathers on the device (`render` under `IRRADIANCE_CACHE`
        /// with `ic_gather_jobs` > 0 traces gather rays instead of camera samples; shaders/
        /// path.wgsl): the dispatch's jobs (one gather ray each), the first job's index in the
        /// round, the round, and the gather's polar strata M (3M azimuthal).
        pub ic_gather_jobs: u32,
        pub ic_gather_job_offset: u32,
        pub ic_gather_round: u32,
        pub ic_gather_polar_strata: u32,
        /// The AOV pass's refinement (shaders/aov.wgsl `aov_refine`): the rays each pixel of
        /// the dispatch's list takes (`integrator::aov::AovRefinement::lists`).
        pub aov_rays: u32,
        pub _pad0: u32,
        pub _pad1: u32,
        pub _pad2: u32,
    }
}

gpu_struct! {
    /// A pixel's progressive photon-mapping state on the GPU (`integrator::sppm::SppmPixel`;
    /// WGSL `sppm_pixels` in shaders/sppm.wgsl). 48 bytes.
    pub struct SppmPixelGpu {
        /// τ: the flux gathered so far, scaled to the current radius.
        pub tau: [f32; 3],
        /// The gather radius; 0 until the pixel's first visible point sets it.
        pub radius: f32,
        /// Σ over passes of the light that needs no photons.
        pub direct: [f32; 3],
        /// N: the photon count the radius stands for.
        pub photon_count: f32,
        /// The radius update's α; 0 until the pixel's first gather decides it.
        pub alpha: f32,
        pub _pad0: u32,
        pub _pad1: u32,
        pub _pad2: u32,
    }
}

gpu_struct! {
    /// A pixel's camera path of one photon-mapping pass on the GPU (`integrator::sppm::
    /// CameraPath`): the light that needs no photons and the visible point, kept as the ray
    /// and hit that made it (the gather builds its interaction and BSDF again, with the
    /// same operations and so the same bits); `triangle` INVALID_INDEX: none. 80 bytes.
    pub struct SppmVisiblePoint {
        pub origin: [f32; 3],
        pub triangle: u32,
        pub direction: [f32; 3],
        pub t: f32,
        /// The hit's barycentrics.
        pub b: [f32; 3],
        /// The ray cone's width there (texture level of detail).
        pub cone_width: f32,
        /// The camera path's throughput over the probability of the non-delta choice.
        pub beta: [f32; 3],
        /// One pixel's footprint there.
        pub footprint: f32,
        pub direct: [f32; 3],
        pub _pad0: u32,
    }
}

gpu_struct! {
    /// One photon record on the GPU (`integrator::sppm::Photon`), its twelve numbers packed
    /// in three vec4s (48 bytes, as on the CPU): position and ω.x; ω.y, ω.z, β.r, β.g;
    /// β.b and the geometric normal (ω: back along the last segment; β: flux before the
    /// division by the pass's photon count).
    pub struct SppmPhoton {
        pub position_wi_x: [f32; 4],
        pub wi_yz_beta_rg: [f32; 4],
        pub beta_b_normal: [f32; 4],
    }
}

gpu_struct! {
    /// One number of a Metropolis chain's primary sample on the GPU (`integrator::mlt::
    /// PrimarySample`): its value and the iteration that set it, and what a rejected
    /// mutation restores; the top bit of each iteration word is the `set` flag. 16 bytes.
    pub struct MltNumberGpu {
        pub value: f32,
        pub backup_value: f32,
        pub modified: u32,
        pub backup_modified: u32,
    }
}

gpu_struct! {
    /// A Metropolis chain between dispatches (`integrator::mlt::Chain`; its numbers are
    /// `MltNumberGpu`s of their own): the sampler's and the chain's xoshiro128** states, the
    /// current state's contribution C, target T and pixel, the chain's depth, the sampler's
    /// iteration and last accepted large step, the bootstrap sample it starts from, the
    /// mutations it has still to make in the pass, how many of its numbers were read, and
    /// whether it has started. 80 bytes.
    pub struct MltChainGpu {
        pub sampler_rng: [u32; 4],
        pub chain_rng: [u32; 4],
        pub value: [f32; 3],
        pub scalar_target: f32,
        pub pixel: u32,
        pub depth: u32,
        pub iteration: u32,
        pub last_large_step: u32,
        pub start: u32,
        pub remaining: u32,
        pub used: u32,
        /// 0 until the chain's first state is made (`mlt_start`).
        pub started: u32,
    }
}

gpu_struct! {
    /// One irradiance-cache record as the kernel reads it (`integrator::irradiance_cache::
    /// IrradianceRecord`, WGSL twin `shaders/irradiance_cache.wgsl`): the validity radius
    /// already clamped and scaled by the accuracy. 144 bytes.
    pub struct IrradianceRecordGpu {
        pub p: [f32; 3],
        pub radius: f32,
        pub n: [f32; 3],
        pub _pad0: u32,
        pub e: [f32; 3],
        pub _pad1: u32,
        /// Per colour channel, xyz.
        pub rotational: [[f32; 4]; 3],
        pub translational: [[f32; 4]; 3],
    }
}

gpu_struct! {
    /// A pixel's first Lambertian vertex as the irradiance cache's placement passes find it on
    /// the device (`ic_first_vertex` in shaders/irradiance_cache.wgsl, twin of
    /// `integrator::irradiance_cache::first_lambertian_vertex`): the ray and the hit that
    /// make it (the gathers shade it again from them, with the same bits), and what the host
    /// reads: the point, its footprint and its shading frame. `triangle` is `INVALID_INDEX`
    /// where the pixel has no such vertex. 112 bytes.
    pub struct IcVertexGpu {
        pub origin: [f32; 3],
        pub triangle: u32,
        pub direction: [f32; 3],
        pub t: f32,
        pub b: [f32; 3],
        pub cone_width: f32,
        pub p: [f32; 3],
        pub footprint: f32,
        pub frame_x: [f32; 3],
        /// Rays the pixel's overture path traced.
        pub rays: u32,
        pub frame_y: [f32; 3],
        pub _pad0: u32,
        pub frame_z: [f32; 3],
        pub _pad1: u32,
    }
}

gpu_struct! {
    /// One gather ray's result on the device (`render`'s gather mode): the radiance it
    /// brings back and its first hit's distance (negative where it left the scene or was
    /// not traced), and the rays its path traced. 32 bytes.
    pub struct IcGatherResultGpu {
        pub radiance: [f32; 3],
        pub distance: f32,
        pub rays: u32,
        pub _pad0: u32,
        pub _pad1: u32,
        pub _pad2: u32,
    }
}

gpu_struct! {
    /// One slot of the irradiance cache's open-addressing hash table of grid cells: the key
    /// (level, x, y, z) and the run of record indices it lists in `ic_indices`; `count` 0:
    /// an empty slot. 32 bytes.
    pub struct IrradianceCell {
        pub key: [i32; 4],
        pub start: u32,
        pub count: u32,
        pub _pad0: u32,
        pub _pad1: u32,
    }
}

gpu_struct! {
    /// One pixel of the film: Welford's running mean and sum of squared deviations
    /// (Welford 1962; Knuth TAOCP vol. 2 §4.2.2), and the running mean of the odd-indexed
    /// samples, the second of the sampler's two independent replicates
    /// (`sampling::replicate_of`), from which the error of a QMC mean is measured. 48 bytes.
    pub struct FilmPixel {
        pub mean: [f32; 3],
        /// Samples accumulated.
        pub count: u32,
        /// Σ (x − mean)², per channel.
        pub m2: [f32; 3],
        /// Samples rejected because they were not finite.
        pub rejected: u32,
        /// Mean of the accumulated samples of replicate 1 (odd sample indices).
        pub odd_mean: [f32; 3],
        /// Samples of replicate 1 accumulated.
        pub odd_count: u32,
    }
}

gpu_struct! {
    /// A pixel's auxiliary images (AOVs) for denoising and compositing, averaged over
    /// `rays` camera rays (`integrator::aov`, WGSL twin
    /// `shaders/aov.wgsl`).
    pub struct PixelAov {
        /// Mean base colour of the first non-delta surface each ray reaches, followed
        /// through mirrors and smooth glass (what Open Image Denoise expects); zero for a
        /// ray that leaves the scene.
        pub albedo: [f32; 3],
        /// Mean distance from the camera to the first surface over the rays that hit one;
        /// 0 where none did (`film::Aovs` makes that +∞).
        pub depth: f32,
        /// Mean world-space shading normal (facing the ray) of the surface the albedo was
        /// read from, not renormalised: shorter where the normals under the pixel disagree;
        /// zero for a ray that leaves the scene.
        pub normal: [f32; 3],
        /// Rays of the pixel that hit a surface.
        pub hits: u32,
        /// Mean emitted radiance of the surface the albedo was read from, where it emits
        /// towards the ray (the emissive factor times its texture): lets a denoiser keep an
        /// emitter's edge apart from the surface beside it, which has the same albedo, normal
        /// and depth.
        pub emission: [f32; 3],
        /// Rays the pixel averaged (`AOV_SAMPLES`, or more where it was refined:
        /// `AOV_VARYING_SAMPLES`, `AOV_SILHOUETTE_SAMPLES`, `AOV_REFINED_SAMPLES`).
        pub rays: u32,
        /// The material the albedo was read from, where every ray of the pixel read the same
        /// one; [`AOV_NO_MATERIAL`] where every ray left the scene; [`AOV_MIXED_MATERIALS`]
        /// where the rays disagree. Tells an emitter's edge (a lamp beside the ceiling, two
        /// materials) from an emissive texture's variation within one material
        /// (`integrator::aov::pixels_to_refine`).
        pub material: u32,
        pub _pad0: u32,
        pub _pad1: u32,
        pub _pad2: u32,
    }
}

gpu_struct! {
    /// What the camera ray of sample 0 hit: for first-hit agreement tests and, later, AOVs.
    pub struct FirstHit {
        /// Shading normal (world, facing the camera); zero on a miss.
        pub normal: [f32; 3],
        /// Distance from the camera; 0 on a miss.
        pub distance: f32,
        /// Base colour of the material hit.
        pub albedo: [f32; 3],
        /// Index of the triangle hit (BVH order), or [`INVALID_INDEX`].
        pub triangle: u32,
    }
}

gpu_struct! {
    /// What the viewer's display pass needs (`src/viewer/display.rs`), 32 bytes.
    pub struct DisplayParams {
        /// The film's size in pixels.
        pub film_width: u32,
        pub film_height: u32,
        /// The render target's size in pixels (the film is stretched over it).
        pub target_width: u32,
        pub target_height: u32,
        /// 2^exposure.
        pub exposure_scale: f32,
        /// One of the `DISPLAY_*` tone maps.
        pub tonemap: u32,
        /// 1: the shader applies the sRGB curve (the target format does not).
        pub encode_srgb: u32,
        pub _pad0: u32,
    }
}

/// [`DisplayParams::tonemap`]: scale and clamp.
pub const DISPLAY_CLAMP: u32 = 0;
/// [`DisplayParams::tonemap`]: Narkowicz's ACES fit (as `film::Tonemap::Aces`).
pub const DISPLAY_ACES: u32 = 1;
/// [`DisplayParams::tonemap`]: false colour of each pixel's relative standard error.
pub const DISPLAY_RELATIVE_ERROR: u32 = 2;

/// One struct's layout: name, size in bytes, and `(field, offset)` pairs.
pub type StructLayout = (&'static str, usize, Vec<(&'static str, usize)>);

/// Every GPU-visible struct's layout, for the layout test.
pub fn all_layouts() -> Vec<StructLayout> {
    fn entry<T: GpuStruct>() -> StructLayout {
        (T::NAME, std::mem::size_of::<T>(), T::field_offsets())
    }
    vec![
        entry::<BvhNode>(),
        entry::<Triangle>(),
        entry::<TriangleNormals>(),
        entry::<Material>(),
        entry::<TextureInfo>(),
        entry::<TextureBinding>(),
        entry::<TriangleTexcoords>(),
        entry::<TriangleTangents>(),
        entry::<Light>(),
        entry::<Camera>(),
        entry::<Environment>(),
        entry::<FrameParams>(),
        entry::<IrradianceRecordGpu>(),
        entry::<IrradianceCell>(),
        entry::<IcVertexGpu>(),
        entry::<IcGatherResultGpu>(),
        entry::<SppmPixelGpu>(),
        entry::<SppmVisiblePoint>(),
        entry::<SppmPhoton>(),
        entry::<MltNumberGpu>(),
        entry::<MltChainGpu>(),
        entry::<FilmPixel>(),
        entry::<FirstHit>(),
        entry::<PixelAov>(),
        entry::<DisplayParams>(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bvh_node_is_32_bytes() {
        assert_eq!(std::mem::size_of::<BvhNode>(), 32);
    }
}
