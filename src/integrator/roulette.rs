//! Russian roulette and the bounce limits every integrator's paths obey.
//!
//! Roulette ends a path with probability 1 − q and divides a survivor by q, which keeps the
//! estimator unbiased for any q fixed before the coin is drawn (Arvo & Kirk 1990, "Particle
//! Transport and Image Synthesis"; pbrt-v4 §2.2.4). q is the throughput's largest component
//! with the refraction factors 1/η² taken out (inside glass the throughput is scaled by
//! 1/η², which leaving undoes, so a path there is as valuable as outside), capped at
//! [`RR_MAX_SURVIVAL`]. Roulette starts only after a path's first `rr_min_depth` non-delta
//! bounces: a mirror or glass bounce only redirects a path, and counting it would thin out
//! caustic paths (floor → glass → glass → light) at their last step, where each survivor
//! carries 1/q of a rare, bright contribution. What each choice gained is in
//! `bench/history/roulette.md`.
//!
//! WGSL twin: `shaders/roulette.wgsl` (the constants the kernel shares).

/// A hard stop against runaway paths (e.g. a non-finite throughput that defeats Russian
/// roulette). Roulette survival is at most 0.95 per bounce, so a path reaching this many
/// bounces carries at most 0.95^(1024 − rr_min_depth) ≈ 1e-23 of its weight: unreachable in
/// practice, and the truncation it introduces is far below any test's resolution.
pub const MAX_BOUNCES_GUARD: u32 = 1024;

/// Roulette survival probability is the path throughput's largest component, at most this.
pub const RR_MAX_SURVIVAL: f32 = 0.95;

/// Roulette applies from this many bounces of any kind on, however few of them scattered
/// (`IntegratorSettings::rr_min_depth` counts only those that did): a path between parallel
/// mirrors would otherwise never meet it. Long enough for the delta chains of glass objects,
/// short enough that a box of mirrors does not trace needlessly long paths (the depths
/// measured: `bench/history/roulette.md`, "Russian roulette counts only non-delta
/// bounces").
pub const RR_ANY_BOUNCE_DEPTH: u32 = 8;

/// Roulette's default start: after a path's fifth non-delta bounce (Mitsuba 3's default
/// too), chosen by efficiency 1 / (relMSE × seconds) on the Cornell boxes with
/// `examples/rr_depth.rs` (`bench/history/roulette.md`, "Where roulette starts").
pub const DEFAULT_RR_MIN_DEPTH: u32 = 5;

/// The probability that a path of throughput `beta` (with `eta_scale`, the product of η²
/// over its refractions) survives roulette.
#[inline(always)]
pub fn survival_probability(beta: glam::Vec3, eta_scale: f32) -> f32 {
    (beta * eta_scale).max_element().min(RR_MAX_SURVIVAL)
}
