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
pub(crate) mod tests;

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::{BatchParallelism, PacketGauge, SceneAccel};
use crate::batch::{Hit, HitBatch, RayBatch};
use crate::sampling::Rng;
use crate::scene::MaterialLibrary;
use bsdf::{EVAL_BATCH, EvalBatch};
use integrator::{Path, Step, Strategy, Vertex};

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

impl RadianceBatch {
    /// Whether ray `i`'s path brought any light: a non-finite value counts, as it is not
    /// known to be none (Weight rejects it).
    #[inline(always)]
    pub fn found_light(&self, i: usize) -> bool {
        // `|`, not `||`: no branch per channel where a batch's rays are tested in a loop.
        (self.r[i] != 0.0) | (self.g[i] != 0.0) | (self.b[i] != 0.0)
    }
}

/// Counters a shading pass adds to: the work done, and where the light came from (or why
/// none came), so that a black image can say why it is black.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShadeStats {
    /// Rays traced inside shading (bounce and shadow rays).
    pub rays_traced: u64,
    /// Camera rays that hit nothing: they see the environment.
    pub camera_rays_escaped: u64,
    /// Bounce rays that hit nothing: they bring the environment's light.
    pub bounce_rays_escaped: u64,
    /// Path vertices on emitting surfaces.
    pub emitter_hits: u64,
    /// Light samples drawn at path vertices (next-event estimation).
    pub light_samples: u64,
    /// … of which the light lay behind the surface (below its geometric horizon).
    pub light_samples_behind: u64,
    /// … of which the shadow ray was blocked.
    pub light_samples_blocked: u64,
    /// … of which the light arrived and was added.
    pub light_samples_reached: u64,
}

impl std::ops::AddAssign for ShadeStats {
    fn add_assign(&mut self, other: ShadeStats) {
        self.rays_traced += other.rays_traced;
        self.camera_rays_escaped += other.camera_rays_escaped;
        self.bounce_rays_escaped += other.bounce_rays_escaped;
        self.emitter_hits += other.emitter_hits;
        self.light_samples += other.light_samples;
        self.light_samples_behind += other.light_samples_behind;
        self.light_samples_blocked += other.light_samples_blocked;
        self.light_samples_reached += other.light_samples_reached;
    }
}

impl ShadeStats {
    /// What was counted since `earlier` (an earlier copy of these counters).
    pub fn since(&self, earlier: &ShadeStats) -> ShadeStats {
        ShadeStats {
            rays_traced: self.rays_traced - earlier.rays_traced,
            camera_rays_escaped: self.camera_rays_escaped - earlier.camera_rays_escaped,
            bounce_rays_escaped: self.bounce_rays_escaped - earlier.bounce_rays_escaped,
            emitter_hits: self.emitter_hits - earlier.emitter_hits,
            light_samples: self.light_samples - earlier.light_samples,
            light_samples_behind: self.light_samples_behind - earlier.light_samples_behind,
            light_samples_blocked: self.light_samples_blocked - earlier.light_samples_blocked,
            light_samples_reached: self.light_samples_reached - earlier.light_samples_reached,
        }
    }
}

impl std::ops::Add for ShadeStats {
    type Output = ShadeStats;

    fn add(mut self, other: ShadeStats) -> ShadeStats {
        self += other;
        self
    }
}

impl std::iter::Sum for ShadeStats {
    fn sum<I: Iterator<Item = ShadeStats>>(iter: I) -> ShadeStats {
        iter.fold(ShadeStats::default(), |a, b| a + b)
    }
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
    /// How a batch's paths are shared among the threads (the same radiance either way).
    pub parallelism: BatchParallelism,
}

