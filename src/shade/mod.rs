//! Shading: a unidirectional path tracer with next-event estimation and multiple importance
//! sampling over glTF metallic-roughness materials. World frame, photometric units
//! (see [`crate::scene`]).

pub mod texture_lookup;

use bevy_ecs::resource::Resource;
use glam::Vec3;

use crate::accel::SceneAccel;
use crate::batch::{HitBatch, RayBatch};
use crate::scene::{MaterialLibrary, PunctualLight};

/// What lies beyond the scene.
#[derive(Clone, Debug)]
pub enum Environment {
    /// A uniform sky of this radiance (nits).
    Uniform(Vec3),
}

/// All light sources, prepared for sampling: punctual lights, emissive triangles, environment.
#[derive(Resource)]
pub struct LightSet {
    _private: (),
}

impl LightSet {
    pub fn build(
        _punctual: &[PunctualLight],
        _accel: &SceneAccel,
        _materials: &MaterialLibrary,
        _environment: &Environment,
    ) -> LightSet {
        unimplemented!("shade: light set")
    }
}

/// Per-ray radiance of a batch (linear RGB, nits), one entry per ray.
#[derive(Clone, Debug, Default)]
pub struct RadianceBatch {
    pub r: Vec<f32>,
    pub g: Vec<f32>,
    pub b: Vec<f32>,
}

/// Counters a shading pass adds to.
#[derive(Clone, Copy, Debug, Default)]
pub struct ShadeStats {
    /// Rays traced inside shading (bounce and shadow rays).
    pub rays_traced: u64,
}

/// Everything shading reads, borrowed for one pass.
pub struct Shader<'a> {
    pub accel: &'a SceneAccel,
    pub materials: &'a MaterialLibrary,
    pub lights: &'a LightSet,
    pub environment: &'a Environment,
    pub max_depth: u32,
    pub seed: u64,
}

impl Shader<'_> {
    /// Radiance arriving along each alive ray of `rays` (world frame, unit directions), given
    /// its closest hit in `hits`. Dead rays get zero. Each ray draws its random numbers from
    /// its own stream keyed by (seed, pixel, sample), so results do not depend on batching.
    pub fn shade_batch(
        &self,
        _rays: &RayBatch,
        _hits: &HitBatch,
        _out: &mut RadianceBatch,
        _stats: &mut ShadeStats,
    ) {
        unimplemented!("shade: batch")
    }
}
