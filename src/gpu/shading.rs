//! The shading data on the GPU (bind group 2): materials, the light-selection distribution with
//! the punctual lights and emissive triangles, and the environment with its sampling
//! distribution, laid out for `shaders/shade.wgsl`, whose path tracer mirrors
//! `Shader::path_radiance` (see that file for the WGSL interface).
//!
//! Everything is copied from the CPU's own prepared structures ([`LightSet`], the
//! [`Environment`]'s distributions), never rebuilt, so both devices sample the same
//! distributions. Textures are not uploaded here: material texture indices point into the
//! scene's texture table (scene.wgsl's `texture_sample`), which holds
//! [`MaterialLibrary::textures`] in order.
//!
//! The WGSL interface (kernel source order: rng.wgsl, scene.wgsl, shade.wgsl):
//! - rng.wgsl: `struct Rng`, `rng_for_sample(seed_lo, seed_hi, pixel, sample) -> Rng`,
//!   `rng_next_u32/rng_next_f32/rng_next_2d(rng: ptr<function, Rng>)` (== `sampling::Rng`).
//! - shade.wgsl: `shade_rng(pixel, sample) -> Rng` (the shading stream of a camera sample, as
//!   `Shader::shade_batch` keys it) and `path_radiance(origin, direction, first_hit: Hit,
//!   rng: ptr<function, Rng>) -> vec3f` (== `Shader::radiance`). Of scene.wgsl it calls
//!   `scene_intersect`, `scene_occluded`, `scene_surface`, `scene_spawn_origin`,
//!   `scene_offset_along_normal`, `scene_triangle_vertices`, `scene_triangle_material`,
//!   `scene_uv_at`, `scene_triangle_spawn_offset`, `scene_is_alpha_hole` and
//!   `texture_sample`; its own names all start with `shade_`/`Shade`.
//!
//! Bindings of group 2, in order:
//! 0. uniform `ShadeParams` (counts, offsets, probabilities, the uniform sky, the stream seed);
//! 1. `array<ShadeMaterial>`: the library's materials, then its default material;
//! 2. `array<ShadeLightSlot>`: one per light-selection slot (a punctual light carries its data);
//! 3. `array<ShadeEmitter>`: emissive triangles (triangle, area), in increasing triangle order;
//! 4. `array<f32>`: every `Distribution1D` as its probabilities followed by its cdf;
//! 5. `array<vec4f>`: the environment image's texels (one zero texel for a uniform sky).

use crate::scene::{Material, MaterialLibrary, PunctualLight, TextureRef};
use crate::shade::distribution::Distribution1D;
use crate::shade::lights::LightSlot;
use crate::shade::{Environment, LightSet, SHADE_STREAM_KEY};

use super::compute::{Access, Bindings, storage_buffer, uniform_buffer};
use super::context::{GpuContext, GpuUnavailable};

/// `shaders/rng.wgsl`: `sampling::Rng` (PCG32) with 64-bit arithmetic in u32 pairs.
pub const RNG_WGSL: &str = include_str!("shaders/rng.wgsl");

/// `shaders/shade.wgsl`: materials, BSDF, lights, environment and `path_radiance`. Needs
/// [`RNG_WGSL`] and scene.wgsl before it.
pub const SHADE_WGSL: &str = include_str!("shaders/shade.wgsl");

/// A texture slot without a texture.
const NO_TEXTURE: u32 = u32::MAX;

/// `ShadeParams` of shade.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct ShadeParams {
    uniform_radiance: [f32; 4],
    seed_lo: u32,
    seed_hi: u32,
    max_depth: u32,
    material_count: u32,
    slot_count: u32,
    emitter_count: u32,
    environment_kind: u32,
    environment_width: u32,
    environment_height: u32,
    triangles_probability: f32,
    environment_probability: f32,
    slot_distribution: u32,
    emitter_distribution: u32,
    environment_marginal: u32,
    environment_rows: u32,
    _padding: u32,
}

/// `ShadeMaterial` of shade.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct ShadeMaterial {
    base_color: [f32; 4],
    /// xyz: emitted radiance; w: normal scale.
    emissive: [f32; 4],
    metallic: f32,
    roughness: f32,
    base_color_texture: u32,
    metallic_roughness_texture: u32,
    normal_texture: u32,
    emissive_texture: u32,
    double_sided: u32,
    _padding: u32,
}

