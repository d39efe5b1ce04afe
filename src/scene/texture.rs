//! Textures: decoded glTF images with their samplers, flattened into one texel array both
//! backends read, and the lookup both perform (WGSL twin: `shaders/texture.wgsl`).
//!
//! Conventions (glTF 2.0 §3.8): UV (0, 0) is the image's top-left corner; texel (i, j) covers
//! [i, i+1] × [j, j+1] / (width, height). baseColor, emissive and specular colour are sRGB
//! encoded (decoded per texel with the exact IEC 61966-2-1 curve, before filtering); every
//! other input is linear. Filtering is bilinear, or nearest when the sampler's `magFilter` is
//! NEAREST; wrap modes REPEAT, CLAMP_TO_EDGE and MIRRORED_REPEAT per axis.

use glam::{Vec2, Vec3, Vec4};

use super::layout::{
    Material, TextureBinding, TextureInfo, TriangleTexcoords, INVALID_INDEX, MATERIAL_ALPHA_BLEND,
    MATERIAL_ALPHA_MASK, TEXTURE_NEAREST, WRAP_CLAMP_TO_EDGE, WRAP_MIRRORED_REPEAT, WRAP_REPEAT,
};
use crate::bsdf::alpha_from_roughness;

/// A decoded image, RGBA8.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageDesc {
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// `width × height × 4` bytes, row 0 at the top.
    pub rgba8: Vec<u8>,
}

/// A glTF texture: an image (when it could be decoded) and how to sample it.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureDesc {
    /// Index into the scene's images; `None` when the image is in a format pathlight does
    /// not decode (the loader warned) — inputs reading it use their factor alone.
    pub image: Option<usize>,
    pub wrap_s: u32,
    pub wrap_t: u32,
    pub nearest: bool,
}

/// The most texel bytes the flattened array may hold: below lavapipe's 128 MiB storage
/// binding (the smallest limit pathlight meets), with room to spare. Larger sets of images
/// are halved in resolution, with a warning, until they fit.
pub const TEXEL_BUDGET_BYTES: usize = 120 << 20;

/// The flattened textures: `infos[i]` for glTF texture `i` (an image shared by several
/// textures is stored once), and the texels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FlatTextures {
    pub infos: Vec<TextureInfo>,
    pub texels: Vec<u32>,
    /// Images halved to fit [`TEXEL_BUDGET_BYTES`], and how often.
    pub downscaled: u32,
}

/// Halves an image (2×2 box filter; odd sizes keep their last row/column).
fn halve(image: &ImageDesc) -> ImageDesc {
    let (w, h) = ((image.width / 2).max(1), (image.height / 2).max(1));
    let mut out = vec![0u8; (w * h * 4) as usize];
    for y in 0..h {
        for x in 0..w {
            for c in 0..4 {
                let mut sum = 0u32;
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let sx = (2 * x + dx).min(image.width - 1);
                    let sy = (2 * y + dy).min(image.height - 1);
                    sum += image.rgba8[((sy * image.width + sx) * 4 + c) as usize] as u32;
                }
                out[((y * w + x) * 4 + c) as usize] = ((sum + 2) / 4) as u8;
            }
        }
    }
    ImageDesc { name: image.name.clone(), width: w, height: h, rgba8: out }
}

impl FlatTextures {
    pub fn build(images: &[ImageDesc], textures: &[TextureDesc]) -> FlatTextures {
        let mut images: Vec<ImageDesc> = images.to_vec();
        let used: Vec<bool> =
            (0..images.len()).map(|i| textures.iter().any(|t| t.image == Some(i))).collect();
        let bytes = |images: &[ImageDesc]| -> usize {
            images.iter().zip(&used).filter(|(_, u)| **u).map(|(i, _)| i.rgba8.len()).sum()
        };
        let mut downscaled = 0;
        while bytes(&images) > TEXEL_BUDGET_BYTES {
            images = images.iter().map(halve).collect();
            downscaled += 1;
        }
        let mut texels = Vec::new();
        let mut offsets = vec![0u32; images.len()];
        for (i, image) in images.iter().enumerate() {
            if !used[i] {
                continue;
            }
            offsets[i] = texels.len() as u32;
            texels.extend(image.rgba8.chunks_exact(4).map(|p| u32::from_le_bytes([p[0], p[1], p[2], p[3]])));
        }
        let infos = textures
            .iter()
            .map(|t| match t.image {
                Some(i) => TextureInfo {
                    offset: offsets[i],
                    width: images[i].width,
                    height: images[i].height,
                    flags: t.wrap_s | (t.wrap_t << 2) | if t.nearest { TEXTURE_NEAREST } else { 0 },
                },
                None => TextureInfo::default(),
            })
            .collect();
        FlatTextures { infos, texels, downscaled }
    }
}

