//! Light sources prepared for next-event estimation: punctual lights, emissive triangles and
//! the environment.
//!
//! One light is drawn per shading point. The choice is made among *slots* (each punctual
//! light, all emissive triangles together, the environment) in proportion to an estimate of
//! each slot's power, mixed with a uniform share so no light is starved; within the triangle
//! slot, a triangle is drawn by area × emitted luminance and then a uniform point on it.
//!
//! Punctual lights follow `KHR_lights_punctual` in photometric units: a point or spot light of
//! intensity I (cd) lights a surface at distance d facing it with illuminance I / d² (lux); a
//! spot's cone uses the extension's smooth falloff, squared linear in cos θ between the outer
//! and inner angles; a directional light delivers its illuminance (lux) from one direction.
//! Where a light has a `range`, the extension's recommended window
//! clamp(1 − (d / range)⁴, 0, 1) multiplies the inverse-square law, as the file's author saw it.

use std::collections::HashMap;
use std::f32::consts::PI;

use bevy_ecs::resource::Resource;
use glam::{Vec2, Vec3};

use super::bsdf::luminance;
use super::distribution::Distribution1D;
use super::environment::Environment;
use super::material::{emits_towards, emitted_radiance};
use super::warp::uniform_triangle;
use crate::accel::SceneAccel;
use crate::sampling::Rng;
use crate::scene::{MaterialLibrary, PunctualLight};

/// Share of slot selection spread uniformly over the lights, whatever their power estimate.
const UNIFORM_SELECTION_SHARE: f32 = 0.1;

/// Whether next-event estimation draws directions towards the environment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EnvironmentSampling {
    /// Towards an image environment only. A uniform sky is left to BSDF sampling: its
    /// radiance is the same from every direction, so the integrand L·f·cos θ is proportional
    /// to f·cos θ, which BSDF sampling already draws in proportion (exactly for Lambert).
    /// Uniform-sphere light samples would spend half their directions below the horizon and a
    /// shadow ray per path vertex on adding variance; both estimators are unbiased (the shading
    /// tests compare them).
    #[default]
    ImagesOnly,
    /// Uniform skies too: kept so the tests can check light sampling of a uniform sky.
    Always,
}

/// Where a shadow ray towards a light sample ends.
#[derive(Clone, Copy, Debug)]
pub enum ShadowTarget {
    /// A point light's position: nothing there can block.
    Point(Vec3),
    /// A point on an emissive surface (its unit front normal, and the offset that clears the
    /// surface, see [`crate::accel::SurfacePoint::spawn_origin`]): the shadow ray must stop
    /// short of the surface itself.
    Surface {
        position: Vec3,
        normal: Vec3,
        offset: f32,
    },
    /// Infinitely far (directional light, environment).
    Infinite,
}

/// A light sample seen from a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point towards the light.
    pub direction: Vec3,
    /// Emitted radiance (nits) for area lights and the environment; for delta lights the
    /// illuminance (lux) on a surface facing the light.
    pub radiance: Vec3,
    /// Solid-angle density, selection included; for delta lights the selection probability.
    pub pdf: f32,
    pub is_delta: bool,
    pub target: ShadowTarget,
}

/// An emissive triangle, with what a light sample on it needs, found once when the lights are
/// prepared rather than per sample (each sample took its vertices out of BVH space twice and
/// made its normal with a cross product and a normalisation).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Emitter {
    pub(crate) triangle: u32,
    pub(crate) area: f32,
    /// World-space vertices ([`SceneAccel::triangle_vertices`]).
    vertices: [Vec3; 3],
    /// Unit normal, (p1 − p0) × (p2 − p0) normalised.
    normal: Vec3,
    /// [`SceneAccel::triangle_spawn_offset`].
    spawn_offset: f32,
    /// [`SceneAccel::triangle_material`].
    material: Option<usize>,
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum LightSlot {
    Punctual(usize),
    Triangles,
    Environment,
}

/// All light sources, prepared for sampling: punctual lights, emissive triangles, environment.
#[derive(Resource)]
pub struct LightSet {
    pub(crate) punctual: Vec<PunctualLight>,
    /// In increasing triangle order.
    pub(crate) emitters: Vec<Emitter>,
    /// Over `emitters`, by area × emitted luminance.
    pub(crate) emitter_distribution: Distribution1D,
    /// Triangle index → index into `emitters`.
    emitter_of_triangle: HashMap<u32, u32>,
    pub(crate) slots: Vec<LightSlot>,
    pub(crate) slot_distribution: Distribution1D,
    pub(crate) triangles_probability: f32,
    pub(crate) environment_probability: f32,
}

