//! Bidirectional path tracing (Veach & Guibas 1995; Veach 1997 ch. 10; pbrt-v3 §16.3 and
//! pbrt-v4 `BDPTIntegrator`): a camera subpath and a light subpath per sample, every pair
//! of their prefixes joined into a path, each such strategy weighted against all the others
//! that could have made the same path by multiple importance sampling.
//!
//! Strategy (s, t) takes s vertices of the light subpath y₀ … y_{s−1} and t of the camera
//! subpath x₀ … x_{t−1} (x₀ on the camera); its path has s + t − 2 scattering events.
//! * s = 0: the camera subpath met an emitter (or left the scene into the environment);
//! * s = 1: a light point sampled afresh from x_{t−1}, as next-event estimation does
//!   (`crate::light::sample_light`, the path tracer's own light sample);
//! * t = 1: y_{s−1} joined to the camera, its value splatted at the pixel it projects into,
//!   summed in the fixed point the light tracer uses (`super::light_tracing`), so that the
//!   sum does not depend on the order the splats arrive in;
//! * otherwise x_{t−1} and y_{s−1} joined by a shadow ray.
//!
//! (1, 1), a light point joined to the camera, is not taken: the camera's own rays see
//! emitters with less noise, and the MIS weights leave it out ([`strategy_is_sampled`]).
//! Orthographic cameras have no t = 1 strategy: nothing can be joined to a direction.
//!
//! **Weights.** The power heuristic (β = 2) through the recurrence of Veach 1997 §10.2 (eq.
//! 10.9; pbrt-v3 `MISWeight`): each vertex keeps the density, in area measure, with which
//! its own subpath made it (`pdf_fwd`) and the density with which the other direction would
//! have (`pdf_rev`); the ratio of two neighbouring strategies' densities is the ratio of
//! those at the one vertex that changes side, so no path is evaluated once per strategy.
//! The vertices next to the join have their reverse densities set for the join. A delta
//! lobe's densities are stored as 0 and read as 1 (`remap0`): they cancel, and no strategy
//! that would join a delta vertex is counted. Russian roulette is not in the densities: the
//! weights of the strategies that made a path still sum to 1, which is all unbiasedness asks.
//!
//! **Adjoint.** The light subpath carries importance (Veach 1997 §5.2–5.3; pbrt-v4
//! `TransportMode::Importance`): refraction's radiance factor 1/η² is absent, and where the
//! shading normal is not the geometric one each light-path vertex carries
//! |ω_l·n_s||ω_c·n_g| / (|ω_l·n_g||ω_c·n_s|). pathlight's glTF BSDF is built for one outgoing
//! direction (its layers scale by albedos of that direction, and the shading frame turns to
//! face it), so it is not reciprocal: a vertex's value f(ω_c, ω_l) is always the BSDF built
//! for the direction towards the camera's side, as the path tracer evaluates it, whichever
//! subpath the vertex belongs to ([`Seen::f_cos`]). A light subpath samples its next
//! direction from the BSDF built for the direction it arrived from, and weighs by the ratio.
//! Delta lobes are weighed as the light tracer weighs them (their value seen from either
//! side is the same Fresnel factor for the refracting and mirror materials the scenes use).
//!
//! **Textures** are read at their finest level at every vertex, camera side too: a ray
//! cone's footprint depends on which end a vertex was reached from, and the weights of a
//! path's strategies sum to 1 only if all of them see one integrand.
//!
//! **Bounded subpaths.** A subpath holds at most [`BDPT_MAX_VERTICES`] vertices (the GPU
//! twin stores them per invocation). A subpath that would go on past them ends there and is
//! counted ([`BdptStats::truncated`], reported by `render`). The weights leave out the
//! strategies a bound makes impossible, so no path the strategies can reach is biased: only
//! paths with more vertices than both subpaths can hold together are lost.
//!
//! **Random numbers.** The camera subpath draws from the pixel's [`PathSampler`] in this
//! order: per vertex [alpha], lobe, direction (2-D), [roulette]; then per camera vertex
//! x_i, i = 1 … in order, the light sample of s = 1 (2-D) and [alpha] for its shadow ray,
//! then [alpha] for each join s = 2 …. The light subpath draws from its own [`Rng`] stream
//! (`LIGHT_PATH_STREAM`'s row): light (2-D), point (2-D), side, direction (2-D); per vertex
//! [alpha], lobe, direction (2-D), [roulette]; then [alpha] for each camera join. [alpha]
//! is drawn only in scenes with alpha-tested materials.

use glam::{Vec2, Vec3};

use super::interaction::{sides_agree, surface_interaction, unblocked_light_sample, SurfaceInteraction};
use super::light_tracing::{sample_triangle_emission, LIGHT_RR_MIN_VERTICES};
use super::roulette::{survival_probability, MAX_BOUNCES_GUARD, RR_ANY_BOUNCE_DEPTH};
use super::IntegratorSettings;
use crate::bsdf::GltfBsdf;
use crate::bvh::ClosestHit;
use crate::geometry::{spawn_ray, spawn_ray_to, Frame, Ray, TriangleHit};
use crate::light::{
    choose_light, environment_lookup, sample_environment, spot_falloff, triangle_light_normal_area,
};
use crate::sampling::{sample_uniform_disk_concentric, sample_uniform_sphere, PathSampler, Rng};
use crate::scene::camera::PinholeProjection;
use crate::scene::layout::{
    Camera, Material, INVALID_INDEX, LIGHT_DIRECTIONAL, LIGHT_ENVIRONMENT, LIGHT_POINT, LIGHT_SPOT,
    LIGHT_TRIANGLE, MATERIAL_DOUBLE_SIDED, MATERIAL_VOLUME, PROJECTION_PERSPECTIVE, TRIANGLE_HAS_NORMALS,
};
use crate::scene::texture::{emitted_radiance, textured_material, LOD_FINEST};
use crate::scene::FlatScene;

/// The most vertices a subpath holds, its endpoint on the camera or light included: 14
/// scattering events on either side, and paths of up to 30 vertices reachable by some
/// strategy. The glass scenes' paths that carry light past it are below a z-test's reach
/// (`tests/bdpt.rs` compares every scene with the path tracer, which has no such bound).
pub const BDPT_MAX_VERTICES: usize = 16;

/// Per strategy (s, t), an image of its weighted contributions (`--bdpt-strategies`).
pub type StrategyImages = std::collections::BTreeMap<(u32, u32), Vec<Vec3>>;

/// What a render's bidirectional samples counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BdptStats {
    /// Subpaths that would have gone on past [`BDPT_MAX_VERTICES`] and were ended there.
    pub truncated: u64,
}

impl std::ops::AddAssign for BdptStats {
    fn add_assign(&mut self, other: BdptStats) {
        self.truncated += other.truncated;
    }
}

/// What kind of point a vertex is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    Camera,
    /// A point on an emissive triangle (a light subpath's origin, or a light sample).
    TriangleLight,
    /// A point or spot light.
    PointLight,
    /// A directional light, at infinity: `n` is the direction its light travels.
    DirectionalLight,
    /// The environment, at infinity: `n` is the unit direction towards it.
    Environment,
    /// A scattering surface.
    Surface,
}

/// A surface vertex's record: the interaction as its own subpath arrived at it, the BSDF
/// built for that arrival, and the hit (to see the point again from other directions).
#[derive(Clone, Copy)]
pub(crate) struct Surface {
    pub(crate) si: SurfaceInteraction,
    material: Material,
    pub(crate) bsdf: GltfBsdf,
    hit: ClosestHit,
    /// The interaction is the same from every direction on its geometric side (no vertex
    /// normals, normal map or coat normal map): [`Vertex::seen_from`] skips rebuilding it.
    view_independent: bool,
}

