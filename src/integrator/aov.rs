//! Auxiliary images (AOVs): what the camera sees at each pixel apart from its radiance, the
//! guides a denoiser needs (Open Image Denoise's albedo and normal; `crate::denoise`) and the
//! depth a compositor reads.
//!
//! WGSL twin: `shaders/aov.wgsl` (entry point `aov`), with the same names and the same
//! random numbers, so that both backends produce the same AOVs up to rounding.
//!
//! Each pixel averages [`AOV_SAMPLES`] camera rays, jittered over the pixel as the render's
//! box filter places its samples, so that the guides are anti-aliased as the image is (an
//! aliased guide puts its staircase into a denoised edge). Their random numbers come from the
//! independent sampler at sample indices the render never reaches ([`AOV_SAMPLE_INDEX`]), so
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
use crate::scene::layout::{Camera, PixelAov, MATERIAL_DOUBLE_SIDED};
use crate::scene::texture::textured_material;
use crate::scene::FlatScene;

/// Camera rays per pixel the AOVs average: 16 places them about as finely as a 16-spp render
/// places its samples, enough that an edge's coverage is resolved to ±1/8 (a further
/// doubling cost more time than the denoiser it guides and changed its error by under 1%
/// on the Cornell box).
pub const AOV_SAMPLES: u32 = 16;

/// Delta bounces an AOV ray follows at most before it takes the surface it stands on: a
/// chain of mirrors or a glass sphere's two faces need 2–4.
pub const AOV_MAX_DELTA_BOUNCES: u32 = 8;

/// The sample index of the first AOV ray; ray k takes `AOV_SAMPLE_INDEX - k`. Renders count
/// their samples up from 0 and never come near (`--spp` is a `u32`, and a render of 2³²−16
/// samples per pixel would take years), so the AOVs' numbers never repeat an image sample's.
pub const AOV_SAMPLE_INDEX: u32 = u32::MAX;

/// The AOVs of pixel `(x, y)` of a `width × height` render through `camera` with seed
/// `seed`.
pub fn pixel_aov(
    scene: &FlatScene,
    camera: &Camera,
    (width, height): (u32, u32),
    x: u32,
    y: u32,
    seed: u32,
) -> PixelAov {
    // Textures are read at the level of detail of a render of AOV_SAMPLES samples.
    let cone = camera_ray_cone(camera, height, AOV_SAMPLES);
    let (mut albedo, mut normal, mut emission) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
    let (mut depth, mut hits) = (0.0f32, 0u32);
    for k in 0..AOV_SAMPLES {
        let mut rng = PathSampler::new(SamplerKind::Independent, x, y, AOV_SAMPLE_INDEX - k, seed);
        let mut ray = generate_camera_ray(camera, width, height, x, y, rng.next_2d());
        let mut travelled = 0.0f32;
        for bounce in 0..=AOV_MAX_DELTA_BOUNCES {
            let alpha_seed = if scene.features.alpha { rng.next_u32() } else { 0 };
            let Some(hit) = scene.intersect_closest(&ray, alpha_seed) else { break };
            let si = surface_interaction(scene, &ray, &hit, cone.width_at(travelled + hit.hit.t));
            travelled += si.distance;
            if bounce == 0 {
                depth += si.distance;
                hits += 1;
            }
            let untextured = &scene.materials[si.material as usize];
            let material = if scene.features.textures {
                textured_material(untextured, &scene.texture_arrays(), si.uv, si.lod)
            } else {
                *untextured
            };
            let bsdf = GltfBsdf::new(&material, si.wo, si.front_face, si.coat_normal);
            if bsdf.has_non_delta() || bounce == AOV_MAX_DELTA_BOUNCES {
                albedo += Vec3::from(material.base_color);
                normal += si.frame.z;
                if si.front_face || material.flags & MATERIAL_DOUBLE_SIDED != 0 {
                    emission += Vec3::from(material.emission);
                }
                break;
            }
            // Both numbers drawn whether or not the BSDF reads the first (the kernel does).
            let u_lobe = rng.next_1d();
            let u_dir = rng.next_direction_2d();
            let Some(bs) = bsdf.sample(si.wo, u_lobe, u_dir) else { break };
            ray = spawn_ray(si.p, si.p_error, si.n_geometric, si.frame.from_local(bs.wi).normalize());
        }
    }
    let n = AOV_SAMPLES as f32;
    PixelAov {
        albedo: (albedo / n).to_array(),
        depth: if hits > 0 { depth / hits as f32 } else { 0.0 },
        normal: (normal / n).to_array(),
        hits,
        emission: (emission / n).to_array(),
        _pad0: 0,
    }
}

/// Every pixel's AOVs, row-major from the top row, rows in parallel.
pub fn render_aovs(scene: &FlatScene, camera: &Camera, width: u32, height: u32, seed: u32) -> Vec<PixelAov> {
    use rayon::prelude::*;
    (0..height)
        .into_par_iter()
        .flat_map_iter(|y| (0..width).map(move |x| pixel_aov(scene, camera, (width, height), x, y, seed)))
        .collect()
}