/// glTF sampler wrap mode (WebGL enum) → `WRAP_*`.
pub fn wrap_mode(mode: gltf::texture::WrappingMode) -> u32 {
    match mode {
        gltf::texture::WrappingMode::Repeat => WRAP_REPEAT,
        gltf::texture::WrappingMode::ClampToEdge => WRAP_CLAMP_TO_EDGE,
        gltf::texture::WrappingMode::MirroredRepeat => WRAP_MIRRORED_REPEAT,
    }
}

/// Texel index along an axis of `size` texels for integer coordinate `i`, by wrap mode.
pub fn wrap_texel(i: i32, size: u32, mode: u32) -> u32 {
    let n = size as i32;
    match mode {
        WRAP_CLAMP_TO_EDGE => i.clamp(0, n - 1) as u32,
        WRAP_MIRRORED_REPEAT => {
            let m = i.rem_euclid(2 * n);
            (if m >= n { 2 * n - 1 - m } else { m }) as u32
        }
        _ => i.rem_euclid(n) as u32,
    }
}

/// The exact inverse sRGB transfer function (IEC 61966-2-1).
pub fn srgb_decode(v: f32) -> f32 {
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

fn fetch(texels: &[u32], info: &TextureInfo, x: u32, y: u32, srgb: bool) -> Vec4 {
    let t = texels[(info.offset + y * info.width + x) as usize];
    let c = Vec4::new((t & 255) as f32, ((t >> 8) & 255) as f32, ((t >> 16) & 255) as f32, (t >> 24) as f32)
        / 255.0;
    if srgb {
        Vec4::new(srgb_decode(c.x), srgb_decode(c.y), srgb_decode(c.z), c.w)
    } else {
        c
    }
}

/// Texel coordinates far outside the image carry no information in f32 and would overflow
/// an i32: clamp to ±2²⁴ texels before converting (the wrap then picks a texel as usual).
const MAX_TEXEL_COORDINATE: f32 = 16_777_216.0;

/// Samples texture `info` at `uv` (RGBA in [0, 1], colour decoded from sRGB when `srgb`).
pub fn texture_sample(texels: &[u32], info: &TextureInfo, uv: Vec2, srgb: bool) -> Vec4 {
    let (wrap_s, wrap_t) = (info.flags & 3, (info.flags >> 2) & 3);
    let x = (uv.x * info.width as f32).clamp(-MAX_TEXEL_COORDINATE, MAX_TEXEL_COORDINATE);
    let y = (uv.y * info.height as f32).clamp(-MAX_TEXEL_COORDINATE, MAX_TEXEL_COORDINATE);
    if info.flags & TEXTURE_NEAREST != 0 {
        let i = wrap_texel(x.floor() as i32, info.width, wrap_s);
        let j = wrap_texel(y.floor() as i32, info.height, wrap_t);
        return fetch(texels, info, i, j, srgb);
    }
    // Bilinear between the four texel centres around (x, y).
    let (fx, fy) = (x - 0.5, y - 0.5);
    let (x0, y0) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - x0, fy - y0);
    let (x0, y0) = (x0 as i32, y0 as i32);
    let i0 = wrap_texel(x0, info.width, wrap_s);
    let i1 = wrap_texel(x0 + 1, info.width, wrap_s);
    let j0 = wrap_texel(y0, info.height, wrap_t);
    let j1 = wrap_texel(y0 + 1, info.height, wrap_t);
    let top = fetch(texels, info, i0, j0, srgb) * (1.0 - tx) + fetch(texels, info, i1, j0, srgb) * tx;
    let bottom = fetch(texels, info, i0, j1, srgb) * (1.0 - tx) + fetch(texels, info, i1, j1, srgb) * tx;
    top * (1.0 - ty) + bottom * ty
}

/// The texture value a material input reads at a point with UV sets `uv0`, `uv1`.
pub fn texture_lookup(
    texels: &[u32],
    infos: &[TextureInfo],
    binding: &TextureBinding,
    uv0: Vec2,
    uv1: Vec2,
    srgb: bool,
) -> Vec4 {
    let uv = if binding.tex_coord == 1 { uv1 } else { uv0 };
    let r0 = binding.row0;
    let r1 = binding.row1;
    let t = Vec2::new(r0[0] * uv.x + r0[1] * uv.y + r0[2], r1[0] * uv.x + r1[1] * uv.y + r1[2]);
    texture_sample(texels, &infos[binding.texture as usize], t, srgb)
}

