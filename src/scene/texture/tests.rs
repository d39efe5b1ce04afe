//! Tests of `texture`.

use super::*;

/// The table holds exactly what decoding each byte as the texel fetch did gives.
#[test]
fn the_srgb_table_is_the_transfer_function_bit_for_bit() {
    for v in 0..256u32 {
        let c = Vec4::splat(v as f32) / 255.0;
        assert_eq!(SRGB_DECODED[v as usize].to_bits(), srgb_decode(c.x).to_bits(), "{v}");
    }
}

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
    let at = |u: f32, v: f32| texture_sample(&texels, &info, Vec2::new(u, v), false, LOD_FINEST).x;
    assert_eq!(at(0.25, 0.25), 0.0, "centre of texel (0, 0)");
    assert_eq!(at(0.75, 0.25), 1.0, "centre of texel (1, 0)");
    assert!((at(0.5, 0.25) - 0.5).abs() < 1e-6, "half way");
    // REPEAT: the left edge blends with the right column.
    assert!((at(0.0, 0.25) - 0.5).abs() < 1e-6);
    let nearest = TextureInfo { flags: TEXTURE_NEAREST, ..info };
    assert_eq!(texture_sample(&texels, &nearest, Vec2::new(0.49, 0.1), false, LOD_FINEST).x, 0.0);
    assert_eq!(texture_sample(&texels, &nearest, Vec2::new(0.51, 0.1), false, LOD_FINEST).x, 1.0);
}

#[test]
fn srgb_is_decoded_per_texel() {
    let texels = vec![0xff80_8080u32];
    let info = TextureInfo { offset: 0, width: 1, height: 1, flags: 0 };
    let c = texture_sample(&texels, &info, Vec2::splat(0.5), true, LOD_FINEST);
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
    let textures =
        vec![TextureDesc { image: Some(0), wrap_s: 0, wrap_t: 0, nearest: false, mipmaps: false }; 1];
    let flat = FlatTextures::build(
        &[image.clone(), image],
        &[textures[0].clone(), TextureDesc { image: Some(1), ..textures[0].clone() }],
        &[false, false],
    );
    assert_eq!(flat.downscaled, 1, "two 64 MiB images halve once");
    assert!(flat.texels.len() * 4 <= TEXEL_BUDGET_BYTES);
    assert_eq!(flat.infos[1].width, side / 2);
}

/// A 2×2 RGBA8 checker: black, white / white, black.
fn checker_image() -> ImageDesc {
    ImageDesc {
        name: "checker".into(),
        width: 2,
        height: 2,
        rgba8: [0u8, 0, 0, 255, 255, 255, 255, 255, 255, 255, 255, 255, 0, 0, 0, 255].to_vec(),
    }
}

#[test]
fn mip_levels_average_in_linear_light() {
    // A 2×2 sRGB checker of black and white: its 1×1 level is linear 0.5, which sRGB
    // encodes as 188 (not the 128 that averaging the codes would give).
    let image = checker_image();
    let chain = mip_chain(&image, true);
    assert_eq!(chain.len(), 2);
    assert_eq!(&chain[1].rgba8, &[188, 188, 188, 255]);
    assert_eq!(&mip_chain(&image, false)[1].rgba8, &[128, 128, 128, 255], "linear data averages its codes");
}

#[test]
fn trilinear_lookup_blends_the_levels_around_lod() {
    let image = checker_image();
    let texture = TextureDesc {
        image: Some(0),
        wrap_s: WRAP_REPEAT,
        wrap_t: WRAP_REPEAT,
        nearest: false,
        mipmaps: true,
    };
    let flat = FlatTextures::build(&[image], &[texture], &[false]);
    let info = &flat.infos[0];
    assert_eq!(texture_levels(info), 2);
    assert_eq!(flat.texels.len(), 5, "level 0 then level 1");
    let centre = Vec2::new(0.25, 0.25); // the centre of black texel (0, 0)
    let at = |lod: f32| texture_sample(&flat.texels, info, centre, false, lod).x;
    assert_eq!(at(LOD_FINEST), 0.0);
    assert_eq!(at(0.0), 0.0);
    assert!((at(1.0) - 128.0 / 255.0).abs() < 1e-6, "coarsest level");
    assert!((at(0.5) - 64.0 / 255.0).abs() < 1e-6, "half way");
    assert!((at(7.0) - 128.0 / 255.0).abs() < 1e-6, "clamped to the coarsest level");
    assert_eq!(at(f32::NAN), 0.0, "a NaN λ reads level 0");
}

#[test]
fn lod_is_zero_where_a_texel_covers_a_pixel_footprint() {
    // A unit square with UVs over [0, 1]² (each triangle half of it) under a 256² texture:
    // a footprint of 1/256 at normal incidence covers one texel, λ = 0; twice that, λ = 1;
    // at 60° from the normal the footprint doubles again.
    let uv = TriangleTexcoords { uv0: [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]], uv1: [[0.0; 2]; 3] };
    let world_double_area = 1.0;
    let texture_term = 0.5 * (256.0f32 * 256.0).log2();
    let lod = |w: f32, cos: f32| lod_bases(&uv, world_double_area, w, cos).x + texture_term;
    assert!(lod(1.0 / 256.0, 1.0).abs() < 1e-5);
    assert!((lod(2.0 / 256.0, 1.0) - 1.0).abs() < 1e-5);
    assert!((lod(2.0 / 256.0, 0.5) - 2.0).abs() < 1e-5);
    assert_eq!(lod_bases(&uv, world_double_area, 0.0, 1.0).x, LOD_FINEST, "no footprint: level 0");
}
