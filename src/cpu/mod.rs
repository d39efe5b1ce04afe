//! The CPU reference renderer: the oracle the GPU kernel is checked against. It renders from
//! the same [`FlatScene`](crate::scene::FlatScene) arrays with the same algorithm, in plain
//! Rust over rayon.

mod integrator;
mod light_tracing;
mod renderer;

pub use integrator::{
    first_hit, radiance, surface_interaction, IntegratorSettings, SurfaceInteraction, DEFAULT_RR_MIN_DEPTH,
    MAX_BOUNCES_GUARD, RR_ANY_BOUNCE_DEPTH, RR_MAX_SURVIVAL,
};
pub use light_tracing::{
    camera_supports_light_tracing, caustic_from_fixed, caustic_to_fixed, scene_supports_light_tracing,
    supports_light_tracing, CAUSTIC_FRACTION_BITS, CAUSTIC_MAX_FIXED, LIGHT_PATH_STREAM,
    LIGHT_RR_MIN_VERTICES,
};
pub use renderer::CpuBackend;
