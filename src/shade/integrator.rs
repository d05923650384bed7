//! The unidirectional path tracer: BSDF-sampled paths with next-event estimation at every
//! vertex, combined by multiple importance sampling (power heuristic).
//!
//! - Emission seen directly by the camera ray is counted in full; emission reached by a BSDF
//!   sample is weighted against the chance light sampling had of finding it, and light
//!   samples against the chance the BSDF had. Delta lights (point, spot, directional) can only
//!   be reached by light sampling, so they take no weight.
//! - `max_depth` counts bounces: 0 shows emitters and the environment only, 1 is direct
//!   lighting (one light sample plus one BSDF sample at the first hit), each further unit adds
//!   one indirect bounce.
//! - After [`RUSSIAN_ROULETTE_START`] bounces a path survives with probability equal to its
//!   throughput's largest component, at most [`MAX_SURVIVAL`], and is reweighted by its
//!   inverse: unbiased, and every path ends even without a depth limit (a white mirror box
//!   would otherwise keep a throughput of 1 forever).
//! - Surfaces scatter into the hemisphere of their geometric normal only (no transmission);
//!   single-sided materials shade on both sides, only their emission is one-sided.

use glam::Vec3;

use super::bsdf::{BsdfSample, EvalBatch, MetalRoughBsdf};
use super::frame::Frame;
use super::lights::{LightSample, ShadowTarget, direction_and_distance};
use super::material::shading_point;
use super::{ShadeStats, Shader};
use crate::accel::spawn::offset_along_normal;
use crate::batch::Hit;
use crate::sampling::Rng;

/// Bounces after which Russian roulette may end a path.
pub const RUSSIAN_ROULETTE_START: u32 = 3;

/// Largest probability with which Russian roulette lets a path continue.
pub const MAX_SURVIVAL: f32 = 0.95;

/// How emission reached by BSDF samples and by light samples is combined. Only [`Strategy::Mis`]
/// is used for rendering; the single strategies exist to validate it (each alone is unbiased
/// for area lights and the environment, so all three must agree).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) enum Strategy {
    Mis,
    /// Area lights and the environment by light sampling only (delta lights as always).
    LightOnly,
    /// Area lights and the environment by BSDF sampling only (delta lights as always).
    BsdfOnly,
}

impl Strategy {
    /// Weight of emission found by a BSDF sample of density `bsdf_pdf`.
    fn bsdf_weight(self, bsdf_pdf: f32, light_pdf: f32) -> f32 {
        match self {
            Strategy::Mis => power_heuristic(bsdf_pdf, light_pdf),
            Strategy::LightOnly => 0.0,
            Strategy::BsdfOnly => 1.0,
        }
    }

    /// Weight of a light sample of density `light_pdf` on an area light or the environment.
    fn light_weight(self, light_pdf: f32, bsdf_pdf: f32) -> f32 {
        match self {
            Strategy::Mis => power_heuristic(light_pdf, bsdf_pdf),
            Strategy::LightOnly => 1.0,
            Strategy::BsdfOnly => 0.0,
        }
    }
}

/// Power heuristic (β = 2) weight of the strategy that drew a sample with density `chosen`,
/// against the one with density `other`. Written as a ratio so huge densities cannot overflow.
pub fn power_heuristic(chosen: f32, other: f32) -> f32 {
    if !(chosen > 0.0) {
        return 0.0;
    }
    if !(other > 0.0) {
        return 1.0;
    }
    let ratio = other / chosen;
    let weight = 1.0 / (1.0 + ratio * ratio);
    if weight.is_finite() { weight } else { 0.0 }
}

/// What a path carries from one vertex to the next.
#[derive(Clone, Copy, Debug)]
pub(super) struct Path {
    /// Unit direction of the path's current ray.
    pub direction: Vec3,
    radiance: Vec3,
    throughput: Vec3,
    /// Density with which the BSDF drew `direction`; `None` for the camera ray.
    bsdf_pdf: Option<f32>,
    bounces: u32,
}

impl Path {
    /// A path whose first ray leaves `origin` along `direction`; `None` when no ray can be
    /// made of them.
    pub fn start(origin: Vec3, direction: Vec3) -> Option<Path> {
        let direction = direction.normalize_or_zero();
        (direction != Vec3::ZERO && origin.is_finite()).then_some(Path {
            direction,
            radiance: Vec3::ZERO,
            throughput: Vec3::ONE,
            bsdf_pdf: None,
            bounces: 0,
        })
    }

