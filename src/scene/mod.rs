//! Scenes: loading glTF, and flattening to the arrays both backends render from.

mod accessor;
pub mod camera;
mod features;
mod flat;
mod gltf_load;
pub mod light;
pub mod material;
mod normals;

use std::path::PathBuf;

use glam::{DVec3, Vec3};

pub use camera::{CameraDesc, Projection};
pub use features::SceneFeatures;
pub use flat::{FlatScene, ViewSettings};
pub use gltf_load::{load, load_from_bytes, SUPPORTED_EXTENSIONS};
pub use light::{PunctualKind, PunctualLight};
pub use material::{AlphaMode, MaterialDesc, TextureSlot};
pub use normals::{oct_decode, oct_encode};

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

    /// Adds a triangle (used by scene generators and tests).
    pub fn push_triangle(&mut self, p: [DVec3; 3], normals: Option<[Vec3; 3]>, material: u32) {
        self.positions.extend_from_slice(&p);
        self.normals.push(normals);
        self.triangle_materials.push(material);
    }
}
