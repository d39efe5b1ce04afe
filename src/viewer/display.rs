//! The display pass: tone-maps a film buffer (`FilmPixel` per pixel) onto a render target,
//! the window's surface or an offscreen texture for screenshots (`shaders/display.wgsl`).

use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::scene::layout::{DisplayParams, FilmPixel};

/// A display pipeline for one target format.
pub struct Display {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    /// The format's own encoding is not sRGB: the shader applies the curve.
    encode_srgb: bool,
}

impl Display {
    pub fn new(ctx: &GpuContext, format: wgpu::TextureFormat) -> Result<Display> {
        let device = &ctx.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("pathlight display"),
            source: wgpu::ShaderSource::Wgsl(crate::gpu::shader::display_source().into()),
        });
        // Storage buffers, not uniforms: lavapipe recompiles a shader for every re-bound
        // uniform (shaders/bindings.wgsl).
        let entry = |binding: u32| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: true },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("display"),
            entries: &[entry(0), entry(1)],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("display"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("display"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("display_vertex"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("display_fragment"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("display params"),
            size: std::mem::size_of::<DisplayParams>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(Error::Gpu(format!("display pipeline rejected: {e}")));
        }
        Ok(Display { pipeline, layout, params, encode_srgb: !format.is_srgb() })
    }

    /// Draws `film` (`film_width × film_height` pixels) over `target` (`target_size`).
    #[allow(clippy::too_many_arguments)] // reason: one draw's full description; a struct would only rename them.
    pub fn draw(
        &self,
        ctx: &GpuContext,
        film: &wgpu::Buffer,
        film_size: (u32, u32),
        target: &wgpu::TextureView,
        target_size: (u32, u32),
        tonemap: u32,
        exposure: f32,
    ) {
        let params = DisplayParams {
            film_width: film_size.0,
            film_height: film_size.1,
            target_width: target_size.0.max(1),
            target_height: target_size.1.max(1),
            exposure_scale: 2f32.powf(exposure),
            tonemap,
            encode_srgb: self.encode_srgb as u32,
            _pad0: 0,
        };
        ctx.queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let bind_group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("display"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: film.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: self.params.as_entire_binding() },
            ],
        });
        let mut encoder =
            ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("display") });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("display"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.draw(0..3, 0..1);
        }
        ctx.queue.submit([encoder.finish()]);
    }
}

/// A film buffer the host fills (the CPU backend's film, uploaded at a bounded rate).
pub fn upload_buffer(ctx: &GpuContext, pixels: usize) -> wgpu::Buffer {
    ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("film upload"),
        size: (pixels.max(1) * std::mem::size_of::<FilmPixel>()) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Renders `film` through `display` into an RGBA8 image of `size` and reads it back: what
/// the window shows, for `--screenshot`.
pub fn screenshot(
    ctx: &GpuContext,
    display: &Display,
    film: &wgpu::Buffer,
    film_size: (u32, u32),
    size: (u32, u32),
    tonemap: u32,
    exposure: f32,
) -> Result<image::RgbaImage> {
    let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("screenshot"),
        size: wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let view = texture.create_view(&Default::default());
    display.draw(ctx, film, film_size, &view, size, tonemap, exposure);
    // Rows of a texture copy are padded to 256 bytes.
    let row = (size.0 * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("screenshot readback"),
        size: (row * size.1) as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture: &texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(size.1),
            },
        },
        wgpu::Extent3d { width: size.0, height: size.1, depth_or_array_layers: 1 },
    );
    let index = ctx.queue.submit([encoder.finish()]);
    let (tx, rx) = std::sync::mpsc::channel();
    staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(index),
            timeout: Some(std::time::Duration::from_secs(60)),
        })
        .map_err(|e| Error::Gpu(format!("waiting for the screenshot failed: {e}")))?;
    rx.recv()
        .map_err(|_| Error::Gpu("screenshot readback lost".into()))?
        .map_err(|e| Error::Gpu(format!("screenshot readback failed: {e}")))?;
    let data = staging
        .slice(..)
        .get_mapped_range()
        .map_err(|e| Error::Gpu(format!("cannot map the screenshot: {e}")))?;
    let mut rgba = Vec::with_capacity((size.0 * size.1 * 4) as usize);
    for y in 0..size.1 as usize {
        rgba.extend_from_slice(&data[y * row as usize..y * row as usize + size.0 as usize * 4]);
    }
    drop(data);
    staging.unmap();
    image::RgbaImage::from_raw(size.0, size.1, rgba)
        .ok_or_else(|| Error::Gpu("screenshot size mismatch".into()))
}
