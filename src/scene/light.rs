//! KHR_lights_punctual lights as placed in the world.

use glam::{DVec3, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PunctualKind {
    Point,
    /// Cone angles in radians.
    Spot {
        inner_cone_angle: f32,
        outer_cone_angle: f32,
    },
    Directional,
}

/// A punctual light. Intensity is `color × intensity` in the renderer's linear units:
/// candela for point and spot lights and lux for directional lights, taken as radiometric
/// (no 683 lm/W conversion), consistent with emissive materials. `range` is ignored: light
/// falls off with the inverse square of distance, as the extension's physically based
/// reading says.
#[derive(Clone, Debug, PartialEq)]
pub struct PunctualLight {
    pub name: String,
    pub kind: PunctualKind,
    pub intensity: Vec3,
    pub position: DVec3,
    /// Unit direction the light travels in (the node's −Z); unused for point lights.
    pub direction: DVec3,
}
