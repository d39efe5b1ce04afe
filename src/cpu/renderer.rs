//! Renders samples into a [`Film`] with rayon, one row per task.

use rayon::prelude::*;

use crate::film::{film_add_sample, Film};
use crate::integrator::bdpt::{bdpt_sample, BdptContext, BdptSink, BdptStats, StrategyImages, Subpaths};
use crate::integrator::delta_view::camera_sees_only_delta_surfaces;
use crate::integrator::irradiance_cache::{IrradianceCache, IrradianceCacheContext, IrradianceCacheStats};
use crate::integrator::light_tracing::{sum_splats, trace_caustic_pass, CausticSums, LIGHT_PATH_STREAM};
use crate::integrator::mlt::{importance_before_pass, mlt_pass, MltContext, MltStats};
use crate::integrator::partition::{camera_supports_light_tracing, scene_supports_light_tracing};
use crate::integrator::photon::{photon_map_sample, PhotonMapSettings, PhotonMaps};
use crate::integrator::sppm::{sppm_film, sppm_pass, SppmContext, SppmPixel, SppmSettings, SppmStats};
use crate::integrator::{path::radiance, Integrator, IntegratorSettings};
use crate::render::{Backend, RenderSettings};
use crate::sampling::{replicate_of, PathSampler, Rng};
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
    /// Rays the light tracer traced (not per pixel: a light path belongs to none).
    light_rays: u64,
    /// The light tracer's pass last traced, by sample index: `render_rows` asks for one
    /// sample index band by band.
    caustic_pass: Option<(u32, Vec<glam::Vec3>)>,
    /// Adaptive sampling: the light tracer's passes summed into one image for the render
    /// ([`CausticSums`]); the film then holds the camera paths alone.
    caustic_sums: Option<CausticSums>,
    /// The settings' and the scene's half of [`Self::light_traces_caustics`], decided once:
    /// `scene_supports_light_tracing` reads every triangle.
    scene_light_traced: bool,
    /// The camera sees only delta surfaces, so no light vertex can be joined to it
    /// ([`camera_sees_only_delta_surfaces`]); decided per camera where light tracing or
    /// BDPT would make such joins.
    camera_sees_only_delta: bool,
    /// Bidirectional path tracing and Metropolis: the sample values of every pixel for the
    /// sample index last rendered (their splats land anywhere in the image, so a pass is
    /// rendered whole before any band of it is added).
    bdpt_pass: Option<(u32, Vec<glam::Vec3>)>,
    bdpt_stats: BdptStats,
    /// `--bdpt-strategies`: each strategy's weighted contributions summed over the passes
    /// rendered, and the number of passes.
    strategies: Option<(StrategyImages, u32)>,
    /// Adaptive sampling: pixel i takes sample indices below `budgets[i]` only.
    budgets: Option<Vec<u32>>,
    /// Stochastic progressive photon mapping: every pixel's state, and the passes taken
    /// (`film` then holds the per-pass estimates, `crate::integrator::sppm`).
    sppm: Option<SppmRender>,
    /// The photon-map integrator's maps, traced before its first sample and kept (they do
    /// not depend on the camera).
    photon_maps: Option<PhotonMaps>,
    /// The path tracer's irradiance cache, placed before its first sample for the current
    /// camera (`RenderSettings::irradiance_cache`).
    irradiance_cache: Option<IrradianceCache>,
    /// What Metropolis's passes counted.
    mlt_stats: MltStats,
    /// Metropolis's importance map, made from the film before passes 1, 2, 4, … (`None`:
    /// none yet, or `--mlt-target luminance`).
    mlt_importance: Option<Vec<f32>>,
}

/// A photon-mapping render's progressive state.
struct SppmRender {
    pixels: Vec<SppmPixel>,
    passes: u32,
    stats: SppmStats,
}

/// A bidirectional sample's destination: its own pixel's sum, the t = 1 splats, and each
/// strategy's share when they are recorded.
struct PixelSink<'a> {
    own: glam::Vec3,
    pixel: usize,
    splats: &'a mut Vec<(usize, glam::Vec3)>,
    strategies: Option<&'a mut Vec<(u32, u32, usize, glam::Vec3)>>,
}

