//! Materials as the glTF file describes them, and their reduction to the kernel's
//! [`Material`](crate::scene::layout::Material).

use glam::Vec3;

use crate::bsdf::alpha_from_roughness;
use crate::scene::layout::{
    self, MATERIAL_ALPHA_BLEND, MATERIAL_ALPHA_MASK, MATERIAL_DOUBLE_SIDED, MATERIAL_VOLUME,
};

/// A texture reference (glTF `textureInfo`, with KHR_texture_transform applied).
#[derive(Clone, Debug, PartialEq)]
pub struct TextureSlot {
    /// Index into the glTF `textures` array.
    pub texture: usize,
    /// Which `TEXCOORD_n` set it reads (after KHR_texture_transform's override).
    pub tex_coord: u32,
    /// KHR_texture_transform as two rows of an affine map: uv' = (row0 · (u, v, 1),
    /// row1 · (u, v, 1)); the identity without the extension.
    pub transform: [[f32; 3]; 2],
}

impl TextureSlot {
    pub const IDENTITY: [[f32; 3]; 2] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

    /// KHR_texture_transform's matrix translation · rotation · scale. The rotation turns UVs
    /// counter-clockwise as the extension's text says, in UV space whose v axis points down
    /// the image: u' = cos·u + sin·v, v' = −sin·u + cos·v. (One copy of the extension's GLSL
    /// sample has the opposite sign; the Khronos TextureTransformTest model, whose markers
    /// say which way is right, and the sample viewers agree with this one.)
    pub fn transform_from(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> [[f32; 3]; 2] {
        let (s, c) = rotation.sin_cos();
        [[c * scale[0], s * scale[1], offset[0]], [-s * scale[0], c * scale[1], offset[1]]]
    }
}

/// How the glTF `alphaMode` asks for coverage to be treated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AlphaMode {
    Opaque,
    Mask,
    Blend,
}

/// One glTF material with the extensions pathlight supports, factors sanitised.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialDesc {
    pub name: String,
    pub base_color: Vec3,
    pub alpha: f32,
    pub metallic: f32,
    pub roughness: f32,
    /// `emissiveFactor × KHR_materials_emissive_strength.emissiveStrength`.
    pub emission: Vec3,
    /// glTF `normalTexture.scale`.
    pub normal_scale: f32,
    pub double_sided: bool,
    pub alpha_mode: AlphaMode,
    /// glTF `alphaCutoff` (0.5 when absent).
    pub alpha_cutoff: f32,
    /// KHR_materials_ior (1.5 when absent).
    pub ior: f32,
    /// KHR_materials_specular (1 and white when absent).
    pub specular_factor: f32,
    pub specular_color: Vec3,
    /// KHR_materials_transmission (0 when absent).
    pub transmission: f32,
    /// KHR_materials_volume `thicknessFactor` (0: thin-walled).
    pub thickness: f32,
    pub attenuation_distance: f32,
    pub attenuation_color: Vec3,
    pub base_color_texture: Option<TextureSlot>,
    pub metallic_roughness_texture: Option<TextureSlot>,
    pub normal_texture: Option<TextureSlot>,
    pub occlusion_texture: Option<TextureSlot>,
    pub emissive_texture: Option<TextureSlot>,
    pub transmission_texture: Option<TextureSlot>,
    pub specular_texture: Option<TextureSlot>,
    pub specular_color_texture: Option<TextureSlot>,
    pub thickness_texture: Option<TextureSlot>,
    /// KHR_materials_clearcoat (factor 0 when absent: no coat).
    pub clearcoat: f32,
    pub clearcoat_roughness: f32,
    pub clearcoat_texture: Option<TextureSlot>,
    pub clearcoat_roughness_texture: Option<TextureSlot>,
    pub clearcoat_normal_texture: Option<TextureSlot>,
    pub clearcoat_normal_scale: f32,
    /// KHR_materials_sheen (black when absent: no sheen).
    pub sheen_color: Vec3,
    pub sheen_roughness: f32,
    pub sheen_color_texture: Option<TextureSlot>,
    pub sheen_roughness_texture: Option<TextureSlot>,
}

