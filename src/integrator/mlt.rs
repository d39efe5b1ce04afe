//! Metropolis light transport in primary sample space (Kelemen et al. 2002) with the
//! multiplexed choice of bidirectional strategy (Hachisuka, Kaplanyan & Dachsbacher 2014,
//! "Multiplexed Metropolis Light Transport"; pbrt-v4 `MLTIntegrator`), over [`super::bdpt`].
//!
//! **The state.** A Markov chain walks over primary samples: vectors of numbers in [0, 1)
//! read in three streams ([`Stream`]) by [`strategy_sample`], which turns them into one
//! bidirectional strategy of one path of a fixed depth, its pixel and its weighted
//! contribution C. The chain's target is T = luminance(C) · w(pixel), its scalar
//! contribution weighed by its pixel's importance ([`MltTarget`]).
//!
//! **Importance.** Any positive target gives the image (the splats divide by T and b
//! multiplies by its integral); what it chooses is where the mutations go. T = luminance(C)
//! (Veach's, pbrt-v4's; `--mlt-target luminance`) sends each pixel mutations in proportion
//! to its brightness, so a bright patch takes most of them and the dim rest of the image,
//! which relative error weighs as much, stays noisy. The default (`relative`) divides by an
//! estimate of the pixel's brightness, as Hoberock & Hart 2010 ("Arbitrary importance
//! functions for Metropolis light transport", multi-stage MLT) do: w = 1 / √(Ī² + ε), Ī the
//! luminance of the image so far blurred over (2·[`IMPORTANCE_BLUR_RADIUS`] + 1)² pixels, ε
//! relMSE's own floor for dark pixels ([`IMPORTANCE_DARK_FLOOR`]). Pixels' mutations then go
//! as Ī / √(Ī² + ε), which minimises Σ var / (Ī² + ε) if a pixel's variance goes as Ī² over
//! its mutations. The map is made before passes 1, 2, 4, 8, … ([`remakes_importance`]) from
//! the film the backend holds (none before the first pass, or after a reset: w = 1), by
//! [`importance_map`] on the host for both backends.
//!
//! **Mutations.** With probability `large_step_probability` every number is drawn afresh
//! (a large step: an independent sample, which keeps the chain ergodic); otherwise each
//! number moves by a normal step of deviation σ, wrapped into [0, 1) (a small step, which
//! explores the neighbourhood of a path that carries light). Numbers are mutated lazily,
//! when read ([`MltSampler`], after pbrt-v4's `MLTSampler`). A proposal is accepted with
//! probability min(1, T(proposal) / T(current)).
//!
//! **Splats.** Both the proposal and the current state are splatted at every mutation,
//! with their expected weights a / T(proposal) and (1 − a) / T(current) (Veach 1997
//! §11.3.3's expected-value estimator): rejected proposals still add their light.
//!
//! **Normalisation.** The image is b · (pixels / N) · Σ C / T over the N splatted
//! mutations, b = Σ_depth ∫ T the integral of the target over primary sample space, which a
//! bootstrap of independent samples estimates; the chains start from bootstrap samples
//! drawn in proportion to their T (so they start in their stationary distribution, with no
//! start-up bias to burn in), each keeping its depth.
//!
//! **Bias.** Consistent, not unbiased: a pass's b is a ratio estimate from its bootstrap,
//! and its chains start from the bootstrap's samples resampled by T, which is the stationary
//! distribution only as the bootstrap grows. Both biases shrink as 1/bootstrap; the tests
//! bound them against BDPT.
//!
//! **Passes and error bars.** A chain's samples are correlated, so their spread says
//! nothing of the error. Each pass (sample index) is a Metropolis render of its own: its
//! own bootstrap (its own b) and its own chains, `mutations_per_pixel` mutations per pixel
//! in all. The film takes each pass's image as one sample, so the variance channels are the
//! spread across passes ([`VARIANCE_MEANING`]). Given the importance map, which earlier
//! passes made, a pass's numbers are independent of theirs and its image is the image in
//! expectation (to the bias below): the passes' errors are uncorrelated (a martingale's
//! differences), so their spread measures the mean's error, and the two replicates' errors
//! are uncorrelated too.
//!
//! **Depth.** Each chain keeps one path depth, so depths are bounded: `--max-depth`, by
//! default [`DEFAULT_MLT_MAX_DEPTH`] scattering events, at most [`MAX_MLT_DEPTH`] (a light
//! subpath's vertices are bounded by `super::bdpt::BDPT_MAX_VERTICES`). Light on longer
//! paths is left out, as from BDPT or the path tracer under the same `--max-depth`.
//!
//! **Determinism.** Bootstrap sample i of pass k draws its numbers from its own stream, and
//! chain c its choice of start and its acceptances from another; the chains' splats are
//! summed in chain order. An image depends on the seed alone, not on the thread count.

use glam::Vec3;
use rayon::prelude::*;

use super::bdpt::{strategy_sample, BdptContext, Stream, StreamNumbers, Subpaths, WalkNumbers};
use super::IntegratorSettings;
use crate::sampling::Rng;
use crate::scene::layout::{Camera, FilmPixel};
use crate::scene::luminance;
use crate::scene::FlatScene;

