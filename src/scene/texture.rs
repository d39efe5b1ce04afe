//! Textures: decoded glTF images with their samplers, flattened into one texel array both
//! backends read, and the lookup both perform (WGSL twin: `shaders/texture.wgsl`).
//!
//! Conventions (glTF 2.0 §3.8): UV (0, 0) is the image's top-left corner; texel (i, j) covers
//! [i, i+1] × [j, j+1] / (width, height). baseColor, emissive and specular colour are sRGB
//! encoded (decoded per texel with the exact IEC 61966-2-1 curve, before filtering); every
//! other input is linear. Filtering is bilinear, or nearest when the sampler's `magFilter` is
//! NEAREST; wrap modes REPEAT, CLAMP_TO_EDGE and MIRRORED_REPEAT per axis.
//!
//! Level of detail: every image carries its mip chain (2×2 box filter, averaged in linear
//! light for sRGB images) unless its sampler's `minFilter` forbids mipmaps, and a lookup
//! blends the two levels around λ (trilinear). λ comes from a ray cone (Akenine-Möller,
//! Nilsson, Andersson, Barré-Brisebois, Toth & Karras 2019, "Texture Level of Detail
//! Strategies for Real-Time Ray Tracing", Ray Tracing Gems ch. 20, eq. 34):
//!
//! ```text
//! λ = ½ log₂(t_a / p_a) + log₂ w − log₂ |n̂ · d̂|,   t_a = W·H·|det T|·uv area, p_a = world area
//! ```
//!
//! with w the cone's width at the hit. The cone starts at the camera with the pixel's
//! spread angle and keeps it along the whole path: bounces add neither the surface's
//! curvature nor the BSDF's spread, which under-filters indirect lookups (the low-bias side;
//! pbrt-v4 likewise sizes secondary footprints from the camera's). Lookups that must agree
//! with light sampling (emission under MIS, alpha inside traversal) read level 0.

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
    /// Minified through mip maps (glTF `minFilter` absent or a `*_MIPMAP_*` mode).
    pub mipmaps: bool,
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

/// Halves an image (2×2 box filter; odd sizes keep their last row/column), averaging in
/// linear light when `srgb` (alpha is always linear).
fn halve(image: &ImageDesc, srgb: bool) -> ImageDesc {
    let (w, h) = ((image.width / 2).max(1), (image.height / 2).max(1));
    let mut out = vec![0u8; (w * h * 4) as usize];
    for y in 0..h {
        for x in 0..w {
            for c in 0..4 {
                let linear = srgb && c < 3;
                let mut sum = 0.0f32;
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let sx = (2 * x + dx).min(image.width - 1);
                    let sy = (2 * y + dy).min(image.height - 1);
                    let v = image.rgba8[((sy * image.width + sx) * 4 + c) as usize] as f32 / 255.0;
                    sum += if linear { srgb_decode(v) } else { v };
                }
                let mean = sum / 4.0;
                let v = if linear { srgb_encode(mean) } else { mean };
                out[((y * w + x) * 4 + c) as usize] = (v * 255.0).round().clamp(0.0, 255.0) as u8;
            }
        }
    }
    ImageDesc { name: image.name.clone(), width: w, height: h, rgba8: out }
}

/// The mip chain below `image`: halved until 1×1.
fn mip_chain(image: &ImageDesc, srgb: bool) -> Vec<ImageDesc> {
    let mut levels = vec![image.clone()];
    while levels.last().is_some_and(|l| l.width > 1 || l.height > 1) && levels.len() < MAX_TEXTURE_LEVELS {
        let next = halve(levels.last().unwrap(), srgb);
        levels.push(next);
    }
    levels
}

/// Levels a mip chain may have (the level count is stored in 4 bits of
/// [`TextureInfo::flags`]); 16 levels reach 1×1 from 32768².
pub const MAX_TEXTURE_LEVELS: usize = 16;

/// Where [`TextureInfo::flags`] keeps the level count minus one (4 bits).
pub const TEXTURE_LEVELS_SHIFT: u32 = 8;

/// How many mip levels texture `info` has (1: level 0 only).
pub fn texture_levels(info: &TextureInfo) -> u32 {
    ((info.flags >> TEXTURE_LEVELS_SHIFT) & 15) + 1
}