impl LightSet {
    /// `environment` must be the one shading will use (the [`super::Shader`]'s).
    pub fn build(
        punctual: &[PunctualLight],
        accel: &SceneAccel,
        materials: &MaterialLibrary,
        environment: &Environment,
    ) -> LightSet {
        Self::build_with(
            punctual,
            accel,
            materials,
            environment,
            EnvironmentSampling::default(),
        )
    }

    /// [`LightSet::build`] with an explicit choice of when the environment is light-sampled.
    pub fn build_with(
        punctual: &[PunctualLight],
        accel: &SceneAccel,
        materials: &MaterialLibrary,
        environment: &Environment,
        environment_sampling: EnvironmentSampling,
    ) -> LightSet {
        let bounds = accel.bounds();
        let scene_radius = if bounds.is_empty() || !(bounds.diagonal() > 0.0) {
            1.0
        } else {
            0.5 * bounds.diagonal()
        };

        let (emitters, emitter_weights) = emissive_triangles(accel, materials);
        let emitter_distribution = Distribution1D::new(emitter_weights.iter().copied());
        let emitter_of_triangle = emitters
            .iter()
            .enumerate()
            .map(|(i, e)| (e.triangle, i as u32))
            .collect();

        // Power estimates (lumens, up to a common factor), as pbrt-v4's Light::Phi.
        let mut slots = Vec::new();
        let mut powers = Vec::new();
        for (i, light) in punctual.iter().enumerate() {
            slots.push(LightSlot::Punctual(i));
            powers.push(punctual_power(light, scene_radius));
        }
        slots.push(LightSlot::Triangles);
        powers.push(PI * emitter_distribution.total() as f32);
        let sample_environment = match environment_sampling {
            EnvironmentSampling::Always => true,
            EnvironmentSampling::ImagesOnly => matches!(environment, Environment::Image(_)),
        };
        if sample_environment {
            slots.push(LightSlot::Environment);
            powers.push(4.0 * PI * PI * scene_radius * scene_radius * environment.mean_luminance());
        }

        let powers: Vec<f32> = powers
            .iter()
            .map(|&p| if p.is_finite() && p > 0.0 { p } else { 0.0 })
            .collect();
        let lit = powers.iter().filter(|&&p| p > 0.0).count();
        let total: f32 = powers.iter().sum();
        let selection = powers.iter().map(|&p| {
            if p > 0.0 {
                (1.0 - UNIFORM_SELECTION_SHARE) * p / total + UNIFORM_SELECTION_SHARE / lit as f32
            } else {
                0.0
            }
        });
        let slot_distribution = Distribution1D::new(selection);
        let probability_of = |wanted: fn(&LightSlot) -> bool| {
            slots
                .iter()
                .position(wanted)
                .map_or(0.0, |i| slot_distribution.probability(i))
        };
        let triangles_probability = probability_of(|s| matches!(s, LightSlot::Triangles));
        let environment_probability = probability_of(|s| matches!(s, LightSlot::Environment));

        LightSet {
            punctual: punctual.to_vec(),
            emitters,
            emitter_distribution,
            emitter_of_triangle,
            slots,
            slot_distribution,
            triangles_probability,
            environment_probability,
        }
    }

    /// Number of emissive triangles that can be sampled.
    pub fn emissive_triangle_count(&self) -> usize {
        self.emitters.len()
    }

    /// Draws a light sample as seen from `position`. `None` when there is no light, or the
    /// drawn one cannot reach the point (behind a single-sided emitter, outside a spot's
    /// cone, in an alpha-mask hole…): a sample of zero.
    pub fn sample(
        &self,
        position: Vec3,
        accel: &SceneAccel,
        materials: &MaterialLibrary,
        environment: &Environment,
        rng: &mut Rng,
    ) -> Option<LightSample> {
        let (slot, _) = self.slot_distribution.sample(rng.next_f32())?;
        let slot_probability = self.slot_distribution.probability(slot);
        match self.slots[slot] {
            LightSlot::Punctual(i) => {
                sample_punctual(&self.punctual[i], position, slot_probability)
            }
            LightSlot::Triangles => self.sample_triangle(position, accel, materials, rng),
            LightSlot::Environment => {
                let sample = environment.sample(rng.next_2d())?;
                Some(LightSample {
                    direction: sample.direction,
                    radiance: sample.radiance,
                    pdf: sample.pdf * slot_probability,
                    is_delta: false,
                    target: ShadowTarget::Infinite,
                })
            }
        }
    }