/// Path depth (scattering events) Metropolis renders up to unless `--max-depth` says
/// otherwise: 10, as far as the bundled Lambertian rooms carry measurable light (0.75¹⁰ ≈
/// 6% of the first bounce's).
pub const DEFAULT_MLT_MAX_DEPTH: u32 = 10;

/// The deepest path Metropolis can render: a strategy of depth d may have s = d + 1 light
/// vertices, and a light subpath holds at most `BDPT_MAX_VERTICES` (16).
pub const MAX_MLT_DEPTH: u32 = super::bdpt::BDPT_MAX_VERTICES as u32 - 1;

/// The most numbers one sample reads from one stream, which the GPU keeps room for per
/// chain (shaders/sampling.wgsl): at depth [`MAX_MLT_DEPTH`] the camera stream reads 3
/// (strategy, film point) + 16 alpha seeds (one per trace) + 15 scatterings × 3 (lobe,
/// direction) = 64, the light stream 7 (the origin) + 15 alpha seeds + 14 × 3 = 64, the
/// connection stream at most 3 (a light sample and its alpha seed). Neither subpath plays
/// roulette here. The CPU sampler grows as it is read and never needs the bound; its test
/// checks reads stay within it.
pub const MLT_NUMBERS_PER_STREAM: u32 = 64;

/// Chains' default length per pass: chains = mutations / this (at least 1), so that each
/// chain has room to explore what it found.
pub const DEFAULT_CHAIN_MUTATIONS: u32 = 1024;

/// The most chains a pass runs (each holds its primary sample, about 1.5 KiB).
pub const MAX_CHAINS: u32 = 1 << 16;

/// Mutations per pixel per pass unless `--mutations-per-pixel` says otherwise.
pub const DEFAULT_MUTATIONS_PER_PIXEL: u32 = 4;

/// Small steps' standard deviation in primary sample space (pbrt-v4's default).
pub const DEFAULT_SIGMA: f32 = 0.01;

/// Probability of a large step unless `--large-step` says otherwise: 0.1, where pbrt-v4's
/// default is 0.3. Measured at equal time (bench/RESULTS.md, "What the defaults were chosen
/// by"): 12% less error in both rooms lit through a gap, 3% and 8% on the two Cornell boxes.
pub const DEFAULT_LARGE_STEP_PROBABILITY: f32 = 0.1;

/// The row of [`Rng::new`] bootstrap samples draw from (their column is the sample's index).
pub const MLT_BOOTSTRAP_STREAM: u32 = u32::MAX - 3;
/// The row chains draw their start and their acceptances from (column: the chain's index).
pub const MLT_CHAIN_STREAM: u32 = u32::MAX - 4;

/// What the EXR's variance channels measure under `--integrator mlt`.
pub const VARIANCE_MEANING: &str = "the spread of each pixel's estimates across passes (each pass \
     its own bootstrap and its own Markov chains, given the importance map earlier passes made, so \
     that the passes' errors are uncorrelated; a chain's samples are correlated, so they are not \
     counted apart): noise only; a pass's small bias (its normalisation and its chains' starts \
     come from a finite bootstrap, a bias that shrinks as the bootstrap grows) is not in it, nor \
     paths deeper than --max-depth";

/// The chains' target ([`MltSettings::target`], `--mlt-target`; the module's "Importance").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MltTarget {
    /// T = luminance(C): mutations in proportion to brightness (Veach, pbrt-v4).
    Luminance,
    /// T = luminance(C) / √(Ī² + ε), Ī the image so far: mutations spread for relative error.
    #[default]
    Relative,
}

/// The importance map's blur: Ī at a pixel is the mean luminance of the image so far over
/// the (2r + 1)² pixels around it (clipped at the image's edges). 2: on the door ajar
/// (128², 20 s, one seed, against a 90-s BDPT reference) a radius of 1 gave 1.44× less
/// error than the plain target and 2 gave 1.54×; a wider map follows a pass's noise less.
pub const IMPORTANCE_BLUR_RADIUS: i32 = 2;

/// ε in the importance map's 1 / √(Ī² + ε): relMSE's own floor (`RELMSE_EPSILON`), below
/// which a pixel's relative error stops counting more as it darkens.
pub const IMPORTANCE_DARK_FLOOR: f32 = crate::film::convergence::RELMSE_EPSILON as f32;

/// Whether the importance map is made again before pass `k` (passes 1, 2, 4, 8, …): each
/// map from twice the passes of the last, a handful of read-backs over any render.
pub fn remakes_importance(k: u32) -> bool {
    k.is_power_of_two()
}