impl BdptSink for PixelSink<'_> {
    fn add(&mut self, s: u32, t: u32, pixel: Option<usize>, value: glam::Vec3) {
        match pixel {
            Some(p) => self.splats.push((p, value)),
            None => self.own += value,
        }
        if let Some(record) = self.strategies.as_mut() {
            record.push((s, t, pixel.unwrap_or(self.pixel), value));
        }
    }
}

impl<'a> CpuBackend<'a> {
    pub fn new(scene: &'a FlatScene, settings: &RenderSettings) -> CpuBackend<'a> {
        Self::with_scene(SceneRef::Borrowed(scene), settings)
    }

    fn with_scene(scene: SceneRef<'a>, settings: &RenderSettings) -> CpuBackend<'a> {
        let scene_light_traced = settings.light_tracing && scene_supports_light_tracing(&scene);
        let joins_camera = scene_light_traced || settings.integrator.joins_camera();
        CpuBackend {
            camera: scene.camera,
            scene_light_traced,
            camera_sees_only_delta: joins_camera && camera_sees_only_delta_surfaces(&scene, &scene.camera),
            scene,
            settings: settings.clone(),
            film: Film::new(settings.width, settings.height),
            rays: vec![0; settings.width as usize * settings.height as usize],
            light_rays: 0,
            caustic_pass: None,
            caustic_sums: None,
            bdpt_pass: None,
            bdpt_stats: BdptStats::default(),
            strategies: settings.record_strategies.then(|| (StrategyImages::new(), 0)),
            budgets: None,
            sppm: (settings.integrator == Integrator::Sppm).then(|| SppmRender::new(settings)),
            photon_maps: None,
            irradiance_cache: None,
            mlt_stats: MltStats::default(),
            mlt_importance: None,
        }
    }

    /// Each strategy's mean weighted contribution per pixel over the passes rendered (its
    /// images sum to the render), when [`RenderSettings::record_strategies`] asked for them.
    pub fn strategy_images(&self) -> Option<StrategyImages> {
        let (images, passes) = self.strategies.as_ref()?;
        let scale = 1.0 / (*passes).max(1) as f32;
        Some(images.iter().map(|(k, image)| (*k, image.iter().map(|v| *v * scale).collect())).collect())
    }

    /// Are the caustic paths light traced ([`RenderSettings::light_tracing`] asked for, and
    /// the scene and camera allow it)?
    pub fn light_traces_caustics(&self) -> bool {
        // BDPT makes the light tracer's paths with its own t = 1 strategy.
        // Under an irradiance cache the gathers see the caustics themselves.
        self.settings.integrator == Integrator::Path
            && self.settings.irradiance_cache.is_none()
            && self.scene_light_traced
            && camera_supports_light_tracing(&self.camera)
            && !self.camera_sees_only_delta
    }

    fn integrator_settings(&self) -> IntegratorSettings {
        let s = &self.settings;
        IntegratorSettings {
            max_depth: s.max_depth_bound().unwrap_or(u32::MAX),
            rr_min_depth: s.rr_min_depth,
            splits: s.splits,
            caustics_by_light_tracing: self.light_traces_caustics(),
            only_strategy: s.bdpt_strategy,
            camera_connections: !self.camera_sees_only_delta,
        }
    }
}

impl SppmRender {
    fn new(settings: &RenderSettings) -> SppmRender {
        let pixels = settings.width as usize * settings.height as usize;
        SppmRender { pixels: vec![SppmPixel::default(); pixels], passes: 0, stats: SppmStats::default() }
    }
}

impl CpuBackend<'_> {
    /// The photon passes' settings (`RenderSettings::photons`, `sppm_radius`).
    fn sppm_settings(&self) -> SppmSettings {
        SppmSettings::of_render(&self.settings)
    }

    /// Photon-mapping pass `k`: the next pass, or the one just taken (a viewer asks for a
    /// pass band by band; the whole pass is taken for its first band).
    fn render_sppm_pass(&mut self, k: u32) -> crate::Result<()> {
        let integrator = self.integrator_settings();
        let sppm = self.sppm_settings();
        let state = self.sppm.as_mut().expect("an sppm render has its state");
        if k + 1 == state.passes {
            return Ok(());
        }
        if k != state.passes {
            return Err(crate::Error::Settings(format!(
                "photon-mapping pass {k} asked for after {} passes: its passes depend on the ones before and run in order",
                state.passes
            )));
        }
        let ctx = SppmContext {
            scene: &self.scene,
            camera: &self.camera,
            settings: &integrator,
            sppm,
            width: self.settings.width,
            height: self.settings.height,
            seed: self.settings.seed,
            sampler: self.settings.sampler,
            passes: self.settings.spp,
        };
        sppm_pass(&ctx, k, &mut state.pixels, &mut self.film, &mut self.rays, &mut state.stats);
        state.passes += 1;
        Ok(())
    }

    /// What the photon passes, or the photon maps, counted (`None` for other integrators).
    pub fn sppm_stats(&self) -> Option<SppmStats> {
        self.sppm.as_ref().map(|s| s.stats).or_else(|| self.photon_maps.as_ref().map(|m| m.stats))
    }

    /// The context photon mapping's functions read.
    fn photon_context<'b>(
        scene: &'b FlatScene,
        camera: &'b Camera,
        s: &RenderSettings,
        integrator: &'b IntegratorSettings,
        sppm: SppmSettings,
    ) -> SppmContext<'b> {
        SppmContext {
            scene,
            camera,
            settings: integrator,
            sppm,
            width: s.width,
            height: s.height,
            seed: s.seed,
            sampler: s.sampler,
            passes: s.spp,
        }
    }

    /// The photon-map integrator's samples `samples` of rows `rows`, its maps traced first
    /// if they are not yet.
    fn render_photon_band(&mut self, samples: std::ops::Range<u32>, rows: std::ops::Range<u32>) {
        let integrator = self.integrator_settings();
        let map_settings = PhotonMapSettings::of_render(&self.settings);
        let sppm = self.sppm_settings();
        if self.photon_maps.is_none() {
            let ctx = Self::photon_context(&self.scene, &self.camera, &self.settings, &integrator, sppm);
            let maps = PhotonMaps::build(&ctx, &map_settings);
            self.photon_maps = Some(maps);
        }
        let maps = self.photon_maps.take().expect("built above");
        {
            let ctx = Self::photon_context(&self.scene, &self.camera, &self.settings, &integrator, sppm);
            let w = self.settings.width as usize;
            let band = rows.start as usize * w..rows.end.min(self.settings.height) as usize * w;
            self.film.pixels[band.clone()]
                .par_chunks_mut(w)
                .zip(self.rays[band].par_chunks_mut(w))
                .enumerate()
                .for_each(|(i, (row, rays))| {
                    let y = rows.start + i as u32;
                    for (x, (pixel, rays)) in row.iter_mut().zip(rays).enumerate() {
                        for k in samples.clone() {
                            let l = photon_map_sample(&ctx, &maps, x as u32, y, k, rays);
                            film_add_sample(pixel, l, replicate_of(k));
                        }
                    }
                });
        }
        self.photon_maps = Some(maps);
    }

    /// What placing the irradiance cache counted (`None` without one, or before it is
    /// placed).
    pub fn irradiance_cache_stats(&self) -> Option<IrradianceCacheStats> {
        self.irradiance_cache.as_ref().map(|c| c.stats)
    }

    /// The irradiance cache for the current camera, placed if it is not yet.
    fn ensure_irradiance_cache(&mut self) {
        let Some(settings) = self.settings.irradiance_cache else { return };
        if self.irradiance_cache.is_some() {
            return;
        }
        let integrator = crate::integrator::irradiance_cache::gather_settings(&self.settings);
        let ctx = IrradianceCacheContext {
            scene: &self.scene,
            camera: &self.camera,
            integrator: &integrator,
            settings,
            width: self.settings.width,
            height: self.settings.height,
            seed: self.settings.seed,
        };
        self.irradiance_cache = Some(IrradianceCache::build(&ctx));
    }

    /// The light tracer's paths for sample index `k`: one per pixel that takes it.
    fn light_paths(&self, k: u32) -> usize {
        let pixels = self.settings.width as usize * self.settings.height as usize;
        match &self.budgets {
            Some(b) => b.iter().filter(|&&n| n > k).count(),
            None => pixels,
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
        if self.settings.integrator == Integrator::Photon {
            return self.render_photon_band(samples, rows);
        }
        let integrator = self.integrator_settings();
        if matches!(self.settings.integrator, Integrator::Bdpt | Integrator::Mlt) {
            for k in samples {
                if self.bdpt_pass.as_ref().map(|(pass, _)| *pass) != Some(k) {
                    let values = match self.settings.integrator {
                        Integrator::Mlt => self.render_mlt_pass(k, &integrator),
                        _ => self.render_bdpt_pass(k, &integrator),
                    };
                    self.bdpt_pass = Some((k, values));
                }
                let (_, values) = self.bdpt_pass.as_ref().expect("rendered above");
                let w = self.settings.width as usize;
                let band = rows.start as usize * w..rows.end.min(self.settings.height) as usize * w;
                for (pixel, value) in self.film.pixels[band.clone()].iter_mut().zip(&values[band]) {
                    film_add_sample(pixel, *value, replicate_of(k));
                }
            }
            return;
        }
        self.ensure_irradiance_cache();
        if !integrator.caustics_by_light_tracing {
            return self.render_band_with(samples, rows, &integrator, None);
        }
        // Each sample index takes the light tracer's pass for that index, so samples are
        // added index by index over the band.
        for k in samples {
            if self.caustic_pass.as_ref().map(|(pass, _)| *pass) != Some(k) {
                let s = &self.settings;
                let paths = self.light_paths(k);
                let (image, rays) = trace_caustic_pass(
                    &self.scene,
                    &self.camera,
                    &integrator,
                    (s.width, s.height),
                    k,
                    s.seed,
                    paths,
                );
                self.light_rays += rays;
                if s.adaptive {
                    let pixels = s.width as usize * s.height as usize;
                    self.caustic_sums
                        .get_or_insert_with(|| CausticSums::new(pixels))
                        .add_pass(k, &image, paths);
                }
                self.caustic_pass = Some((k, image));
            }
            let pass = self.caustic_pass.take();
            // An adaptive render's film takes the camera paths alone (`CausticSums`).
            let per_sample = pass.as_ref().filter(|_| !self.settings.adaptive);
            self.render_band_with(
                k..k + 1,
                rows.clone(),
                &integrator,
                per_sample.map(|(_, image)| &image[..]),
            );
            self.caustic_pass = pass;
        }
    }

    /// Bidirectional path tracing's sample index `k` of every pixel: each pixel's camera
    /// subpath with the light subpath of the same index, its own strategies plus the image
    /// of all pixels' t = 1 splats over the number of light paths (one per pixel, as the
    /// camera's density in `bdpt` assumes).
    fn render_bdpt_pass(&mut self, k: u32, integrator: &IntegratorSettings) -> Vec<glam::Vec3> {
        let scene: &FlatScene = &self.scene;
        let s = &self.settings;
        let (width, height, seed) = (s.width, s.height, s.seed);
        let ctx = BdptContext::new(scene, &self.camera, integrator, width, height);
        let record = self.strategies.is_some();
        let w = width as usize;
        type Row = (Vec<glam::Vec3>, Vec<(usize, glam::Vec3)>, Vec<(u32, u32, usize, glam::Vec3)>, BdptStats);
        let rows: Vec<Row> = self
            .rays
            .par_chunks_mut(w)
            .enumerate()
            .map(|(y, rays)| {
                let mut own = Vec::with_capacity(w);
                let mut splats = Vec::new();
                let mut strategies = Vec::new();
                let mut stats = BdptStats::default();
                let mut paths = Subpaths::new();
                for (x, rays) in rays.iter_mut().enumerate() {
                    let pixel = y * w + x;
                    let mut sampler = PathSampler::new(s.sampler, x as u32, y as u32, k, seed);
                    let mut light_rng = Rng::new(pixel as u32, LIGHT_PATH_STREAM, k, seed);
                    let ray = generate_camera_ray(
                        &self.camera,
                        width,
                        height,
                        x as u32,
                        y as u32,
                        sampler.next_2d(),
                    );
                    let mut sink = PixelSink {
                        own: glam::Vec3::ZERO,
                        pixel,
                        splats: &mut splats,
                        strategies: record.then_some(&mut strategies),
                    };
                    bdpt_sample(
                        &ctx,
                        ray,
                        &mut sampler,
                        &mut light_rng,
                        &mut paths,
                        &mut sink,
                        rays,
                        &mut stats,
                    );
                    own.push(sink.own);
                }
                (own, splats, strategies, stats)
            })
            .collect();
        let pixels = w * height as usize;
        let scale = 1.0 / pixels as f32;
        let mut values = Vec::with_capacity(pixels);
        let mut splat_lists = Vec::with_capacity(rows.len());
        for (own, splats, strategies, stats) in rows {
            values.extend(own);
            splat_lists.push(splats);
            self.bdpt_stats += stats;
            if let Some((images, _)) = self.strategies.as_mut() {
                for (s, t, pixel, value) in strategies {
                    let image = images.entry((s, t)).or_insert_with(|| vec![glam::Vec3::ZERO; pixels]);
                    image[pixel] += if t == 1 { value * scale } else { value };
                }
            }
        }
        if let Some((_, passes)) = self.strategies.as_mut() {
            *passes += 1;
        }
        let splatted = sum_splats(pixels, &splat_lists, scale);
        for (value, splat) in values.iter_mut().zip(splatted) {
            *value += splat;
        }
        values
    }

    /// Metropolis's pass `k`: an estimate of the whole image (`mlt_pass`), its chains'
    /// target weighed by the importance map the film of the passes before made.
    fn render_mlt_pass(&mut self, k: u32, integrator: &IntegratorSettings) -> Vec<glam::Vec3> {
        let s = &self.settings;
        let film = &self.film;
        let remade = importance_before_pass(s.mlt.target, k, (s.width, s.height), || {
            Ok::<_, std::convert::Infallible>(film.pixels.clone())
        });
        if let Ok(Some(map)) = remade {
            self.mlt_importance = Some(map);
        }
        let ctx = MltContext {
            importance: self.mlt_importance.as_deref(),
            scene: &self.scene,
            camera: &self.camera,
            integrator,
            settings: s.mlt,
            width: s.width,
            height: s.height,
            seed: s.seed,
        };
        let (image, stats) = mlt_pass(&ctx, k);
        self.mlt_stats += stats;
        image
    }

    /// [`Self::render_band`] for one integrator, with `caustics` (the light tracer's image
    /// for the one sample index in `samples`) added to every sample when given.
    fn render_band_with(
        &mut self,
        samples: std::ops::Range<u32>,
        rows: std::ops::Range<u32>,
        integrator: &IntegratorSettings,
        caustics: Option<&[glam::Vec3]>,
    ) {
        let scene: &FlatScene = &self.scene;
        let camera = &self.camera;
        let s = &self.settings;
        let (width, height, seed) = (s.width, s.height, s.seed);
        let cone = crate::scene::camera::camera_ray_cone(camera, height, s.spp);
        let w = width as usize;
        let band = rows.start as usize * w..rows.end.min(height) as usize * w;
        let budgets = self.budgets.as_deref();
        let cache = self.irradiance_cache.as_ref();
        self.film.pixels[band.clone()]
            .par_chunks_mut(w)
            .zip(self.rays[band].par_chunks_mut(w))
            .enumerate()
            .for_each(|(i, (row, rays))| {
                let y = rows.start as usize + i;
                for (x, (pixel, rays)) in row.iter_mut().zip(rays).enumerate() {
                    let light_traced = caustics.map_or(glam::Vec3::ZERO, |image| image[y * w + x]);
                    let end = budgets.map_or(samples.end, |b| samples.end.min(b[y * w + x]));
                    for k in samples.start..end {
                        let mut sampler = PathSampler::new(s.sampler, x as u32, y as u32, k, seed);
                        let ray =
                            generate_camera_ray(camera, width, height, x as u32, y as u32, sampler.next_2d());
                        let l = match s.integrator {
                            Integrator::Path => {
                                radiance(scene, integrator, cache, ray, cone, &mut sampler, rays)
                            }
                            Integrator::Bdpt | Integrator::Sppm | Integrator::Photon | Integrator::Mlt => {
                                unreachable!("rendered by their own bands")
                            }
                        };
                        film_add_sample(pixel, l + light_traced, replicate_of(k));
                    }
                }
            });
    }
}

