//! Cameras: glTF perspective and orthographic cameras, and the default framing camera.

use glam::{DMat3, DVec3};

use crate::scene::layout::{self, PROJECTION_ORTHOGRAPHIC, PROJECTION_PERSPECTIVE};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Vertical field of view (radians) and the file's aspect ratio, if it gives one.
    Perspective { yfov: f64, aspect_ratio: Option<f64> },
    /// Half-extents of the view volume (glTF `xmag`, `ymag`).
    Orthographic { xmag: f64, ymag: f64 },
}

/// A camera placed in the world. Axes are orthonormal (any node scale is removed).
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    pub name: String,
    pub projection: Projection,
    pub position: DVec3,
    /// Unit viewing direction (the node's −Z).
    pub forward: DVec3,
    /// Unit up direction (the node's +Y, made orthogonal to `forward`).
    pub up: DVec3,
}

impl CameraDesc {
    /// A camera from a node's world rotation/scale part and translation.
    pub fn from_node(
        name: String,
        projection: Projection,
        linear: DMat3,
        position: DVec3,
    ) -> Option<CameraDesc> {
        let forward = (linear * DVec3::NEG_Z).try_normalize()?;
        let up_raw = linear * DVec3::Y;
        let up = (up_raw - forward * up_raw.dot(forward)).try_normalize()?;
        Some(CameraDesc { name, projection, position, forward, up })
    }

    /// A perspective camera with a 45° vertical field of view looking down −Z at the centre
    /// of the bounds, far enough back that their bounding sphere fits in the view at `aspect`.
    pub fn framing(bounds_min: DVec3, bounds_max: DVec3, aspect: f64) -> CameraDesc {
        let yfov = 45f64.to_radians();
        let center = 0.5 * (bounds_min + bounds_max);
        let radius = (0.5 * (bounds_max - bounds_min).length()).max(1e-6);
        let half_y = (yfov / 2.0).tan();
        let half_x = half_y * aspect;
        let half_min = half_x.min(half_y);
        // A sphere of radius r fits in a cone of half-angle θ at distance r / sin θ.
        let distance = radius / half_min.atan().sin() * 1.05;
        CameraDesc {
            name: "default (framing the scene)".into(),
            projection: Projection::Perspective { yfov, aspect_ratio: None },
            position: center + DVec3::Z * distance,
            forward: DVec3::NEG_Z,
            up: DVec3::Y,
        }
    }

    /// The aspect ratio the file asks for, if any.
    pub fn aspect_ratio(&self) -> Option<f64> {
        match self.projection {
            Projection::Perspective { aspect_ratio, .. } => aspect_ratio,
            Projection::Orthographic { xmag, ymag } => Some(xmag / ymag),
        }
    }

    /// The kernel's camera for an image of the given aspect (width / height), in
    /// camera-relative space (the camera at the origin).
    pub fn to_gpu(&self, aspect: f64) -> layout::Camera {
        let right = self.forward.cross(self.up).normalize();
        let (projection, half_height, half_width) = match self.projection {
            Projection::Perspective { yfov, .. } => {
                let h = (yfov / 2.0).tan();
                (PROJECTION_PERSPECTIVE, h, h * aspect)
            }
            // glTF's xmag/ymag are half-extents; keep ymag and follow the image's aspect.
            Projection::Orthographic { ymag, .. } => (PROJECTION_ORTHOGRAPHIC, ymag, ymag * aspect),
        };
        layout::Camera {
            right: right.as_vec3().to_array(),
            projection,
            up: self.up.as_vec3().to_array(),
            half_height: half_height as f32,
            forward: self.forward.as_vec3().to_array(),
            half_width: half_width as f32,
            position: [0.0; 3],
            _pad0: 0,
        }
    }
}

/// A ray cone for texture level of detail (Akenine-Möller et al. 2019, Ray Tracing Gems
/// ch. 20): at distance t along a path the footprint is `width + spread · t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayCone {
    pub width: f32,
    /// Spread angle (radians).
    pub spread: f32,
}

impl RayCone {
    /// The footprint's width after `distance` along the path.
    pub fn width_at(&self, distance: f32) -> f32 {
        self.width + self.spread * distance
    }
}

