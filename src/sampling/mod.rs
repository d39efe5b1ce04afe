//! Random numbers (the path sampler and a plain generator), warps from the unit square, and discrete distributions.
//!
//! WGSL twin: `shaders/sampling.wgsl` (same function names).

pub mod adaptive;
mod alias;
mod rng;
mod sobol;
mod warp;

pub use alias::{build_alias_table, AliasEntry};
pub use rng::{pcg4d, Rng};
pub use sobol::{hash_u32, replicate_of, PathSampler, SamplerKind};
#[cfg(test)]
pub(crate) use sobol::{DIMENSION_STEP, SPLIT_STREAM_SALT};
pub use warp::*;