impl Backend for CpuBackend<'_> {
    fn name(&self) -> String {
        let caustics = if self.light_traces_caustics() { ", caustics light-traced" } else { "" };
        format!("cpu ({} threads{caustics})", rayon::current_num_threads())
    }

    fn render(&mut self, sample_offset: u32, samples: u32) -> crate::Result<()> {
        if self.sppm.is_some() {
            for k in sample_offset..sample_offset + samples {
                self.render_sppm_pass(k)?;
            }
            return Ok(());
        }
        self.render_band(sample_offset..sample_offset + samples, 0..self.settings.height);
        Ok(())
    }

    fn render_rows(&mut self, sample_index: u32, rows: std::ops::Range<u32>) -> crate::Result<()> {
        if self.sppm.is_some() {
            return self.render_sppm_pass(sample_index);
        }
        self.render_band(sample_index..sample_index + 1, rows);
        Ok(())
    }

    fn reset(&mut self) -> crate::Result<()> {
        self.film = Film::new(self.settings.width, self.settings.height);
        self.rays.iter_mut().for_each(|r| *r = 0);
        self.light_rays = 0;
        // A pass the sums no longer hold is traced again (deterministically) when next asked.
        self.caustic_pass = None;
        self.caustic_sums = None;
        self.bdpt_pass = None;
        self.bdpt_stats = BdptStats::default();
        self.mlt_stats = MltStats::default();
        self.mlt_importance = None;
        if let Some(strategies) = self.strategies.as_mut() {
            *strategies = (StrategyImages::new(), 0);
        }
        if self.sppm.is_some() {
            self.sppm = Some(SppmRender::new(&self.settings));
        }
        Ok(())
    }

    fn set_sample_budgets(&mut self, budgets: Option<&[u32]>) -> crate::Result<()> {
        let pixels = self.settings.width as usize * self.settings.height as usize;
        if budgets.is_some_and(|b| b.len() != pixels) {
            return Err(crate::Error::Settings(format!("sample budgets for {pixels} pixels expected")));
        }
        self.budgets = budgets.map(<[u32]>::to_vec);
        Ok(())
    }

    fn set_camera(&mut self, camera: &Camera) -> crate::Result<()> {
        self.camera = *camera;
        let joins_camera = self.scene_light_traced || self.settings.integrator.joins_camera();
        self.camera_sees_only_delta = joins_camera && camera_sees_only_delta_surfaces(&self.scene, camera);
        self.caustic_pass = None;
        self.bdpt_pass = None;
        // Records are placed where this camera's paths land.
        self.irradiance_cache = None;
        Ok(())
    }

    fn film(&mut self) -> crate::Result<Film> {
        match &self.sppm {
            Some(state) => {
                Ok(sppm_film(&self.film, &state.pixels, state.passes, self.sppm_settings().photons))
            }
            None => Ok(match &self.caustic_sums {
                Some(sums) => sums.fold_into(&self.film),
                None => self.film.clone(),
            }),
        }
    }

    fn aovs(&mut self) -> crate::Result<Vec<crate::scene::layout::PixelAov>> {
        let (w, h) = (self.settings.width, self.settings.height);
        Ok(crate::integrator::aov::render_aovs(
            &self.scene,
            &self.camera,
            (w, h),
            self.settings.seed,
            self.settings.spp,
        ))
    }

    fn rays_traced(&mut self) -> crate::Result<u64> {
        let photon_rays = self.sppm_stats().map_or(0, |s| s.photon_rays);
        let cache_rays = self.irradiance_cache_stats().map_or(0, |s| s.gather_rays + s.overture_rays);
        let mlt_rays = self.mlt_stats.rays;
        Ok(self.rays.iter().sum::<u64>() + self.light_rays + photon_rays + cache_rays + mlt_rays)
    }

    fn strategy_images(&mut self) -> crate::Result<Option<StrategyImages>> {
        Ok(CpuBackend::strategy_images(self))
    }

    fn sppm_stats(&mut self) -> Option<SppmStats> {
        CpuBackend::sppm_stats(self)
    }

    fn irradiance_cache_stats(&mut self) -> Option<IrradianceCacheStats> {
        CpuBackend::irradiance_cache_stats(self)
    }

    fn irradiance_record_pixels(&mut self) -> Option<Vec<(u32, u32)>> {
        self.irradiance_cache.as_ref().map(|c| c.records().iter().map(|r| r.pixel).collect())
    }

    fn bdpt_stats(&mut self) -> Option<BdptStats> {
        (self.settings.integrator == Integrator::Bdpt).then_some(self.bdpt_stats)
    }

    fn mlt_stats(&mut self) -> Option<MltStats> {
        (self.settings.integrator == Integrator::Mlt).then_some(self.mlt_stats)
    }
}