impl Shader<'_> {
    /// Radiance arriving along each alive ray of `rays` (world frame, unit directions), given
    /// its closest hit in `hits`. Dead rays get zero. Each ray draws its random numbers from
    /// its own stream keyed by (seed, pixel, sample), so results do not depend on batching.
    ///
    /// The batch's throughput (`tr`, `tg`, `tb`) is *not* applied: `out` holds radiance, and
    /// the caller weights it. A ray without an entry in `hits` is traced here.
    ///
    /// The paths advance together, one vertex at a time (a wavefront): every path takes its
    /// next step (`Shader::advance`, the same step the one-ray reference
    /// `Shader::path_radiance` takes), then all the bounce rays are traced as one batch,
    /// grouped by direction octant so that the batch call's 8-ray packets hold rays of one
    /// octant leaving neighbouring pixels. The hits are exactly those of single rays and each
    /// path keeps its own random stream, so the result is the reference's, bit for bit.
    pub fn shade_batch(
        &self,
        rays: &RayBatch,
        hits: &HitBatch,
        out: &mut RadianceBatch,
        stats: &mut ShadeStats,
    ) {
        match self.parallelism {
            // Nothing under it runs other tasks on this thread, so the thread's own scratch
            // is free, and warm in its caches.
            BatchParallelism::OneThread => SHADE_SCRATCH
                .with_borrow_mut(|scratch| self.shade_batch_in(rays, hits, out, stats, scratch)),
            // Its tasks may run another batch's on this thread: a scratch of its own.
            BatchParallelism::Spread => {
                self.shade_batch_in(rays, hits, out, stats, &mut ShadeScratch::default())
            }
        }
    }

    /// [`Shader::shade_batch`] with its working memory in `scratch`, which keeps its capacity
    /// from one call to the next.
    fn shade_batch_in(
        &self,
        rays: &RayBatch,
        hits: &HitBatch,
        out: &mut RadianceBatch,
        stats: &mut ShadeStats,
        scratch: &mut ShadeScratch,
    ) {
        let ShadeScratch { live, bounce } = scratch;
        let n = rays.len();
        // Room for every ray's path: how many start varies from pass to pass.
        live.clear();
        live.reserve(n);
        bounce.clear_with_room(n);
        out.r.clear();
        out.r.resize(n, 0.0);
        out.g.clear();
        out.g.resize(n, 0.0);
        out.b.clear();
        out.b.resize(n, 0.0);
        // The paths still going, in the order their rays are traced.
        let start = |i: usize| {
            if !rays.alive[i] {
                return None;
            }
            let origin = Vec3::from(rays.origin(i));
            let path = Path::start(origin, Vec3::from(rays.direction(i)))?;
            let (hit, rays_traced) = if i < hits.len() {
                (hits.hit(i), 0)
            } else {
                (
                    self.accel.intersect(origin, path.direction, f32::INFINITY),
                    1,
                )
            };
            Some(PathSlot {
                index: i as u32,
                path,
                rng: Rng::for_sample(self.seed ^ SHADE_STREAM_KEY, rays.pixel[i], rays.sample[i]),
                hit,
                next: None,
                rays_traced,
            })
        };
        match self.parallelism {
            BatchParallelism::OneThread => live.extend((0..n).filter_map(start)),
            BatchParallelism::Spread => {
                live.par_extend((0..n).into_par_iter().with_min_len(64).filter_map(start))
            }
        }

        stats.rays_traced += live.iter().map(|slot| slot.rays_traced).sum::<u64>();
        while !live.is_empty() {
            // Deep paths leave few live ones per step; tasks of fewer than 64 paths cost
            // more to split than they save (default scene, depth 8: 6 % slower at 16).
            // Each task counts into its own stats, summed (integers: in any order alike).
            *stats += live
                .par_chunks_mut(self.parallelism.min_task_len(64))
                .map(|slots| self.step_paths(slots))
                .sum::<ShadeStats>();
            live.retain(|slot| {
                if slot.next.is_none() {
                    let radiance = slot.path.radiance();
                    let i = slot.index as usize;
                    (out.r[i], out.g[i], out.b[i]) = (radiance.x, radiance.y, radiance.z);
                }
                slot.next.is_some()
            });
            stats.rays_traced += live.len() as u64;
            bounce.trace(self.accel, live, self.parallelism);
        }
    }
}