/// The importance map to use from pass `k` on under `target`, made from the film `film`
/// returns (read only when one is due: [`remakes_importance`]), or `None` where the map
/// stays as it is: the luminance target, a pass that makes none, or a film without a
/// sample yet. Both backends decide by this, each reading its own film.
pub fn importance_before_pass<E>(
    target: MltTarget,
    k: u32,
    (width, height): (u32, u32),
    film: impl FnOnce() -> Result<Vec<FilmPixel>, E>,
) -> Result<Option<Vec<f32>>, E> {
    if target != MltTarget::Relative || !remakes_importance(k) {
        return Ok(None);
    }
    let film = film()?;
    if film.iter().all(|p| p.count == 0) {
        return Ok(None);
    }
    let means: Vec<Vec3> = film.iter().map(|p| Vec3::from(p.mean)).collect();
    Ok(Some(importance_map(&means, width, height)))
}

/// The importance map of an image `means` (row-major, `width` × `height`): per pixel
/// 1 / √(Ī² + [`IMPORTANCE_DARK_FLOOR`]), Ī its luminance blurred over the
/// [`IMPORTANCE_BLUR_RADIUS`] box. Every weight is finite, positive and at most 1 / √ε; a
/// non-finite or negative pixel counts as black.
pub fn importance_map(means: &[Vec3], width: u32, height: u32) -> Vec<f32> {
    let (w, h) = (width as usize, height as usize);
    let r = IMPORTANCE_BLUR_RADIUS as usize;
    let lum: Vec<f32> = means
        .iter()
        .map(|&m| {
            let l = luminance(m);
            if l.is_finite() && l > 0.0 {
                l
            } else {
                0.0
            }
        })
        .collect();
    // The box sum, separably: rows, then columns, in f64 so that the order is harmless.
    let mut rows = vec![0.0f64; w * h];
    for y in 0..h {
        for x in 0..w {
            let (a, b) = (x.saturating_sub(r), (x + r).min(w - 1));
            rows[y * w + x] = lum[y * w + a..=y * w + b].iter().map(|&v| v as f64).sum();
        }
    }
    let mut map = vec![0.0f32; w * h];
    for y in 0..h {
        let (a, b) = (y.saturating_sub(r), (y + r).min(h - 1));
        for x in 0..w {
            let sum: f64 = (a..=b).map(|yy| rows[yy * w + x]).sum();
            let count = ((b - a + 1) * (x.min(r) + (w - 1 - x).min(r) + 1)) as f64;
            let mean = (sum / count) as f32;
            map[y * w + x] = 1.0 / (mean * mean + IMPORTANCE_DARK_FLOOR).sqrt();
        }
    }
    map
}

/// Metropolis's own settings (`--mutations-per-pixel`, `--bootstrap-samples`, `--chains`,
/// `--large-step`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MltSettings {
    /// Mutations per pixel in each pass.
    pub mutations_per_pixel: u32,
    /// Bootstrap samples per path depth in each pass; `None`: a quarter of the pass's
    /// mutations spread over the depths (at least 64 per depth).
    pub bootstrap_samples: Option<u32>,
    /// Chains per pass; `None`: one per [`DEFAULT_CHAIN_MUTATIONS`] mutations.
    pub chains: Option<u32>,
    /// Probability of a large step.
    pub large_step_probability: f32,
    /// The chains' target (`--mlt-target`).
    pub target: MltTarget,
}

impl Default for MltSettings {
    fn default() -> Self {
        MltSettings {
            mutations_per_pixel: DEFAULT_MUTATIONS_PER_PIXEL,
            bootstrap_samples: None,
            chains: None,
            large_step_probability: DEFAULT_LARGE_STEP_PROBABILITY,
            target: MltTarget::default(),
        }
    }
}

impl MltSettings {
    /// Checks every setting is usable, naming the one that is not.
    pub fn validate(&self) -> crate::Result<()> {
        let bad = |m: String| Err(crate::Error::Settings(m));
        if !(1..=1 << 16).contains(&self.mutations_per_pixel) {
            return bad(format!(
                "--mutations-per-pixel is mutations per pixel in each pass: 1 to 65536, not {}",
                self.mutations_per_pixel
            ));
        }
        if let Some(n) = self.bootstrap_samples {
            if !(1..=1 << 24).contains(&n) {
                return bad(format!(
                    "--bootstrap-samples is samples per path depth in each pass: 1 to 16777216, not {n}"
                ));
            }
        }
        if let Some(n) = self.chains {
            if !(1..=MAX_CHAINS).contains(&n) {
                return bad(format!("--chains must be between 1 and {MAX_CHAINS}, not {n}"));
            }
        }
        let p = self.large_step_probability;
        if !(p.is_finite() && p > 0.0 && p <= 1.0) {
            return bad(format!(
                "--large-step is the probability of a large step: a number in (0, 1], not {p} (0 would \
                 leave the chains unable to reach every path)"
            ));
        }
        Ok(())
    }

    /// The pass's bootstrap samples per depth for `mutations` mutations over `depths` depths.
    fn bootstrap_per_depth(&self, mutations: u64, depths: u32) -> u64 {
        self.bootstrap_samples.map_or((mutations / (4 * depths as u64)).max(64), u64::from)
    }

    /// The pass's chains for `mutations` mutations.
    fn chain_count(&self, mutations: u64) -> u64 {
        self.chains
            .map_or((mutations / DEFAULT_CHAIN_MUTATIONS as u64).clamp(1, MAX_CHAINS as u64), u64::from)
    }
}

