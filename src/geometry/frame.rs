//! Orthonormal frames.

use glam::Vec3;

/// An orthonormal basis whose `z` axis is a given unit normal.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub x: Vec3,
    pub y: Vec3,
    pub z: Vec3,
}

impl Frame {
    /// The world axes: the frame of a layer that is absent.
    pub const IDENTITY: Frame = Frame { x: Vec3::X, y: Vec3::Y, z: Vec3::Z };

    /// Builds a frame around the unit vector `n` without branching on a threshold
    /// (Duff, Burgess, Christensen, Hery, Kensler, Liani & Villemin 2017, "Building an
    /// Orthonormal Basis, Revisited", JCGT 6(1), Listing 3).
    pub fn from_z(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let x = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let y = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { x, y, z: n }
    }

    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }

    pub fn from_local(&self, v: Vec3) -> Vec3 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    #[test]
    fn frames_are_orthonormal_everywhere() {
        let mut rng = Rng::new(1, 2, 3, 4);
        let mut normals: Vec<Vec3> =
            (0..10_000).map(|_| crate::sampling::sample_uniform_sphere(rng.next_2d())).collect();
        // The cases that break naive constructions.
        normals.extend([Vec3::Z, -Vec3::Z, Vec3::X, -Vec3::Y, Vec3::new(0.0, 1e-20, -1.0)]);
        for n in normals {
            let n = n.normalize();
            let f = Frame::from_z(n);
            // Each product is a few f32 roundings of unit-length quantities.
            let tol = 1e-5;
            assert!((f.x.length() - 1.0).abs() < tol, "{n:?}");
            assert!((f.y.length() - 1.0).abs() < tol, "{n:?}");
            assert!(f.x.dot(f.y).abs() < tol && f.x.dot(n).abs() < tol && f.y.dot(n).abs() < tol);
            assert!((f.x.cross(f.y) - n).length() < 1e-4, "right-handed for {n:?}");
        }
    }
}
