//! Auxiliary images (AOVs): what the camera sees at each pixel apart from its radiance, the
//! guides a denoiser needs (Open Image Denoise's albedo and normal; `crate::denoise`) and the
//! depth a compositor reads.
//!
//! WGSL twin: `shaders/aov.wgsl` (entry point `aov`), with the same names and the same
//! random numbers, so that both backends produce the same AOVs up to rounding.
//!
//! Each pixel averages [`AOV_SAMPLES`] camera rays, stratified over the pixel as the
//! render's box filter places its samples, so that the guides are anti-aliased as the image
//! is (an aliased guide puts its staircase into a denoised edge), then more where they vary
//! ([`pixels_to_refine`]): [`AOV_VARYING_SAMPLES`] where its rays disagree or a neighbour
//! sees another surface, [`AOV_SILHOUETTE_SAMPLES`] on silhouettes, [`AOV_REFINED_SAMPLES`]
//! on emitters' edges. Their random numbers come from the independent sampler at sample
//! indices the render never reaches ([`AOV_SAMPLE_INDEX`]), so
//! the guides' jitter is independent of the image's noise: a denoiser weighting by features
//! that correlate with the noise it removes would keep part of it (Rousselle et al. 2013
//! discuss this for feature-guided filters).
//!
//! A ray that meets only delta lobes (a mirror, smooth glass) follows them, choosing one lobe
//! by the BSDF's own sampling, up to [`AOV_MAX_DELTA_BOUNCES`] times: the albedo and normal
//! are those of the first surface with a non-delta lobe, as Open Image Denoise's
//! documentation asks (the albedo of a perfect mirror says nothing of the noisy reflection
//! it shows), and so is the emission (what that surface emits towards the ray, for a
//! denoiser to keep an emitter's edge apart). Depth is the distance to the first surface,
//! mirror or not.

use glam::Vec3;

use super::interaction::surface_interaction;
use crate::bsdf::GltfBsdf;
use crate::geometry::spawn_ray;
use crate::sampling::{PathSampler, SamplerKind};
use crate::scene::camera::{camera_ray_cone, generate_camera_ray};
use crate::scene::layout::{Camera, PixelAov, AOV_MIXED_MATERIALS, AOV_NO_MATERIAL, MATERIAL_DOUBLE_SIDED};
use crate::scene::texture::textured_material;
use crate::scene::FlatScene;

/// Camera rays per pixel of the first AOV pass, one in each cell of a 2 × 2 grid over the
/// pixel: where the surface under a pixel is smooth (its features vary at most linearly
/// across it, which a stratified grid's mean states to a fraction of the step to the next
/// pixel) four state its mean; where they do not, its own rays disagree or a neighbour sees
/// another surface, and the pixel is refined ([`pixels_to_refine`]).
pub const AOV_SAMPLES: u32 = 4;
/// Rays per pixel where the first pass's features vary across the pixel
/// ([`pixels_to_refine`]), one in each cell of a 4 × 4 grid: 16 place them about as finely
/// as a 16-spp render places its samples (a further doubling cost more time than the
/// denoiser it guides and changed its error by under 1% on the Cornell box).
pub const AOV_VARYING_SAMPLES: u32 = 16;
/// The pixel's own rays' mean normal shorter than this (their normals about 10° apart or
/// more), a neighbour's depth more than [`AOV_VARYING_DEPTH`] of the pixel's from it, its
/// emission more than [`AOV_VARYING_EMISSION`] from it, or its material other: the pixel's
/// features vary across it faster than four rays state ([`pixels_to_refine`]).
pub const AOV_VARYING_COS: f32 = 0.985;
/// See [`AOV_VARYING_COS`].
pub const AOV_VARYING_DEPTH: f32 = 0.05;
/// See [`AOV_VARYING_COS`]: emission differs by more than this share of the brighter.
pub const AOV_VARYING_EMISSION: f32 = 0.01;
/// Rays per pixel on an emitter's edge ([`pixels_to_refine`]), one in each cell of a
/// 16 × 16 grid: there the denoiser reads emission as the share of the pixel it takes
/// (`crate::denoise::edges` puts the pixel's own emission back after its regression), and
/// 16 rays would state a bright emitter's share only to ±1/16 or so, where its radiance may
/// be a hundred times what it lights.
pub const AOV_REFINED_SAMPLES: u32 = 256;
/// Rays per pixel on a silhouette that no emitter's edge crosses ([`pixels_to_refine`]),
/// one in each cell of an 8 × 8 grid: the denoiser's edge regression reads coverage as a
/// feature, and ±1/64 of it moves a pixel by a sixty-fourth of the contrast across the
/// edge, well below the noise of the renders a denoiser is for. At 512² the Cornell box
/// has 5,913 such pixels of 6,360 refined, DamagedHelmet 2,777 of 3,052 (the rest where its
/// emissive parts meet the background), where 256 rays on every refined pixel made the
/// refinement 64% of the AOV pass (bench/RESULTS.md, "Denoising").
pub const AOV_SILHOUETTE_SAMPLES: u32 = 64;

