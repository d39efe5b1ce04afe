//! [`FlatScene`]: the scene as both backends render it — camera-relative f32 arrays, the
//! flattened BVH, and the light table.

use glam::{DVec3, Vec2, Vec3};

use super::texture::{emitted_radiance, FlatTextures, TextureArrays};
use super::{oct_encode, CameraDesc, PunctualKind, Scene, SceneFeatures};
use crate::bvh::{self, BvhStats};
use crate::error::{Error, Result};
use crate::light::{triangle_normal_area, EnvironmentDesc, FlatEnvironment};
use crate::sampling::build_alias_table;
use crate::sampling::sample_uniform_triangle;
use crate::scene::layout::{
    self, BvhNode, Light, TextureBinding, Triangle, TriangleNormals, TriangleTangents, TriangleTexcoords,
    INVALID_INDEX, LIGHT_DIRECTIONAL, LIGHT_ENVIRONMENT, LIGHT_POINT, LIGHT_SPOT, LIGHT_TRIANGLE,
    MATERIAL_DOUBLE_SIDED, TRIANGLE_HAS_NORMALS, TRIANGLE_HAS_TANGENTS,
};

/// Which camera to render through, and the image's shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewSettings {
    /// Index into the scene's cameras; `None`: the first, or a framing camera if none.
    pub camera: Option<usize>,
    /// Image width / height.
    pub aspect: f64,
}

/// Everything a backend needs, in the layout the GPU reads.
#[derive(Clone, Debug)]
pub struct FlatScene {
    /// The binary BVH (the GPU's).
    pub nodes: Vec<BvhNode>,
    /// The same tree collapsed 8-wide, which the CPU backend traverses.
    pub wide_bvh: crate::bvh::WideBvh,
    /// BVH leaf order.
    pub triangles: Vec<Triangle>,
    pub normals: Vec<TriangleNormals>,
    pub materials: Vec<layout::Material>,
    /// Per material: does some triangle use it? (The loader keeps a default material that
    /// may be used by none; [`SceneFeatures`] and the light tracer look only at used ones.)
    pub used_materials: Vec<bool>,
    pub lights: Vec<Light>,
    pub camera: layout::Camera,
    /// The camera as placed in the world (its position is this scene's origin).
    pub camera_desc: CameraDesc,
    pub features: SceneFeatures,
    pub bvh_stats: BvhStats,
    /// Radius of the sphere about the scene's bounding-box centre that holds it.
    pub scene_radius: f32,
    /// That sphere's centre (camera-relative): bidirectional path tracing starts the paths of
    /// lights at infinity (environment, directional) on a disk of `scene_radius` about it.
    pub scene_center: Vec3,
    /// The environment light (`params.present == 0` when there is none).
    pub environment: FlatEnvironment,
    /// The scene has no light of its own and no environment was given, so it is lit by
    /// [`DEFAULT_BACKGROUND`] rather than rendered black; callers should say so.
    pub default_environment: bool,
    /// Texels and per-texture descriptors (empty without textures).
    pub textures: FlatTextures,
    /// How each material input reads its texture ([`layout::Material`]'s `*_texture`).
    pub texture_bindings: Vec<TextureBinding>,
    /// Per triangle in BVH order, when some material is textured; else empty.
    pub texcoords: Vec<TriangleTexcoords>,
    pub tangents: Vec<TriangleTangents>,
}

