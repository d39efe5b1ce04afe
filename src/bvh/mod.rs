//! Bounding volume hierarchy over triangles: built by binned SAH straight into the 32-byte
//! [`BvhNode`](crate::scene::layout::BvhNode) array that the GPU traverses, and collapsed
//! from it into the CPU's 8-wide [`WideBvh`].
//!
//! WGSL twin of `traverse.rs`: `shaders/bvh.wgsl`.

mod build;
mod lanes;
mod sah;
pub mod trail;
mod traverse;
mod wide;

pub use build::{build, Bvh, BvhStats, MAX_DEPTH};
pub use traverse::{
    intersect_any, intersect_any_filtered, intersect_closest, intersect_closest_filtered,
    traverse_with_short_stack, ClosestHit, Traversal, SHORT_STACK_SIZE,
};
pub use wide::{WideBvh, WideNode};