    /// Radiance gathered so far; 0 if it is not finite.
    pub fn radiance(&self) -> Vec3 {
        if self.radiance.is_finite() {
            self.radiance
        } else {
            Vec3::ZERO
        }
    }
}

/// What [`Shader::advance`] made of a path.
pub(super) enum Step {
    /// Trace the path's next ray from `origin` along its direction.
    Continue {
        origin: Vec3,
    },
    Done,
}

impl Shader<'_> {
    /// Radiance (nits) arriving at `origin` from `direction` (world frame), given the ray's
    /// closest hit, which the caller has already traced. Non-finite results are returned as 0.
    pub fn radiance(
        &self,
        origin: Vec3,
        direction: Vec3,
        first_hit: Option<Hit>,
        rng: &mut Rng,
    ) -> Vec3 {
        let mut stats = ShadeStats::default();
        self.path_radiance(origin, direction, first_hit, rng, &mut stats, Strategy::Mis)
    }

    /// [`Shader::radiance`], counting what it does into `stats` (the camera ray itself not
    /// among the rays traced): the reference, depth first, one ray at a time.
    /// [`Shader::shade_batch`] takes the same steps ([`Shader::advance`]) for a whole batch of
    /// paths, tracing their bounce rays together.
    pub(super) fn path_radiance(
        &self,
        origin: Vec3,
        direction: Vec3,
        first_hit: Option<Hit>,
        rng: &mut Rng,
        stats: &mut ShadeStats,
        strategy: Strategy,
    ) -> Vec3 {
        let Some(mut path) = Path::start(origin, direction) else {
            return Vec3::ZERO;
        };
        let mut hit = first_hit;
        while let Step::Continue { origin } = self.advance(&mut path, hit, rng, stats, strategy) {
            hit = self.accel.intersect(origin, path.direction, f32::INFINITY);
            stats.rays_traced += 1;
        }
        path.radiance()
    }

    /// One path vertex: takes the closest hit of the path's current ray (`None`: it escaped),
    /// adds the emission and direct light found there, and either ends the path or turns it
    /// into the next ray, leaving from the returned origin along `path.direction`. Shadow
    /// rays and what happened are counted into `stats`. The reference's way: the vertex's two
    /// halves with its BSDF evaluations between them, one at a time; the wavefront makes the
    /// evaluations of many vertices at once (`Shader::step_paths`), with the same results.
    pub(super) fn advance(
        &self,
        path: &mut Path,
        hit: Option<Hit>,
        rng: &mut Rng,
        stats: &mut ShadeStats,
        strategy: Strategy,
    ) -> Step {
        let mut evaluations = OneByOne::default();
        let Some(vertex) = self.begin_vertex(path, hit, rng, stats, strategy, &mut evaluations)
        else {
            return Step::Done;
        };
        self.finish_vertex(path, &vertex, &evaluations, rng, stats, strategy)
    }

    /// A vertex's first half: the emission and environment the path sees, everything the
    /// vertex draws (its light sample, then the BSDF sample's direction), and the BSDF
    /// evaluations it needs asked of `evaluator`; `None` when the path ends here (it escaped,
    /// or has taken its last bounce).
    pub(super) fn begin_vertex(
        &self,
        path: &mut Path,
        hit: Option<Hit>,
        rng: &mut Rng,
        stats: &mut ShadeStats,
        strategy: Strategy,
        evaluator: &mut impl Evaluator,
    ) -> Option<Vertex> {
        let direction = path.direction;
        let Some(current) = hit else {
            if path.bsdf_pdf.is_none() {
                stats.camera_rays_escaped += 1;
            } else {
                stats.bounce_rays_escaped += 1;
            }
            let weight = path.bsdf_pdf.map_or(1.0, |pdf| {
                strategy.bsdf_weight(
                    pdf,
                    self.lights.environment_pdf(self.environment, direction),
                )
            });
            path.radiance += path.throughput * self.environment.radiance(direction) * weight;
            return None;
        };
        let surface = self.accel.surface(&current, direction);
        let wo = -direction;
        let material = self.materials.get(surface.material);
        let shading = shading_point(material, &self.materials.textures, &surface, wo);

        if shading.emission != Vec3::ZERO {
            stats.emitter_hits += 1;
            let weight = path.bsdf_pdf.map_or(1.0, |pdf| {
                let cos_light = surface.geometric_normal.dot(wo);
                strategy.bsdf_weight(
                    pdf,
                    self.lights
                        .triangle_pdf(current.triangle, current.t, cos_light),
                )
            });
            path.radiance += path.throughput * shading.emission * weight;
        }

        path.bounces += 1;
        if path.bounces > self.max_depth {
            return None;
        }
        // One light sample, weighed in the second half (a light below the surface's geometric
        // horizon adds nothing).
        let light = self
            .lights
            .sample(
                surface.position,
                self.accel,
                self.materials,
                self.environment,
                rng,
            )
            .and_then(|light| {
                stats.light_samples += 1;
                let behind = light.direction.dot(surface.geometric_normal) <= 0.0;
                stats.light_samples_behind += u64::from(behind);
                (!behind).then_some(light)
            });
        let frame = shading.frame;
        let wo_local = frame.to_local(wo);
        let (u_lobe, u) = (rng.next_f32(), rng.next_2d());
        let bsdf = &shading.bsdf;
        // Without a start wo is below the surface, where the BSDF is zero: no light is
        // reflected and no sample drawn.
        let start = bsdf.begin_sample(wo_local, u_lobe, u);
        let light = light.map(|light| {
            let wi = frame.to_local(light.direction);
            // The BSDF is zero with the light's direction below the shading surface too.
            let asked = start
                .filter(|_| wi.z > 0.0)
                .map(|start| evaluator.ask(bsdf, wo_local, wi, start.p_specular));
            (light, wi.z, asked)
        });
        let sample = start.and_then(|start| {
            let wi = start.wi?;
            Some((wi, evaluator.ask(bsdf, wo_local, wi, start.p_specular)))
        });
        Some(Vertex {
            position: surface.position,
            geometric_normal: surface.geometric_normal,
            spawn_offset: surface.spawn_offset,
            frame,
            light,
            sample,
        })
    }

    /// A vertex's second half, once `evaluator` has made the evaluations its first half asked
    /// for: the light sample's contribution (its shadow ray traced), then the BSDF sample
    /// taken or the path ended.
    pub(super) fn finish_vertex(
        &self,
        path: &mut Path,
        vertex: &Vertex,
        evaluator: &impl Evaluator,
        rng: &mut Rng,
        stats: &mut ShadeStats,
        strategy: Strategy,
    ) -> Step {
        path.radiance += path.throughput * self.direct_light(vertex, evaluator, stats, strategy);

        let Some((wi_local, asked)) = vertex.sample else {
            return Step::Done;
        };
        let (value, pdf) = evaluator.answer(asked);
        let Some(sample) = BsdfSample::of(wi_local, value, pdf) else {
            return Step::Done;
        };
        let wi = vertex.frame.to_world(sample.wi);
        // A shading normal can send a sample under the real surface: it would leak light.
        if wi.dot(vertex.geometric_normal) <= 0.0 {
            return Step::Done;
        }
        path.throughput *= sample.value * (sample.wi.z / sample.pdf);
        if !path.throughput.is_finite() {
            return Step::Done;
        }
        if path.bounces >= RUSSIAN_ROULETTE_START {
            let survival = path.throughput.max_element().min(MAX_SURVIVAL);
            if !(survival > 0.0) || rng.next_f32() >= survival {
                return Step::Done;
            }
            path.throughput /= survival;
        }
        path.direction = wi;
        path.bsdf_pdf = Some(sample.pdf);
        Step::Continue {
            origin: vertex.spawn_origin(wi),
        }
    }

    /// The vertex's light sample's reflected radiance towards wo (the BSDF's value and density
    /// there answered by `evaluator`), MIS-weighted against BSDF sampling for area lights and
    /// the environment.
    fn direct_light(
        &self,
        vertex: &Vertex,
        evaluator: &impl Evaluator,
        stats: &mut ShadeStats,
        strategy: Strategy,
    ) -> Vec3 {
        let Some((light, cos_light, asked)) = vertex.light else {
            return Vec3::ZERO;
        };
        let (value, bsdf_pdf) = asked.map_or((Vec3::ZERO, 0.0), |i| evaluator.answer(i));
        let reflected = value * light.radiance * cos_light;
        if reflected.max_element() <= 0.0 {
            return Vec3::ZERO;
        }
        let weight = if light.is_delta {
            1.0
        } else {
            strategy.light_weight(light.pdf, bsdf_pdf)
        };
        if weight <= 0.0 {
            return Vec3::ZERO;
        }

        let wi = light.direction;
        let origin = vertex.spawn_origin(wi);
        let shadow_ray = match light.target {
            ShadowTarget::Infinite => Some((wi, f32::INFINITY)),
            ShadowTarget::Point(position) => direction_and_distance(origin, position),
            ShadowTarget::Surface {
                position,
                normal,
                offset,
            } => direction_and_distance(
                origin,
                offset_along_normal(position, normal, offset, origin - position),
            ),
        };
        let Some((shadow_direction, distance)) = shadow_ray else {
            return Vec3::ZERO;
        };
        stats.rays_traced += 1;
        if self.accel.occluded(origin, shadow_direction, distance) {
            stats.light_samples_blocked += 1;
            return Vec3::ZERO;
        }
        stats.light_samples_reached += 1;
        reflected * (weight / light.pdf)
    }
}