/// A subpath vertex (pbrt-v3 `Vertex`).
#[derive(Clone, Copy)]
pub(crate) struct Vertex {
    pub(crate) kind: Kind,
    pub(crate) p: Vec3,
    /// Surfaces: the unit geometric normal (winding). Triangle lights: the normal of the side
    /// the path left from. Environment and directional lights: see [`Kind`]. Else zero.
    pub(crate) n: Vec3,
    pub(crate) surface: Option<Surface>,
    /// The light's index in the light array (light vertices).
    light: u32,
    /// Throughput of the subpath up to this vertex, its scattering here excluded.
    pub(crate) beta: Vec3,
    /// Density, per unit area (per solid angle at infinity), with which the vertex's own
    /// subpath produced it.
    pdf_fwd: f32,
    /// The density with which a subpath from the other end would have produced it.
    pdf_rev: f32,
    /// Scattered by a delta lobe.
    pub(crate) delta: bool,
}

impl Vertex {
    fn endpoint(kind: Kind, p: Vec3, n: Vec3, light: u32, beta: Vec3, pdf_fwd: f32) -> Vertex {
        Vertex { kind, p, n, surface: None, light, beta, pdf_fwd, pdf_rev: 0.0, delta: false }
    }

    /// Lies at infinity (densities there are per solid angle).
    fn at_infinity(&self) -> bool {
        matches!(self.kind, Kind::Environment | Kind::DirectionalLight)
    }

    /// Has an area measure with a normal (its density per unit area carries a cosine).
    fn on_surface(&self) -> bool {
        matches!(self.kind, Kind::Surface | Kind::TriangleLight)
    }

    /// A light whose position or direction is a delta (point, spot, directional).
    fn is_delta_light(&self) -> bool {
        matches!(self.kind, Kind::PointLight | Kind::DirectionalLight)
    }

    /// Can a join end here (a non-delta lobe to evaluate)?
    fn connectible(&self) -> bool {
        match &self.surface {
            Some(s) => s.bsdf.has_non_delta(),
            None => true,
        }
    }

    /// A density per solid angle `pdf_solid_angle` of leaving this vertex towards `next`,
    /// in `next`'s measure (pbrt-v3 `Vertex::ConvertDensity`).
    fn convert_density(&self, pdf_solid_angle: f32, next: &Vertex) -> f32 {
        if self.at_infinity() {
            // A light at infinity sends its paths from a disk across its beam: the density
            // is per unit area of the disk, projected onto `next`.
            let cos = if next.on_surface() { self.emitted_towards(next).dot(next.n).abs() } else { 1.0 };
            return pdf_solid_angle * cos;
        }
        if next.at_infinity() {
            return pdf_solid_angle;
        }
        let d = next.p - self.p;
        let dist2 = d.length_squared();
        if dist2 == 0.0 {
            return 0.0;
        }
        let mut pdf = pdf_solid_angle / dist2;
        if next.on_surface() {
            pdf *= (d / dist2.sqrt()).dot(next.n).abs();
        }
        pdf
    }

    /// The unit direction light leaves this light vertex in towards `other`.
    fn emitted_towards(&self, other: &Vertex) -> Vec3 {
        match self.kind {
            Kind::Environment => -self.n,
            Kind::DirectionalLight => self.n,
            _ => (other.p - self.p).normalize_or_zero(),
        }
    }

    /// The surface as a path arriving from direction `w` sees it ([`Surface::seen_from`]).
    fn seen_from(&self, scene: &FlatScene, w: Vec3) -> Option<Seen> {
        Some(self.surface.as_ref()?.seen_from(scene, w))
    }
}

impl Surface {
    /// The surface as a path arriving from direction `w` (unit, world, pointing away from
    /// the surface) sees it, with its BSDF built for `w`: its own record when `w` is the
    /// direction its subpath arrived from.
    fn seen_from(&self, scene: &FlatScene, w: Vec3) -> Seen {
        let s = self;
        if w == s.si.wo_world {
            return Seen { si: s.si, bsdf: s.bsdf };
        }
        let same_side = (w.dot(s.si.n_geometric) > 0.0) == s.si.front_face;
        if s.view_independent && same_side {
            let mut si = s.si;
            si.wo_world = w;
            si.wo = si.frame.to_local(w);
            let bsdf = GltfBsdf::new(&s.material, si.wo, si.front_face, si.coat_normal);
            return Seen { si, bsdf };
        }
        let ray = Ray { origin: s.si.p + w, direction: -w, t_max: f32::MAX };
        let hit = ClosestHit { triangle: s.hit.triangle, hit: TriangleHit { t: 1.0, ..s.hit.hit } };
        let si = surface_interaction(scene, &ray, &hit, 0.0);
        let material = vertex_material(scene, &si);
        let bsdf = GltfBsdf::new(&material, si.wo, si.front_face, si.coat_normal);
        Seen { si, bsdf }
    }
}

/// A surface seen from one direction ([`Vertex::seen_from`]): its interaction and its BSDF
/// built for that direction, which both a vertex's value and its densities read.
struct Seen {
    si: SurfaceInteraction,
    bsdf: GltfBsdf,
}

impl Seen {
    /// f(ω_c, ω_l)·|ω_l·n_s|, ω_c the direction it is seen from (towards the camera's end):
    /// the BSDF evaluated for `w_light`, times the cosine at the light's side in this frame.
    /// Zero where the two sides disagree (`sides_agree`).
    fn f_cos(&self, w_light: Vec3) -> Vec3 {
        let wi = self.si.frame.to_local(w_light);
        if !sides_agree(&self.si, w_light, wi) {
            return Vec3::ZERO;
        }
        self.bsdf.eval(self.si.wo, wi) * wi.z.abs()
    }

    /// The density per solid angle with which a subpath arriving from the direction it is
    /// seen from samples `w_to` (unit, world, pointing away from the surface).
    fn pdf(&self, w_to: Vec3) -> f32 {
        let wi = self.si.frame.to_local(w_to);
        if !sides_agree(&self.si, w_to, wi) {
            return 0.0;
        }
        self.bsdf.pdf(self.si.wo, wi)
    }
}

/// A surface vertex's material, textured at the finest level (the module's "Textures"):
/// photon mapping's final gather reads it so too (`super::photon`).
pub(crate) fn vertex_material(scene: &FlatScene, si: &SurfaceInteraction) -> Material {
    let m = scene.materials[si.material as usize];
    if scene.features.textures {
        textured_material(&m, &scene.texture_arrays(), si.uv, Vec2::splat(LOD_FINEST))
    } else {
        m
    }
}

/// The camera's density per solid angle of direction `w`, per light path: a pinhole's
/// 1 / (A cos³θ) with A the image plane's area at distance 1 (pbrt-v3
/// `PerspectiveCamera::Pdf_We`). Each pixel's camera ray is placed within its own pixel,
/// but one pass traces one light path per pixel: for the weights the pass is N camera rays
/// spread over the whole image against N light paths, so A is the whole image's area.
fn camera_pdf_direction(camera: &Camera, w: Vec3) -> f32 {
    let cos = w.dot(Vec3::from(camera.forward));
    if camera.projection != PROJECTION_PERSPECTIVE || cos <= 0.0 {
        return 0.0;
    }
    let area = 4.0 * camera.half_width * camera.half_height;
    1.0 / (area * cos * cos * cos)
}

