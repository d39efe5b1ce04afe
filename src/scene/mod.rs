//! Scenes: loading glTF, and flattening to the arrays both backends render from.

mod accessor;
pub mod camera;
mod features;
mod flat;
mod gltf_load;
mod gltf_material;
mod gltf_mesh;
pub mod layout;
pub mod light;
pub mod material;
mod normals;
pub mod texture;
pub mod uri;

use std::path::PathBuf;

use glam::{DVec3, Vec3};

pub use camera::{CameraDesc, Projection};
pub use features::SceneFeatures;
pub use flat::{luminance, FlatScene, ViewSettings, DEFAULT_BACKGROUND};
pub use gltf_load::{load, load_from_bytes, load_with, SUPPORTED_EXTENSIONS};
pub use light::{PunctualKind, PunctualLight};
pub use material::{AlphaMode, MaterialDesc, TextureSlot};
pub use normals::{oct_decode, oct_encode};
pub use uri::LoadOptions;

/// A scene of the repository's `scenes/` folder (`name` relative to it), flattened with its
/// own camera at a square aspect: the fixture of unit tests that need real geometry.
#[cfg(test)]
pub(crate) fn bundled_flat_scene(name: &str) -> FlatScene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    let (scene, _) = load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
    FlatScene::build(&scene, &ViewSettings { camera: None, aspect: 1.0 })
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// A node's world transform as it applies to a mesh: points by the affine matrix, normals by
/// the inverse transpose of its linear part (pbrt-v4 §3.10.3), and the winding flipped when
/// the determinant is negative so front faces stay front faces (glTF 2.0 §3.7.4).
#[derive(Clone, Copy, Debug)]
pub struct MeshTransform {
    world: glam::DMat4,
    normal_matrix: glam::DMat3,
    pub flips_winding: bool,
}

impl MeshTransform {
    pub fn new(world: glam::DMat4) -> MeshTransform {
        let linear = glam::DMat3::from_mat4(world);
        MeshTransform {
            world,
            normal_matrix: linear.inverse().transpose(),
            flips_winding: linear.determinant() < 0.0,
        }
    }

    /// A direction (tangent) by the linear part alone, not normalised.
    pub fn vector(&self, v: DVec3) -> DVec3 {
        self.world.transform_vector3(v)
    }

    pub fn point(&self, p: DVec3) -> DVec3 {
        self.world.transform_point3(p)
    }

    /// The unit world-space normal, or `None` if it is zero or not finite.
    pub fn normal(&self, n: DVec3) -> Option<Vec3> {
        (self.normal_matrix * n).try_normalize().map(|w| w.as_vec3())
    }
}

/// A loaded scene in world space, geometry in f64.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// The file it came from.
    pub source: PathBuf,
    /// Three world-space vertices per triangle, counter-clockwise seen from the front.
    pub positions: Vec<DVec3>,
    /// Per triangle: unit world-space vertex normals, or `None` for flat shading.
    pub normals: Vec<Option<[Vec3; 3]>>,
    /// Per triangle: index into `materials`.
    pub triangle_materials: Vec<u32>,
    pub materials: Vec<MaterialDesc>,
    pub lights: Vec<PunctualLight>,
    pub cameras: Vec<CameraDesc>,
    /// Light from infinitely far away (`--env`, `--background`); glTF files carry none.
    pub environment: Option<crate::light::EnvironmentDesc>,
    /// Per triangle: texture coordinates of UV sets 0 and 1 (zero where the file has none).
    pub texcoords: Vec<[[glam::Vec2; 3]; 2]>,
    /// Per triangle: world-space unit tangents and bitangent signs (glTF `TANGENT`, or
    /// MikkTSpace's), where a normal texture needs them.
    pub tangents: Vec<Option<[glam::Vec4; 3]>>,
    pub images: Vec<texture::ImageDesc>,
    /// glTF textures, indexed as in the file.
    pub textures: Vec<texture::TextureDesc>,
}

impl Scene {
    pub fn triangle_count(&self) -> usize {
        self.triangle_materials.len()
    }

    /// World-space bounds of all triangles (`None` when there are none).
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        let first = *self.positions.first()?;
        Some(self.positions.iter().fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))))
    }

    /// Appends every triangle of `other`, transformed by `transform` (f64), with its
    /// materials; `material` overrides them all when given. Lights and cameras of `other`
    /// are not taken. Used to compose benchmark scenes (a scanned mesh in a lit room).
    pub fn append(&mut self, other: &Scene, transform: glam::DMat4, material: Option<MaterialDesc>) {
        let base = self.materials.len() as u32;
        let overridden = material.is_some();
        // Textures and images follow their materials, their indices shifted.
        let (texture_base, image_base) = (self.textures.len(), self.images.len());
        self.images.extend(other.images.iter().cloned());
        self.textures.extend(
            other
                .textures
                .iter()
                .map(|t| texture::TextureDesc { image: t.image.map(|i| i + image_base), ..t.clone() }),
        );
        match material {
            Some(m) => self.materials.push(m),
            None => {
                self.materials.extend(other.materials.iter().map(|m| m.with_texture_offset(texture_base)))
            }
        }
        let t = MeshTransform::new(transform);
        for (i, tri) in other.positions.chunks_exact(3).enumerate() {
            let mut p = [tri[0], tri[1], tri[2]].map(|v| t.point(v));
            let mut n = other.normals[i].and_then(|[a, b, c]| {
                Some([t.normal(a.as_dvec3())?, t.normal(b.as_dvec3())?, t.normal(c.as_dvec3())?])
            });
            if t.flips_winding {
                p.swap(1, 2);
                if let Some(ns) = n.as_mut() {
                    ns.swap(1, 2);
                }
            }
            let m = if overridden { base } else { base + other.triangle_materials[i] };
            let mut uv = other.texcoords[i];
            let mut tangents = other.tangents[i].map(|ts| {
                ts.map(|tv| {
                    let d = t.vector(tv.truncate().as_dvec3()).normalize_or_zero().as_vec3();
                    // A mirroring transform flips the bitangent (its sign) with the winding.
                    d.extend(if t.flips_winding { -tv.w } else { tv.w })
                })
            });
            if t.flips_winding {
                uv[0].swap(1, 2);
                uv[1].swap(1, 2);
                if let Some(ts) = tangents.as_mut() {
                    ts.swap(1, 2);
                }
            }
            self.push_triangle(p, n, m);
            let last = self.texcoords.len() - 1;
            self.texcoords[last] = uv;
            self.tangents[last] = tangents;
        }
    }

    /// Adds a triangle (used by scene generators and tests), with no UVs or tangents.
    pub fn push_triangle(&mut self, p: [DVec3; 3], normals: Option<[Vec3; 3]>, material: u32) {
        self.positions.extend_from_slice(&p);
        self.normals.push(normals);
        self.triangle_materials.push(material);
        self.texcoords.push([[glam::Vec2::ZERO; 3]; 2]);
        self.tangents.push(None);
    }
}