/// What Metropolis passes counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MltStats {
    pub passes: u64,
    /// Mutations proposed and accepted (the acceptance rate is their ratio).
    pub proposed: u64,
    pub accepted: u64,
    /// Passes whose bootstrap found no path that carries light: their image is black.
    pub passes_without_light: u64,
    /// Rays traced, bootstrap included.
    pub rays: u64,
    /// Samples the GPU dropped because they read more than [`MLT_NUMBERS_PER_STREAM`]
    /// numbers from a stream (by its count, none can; the CPU never drops any).
    pub dropped_samples: u64,
}

impl MltStats {
    /// The fraction of proposals accepted.
    pub fn acceptance_rate(&self) -> f64 {
        self.accepted as f64 / self.proposed.max(1) as f64
    }
}

impl std::ops::AddAssign for MltStats {
    fn add_assign(&mut self, o: MltStats) {
        self.passes += o.passes;
        self.proposed += o.proposed;
        self.accepted += o.accepted;
        self.passes_without_light += o.passes_without_light;
        self.rays += o.rays;
        self.dropped_samples += o.dropped_samples;
    }
}

/// One number of a primary sample, with what a rejected mutation restores.
#[derive(Clone, Copy, Default)]
struct PrimarySample {
    value: f32,
    /// The iteration that last set `value`.
    last_modified: u64,
    /// Has any state read it? A number no state has read is drawn uniformly when first read:
    /// the target's marginal in a coordinate the contribution ignores is uniform. (pbrt-v4
    /// instead starts it at 0 and takes a small step from there until the chain's first
    /// accepted large step, a small bias towards 0.)
    set: bool,
    backup_value: f32,
    backup_modified: u64,
    backup_set: bool,
}

/// A Markov chain's primary sample, mutated lazily (pbrt-v4 `MLTSampler`): number j of
/// stream s is entry 3j + s, brought up to the current iteration when it is read.
pub(crate) struct MltSampler {
    rng: Rng,
    large_step_probability: f32,
    samples: Vec<PrimarySample>,
    iteration: u64,
    large_step: bool,
    last_large_step: u64,
    stream: usize,
    index: usize,
}

impl MltSampler {
    /// A sampler whose first state is an independent sample drawn from `rng`.
    pub(crate) fn new(rng: Rng, large_step_probability: f32) -> MltSampler {
        MltSampler {
            rng,
            large_step_probability,
            samples: Vec::with_capacity(64),
            iteration: 0,
            large_step: true,
            last_large_step: 0,
            stream: 0,
            index: 0,
        }
    }

    /// Begins a proposal: a large step or a small one.
    pub(crate) fn start_iteration(&mut self) {
        self.iteration += 1;
        self.large_step = self.rng.next_1d() < self.large_step_probability;
    }

    /// The proposal becomes the state.
    pub(crate) fn accept(&mut self) {
        if self.large_step {
            self.last_large_step = self.iteration;
        }
    }

    /// The proposal is forgotten: every number it changed gets its value back.
    pub(crate) fn reject(&mut self) {
        for x in &mut self.samples {
            if x.last_modified == self.iteration {
                x.value = x.backup_value;
                x.last_modified = x.backup_modified;
                x.set = x.backup_set;
            }
        }
        self.iteration -= 1;
    }

    fn next(&mut self) -> f32 {
        let i = self.index * 3 + self.stream;
        self.index += 1;
        if i >= self.samples.len() {
            self.samples.resize(i + 1, PrimarySample::default());
        }
        let x = &mut self.samples[i];
        // Untouched since before the last accepted large step: that step replaced it.
        if x.set && x.last_modified < self.last_large_step {
            x.value = self.rng.next_1d();
            x.last_modified = self.last_large_step;
        }
        x.backup_value = x.value;
        x.backup_modified = x.last_modified;
        x.backup_set = x.set;
        if self.large_step || !x.set {
            x.value = self.rng.next_1d();
            x.set = true;
        } else {
            // The small steps it missed add up to one of deviation σ·√n.
            let missed = (self.iteration - x.last_modified) as f32;
            let (u1, u2) = (1.0 - self.rng.next_1d(), self.rng.next_1d());
            let normal = (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos();
            let moved = x.value + normal * DEFAULT_SIGMA * missed.sqrt();
            let wrapped = moved - moved.floor();
            // A tiny negative step can round up to exactly 1.
            x.value = if wrapped < 1.0 { wrapped } else { 0.0 };
        }
        x.last_modified = self.iteration;
        x.value
    }
}

impl WalkNumbers for MltSampler {
    fn u32(&mut self) -> u32 {
        (self.next() * 4_294_967_296.0) as u32
    }
    fn lobe(&mut self, _used: bool) -> f32 {
        self.next()
    }
    fn direction(&mut self) -> glam::Vec2 {
        glam::Vec2::new(self.next(), self.next())
    }
    fn roulette(&mut self) -> f32 {
        self.next()
    }
    fn uniform_1d(&mut self) -> f32 {
        self.next()
    }
    fn uniform_2d(&mut self) -> glam::Vec2 {
        glam::Vec2::new(self.next(), self.next())
    }
}

impl StreamNumbers for MltSampler {
    fn start_stream(&mut self, stream: Stream) {
        self.stream = stream as usize;
        self.index = 0;
    }
}

/// One pass's context.
pub struct MltContext<'a> {
    pub scene: &'a FlatScene,
    pub camera: &'a Camera,
    /// The integrator settings: `max_depth` is the depth bound, `camera_connections` whether
    /// t = 1 strategies are taken.
    pub integrator: &'a IntegratorSettings,
    pub settings: MltSettings,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    /// The importance map ([`importance_map`]; the module's "Importance"), or `None`: 1
    /// everywhere.
    pub importance: Option<&'a [f32]>,
}