/// The arrays a texture lookup reads.
#[derive(Clone, Copy)]
pub struct TextureArrays<'a> {
    pub texels: &'a [u32],
    pub infos: &'a [TextureInfo],
    pub bindings: &'a [TextureBinding],
    pub texcoords: &'a [TriangleTexcoords],
}

impl TextureArrays<'_> {
    /// UV sets 0 and 1 of triangle `triangle` at barycentrics `b`.
    pub fn uv(&self, triangle: u32, b: Vec3) -> (Vec2, Vec2) {
        match self.texcoords.get(triangle as usize) {
            Some(t) => {
                let at = |s: &[[f32; 2]; 3]| {
                    b.x * Vec2::from(s[0]) + b.y * Vec2::from(s[1]) + b.z * Vec2::from(s[2])
                };
                (at(&t.uv0), at(&t.uv1))
            }
            None => (Vec2::ZERO, Vec2::ZERO),
        }
    }

    /// Material input `binding` (an index, or `INVALID_INDEX`: `None`) at UVs `uv`.
    pub fn lookup(&self, binding: u32, uv: (Vec2, Vec2), srgb: bool) -> Option<glam::Vec4> {
        (binding != INVALID_INDEX).then(|| {
            texture_lookup(self.texels, self.infos, &self.bindings[binding as usize], uv.0, uv.1, srgb)
        })
    }
}

/// Emitted radiance of `material` on triangle `triangle` at barycentrics `b`: the emission
/// factor times the emissive texture (sRGB) where there is one.
pub fn emitted_radiance(arrays: &TextureArrays, material: &Material, triangle: usize, b: Vec3) -> Vec3 {
    let le = Vec3::from(material.emission);
    match arrays.lookup(material.emissive_texture, arrays.uv(triangle as u32, b), true) {
        Some(t) => le * t.truncate(),
        None => le,
    }
}

/// `material` with its textures applied at UVs `uv` (glTF 2.0 Appendix B and the
/// extensions' definitions): baseColor (sRGB) scales base colour and alpha; metallicRoughness
/// scales metallic by B and roughness by G; emissive (sRGB) scales emission; transmission by
/// R; specular by A; specular colour (sRGB) by RGB; clearcoat by R, clearcoat roughness by
/// G; sheen colour (sRGB) by RGB, sheen roughness by A. Occlusion is not applied: a path tracer
/// computes occlusion itself.
pub fn textured_material(material: &Material, arrays: &TextureArrays, uv: (Vec2, Vec2)) -> Material {
    let mut m = *material;
    if let Some(t) = arrays.lookup(m.base_color_texture, uv, true) {
        m.base_color = (Vec3::from(m.base_color) * t.truncate()).to_array();
        m.alpha *= t.w;
    }
    if let Some(t) = arrays.lookup(m.metallic_roughness_texture, uv, false) {
        m.metallic *= t.z;
        m.roughness *= t.y;
        m.alpha_roughness = alpha_from_roughness(m.roughness);
    }
    if let Some(t) = arrays.lookup(m.emissive_texture, uv, true) {
        m.emission = (Vec3::from(m.emission) * t.truncate()).to_array();
    }
    if let Some(t) = arrays.lookup(m.transmission_texture, uv, false) {
        m.transmission *= t.x;
    }
    if let Some(t) = arrays.lookup(m.specular_texture, uv, false) {
        m.specular_factor *= t.w;
    }
    if let Some(t) = arrays.lookup(m.specular_color_texture, uv, true) {
        m.specular_color = (Vec3::from(m.specular_color) * t.truncate()).to_array();
    }
    if let Some(t) = arrays.lookup(m.clearcoat_texture, uv, false) {
        m.clearcoat *= t.x;
    }
    if let Some(t) = arrays.lookup(m.clearcoat_roughness_texture, uv, false) {
        m.clearcoat_roughness *= t.y;
    }
    if let Some(t) = arrays.lookup(m.sheen_color_texture, uv, true) {
        m.sheen_color = (Vec3::from(m.sheen_color) * t.truncate()).to_array();
    }
    if let Some(t) = arrays.lookup(m.sheen_roughness_texture, uv, false) {
        m.sheen_roughness *= t.w;
    }
    m
}

