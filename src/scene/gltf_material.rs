//! glTF 2.0 materials, textures and images → [`MaterialDesc`]s, [`TextureDesc`]s and
//! [`ImageDesc`]s: the metallic-roughness core and the KHR material extensions, read from
//! the typed document and, for extensions the `gltf` crate does not model, from the raw
//! JSON. Part of [`super::gltf_load`].

use std::path::Path;

use glam::Vec3;

use super::accessor::scene_folder;
use super::gltf_load::f64_array;
use super::material::{AlphaMode, MaterialDesc, TextureSlot};
use super::texture::{wrap_mode, ImageDesc, TextureDesc};
use super::uri::{read_uri, LoadOptions};
use crate::error::{Error, Result};

/// Most texels per side accepted from a file (the texel array is bounded separately).
const MAX_IMAGE_SIDE: u32 = 16384;

/// Decodes every image (PNG and JPEG; other formats are a warning naming the texture, and
/// inputs reading it fall back to their factor) and reads every texture's sampler.
pub(super) fn load_images_and_textures(
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    file: &Path,
    options: &LoadOptions,
    warnings: &mut Vec<String>,
) -> Result<(Vec<ImageDesc>, Vec<TextureDesc>)> {
    let err = |m: String| Error::scene(file, m);
    let mut images = Vec::new();
    let mut decoded: Vec<Option<usize>> = Vec::new();
    for image in doc.images() {
        let i = image.index();
        let name = image.name().map(|n| format!("image {i} '{n}'")).unwrap_or_else(|| format!("image {i}"));
        let (bytes, mime) = match image.source() {
            gltf::image::Source::Uri { uri, mime_type } => (
                read_uri(uri, scene_folder(file), options).map_err(|m| err(format!("{name}: {m}")))?,
                mime_type.map(str::to_owned),
            ),
            gltf::image::Source::View { view, mime_type } => {
                let buffer = &buffers[view.buffer().index()];
                let bytes = view
                    .offset()
                    .checked_add(view.length())
                    .filter(|end| *end <= buffer.len())
                    .map(|end| buffer[view.offset()..end].to_vec())
                    .ok_or_else(|| {
                        err(format!("{name}: buffer view {} lies outside its buffer", view.index()))
                    })?;
                (bytes, Some(mime_type.to_owned()))
            }
        };
        let format = match image::guess_format(&bytes) {
            Ok(f @ (image::ImageFormat::Png | image::ImageFormat::Jpeg)) => f,
            _ => {
                warnings.push(format!(
                    "{name} ({}) is not PNG or JPEG, which pathlight decodes; textures using it are ignored",
                    mime.unwrap_or_else(|| "unknown type".into())
                ));
                decoded.push(None);
                continue;
            }
        };
        let mut reader = image::ImageReader::with_format(std::io::Cursor::new(&bytes), format);
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(MAX_IMAGE_SIDE);
        limits.max_image_height = Some(MAX_IMAGE_SIDE);
        reader.limits(limits);
        let rgba = reader.decode().map_err(|e| err(format!("{name}: cannot decode: {e}")))?.to_rgba8();
        decoded.push(Some(images.len()));
        images.push(ImageDesc { name, width: rgba.width(), height: rgba.height(), rgba8: rgba.into_raw() });
    }
    let textures = doc
        .textures()
        .map(|t| {
            let sampler = t.sampler();
            TextureDesc {
                image: decoded.get(t.source().index()).copied().flatten(),
                wrap_s: wrap_mode(sampler.wrap_s()),
                wrap_t: wrap_mode(sampler.wrap_t()),
                nearest: sampler.mag_filter() == Some(gltf::texture::MagFilter::Nearest),
                // Without a minFilter the renderer chooses: mip maps.
                mipmaps: !matches!(
                    sampler.min_filter(),
                    Some(gltf::texture::MinFilter::Nearest | gltf::texture::MinFilter::Linear)
                ),
            }
        })
        .collect();
    Ok((images, textures))
}

pub(super) fn slot(info: Option<gltf::texture::Info>) -> Option<TextureSlot> {
    info.map(|i| {
        let (tex_coord, transform) = match i.texture_transform() {
            Some(t) => {
                let sane = |v: f32, default: f32| if v.is_finite() { v } else { default };
                let offset = t.offset().map(|v| sane(v, 0.0));
                let scale = t.scale().map(|v| sane(v, 1.0));
                (
                    t.tex_coord().unwrap_or(i.tex_coord()),
                    TextureSlot::transform_from(offset, sane(t.rotation(), 0.0), scale),
                )
            }
            None => (i.tex_coord(), TextureSlot::IDENTITY),
        };
        TextureSlot { texture: i.texture().index(), tex_coord, transform }
    })
}

