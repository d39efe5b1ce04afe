// Twin of `generate_camera_ray` in src/scene/camera.rs: box pixel filter, one uniformly
// placed sample; unit direction.

fn generate_camera_ray(width: u32, height: u32, x: u32, y: u32, u: vec2<f32>) -> Ray {
    let ndc_x = 2.0 * (f32(x) + u.x) / f32(width) - 1.0;
    let ndc_y = 1.0 - 2.0 * (f32(y) + u.y) / f32(height);
    let right = camera.right * (ndc_x * camera.half_width);
    let up = camera.up * (ndc_y * camera.half_height);
    if (camera.projection == PROJECTION_ORTHOGRAPHIC) {
        return Ray(camera.position + right + up, camera.forward, F32_MAX);
    }
    return Ray(camera.position, normalize(camera.forward + right + up), F32_MAX);
}

// Twin of `PinholeProjection::project` in src/scene/camera.rs: the pixel (row-major index)
// whose box `p` projects into, the cosine between the view axis and the direction to `p`,
// that unit direction and the squared distance; `valid` false outside the image or behind
// the camera.
struct PixelProjection {
    pixel: u32,
    cos_theta: f32,
    direction: vec3<f32>,
    distance2: f32,
    valid: bool,
}

fn project_to_pixel(p: vec3<f32>, width: u32, height: u32) -> PixelProjection {
    var out = PixelProjection(0u, 0.0, vec3<f32>(0.0), 0.0, false);
    let v = p - camera.position;
    let z = dot(v, camera.forward);
    if (z <= 0.0) {
        return out;
    }
    let ndc_x = dot(v, camera.right) / (z * camera.half_width);
    let ndc_y = dot(v, camera.up) / (z * camera.half_height);
    let x = (ndc_x + 1.0) * 0.5 * f32(width);
    let y = (1.0 - ndc_y) * 0.5 * f32(height);
    if (!(x >= 0.0 && y >= 0.0 && x < f32(width) && y < f32(height))) {
        return out;
    }
    out.pixel = u32(y) * width + u32(x);
    out.distance2 = dot(v, v);
    let distance = sqrt(out.distance2);
    out.cos_theta = z / distance;
    out.direction = v / distance;
    out.valid = true;
    return out;
}

// Twin of `PinholeProjection::pixel_area`: one pixel's area on the image plane at distance 1.
fn pinhole_pixel_area(width: u32, height: u32) -> f32 {
    return (2.0 * camera.half_width / f32(width)) * (2.0 * camera.half_height / f32(height));
}

// The pixel (x, y) of invocation `gid` within this dispatch's band of rows
// [row_offset, row_offset + row_count); z = 0 when it lies outside the band or the image.
fn band_pixel(gid: vec3<u32>) -> vec3<u32> {
    let y = gid.y + frame.row_offset;
    let inside = gid.x < frame.width && gid.y < frame.row_count && y < frame.height;
    return vec3<u32>(gid.x, y, select(0u, 1u, inside));
}

// Item `i` of a dispatch over `items` items for `gid` (photons, Metropolis's samples and
// chains, irradiance-cache gather rays): rows of `frame.width` items in workgroups of 8
// rows, the rows past 65,535 workgroups in y going on in z layers (the host's
// `GpuBackend::item_groups`); INVALID_INDEX past `items`.
fn dispatch_item(gid: vec3<u32>, groups: vec3<u32>, items: u32) -> u32 {
    if (gid.x >= frame.width) {
        return INVALID_INDEX;
    }
    let row = gid.y + gid.z * groups.y * 8u;
    let i = row * frame.width + gid.x;
    return select(INVALID_INDEX, i, i < items);
}
