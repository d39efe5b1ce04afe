//! The built-in denoiser's iterations on the GPU (`shaders/denoise.wgsl`; CPU twin:
//! `crate::denoise::atrous`, whose `prepare` and `finish`, and the edge regression
//! `crate::denoise::edges`, run on the host for both).

use std::time::Duration;

use glam::{Vec3, Vec4};
use wgpu::util::DeviceExt;

use super::GpuContext;
use crate::denoise::atrous::{finish, prepare, ITERATIONS};
use crate::denoise::DenoiseInput;
use crate::error::{Error, Result};

/// The longest one iteration may take (each is 25 taps a pixel: milliseconds on hardware,
/// about a second for 4 Mpixels on lavapipe).
const ITERATION_TIMEOUT: Duration = Duration::from_secs(120);

/// `shaders/denoise.wgsl`'s `DenoiseParams`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct DenoiseParams {
    width: u32,
    height: u32,
    step: i32,
    pad: u32,
}

/// [`crate::denoise::atrous::denoise`] with its iterations run on `ctx`'s device.
pub fn denoise_atrous(ctx: &GpuContext, input: &DenoiseInput) -> Result<Vec<Vec3>> {
    let prepared = prepare(input);
    let device = &ctx.device;
    let scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("denoise"),
        source: wgpu::ShaderSource::Wgsl(include_str!("../../shaders/denoise.wgsl").into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("atrous_iteration"),
        layout: None,
        module: &module,
        entry_point: Some("atrous_iteration"),
        compilation_options: Default::default(),
        cache: None,
    });
    let storage = |label: &str, contents: &[u8], usage: wgpu::BufferUsages| {
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage })
    };
    let read = wgpu::BufferUsages::STORAGE;
    let rw = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST;
    let guide = storage("denoise guide", bytemuck::cast_slice(&prepared.guide), read);
    let aux = storage("denoise aux guides", bytemuck::cast_slice(&prepared.aux), read);
    // Ping-pong between two signal buffers; a parameter buffer per iteration, so that all
    // of them are queued in one submit.
    let signals = [
        storage("denoise signal 0", bytemuck::cast_slice(&prepared.signal), rw),
        storage("denoise signal 1", bytemuck::cast_slice(&prepared.signal), rw),
    ];
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(Error::Gpu(format!("out of GPU memory for the denoiser: {e}")));
    }
    let layout = pipeline.get_bind_group_layout(0);
    let mut encoder =
        device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("denoise") });
    for i in 0..ITERATIONS {
        let params = DenoiseParams { width: input.width, height: input.height, step: 1 << i, pad: 0 };
        let params = storage("denoise params", bytemuck::bytes_of(&params), read);
        let (src, dst) = (&signals[i as usize % 2], &signals[(i as usize + 1) % 2]);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("denoise"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: src.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: guide.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 3, resource: aux.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 4, resource: dst.as_entire_binding() },
            ],
        });
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("atrous iteration"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(input.width.div_ceil(8), input.height.div_ceil(8), 1);
    }
    let index = ctx.queue.submit([encoder.finish()]);
    ctx.wait_for(index, ITERATION_TIMEOUT * ITERATIONS)?;
    let out: Vec<Vec4> = ctx.read_buffer(&signals[ITERATIONS as usize % 2], ITERATION_TIMEOUT)?;
    // The edge regression touches a few per cent of the pixels and solves an 11 × 11 system
    // in f64 for each: it runs on the host for both backends (`crate::denoise::edges`).
    let filtered = finish(&prepared, &out);
    Ok(crate::denoise::edges::reconstruct_edges(input, &prepared, &out, &filtered))
}

#[cfg(test)]
mod tests {
    use crate::denoise::atrous;

    /// The WGSL twin's constants are the CPU filter's, read from the shader as naga parses
    /// it (no "must match" comment to keep true by hand).
    #[test]
    fn the_shaders_constants_are_the_cpus() {
        let module = naga::front::wgsl::parse_str(include_str!("../../shaders/denoise.wgsl")).unwrap();
        let constant = |name: &str| crate::gpu::shader::literal_constant(&module, name);
        let expected: &[(&str, f64)] = &[
            ("SIGMA_LUMINANCE", atrous::SIGMA_LUMINANCE as f64),
            ("SIGMA_NORMAL_SQUARINGS", atrous::SIGMA_NORMAL_SQUARINGS as f64),
            ("WEIGHT_EXPONENT_CUTOFF", atrous::WEIGHT_EXPONENT_CUTOFF as f64),
            ("SIGMA_DEPTH", atrous::SIGMA_DEPTH as f64),
            ("SIGMA_EMISSION", atrous::SIGMA_EMISSION as f64),
            ("SIGMA_COVERAGE", atrous::SIGMA_COVERAGE as f64),
        ];
        for &(name, value) in expected {
            assert_eq!(constant(name), value, "{name}");
        }
    }
}
