//! Rays, frames and the numerically robust intersection and spawning routines.
//!
//! WGSL twin: `shaders/geometry.wgsl` (same function names).

mod bounds;
mod float;
mod frame;
mod ray;
mod triangle;

pub use bounds::{box_entry, entry_within, Aabb, RayBoxPrecomp};
pub use float::{difference_of_products, gamma, next_float_down, next_float_up};
pub use frame::Frame;
pub use ray::{offset_ray_origin, spawn_ray, spawn_ray_to, Ray, SHADOW_EPSILON};
pub use triangle::{
    intersect_triangle, intersect_triangle_precomp, triangle_error_bound, RayTrianglePrecomp, TriangleHit,
};