/// A `textureInfo` (or `normalTextureInfo`) read from the raw JSON, with its
/// KHR_texture_transform: for the extensions the gltf crate does not parse. `Ok(None)` when
/// absent.
pub(super) fn raw_texture_slot(
    v: &serde_json::Value,
    texture_count: usize,
    what: &str,
) -> std::result::Result<Option<TextureSlot>, String> {
    if v.is_null() {
        return Ok(None);
    }
    let index = v["index"].as_u64().ok_or_else(|| format!("{what}.index must be a non-negative integer"))?;
    if index as usize >= texture_count || index > u32::MAX as u64 {
        return Err(format!("{what}.index is {index}, but the file has {texture_count} textures"));
    }
    let tex_coord = |v: &serde_json::Value, default: u64| -> std::result::Result<u32, String> {
        match v {
            serde_json::Value::Null => Ok(default as u32),
            v => v
                .as_u64()
                .filter(|&t| t <= u32::MAX as u64)
                .map(|t| t as u32)
                .ok_or_else(|| format!("{what}.texCoord must be a non-negative integer")),
        }
    };
    let base_tex_coord = tex_coord(&v["texCoord"], 0)?;
    let t = &v["extensions"]["KHR_texture_transform"];
    let (tex_coord, transform) = if t.is_object() {
        let sane = |x: f64, default: f32| if x.is_finite() { x as f32 } else { default };
        let offset = f64_array::<2>(t.get("offset"), [0.0, 0.0], "KHR_texture_transform.offset")?;
        let scale = f64_array::<2>(t.get("scale"), [1.0, 1.0], "KHR_texture_transform.scale")?;
        let rotation = t["rotation"].as_f64().unwrap_or(0.0);
        (
            tex_coord(&t["texCoord"], base_tex_coord as u64)?,
            TextureSlot::transform_from(
                [sane(offset[0], 0.0), sane(offset[1], 0.0)],
                sane(rotation, 0.0),
                [sane(scale[0], 1.0), sane(scale[1], 1.0)],
            ),
        )
    } else {
        (base_tex_coord, TextureSlot::IDENTITY)
    };
    Ok(Some(TextureSlot { texture: index as usize, tex_coord, transform }))
}

/// A number of the raw JSON, `default` when absent; an error when present and not a finite
/// number.
pub(super) fn raw_number(
    v: &serde_json::Value,
    default: f32,
    what: &str,
) -> std::result::Result<f32, String> {
    match v {
        serde_json::Value::Null => Ok(default),
        v => v
            .as_f64()
            .map(|x| x as f32)
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{what} must be a finite number")),
    }
}

/// What the gltf crate does not read, from the material's raw JSON: KHR_materials_clearcoat,
/// KHR_materials_sheen, and KHR_texture_transform on the normal texture.
pub(super) fn read_raw_material(
    m: &serde_json::Value,
    texture_count: usize,
    desc: &mut MaterialDesc,
) -> std::result::Result<(), String> {
    if let Some(slot) = raw_texture_slot(&m["normalTexture"], texture_count, "normalTexture")? {
        desc.normal_texture = Some(slot);
    }
    let c = &m["extensions"]["KHR_materials_clearcoat"];
    if c.is_object() {
        desc.clearcoat = raw_number(&c["clearcoatFactor"], 0.0, "clearcoatFactor")?.clamp(0.0, 1.0);
        desc.clearcoat_roughness =
            raw_number(&c["clearcoatRoughnessFactor"], 0.0, "clearcoatRoughnessFactor")?.clamp(0.0, 1.0);
        desc.clearcoat_texture = raw_texture_slot(&c["clearcoatTexture"], texture_count, "clearcoatTexture")?;
        desc.clearcoat_roughness_texture =
            raw_texture_slot(&c["clearcoatRoughnessTexture"], texture_count, "clearcoatRoughnessTexture")?;
        let normal = &c["clearcoatNormalTexture"];
        desc.clearcoat_normal_texture = raw_texture_slot(normal, texture_count, "clearcoatNormalTexture")?;
        desc.clearcoat_normal_scale = raw_number(&normal["scale"], 1.0, "clearcoatNormalTexture.scale")?;
    }
    let sh = &m["extensions"]["KHR_materials_sheen"];
    if sh.is_object() {
        let color = f64_array::<3>(sh.get("sheenColorFactor"), [0.0; 3], "sheenColorFactor")?;
        let color = Vec3::new(color[0] as f32, color[1] as f32, color[2] as f32);
        if !color.is_finite() {
            return Err("sheenColorFactor must be finite".into());
        }
        desc.sheen_color = color.clamp(Vec3::ZERO, Vec3::ONE);
        desc.sheen_roughness =
            raw_number(&sh["sheenRoughnessFactor"], 0.0, "sheenRoughnessFactor")?.clamp(0.0, 1.0);
        desc.sheen_color_texture =
            raw_texture_slot(&sh["sheenColorTexture"], texture_count, "sheenColorTexture")?;
        desc.sheen_roughness_texture =
            raw_texture_slot(&sh["sheenRoughnessTexture"], texture_count, "sheenRoughnessTexture")?;
    }
    Ok(())
}