/// Does a ray hit on `triangle` at barycentrics `b` count, by its material's alpha mode
/// (glTF 2.0 §3.9.4)? OPAQUE: always. MASK: where alpha ≥ `alphaCutoff`. BLEND: with
/// probability alpha (stochastic transparency, Enderton et al. 2010), decided by a hash of
/// the ray's `alpha_seed` and the triangle, so one ray sees one answer per triangle and both
/// backends see the same. alpha = `baseColorFactor.a` × the base colour texture's alpha.
pub fn alpha_accepts(
    materials: &[Material],
    triangles: &[super::layout::Triangle],
    arrays: &TextureArrays,
    triangle: u32,
    b: Vec3,
    alpha_seed: u32,
) -> bool {
    let m = &materials[triangles[triangle as usize].material as usize];
    let mask = m.flags & MATERIAL_ALPHA_MASK != 0;
    if !mask && m.flags & MATERIAL_ALPHA_BLEND == 0 {
        return true;
    }
    let texture_alpha =
        arrays.lookup(m.base_color_texture, arrays.uv(triangle, b), false).map_or(1.0, |t| t.w);
    let alpha = m.alpha * texture_alpha;
    if mask {
        alpha >= m.alpha_cutoff
    } else {
        let h = crate::sampling::pcg4d(glam::UVec4::new(alpha_seed, triangle, ALPHA_HASH_SALT, 0)).x;
        ((h >> 8) as f32 * (1.0 / 16_777_216.0)) < alpha
    }
}

/// Separates the alpha hash from other uses of pcg4d.
pub const ALPHA_HASH_SALT: u32 = 0x2545_f491;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_modes_follow_the_spec() {
        let w = 4;
        let got = |mode| (-5..9).map(|i| wrap_texel(i, w, mode)).collect::<Vec<_>>();
        assert_eq!(got(WRAP_REPEAT), vec![3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0]);
        assert_eq!(got(WRAP_CLAMP_TO_EDGE), vec![0, 0, 0, 0, 0, 0, 1, 2, 3, 3, 3, 3, 3, 3]);
        assert_eq!(got(WRAP_MIRRORED_REPEAT), vec![3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0]);
    }

    fn checker() -> (Vec<u32>, TextureInfo) {
        // 2×2: black, white / white, black; A = 255.
        let texels = vec![0xff00_0000, 0xffff_ffff, 0xffff_ffff, 0xff00_0000];
        (texels, TextureInfo { offset: 0, width: 2, height: 2, flags: 0 })
    }

    #[test]
    fn bilinear_hits_texel_centres_and_blends_between() {
        let (texels, info) = checker();
        let at = |u: f32, v: f32| texture_sample(&texels, &info, Vec2::new(u, v), false).x;
        assert_eq!(at(0.25, 0.25), 0.0, "centre of texel (0, 0)");
        assert_eq!(at(0.75, 0.25), 1.0, "centre of texel (1, 0)");
        assert!((at(0.5, 0.25) - 0.5).abs() < 1e-6, "half way");
        // REPEAT: the left edge blends with the right column.
        assert!((at(0.0, 0.25) - 0.5).abs() < 1e-6);
        let nearest = TextureInfo { flags: TEXTURE_NEAREST, ..info };
        assert_eq!(texture_sample(&texels, &nearest, Vec2::new(0.49, 0.1), false).x, 0.0);
        assert_eq!(texture_sample(&texels, &nearest, Vec2::new(0.51, 0.1), false).x, 1.0);
    }

    #[test]
    fn srgb_is_decoded_per_texel() {
        let texels = vec![0xff80_8080u32];
        let info = TextureInfo { offset: 0, width: 1, height: 1, flags: 0 };
        let c = texture_sample(&texels, &info, Vec2::splat(0.5), true);
        // 128/255 in sRGB is 0.2158605 linear (IEC 61966-2-1); alpha stays linear.
        assert!((c.x - 0.215_860_5).abs() < 1e-6, "{}", c.x);
        assert_eq!(c.w, 1.0);
    }

    #[test]
    fn oversize_images_are_halved_to_fit() {
        let side = 4096u32;
        let image = ImageDesc {
            name: "big".into(),
            width: side,
            height: side,
            rgba8: vec![7; (side * side * 4) as usize],
        };
        let textures = vec![TextureDesc { image: Some(0), wrap_s: 0, wrap_t: 0, nearest: false }; 1];
        let flat = FlatTextures::build(
            &[image.clone(), image],
            &[textures[0].clone(), TextureDesc { image: Some(1), ..textures[0].clone() }],
        );
        assert_eq!(flat.downscaled, 1, "two 64 MiB images halve once");
        assert!(flat.texels.len() * 4 <= TEXEL_BUDGET_BYTES);
        assert_eq!(flat.infos[1].width, side / 2);
    }
}
