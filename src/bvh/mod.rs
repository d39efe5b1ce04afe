//! Bounding volume hierarchy over triangles: built by binned SAH in a pointer tree,
//! flattened into the 32-byte [`BvhNode`](crate::scene::layout::BvhNode) array that both
//! backends traverse.
//!
//! WGSL twin of `traverse.rs`: `shaders/bvh.wgsl`.

mod build;
mod traverse;

pub use build::{build, Bvh, BvhStats, MAX_DEPTH};
pub use traverse::{
    intersect_any, intersect_any_filtered, intersect_closest, intersect_closest_filtered, ClosestHit,
    TRAVERSAL_STACK_SIZE,
};