/// A state of a chain: its pixel, contribution C and target T.
#[derive(Clone, Copy)]
struct State {
    pixel: usize,
    value: Vec3,
    target: f32,
}

impl State {
    /// The state of `sample`, its target weighed by `importance` at its pixel.
    fn of(sample: Option<(usize, Vec3)>, importance: Option<&[f32]>) -> State {
        match sample {
            Some((pixel, value)) => {
                let weight = importance.map_or(1.0, |map| map[pixel]);
                State { pixel, value, target: luminance(value).max(0.0) * weight }
            }
            None => State { pixel: 0, value: Vec3::ZERO, target: 0.0 },
        }
    }
}

/// Splats a pass holds at once, over all its chains (`mlt_pass`'s rounds): 32 MiB.
const ROUND_SPLATS: u64 = 1 << 21;

/// A Markov chain between rounds.
struct Chain {
    sampler: MltSampler,
    /// Its start and its acceptances.
    rng: Rng,
    current: State,
    depth: u32,
    /// Mutations still to make in this pass.
    remaining: u64,
}

impl Chain {
    /// `n` mutations: their expected-value splats (pixel, C · weight / T), and what they
    /// counted.
    fn run(
        &mut self,
        bdpt: &BdptContext,
        resolution: (u32, u32),
        n: u64,
        importance: Option<&[f32]>,
    ) -> (Vec<(u32, Vec3)>, MltStats) {
        let mut stats = MltStats::default();
        let mut paths = Subpaths::new();
        let mut splats = Vec::with_capacity(2 * n as usize);
        for _ in 0..n {
            self.sampler.start_iteration();
            let sample =
                strategy_sample(bdpt, &mut self.sampler, self.depth, resolution, &mut paths, &mut stats.rays);
            let (proposal, current) = (State::of(sample, importance), self.current);
            let accept = if current.target > 0.0 { (proposal.target / current.target).min(1.0) } else { 1.0 };
            if proposal.target > 0.0 && accept > 0.0 {
                splats.push((proposal.pixel as u32, proposal.value * (accept / proposal.target)));
            }
            if current.target > 0.0 && accept < 1.0 {
                splats.push((current.pixel as u32, current.value * ((1.0 - accept) / current.target)));
            }
            stats.proposed += 1;
            if self.rng.next_1d() < accept {
                self.current = proposal;
                self.sampler.accept();
                stats.accepted += 1;
            } else {
                self.sampler.reject();
            }
        }
        self.remaining -= n;
        (splats, stats)
    }
}

/// A pass's sizes, the same on both backends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PassPlan {
    pub pixels: u64,
    /// Path depths the chains are spread over (0 to the depth bound).
    pub depths: u32,
    /// Mutations in the pass, over all its chains.
    pub mutations: u64,
    /// Bootstrap samples per depth, and in all (sample i has depth i mod `depths`).
    pub per_depth: u64,
    pub bootstrap: u64,
    pub chains: u64,
}

impl PassPlan {
    /// The sizes of a pass of `ctx`.
    pub fn of(settings: &MltSettings, max_depth: u32, width: u32, height: u32) -> PassPlan {
        let pixels = width as u64 * height as u64;
        let depths = max_depth.min(MAX_MLT_DEPTH) + 1;
        let mutations = settings.mutations_per_pixel as u64 * pixels;
        let per_depth = settings.bootstrap_per_depth(mutations, depths);
        PassPlan {
            pixels,
            depths,
            mutations,
            per_depth,
            bootstrap: per_depth * depths as u64,
            chains: settings.chain_count(mutations),
        }
    }

    /// Bootstrap sample `i`'s path depth.
    pub fn depth_of(&self, i: u64) -> u32 {
        (i % self.depths as u64) as u32
    }

    /// The factor from a pass's summed splats (each C · weight / T) to its image:
    /// b · pixels / mutations.
    pub fn image_scale(&self, b: f64) -> f64 {
        b * self.pixels as f64 / self.mutations as f64
    }
}

/// Where a chain starts: the bootstrap sample it resumes, that sample's depth, and the
/// mutations it makes in the pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChainStart {
    pub sample: u64,
    pub depth: u32,
    pub mutations: u64,
}