/// Delta bounces an AOV ray follows at most before it takes the surface it stands on: a
/// chain of mirrors or a glass sphere's two faces need 2–4.
pub const AOV_MAX_DELTA_BOUNCES: u32 = 8;

/// The sample index of the first AOV ray; ray k takes `AOV_SAMPLE_INDEX - k`. Renders count
/// their samples up from 0 and never come near (`--spp` is a `u32`, and a render of 2³²−256
/// samples per pixel would take years), so the AOVs' numbers never repeat an image sample's.
pub const AOV_SAMPLE_INDEX: u32 = u32::MAX;

/// What one AOV ray found.
#[derive(Clone, Copy, Debug, PartialEq)]
struct AovRay {
    /// Did the camera ray hit a surface (and at what distance)?
    hit: bool,
    depth: f32,
    albedo: Vec3,
    normal: Vec3,
    emission: Vec3,
    /// The material the albedo was read from; [`AOV_NO_MATERIAL`] for a ray that left the
    /// scene.
    material: u32,
}

impl Default for AovRay {
    fn default() -> Self {
        AovRay {
            hit: false,
            depth: 0.0,
            albedo: Vec3::ZERO,
            normal: Vec3::ZERO,
            emission: Vec3::ZERO,
            material: AOV_NO_MATERIAL,
        }
    }
}

/// AOV ray `k` of `rays` (a square number) of pixel `(x, y)`: in cell k of a √rays × √rays
/// grid over the pixel, jittered within it.
#[allow(clippy::too_many_arguments)] // reason: a pixel's ray needs all of these; the WGSL twin takes the same
fn aov_ray(
    scene: &FlatScene,
    camera: &Camera,
    (width, height): (u32, u32),
    (x, y): (u32, u32),
    seed: u32,
    cone: crate::scene::camera::RayCone,
    k: u32,
    rays: u32,
) -> AovRay {
    let side = rays.isqrt();
    let mut rng = PathSampler::new(SamplerKind::Independent, x, y, AOV_SAMPLE_INDEX - k, seed);
    let jitter = rng.next_2d();
    let cell = glam::Vec2::new((k % side) as f32, (k / side) as f32);
    let u = ((cell + jitter) / side as f32).min(glam::Vec2::splat(1.0 - f32::EPSILON));
    let mut ray = generate_camera_ray(camera, width, height, x, y, u);
    let mut out = AovRay::default();
    let mut travelled = 0.0f32;
    for bounce in 0..=AOV_MAX_DELTA_BOUNCES {
        let alpha_seed = if scene.features.alpha { rng.next_u32() } else { 0 };
        let Some(hit) = scene.intersect_closest(&ray, alpha_seed) else { break };
        let si = surface_interaction(scene, &ray, &hit, cone.width_at(travelled + hit.hit.t));
        travelled += si.distance;
        if bounce == 0 {
            out.hit = true;
            out.depth = si.distance;
        }
        let untextured = &scene.materials[si.material as usize];
        let material = if scene.features.textures {
            textured_material(untextured, &scene.texture_arrays(), si.uv, si.lod)
        } else {
            *untextured
        };
        let bsdf = GltfBsdf::new(&material, si.wo, si.front_face, si.coat_normal);
        if bsdf.has_non_delta() || bounce == AOV_MAX_DELTA_BOUNCES {
            out.albedo = Vec3::from(material.base_color);
            out.normal = si.frame.z;
            out.material = si.material;
            if si.front_face || material.flags & MATERIAL_DOUBLE_SIDED != 0 {
                out.emission = Vec3::from(material.emission);
            }
            break;
        }
        // Both numbers drawn whether or not the BSDF reads the first (the kernel does).
        let u_lobe = rng.next_1d();
        let u_dir = rng.next_direction_2d();
        let Some(bs) = bsdf.sample(si.wo, u_lobe, u_dir) else { break };
        ray = spawn_ray(si.p, si.p_error, si.n_geometric, si.frame.from_local(bs.wi).normalize());
    }
    out
}