/// Level `level` of texture `info`, as a one-level descriptor: its levels are stored one
/// after the other from `info.offset`, each `max(1, size >> level)` on a side.
pub fn texture_level(info: &TextureInfo, level: u32) -> TextureInfo {
    let mut offset = info.offset;
    let (mut w, mut h) = (info.width, info.height);
    for _ in 0..level {
        offset += w * h;
        w = (w / 2).max(1);
        h = (h / 2).max(1);
    }
    TextureInfo { offset, width: w, height: h, flags: info.flags }
}

impl FlatTextures {
    /// Flattens `images` (those some texture uses) with their mip chains; `srgb[i]` says
    /// whether image `i` holds sRGB colour (averaged in linear light).
    pub fn build(images: &[ImageDesc], textures: &[TextureDesc], srgb: &[bool]) -> FlatTextures {
        let mut images: Vec<ImageDesc> = images.to_vec();
        let used: Vec<bool> =
            (0..images.len()).map(|i| textures.iter().any(|t| t.image == Some(i))).collect();
        let mipmapped: Vec<bool> =
            (0..images.len()).map(|i| textures.iter().any(|t| t.image == Some(i) && t.mipmaps)).collect();
        // A full chain adds at most a third to the level-0 texels (and a texel per level for
        // 1-texel-wide images): budget for that.
        let bytes = |images: &[ImageDesc]| -> usize {
            images
                .iter()
                .enumerate()
                .filter(|(i, _)| used[*i])
                .map(|(i, im)| {
                    if mipmapped[i] {
                        im.rgba8.len() * 4 / 3 + 4 * MAX_TEXTURE_LEVELS
                    } else {
                        im.rgba8.len()
                    }
                })
                .sum()
        };
        let mut downscaled = 0;
        while bytes(&images) > TEXEL_BUDGET_BYTES {
            images = images.iter().enumerate().map(|(i, im)| halve(im, srgb.get(i) == Some(&true))).collect();
            downscaled += 1;
        }
        let mut texels = Vec::new();
        let mut offsets = vec![0u32; images.len()];
        let mut levels = vec![1u32; images.len()];
        for (i, image) in images.iter().enumerate() {
            if !used[i] {
                continue;
            }
            offsets[i] = texels.len() as u32;
            let chain =
                if mipmapped[i] { mip_chain(image, srgb.get(i) == Some(&true)) } else { vec![image.clone()] };
            levels[i] = chain.len() as u32;
            for level in &chain {
                texels.extend(
                    level.rgba8.chunks_exact(4).map(|p| u32::from_le_bytes([p[0], p[1], p[2], p[3]])),
                );
            }
        }
        let infos = textures
            .iter()
            .map(|t| match t.image {
                Some(i) => {
                    // A texture that asks for no mipmaps reads level 0 of a shared chain.
                    let count = if t.mipmaps { levels[i] } else { 1 };
                    TextureInfo {
                        offset: offsets[i],
                        width: images[i].width,
                        height: images[i].height,
                        flags: t.wrap_s
                            | (t.wrap_t << 2)
                            | if t.nearest { TEXTURE_NEAREST } else { 0 }
                            | ((count - 1) << TEXTURE_LEVELS_SHIFT),
                    }
                }
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

/// The exact sRGB transfer function (IEC 61966-2-1), linear to encoded.
pub fn srgb_encode(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
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

/// [`srgb_decode`] of each 8-bit value v / 255, the same expression evaluated once: a texel
/// fetch is then a table read, bit for bit what it was. `powf` had taken 16% of the AOV
/// pass on DamagedHelmet, three of them per texel of a colour texture, four texels per
/// bilinear lookup (`bench/history/denoising.md`). The WGSL twin keeps `pow`, one
/// instruction on a GPU.
static SRGB_DECODED: std::sync::LazyLock<[f32; 256]> =
    std::sync::LazyLock::new(|| std::array::from_fn(|v| srgb_decode(v as f32 / 255.0)));

fn fetch(texels: &[u32], info: &TextureInfo, x: u32, y: u32, srgb: bool) -> Vec4 {
    let t = texels[(info.offset + y * info.width + x) as usize];
    let byte = |k: u32| ((t >> (8 * k)) & 255) as usize;
    if srgb {
        let decoded = &*SRGB_DECODED;
        Vec4::new(decoded[byte(0)], decoded[byte(1)], decoded[byte(2)], byte(3) as f32 / 255.0)
    } else {
        Vec4::new(byte(0) as f32, byte(1) as f32, byte(2) as f32, byte(3) as f32) / 255.0
    }
}

/// Texel coordinates far outside the image carry no information in f32 and would overflow
/// an i32: clamp to ±2²⁴ texels before converting (the wrap then picks a texel as usual).
const MAX_TEXEL_COORDINATE: f32 = 16_777_216.0;

/// Samples one level `info` at `uv` (RGBA in [0, 1], colour decoded from sRGB when `srgb`):
/// bilinear, or nearest when `nearest`.
fn level_sample(texels: &[u32], info: &TextureInfo, uv: Vec2, srgb: bool, nearest: bool) -> Vec4 {
    let (wrap_s, wrap_t) = (info.flags & 3, (info.flags >> 2) & 3);
    let x = (uv.x * info.width as f32).clamp(-MAX_TEXEL_COORDINATE, MAX_TEXEL_COORDINATE);
    let y = (uv.y * info.height as f32).clamp(-MAX_TEXEL_COORDINATE, MAX_TEXEL_COORDINATE);
    if nearest {
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

/// λ at or below which a lookup reads level 0 alone (magnification, or no footprint).
pub const LOD_FINEST: f32 = -1000.0;

/// Samples texture `info` at `uv` and level of detail `lod` (λ, in levels; ≤ 0 reads level 0
/// with the magnification filter, larger values blend the two levels around λ).
pub fn texture_sample(texels: &[u32], info: &TextureInfo, uv: Vec2, srgb: bool, lod: f32) -> Vec4 {
    let levels = texture_levels(info);
    // A NaN λ reads level 0 too (the WGSL twin's `!(lod > 0)`).
    if levels == 1 || lod.is_nan() || lod <= 0.0 {
        return level_sample(texels, info, uv, srgb, info.flags & TEXTURE_NEAREST != 0);
    }
    let lod = lod.min((levels - 1) as f32);
    let l0 = lod.floor();
    let t = lod - l0;
    let l0 = l0 as u32;
    let a = level_sample(texels, &texture_level(info, l0), uv, srgb, false);
    if t == 0.0 || l0 + 1 >= levels {
        return a;
    }
    let b = level_sample(texels, &texture_level(info, l0 + 1), uv, srgb, false);
    a * (1.0 - t) + b * t
}

/// The texture value a material input reads at a point with UV sets `uv0`, `uv1`, at the
/// footprint `lod_base` (per UV set, see [`lod_bases`]; [`LOD_FINEST`] for level 0).
pub fn texture_lookup(
    texels: &[u32],
    infos: &[TextureInfo],
    binding: &TextureBinding,
    uv0: Vec2,
    uv1: Vec2,
    lod_base: Vec2,
    srgb: bool,
) -> Vec4 {
    let second = binding.tex_coord == 1;
    let uv = if second { uv1 } else { uv0 };
    let r0 = binding.row0;
    let r1 = binding.row1;
    let t = Vec2::new(r0[0] * uv.x + r0[1] * uv.y + r0[2], r1[0] * uv.x + r1[1] * uv.y + r1[2]);
    let info = &infos[binding.texture as usize];
    // λ = base + ½ log₂(W · H · |det T|): the texture's resolution and the transform's
    // scaling of UV area.
    let det = (r0[0] * r1[1] - r0[1] * r1[0]).abs();
    let lod = (if second { lod_base.y } else { lod_base.x })
        + 0.5 * (info.width as f32 * info.height as f32 * det).log2();
    texture_sample(texels, info, t, srgb, lod)
}

/// The part of λ that depends on the hit, per UV set: ½ log₂(uv area / world area) +
/// log₂(cone width / |cos θ|) (Akenine-Möller et al. 2019, eq. 34). `cos_theta` is the cosine
/// between the ray and the geometric normal. Degenerate UVs or no footprint give
/// [`LOD_FINEST`] (level 0); a grazing hit is bounded by the coarsest level later.
pub fn lod_bases(uv: &TriangleTexcoords, world_double_area: f32, cone_width: f32, cos_theta: f32) -> Vec2 {
    let base = |s: &[[f32; 2]; 3]| {
        let (a, b, c) = (Vec2::from(s[0]), Vec2::from(s[1]), Vec2::from(s[2]));
        let uv_area = (b - a).perp_dot(c - a).abs();
        let footprint = cone_width / cos_theta.abs().max(1e-4);
        let lod = 0.5 * (uv_area / world_double_area).log2() + footprint.log2();
        if lod.is_finite() {
            lod
        } else {
            LOD_FINEST
        }
    };
    Vec2::new(base(&uv.uv0), base(&uv.uv1))
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

    /// Material input `binding` (an index, or `INVALID_INDEX`: `None`) at UVs `uv`, level 0.
    pub fn lookup(&self, binding: u32, uv: (Vec2, Vec2), srgb: bool) -> Option<glam::Vec4> {
        self.lookup_lod(binding, uv, Vec2::splat(LOD_FINEST), srgb)
    }

    /// Material input `binding` at UVs `uv` and footprint `lod_base` (see [`lod_bases`]).
    pub fn lookup_lod(
        &self,
        binding: u32,
        uv: (Vec2, Vec2),
        lod_base: Vec2,
        srgb: bool,
    ) -> Option<glam::Vec4> {
        (binding != INVALID_INDEX).then(|| {
            texture_lookup(
                self.texels,
                self.infos,
                &self.bindings[binding as usize],
                uv.0,
                uv.1,
                lod_base,
                srgb,
            )
        })
    }

    /// λ bases of triangle `triangle` (corners `p`) for a ray cone of width `cone_width` at
    /// the hit arriving at cosine `cos_theta` to the geometric normal.
    pub fn lod_bases(&self, triangle: u32, p: [Vec3; 3], cone_width: f32, cos_theta: f32) -> Vec2 {
        match self.texcoords.get(triangle as usize) {
            Some(t) => lod_bases(t, (p[1] - p[0]).cross(p[2] - p[0]).length(), cone_width, cos_theta),
            None => Vec2::splat(LOD_FINEST),
        }
    }
}

/// Emitted radiance of `material` on triangle `triangle` at barycentrics `b`: the emission
/// factor times the emissive texture (sRGB) where there is one.
pub fn emitted_radiance(arrays: &TextureArrays, material: &Material, triangle: usize, b: Vec3) -> Vec3 {
    let le = Vec3::from(material.emission);
    // Without an emissive texture the UVs are not needed (every light sample asks).
    if material.emissive_texture == INVALID_INDEX {
        return le;
    }
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
pub fn textured_material(
    material: &Material,
    arrays: &TextureArrays,
    uv: (Vec2, Vec2),
    lod: Vec2,
) -> Material {
    let mut m = *material;
    if let Some(t) = arrays.lookup_lod(m.base_color_texture, uv, lod, true) {
        m.base_color = (Vec3::from(m.base_color) * t.truncate()).to_array();
        m.alpha *= t.w;
    }
    if let Some(t) = arrays.lookup_lod(m.metallic_roughness_texture, uv, lod, false) {
        m.metallic *= t.z;
        m.roughness *= t.y;
        m.alpha_roughness = alpha_from_roughness(m.roughness);
    }
    if let Some(t) = arrays.lookup_lod(m.emissive_texture, uv, lod, true) {
        m.emission = (Vec3::from(m.emission) * t.truncate()).to_array();
    }
    if let Some(t) = arrays.lookup_lod(m.transmission_texture, uv, lod, false) {
        m.transmission *= t.x;
    }
    if let Some(t) = arrays.lookup_lod(m.specular_texture, uv, lod, false) {
        m.specular_factor *= t.w;
    }
    if let Some(t) = arrays.lookup_lod(m.specular_color_texture, uv, lod, true) {
        m.specular_color = (Vec3::from(m.specular_color) * t.truncate()).to_array();
    }
    if let Some(t) = arrays.lookup_lod(m.clearcoat_texture, uv, lod, false) {
        m.clearcoat *= t.x;
    }
    if let Some(t) = arrays.lookup_lod(m.clearcoat_roughness_texture, uv, lod, false) {
        m.clearcoat_roughness *= t.y;
    }
    if let Some(t) = arrays.lookup_lod(m.sheen_color_texture, uv, lod, true) {
        m.sheen_color = (Vec3::from(m.sheen_color) * t.truncate()).to_array();
    }
    if let Some(t) = arrays.lookup_lod(m.sheen_roughness_texture, uv, lod, false) {
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
mod tests;