/// What lights a scene that has no light of its own and no `--env`/`--background`: a
/// constant white sky of radiance 1, under which a white Lambertian surface that sees only
/// sky has radiance 1.
pub const DEFAULT_BACKGROUND: Vec3 = Vec3::ONE;

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl FlatScene {
    pub fn build(scene: &Scene, view: &ViewSettings) -> Result<FlatScene> {
        let (bmin, bmax) = scene
            .bounds()
            .ok_or_else(|| Error::scene(&scene.source, "the scene has no triangles to render"))?;
        let camera_desc = match view.camera {
            Some(i) => scene.cameras.get(i).cloned().ok_or_else(|| {
                Error::Settings(format!(
                    "--camera {i}: {} has {} camera(s)",
                    scene.source.display(),
                    scene.cameras.len()
                ))
            })?,
            None => {
                scene.cameras.first().cloned().unwrap_or_else(|| CameraDesc::framing(bmin, bmax, view.aspect))
            }
        };
        // Camera-relative coordinates: subtract the camera position in f64, then round.
        let origin = camera_desc.position;
        let rel = |p: DVec3| (p - origin).as_vec3();
        let positions: Vec<[Vec3; 3]> =
            scene.positions.chunks_exact(3).map(|t| [rel(t[0]), rel(t[1]), rel(t[2])]).collect();
        let bvh = bvh::build(&positions);

        // Images some material reads as sRGB colour: their mip levels average in linear light.
        let mut srgb_images = vec![false; scene.images.len()];
        for t in scene.materials.iter().flat_map(|m| m.srgb_textures()) {
            if let Some(i) = scene.textures.get(t).and_then(|t| t.image) {
                srgb_images[i] = true;
            }
        }
        let textures = FlatTextures::build(&scene.images, &scene.textures, &srgb_images);
        let mut texture_bindings = Vec::new();
        let usable = |t: usize| scene.textures.get(t).is_some_and(|t| t.image.is_some());
        let mut materials: Vec<layout::Material> =
            scene.materials.iter().map(|m| m.to_gpu(&mut texture_bindings, &usable)).collect();
        for m in &mut materials {
            if crate::bsdf::is_delta_only(m) {
                m.flags |= layout::MATERIAL_DELTA_ONLY;
            }
        }
        let textured = |m: &layout::Material| m.texture_inputs().iter().any(|&t| t != INVALID_INDEX);
        // Per-triangle UVs and tangents only when some triangle's material reads a texture.
        let any_textured = scene.triangle_materials.iter().any(|&m| textured(&materials[m as usize]));
        let mut triangles = Vec::with_capacity(positions.len());
        let mut normals = Vec::with_capacity(positions.len());
        let mut texcoords = Vec::new();
        let mut tangents = Vec::new();
        for &src in &bvh.order {
            let src = src as usize;
            let [p0, p1, p2] = positions[src];
            let n = scene.normals[src];
            let material = scene.triangle_materials[src];
            let t = scene.tangents.get(src).copied().flatten();
            let has_tangents = t.is_some() && materials[material as usize].is_normal_mapped();
            triangles.push(Triangle {
                p0: p0.to_array(),
                material,
                p1: p1.to_array(),
                emitter: INVALID_INDEX,
                p2: p2.to_array(),
                flags: if n.is_some() { TRIANGLE_HAS_NORMALS } else { 0 }
                    | if has_tangents { TRIANGLE_HAS_TANGENTS } else { 0 },
            });
            normals.push(match n {
                Some([n0, n1, n2]) => {
                    TriangleNormals { n0: oct_encode(n0), n1: oct_encode(n1), n2: oct_encode(n2), _pad0: 0 }
                }
                None => TriangleNormals::default(),
            });
            if any_textured {
                let uv = scene.texcoords.get(src).copied().unwrap_or_default();
                texcoords.push(TriangleTexcoords {
                    uv0: uv[0].map(|v| v.to_array()),
                    uv1: uv[1].map(|v| v.to_array()),
                });
                tangents.push(match t {
                    Some([t0, t1, t2]) if has_tangents => TriangleTangents {
                        t0: oct_encode(t0.truncate()),
                        t1: oct_encode(t1.truncate()),
                        t2: oct_encode(t2.truncate()),
                        signs: (t0.w < 0.0) as u32 | ((t1.w < 0.0) as u32) << 1 | ((t2.w < 0.0) as u32) << 2,
                    },
                    _ => TriangleTangents::default(),
                });
            }
        }
        let texture_arrays = TextureArrays {
            texels: &textures.texels,
            infos: &textures.infos,
            bindings: &texture_bindings,
            texcoords: &texcoords,
        };

        let scene_radius = (0.5 * (bmax - bmin).length()).max(1e-6) as f32;
        let scene_center = rel(0.5 * (bmin + bmax));

        // Lights and their powers (pbrt-v4 `PowerLightSampler`): Φ = π·A·L (×2 two-sided)
        // for emissive triangles, 4π·I for point lights, 2π·I·(1 − (cos_in + cos_out)/2) for
        // spots, π·r²·E for directional lights over the scene's bounding disk.
        let mut lights = Vec::new();
        let mut powers = Vec::new();
        let has_emission = triangles.iter().any(|t| {
            let m = &materials[t.material as usize];
            Vec3::from(m.emission).max_element() > 0.0
        });
        let default_environment = scene.environment.is_none() && scene.lights.is_empty() && !has_emission;
        let environment_desc = match &scene.environment {
            Some(e) => Some(e.clone()),
            None if default_environment => Some(EnvironmentDesc::constant(DEFAULT_BACKGROUND)),
            None => None,
        };
        let mut environment = FlatEnvironment::default();
        if let Some(desc) = &environment_desc {
            environment = FlatEnvironment::build(desc, scene_radius);
            if environment.power > 0.0 {
                environment.params.light_index = lights.len() as u32;
                lights.push(Light { kind: LIGHT_ENVIRONMENT, triangle: INVALID_INDEX, ..Default::default() });
                powers.push(environment.power);
            }
        }
        for (i, tri) in triangles.iter_mut().enumerate() {
            let m = &materials[tri.material as usize];
            let le = Vec3::from(m.emission);
            if le.max_element() <= 0.0 {
                continue;
            }
            let (normal, area) = triangle_normal_area(tri);
            let sides = if m.flags & MATERIAL_DOUBLE_SIDED != 0 { 2.0 } else { 1.0 };
            // An emissive texture shapes the emission: weight by its mean over the triangle
            // (4×4 stratified points), so black texels draw no light samples. MIS stays
            // consistent: a triangle that draws none is still counted when a path hits it.
            let mean_luminance = if m.emissive_texture == INVALID_INDEX {
                luminance(le) as f64
            } else {
                let mut sum = 0.0f64;
                for k in 0..16 {
                    let u = Vec2::new(((k % 4) as f32 + 0.5) / 4.0, ((k / 4) as f32 + 0.5) / 4.0);
                    let b = sample_uniform_triangle(u);
                    sum += luminance(emitted_radiance(&texture_arrays, m, i, b)) as f64;
                }
                sum / 16.0
            };
            if mean_luminance <= 0.0 {
                continue;
            }
            tri.emitter = lights.len() as u32;
            lights.push(Light {
                kind: LIGHT_TRIANGLE,
                triangle: i as u32,
                direction: normal.to_array(),
                intensity: [area, 0.0, 0.0],
                ..Default::default()
            });
            powers.push(std::f64::consts::PI * area as f64 * mean_luminance * sides);
        }
        for pl in &scene.lights {
            let intensity = pl.intensity;
            let mut light = Light {
                position: rel(pl.position).to_array(),
                direction: pl.direction.as_vec3().to_array(),
                intensity: intensity.to_array(),
                triangle: INVALID_INDEX,
                ..Default::default()
            };
            let lum = luminance(intensity) as f64;
            let power = match pl.kind {
                PunctualKind::Point => {
                    light.kind = LIGHT_POINT;
                    4.0 * std::f64::consts::PI * lum
                }
                PunctualKind::Spot { inner_cone_angle, outer_cone_angle } => {
                    light.kind = LIGHT_SPOT;
                    let inner = inner_cone_angle.min(outer_cone_angle);
                    light.cos_outer = outer_cone_angle.cos();
                    light.spot_scale = 1.0 / (inner.cos() - light.cos_outer).max(1e-3);
                    let (ci, co) = (inner.cos() as f64, light.cos_outer as f64);
                    2.0 * std::f64::consts::PI * lum * (1.0 - 0.5 * (ci + co))
                }
                PunctualKind::Directional => {
                    light.kind = LIGHT_DIRECTIONAL;
                    std::f64::consts::PI * (scene_radius as f64).powi(2) * lum
                }
            };
            lights.push(light);
            powers.push(power);
        }
        if let Some(table) = build_alias_table(&powers) {
            for (l, e) in lights.iter_mut().zip(table) {
                l.pmf = e.pmf;
                l.alias_probability = e.probability;
                l.alias_index = e.alias;
            }
        } else {
            // No light carries power: nothing to sample. Emissive triangles and the
            // environment keep no index.
            lights.clear();
            for t in &mut triangles {
                t.emitter = INVALID_INDEX;
            }
            environment.params.light_index = INVALID_INDEX;
        }
        let mut used_materials = vec![false; materials.len()];
        for t in &triangles {
            used_materials[t.material as usize] = true;
        }
        let mut features = SceneFeatures::detect(&materials, &used_materials, &lights);
        features.environment = environment.params.present != 0;
        features.textures = any_textured;
        features.normal_maps = triangles.iter().any(|t| t.flags & TRIANGLE_HAS_TANGENTS != 0);
        features.deep_tree = crate::bvh::trail::needs_second_word(bvh.stats.max_depth);
        Ok(FlatScene {
            camera: camera_desc.to_gpu(view.aspect),
            wide_bvh: crate::bvh::WideBvh::collapse(&bvh.nodes),
            nodes: bvh.nodes,
            triangles,
            normals,
            materials,
            used_materials,
            lights,
            camera_desc,
            features,
            bvh_stats: bvh.stats,
            scene_radius,
            scene_center,
            environment,
            default_environment,
            textures,
            texture_bindings,
            texcoords,
            tangents,
        })
    }

    /// What flattening decided on the caller's behalf and should be told: a default sky for a
    /// scene with no light, images halved to fit the texel budget.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.default_environment {
            out.push(
                "the scene has no lights and no --env or --background was given; lighting it with a constant white background of radiance 1 (see README, \"Environment light\")"
                    .into(),
            );
        }
        if self.textures.downscaled > 0 {
            out.push(format!(
                "the textures exceed {} MiB; every image was halved {} time(s) to fit",
                super::texture::TEXEL_BUDGET_BYTES >> 20,
                self.textures.downscaled
            ));
        }
        out
    }

    /// The arrays a texture lookup reads.
    pub fn texture_arrays(&self) -> TextureArrays<'_> {
        TextureArrays {
            texels: &self.textures.texels,
            infos: &self.textures.infos,
            bindings: &self.texture_bindings,
            texcoords: &self.texcoords,
        }
    }

    /// The any-hit test of traversal: a hit counts unless its material's alpha mode
    /// discards it for this ray (`alpha_seed`, see [`super::texture::alpha_accepts`]).
    fn alpha_filter(&self, alpha_seed: u32) -> impl Fn(u32, &crate::geometry::TriangleHit) -> bool + '_ {
        let arrays = self.texture_arrays();
        move |i, h| {
            super::texture::alpha_accepts(
                &self.materials,
                &self.triangles,
                &arrays,
                i,
                Vec3::new(h.b0, h.b1, h.b2),
                alpha_seed,
            )
        }
    }

    /// The nearest hit of `ray`, alpha-tested when the scene has alpha.
    pub fn intersect_closest(
        &self,
        ray: &crate::geometry::Ray,
        alpha_seed: u32,
    ) -> Option<crate::bvh::ClosestHit> {
        if !self.features.alpha {
            return crate::bvh::intersect_closest(&self.wide_bvh, &self.triangles, ray);
        }
        crate::bvh::intersect_closest_filtered(
            &self.wide_bvh,
            &self.triangles,
            ray,
            self.alpha_filter(alpha_seed),
        )
    }

    /// Is anything hit along `ray` (shadow rays), alpha-tested like [`Self::intersect_closest`].
    pub fn intersect_any(&self, ray: &crate::geometry::Ray, alpha_seed: u32) -> bool {
        if !self.features.alpha {
            return crate::bvh::intersect_any(&self.wide_bvh, &self.triangles, ray);
        }
        crate::bvh::intersect_any_filtered(
            &self.wide_bvh,
            &self.triangles,
            ray,
            self.alpha_filter(alpha_seed),
        )
    }

    /// The arrays light sampling reads.
    pub fn light_arrays(&self) -> crate::light::LightArrays<'_> {
        crate::light::LightArrays {
            lights: &self.lights,
            triangles: &self.triangles,
            materials: &self.materials,
            environment: &self.environment.params,
            environment_texels: &self.environment.texels,
            environment_cdf: &self.environment.cdf,
            textures: self.texture_arrays(),
        }
    }
}