/// The AOVs of pixel `(x, y)` of a `width × height` render through `camera` with seed
/// `seed`, averaged over `rays` rays ([`AOV_SAMPLES`], [`AOV_SILHOUETTE_SAMPLES`] or
/// [`AOV_REFINED_SAMPLES`]), textures
/// read through `cone`.
#[allow(clippy::too_many_arguments)] // reason: a pixel's AOVs need all of these; the WGSL twin reads them from the frame
pub fn pixel_aov(
    scene: &FlatScene,
    camera: &Camera,
    (width, height): (u32, u32),
    (x, y): (u32, u32),
    seed: u32,
    rays: u32,
    cone: crate::scene::camera::RayCone,
) -> PixelAov {
    let mut p = PixelAov { rays, ..PixelAov::default() };
    let (mut albedo, mut normal, mut emission) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
    for k in 0..rays {
        let r = aov_ray(scene, camera, (width, height), (x, y), seed, cone, k, rays);
        p.material = if k == 0 || r.material == p.material { r.material } else { AOV_MIXED_MATERIALS };
        albedo += r.albedo;
        normal += r.normal;
        emission += r.emission;
        p.depth += r.depth;
        p.hits += r.hit as u32;
    }
    let n = rays as f32;
    p.albedo = (albedo / n).to_array();
    p.normal = (normal / n).to_array();
    p.emission = (emission / n).to_array();
    p.depth = if p.hits > 0 { p.depth / p.hits as f32 } else { 0.0 };
    p
}

/// The pixels the second AOV pass refines ([`pixels_to_refine`]), row-major indices,
/// ascending in each list; a pixel is in one list at most.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct AovRefinement {
    /// Features that vary across the pixel: [`AOV_VARYING_SAMPLES`] rays each.
    pub varying: Vec<u32>,
    /// Silhouettes: [`AOV_SILHOUETTE_SAMPLES`] rays each.
    pub silhouettes: Vec<u32>,
    /// Emitters' edges: [`AOV_REFINED_SAMPLES`] rays each.
    pub emitter_edges: Vec<u32>,
}

impl AovRefinement {
    /// Each list with the rays its pixels take, in the order both backends refine them.
    pub fn lists(&self) -> [(&[u32], u32); 3] {
        [
            (&self.varying, AOV_VARYING_SAMPLES),
            (&self.silhouettes, AOV_SILHOUETTE_SAMPLES),
            (&self.emitter_edges, AOV_REFINED_SAMPLES),
        ]
    }

    /// The rays pixel `i` takes in all: its refinement's, else the first pass's.
    pub fn rays_of(&self, i: u32) -> u32 {
        self.lists()
            .into_iter()
            .find(|(list, _)| list.binary_search(&i).is_ok())
            .map_or(AOV_SAMPLES, |(_, rays)| rays)
    }
}

/// Do two neighbouring first-pass pixels see different things: another material, another
/// depth or another emission ([`AOV_VARYING_COS`])?
///
/// Their normals and albedos are not compared. Within one material at one depth those
/// differ by the surface's texture, normal map or curvature, which the render's samples see
/// through the same mip levels as the first pass's four stratified rays; a crease or a
/// texture's edge that crosses a pixel spreads its own rays' normals or materials. On
/// DamagedHelmet at 512² comparing them sent 35,366 of its 45,000 pixels to
/// [`AOV_VARYING_SAMPLES`] rays, on textured, normal-mapped steps from one pixel to the next;
/// without them the AOV pass takes 29% less time (0.41 s against 0.58 s) and the denoised
/// relMSE at 256², 16 spp moved by 1.3% or less on the helmet and the Cornell box, with the
/// built-in filter and with OIDN (`bench/history/denoising.md`).
fn features_differ(p: &PixelAov, q: &PixelAov) -> bool {
    let (ep, eq) = (Vec3::from(p.emission), Vec3::from(q.emission));
    p.material != q.material
        || (p.depth - q.depth).abs() > AOV_VARYING_DEPTH * p.depth.max(q.depth)
        || (ep - eq).abs().max_element() > AOV_VARYING_EMISSION * ep.max(eq).max_element()
}

