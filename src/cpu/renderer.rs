//! Renders samples into a [`Film`] with rayon, one row per task.

use rayon::prelude::*;

use super::integrator::{radiance, IntegratorSettings};
use crate::film::{film_add_sample, Film};
use crate::render::{Backend, RenderSettings};
use crate::sampling::{replicate_of, PathSampler};
use crate::scene::camera::generate_camera_ray;
use crate::scene::layout::Camera;
use crate::scene::FlatScene;
use std::sync::Arc;

/// The scene a [`CpuBackend`] renders: borrowed (tests, one-shot renders) or shared (a
/// [`crate::session::Session`] that owns it).
enum SceneRef<'a> {
    Borrowed(&'a FlatScene),
    Shared(Arc<FlatScene>),
}

impl std::ops::Deref for SceneRef<'_> {
    type Target = FlatScene;
    fn deref(&self) -> &FlatScene {
        match self {
            SceneRef::Borrowed(s) => s,
            SceneRef::Shared(s) => s,
        }
    }
}

/// The CPU backend. Deterministic: each pixel's samples are taken in order by one task, and
/// each sample's random numbers depend only on (sampler, pixel, sample index, seed).
pub struct CpuBackend<'a> {
    scene: SceneRef<'a>,
    camera: Camera,
    settings: RenderSettings,
    film: Film,
    /// Rays traced per pixel (64-bit: a long render traces more than 2³² per pixel).
    rays: Vec<u64>,
}

impl<'a> CpuBackend<'a> {
    pub fn new(scene: &'a FlatScene, settings: &RenderSettings) -> CpuBackend<'a> {
        Self::with_scene(SceneRef::Borrowed(scene), settings)
    }

    fn with_scene(scene: SceneRef<'a>, settings: &RenderSettings) -> CpuBackend<'a> {
        CpuBackend {
            camera: scene.camera,
            scene,
            settings: settings.clone(),
            film: Film::new(settings.width, settings.height),
            rays: vec![0; settings.width as usize * settings.height as usize],
        }
    }
}

impl CpuBackend<'static> {
    /// A backend that shares ownership of its scene.
    pub fn shared(scene: Arc<FlatScene>, settings: &RenderSettings) -> CpuBackend<'static> {
        Self::with_scene(SceneRef::Shared(scene), settings)
    }
}

impl CpuBackend<'_> {
    /// Adds samples `samples` to the rows `rows` of the film.
    fn render_band(&mut self, samples: std::ops::Range<u32>, rows: std::ops::Range<u32>) {
        let scene: &FlatScene = &self.scene;
        let camera = &self.camera;
        let s = &self.settings;
        let (width, height, seed) = (s.width, s.height, s.seed);
        let integrator = IntegratorSettings {
            max_depth: s.max_depth.unwrap_or(u32::MAX),
            rr_min_depth: s.rr_min_depth,
            splits: s.splits,
        };
        let cone = crate::scene::camera::camera_ray_cone(camera, height, s.spp);
        let w = width as usize;
        let band = rows.start as usize * w..rows.end.min(height) as usize * w;
        self.film.pixels[band.clone()]
            .par_chunks_mut(w)
            .zip(self.rays[band].par_chunks_mut(w))
            .enumerate()
            .for_each(|(i, (row, rays))| {
                let y = rows.start as usize + i;
                for (x, (pixel, rays)) in row.iter_mut().zip(rays).enumerate() {
                    for k in samples.clone() {
                        let mut sampler = PathSampler::new(s.sampler, x as u32, y as u32, k, seed);
                        let ray =
                            generate_camera_ray(camera, width, height, x as u32, y as u32, sampler.next_2d());
                        let l = radiance(scene, &integrator, ray, cone, &mut sampler, rays);
                        film_add_sample(pixel, l, replicate_of(k));
                    }
                }
            });
    }
}

impl Backend for CpuBackend<'_> {
    fn name(&self) -> String {
        format!("cpu ({} threads)", rayon::current_num_threads())
    }

    fn render(&mut self, sample_offset: u32, samples: u32) -> crate::Result<()> {
        self.render_band(sample_offset..sample_offset + samples, 0..self.settings.height);
        Ok(())
    }

    fn render_rows(&mut self, sample_index: u32, rows: std::ops::Range<u32>) -> crate::Result<()> {
        self.render_band(sample_index..sample_index + 1, rows);
        Ok(())
    }

    fn reset(&mut self) -> crate::Result<()> {
        self.film = Film::new(self.settings.width, self.settings.height);
        self.rays.iter_mut().for_each(|r| *r = 0);
        Ok(())
    }

    fn set_camera(&mut self, camera: &Camera) -> crate::Result<()> {
        self.camera = *camera;
        Ok(())
    }

    fn film(&mut self) -> crate::Result<Film> {
        Ok(self.film.clone())
    }

    fn rays_traced(&mut self) -> crate::Result<u64> {
        Ok(self.rays.iter().sum())
    }
}
