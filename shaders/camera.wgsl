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

