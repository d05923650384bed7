//! Shading: a unidirectional path tracer with next-event estimation and multiple importance
//! sampling over glTF metallic-roughness materials. World frame, photometric units
//! (see [`crate::scene`]).
//!
//! - [`bsdf`] / [`ggx`]: the glTF 2.0 Appendix B BRDF (Lambert + GGX, Smith height-correlated,
//!   Schlick Fresnel).
//! - [`material`]: textures and normal maps at a hit; emission sidedness.
//! - [`lights`]: punctual lights, emissive triangles, environment; light selection.
//! - [`environment`]: uniform sky or equirectangular image ([`load_environment`]).
//! - [`integrator`]: the path loop, MIS, Russian roulette.

// `!(x > 0.0)` is how this module rejects NaN together with non-positive values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bsdf;
pub(crate) mod distribution;
pub mod environment;
pub(crate) mod frame;
pub mod ggx;
pub mod integrator;
pub mod lights;
pub mod material;
pub(crate) mod warp;

#[cfg(test)]
mod tests;

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::{Hit, SceneAccel};
use crate::batch::{HitBatch, RayBatch};
use crate::sampling::Rng;
use crate::scene::MaterialLibrary;
use integrator::Strategy;

pub use environment::{Environment, EnvironmentMap, load_environment};
pub use lights::{EnvironmentSampling, LightSet};

/// Mixed into the seed of every shading stream, so shading draws numbers independent of any
/// other stage keyed by the same (seed, pixel, sample).
pub const SHADE_STREAM_KEY: u64 = 0x5348_4144_455f_5041; // "SHADE_PA"

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
    /// Built from the same accelerator, materials and environment as this shader's.
    pub lights: &'a LightSet,
    pub environment: &'a Environment,
    /// Number of bounces: 0 = emitters and environment only, 1 = direct lighting, …
    pub max_depth: u32,
    pub seed: u64,
}

impl Shader<'_> {
    /// Radiance arriving along each alive ray of `rays` (world frame, unit directions), given
    /// its closest hit in `hits`. Dead rays get zero. Each ray draws its random numbers from
    /// its own stream keyed by (seed, pixel, sample), so results do not depend on batching.
    ///
    /// The batch's throughput (`tr`, `tg`, `tb`) is *not* applied: `out` holds radiance, and
    /// the caller weights it. A ray without an entry in `hits` is traced here.
    pub fn shade_batch(
        &self,
        rays: &RayBatch,
        hits: &HitBatch,
        out: &mut RadianceBatch,
        stats: &mut ShadeStats,
    ) {
        let n = rays.len();
        let mut shaded: Vec<(Vec3, u64)> = Vec::with_capacity(n);
        (0..n)
            .into_par_iter()
            .with_min_len(16)
            .map(|i| {
                if !rays.alive[i] {
                    return (Vec3::ZERO, 0);
                }
                let (origin, direction) =
                    (Vec3::from(rays.origin(i)), Vec3::from(rays.direction(i)));
                let mut rays_traced = 0;
                let first_hit = match hits.triangle.get(i) {
                    Some(&HitBatch::MISS) => None,
                    Some(&triangle) => Some(Hit {
                        t: hits.t[i],
                        triangle,
                        u: hits.u[i],
                        v: hits.v[i],
                    }),
                    None => {
                        rays_traced += 1;
                        self.accel.intersect(origin, direction, f32::INFINITY)
                    }
                };
                let mut rng =
                    Rng::for_sample(self.seed ^ SHADE_STREAM_KEY, rays.pixel[i], rays.sample[i]);
                let radiance = self.path_radiance(
                    origin,
                    direction,
                    first_hit,
                    &mut rng,
                    &mut rays_traced,
                    Strategy::Mis,
                );
                (radiance, rays_traced)
            })
            .collect_into_vec(&mut shaded);

        out.r.clear();
        out.g.clear();
        out.b.clear();
        for &(radiance, rays_traced) in &shaded {
            out.r.push(radiance.x);
            out.g.push(radiance.y);
            out.b.push(radiance.z);
            stats.rays_traced += rays_traced;
        }
    }
}