/// The pass's normalisation b = Σ_depth ∫ T and its chains' starts, drawn in proportion to
/// the bootstrap's targets `weights` (chain c draws from its own stream); `None` where the
/// bootstrap found no light. Both backends call this on their bootstrap's weights, so
/// their chains start alike.
pub fn chain_starts(
    plan: &PassPlan,
    weights: &[f32],
    pass: u32,
    seed: u32,
) -> Option<(f64, Vec<ChainStart>)> {
    let mut cdf = Vec::with_capacity(weights.len());
    let mut total = 0.0f64;
    for w in weights {
        total += *w as f64;
        cdf.push(total);
    }
    if total <= 0.0 {
        return None;
    }
    // b = Σ_depth ∫ T: each depth's mean T, summed.
    let b = total / plan.per_depth as f64;
    let chains = plan.chains;
    let starts = (0..chains)
        .map(|c| {
            let mut rng = Rng::new(c as u32, MLT_CHAIN_STREAM, pass, seed);
            let u = rng.next_1d() as f64 * total;
            let sample = (cdf.partition_point(|&x| x <= u) as u64).min(plan.bootstrap - 1);
            let mutations = plan.mutations / chains + u64::from(c < plan.mutations % chains);
            ChainStart { sample, depth: plan.depth_of(sample), mutations }
        })
        .collect();
    Some((b, starts))
}

/// Bootstrap sample `i`'s sampler: an independent sample drawn from its own stream.
pub(crate) fn bootstrap_sampler(i: u64, pass: u32, seed: u32, large_step_probability: f32) -> MltSampler {
    MltSampler::new(Rng::new(i as u32, MLT_BOOTSTRAP_STREAM, pass, seed), large_step_probability)
}