/// The pixels of a first AOV pass that straddle a silhouette or an emitter's edge, or whose
/// features vary across them, which the second pass refines.
/// * An emitter's edge is where one surface emits and another beside it does not: the
///   pixel's rays read more than one material and some of them an emitter, or a pixel of
///   its 3 × 3 neighbourhood sees an emitter where the pixel sees none (or the other way
///   round) and reads another material (a thin emitter's edge can miss all the first rays
///   of a pixel it crosses, so the neighbours tell).
/// * A silhouette, otherwise: its coverage is partial, or a neighbour's differs.
/// * Varying, otherwise: its rays read more than one material or their normals spread, or a
///   neighbour's depth, emission or material differs from its own ([`features_differ`]).
///
/// Within one material an emissive texture's variation is no emitter's edge, even where it
/// goes from emitting to dark: its texels are no brighter than the texture's own range,
/// which [`AOV_VARYING_SAMPLES`] rays state as well as they state an albedo texture, while
/// a lamp beside a ceiling may be a hundred times brighter than the surface it lights.
/// Refining every emitting-to-dark step of DamagedHelmet's emissive texture with 256 rays
/// (5,270 pixels at 512²) took half its AOV pass (`bench/history/denoising.md`).
pub fn pixels_to_refine(width: u32, height: u32, first: &[PixelAov]) -> AovRefinement {
    let (w, h) = (width as usize, height as usize);
    let coverage = |p: &PixelAov| p.hits as f32 / p.rays.max(1) as f32;
    let emits = |p: &PixelAov| Vec3::from(p.emission).max_element() > 0.0;
    let mut out = AovRefinement::default();
    for i in 0..w * h {
        let p = &first[i];
        let (c, e) = (coverage(p), emits(p));
        let partial = c > 0.0 && c < 1.0;
        let (x, y) = (i % w, i / w);
        // Its own rays read several materials, or their normals spread (their mean is short).
        let own_rays_differ = p.material == AOV_MIXED_MATERIALS
            || (c == 1.0 && Vec3::from(p.normal).length() < AOV_VARYING_COS);
        let (mut coverage_differs, mut emitter_beside, mut varies) = (false, false, own_rays_differ);
        for qy in y.saturating_sub(1)..=(y + 1).min(h - 1) {
            for qx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                let q = &first[qy * w + qx];
                coverage_differs |= coverage(q) != c;
                emitter_beside |= emits(q) != e && q.material != p.material;
                varies |= features_differ(p, q);
            }
        }
        if emitter_beside || (e && p.material == AOV_MIXED_MATERIALS) {
            out.emitter_edges.push(i as u32);
        } else if partial || coverage_differs {
            out.silhouettes.push(i as u32);
        } else if varies {
            out.varying.push(i as u32);
        }
    }
    out
}