pub(super) fn read_material(m: &gltf::Material, file: &Path) -> Result<MaterialDesc> {
    let index = m.index().unwrap_or(0);
    let name = m.name().map(str::to_owned).unwrap_or_else(|| format!("material {index}"));
    let err = |what: &str| Error::scene(file, format!("material {index} '{name}': {what} is not finite"));
    let pbr = m.pbr_metallic_roughness();
    let bc = pbr.base_color_factor();
    let strength = m.emissive_strength().unwrap_or(1.0);
    let emission = Vec3::from(m.emissive_factor()) * strength;
    if !emission.is_finite() {
        return Err(err("emissiveFactor × emissiveStrength"));
    }
    let finite = |v: f32, what: &str| if v.is_finite() { Ok(v) } else { Err(err(what)) };
    let mut desc = MaterialDesc {
        name: name.clone(),
        base_color: Vec3::new(bc[0], bc[1], bc[2]).clamp(Vec3::ZERO, Vec3::ONE),
        alpha: finite(bc[3], "baseColorFactor")?.clamp(0.0, 1.0),
        metallic: finite(pbr.metallic_factor(), "metallicFactor")?.clamp(0.0, 1.0),
        roughness: finite(pbr.roughness_factor(), "roughnessFactor")?.clamp(0.0, 1.0),
        emission: emission.max(Vec3::ZERO),
        double_sided: m.double_sided(),
        alpha_mode: match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
            gltf::material::AlphaMode::Mask => AlphaMode::Mask,
            gltf::material::AlphaMode::Blend => AlphaMode::Blend,
        },
        alpha_cutoff: m.alpha_cutoff().filter(|c| c.is_finite()).unwrap_or(0.5),
        base_color_texture: slot(pbr.base_color_texture()),
        metallic_roughness_texture: slot(pbr.metallic_roughness_texture()),
        // normalTexture is re-read with its KHR_texture_transform by `read_raw_material`.
        normal_texture: m.normal_texture().map(|t| TextureSlot {
            texture: t.texture().index(),
            tex_coord: t.tex_coord(),
            transform: TextureSlot::IDENTITY,
        }),
        normal_scale: m.normal_texture().map(|t| t.scale()).filter(|s| s.is_finite()).unwrap_or(1.0),
        occlusion_texture: m.occlusion_texture().map(|t| TextureSlot {
            texture: t.texture().index(),
            tex_coord: t.tex_coord(),
            transform: TextureSlot::IDENTITY,
        }),
        emissive_texture: slot(m.emissive_texture()),
        ..MaterialDesc::default()
    };
    if !Vec3::new(bc[0], bc[1], bc[2]).is_finite() {
        return Err(err("baseColorFactor"));
    }
    if let Some(ior) = m.ior() {
        let ior = finite(ior, "ior")?;
        // KHR_materials_ior: 0 (meaning ∞) or ≥ 1.
        desc.ior = if ior == 0.0 { 0.0 } else { ior.max(1.0) };
    }
    if let Some(s) = m.specular() {
        desc.specular_factor = finite(s.specular_factor(), "specularFactor")?.clamp(0.0, 1.0);
        let c = Vec3::from(s.specular_color_factor());
        if !c.is_finite() {
            return Err(err("specularColorFactor"));
        }
        desc.specular_color = c.max(Vec3::ZERO);
        desc.specular_texture = slot(s.specular_texture());
        desc.specular_color_texture = slot(s.specular_color_texture());
    }
    if let Some(t) = m.transmission() {
        desc.transmission = finite(t.transmission_factor(), "transmissionFactor")?.clamp(0.0, 1.0);
        desc.transmission_texture = slot(t.transmission_texture());
    }
    if let Some(v) = m.volume() {
        desc.thickness = finite(v.thickness_factor(), "thicknessFactor")?.max(0.0);
        let d = v.attenuation_distance();
        desc.attenuation_distance = if d > 0.0 { d } else { f32::INFINITY };
        let c = Vec3::from(v.attenuation_color());
        if !c.is_finite() {
            return Err(err("attenuationColor"));
        }
        desc.attenuation_color = c.clamp(Vec3::ZERO, Vec3::ONE);
        desc.thickness_texture = slot(v.thickness_texture());
    }
    Ok(desc)
}