    fn sample_triangle(
        &self,
        position: Vec3,
        accel: &SceneAccel,
        materials: &MaterialLibrary,
        rng: &mut Rng,
    ) -> Option<LightSample> {
        let (index, _) = self.emitter_distribution.sample(rng.next_f32())?;
        let emitter = self.emitters[index];
        let (u, v) = uniform_triangle(rng.next_2d());
        if accel.is_alpha_hole(emitter.triangle, u, v) {
            return None;
        }
        let [p0, p1, p2] = emitter.vertices;
        let light_point = p0 * (1.0 - u - v) + p1 * u + p2 * v;
        let normal = emitter.normal;
        let to_light = light_point - position;
        let distance2 = to_light.length_squared();
        let direction = to_light.normalize_or_zero();
        let cos_light = -normal.dot(direction);
        let material = materials.get(emitter.material);
        if direction == Vec3::ZERO || !emits_towards(material, cos_light < 0.0) {
            return None;
        }
        let radiance = emitted_radiance(
            material,
            &materials.textures,
            accel.uv_at(emitter.triangle, u, v),
        );
        let pdf =
            self.triangles_probability * self.emitter_distribution.probability(index) * distance2
                / (emitter.area * cos_light.abs());
        (pdf > 0.0 && pdf.is_finite()).then_some(LightSample {
            direction,
            radiance,
            pdf,
            is_delta: false,
            target: ShadowTarget::Surface {
                position: light_point,
                normal,
                offset: emitter.spawn_offset,
            },
        })
    }

    /// Solid-angle density with which [`LightSet::sample`] reaches a point of `triangle` seen at
    /// `distance` and at cosine `cos_light` to the triangle's normal: the light-sampling side of
    /// the MIS weight for emission found by BSDF sampling. Zero for non-emitters.
    pub fn triangle_pdf(&self, triangle: u32, distance: f32, cos_light: f32) -> f32 {
        let Some(&index) = self.emitter_of_triangle.get(&triangle) else {
            return 0.0;
        };
        let emitter = self.emitters[index as usize];
        let cos_light = cos_light.abs();
        if !(cos_light > 0.0) {
            return 0.0;
        }
        let pdf = self.triangles_probability
            * self.emitter_distribution.probability(index as usize)
            * distance
            * distance
            / (emitter.area * cos_light);
        if pdf.is_finite() { pdf } else { 0.0 }
    }

    /// Solid-angle density with which [`LightSet::sample`] draws `direction` from the
    /// environment.
    pub fn environment_pdf(&self, environment: &Environment, direction: Vec3) -> f32 {
        if self.environment_probability > 0.0 {
            self.environment_probability * environment.pdf(direction)
        } else {
            0.0
        }
    }
}

/// Emissive triangles and their selection weights, area × luminance of the emitted radiance
/// (× 2 for double-sided emitters). Textured emission is estimated from seven points of the
/// triangle; a triangle that reads black there keeps a small weight, because its texture may
/// still glow between the points.
fn emissive_triangles(accel: &SceneAccel, materials: &MaterialLibrary) -> (Vec<Emitter>, Vec<f32>) {
    const PROBES: [(f32, f32); 7] = [
        (0.0, 0.0),
        (1.0, 0.0),
        (0.0, 1.0),
        (0.5, 0.0),
        (0.0, 0.5),
        (0.5, 0.5),
        (1.0 / 3.0, 1.0 / 3.0),
    ];
    const UNSEEN_TEXTURE_WEIGHT: f32 = 0.01;
    let mut emitters = Vec::new();
    let mut weights = Vec::new();
    for triangle in 0..accel.triangle_count() as u32 {
        let material_index = accel.triangle_material(triangle);
        let material = materials.get(material_index);
        if !material.is_emissive() {
            continue;
        }
        let vertices @ [p0, p1, p2] = accel.triangle_vertices(triangle);
        let area = 0.5 * (p1 - p0).cross(p2 - p0).length();
        if !(area > 0.0 && area.is_finite()) {
            continue;
        }
        let mean_luminance = if material.emissive_texture.is_some() {
            let sum: f32 = PROBES
                .iter()
                .map(|&(u, v)| {
                    luminance(emitted_radiance(
                        material,
                        &materials.textures,
                        accel.uv_at(triangle, u, v),
                    ))
                })
                .sum();
            let mean = sum / PROBES.len() as f32;
            if mean > 0.0 {
                mean
            } else {
                UNSEEN_TEXTURE_WEIGHT * luminance(material.emissive)
            }
        } else {
            luminance(emitted_radiance(material, &materials.textures, Vec2::ZERO))
        };
        let sides = if material.double_sided { 2.0 } else { 1.0 };
        emitters.push(Emitter {
            triangle,
            area,
            vertices,
            normal: (p1 - p0).cross(p2 - p0).normalize_or_zero(),
            spawn_offset: accel.triangle_spawn_offset(triangle),
            material: material_index,
        });
        weights.push(area * mean_luminance * sides);
    }
    (emitters, weights)
}