/// Path vertices [`Shader::step_paths`] takes through their first halves before making their
/// BSDF evaluations together (at most two each: an [`EvalBatch`]'s worth).
const VERTEX_GROUP: usize = EVAL_BATCH / 2;

/// How many paths ahead of the one it steps [`Shader::step_paths`] asks for a hit's vertex
/// data (twice as many for its triangle, half as many for its texels). Chosen by measurement:
/// 2 to 8 were alike within noise (BENCHMARKS.md, "Surface data asked for ahead").
const PREFETCH_AHEAD: usize = 4;

impl Shader<'_> {
    /// Takes one step of every path in `slots` ([`Shader::advance`]'s, with the BSDF evaluations of
    /// [`VERTEX_GROUP`] vertices made together between their halves), in order; counts what
    /// the steps did.
    ///
    /// Which triangle a path hit is known before its step, so its surface data (scattered
    /// over a large scene's arrays: several cache misses a hit) is asked for a few paths ahead,
    /// in stages: the vertices' addresses are in the triangle's record, and the texels' depend
    /// on the UVs at the vertices.
    fn step_paths(&self, slots: &mut [PathSlot]) -> ShadeStats {
        let mut counts = ShadeStats::default();
        let hit_at = |slots: &[PathSlot], i: usize| slots.get(i).and_then(|slot| slot.hit);
        let textured = !self.materials.textures.is_empty();
        let mut batch = EvalBatch::new();
        let mut vertices: [Option<Vertex>; VERTEX_GROUP] = [None; VERTEX_GROUP];
        for group in (0..slots.len()).step_by(VERTEX_GROUP) {
            let end = (group + VERTEX_GROUP).min(slots.len());
            batch.clear();
            for i in group..end {
                if let Some(hit) = hit_at(slots, i + 2 * PREFETCH_AHEAD) {
                    self.accel.prefetch_triangle(hit.triangle);
                }
                if let Some(hit) = hit_at(slots, i + PREFETCH_AHEAD) {
                    self.accel.prefetch_vertices(hit.triangle);
                }
                if let Some(hit) = hit_at(slots, i + PREFETCH_AHEAD / 2)
                    && textured
                {
                    self.prefetch_texels(hit);
                }
                let slot = &mut slots[i];
                slot.next = None;
                vertices[i - group] = self.begin_vertex(
                    &mut slot.path,
                    slot.hit.take(),
                    &mut slot.rng,
                    &mut counts,
                    Strategy::Mis,
                    &mut batch,
                );
            }
            batch.run();
            for i in group..end {
                let Some(vertex) = &vertices[i - group] else {
                    continue;
                };
                let slot = &mut slots[i];
                let step = self.finish_vertex(
                    &mut slot.path,
                    vertex,
                    &batch,
                    &mut slot.rng,
                    &mut counts,
                    Strategy::Mis,
                );
                slot.next = match step {
                    Step::Continue { origin } => Some(origin),
                    Step::Done => None,
                };
            }
        }
        counts
    }

    /// Asks for the texels the hit's material reads there ([`material::shading_point`]'s
    /// look-ups), once its vertices' UVs have arrived.
    #[inline(always)]
    fn prefetch_texels(&self, hit: Hit) {
        let material = self
            .materials
            .get(self.accel.triangle_material(hit.triangle));
        let mut textures = material.shaded_textures().peekable();
        if textures.peek().is_none() {
            return;
        }
        let uv = self.accel.uv_at(hit.triangle, hit.u, hit.v);
        for texture in textures.filter_map(|r| self.materials.textures.get(r.texture)) {
            texture.prefetch(uv);
        }
    }
}

