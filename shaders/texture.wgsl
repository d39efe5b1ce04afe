// Twin of src/scene/texture.rs: texture lookup (wrap modes, bilinear or nearest, sRGB
// decoded per texel before filtering, trilinear between mip levels at a ray cone's level of
// detail) and the material inputs it drives.

const TEXTURE_LEVELS_SHIFT: u32 = 8u;
const LOD_FINEST: f32 = -1000.0;

fn wrap_texel(i: i32, size: u32, mode: u32) -> u32 {
    let n = i32(size);
    if (mode == WRAP_CLAMP_TO_EDGE) {
        return u32(clamp(i, 0, n - 1));
    }
    // Euclidean remainder (WGSL's % truncates towards zero).
    if (mode == WRAP_MIRRORED_REPEAT) {
        let p = 2 * n;
        let m = ((i % p) + p) % p;
        return u32(select(m, p - 1 - m, m >= n));
    }
    return u32(((i % n) + n) % n);
}

fn srgb_decode(v: f32) -> f32 {
    if (v <= 0.04045) {
        return v / 12.92;
    }
    return pow((v + 0.055) / 1.055, 2.4);
}

fn texel_fetch(info: TextureInfo, x: u32, y: u32, srgb: bool) -> vec4<f32> {
    let t = texels[info.offset + y * info.width + x];
    let c = vec4<f32>(f32(t & 255u), f32((t >> 8u) & 255u), f32((t >> 16u) & 255u), f32(t >> 24u)) / 255.0;
    if (srgb) {
        return vec4<f32>(srgb_decode(c.x), srgb_decode(c.y), srgb_decode(c.z), c.w);
    }
    return c;
}

const MAX_TEXEL_COORDINATE: f32 = 16777216.0;

fn level_sample(info: TextureInfo, uv: vec2<f32>, srgb: bool, nearest: bool) -> vec4<f32> {
    let wrap_s = info.flags & 3u;
    let wrap_t = (info.flags >> 2u) & 3u;
    let x = clamp(uv.x * f32(info.width), -MAX_TEXEL_COORDINATE, MAX_TEXEL_COORDINATE);
    let y = clamp(uv.y * f32(info.height), -MAX_TEXEL_COORDINATE, MAX_TEXEL_COORDINATE);
    if (nearest) {
        let i = wrap_texel(i32(floor(x)), info.width, wrap_s);
        let j = wrap_texel(i32(floor(y)), info.height, wrap_t);
        return texel_fetch(info, i, j, srgb);
    }
    let fx = x - 0.5;
    let fy = y - 0.5;
    let x0 = floor(fx);
    let y0 = floor(fy);
    let tx = fx - x0;
    let ty = fy - y0;
    let i0 = wrap_texel(i32(x0), info.width, wrap_s);
    let i1 = wrap_texel(i32(x0) + 1, info.width, wrap_s);
    let j0 = wrap_texel(i32(y0), info.height, wrap_t);
    let j1 = wrap_texel(i32(y0) + 1, info.height, wrap_t);
    let top = texel_fetch(info, i0, j0, srgb) * (1.0 - tx) + texel_fetch(info, i1, j0, srgb) * tx;
    let bottom = texel_fetch(info, i0, j1, srgb) * (1.0 - tx) + texel_fetch(info, i1, j1, srgb) * tx;
    return top * (1.0 - ty) + bottom * ty;
}

fn texture_levels(info: TextureInfo) -> u32 {
    return ((info.flags >> TEXTURE_LEVELS_SHIFT) & 15u) + 1u;
}

fn texture_level(info: TextureInfo, level: u32) -> TextureInfo {
    var offset = info.offset;
    var w = info.width;
    var h = info.height;
    for (var k = 0u; k < level; k++) {
        offset += w * h;
        w = max(w / 2u, 1u);
        h = max(h / 2u, 1u);
    }
    return TextureInfo(offset, w, h, info.flags);
}

fn texture_sample(info: TextureInfo, uv: vec2<f32>, srgb: bool, lod_in: f32) -> vec4<f32> {
    let levels = texture_levels(info);
    // `!(lod > 0)` also catches a NaN λ.
    if (levels == 1u || !(lod_in > 0.0)) {
        return level_sample(info, uv, srgb, (info.flags & TEXTURE_NEAREST) != 0u);
    }
    let lod = min(lod_in, f32(levels - 1u));
    let l0f = floor(lod);
    let l0 = u32(l0f);
    // No blend at the coarsest level or exactly on a level.
    let t = select(lod - l0f, 0.0, l0 + 1u >= levels);
    // Both levels through one copy of the bilinear code (see `textured_material`).
    var result = vec4<f32>(0.0);
    for (var k = 0u; k < select(2u, 1u, t == 0.0); k++) {
        result += select(1.0 - t, t, k == 1u) * level_sample(texture_level(info, l0 + k), uv, srgb, false);
    }
    return result;
}

// UV sets 0 (xy) and 1 (zw) of a triangle at barycentrics b.
fn triangle_uv(triangle: u32, b: vec3<f32>) -> vec4<f32> {
    if (!FEATURE_TEXTURES) {
        return vec4<f32>(0.0);
    }
    let t = texcoords[triangle];
    let uv0 = b.x * t.uv0[0] + b.y * t.uv0[1] + b.z * t.uv0[2];
    let uv1 = b.x * t.uv1[0] + b.y * t.uv1[1] + b.z * t.uv1[2];
    return vec4<f32>(uv0, uv1);
}

fn texture_lookup(binding_index: u32, uv: vec4<f32>, srgb: bool) -> vec4<f32> {
    return texture_lookup_lod(binding_index, uv, vec2<f32>(LOD_FINEST), srgb);
}

