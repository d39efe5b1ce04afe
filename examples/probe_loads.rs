//! What one 16-byte load costs on a Vulkan adapter, by where the data lives: a storage
//! buffer (`array<vec4<u32>>`, what the megakernel binds), a sampled texture read with
//! `textureLoad` (RGBA32Uint), or a uniform buffer (64 KiB at most, so the small table only).
//!
//! Each invocation follows a chain of dependent loads through a table of random links (the
//! next index comes from the loaded value), as a BVH walk does, so the load and the code
//! the driver wraps around it are what is timed. On lavapipe, storage-buffer loads loop over
//! the SIMD lanes (Mesa's `emit_load_mem`), uniform loads with varying offsets are an
//! unrolled gather, and texel fetches go through the sampler's code (`bench/history/lavapipe.md`).
//!
//!   XDG_RUNTIME_DIR=/tmp WGPU_DEBUG=0 cargo run --release --example probe_loads [-- --steps 128 --invocations 32768]

use std::process::ExitCode;
use std::time::Instant;

use wgpu::util::DeviceExt;

/// Texels per row of the texture form of the table.
const TEXTURE_WIDTH: u32 = 1024;

#[derive(Clone, Copy, PartialEq)]
enum Source {
    Storage,
    Texture,
    Uniform,
}

impl Source {
    fn name(self) -> &'static str {
        match self {
            Source::Storage => "storage",
            Source::Texture => "texture",
            Source::Uniform => "uniform",
        }
    }
}

/// Where the table was put: a buffer (storage or uniform) or a texture's view.
enum Table {
    Buffer(wgpu::Buffer),
    Texture(wgpu::TextureView),
}

fn shader(source: Source, steps: u32, entries: u32) -> String {
    let (decl, load) = match source {
        Source::Storage => (
            "@group(0) @binding(0) var<storage, read> table: array<vec4<u32>>;".to_string(),
            "table[i]".to_string(),
        ),
        Source::Texture => (
            "@group(0) @binding(0) var table: texture_2d<u32>;".to_string(),
            format!("textureLoad(table, vec2<u32>(i % {TEXTURE_WIDTH}u, i / {TEXTURE_WIDTH}u), 0)"),
        ),
        Source::Uniform => (
            format!("@group(0) @binding(0) var<uniform> table: array<vec4<u32>, {entries}>;"),
            "table[i]".to_string(),
        ),
    };
    format!(
        "{decl}
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
    var i = (id.x * 2654435761u) % {entries}u;
    var acc = 0u;
    for (var s = 0u; s < {steps}u; s++) {{
        let v = {load};
        acc += v.y ^ v.z ^ v.w;
        i = v.x;
    }}
    out[id.x] = acc + i;
}}"
    )
}

/// A table of `entries` links forming one random cycle (Sattolo's shuffle), so no chain
/// falls into a short loop that stays in the first-level cache.
fn table(entries: u32) -> Vec<[u32; 4]> {
    let mut next: Vec<u32> = (0..entries).collect();
    let mut state = 0x9E37_79B9u64;
    for k in (1..entries as usize).rev() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        next.swap(k, (state % k as u64) as usize);
    }
    (0..entries).map(|i| [next[i as usize], i, i.wrapping_mul(3), i.wrapping_mul(7)]).collect()
}

