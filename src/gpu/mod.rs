//! The GPU megakernel backend: WGSL compute shaders (`shaders/`) run through wgpu on Vulkan,
//! specialised to each scene's features, rendering from the same flat arrays as the CPU
//! reference.

pub mod context;
pub mod denoise;
mod renderer;
pub mod shader;
pub mod tables;

pub use context::{describe_adapter, enumerate_adapters, hardware_adapter, GpuContext, Kernel, KernelKey};
pub use renderer::GpuBackend;
pub use tables::UniformTables;
