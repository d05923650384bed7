//! Orthonormal shading frames: BSDFs work in a local frame whose +z is the shading normal.

use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub tangent: Vec3,
    pub bitangent: Vec3,
    pub normal: Vec3,
}

impl Frame {
    /// A frame around a unit normal; the tangent's azimuth is arbitrary (isotropic BSDFs only).
    pub fn from_normal(normal: Vec3) -> Self {
        // Duff et al. 2017, branchless and continuous except at one point.
        let (tangent, bitangent) = normal.any_orthonormal_pair();
        Frame {
            tangent,
            bitangent,
            normal,
        }
    }

    pub fn to_local(self, world: Vec3) -> Vec3 {
        Vec3::new(
            world.dot(self.tangent),
            world.dot(self.bitangent),
            world.dot(self.normal),
        )
    }

    pub fn to_world(self, local: Vec3) -> Vec3 {
        self.tangent * local.x + self.bitangent * local.y + self.normal * local.z
    }
}
