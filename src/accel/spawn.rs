//! Spawning rays from surfaces without hitting the surface they start on.
//!
//! A hit point computed in f32 lies off the true surface by a few ulps of its coordinates (and
//! of the triangle's vertex coordinates), so a ray leaving it can hit its own triangle again.
//! Moving the origin along the geometric normal by an epsilon that scales with both the
//! point's coordinates and the scene's size works from 7 mm scenes to 100 m ones.

use glam::Vec3;

use super::SceneAccel;
use crate::scene::Bounds;

/// Relative to the largest coordinate of the point: 2^-16 ≈ 128 ulps of f32.
const COORDINATE_RELATIVE: f32 = 1.0 / 65536.0;
/// Relative to the scene's diagonal, for points near the origin (whose own coordinates say
/// little about the size of the triangles around them): 2^-18 ≈ 4 ppm of the scene.
const SCENE_RELATIVE: f32 = 1.0 / 262144.0;

/// The scene-size part of the epsilon; a metre-sized scene is assumed when bounds are empty.
pub(super) fn scene_epsilon(bounds: &Bounds) -> f32 {
    let diagonal = bounds.diagonal();
    if bounds.is_empty() || !diagonal.is_finite() || diagonal <= 0.0 {
        SCENE_RELATIVE
    } else {
        SCENE_RELATIVE * diagonal
    }
}

impl SceneAccel {
    /// How far (m) off a surface a ray starting at `position` must begin.
    pub fn self_intersection_epsilon(&self, position: Vec3) -> f32 {
        let coordinate_scale = position.abs().max_element();
        let coordinate_scale = if coordinate_scale.is_finite() {
            coordinate_scale
        } else {
            0.0
        };
        COORDINATE_RELATIVE * coordinate_scale + self.scene_epsilon
    }

    /// `position` moved off its surface along `geometric_normal`, to the side `direction`
    /// leaves to: the origin for a ray in `direction` that will not hit its own surface.
    pub fn offset_ray_origin(
        &self,
        position: Vec3,
        geometric_normal: Vec3,
        direction: Vec3,
    ) -> Vec3 {
        let toward = if geometric_normal.dot(direction) < 0.0 {
            -geometric_normal
        } else {
            geometric_normal
        };
        position + toward * self.self_intersection_epsilon(position)
    }
}
