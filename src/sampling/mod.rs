//! Random numbers, warps from the unit square, and discrete distributions.
//!
//! WGSL twin: `shaders/sampling.wgsl` (same function names).

mod alias;
mod rng;
mod warp;

pub use alias::{build_alias_table, AliasEntry};
pub use rng::{pcg4d, Rng};
pub use warp::*;