/// Every pixel's AOVs, row-major from the top row, rows in parallel: a first pass of
/// [`AOV_SAMPLES`] rays, then more for the pixels [`pixels_to_refine`] names. Textures are read at the level of detail of a render of `spp` samples per pixel,
/// the render the AOVs go with, so that the albedo a denoiser divides the colour by is the
/// one the render's samples saw (a 16-spp render reads blurrier mip levels than a 1,024-spp
/// one: `scene::camera::camera_ray_cone`).
pub fn render_aovs(
    scene: &FlatScene,
    camera: &Camera,
    (width, height): (u32, u32),
    seed: u32,
    spp: u32,
) -> Vec<PixelAov> {
    use rayon::prelude::*;
    let size = (width, height);
    let cone = camera_ray_cone(camera, height, spp);
    let mut aovs: Vec<PixelAov> = (0..height)
        .into_par_iter()
        .flat_map_iter(|y| {
            (0..width).map(move |x| pixel_aov(scene, camera, size, (x, y), seed, AOV_SAMPLES, cone))
        })
        .collect();
    let refine = pixels_to_refine(width, height, &aovs);
    for (list, rays) in refine.lists() {
        let refined: Vec<PixelAov> = list
            .par_iter()
            .map(|&i| pixel_aov(scene, camera, size, (i % width, i / width), seed, rays, cone))
            .collect();
        for (&i, p) in list.iter().zip(refined) {
            aovs[i as usize] = p;
        }
    }
    aovs
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A first pass over 6 × 3 pixels: columns 0–1 miss, column 2 half covers a surface
    /// (material 0), columns 3–4 see it fully, and column 5 sees a lamp (material 1) emit;
    /// with `textured` the lamp is instead material 0 too, an emissive texture that lights
    /// up in column 5.
    fn first_pass(w: u32, h: u32, textured: bool) -> Vec<PixelAov> {
        (0..w * h)
            .map(|i| {
                let x = i % w;
                let (hits, material) = match x {
                    0 | 1 => (0, AOV_NO_MATERIAL),
                    2 => (AOV_SAMPLES / 2, AOV_MIXED_MATERIALS),
                    5 if !textured => (AOV_SAMPLES, 1),
                    _ => (AOV_SAMPLES, 0),
                };
                let emission = if x == 5 { [1.0, 1.0, 1.0] } else { [0.0; 3] };
                PixelAov { rays: AOV_SAMPLES, hits, emission, material, ..PixelAov::default() }
            })
            .collect()
    }

    fn columns(w: u32, list: &[u32]) -> Vec<u32> {
        let mut c: Vec<u32> = list.iter().map(|i| i % w).collect();
        c.sort();
        c.dedup();
        c
    }

    #[test]
    fn silhouettes_and_emitters_edges_are_refined_apart() {
        let (w, h) = (6u32, 3u32);
        let refine = pixels_to_refine(w, h, &first_pass(w, h, false));
        // Coverage changes between columns 1, 2 and 3; emission between 4 and 5.
        assert_eq!(columns(w, &refine.silhouettes), [1, 2, 3]);
        assert_eq!(columns(w, &refine.emitter_edges), [4, 5]);
        assert_eq!(refine.silhouettes.len() + refine.emitter_edges.len(), 5 * h as usize);
        assert_eq!(refine.rays_of(2), AOV_SILHOUETTE_SAMPLES);
        assert_eq!(refine.rays_of(5), AOV_REFINED_SAMPLES);
        assert_eq!(refine.rays_of(0), AOV_SAMPLES);
    }

    /// An emissive texture lighting up within one material is no emitter's edge; a pixel
    /// that straddles two materials, one of them emitting, is.
    #[test]
    fn an_emissive_texture_is_not_refined_as_an_emitters_edge() {
        let (w, h) = (6u32, 3u32);
        let refine = pixels_to_refine(w, h, &first_pass(w, h, true));
        assert_eq!(columns(w, &refine.silhouettes), [1, 2, 3]);
        assert!(refine.emitter_edges.is_empty(), "{:?}", refine.emitter_edges);
        // The texture's step is refined as any feature's is.
        assert_eq!(columns(w, &refine.varying), [4, 5]);
        assert_eq!(refine.rays_of(5), AOV_VARYING_SAMPLES);

        let mut first = first_pass(w, h, true);
        first[(w + 4) as usize].material = AOV_MIXED_MATERIALS;
        first[(w + 4) as usize].emission = [0.5; 3];
        let refine = pixels_to_refine(w, h, &first);
        // The straddling pixel, and its neighbours that emit otherwise and read one material.
        assert!(refine.emitter_edges.contains(&(w + 4)));
        assert!(refine.emitter_edges.contains(&3) && !refine.emitter_edges.contains(&5));
    }

    /// A surface seen whole by every pixel of a 6 × 3 first pass, its normal turning by
    /// `turn(x)` degrees about y at column x, its albedo `albedo(x)`.
    fn surface(turn: impl Fn(u32) -> f32, albedo: impl Fn(u32) -> f32) -> Vec<PixelAov> {
        (0..18u32)
            .map(|i| {
                let a = turn(i % 6).to_radians();
                PixelAov {
                    albedo: [albedo(i % 6); 3],
                    depth: 1.0,
                    normal: [a.sin(), 0.0, a.cos()],
                    hits: AOV_SAMPLES,
                    rays: AOV_SAMPLES,
                    ..PixelAov::default()
                }
            })
            .collect()
    }

    /// A surface whose normal or albedo steps from one pixel to the next, each pixel's rays
    /// agreeing, keeps the first pass's rays (a normal map, a texture, a crease along the
    /// pixels' border); a pixel whose own rays' normals spread, or whose neighbour lies at
    /// another depth, is refined with [`AOV_VARYING_SAMPLES`].
    #[test]
    fn pixels_whose_features_vary_are_refined() {
        let refine = |first: &[PixelAov]| pixels_to_refine(6, 3, first);
        let smooth = refine(&surface(|x| 2.0 * x as f32, |_| 0.5));
        assert_eq!(smooth, AovRefinement::default());
        let crease = refine(&surface(|x| if x < 3 { 0.0 } else { 45.0 }, |_| 0.5));
        assert_eq!(crease, AovRefinement::default());
        let step = refine(&surface(|_| 0.0, |x| if x < 4 { 0.5 } else { 0.55 }));
        assert_eq!(step, AovRefinement::default());
        let mut spread = surface(|_| 0.0, |_| 0.5);
        spread[7].normal = [0.0, 0.0, 0.9];
        assert_eq!(refine(&spread).varying, [7]);
        let mut deeper = surface(|_| 0.0, |_| 0.5);
        deeper[9].depth = 1.2;
        assert_eq!(refine(&deeper).varying, [2, 3, 4, 8, 9, 10, 14, 15, 16]);
    }
}