/// Pass `pass`: an independent Metropolis estimate of the whole image (row-major, the
/// film's layout), and what it counted.
pub fn mlt_pass(ctx: &MltContext, pass: u32) -> (Vec<Vec3>, MltStats) {
    let resolution = (ctx.width, ctx.height);
    let plan = PassPlan::of(&ctx.settings, ctx.integrator.max_depth, ctx.width, ctx.height);
    let pixels = plan.pixels as usize;
    let bdpt = BdptContext::new(ctx.scene, ctx.camera, ctx.integrator, ctx.width, ctx.height);
    let p_large = ctx.settings.large_step_probability;
    let sampler_for = |i: u64| bootstrap_sampler(i, pass, ctx.seed, p_large);
    let mut stats = MltStats { passes: 1, ..MltStats::default() };

    // The bootstrap: T of independent samples, every depth alike.
    const BOOTSTRAP_CHUNK: u64 = 256;
    let chunks: Vec<(Vec<f32>, u64)> = (0..plan.bootstrap.div_ceil(BOOTSTRAP_CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut paths = Subpaths::new();
            let mut rays = 0;
            let range = c * BOOTSTRAP_CHUNK..((c + 1) * BOOTSTRAP_CHUNK).min(plan.bootstrap);
            let weights = range
                .map(|i| {
                    let mut sampler = sampler_for(i);
                    let sample = strategy_sample(
                        &bdpt,
                        &mut sampler,
                        plan.depth_of(i),
                        resolution,
                        &mut paths,
                        &mut rays,
                    );
                    State::of(sample, ctx.importance).target
                })
                .collect();
            (weights, rays)
        })
        .collect();
    stats.rays += chunks.iter().map(|(_, rays)| rays).sum::<u64>();
    let weights: Vec<f32> = chunks.into_iter().flat_map(|(w, _)| w).collect();
    let Some((b, starts)) = chain_starts(&plan, &weights, pass, ctx.seed) else {
        stats.passes_without_light = 1;
        return (vec![Vec3::ZERO; pixels], stats);
    };

    let (mut states, start_rays): (Vec<Chain>, Vec<u64>) = starts
        .into_par_iter()
        .enumerate()
        .map(|(c, start)| {
            let mut rng = Rng::new(c as u32, MLT_CHAIN_STREAM, pass, ctx.seed);
            // The draw `chain_starts` made of the start.
            rng.next_1d();
            let mut sampler = sampler_for(start.sample);
            let mut rays = 0;
            let sample = strategy_sample(
                &bdpt,
                &mut sampler,
                start.depth,
                resolution,
                &mut Subpaths::new(),
                &mut rays,
            );
            let current = State::of(sample, ctx.importance);
            (Chain { sampler, rng, current, depth: start.depth, remaining: start.mutations }, rays)
        })
        .unzip();
    stats.rays += start_rays.iter().sum::<u64>();
    // The chains run in rounds of at most `per_round` mutations each, their splats summed
    // in chain order after each round: memory stays bounded (about 2 splats of 16 bytes per
    // mutation of a round) and the sum's order depends on the settings alone.
    let per_round = (ROUND_SPLATS / (2 * plan.chains)).max(1);
    let mut image = vec![[0.0f64; 3]; pixels];
    while states.iter().any(|c| c.remaining > 0) {
        let results: Vec<(Vec<(u32, Vec3)>, MltStats)> = states
            .par_iter_mut()
            .map(|chain| chain.run(&bdpt, resolution, per_round.min(chain.remaining), ctx.importance))
            .collect();
        for (splats, chain_stats) in results {
            stats += chain_stats;
            for (pixel, value) in splats {
                let sum = &mut image[pixel as usize];
                for (s, v) in sum.iter_mut().zip(value.to_array()) {
                    *s += v as f64;
                }
            }
        }
    }
    let scale = plan.image_scale(b);
    let image = image.iter().map(|s| Vec3::from(s.map(|v| (v * scale) as f32))).collect();
    (image, stats)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every number a sampler gives is in [0, 1), and a rejected mutation gives back
    /// exactly the numbers of the state before it.
    #[test]
    fn rejected_mutations_restore_the_state() {
        let mut sampler = MltSampler::new(Rng::new(1, 2, 3, 4), 0.3);
        let read = |s: &mut MltSampler| -> Vec<f32> {
            let mut v = Vec::new();
            for stream in [Stream::Camera, Stream::Light, Stream::Connection] {
                s.start_stream(stream);
                v.extend((0..7).map(|_| s.uniform_1d()));
            }
            v
        };
        let mut state = read(&mut sampler);
        for k in 0..2000 {
            sampler.start_iteration();
            let proposal = read(&mut sampler);
            assert!(proposal.iter().all(|x| (0.0..1.0).contains(x)), "{proposal:?}");
            if k % 3 == 0 {
                sampler.accept();
                state = proposal;
            } else {
                sampler.reject();
                // Reading again as a proposal must start from `state`: check by a
                // zero-probability detour, reading the state back through a rejection.
                let before = sampler.samples.iter().map(|x| x.value).collect::<Vec<_>>();
                assert_eq!(before.len(), 21);
                let values: Vec<f32> = [0usize, 1, 2]
                    .iter()
                    .flat_map(|&s| (0..7).map(move |j| (s, j)))
                    .map(|(s, j)| before[3 * j + s])
                    .collect();
                assert_eq!(values, state);
            }
        }
    }

    /// No sample reads more than [`MLT_NUMBERS_PER_STREAM`] numbers from one stream (the
    /// room the GPU keeps per chain): 20,000 samples of the deepest paths Metropolis renders,
    /// every strategy, in the closed lamp room, which keeps most paths going to the end.
    /// Its walls are opaque Lambertian and untextured, so each scattering reads 3 numbers
    /// and each trace none: the camera stream's longest is 3 + 15 × 3 = 48, the light
    /// stream's 7 + 14 × 3 = 49, which the test must reach to mean anything; alpha seeds add
    /// one per trace up to the bound of 64.
    #[test]
    fn samples_read_within_the_gpu_bound() {
        let flat = crate::scene::bundled_flat_scene("lamp-shade-room.gltf");
        let settings = IntegratorSettings { max_depth: MAX_MLT_DEPTH, ..IntegratorSettings::default() };
        let bdpt = BdptContext::new(&flat, &flat.camera, &settings, 16, 16);
        let mut longest = [0usize; 3];
        for i in 0..20_000 {
            let mut sampler = bootstrap_sampler(i, 0, 1, 0.3);
            strategy_sample(&bdpt, &mut sampler, MAX_MLT_DEPTH, (16, 16), &mut Subpaths::new(), &mut 0);
            for (stream, most) in longest.iter_mut().enumerate() {
                let read = (0..sampler.samples.len())
                    .filter(|j| j % 3 == stream)
                    .filter(|j| sampler.samples[*j].set)
                    .count();
                *most = (*most).max(read);
            }
        }
        assert!(longest.iter().all(|&n| n <= MLT_NUMBERS_PER_STREAM as usize), "{longest:?}");
        assert_eq!(longest[..2], [48, 49], "the deepest paths were not all reached");
    }

    /// Small steps move each number by a normal of deviation σ (wrapped): their spread
    /// matches σ within the sampling error of 20,000 steps (3% at 4σ).
    #[test]
    fn small_steps_have_deviation_sigma() {
        let mut sampler = MltSampler::new(Rng::new(5, 6, 7, 8), 1e-9);
        sampler.start_stream(Stream::Camera);
        let mut x = sampler.uniform_1d();
        let (mut sum2, mut n) = (0.0f64, 0);
        for _ in 0..20_000 {
            sampler.start_iteration();
            sampler.start_stream(Stream::Camera);
            let y = sampler.uniform_1d();
            let mut d = y - x;
            d -= d.round(); // the wrap
            sum2 += (d as f64).powi(2);
            n += 1;
            sampler.accept();
            x = y;
        }
        let sigma = (sum2 / n as f64).sqrt();
        assert!((sigma / DEFAULT_SIGMA as f64 - 1.0).abs() < 0.03, "σ = {sigma}");
    }

    /// A number not read for n small steps moves by one step of deviation σ√n when it is
    /// read (the lazy mutation's missed steps), and a large step that was accepted replaces
    /// every number read after it.
    #[test]
    fn lazy_numbers_catch_up() {
        let mut spread = 0.0f64;
        let trials = 4000;
        for k in 0..trials {
            let mut sampler = MltSampler::new(Rng::new(k, 9, 9, 9), 1e-9);
            sampler.start_stream(Stream::Light);
            let x = sampler.uniform_1d();
            for _ in 0..16 {
                sampler.start_iteration();
                sampler.accept();
            }
            sampler.start_iteration();
            sampler.start_stream(Stream::Light);
            let mut d = sampler.uniform_1d() - x;
            d -= d.round();
            spread += (d as f64).powi(2);
        }
        let sigma = (spread / trials as f64).sqrt();
        // 4σ of the estimate of a deviation from 4000 normals: 4/√(2·4000) ≈ 4.5%.
        assert!((sigma / (4.0 * DEFAULT_SIGMA as f64) - 1.0).abs() < 0.045, "σ√16 = {sigma}");

        // Numbers first read after an accepted large step that did not read them are
        // uniform afresh: most move far, where small steps alone would move none of them
        // past 0.1 (25σ). A fresh uniform lands within 0.1 of the old value 20% of the time.
        let far = (0..400)
            .filter(|&k| {
                let mut sampler = MltSampler::new(Rng::new(k, 1, 1, 1), 1.0);
                sampler.start_stream(Stream::Camera);
                let x = sampler.uniform_1d();
                sampler.start_iteration();
                sampler.accept(); // a large step, accepted without reading the number
                sampler.large_step_probability = 0.0;
                sampler.start_iteration();
                sampler.start_stream(Stream::Camera);
                let mut d = sampler.uniform_1d() - x;
                d -= d.round();
                d.abs() > 0.1
            })
            .count();
        // 4σ below the binomial mean of 320 (σ = 8).
        assert!(far > 288, "{far} of 400 moved far");
    }

    /// The map weighs a pixel by 1 / √(Ī² + ε), Ī its neighbourhood's mean luminance: an
    /// even image gives an even map; a bright pixel lowers exactly the weights of the pixels
    /// whose box holds it, by its share of each box (which the image's edges clip); a black
    /// or non-finite image gives the largest weight, 1 / √ε, everywhere.
    #[test]
    fn the_importance_map_divides_by_the_blurred_brightness() {
        let (w, h) = (9u32, 7u32);
        let weight = |l: f32| 1.0 / (l * l + IMPORTANCE_DARK_FLOOR).sqrt();
        let even = importance_map(&vec![Vec3::splat(0.5); 63], w, h);
        assert!(even.iter().all(|&x| (x - weight(0.5)).abs() < 1e-6 * weight(0.5)), "{even:?}");

        let mut spot = vec![Vec3::ZERO; 63];
        spot[3 * 9 + 1] = Vec3::splat(20.0); // (1, 3): two pixels from the left edge
        let map = importance_map(&spot, w, h);
        let r = IMPORTANCE_BLUR_RADIUS;
        for y in 0..h as i32 {
            for x in 0..w as i32 {
                let inside = (x - 1).abs() <= r && (y - 3).abs() <= r;
                let expected = if inside {
                    // The box clipped to the image: columns max(x − r, 0) … min(x + r, 8).
                    let columns = (x.min(r) + (w as i32 - 1 - x).min(r) + 1) as f32;
                    let rows = (y.min(r) + (h as i32 - 1 - y).min(r) + 1) as f32;
                    weight(20.0 / (columns * rows))
                } else {
                    weight(0.0)
                };
                let got = map[(y * w as i32 + x) as usize];
                assert!((got - expected).abs() < 1e-5 * expected, "({x}, {y}): {got} against {expected}");
            }
        }

        let bad =
            importance_map(&[Vec3::splat(f32::NAN), Vec3::splat(-1.0), Vec3::splat(f32::INFINITY)], 3, 1);
        let most = 1.0 / IMPORTANCE_DARK_FLOOR.sqrt();
        assert!(bad.iter().all(|&x| (x - most).abs() < 1e-6 * most), "{bad:?}");
    }

    /// The map is remade before passes 1, 2, 4, 8, …, never before the first; the film is
    /// read only then, under the relative target, and a film without a sample makes none.
    #[test]
    fn the_importance_map_is_remade_at_powers_of_two() {
        let remade: Vec<u32> = (0..40).filter(|&k| remakes_importance(k)).collect();
        assert_eq!(remade, [1, 2, 4, 8, 16, 32]);

        let lit = FilmPixel { mean: [0.5; 3], count: 2, ..FilmPixel::default() };
        let made = |target, k, film: Vec<FilmPixel>| {
            let mut read = false;
            let map = importance_before_pass(target, k, (2, 1), || {
                read = true;
                Ok::<_, ()>(film)
            })
            .unwrap();
            (map, read)
        };
        assert_eq!(made(MltTarget::Relative, 3, vec![lit; 2]), (None, false));
        assert_eq!(made(MltTarget::Luminance, 4, vec![lit; 2]), (None, false));
        assert_eq!(made(MltTarget::Relative, 4, vec![FilmPixel::default(); 2]), (None, true));
        let (map, read) = made(MltTarget::Relative, 4, vec![lit; 2]);
        assert!(read);
        assert_eq!(map, Some(importance_map(&[Vec3::splat(0.5); 2], 2, 1)));
    }
}
