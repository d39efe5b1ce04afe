// Resources of the megakernel (src/gpu/pipeline.rs creates the matching layout).

@group(0) @binding(0) var<storage, read> nodes: array<BvhNode>;
@group(0) @binding(1) var<storage, read> triangles: array<Triangle>;
@group(0) @binding(2) var<storage, read> normals: array<TriangleNormals>;
@group(0) @binding(3) var<storage, read> materials: array<Material>;
@group(0) @binding(4) var<storage, read> lights: array<Light>;
@group(0) @binding(5) var<uniform> camera: Camera;
@group(0) @binding(6) var<uniform> frame: FrameParams;
@group(0) @binding(7) var<storage, read_write> film: array<FilmPixel>;
@group(0) @binding(8) var<storage, read_write> first_hits: array<FirstHit>;
// Rays traced per pixel (closest-hit and shadow rays), for throughput reporting.
@group(0) @binding(9) var<storage, read_write> ray_counts: array<u32>;
