//! The GPU megakernel backend (wgpu on Vulkan).

pub mod layout;