/// A path vertex between its two halves ([`Shader::begin_vertex`] and
/// [`Shader::finish_vertex`]): what the second half needs of the surface and of what the first
/// drew. Kept small: the wavefront holds a group of them between the halves.
#[derive(Clone, Copy, Debug)]
pub(super) struct Vertex {
    /// Where rays leave the surface from ([`SurfacePoint::spawn_origin`](crate::accel::SurfacePoint::spawn_origin)).
    position: Vec3,
    geometric_normal: Vec3,
    spawn_offset: f32,
    /// The shading frame.
    frame: Frame,
    /// The light sample, when one was drawn above the surface's geometric horizon: with its
    /// direction's cosine to the shading normal, and its evaluation asked of the evaluator
    /// (`None` where the BSDF is zero: wo or that direction below the shading surface).
    light: Option<(LightSample, f32, Option<u8>)>,
    /// The BSDF sample's direction in the shading frame and its evaluation asked of the
    /// evaluator (`None`: the path ends after the light sample).
    sample: Option<(Vec3, u8)>,
}

impl Vertex {
    /// [`SurfacePoint::spawn_origin`](crate::accel::SurfacePoint::spawn_origin) of the vertex's surface point.
    fn spawn_origin(&self, direction: Vec3) -> Vec3 {
        offset_along_normal(
            self.position,
            self.geometric_normal,
            self.spawn_offset,
            direction,
        )
    }
}