/// The cone of a camera ray in an image `height` pixels tall rendered at `spp` samples per
/// pixel: a pinhole's cone starts at width 0 with the pixel's spread angle
/// atan(2 tan(yfov/2) / height) (eq. 30 there); an orthographic camera's has the pixel's
/// width and no spread. Both are scaled by max(1/8, 1/√spp), as pbrt-v4 scales its ray
/// differentials (`RayIntegrator::EvaluatePixelSample`): with many samples the pixel is
/// integrated by the samples themselves, so each needs to filter only its share of it.
pub fn camera_ray_cone(camera: &layout::Camera, height: u32, spp: u32) -> RayCone {
    let pixel = 2.0 * camera.half_height / height as f32;
    let scale = (1.0 / (spp.max(1) as f32).sqrt()).max(0.125);
    if camera.projection == PROJECTION_ORTHOGRAPHIC {
        RayCone { width: pixel * scale, spread: 0.0 }
    } else {
        RayCone { width: 0.0, spread: pixel.atan() * scale }
    }
}

/// The camera ray through image position `(x + u.x, y + u.y)` (pixels, y down) of a
/// `width × height` image: a box pixel filter with one uniformly placed sample. Direction
/// is unit length, so `t` is distance.
pub fn generate_camera_ray(
    camera: &layout::Camera,
    width: u32,
    height: u32,
    x: u32,
    y: u32,
    u: glam::Vec2,
) -> crate::geometry::Ray {
    use glam::Vec3;
    let ndc_x = 2.0 * (x as f32 + u.x) / width as f32 - 1.0;
    let ndc_y = 1.0 - 2.0 * (y as f32 + u.y) / height as f32;
    let right = Vec3::from(camera.right) * (ndc_x * camera.half_width);
    let up = Vec3::from(camera.up) * (ndc_y * camera.half_height);
    let forward = Vec3::from(camera.forward);
    let position = Vec3::from(camera.position);
    let (origin, direction) = if camera.projection == PROJECTION_ORTHOGRAPHIC {
        (position + right + up, forward)
    } else {
        (position, (forward + right + up).normalize())
    };
    crate::geometry::Ray { origin, direction, t_max: f32::MAX }
}

/// A pinhole camera run backwards: which pixel a point is seen in, for a light path's
/// connection to the camera (`crate::cpu` light tracing). The inverse of
/// [`generate_camera_ray`] for perspective cameras.
pub struct PinholeProjection {
    pub position: glam::Vec3,
    right: glam::Vec3,
    up: glam::Vec3,
    forward: glam::Vec3,
    half_width: f32,
    half_height: f32,
    width: u32,
    height: u32,
    /// Area of one pixel on the image plane at distance 1.
    pub pixel_area: f32,
}

impl PinholeProjection {
    pub fn new(camera: &layout::Camera, width: u32, height: u32) -> PinholeProjection {
        PinholeProjection {
            position: glam::Vec3::from(camera.position),
            right: glam::Vec3::from(camera.right),
            up: glam::Vec3::from(camera.up),
            forward: glam::Vec3::from(camera.forward),
            half_width: camera.half_width,
            half_height: camera.half_height,
            width,
            height,
            pixel_area: (2.0 * camera.half_width / width as f32) * (2.0 * camera.half_height / height as f32),
        }
    }

    /// The pixel (row-major index) whose box `p` projects into, the cosine between the view
    /// axis and the direction to `p`, that unit direction, and the squared distance.
    pub fn project(&self, p: glam::Vec3) -> Option<(usize, f32, glam::Vec3, f32)> {
        let v = p - self.position;
        let z = v.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let ndc_x = v.dot(self.right) / (z * self.half_width);
        let ndc_y = v.dot(self.up) / (z * self.half_height);
        let x = (ndc_x + 1.0) * 0.5 * self.width as f32;
        let y = (1.0 - ndc_y) * 0.5 * self.height as f32;
        if !(x >= 0.0 && y >= 0.0 && x < self.width as f32 && y < self.height as f32) {
            return None;
        }
        let pixel = y as usize * self.width as usize + x as usize;
        let distance2 = v.length_squared();
        let distance = distance2.sqrt();
        Some((pixel, z / distance, v / distance, distance2))
    }
}
