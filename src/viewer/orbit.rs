//! Mouse navigation: orbit about a target point, pan, and dolly, from the scene's starting
//! camera (the glTF camera, or the one framing the scene).

use glam::DVec3;

use crate::scene::camera::CameraDesc;
use crate::scene::layout::Camera;

/// The viewer's camera as yaw and pitch about a target, +Y up.
#[derive(Clone, Debug)]
pub struct Orbit {
    start: CameraDesc,
    target: DVec3,
    distance: f64,
    yaw: f64,
    pitch: f64,
    /// The world point the flat scene's coordinates are relative to.
    origin: DVec3,
    /// Still the starting camera (no input yet): rendered exactly as the file has it.
    moved: bool,
}

/// Pitch stays this far from straight up or down (radians), so +Y can stay the up vector.
const PITCH_LIMIT: f64 = 1.55;

impl Orbit {
    /// Orbits around the point of the scene's bounds nearest the view axis; `origin` is the
    /// flat scene's camera-relative origin.
    pub fn new(start: &CameraDesc, bounds: (DVec3, DVec3), origin: DVec3) -> Orbit {
        let center = 0.5 * (bounds.0 + bounds.1);
        let radius = 0.5 * (bounds.1 - bounds.0).length();
        let along = (center - start.position).dot(start.forward);
        let distance = along.max(0.1 * radius).max(1e-6);
        let target = start.position + start.forward * distance;
        let offset = (start.position - target) / distance;
        Orbit {
            start: start.clone(),
            target,
            distance,
            yaw: offset.x.atan2(offset.z),
            pitch: offset.y.clamp(-1.0, 1.0).asin().clamp(-PITCH_LIMIT, PITCH_LIMIT),
            origin,
            moved: false,
        }
    }

    fn eye(&self) -> DVec3 {
        let (sp, cp) = self.pitch.sin_cos();
        let (sy, cy) = self.yaw.sin_cos();
        self.target + self.distance * DVec3::new(cp * sy, sp, cp * cy)
    }

    fn basis(&self) -> (DVec3, DVec3, DVec3) {
        let forward = (self.target - self.eye()).normalize();
        let right = forward.cross(DVec3::Y).normalize();
        (forward, right, right.cross(forward))
    }

    /// Turns by a mouse drag of `(dx, dy)` pixels.
    pub fn rotate(&mut self, dx: f64, dy: f64) {
        self.yaw -= dx * 0.005;
        self.pitch = (self.pitch + dy * 0.005).clamp(-PITCH_LIMIT, PITCH_LIMIT);
        self.moved = true;
    }

    /// Moves the target and the eye across the view by a drag of `(dx, dy)` pixels.
    pub fn pan(&mut self, dx: f64, dy: f64) {
        let (_, right, up) = self.basis();
        self.target += (-dx * right + dy * up) * self.distance * 0.0015;
        self.moved = true;
    }

    /// Dollies towards the target by `steps` wheel notches (negative: away).
    pub fn zoom(&mut self, steps: f64) {
        self.distance = (self.distance * 0.9f64.powf(steps)).max(1e-6);
        self.moved = true;
    }

    /// The kernel's camera for an image of `aspect` (width / height).
    pub fn camera(&self, aspect: f64) -> Camera {
        if !self.moved {
            let mut c = self.start.to_gpu(aspect);
            c.position = (self.start.position - self.origin).as_vec3().to_array();
            return c;
        }
        let (forward, _, up) = self.basis();
        let desc = CameraDesc { position: self.eye(), forward, up, ..self.start.clone() };
        let mut c = desc.to_gpu(aspect);
        c.position = (desc.position - self.origin).as_vec3().to_array();
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::camera::Projection;

    fn start() -> CameraDesc {
        CameraDesc {
            name: "test".into(),
            projection: Projection::Perspective { yfov: 0.8, aspect_ratio: None },
            position: DVec3::new(0.0, 1.0, 5.0),
            forward: DVec3::NEG_Z,
            up: DVec3::Y,
        }
    }

    #[test]
    fn the_starting_view_is_the_files_camera() {
        let s = start();
        let o = Orbit::new(&s, (DVec3::splat(-1.0), DVec3::splat(1.0)), s.position);
        let c = o.camera(1.0);
        assert_eq!(c.position, [0.0; 3]);
        assert_eq!(c.forward, [0.0, 0.0, -1.0]);
    }

    #[test]
    fn orbiting_keeps_the_distance_to_the_target() {
        let s = start();
        let mut o = Orbit::new(&s, (DVec3::splat(-1.0), DVec3::splat(1.0)), DVec3::ZERO);
        let d0 = (o.eye() - o.target).length();
        o.rotate(120.0, -40.0);
        assert!(((o.eye() - o.target).length() - d0).abs() < 1e-9);
        let c = o.camera(1.0);
        let forward = glam::Vec3::from(c.forward);
        let to_target = (o.target - o.eye()).normalize().as_vec3();
        assert!((forward - to_target).length() < 1e-5, "looks at the target");
        o.zoom(3.0);
        assert!(((o.eye() - o.target).length() - d0 * 0.729).abs() < 1e-9);
    }
}
