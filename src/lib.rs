//! pathlight: a physically based Monte Carlo path tracer.
//!
//! The production renderer is a WGSL compute megakernel run through wgpu on Vulkan
//! ([`gpu`]); the CPU reference renderer ([`cpu`]) implements the same algorithm from the
//! same flat arrays and proves it right.
//!
//! ```text
//! glTF ──scene::load──▶ Scene (f64) ──FlatScene::build──▶ camera-relative f32 arrays + BVH
//!                                                       ├─▶ cpu::CpuBackend ─┐
//!                                                       └─▶ gpu::GpuBackend ─┴─▶ Film ─▶ EXR/PNG
//! ```

pub mod bench;
pub mod bsdf;
pub mod bvh;
pub mod cpu;
pub mod denoise;
pub mod error;
pub mod film;
pub mod geometry;
pub mod gpu;
pub mod integrator;
pub mod light;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod session;
pub mod stats;
pub mod tev;
pub mod viewer;

pub use error::{Error, Result};
pub use render::{
    render_progressive, render_progressive_from, render_progressive_with, Backend, RenderSettings,
    RenderStats,
};
