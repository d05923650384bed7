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

use super::lights::{ShadowTarget, direction_and_distance};
use super::material::{ShadingPoint, shading_point};
use super::{ShadeStats, Shader};
use crate::accel::SurfacePoint;
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
    /// rays and what happened are counted into `stats`.
    pub(super) fn advance(
        &self,
        path: &mut Path,
        hit: Option<Hit>,
        rng: &mut Rng,
        stats: &mut ShadeStats,
        strategy: Strategy,
    ) -> Step {
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
            return Step::Done;
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
            return Step::Done;
        }
        path.radiance +=
            path.throughput * self.direct_light(&surface, &shading, wo, rng, stats, strategy);

        let wo_local = shading.frame.to_local(wo);
        let Some(sample) = shading.bsdf.sample(wo_local, rng.next_f32(), rng.next_2d()) else {
            return Step::Done;
        };
        let wi = shading.frame.to_world(sample.wi);
        // A shading normal can send a sample under the real surface: it would leak light.
        if wi.dot(surface.geometric_normal) <= 0.0 {
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
            origin: surface.spawn_origin(wi),
        }
    }

    /// One light sample at a surface point: reflected radiance towards `wo`, MIS-weighted
    /// against BSDF sampling for area lights and the environment.
    fn direct_light(
        &self,
        surface: &SurfacePoint,
        shading: &ShadingPoint,
        wo: Vec3,
        rng: &mut Rng,
        stats: &mut ShadeStats,
        strategy: Strategy,
    ) -> Vec3 {
        let Some(light) = self.lights.sample(
            surface.position,
            self.accel,
            self.materials,
            self.environment,
            rng,
        ) else {
            return Vec3::ZERO;
        };
        stats.light_samples += 1;
        let wi = light.direction;
        if wi.dot(surface.geometric_normal) <= 0.0 {
            stats.light_samples_behind += 1;
            return Vec3::ZERO;
        }
        let (wo_local, wi_local) = (shading.frame.to_local(wo), shading.frame.to_local(wi));
        let (value, bsdf_pdf) = shading.bsdf.eval_and_pdf(wo_local, wi_local);
        let reflected = value * light.radiance * wi_local.z;
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

        let origin = surface.spawn_origin(wi);
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