impl ShadeMaterial {
    fn of(material: &Material, texture_count: usize) -> ShadeMaterial {
        // `MaterialLibrary::textures.get`: a reference past the table reads as no texture.
        let texture = |slot: Option<TextureRef>| {
            slot.filter(|r| r.texture < texture_count)
                .map_or(NO_TEXTURE, |r| r.texture as u32)
        };
        ShadeMaterial {
            base_color: material.base_color.to_array(),
            emissive: material.emissive.extend(material.normal_scale).to_array(),
            metallic: material.metallic,
            roughness: material.roughness,
            base_color_texture: texture(material.base_color_texture),
            metallic_roughness_texture: texture(material.metallic_roughness_texture),
            normal_texture: texture(material.normal_texture),
            emissive_texture: texture(material.emissive_texture),
            double_sided: material.double_sided as u32,
            _padding: 0,
        }
    }
}

/// Slot kinds of shade.wgsl (`SHADE_SLOT_*`).
const SLOT_POINT: u32 = 0;
const SLOT_SPOT: u32 = 1;
const SLOT_DIRECTIONAL: u32 = 2;
const SLOT_TRIANGLES: u32 = 3;
const SLOT_ENVIRONMENT: u32 = 4;

/// `ShadeLightSlot` of shade.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct ShadeLightSlot {
    position: [f32; 4],
    direction: [f32; 4],
    intensity: [f32; 4],
    kind: u32,
    /// 0: no range (the CPU's window is 1 for any range that is not positive).
    range: f32,
    cos_inner: f32,
    cos_outer: f32,
}

impl ShadeLightSlot {
    fn of(slot: LightSlot, punctual: &[PunctualLight]) -> ShadeLightSlot {
        let kind_only = |kind| ShadeLightSlot {
            kind,
            ..Default::default()
        };
        match slot {
            LightSlot::Triangles => kind_only(SLOT_TRIANGLES),
            LightSlot::Environment => kind_only(SLOT_ENVIRONMENT),
            LightSlot::Punctual(i) => match punctual[i] {
                PunctualLight::Point {
                    position,
                    intensity,
                    range,
                } => ShadeLightSlot {
                    position: position.extend(1.0).to_array(),
                    intensity: intensity.extend(0.0).to_array(),
                    kind: SLOT_POINT,
                    range: range.unwrap_or(0.0),
                    ..Default::default()
                },
                // The cone's cosines in f32 on the CPU, as `lights::spot_falloff` takes them.
                PunctualLight::Spot {
                    position,
                    direction,
                    intensity,
                    range,
                    inner_cone_angle,
                    outer_cone_angle,
                } => ShadeLightSlot {
                    position: position.extend(1.0).to_array(),
                    direction: direction.extend(0.0).to_array(),
                    intensity: intensity.extend(0.0).to_array(),
                    kind: SLOT_SPOT,
                    range: range.unwrap_or(0.0),
                    cos_inner: inner_cone_angle.cos(),
                    cos_outer: outer_cone_angle.cos(),
                },
                PunctualLight::Directional {
                    direction,
                    illuminance,
                } => ShadeLightSlot {
                    direction: direction.extend(0.0).to_array(),
                    intensity: illuminance.extend(0.0).to_array(),
                    kind: SLOT_DIRECTIONAL,
                    ..Default::default()
                },
            },
        }
    }
}

/// `ShadeEmitter` of shade.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct ShadeEmitter {
    triangle: u32,
    area: f32,
}

/// Distributions packed one after another into one f32 buffer.
#[derive(Default)]
struct PackedDistributions {
    values: Vec<f32>,
}

impl PackedDistributions {
    /// Appends `distribution` (its n probabilities, then its n + 1 cdf entries) and returns
    /// its offset.
    fn push(&mut self, distribution: &Distribution1D) -> u32 {
        let offset = self.values.len() as u32;
        let n = distribution.probabilities.len();
        self.values.extend_from_slice(&distribution.probabilities);
        // A default (never built) distribution has no cdf: an all-zero one is as empty.
        let mut cdf = distribution.cdf.clone();
        cdf.resize(n + 1, 0.0);
        self.values.extend_from_slice(&cdf);
        offset
    }
}

/// The shading data of one scene on the GPU: bind group 2 of the render kernels.
#[derive(Debug)]
pub struct GpuShading {
    pub bindings: Bindings,
}

