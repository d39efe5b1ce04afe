//! Which parts of the renderer a scene actually needs ("model only what a scene needs").
//! The GPU kernel is specialised to this set; the CPU reference ignores it, so a wrong
//! feature set shows up as a GPU–CPU disagreement in the equivalence tests.

use crate::scene::layout::{
    self, LIGHT_DIRECTIONAL, LIGHT_POINT, LIGHT_SPOT, LIGHT_TRIANGLE, MATERIAL_VOLUME,
};

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SceneFeatures {
    /// Some material has a GGX lobe (metallic > 0, or a dielectric specular layer), rough or
    /// smooth.
    pub specular: bool,
    /// Some material transmits (KHR_materials_transmission > 0).
    pub transmission: bool,
    /// Some transmissive material is a refracting solid with Beer–Lambert absorption.
    pub volume: bool,
    /// Some triangle emits.
    pub emissive_triangles: bool,
    /// Point or spot lights.
    pub point_lights: bool,
    /// Spot lights (their cone falloff).
    pub spot_lights: bool,
    pub directional_lights: bool,
    /// An environment light (a map or a constant background).
    pub environment: bool,
    /// Some material reads a texture.
    pub textures: bool,
    /// Some triangle is normal-mapped.
    pub normal_maps: bool,
    /// Some material's alpha mode is MASK or BLEND (alpha tests inside traversal).
    pub alpha: bool,
    /// Some material has a clear coat (KHR_materials_clearcoat factor > 0).
    pub clearcoat: bool,
    /// Some material has a sheen (KHR_materials_sheen colour not black).
    pub sheen: bool,
    /// The BVH has nodes more than 32 levels below its root, so the kernel's restart trail
    /// needs its second 32-bit word (`traverse` in shaders/bvh.wgsl): 5% of lavapipe's
    /// render time on the bunny in the Cornell box when kept where it is not needed.
    pub deep_tree: bool,
}

impl SceneFeatures {
    /// Every feature on: the un-specialised kernel.
    pub const ALL: SceneFeatures = SceneFeatures {
        specular: true,
        transmission: true,
        volume: true,
        emissive_triangles: true,
        point_lights: true,
        spot_lights: true,
        directional_lights: true,
        environment: true,
        textures: true,
        normal_maps: true,
        alpha: true,
        clearcoat: true,
        sheen: true,
        deep_tree: true,
    };

    /// The features of `materials[i]` for every `i` in `used_materials`, and of `lights`.
    pub fn detect(
        materials: &[layout::Material],
        used_materials: &[bool],
        lights: &[layout::Light],
    ) -> SceneFeatures {
        let mut f = SceneFeatures::default();
        for (m, _) in materials.iter().zip(used_materials).filter(|(_, used)| **used) {
            // The dielectric specular layer vanishes only when specularFactor is 0; a metal
            // lobe needs metallic > 0.
            f.specular |= m.metallic > 0.0 || m.specular_factor > 0.0;
            f.transmission |= m.transmission > 0.0;
            f.volume |= m.flags & MATERIAL_VOLUME != 0;
            f.alpha |= m.flags & (layout::MATERIAL_ALPHA_MASK | layout::MATERIAL_ALPHA_BLEND) != 0;
            f.clearcoat |= m.clearcoat > 0.0;
            f.sheen |= m.sheen_color.iter().any(|&c| c > 0.0);
        }
        for l in lights {
            match l.kind {
                LIGHT_TRIANGLE => f.emissive_triangles = true,
                LIGHT_POINT => f.point_lights = true,
                LIGHT_SPOT => {
                    f.point_lights = true;
                    f.spot_lights = true
                }
                LIGHT_DIRECTIONAL => f.directional_lights = true,
                _ => {}
            }
        }
        f
    }

    /// The features of either: a kernel specialised to them renders scenes of both kinds.
    pub fn union(&self, other: &SceneFeatures) -> SceneFeatures {
        SceneFeatures {
            specular: self.specular || other.specular,
            transmission: self.transmission || other.transmission,
            volume: self.volume || other.volume,
            emissive_triangles: self.emissive_triangles || other.emissive_triangles,
            point_lights: self.point_lights || other.point_lights,
            spot_lights: self.spot_lights || other.spot_lights,
            directional_lights: self.directional_lights || other.directional_lights,
            environment: self.environment || other.environment,
            textures: self.textures || other.textures,
            normal_maps: self.normal_maps || other.normal_maps,
            alpha: self.alpha || other.alpha,
            clearcoat: self.clearcoat || other.clearcoat,
            sheen: self.sheen || other.sheen,
            deep_tree: self.deep_tree || other.deep_tree,
        }
    }

    /// `(WGSL override name, value)` for each feature, as the kernel declares them.
    pub fn pipeline_constants(&self) -> [(&'static str, bool); 14] {
        [
            ("FEATURE_SPECULAR", self.specular),
            ("FEATURE_TRANSMISSION", self.transmission),
            ("FEATURE_VOLUME", self.volume),
            ("FEATURE_EMISSIVE_TRIANGLES", self.emissive_triangles),
            ("FEATURE_POINT_LIGHTS", self.point_lights),
            ("FEATURE_SPOT_LIGHTS", self.spot_lights),
            ("FEATURE_DIRECTIONAL_LIGHTS", self.directional_lights),
            ("FEATURE_ENVIRONMENT", self.environment),
            ("FEATURE_TEXTURES", self.textures),
            ("FEATURE_NORMAL_MAPS", self.normal_maps),
            ("FEATURE_ALPHA", self.alpha),
            ("FEATURE_CLEARCOAT", self.clearcoat),
            ("FEATURE_SHEEN", self.sheen),
            ("FEATURE_DEEP_TREE", self.deep_tree),
        ]
    }

    /// A short human-readable list, e.g. `specular+emissive`.
    pub fn describe(&self) -> String {
        let names: Vec<&str> = self
            .pipeline_constants()
            .iter()
            .filter(|(_, on)| *on)
            .map(|(n, _)| n.trim_start_matches("FEATURE_"))
            .collect();
        if names.is_empty() {
            "diffuse only".into()
        } else {
            names.join("+").to_lowercase()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each feature of a union is on exactly where either side has it on.
    #[test]
    fn a_union_has_each_feature_of_either() {
        let a = SceneFeatures { specular: true, textures: true, ..SceneFeatures::default() };
        let b = SceneFeatures { textures: true, sheen: true, deep_tree: true, ..SceneFeatures::default() };
        let u = a.union(&b);
        for ((name, on), ((_, in_a), (_, in_b))) in u
            .pipeline_constants()
            .into_iter()
            .zip(a.pipeline_constants().into_iter().zip(b.pipeline_constants()))
        {
            assert_eq!(on, in_a || in_b, "{name}");
        }
        assert_eq!(a.union(&SceneFeatures::default()), a);
        assert_eq!(a.union(&SceneFeatures::ALL), SceneFeatures::ALL);
    }
}