fn parse_flag(args: &[String], name: &str, default: u32) -> Result<u32, String> {
    match args.iter().position(|a| a == name) {
        None => Ok(default),
        Some(i) => match args.get(i + 1).map(|v| v.parse::<u32>()) {
            Some(Ok(v)) if v > 0 => Ok(v),
            _ => Err(format!("{name} takes a positive whole number")),
        },
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (steps, invocations) =
        match (parse_flag(&args, "--steps", 128), parse_flag(&args, "--invocations", 32768)) {
            (Ok(s), Ok(n)) => (s, n.div_ceil(64) * 64),
            (Err(e), _) | (_, Err(e)) => {
                eprintln!("probe_loads: {e}");
                return ExitCode::from(2);
            }
        };
    let instance = pathlight::gpu::context::instance();
    let Ok(adapter) = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))
    else {
        eprintln!("probe_loads: no Vulkan adapter (apt-get install mesa-vulkan-drivers for lavapipe)");
        return ExitCode::from(2);
    };
    println!("{}: {invocations} invocations × {steps} dependent loads", adapter.get_info().name);
    let (device, queue) =
        match pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            required_limits: adapter.limits(),
            ..Default::default()
        })) {
            Ok(d) => d,
            Err(e) => {
                eprintln!("probe_loads: cannot open the adapter: {e}");
                return ExitCode::from(2);
            }
        };
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: invocations as u64 * 4,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    // 64 KiB (fits a uniform buffer and the first-level caches' neighbourhood) and 16 MiB
    // (far beyond the second-level caches).
    for entries in [4096u32, 1 << 20] {
        let data = table(entries);
        let sources: &[Source] = if entries as u64 * 16 <= adapter.limits().max_uniform_buffer_binding_size {
            &[Source::Storage, Source::Texture, Source::Uniform]
        } else {
            &[Source::Storage, Source::Texture]
        };
        for &source in sources {
            let buffer = |usage| {
                device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: None,
                    contents: bytemuck::cast_slice(&data),
                    usage,
                })
            };
            let texture_view = |data: &[[u32; 4]]| {
                let height = entries.div_ceil(TEXTURE_WIDTH);
                let mut padded = data.to_vec();
                padded.resize((TEXTURE_WIDTH * height) as usize, [0; 4]);
                device
                    .create_texture_with_data(
                        &queue,
                        &wgpu::TextureDescriptor {
                            label: None,
                            size: wgpu::Extent3d { width: TEXTURE_WIDTH, height, depth_or_array_layers: 1 },
                            mip_level_count: 1,
                            sample_count: 1,
                            dimension: wgpu::TextureDimension::D2,
                            format: wgpu::TextureFormat::Rgba32Uint,
                            usage: wgpu::TextureUsages::TEXTURE_BINDING,
                            view_formats: &[],
                        },
                        wgpu::util::TextureDataOrder::LayerMajor,
                        bytemuck::cast_slice(&padded),
                    )
                    .create_view(&Default::default())
            };
            let buffer_type =
                |ty| wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None };
            let (table_type, table) = match source {
                Source::Storage => (
                    buffer_type(wgpu::BufferBindingType::Storage { read_only: true }),
                    Table::Buffer(buffer(wgpu::BufferUsages::STORAGE)),
                ),
                Source::Uniform => (
                    buffer_type(wgpu::BufferBindingType::Uniform),
                    Table::Buffer(buffer(wgpu::BufferUsages::UNIFORM)),
                ),
                Source::Texture => (
                    wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Uint,
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    Table::Texture(texture_view(&data)),
                ),
            };
            let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty,
                count: None,
            };
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: None,
                entries: &[
                    entry(0, table_type),
                    entry(1, buffer_type(wgpu::BufferBindingType::Storage { read_only: false })),
                ],
            });
            let table_resource = match &table {
                Table::Buffer(b) => b.as_entire_binding(),
                Table::Texture(view) => wgpu::BindingResource::TextureView(view),
            };
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: table_resource },
                    wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
                ],
            });
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: None,
                source: wgpu::ShaderSource::Wgsl(shader(source, steps, entries).into()),
            });
            let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: None,
                layout: Some(&device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: None,
                    bind_group_layouts: &[Some(&layout)],
                    immediate_size: 0,
                })),
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            });
            let run = || -> Result<f64, String> {
                let start = Instant::now();
                let mut encoder = device.create_command_encoder(&Default::default());
                {
                    let mut pass = encoder.begin_compute_pass(&Default::default());
                    pass.set_pipeline(&pipeline);
                    pass.set_bind_group(0, &bind_group, &[]);
                    pass.dispatch_workgroups(invocations / 64, 1, 1);
                }
                let index = queue.submit([encoder.finish()]);
                device
                    .poll(wgpu::PollType::Wait { submission_index: Some(index), timeout: None })
                    .map_err(|e| format!("waiting for the dispatch failed: {e}"))?;
                Ok(start.elapsed().as_secs_f64())
            };
            // The first dispatch compiles the shader on lavapipe; the best of three after it.
            let best = (0..4).map(|_| run()).collect::<Result<Vec<f64>, String>>();
            let best = match best {
                Ok(times) => times[1..].iter().copied().fold(f64::MAX, f64::min),
                Err(e) => {
                    eprintln!("probe_loads: {e}");
                    return ExitCode::FAILURE;
                }
            };
            let loads = invocations as f64 * steps as f64;
            println!(
                "{entries:>8} entries ({:>5} KiB) {:>8}: {:6.2} ns per load ({:7.1} M loads/s)",
                entries * 16 / 1024,
                source.name(),
                best * 1e9 / loads,
                loads / best / 1e6
            );
        }
    }
    ExitCode::SUCCESS
}
