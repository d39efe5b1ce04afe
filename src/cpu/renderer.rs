//! Renders samples into a [`Film`] with rayon, one row per task.

use rayon::prelude::*;

use super::integrator::{radiance, IntegratorSettings};
use crate::film::{film_add_sample, Film};
use crate::render::{Backend, RenderSettings};
use crate::sampling::Rng;
use crate::scene::camera::generate_camera_ray;
use crate::scene::FlatScene;

/// The CPU backend. Deterministic: each pixel's samples are taken in order by one task, and
/// each sample's random stream depends only on (pixel, sample index, seed).
pub struct CpuBackend<'a> {
    scene: &'a FlatScene,
    settings: RenderSettings,
    film: Film,
    /// Rays traced per pixel.
    rays: Vec<u32>,
}

impl<'a> CpuBackend<'a> {
    pub fn new(scene: &'a FlatScene, settings: &RenderSettings) -> CpuBackend<'a> {
        CpuBackend {
            scene,
            settings: settings.clone(),
            film: Film::new(settings.width, settings.height),
            rays: vec![0; settings.width as usize * settings.height as usize],
        }
    }
}

impl Backend for CpuBackend<'_> {
    fn name(&self) -> String {
        format!("cpu ({} threads)", rayon::current_num_threads())
    }

    fn render(&mut self, sample_offset: u32, samples: u32) -> crate::Result<()> {
        let scene = self.scene;
        let s = &self.settings;
        let (width, height, seed) = (s.width, s.height, s.seed);
        let integrator =
            IntegratorSettings { max_depth: s.max_depth.unwrap_or(u32::MAX), rr_min_depth: s.rr_min_depth };
        let cone = crate::scene::camera::camera_ray_cone(&scene.camera, height, s.spp);
        self.film
            .pixels
            .par_chunks_mut(width as usize)
            .zip(self.rays.par_chunks_mut(width as usize))
            .enumerate()
            .for_each(|(y, (row, rays))| {
                for (x, (pixel, rays)) in row.iter_mut().zip(rays).enumerate() {
                    for k in sample_offset..sample_offset + samples {
                        let mut rng = Rng::new(x as u32, y as u32, k, seed);
                        let ray = generate_camera_ray(
                            &scene.camera,
                            width,
                            height,
                            x as u32,
                            y as u32,
                            rng.next_2d(),
                        );
                        let l = radiance(scene, &integrator, ray, cone, &mut rng, rays);
                        film_add_sample(pixel, l);
                    }
                }
            });
        Ok(())
    }

    fn film(&mut self) -> crate::Result<Film> {
        Ok(self.film.clone())
    }

    fn rays_traced(&mut self) -> crate::Result<u64> {
        Ok(self.rays.iter().map(|&r| r as u64).sum())
    }
}
