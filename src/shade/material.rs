//! A glTF material evaluated at a surface point: textures read, normal map applied.
//!
//! All texture slots read `TEXCOORD_0` (the only UV set the scene's meshes carry). Vertex
//! colours are not part of the scene model and are ignored.

use std::sync::Arc;

use glam::{Vec2, Vec3, Vec4};

use super::bsdf::MetalRoughBsdf;
use super::frame::Frame;
use crate::accel::SurfacePoint;
use crate::scene::{Material, Texture, TextureRef};

/// What shading needs at one surface point.
#[derive(Clone, Copy, Debug)]
pub struct ShadingPoint {
    /// Around the normal-mapped shading normal.
    pub frame: Frame,
    pub bsdf: MetalRoughBsdf,
    /// Radiance (nits) emitted towards the side the ray came from.
    pub emission: Vec3,
}

fn texture_value(textures: &[Arc<Texture>], slot: Option<TextureRef>, uv: Vec2) -> Vec4 {
    slot.and_then(|r| textures.get(r.texture))
        .map_or(Vec4::ONE, |t| Vec4::from_array(t.sample(uv)))
}

/// Radiance a material emits from its front face at `uv`: emissive factor (strength applied)
/// × emissive texture.
pub fn emitted_radiance(material: &Material, textures: &[Arc<Texture>], uv: Vec2) -> Vec3 {
    if !material.is_emissive() {
        return Vec3::ZERO;
    }
    let radiance =
        material.emissive * texture_value(textures, material.emissive_texture, uv).truncate();
    if radiance.is_finite() {
        radiance.max(Vec3::ZERO)
    } else {
        Vec3::ZERO
    }
}

/// True when a material emits towards a viewer on the given side. glTF emitters are
/// single-sided (front face, counter-clockwise winding) unless the material is double-sided.
pub fn emits_towards(material: &Material, back_face: bool) -> bool {
    !back_face || material.double_sided
}

/// Evaluates `material` at `surface`, seen from direction `wo` (unit, pointing away from the
/// surface towards the viewer).
pub fn shading_point(
    material: &Material,
    textures: &[Arc<Texture>],
    surface: &SurfacePoint,
    wo: Vec3,
) -> ShadingPoint {
    let uv = surface.uv;
    let base_color = material.base_color.truncate()
        * texture_value(textures, material.base_color_texture, uv).truncate();
    // glTF packs roughness in green and metalness in blue.
    let metal_rough = texture_value(textures, material.metallic_roughness_texture, uv);
    let bsdf = MetalRoughBsdf::new(
        base_color,
        material.metallic * metal_rough.z,
        material.roughness * metal_rough.y,
    );

    let mapped = normal_mapped(material, textures, surface);
    // A shading normal the viewer is behind (normal maps, interpolated normals at silhouettes)
    // would make the BRDF see the light from below: fall back towards the geometric normal.
    let normal = [mapped, surface.shading_normal, surface.geometric_normal]
        .into_iter()
        .find(|n| n.dot(wo) > 0.0)
        .unwrap_or(surface.geometric_normal);

    let emission = if emits_towards(material, surface.back_face) {
        emitted_radiance(material, textures, uv)
    } else {
        Vec3::ZERO
    };
    ShadingPoint {
        frame: Frame::from_normal(normal),
        bsdf,
        emission,
    }
}

/// The shading normal perturbed by the material's tangent-space normal map, or the
/// interpolated one when there is no map or no tangent frame.
fn normal_mapped(material: &Material, textures: &[Arc<Texture>], surface: &SurfacePoint) -> Vec3 {
    let n = surface.shading_normal;
    let Some(texture) = material
        .normal_texture
        .and_then(|r| textures.get(r.texture))
    else {
        return n;
    };
    if surface.tangent == Vec4::ZERO {
        return n;
    }
    let t = surface.tangent.truncate();
    let b = n.cross(t) * surface.tangent.w;
    // Texels store (x, y, z) × 0.5 + 0.5; normalScale scales x and y (glTF 2.0 §3.9.3).
    let texel = Vec4::from_array(texture.sample(surface.uv)).truncate() * 2.0 - Vec3::ONE;
    let local = Vec3::new(
        texel.x * material.normal_scale,
        texel.y * material.normal_scale,
        texel.z,
    );
    let mapped = (t * local.x + b * local.y + n * local.z).normalize_or_zero();
    if mapped == Vec3::ZERO || !mapped.is_finite() {
        n
    } else {
        mapped
    }
}