/// Where the BSDF evaluations of path vertices are made: asked for in a vertex's first half,
/// answered in its second.
pub(super) trait Evaluator {
    /// Asks for `bsdf`'s value and density at (`wo`, `wi`), both above the surface, with the
    /// specular lobe's probability `p_specular` at `wo`; returns the answer's index.
    fn ask(&mut self, bsdf: &MetalRoughBsdf, wo: Vec3, wi: Vec3, p_specular: f32) -> u8;
    /// Answer `i`.
    fn answer(&self, i: u8) -> (Vec3, f32);
}

/// The reference's evaluator: each evaluation made when it is asked for (a vertex asks for
/// two at most).
#[derive(Default)]
struct OneByOne {
    answers: [(Vec3, f32); 2],
    len: u8,
}

impl Evaluator for OneByOne {
    fn ask(&mut self, bsdf: &MetalRoughBsdf, wo: Vec3, wi: Vec3, p_specular: f32) -> u8 {
        let i = self.len;
        self.answers[usize::from(i)] = bsdf.eval_and_pdf_above(wo, wi, p_specular);
        self.len += 1;
        i
    }

    fn answer(&self, i: u8) -> (Vec3, f32) {
        self.answers[usize::from(i)]
    }
}

/// The wavefront's evaluator: the evaluations of a group of vertices made together, eight at
/// a time, once every vertex of the group has asked ([`EvalBatch::run`]).
impl Evaluator for EvalBatch {
    fn ask(&mut self, bsdf: &MetalRoughBsdf, wo: Vec3, wi: Vec3, p_specular: f32) -> u8 {
        self.push(bsdf, wo, wi, p_specular) as u8
    }

    fn answer(&self, i: u8) -> (Vec3, f32) {
        self.result(usize::from(i))
    }
}