/// One sample's context: the scene, the camera, and the settings.
pub struct BdptContext<'a> {
    pub scene: &'a FlatScene,
    pub camera: &'a Camera,
    /// The pinhole run backwards for t = 1 (none for an orthographic camera).
    pub projection: Option<PinholeProjection>,
    pub settings: &'a IntegratorSettings,
    /// `settings.only_strategy`: strategy (s, t) alone with weight 1 and every other left
    /// out, to test each strategy's densities (`tests/bdpt.rs`): each then converges on its
    /// own to the paths it can make.
    only_strategy: Option<(u32, u32)>,
}

impl<'a> BdptContext<'a> {
    pub fn new(
        scene: &'a FlatScene,
        camera: &'a Camera,
        settings: &'a IntegratorSettings,
        width: u32,
        height: u32,
    ) -> BdptContext<'a> {
        let projection = (camera.projection == PROJECTION_PERSPECTIVE && settings.camera_connections)
            .then(|| PinholeProjection::new(camera, width, height));
        BdptContext { scene, camera, projection, settings, only_strategy: settings.only_strategy }
    }

    /// Does some sample make strategy (s, t)? The weights count no other.
    fn strategy_is_sampled(&self, s: usize, t: usize) -> bool {
        (t != 1 || (s != 1 && self.projection.is_some())) && s <= BDPT_MAX_VERTICES
    }

    /// The depth limit: strategy (s, t) has s + t − 2 scattering events.
    fn depth_allowed(&self, s: usize, t: usize) -> bool {
        let depth = (s + t) as u64 - 2;
        depth <= self.settings.max_depth.min(MAX_BOUNCES_GUARD) as u64
    }
}

/// Where a sample's weighted contributions go: the sum for its own pixel, and the t = 1
/// splats for the pixels they project into. Each is also reported with its strategy
/// (`--bdpt-strategies`).
pub trait BdptSink {
    /// Strategy (s, t)'s weighted contribution `value` to `pixel` (`None`: the sample's
    /// own pixel).
    fn add(&mut self, s: u32, t: u32, pixel: Option<usize>, value: Vec3);
}

/// The light subpath of one sample and its camera subpath's densities, reused from sample
/// to sample.
#[derive(Default)]
pub struct Subpaths {
    light: Vec<Vertex>,
    camera: Vec<Densities>,
}

impl Subpaths {
    pub fn new() -> Subpaths {
        Subpaths { light: Vec::with_capacity(BDPT_MAX_VERTICES), camera: Vec::with_capacity(64) }
    }
}

/// The camera subpath as a join at its last vertex sees it: x_{t−2} (x₀ when t = 2),
/// x_{t−1}, and the densities of x₀ … x_{t−1}. The camera subpath is joined vertex by
/// vertex as it is traced, so only these are kept.
struct CameraEnd<'a> {
    before: &'a Vertex,
    end: &'a Vertex,
    densities: &'a [Densities],
}

/// One bidirectional sample: camera ray `ray` (unit direction) drawn from `sampler`, its
/// light subpath from `light_rng`. Every strategy's weighted contribution goes to `sink`;
/// `rays` counts the rays traced, `stats` what was truncated.
///
/// The light subpath is traced first and kept (at most [`BDPT_MAX_VERTICES`]); its t = 1
/// joins follow; then the camera subpath is traced, each of its vertices joined to every
/// light vertex as it is reached. The camera subpath has no bound but the path tracer's
/// ([`MAX_BOUNCES_GUARD`]): every path the path tracer samples, strategies s = 0 and 1 can.
#[allow(clippy::too_many_arguments)] // reason: one sample's whole state, as `path::radiance` takes it
pub fn bdpt_sample(
    ctx: &BdptContext,
    ray: Ray,
    sampler: &mut PathSampler,
    light_rng: &mut Rng,
    paths: &mut Subpaths,
    sink: &mut impl BdptSink,
    rays: &mut u64,
    stats: &mut BdptStats,
) {
    paths.light.clear();
    paths.camera.clear();
    if light_subpath(ctx, light_rng, &mut paths.light, rays, SubpathLength::Roulette) {
        stats.truncated += 1;
    }
    let light = &paths.light[..];
    let wanted = |s: usize, t: usize| {
        ctx.depth_allowed(s, t) && ctx.only_strategy.is_none_or(|o| o == (s as u32, t as u32))
    };

    let camera = ctx.camera;
    let x0 = camera_vertex(camera, &ray);
    paths.camera.push(Densities { fwd: 1.0, rev: 0.0, delta: x0.delta });
    for s in 2..=light.len() {
        if wanted(s, 1) {
            if let Some((pixel, value)) = join_camera(ctx, &x0, &paths.camera, light, s, light_rng, rays) {
                sink.add(s as u32, 1, Some(pixel), value);
            }
        }
    }

    let pdf_direction = if x0.delta { 1.0 } else { camera_pdf_direction(camera, ray.direction) };
    let mut walk = Walk::new(ray, Vec3::ONE, pdf_direction, Transport::Radiance);
    let mut from = x0;
    while let Some(mut v) = walk.trace(ctx, sampler, &from, rays) {
        paths.camera.push(Densities { fwd: v.pdf_fwd, rev: 0.0, delta: false });
        let t = paths.camera.len();
        let cam = CameraEnd { before: &from, end: &v, densities: &paths.camera };
        for s in 0..=light.len() {
            if !wanted(s, t) {
                continue;
            }
            let value = match s {
                0 => emitter_hit(ctx, &cam, t),
                1 => join_light_sample(ctx, &cam, t, sampler, rays),
                _ => join(ctx, &cam, light, s, t, sampler, rays),
            };
            if value.max_element() > 0.0 {
                sink.add(s as u32, t as u32, None, value);
            }
        }
        if v.kind == Kind::Environment {
            break;
        }
        let Some(rev) = walk.scatter(ctx, sampler, &mut v, &from, t - 1) else { break };
        paths.camera[t - 2].rev = rev;
        paths.camera[t - 1].delta = v.delta;
        from = v;
    }
}

/// The camera subpath's first vertex x₀, where camera ray `ray` starts. An orthographic
/// camera's direction is a delta: no strategy can join to it.
fn camera_vertex(camera: &Camera, ray: &Ray) -> Vertex {
    let mut x0 = Vertex::endpoint(Kind::Camera, ray.origin, Vec3::from(camera.forward), 0, Vec3::ONE, 1.0);
    x0.delta = camera.projection != PROJECTION_PERSPECTIVE;
    x0
}

/// The three streams of numbers one Metropolis sample draws from (pbrt-v4
/// `MLTIntegrator`'s camera, light and connection streams): a mutation of one stream's
/// numbers leaves the others' meanings unchanged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stream {
    Camera = 0,
    Light = 1,
    Connection = 2,
}

/// Numbers drawn stream by stream ([`Stream`]): a Metropolis sampler's primary sample.
pub(crate) trait StreamNumbers: WalkNumbers {
    /// From now on numbers come from `stream`, from its first.
    fn start_stream(&mut self, stream: Stream);
}