fn texture_lookup_lod(binding_index: u32, uv: vec4<f32>, lod_base: vec2<f32>, srgb: bool) -> vec4<f32> {
    let binding = texture_bindings[binding_index];
    let second = binding.tex_coord == 1u;
    let st = select(uv.xy, uv.zw, second);
    let t = vec2<f32>(dot(binding.row0, vec3<f32>(st, 1.0)), dot(binding.row1, vec3<f32>(st, 1.0)));
    let info = texture_infos[binding.texture];
    let det = abs(binding.row0.x * binding.row1.y - binding.row0.y * binding.row1.x);
    let lod = select(lod_base.x, lod_base.y, second) + 0.5 * log2(f32(info.width) * f32(info.height) * det);
    return texture_sample(info, t, srgb, lod);
}

// Twin of `lod_bases`: ½ log₂(uv area / world area) + log₂(cone width / |cos θ|) per UV set.
fn lod_bases(triangle: u32, world_double_area: f32, cone_width: f32, cos_theta: f32) -> vec2<f32> {
    if (!FEATURE_TEXTURES) {
        return vec2<f32>(LOD_FINEST);
    }
    let t = texcoords[triangle];
    let footprint = cone_width / max(abs(cos_theta), 1e-4);
    let a0 = abs(cross2(t.uv0[1] - t.uv0[0], t.uv0[2] - t.uv0[0]));
    let a1 = abs(cross2(t.uv1[1] - t.uv1[0], t.uv1[2] - t.uv1[0]));
    let l0 = 0.5 * log2(a0 / world_double_area) + log2(footprint);
    let l1 = 0.5 * log2(a1 / world_double_area) + log2(footprint);
    return vec2<f32>(select(LOD_FINEST, l0, is_finite_f32(l0)), select(LOD_FINEST, l1, is_finite_f32(l1)));
}

fn cross2(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return a.x * b.y - a.y * b.x;
}

// The texture slots of a material, in `textured_material`'s order.
const TEXTURE_SLOTS: u32 = 10u;

// One loop over the slots, not one inlined lookup per slot: a lookup is two bilinear level
// samples of four texel fetches each, and ten inlined copies of it made the specialised
// kernel of every textured scene 2–4× slower on an H100 (register pressure;
// bench/history/gltf-content.md).
fn textured_material(material: Material, uv: vec4<f32>, lod: vec2<f32>) -> Material {
    var m = material;
    if (!FEATURE_TEXTURES) {
        return m;
    }
    var slots = array<u32, TEXTURE_SLOTS>(
        m.base_color_texture,
        m.metallic_roughness_texture,
        m.emissive_texture,
        m.transmission_texture,
        m.specular_texture,
        m.specular_color_texture,
        m.clearcoat_texture,
        m.clearcoat_roughness_texture,
        m.sheen_color_texture,
        m.sheen_roughness_texture,
    );
    for (var k = 0u; k < TEXTURE_SLOTS; k++) {
        let binding_index = slots[k];
        if (binding_index == INVALID_INDEX) {
            continue;
        }
        // Colours are sRGB-encoded; factors are linear.
        let srgb = k == 0u || k == 2u || k == 5u || k == 8u;
        let t = texture_lookup_lod(binding_index, uv, lod, srgb);
        switch k {
            case 0u: {
                m.base_color *= t.xyz;
                m.alpha *= t.w;
            }
            case 1u: {
                m.metallic *= t.z;
                m.roughness *= t.y;
                m.alpha_roughness = alpha_from_roughness(m.roughness);
            }
            case 2u: {
                m.emission *= t.xyz;
            }
            case 3u: {
                m.transmission *= t.x;
            }
            case 4u: {
                m.specular_factor *= t.w;
            }
            case 5u: {
                m.specular_color *= t.xyz;
            }
            case 6u: {
                m.clearcoat *= t.x;
            }
            case 7u: {
                m.clearcoat_roughness *= t.y;
            }
            case 8u: {
                m.sheen_color *= t.xyz;
            }
            default: {
                m.sheen_roughness *= t.w;
            }
        }
    }
    return m;
}

fn emitted_radiance(material: Material, triangle: u32, b: vec3<f32>) -> vec3<f32> {
    if (FEATURE_TEXTURES && material.emissive_texture != INVALID_INDEX) {
        return material.emission * texture_lookup(material.emissive_texture, triangle_uv(triangle, b), true).xyz;
    }
    return material.emission;
}

const ALPHA_HASH_SALT: u32 = 0x2545f491u;

// Twin of `alpha_accepts` (src/scene/texture.rs): OPAQUE always, MASK where alpha ≥ cutoff,
// BLEND with probability alpha by a hash of the ray's seed and the triangle.
fn alpha_accepts(triangle: u32, b: vec3<f32>, alpha_seed: u32) -> bool {
    let m = materials[triangles[triangle].material];
    let mask = (m.flags & MATERIAL_ALPHA_MASK) != 0u;
    if (!mask && (m.flags & MATERIAL_ALPHA_BLEND) == 0u) {
        return true;
    }
    var alpha = m.alpha;
    if (FEATURE_TEXTURES && m.base_color_texture != INVALID_INDEX) {
        alpha *= texture_lookup(m.base_color_texture, triangle_uv(triangle, b), false).w;
    }
    if (mask) {
        return alpha >= m.alpha_cutoff;
    }
    let h = pcg4d(vec4<u32>(alpha_seed, triangle, ALPHA_HASH_SALT, 0u)).x;
    return f32(h >> 8u) * (1.0 / 16777216.0) < alpha;
}
