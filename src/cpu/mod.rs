//! The CPU reference renderer: the oracle the GPU kernel is checked against. It renders from
//! the same [`FlatScene`](crate::scene::FlatScene) arrays with the same integrators
//! ([`crate::integrator`]), in plain Rust over rayon.

mod renderer;

pub use renderer::CpuBackend;