/// One strategy of one path, as multiplexed Metropolis light transport samples it
/// (Hachisuka et al. 2014, §4; pbrt-v4 `MLTIntegrator::L`): a path of `depth` scattering
/// events, the strategy (s, t) chosen uniformly among the depth + 2 of them by the camera
/// stream's first number (depth 0 has the one, s = 0), a camera subpath of exactly t
/// vertices through a point of the image chosen by the next two, a light subpath of exactly
/// s, no Russian roulette on either, and the join. Returns the pixel and the strategy's
/// weighted contribution times the number of strategies (its density's reciprocal), so that
/// its expectation over strategies is the path's; `None` where it carries nothing. A
/// strategy that BDPT does not sample ((1, 1), or t = 1 through an orthographic camera)
/// carries nothing here either, and the weights of the others leave it out alike.
///
/// For t = 1 the value is divided by the image's pixels: BDPT sums a pass's splats over one
/// light subpath per pixel, while here one sample stands for itself (pbrt-v4 normalises its
/// camera's importance over the whole film for the same reason).
pub(crate) fn strategy_sample(
    ctx: &BdptContext,
    numbers: &mut impl StreamNumbers,
    depth: u32,
    (width, height): (u32, u32),
    paths: &mut Subpaths,
    rays: &mut u64,
) -> Option<(usize, Vec3)> {
    paths.light.clear();
    paths.camera.clear();
    numbers.start_stream(Stream::Camera);
    let (s, t, strategies) = if depth == 0 {
        (0, 2, 1)
    } else {
        let n = depth as usize + 2;
        let s = ((numbers.uniform_1d() * n as f32) as usize).min(n - 1);
        (s, n - s, n)
    };
    let u_film = numbers.uniform_2d();
    if !ctx.strategy_is_sampled(s, t) {
        return None;
    }
    let (fx, fy) = (u_film.x * width as f32, u_film.y * height as f32);
    let (px, py) = ((fx as u32).min(width - 1), (fy as u32).min(height - 1));
    let jitter = Vec2::new((fx - px as f32).clamp(0.0, 1.0), (fy - py as f32).clamp(0.0, 1.0));
    let ray = crate::scene::camera::generate_camera_ray(ctx.camera, width, height, px, py, jitter);
    let pixel = py as usize * width as usize + px as usize;

    let camera = ctx.camera;
    let x0 = camera_vertex(camera, &ray);
    paths.camera.push(Densities { fwd: 1.0, rev: 0.0, delta: x0.delta });
    // x_{t−2} and x_{t−1} (both x₀ when t = 1).
    let (mut before, mut end) = (x0, x0);
    if t >= 2 {
        let pdf_direction = if x0.delta { 1.0 } else { camera_pdf_direction(camera, ray.direction) };
        let mut walk = Walk::new(ray, Vec3::ONE, pdf_direction, Transport::Radiance);
        walk.roulette = false;
        let mut from = x0;
        loop {
            let mut v = walk.trace(ctx, numbers, &from, rays)?;
            paths.camera.push(Densities { fwd: v.pdf_fwd, rev: 0.0, delta: false });
            let here = paths.camera.len();
            if here == t {
                (before, end) = (from, v);
                break;
            }
            if v.kind == Kind::Environment {
                return None;
            }
            let rev = walk.scatter(ctx, numbers, &mut v, &from, here - 1)?;
            paths.camera[here - 2].rev = rev;
            paths.camera[here - 1].delta = v.delta;
            from = v;
        }
    }

    numbers.start_stream(Stream::Light);
    if s >= 2 {
        light_subpath(ctx, numbers, &mut paths.light, rays, SubpathLength::Fixed(s));
        if paths.light.len() != s {
            return None;
        }
    }

    numbers.start_stream(Stream::Connection);
    let cam = CameraEnd { before: &before, end: &end, densities: &paths.camera };
    let (pixel, value) = match (s, t) {
        (_, 1) => {
            let (pixel, value) = join_camera(ctx, &x0, &paths.camera, &paths.light, s, numbers, rays)?;
            (pixel, value / (width as f32 * height as f32))
        }
        (0, _) => (pixel, emitter_hit(ctx, &cam, t)),
        (1, _) => (pixel, join_light_sample(ctx, &cam, t, numbers, rays)),
        _ => (pixel, join(ctx, &cam, &paths.light, s, t, numbers, rays)),
    };
    let value = value * strategies as f32;
    (value.is_finite() && value.max_element() > 0.0).then_some((pixel, value))
}

/// Which quantity a subpath carries.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Transport {
    /// The camera subpath: radiance, as the path tracer carries it.
    Radiance,
    /// The light subpath: importance (the module's "Adjoint").
    Importance,
}

/// Where a random walk draws its numbers from: the camera's sampler or a light path's
/// stream.
pub(crate) trait WalkNumbers {
    fn u32(&mut self) -> u32;
    fn lobe(&mut self, used: bool) -> f32;
    fn direction(&mut self) -> Vec2;
    fn roulette(&mut self) -> f32;
    /// A number for anything else (a light's choice, a side).
    fn uniform_1d(&mut self) -> f32;
    /// Two numbers for anything else (a light sample, a point on a light).
    fn uniform_2d(&mut self) -> Vec2;
}

impl WalkNumbers for PathSampler {
    fn u32(&mut self) -> u32 {
        self.next_u32()
    }
    fn lobe(&mut self, used: bool) -> f32 {
        if used {
            self.next_1d()
        } else {
            self.skip_1d();
            0.0
        }
    }
    fn direction(&mut self) -> Vec2 {
        self.next_direction_2d()
    }
    fn roulette(&mut self) -> f32 {
        self.next_1d()
    }
    fn uniform_1d(&mut self) -> f32 {
        self.next_1d()
    }
    fn uniform_2d(&mut self) -> Vec2 {
        self.next_2d()
    }
}

impl WalkNumbers for Rng {
    fn u32(&mut self) -> u32 {
        self.next_u32()
    }
    fn lobe(&mut self, _used: bool) -> f32 {
        self.next_1d()
    }
    fn direction(&mut self) -> Vec2 {
        self.next_2d()
    }
    fn roulette(&mut self) -> f32 {
        self.next_1d()
    }
    fn uniform_1d(&mut self) -> f32 {
        self.next_1d()
    }
    fn uniform_2d(&mut self) -> Vec2 {
        self.next_2d()
    }
}

/// A subpath being traced (pbrt-v3 `RandomWalk`, one vertex at a time): the ray to trace
/// next, the throughput it carries, and what roulette needs.
pub(crate) struct Walk {
    ray: Ray,
    beta: Vec3,
    /// The density per solid angle with which `ray`'s direction was chosen (0 after a
    /// delta lobe).
    pdf_solid_angle: f32,
    /// Product of η² over the refractions (the path tracer's `eta_scale`).
    eta_scale: f32,
    non_delta_depth: u32,
    /// The light subpath's roulette compares its throughput with the light's (as the light
    /// tracer's does): a light path carries power, not a unit.
    roulette_scale: f32,
    transport: Transport,
    /// Plays Russian roulette; off where the caller fixes the subpath's length (Metropolis,
    /// [`strategy_sample`]).
    roulette: bool,
}

impl Walk {
    fn new(ray: Ray, beta: Vec3, pdf_solid_angle: f32, transport: Transport) -> Walk {
        let roulette_scale = if transport == Transport::Importance { 1.0 / beta.max_element() } else { 1.0 };
        Walk {
            ray,
            beta,
            pdf_solid_angle,
            eta_scale: 1.0,
            non_delta_depth: 0,
            roulette_scale,
            transport,
            roulette: true,
        }
    }

    /// Traces the ray from vertex `from`: the vertex it reaches (for the camera subpath, the
    /// environment where it leaves the scene), with its forward density.
    pub(crate) fn trace(
        &mut self,
        ctx: &BdptContext,
        numbers: &mut impl WalkNumbers,
        from: &Vertex,
        rays: &mut u64,
    ) -> Option<Vertex> {
        let Some(surface) = self.trace_surface(ctx, numbers, rays) else {
            // The camera subpath may end in the environment (s = 0 sees it); a light
            // subpath that leaves the scene ends.
            let env = &ctx.scene.environment.params;
            return (self.transport == Transport::Radiance && env.present != 0).then(|| {
                Vertex::endpoint(
                    Kind::Environment,
                    Vec3::ZERO,
                    self.ray.direction,
                    env.light_index,
                    self.beta,
                    self.pdf_solid_angle,
                )
            });
        };
        let mut v = Vertex {
            kind: Kind::Surface,
            p: surface.si.p,
            n: surface.si.n_geometric,
            light: surface.si.emitter,
            surface: Some(surface),
            beta: self.beta,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            delta: false,
        };
        v.pdf_fwd = from.convert_density(self.pdf_solid_angle, &v);
        Some(v)
    }

