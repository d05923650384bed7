//! Ray–scene intersection: an obvhs BVH over every world-space triangle of the scene.
//!
//! Built once per scene in the BuildBvh stage; read by Trace (camera rays, in batches) and by
//! Shade (bounce and shadow rays). World frame, metres (see [`crate::scene`]).

use std::time::Duration;

use bevy_ecs::resource::Resource;
use glam::{Vec2, Vec3};

use crate::batch::{HitBatch, RayBatch};
use crate::scene::{MaterialLibrary, MeshInstance};

/// A ray–triangle hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Triangle index in [`SceneAccel`] order.
    pub triangle: u32,
    /// Barycentric weights of vertices 1 and 2.
    pub u: f32,
    pub v: f32,
}

/// The shading frame and attributes at a hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub position: Vec3,
    /// Unit geometric normal, facing the side the ray came from.
    pub geometric_normal: Vec3,
    /// Unit interpolated vertex normal (before normal mapping), same hemisphere as the geometric one.
    pub shading_normal: Vec3,
    /// Unit tangent along +u for normal mapping (w = bitangent sign), zero if unavailable.
    pub tangent: glam::Vec4,
    pub uv: Vec2,
    /// Index into the material library (`None` = default material).
    pub material: Option<usize>,
    /// True when the ray hit the side the geometric normal (winding) points away from.
    pub back_face: bool,
}

/// The scene's BVH and the triangle data it indexes, in BVH order.
#[derive(Resource)]
pub struct SceneAccel {
    _private: (),
}

impl SceneAccel {
    pub fn build<'a>(
        _instances: impl IntoIterator<Item = &'a MeshInstance>,
        _materials: &MaterialLibrary,
    ) -> anyhow::Result<SceneAccel> {
        unimplemented!("accel: build")
    }

    pub fn triangle_count(&self) -> usize {
        unimplemented!()
    }

    pub fn node_count(&self) -> usize {
        unimplemented!()
    }

    pub fn build_time(&self) -> Duration {
        unimplemented!()
    }

    /// Closest hit in (t_min, t_max), skipping alpha-masked holes.
    pub fn intersect(&self, _origin: Vec3, _direction: Vec3, _t_max: f32) -> Option<Hit> {
        unimplemented!()
    }

    /// Any hit in (t_min, t_max), skipping alpha-masked holes (shadow rays).
    pub fn occluded(&self, _origin: Vec3, _direction: Vec3, _t_max: f32) -> bool {
        unimplemented!()
    }

    /// Closest hits of every alive ray of the batch (dead rays get a miss).
    pub fn intersect_batch(&self, _rays: &RayBatch, _hits: &mut HitBatch) {
        unimplemented!()
    }

    pub fn surface(&self, _hit: &Hit, _ray_direction: Vec3) -> SurfacePoint {
        unimplemented!()
    }
}