impl Default for MaterialDesc {
    /// The glTF default material (spec §3.9.6): white, fully metallic, fully rough.
    fn default() -> Self {
        MaterialDesc {
            name: "default".into(),
            base_color: Vec3::ONE,
            alpha: 1.0,
            metallic: 1.0,
            roughness: 1.0,
            emission: Vec3::ZERO,
            normal_scale: 1.0,
            double_sided: false,
            alpha_mode: AlphaMode::Opaque,
            alpha_cutoff: 0.5,
            ior: 1.5,
            specular_factor: 1.0,
            specular_color: Vec3::ONE,
            transmission: 0.0,
            thickness: 0.0,
            attenuation_distance: f32::INFINITY,
            attenuation_color: Vec3::ONE,
            base_color_texture: None,
            metallic_roughness_texture: None,
            normal_texture: None,
            occlusion_texture: None,
            emissive_texture: None,
            transmission_texture: None,
            specular_texture: None,
            specular_color_texture: None,
            thickness_texture: None,
            clearcoat: 0.0,
            clearcoat_roughness: 0.0,
            clearcoat_texture: None,
            clearcoat_roughness_texture: None,
            clearcoat_normal_texture: None,
            clearcoat_normal_scale: 1.0,
            sheen_color: Vec3::ZERO,
            sheen_roughness: 0.0,
            sheen_color_texture: None,
            sheen_roughness_texture: None,
        }
    }
}

/// KHR_materials_ior allows `ior = 0` to mean "infinite" (full specular reflection, for
/// specular-glossiness conversions); this finite stand-in gives F₀ = 0.9996.
const IOR_INFINITE_STANDIN: f32 = 1e4;

impl MaterialDesc {
    /// Every texture slot, read-only.
    fn texture_slots(&self) -> [&Option<TextureSlot>; 14] {
        [
            &self.base_color_texture,
            &self.metallic_roughness_texture,
            &self.normal_texture,
            &self.occlusion_texture,
            &self.emissive_texture,
            &self.transmission_texture,
            &self.specular_texture,
            &self.specular_color_texture,
            &self.thickness_texture,
            &self.clearcoat_texture,
            &self.clearcoat_roughness_texture,
            &self.clearcoat_normal_texture,
            &self.sheen_color_texture,
            &self.sheen_roughness_texture,
        ]
    }