    /// Traces the ray: the surface it reaches, `None` where it leaves the scene. The walk's
    /// throughput then includes the attenuation inside a volume up to the surface. Photon
    /// tracing (`super::sppm`) walks by this and [`Self::scatter_surface`] alone: it keeps
    /// no vertices and no densities.
    #[inline(always)]
    pub(crate) fn trace_surface(
        &mut self,
        ctx: &BdptContext,
        numbers: &mut impl WalkNumbers,
        rays: &mut u64,
    ) -> Option<Surface> {
        let scene = ctx.scene;
        *rays += 1;
        let alpha_seed = if scene.features.alpha { numbers.u32() } else { 0 };
        let hit = scene.intersect_closest(&self.ray, alpha_seed)?;
        let si = surface_interaction(scene, &self.ray, &hit, 0.0);
        let material = vertex_material(scene, &si);
        if material.flags & MATERIAL_VOLUME != 0 && !si.front_face {
            self.beta *= (-Vec3::from(material.attenuation_coefficient) * si.distance).exp();
        }
        let bsdf = GltfBsdf::new(&material, si.wo, si.front_face, si.coat_normal);
        let tri = &scene.triangles[hit.triangle as usize];
        let view_independent = tri.flags & TRIANGLE_HAS_NORMALS == 0
            && material.normal_texture == INVALID_INDEX
            && (material.clearcoat <= 0.0 || material.clearcoat_normal_texture == INVALID_INDEX);
        Some(Surface { si, material, bsdf, hit, view_independent })
    }

    /// Samples the BSDF at `v`, vertex `here` of its subpath (reached from `from`), and plays
    /// roulette. Sets `v.delta`; returns the reverse density of `from` (in its measure) if
    /// the walk goes on along the new ray, `None` if it ends.
    pub(crate) fn scatter(
        &mut self,
        ctx: &BdptContext,
        numbers: &mut impl WalkNumbers,
        v: &mut Vertex,
        from: &Vertex,
        here: usize,
    ) -> Option<f32> {
        let scattered = self.scatter_surface(ctx, numbers, v.surface.as_ref()?, here, true)?;
        v.delta = scattered.delta;
        let rev = if scattered.delta { 0.0 } else { v.convert_density(scattered.pdf_reverse, from) };
        scattered.goes_on.then_some(rev)
    }

    /// [`Self::scatter`] at surface `s`, vertex `here` of its subpath, without the vertices:
    /// `None` where the walk ends before a direction is chosen (the depth limit, a sample
    /// that fails or carries nothing), else the lobe's kind, the reverse density per solid
    /// angle (computed only if `reverse_density`), and whether roulette let the walk go on
    /// along the new ray.
    #[inline(always)]
    pub(crate) fn scatter_surface(
        &mut self,
        ctx: &BdptContext,
        numbers: &mut impl WalkNumbers,
        s: &Surface,
        here: usize,
        reverse_density: bool,
    ) -> Option<Scattered> {
        let (scene, settings) = (ctx.scene, ctx.settings);
        // Scattering here makes paths of at least `here` scattering events (camera side:
        // x₁ … x_here) or `here + 1` (light side: y₁ … y_here and the join).
        let least_depth = here as u32 + (self.transport == Transport::Importance) as u32;
        if least_depth > settings.max_depth.min(MAX_BOUNCES_GUARD) {
            return None;
        }
        let (si, bsdf) = (&s.si, &s.bsdf);
        let u_lobe = numbers.lobe(bsdf.chooses_a_lobe());
        let u_dir = numbers.direction();
        let bs = bsdf.sample(si.wo, u_lobe, u_dir)?;
        let w_next = si.frame.from_local(bs.wi).normalize();
        if !sides_agree(si, w_next, bs.wi) {
            return None;
        }
        let ng = si.n_geometric;
        let (pdf_reverse, weight) = match (self.transport, bs.is_delta) {
            (Transport::Radiance, true) => (0.0, bs.weight),
            (Transport::Importance, true) => {
                let shading = if si.frame.z == ng || si.frame.z == -ng {
                    1.0
                } else {
                    (si.wo.z * w_next.dot(ng).abs()) / (si.wo_world.dot(ng).abs() * bs.wi.z.abs())
                };
                (0.0, bs.weight * (bs.eta_scale * shading))
            }
            (Transport::Radiance, false) => {
                let pdf_reverse =
                    if reverse_density { s.seen_from(scene, w_next).pdf(si.wo_world) } else { 0.0 };
                (pdf_reverse, bs.weight)
            }
            (Transport::Importance, false) => {
                // The value is the BSDF built for the camera's side, `w_next` (the module's
                // "Adjoint"), over the density it was sampled with from the light's side.
                let seen = s.seen_from(scene, w_next);
                let f_cos = seen.f_cos(si.wo_world);
                let cos_in = si.wo_world.dot(ng).abs();
                let weight = if cos_in > 0.0 {
                    f_cos * (w_next.dot(ng).abs() / (cos_in * bs.pdf_solid_angle))
                } else {
                    Vec3::ZERO
                };
                (if reverse_density { seen.pdf(si.wo_world) } else { 0.0 }, weight)
            }
        };
        let (p, p_error) = (si.p, si.p_error);
        self.beta *= weight;
        if !self.beta.is_finite() || self.beta.max_element() <= 0.0 {
            return None;
        }
        let delta = bs.is_delta;
        self.pdf_solid_angle = if bs.is_delta { 0.0 } else { bs.pdf_solid_angle };
        self.eta_scale *= bs.eta_scale;
        if !bs.is_delta {
            self.non_delta_depth += 1;
        }
        let survival = match self.transport {
            _ if !self.roulette => None,
            Transport::Radiance => (self.non_delta_depth >= settings.rr_min_depth
                || here as u32 >= RR_ANY_BOUNCE_DEPTH)
                .then(|| survival_probability(self.beta, self.eta_scale)),
            Transport::Importance => (here as u32 >= LIGHT_RR_MIN_VERTICES)
                .then(|| survival_probability(self.beta, self.roulette_scale)),
        };
        if let Some(q) = survival {
            if q <= 0.0 || numbers.roulette() >= q {
                return Some(Scattered { delta, pdf_reverse, goes_on: false });
            }
            self.beta /= q;
        }
        self.ray = spawn_ray(p, p_error, ng, w_next);
        Some(Scattered { delta, pdf_reverse, goes_on: true })
    }

    /// The walk's throughput so far (the next vertex's, before its own scattering).
    pub(crate) fn beta(&self) -> Vec3 {
        self.beta
    }
}

/// A scattering event of a [`Walk`] ([`Walk::scatter_surface`]).
pub(crate) struct Scattered {
    /// By a delta lobe.
    pub(crate) delta: bool,
    /// The density per solid angle of scattering back along the path's arriving direction,
    /// from the new direction's side (0 after a delta lobe, or where not asked for).
    pdf_reverse: f32,
    /// Roulette let the walk go on along the new ray.
    pub(crate) goes_on: bool,
}

/// How long a light subpath is.
#[derive(Clone, Copy, PartialEq, Eq)]
enum SubpathLength {
    /// BDPT's own: Russian roulette ends it, or [`BDPT_MAX_VERTICES`] (a truncation).
    Roulette,
    /// Exactly this many vertices, or fewer where the walk cannot go on; no roulette
    /// (Metropolis, [`strategy_sample`]).
    Fixed(usize),
}