/// Power estimate of a punctual light (lumens).
fn punctual_power(light: &PunctualLight, scene_radius: f32) -> f32 {
    match light {
        PunctualLight::Point { intensity, .. } => 4.0 * PI * luminance(*intensity),
        PunctualLight::Spot {
            intensity,
            inner_cone_angle,
            outer_cone_angle,
            ..
        } => {
            let mean_cos = 0.5 * (inner_cone_angle.cos() + outer_cone_angle.cos());
            2.0 * PI * (1.0 - mean_cos).max(0.0) * luminance(*intensity)
        }
        PunctualLight::Directional { illuminance, .. } => {
            PI * scene_radius * scene_radius * luminance(*illuminance)
        }
    }
}

/// glTF's recommended range window, clamp(1 − (d / range)⁴, 0, 1); 1 without a range.
fn range_window(distance: f32, range: Option<f32>) -> f32 {
    match range {
        Some(range) if range > 0.0 => (1.0 - (distance / range).powi(4)).clamp(0.0, 1.0),
        _ => 1.0,
    }
}

/// `KHR_lights_punctual` spot falloff: (clamp((cos θ − cos outer) / (cos inner − cos outer)))².
fn spot_falloff(cos_angle: f32, inner_cone_angle: f32, outer_cone_angle: f32) -> f32 {
    let (cos_inner, cos_outer) = (inner_cone_angle.cos(), outer_cone_angle.cos());
    let scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
    let attenuation = ((cos_angle - cos_outer) * scale).clamp(0.0, 1.0);
    attenuation * attenuation
}

fn sample_punctual(light: &PunctualLight, position: Vec3, selection: f32) -> Option<LightSample> {
    let (direction, illuminance, target) = match *light {
        PunctualLight::Point {
            position: light_position,
            intensity,
            range,
        } => {
            let (direction, distance) = direction_and_distance(position, light_position)?;
            let illuminance = intensity * range_window(distance, range) / (distance * distance);
            (direction, illuminance, ShadowTarget::Point(light_position))
        }
        PunctualLight::Spot {
            position: light_position,
            direction: axis,
            intensity,
            range,
            inner_cone_angle,
            outer_cone_angle,
        } => {
            let (direction, distance) = direction_and_distance(position, light_position)?;
            let cone = spot_falloff(
                axis.normalize_or_zero().dot(-direction),
                inner_cone_angle,
                outer_cone_angle,
            );
            let illuminance =
                intensity * cone * range_window(distance, range) / (distance * distance);
            (direction, illuminance, ShadowTarget::Point(light_position))
        }
        PunctualLight::Directional {
            direction: travel,
            illuminance,
        } => (
            -travel.normalize_or_zero(),
            illuminance,
            ShadowTarget::Infinite,
        ),
    };
    let usable =
        direction != Vec3::ZERO && illuminance.is_finite() && illuminance.max_element() > 0.0;
    usable.then_some(LightSample {
        direction,
        radiance: illuminance,
        pdf: selection,
        is_delta: true,
        target,
    })
}

/// Unit direction and distance from `from` to `to`; `None` when they coincide.
pub fn direction_and_distance(from: Vec3, to: Vec3) -> Option<(Vec3, f32)> {
    let offset = to - from;
    let distance = offset.length();
    (distance > 0.0 && distance.is_finite()).then(|| (offset / distance, distance))
}