impl GpuShading {
    /// Uploads what `path_radiance` reads. `lights` must have been built for `materials` and
    /// `environment` (as the CPU's [`crate::shade::Shader`] requires), and the scene's texture
    /// table must hold `materials.textures` in order. `seed` is the render's seed: the shading
    /// streams are keyed by `seed ^ SHADE_STREAM_KEY`, as on the CPU (`shade_rng`).
    pub fn upload(
        context: &GpuContext,
        materials: &MaterialLibrary,
        lights: &LightSet,
        environment: &Environment,
        max_depth: u32,
        seed: u64,
    ) -> Result<GpuShading, GpuUnavailable> {
        let texture_count = materials.textures.len();
        let gpu_materials: Vec<ShadeMaterial> = materials
            .materials
            .iter()
            .chain(std::iter::once(&materials.default_material))
            .map(|material| ShadeMaterial::of(material, texture_count))
            .collect();
        let slots: Vec<ShadeLightSlot> = lights
            .slots
            .iter()
            .map(|&slot| ShadeLightSlot::of(slot, &lights.punctual))
            .collect();
        let emitters: Vec<ShadeEmitter> = lights
            .emitters
            .iter()
            .map(|e| ShadeEmitter {
                triangle: e.triangle,
                area: e.area,
            })
            .collect();

        let mut distributions = PackedDistributions::default();
        let slot_distribution = distributions.push(&lights.slot_distribution);
        let emitter_distribution = distributions.push(&lights.emitter_distribution);
        let (kind, uniform_radiance, width, height, texels, marginal, rows) = match environment {
            Environment::Uniform(radiance) => (
                0,
                radiance.extend(0.0).to_array(),
                0,
                0,
                Vec::new(),
                distributions.push(&Distribution1D::default()),
                0,
            ),
            Environment::Image(map) => {
                let marginal = distributions.push(&map.distribution.marginal);
                let rows = distributions.values.len() as u32;
                for row in &map.distribution.rows {
                    distributions.push(row);
                }
                (
                    1,
                    [0.0; 4],
                    map.image.width,
                    map.image.height,
                    map.image.texels.clone(),
                    marginal,
                    rows,
                )
            }
        };

        let params = ShadeParams {
            uniform_radiance,
            seed_lo: (seed ^ SHADE_STREAM_KEY) as u32,
            seed_hi: ((seed ^ SHADE_STREAM_KEY) >> 32) as u32,
            max_depth,
            material_count: materials.materials.len() as u32,
            slot_count: slots.len() as u32,
            emitter_count: emitters.len() as u32,
            environment_kind: kind,
            environment_width: width,
            environment_height: height,
            triangles_probability: lights.triangles_probability,
            environment_probability: lights.environment_probability,
            slot_distribution,
            emitter_distribution,
            environment_marginal: marginal,
            environment_rows: rows,
            _padding: 0,
        };

        let largest = [
            size_of_val(gpu_materials.as_slice()),
            size_of_val(slots.as_slice()),
            size_of_val(emitters.as_slice()),
            size_of_val(distributions.values.as_slice()),
            size_of_val(texels.as_slice()),
        ]
        .into_iter()
        .max()
        .unwrap_or(0) as u64;
        let limit = context.limits.max_storage_buffer_binding_size;
        if largest > limit {
            return Err(GpuUnavailable(format!(
                "the shading data needs a {largest}-byte buffer; the GPU {} binds at most \
                 {limit} bytes (a smaller environment image would fit)",
                context.adapter
            )));
        }

        let params = uniform_buffer(context, "shade params", &params);
        let gpu_materials = storage_buffer(context, "shade materials", &gpu_materials);
        let slots = storage_buffer(context, "shade light slots", &slots);
        let emitters = storage_buffer(context, "shade emitters", &emitters);
        let distributions = storage_buffer(context, "shade distributions", &distributions.values);
        let texels = storage_buffer(context, "shade environment", &texels);
        let bindings = Bindings::new(
            context,
            "shading",
            &[
                (&params, Access::Uniform),
                (&gpu_materials, Access::ReadOnly),
                (&slots, Access::ReadOnly),
                (&emitters, Access::ReadOnly),
                (&distributions, Access::ReadOnly),
                (&texels, Access::ReadOnly),
            ],
        );
        Ok(GpuShading { bindings })
    }
}

#[cfg(test)]
mod tests;