/// The light subpath y₀ …: a light chosen by power (the alias table), a point on it and a
/// direction from it ([`light_subpath_origin`]), then a random walk carrying importance.
/// Returns whether it would have gone on past [`BDPT_MAX_VERTICES`] and was ended there.
fn light_subpath(
    ctx: &BdptContext,
    rng: &mut impl WalkNumbers,
    vertices: &mut Vec<Vertex>,
    rays: &mut u64,
    length: SubpathLength,
) -> bool {
    let Some((y0, mut walk)) = light_subpath_origin(ctx.scene, rng) else { return false };
    walk.roulette = length == SubpathLength::Roulette;
    vertices.push(y0);
    loop {
        let here = vertices.len();
        let Some(mut v) = walk.trace(ctx, rng, &vertices[here - 1], rays) else { return false };
        if length == SubpathLength::Fixed(here + 1) {
            // The last vertex: a join evaluates it, nothing scatters from it.
            vertices.push(v);
            return false;
        }
        let rev = walk.scatter(ctx, rng, &mut v, &vertices[here - 1], here);
        vertices.push(v);
        let Some(rev) = rev else { return false };
        vertices[here - 1].pdf_rev = rev;
        if vertices.len() == BDPT_MAX_VERTICES {
            return true;
        }
    }
}

/// A light subpath's origin y₀ and the walk leaving it: a light chosen by power (the alias
/// table), a point on it and a direction from it, drawn from `rng` in the order the
/// module's "Random numbers" gives. Lights at infinity (directional, environment) send
/// their paths from a disk covering the scene. `None` where the scene has no light or the
/// sample carries nothing. Photon tracing (`super::sppm`) starts its photons here too.
pub(crate) fn light_subpath_origin(scene: &FlatScene, rng: &mut impl WalkNumbers) -> Option<(Vertex, Walk)> {
    if scene.lights.is_empty() {
        return None;
    }
    let index = choose_light(&scene.lights, rng.uniform_2d());
    let u_point = rng.uniform_2d();
    let u_side = rng.uniform_1d();
    let u_direction = rng.uniform_2d();
    let light = &scene.lights[index];
    let pmf = light.pmf;
    if pmf <= 0.0 {
        return None;
    }
    let disk_area = std::f32::consts::PI * scene.scene_radius * scene.scene_radius;
    // (y₀, the ray leaving it, throughput carried by the ray, its direction's density, y₁'s
    // density per unit area before the cosine at y₁).
    let (y0, ray, beta, pdf_direction) = match light.kind {
        LIGHT_TRIANGLE => {
            let e = sample_triangle_emission(scene, light, u_point, u_side, u_direction)?;
            let y0 = Vertex::endpoint(
                Kind::TriangleLight,
                e.point,
                e.normal,
                index as u32,
                e.radiance,
                e.pdf_area,
            );
            (y0, e.ray, e.beta, e.pdf_direction)
        }
        LIGHT_POINT | LIGHT_SPOT => {
            let position = Vec3::from(light.position);
            let (direction, pdf) = if light.kind == LIGHT_SPOT {
                let axis = Vec3::from(light.direction);
                let (direction, pdf) = sample_cone(axis, light.cos_outer, u_direction);
                (direction, pdf)
            } else {
                (sample_uniform_sphere(u_direction), 1.0 / (4.0 * std::f32::consts::PI))
            };
            let mut intensity = Vec3::from(light.intensity);
            if light.kind == LIGHT_SPOT {
                intensity *= spot_falloff(light, direction.dot(Vec3::from(light.direction)));
            }
            let y0 = Vertex::endpoint(Kind::PointLight, position, Vec3::ZERO, index as u32, intensity, pmf);
            let ray = Ray { origin: position, direction, t_max: f32::MAX };
            (y0, ray, intensity / (pmf * pdf), pdf)
        }
        LIGHT_DIRECTIONAL => {
            let direction = Vec3::from(light.direction);
            let origin = disk_point(scene, -direction, u_point);
            let irradiance = Vec3::from(light.intensity);
            let y0 =
                Vertex::endpoint(Kind::DirectionalLight, origin, direction, index as u32, irradiance, pmf);
            let ray = Ray { origin, direction, t_max: f32::MAX };
            (y0, ray, irradiance * (disk_area / pmf), 1.0)
        }
        LIGHT_ENVIRONMENT => {
            let env = &scene.environment;
            let (to_env, le, pdf) = sample_environment(&env.params, &env.texels, &env.cdf, u_direction)?;
            let origin = disk_point(scene, to_env, u_point);
            let y0 = Vertex::endpoint(Kind::Environment, Vec3::ZERO, to_env, index as u32, le, pmf * pdf);
            let ray = Ray { origin, direction: -to_env, t_max: f32::MAX };
            (y0, ray, le * (disk_area / (pmf * pdf)), 1.0)
        }
        _ => return None,
    };
    if !beta.is_finite() || beta.max_element() <= 0.0 {
        return None;
    }
    // Lights at infinity send y₁ the density of the disk's point (`convert_density`).
    let pdf_solid_angle = if y0.at_infinity() { 1.0 / disk_area } else { pdf_direction };
    Some((y0, Walk::new(ray, beta, pdf_solid_angle, Transport::Importance)))
}

/// A point on the disk of the scene's bounding sphere facing direction `towards` (unit),
/// pushed out to the sphere's surface along it: where paths of lights at infinity start.
fn disk_point(scene: &FlatScene, towards: Vec3, u: Vec2) -> Vec3 {
    let frame = Frame::from_z(towards);
    let d = sample_uniform_disk_concentric(u) * scene.scene_radius;
    scene.scene_center + towards * scene.scene_radius + frame.x * d.x + frame.y * d.y
}

/// A direction uniform in the cone of half-angle acos(`cos_max`) about `axis`, and its
/// density per solid angle.
fn sample_cone(axis: Vec3, cos_max: f32, u: Vec2) -> (Vec3, f32) {
    let cos = 1.0 - u.x * (1.0 - cos_max);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * u.y;
    let local = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
    let pdf = 1.0 / (std::f32::consts::TAU * (1.0 - cos_max).max(f32::MIN_POSITIVE));
    (Frame::from_z(axis).from_local(local), pdf)
}

/// The density with which the light at light vertex `v` (or the emitter that surface `v`
/// lies on) is chosen and `v` picked on it, per unit area (per solid angle at infinity):
/// pbrt-v3 `Vertex::PdfLightOrigin`.
fn pdf_light_origin(scene: &FlatScene, v: &Vertex) -> f32 {
    let Some(light) = scene.lights.get(v.light as usize) else { return 0.0 };
    match v.kind {
        Kind::TriangleLight | Kind::Surface => {
            let (_, area) = triangle_light_normal_area(light);
            if area > 0.0 {
                light.pmf / area
            } else {
                0.0
            }
        }
        Kind::Environment => {
            let (_, pdf) = environment_lookup(&scene.environment.params, &scene.environment.texels, v.n);
            light.pmf * pdf
        }
        Kind::PointLight | Kind::DirectionalLight => light.pmf,
        Kind::Camera => 0.0,
    }
}