    /// The glTF textures this material reads as sRGB colour (baseColor, emissive, specular
    /// colour, sheen colour).
    pub fn srgb_textures(&self) -> impl Iterator<Item = usize> + '_ {
        [
            &self.base_color_texture,
            &self.emissive_texture,
            &self.specular_color_texture,
            &self.sheen_color_texture,
        ]
        .into_iter()
        .filter_map(|t| t.as_ref().map(|t| t.texture))
    }

    /// Does the material refer to any texture?
    pub fn uses_textures(&self) -> bool {
        self.texture_slots().iter().any(|t| t.is_some())
    }

    /// The same material with every texture index shifted by `offset` (scenes merged).
    pub fn with_texture_offset(&self, offset: usize) -> MaterialDesc {
        let mut m = self.clone();
        for slot in [
            &mut m.base_color_texture,
            &mut m.metallic_roughness_texture,
            &mut m.normal_texture,
            &mut m.occlusion_texture,
            &mut m.emissive_texture,
            &mut m.transmission_texture,
            &mut m.specular_texture,
            &mut m.specular_color_texture,
            &mut m.thickness_texture,
            &mut m.clearcoat_texture,
            &mut m.clearcoat_roughness_texture,
            &mut m.clearcoat_normal_texture,
            &mut m.sheen_color_texture,
            &mut m.sheen_roughness_texture,
        ] {
            if let Some(t) = slot.as_mut() {
                t.texture += offset;
            }
        }
        m
    }

    /// Does the material need a tangent frame (a normal map on the base or on the coat)?
    pub fn needs_tangents(&self) -> Option<&TextureSlot> {
        self.normal_texture.as_ref().or(self.clearcoat_normal_texture.as_ref())
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// A refracting solid (KHR_materials_volume with thickness > 0 on a transmissive
    /// material); otherwise transmission is thin-walled.
    pub fn is_volume(&self) -> bool {
        self.thickness > 0.0 && self.transmission > 0.0
    }

    /// The kernel's view of this material. Each texture input becomes an entry of
    /// `bindings`; `usable(texture)` says whether a glTF texture was decoded (an input whose
    /// image could not be is left untextured: its factor alone).
    pub fn to_gpu(
        &self,
        bindings: &mut Vec<layout::TextureBinding>,
        usable: &dyn Fn(usize) -> bool,
    ) -> layout::Material {
        let mut bind = |slot: &Option<TextureSlot>| -> u32 {
            match slot {
                Some(t) if usable(t.texture) => {
                    bindings.push(layout::TextureBinding {
                        row0: t.transform[0],
                        texture: t.texture as u32,
                        row1: t.transform[1],
                        tex_coord: t.tex_coord.min(1),
                    });
                    bindings.len() as u32 - 1
                }
                _ => layout::INVALID_INDEX,
            }
        };
        let ior = if self.ior == 0.0 { IOR_INFINITE_STANDIN } else { self.ior };
        // Beer–Lambert: transmittance over distance d is attenuationColor^(d / distance),
        // i.e. exp(−σₐ d) with σₐ = −ln(c) / distance (KHR_materials_volume). A colour of 0 is
        // clamped so σₐ stays finite (1e-6 per attenuation distance is already black).
        let sigma = if self.attenuation_distance.is_finite() && self.is_volume() {
            let c = self.attenuation_color.clamp(Vec3::splat(1e-6), Vec3::ONE);
            Vec3::new(-c.x.ln(), -c.y.ln(), -c.z.ln()) / self.attenuation_distance
        } else {
            Vec3::ZERO
        };
        let mut flags = 0;
        if self.double_sided {
            flags |= MATERIAL_DOUBLE_SIDED;
        }
        if self.is_volume() {
            flags |= MATERIAL_VOLUME;
        }
        flags |= match self.alpha_mode {
            AlphaMode::Opaque => 0,
            AlphaMode::Mask => MATERIAL_ALPHA_MASK,
            AlphaMode::Blend => MATERIAL_ALPHA_BLEND,
        };
        layout::Material {
            base_color: self.base_color.to_array(),
            alpha: self.alpha,
            emission: self.emission.to_array(),
            flags,
            specular_color: self.specular_color.to_array(),
            specular_factor: self.specular_factor,
            attenuation_coefficient: sigma.to_array(),
            ior,
            metallic: self.metallic,
            alpha_roughness: alpha_from_roughness(self.roughness),
            transmission: self.transmission,
            roughness: self.roughness,
            base_color_texture: bind(&self.base_color_texture),
            metallic_roughness_texture: bind(&self.metallic_roughness_texture),
            normal_texture: bind(&self.normal_texture),
            emissive_texture: bind(&self.emissive_texture),
            transmission_texture: bind(&self.transmission_texture),
            specular_texture: bind(&self.specular_texture),
            specular_color_texture: bind(&self.specular_color_texture),
            normal_scale: self.normal_scale,
            alpha_cutoff: self.alpha_cutoff,
            clearcoat: self.clearcoat,
            clearcoat_roughness: self.clearcoat_roughness,
            clearcoat_texture: bind(&self.clearcoat_texture),
            clearcoat_roughness_texture: bind(&self.clearcoat_roughness_texture),
            clearcoat_normal_texture: bind(&self.clearcoat_normal_texture),
            clearcoat_normal_scale: self.clearcoat_normal_scale,
            sheen_roughness: self.sheen_roughness,
            sheen_color: self.sheen_color.to_array(),
            sheen_color_texture: bind(&self.sheen_color_texture),
            sheen_roughness_texture: bind(&self.sheen_roughness_texture),
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        }
    }
}