/// What [`Shader::shade_batch_in`] works in: the live paths and the bounce rays of a step,
/// kept between calls so that their vectors keep their capacity.
#[derive(Default)]
struct ShadeScratch {
    live: Vec<PathSlot>,
    bounce: BounceRays,
}

thread_local! {
    /// The thread's scratch for the batches it shades alone: warm in its caches, where a
    /// scratch kept per tile would come cold from memory for each tile.
    static SHADE_SCRATCH: std::cell::RefCell<ShadeScratch> =
        std::cell::RefCell::new(ShadeScratch::default());
}

/// A path of the wavefront and what its next step needs.
struct PathSlot {
    /// The ray of the batch the path started from.
    index: u32,
    path: Path,
    rng: Rng,
    /// The closest hit of the path's current ray, once traced.
    hit: Option<Hit>,
    /// After a step: where the next ray leaves from (`None`: the path has ended).
    next: Option<Vec3>,
    /// Rays traced to start the path (1 when its camera ray came without a hit).
    rays_traced: u64,
}

/// The bounce rays of one wavefront step, as a batch.
#[derive(Default)]
struct BounceRays {
    /// Indices into the live paths, grouped by direction octant.
    order: Vec<u32>,
    rays: RayBatch,
    hits: HitBatch,
    /// How full this thread's bounce packets have run lately (see
    /// [`SceneAccel::intersect_batch_gauged`]): kept with the thread's scratch, from batch to
    /// batch.
    gauge: PacketGauge,
}

impl BounceRays {
    /// Empties the arrays, with room for `paths` bounce rays.
    fn clear_with_room(&mut self, paths: usize) {
        self.order.clear();
        self.order.reserve(paths);
        self.rays.clear();
        self.rays.reserve(paths);
        self.hits.resize(0);
        self.hits.reserve(paths);
    }

    /// Traces the next ray of every path in `live` (all have one) and hands each its hit.
    /// The rays are grouped by direction octant, stably (a counting sort), so that within an
    /// octant they stay in pixel order: the 8-ray packets then hold one octant's rays from
    /// neighbouring pixels. On one thread they walk as packets where the thread's gauge says
    /// packets pay (on a scene of a million small triangles bounce rays part ways, and go one by
    /// one: see [`crate::accel::PacketUse`]).
    fn trace(&mut self, accel: &SceneAccel, live: &mut [PathSlot], parallelism: BatchParallelism) {
        let octant = |slot: &PathSlot| {
            let d = slot.path.direction;
            (d.x < 0.0) as usize | ((d.y < 0.0) as usize) << 1 | ((d.z < 0.0) as usize) << 2
        };
        let mut starts = [0usize; 9];
        for slot in live.iter() {
            starts[octant(slot) + 1] += 1;
        }
        for k in 1..9 {
            starts[k] += starts[k - 1];
        }
        self.order.resize(live.len(), 0);
        for (k, slot) in live.iter().enumerate() {
            let o = octant(slot);
            self.order[starts[o]] = k as u32;
            starts[o] += 1;
        }
        let rays = &mut self.rays;
        rays.resize(live.len());
        for (j, &k) in self.order.iter().enumerate() {
            let slot = &live[k as usize];
            let origin = slot.next.expect("live paths have a next ray");
            let direction = slot.path.direction;
            (rays.ox[j], rays.oy[j], rays.oz[j]) = (origin.x, origin.y, origin.z);
            (rays.dx[j], rays.dy[j], rays.dz[j]) = (direction.x, direction.y, direction.z);
        }
        match parallelism {
            BatchParallelism::OneThread => {
                accel.intersect_batch_gauged(rays, &mut self.hits, &mut self.gauge)
            }
            BatchParallelism::Spread => {
                accel.intersect_batch_with(rays, &mut self.hits, parallelism)
            }
        }
        for (j, &k) in self.order.iter().enumerate() {
            live[k as usize].hit = self.hits.hit(j);
        }
    }
}