/// The density with which light vertex `v` (or emissive surface `v`) sends a light path
/// to `to`, in `to`'s measure (pbrt-v3 `Vertex::PdfLight`).
fn pdf_light(scene: &FlatScene, v: &Vertex, to: &Vertex) -> f32 {
    let disk_area = std::f32::consts::PI * scene.scene_radius * scene.scene_radius;
    let w = v.emitted_towards(to);
    let cos_to = if to.on_surface() { w.dot(to.n).abs() } else { 1.0 };
    match v.kind {
        Kind::Environment | Kind::DirectionalLight => cos_to / disk_area,
        Kind::TriangleLight | Kind::Surface => {
            let (n, double_sided) = match &v.surface {
                Some(s) => {
                    let two = scene.materials[s.si.material as usize].flags & MATERIAL_DOUBLE_SIDED != 0;
                    (s.si.n_geometric, two)
                }
                None => {
                    let tri = &scene.triangles[scene.lights[v.light as usize].triangle as usize];
                    (v.n, scene.materials[tri.material as usize].flags & MATERIAL_DOUBLE_SIDED != 0)
                }
            };
            // A light vertex's `n` is the side it emits from; a surface's its winding's, the
            // front (the only side a one-sided emitter lights).
            let cos = w.dot(n);
            let pdf_direction = if double_sided {
                cos.abs() / (2.0 * std::f32::consts::PI)
            } else if cos > 0.0 || v.surface.is_none() {
                cos.abs() / std::f32::consts::PI
            } else {
                0.0
            };
            v.convert_density(pdf_direction, to)
        }
        Kind::PointLight => {
            let light = &scene.lights[v.light as usize];
            let pdf_direction = if light.kind == LIGHT_SPOT {
                if w.dot(Vec3::from(light.direction)) >= light.cos_outer {
                    1.0 / (std::f32::consts::TAU * (1.0 - light.cos_outer).max(f32::MIN_POSITIVE))
                } else {
                    0.0
                }
            } else {
                1.0 / (4.0 * std::f32::consts::PI)
            };
            v.convert_density(pdf_direction, to)
        }
        Kind::Camera => 0.0,
    }
}

/// One vertex's densities and delta flag, for the weights.
#[derive(Clone, Copy, Default)]
struct Densities {
    fwd: f32,
    rev: f32,
    delta: bool,
}

/// The densities of the join of strategy (s, t) that differ from the subpaths' own: the
/// reverse densities of the two join vertices and of their predecessors, and for s = 1 the
/// light sample standing in for y₀.
#[derive(Default)]
struct JoinDensities {
    /// Reverse density of y_{s−1} (made from x_{t−1}).
    light_end: f32,
    /// Reverse density of y_{s−2}.
    light_before: f32,
    /// Reverse density of x_{t−1} (made from y_{s−1}).
    camera_end: f32,
    /// Reverse density of x_{t−2}.
    camera_before: f32,
    /// For s = 1: the sampled light vertex's forward density and whether it is a delta light.
    light_sample: Option<(f32, bool)>,
}

/// The power-heuristic weight of strategy (s, t) for the path it made (pbrt-v3 `MISWeight`
/// with β = 2): `camera` holds the densities of x₀ … x_{t−1}, `light` the light subpath
/// (for s = 1, the sampled light point as y₀).
fn mis_weight(
    ctx: &BdptContext,
    camera: &[Densities],
    light: &[Vertex],
    s: usize,
    t: usize,
    join: &JoinDensities,
) -> f32 {
    if ctx.only_strategy.is_some() {
        return 1.0;
    }
    let remap0 = |x: f32| if x != 0.0 { x } else { 1.0 };
    // The join's vertices are never delta (they are evaluated, not sampled), and their
    // reverse densities and their predecessors' are the join's.
    let camera_at = |i: usize| {
        let d = camera[i];
        match t - 1 - i {
            0 => Densities { rev: join.camera_end, delta: false, ..d },
            1 => Densities { rev: join.camera_before, ..d },
            _ => d,
        }
    };
    let light_at = |i: usize| {
        let v = &light[i];
        let mut d = Densities { fwd: v.pdf_fwd, rev: v.pdf_rev, delta: v.delta };
        if i == 0 {
            if let Some((fwd, _)) = join.light_sample {
                d = Densities { fwd, rev: 0.0, delta: false };
            }
        }
        match s - 1 - i {
            0 => Densities { rev: join.light_end, delta: false, ..d },
            1 => Densities { rev: join.light_before, ..d },
            _ => d,
        }
    };
    let light0_delta = match join.light_sample {
        Some((_, delta_light)) => delta_light,
        None => light.first().is_some_and(|y0| y0.is_delta_light()),
    };
    let mut sum = 0.0f32;
    let mut ri = 1.0f32;
    let mut next = camera_at(t - 1);
    for i in (1..t).rev() {
        let here = next;
        next = camera_at(i - 1);
        ri *= remap0(here.rev) / remap0(here.fwd);
        if !here.delta && !next.delta && ctx.strategy_is_sampled(s + t - i, i) {
            sum += ri * ri;
        }
    }
    ri = 1.0;
    for i in (0..s).rev() {
        let here = light_at(i);
        ri *= remap0(here.rev) / remap0(here.fwd);
        let delta_before = if i > 0 { light_at(i - 1).delta } else { light0_delta };
        if !here.delta && !delta_before && ctx.strategy_is_sampled(i, s + t - i) {
            sum += ri * ri;
        }
    }
    let w = 1.0 / (1.0 + sum);
    if w.is_finite() {
        w
    } else {
        0.0
    }
}

/// s = 0: the emission camera vertex x_{t−1} met, weighted.
fn emitter_hit(ctx: &BdptContext, cam: &CameraEnd, t: usize) -> Vec3 {
    let scene = ctx.scene;
    let (pt, ptm) = (cam.end, cam.before);
    let le = match pt.kind {
        Kind::Environment => environment_lookup(&scene.environment.params, &scene.environment.texels, pt.n).0,
        Kind::Surface => {
            let s = pt.surface.as_ref().expect("a surface vertex has its record");
            let untextured = &scene.materials[s.si.material as usize];
            let lit_side = s.si.front_face || untextured.flags & MATERIAL_DOUBLE_SIDED != 0;
            if Vec3::from(untextured.emission).max_element() <= 0.0 || !lit_side {
                return Vec3::ZERO;
            }
            if pt.light == INVALID_INDEX {
                // Emission that is no light: only this strategy finds it.
                return pt.beta * Vec3::from(s.material.emission);
            }
            let b = Vec3::new(s.hit.hit.b0, s.hit.hit.b1, s.hit.hit.b2);
            emitted_radiance(&scene.texture_arrays(), untextured, s.hit.triangle as usize, b)
        }
        _ => return Vec3::ZERO,
    };
    let value = pt.beta * le;
    if pt.light == INVALID_INDEX || value.max_element() <= 0.0 || t == 2 {
        // Seen directly, or no light to sample: no other strategy makes this path ((1, 1)
        // is not sampled).
        return value;
    }
    let join = JoinDensities {
        camera_end: pdf_light_origin(scene, pt),
        camera_before: pdf_light(scene, pt, ptm),
        ..JoinDensities::default()
    };
    value * mis_weight(ctx, cam.densities, &[], 0, t, &join)
}

/// t = 1: light vertex y_{s−1} joined to camera vertex `x0`, as (pixel, weighted value).
fn join_camera(
    ctx: &BdptContext,
    x0: &Vertex,
    camera: &[Densities],
    light: &[Vertex],
    s: usize,
    rng: &mut impl WalkNumbers,
    rays: &mut u64,
) -> Option<(usize, Vec3)> {
    let scene = ctx.scene;
    let alpha_seed = if scene.features.alpha { rng.u32() } else { 0 };
    let projection = ctx.projection.as_ref()?;
    let qs = &light[s - 1];
    let surface = qs.surface.as_ref()?;
    if !qs.connectible() {
        return None;
    }
    let (pixel, cos_theta, direction, distance2) = projection.project(qs.p)?;
    let w_camera = -direction;
    let seen = qs.seen_from(scene, w_camera)?;
    let f_cos = seen.f_cos(surface.si.wo_world);
    if f_cos.max_element() <= 0.0 {
        return None;
    }
    let ng = surface.si.n_geometric;
    let cos_in = surface.si.wo_world.dot(ng).abs();
    if cos_in == 0.0 {
        return None;
    }
    *rays += 1;
    if scene.intersect_any(&spawn_ray_to(qs.p, surface.si.p_error, ng, projection.position), alpha_seed) {
        return None;
    }
    // W_e·G for a pinhole whose box pixel has area A_pixel on the plane at distance 1:
    // |ω_cam·n_g| / (A_pixel cos³θ d²) (pbrt-v3 `PerspectiveCamera::We`); f_cos over
    // |ω_l·n_g| is the light vertex's value (the module's "Adjoint").
    let value = qs.beta * f_cos * direction.dot(ng).abs()
        / (cos_in * projection.pixel_area * cos_theta * cos_theta * cos_theta * distance2);
    if !value.is_finite() {
        return None;
    }
    let join = JoinDensities {
        light_end: x0.convert_density(camera_pdf_direction(ctx.camera, direction), qs),
        light_before: qs.convert_density(seen.pdf(surface.si.wo_world), &light[s - 2]),
        ..JoinDensities::default()
    };
    Some((pixel, value * mis_weight(ctx, camera, light, s, 1, &join)))
}

/// s = 1: a light sample from camera vertex x_{t−1}, weighted.
fn join_light_sample(
    ctx: &BdptContext,
    cam: &CameraEnd,
    t: usize,
    sampler: &mut impl WalkNumbers,
    rays: &mut u64,
) -> Vec3 {
    let scene = ctx.scene;
    let pt = cam.end;
    let Some(surface) = pt.surface.as_ref() else { return Vec3::ZERO };
    if !pt.connectible() || scene.lights.is_empty() {
        return Vec3::ZERO;
    }
    let si = &surface.si;
    let u_light = sampler.uniform_2d();
    let lights = scene.light_arrays();
    let Some((ls, wi, f)) =
        unblocked_light_sample(scene, lights, si, &surface.bsdf, u_light, || sampler.u32(), rays)
    else {
        return Vec3::ZERO;
    };
    let value = pt.beta * f * wi.z.abs() * ls.radiance / ls.pdf;
    // The sampled light as a vertex, for its densities.
    let light = &scene.lights[ls.light_index as usize];
    let endpoint = |kind, p, n| Vertex::endpoint(kind, p, n, ls.light_index, Vec3::ZERO, 0.0);
    let y0 = match light.kind {
        LIGHT_TRIANGLE => {
            // The side facing x_{t−1}: the one the light sample left from.
            let (n, _) = triangle_light_normal_area(light);
            endpoint(Kind::TriangleLight, ls.position, if n.dot(ls.wi) > 0.0 { -n } else { n })
        }
        LIGHT_POINT | LIGHT_SPOT => endpoint(Kind::PointLight, ls.position, Vec3::ZERO),
        LIGHT_DIRECTIONAL => endpoint(Kind::DirectionalLight, Vec3::ZERO, Vec3::from(light.direction)),
        _ => endpoint(Kind::Environment, Vec3::ZERO, ls.wi),
    };
    let join = JoinDensities {
        light_end: if ls.is_delta { 0.0 } else { pt.convert_density(surface.bsdf.pdf(si.wo, wi), &y0) },
        camera_end: pdf_light(scene, &y0, pt),
        camera_before: if t >= 3 {
            let pdf = pt.seen_from(scene, ls.wi).map_or(0.0, |seen| seen.pdf(si.wo_world));
            pt.convert_density(pdf, cam.before)
        } else {
            0.0
        },
        light_sample: Some((pdf_light_origin(scene, &y0), y0.is_delta_light())),
        ..JoinDensities::default()
    };
    value * mis_weight(ctx, cam.densities, &[y0], 1, t, &join)
}

/// s ≥ 2, t ≥ 2: camera vertex x_{t−1} joined to light vertex y_{s−1}, weighted.
fn join(
    ctx: &BdptContext,
    cam: &CameraEnd,
    light: &[Vertex],
    s: usize,
    t: usize,
    sampler: &mut impl WalkNumbers,
    rays: &mut u64,
) -> Vec3 {
    let scene = ctx.scene;
    let alpha_seed = if scene.features.alpha { sampler.u32() } else { 0 };
    let (pt, qs) = (cam.end, &light[s - 1]);
    let (Some(cs), Some(ls)) = (pt.surface.as_ref(), qs.surface.as_ref()) else { return Vec3::ZERO };
    if !pt.connectible() || !qs.connectible() {
        return Vec3::ZERO;
    }
    let d = qs.p - pt.p;
    let dist2 = d.length_squared();
    if dist2 == 0.0 {
        return Vec3::ZERO;
    }
    // A join must leave each surface by more than the points' rounding: between two points
    // of one plane (a wall's two faces) the direction's side is rounding noise, and a
    // shadow ray along the plane can slip past it (the sealed room would leak).
    let error = cs.si.p_error + ls.si.p_error;
    for n in [cs.si.n_geometric, ls.si.n_geometric] {
        if d.dot(n).abs() <= error.dot(n.abs()) {
            return Vec3::ZERO;
        }
    }
    let w = d / dist2.sqrt();
    let own = |s: &Surface| Seen { si: s.si, bsdf: s.bsdf };
    let (pt_own, qs_own) = (own(cs), own(ls));
    let f_camera = pt_own.f_cos(w);
    if f_camera.max_element() <= 0.0 {
        return Vec3::ZERO;
    }
    let Some(qs_seen) = qs.seen_from(scene, -w) else { return Vec3::ZERO };
    let f_light = qs_seen.f_cos(ls.si.wo_world);
    if f_light.max_element() <= 0.0 {
        return Vec3::ZERO;
    }
    let cos_in = ls.si.wo_world.dot(ls.si.n_geometric).abs();
    if cos_in == 0.0 {
        return Vec3::ZERO;
    }
    // β_c · f_c|ω·n_s| · G · f_l|ω_l·n_s|/|ω_l·n_g| · β_l with G's cosine at x_{t−1}
    // cancelled by the camera vertex's own |ω·n_g| (the module's "Adjoint").
    let mut value =
        pt.beta * f_camera * f_light * qs.beta * (w.dot(ls.si.n_geometric).abs() / (cos_in * dist2));
    if !value.is_finite() || value.max_element() <= 0.0 {
        return Vec3::ZERO;
    }
    // A join inside a refracting solid crosses its medium.
    if cs.material.flags & MATERIAL_VOLUME != 0 && w.dot(cs.si.n_geometric) < 0.0 {
        value *= (-Vec3::from(cs.material.attenuation_coefficient) * dist2.sqrt()).exp();
    }
    *rays += 1;
    let q_target = crate::geometry::offset_ray_origin(qs.p, ls.si.p_error, ls.si.n_geometric, -w);
    if scene.intersect_any(&spawn_ray_to(pt.p, cs.si.p_error, cs.si.n_geometric, q_target), alpha_seed) {
        return Vec3::ZERO;
    }
    let join = JoinDensities {
        light_end: pt.convert_density(pt_own.pdf(w), qs),
        light_before: qs.convert_density(qs_seen.pdf(ls.si.wo_world), &light[s - 2]),
        camera_end: qs.convert_density(qs_own.pdf(-w), pt),
        camera_before: if t >= 3 {
            let pdf = pt.seen_from(scene, w).map_or(0.0, |seen| seen.pdf(cs.si.wo_world));
            pt.convert_density(pdf, cam.before)
        } else {
            0.0
        },
        light_sample: None,
    };
    value * mis_weight(ctx, cam.densities, light, s, t, &join)
}
